//! The stroke evaluation of Hybrid Inverse Motion Control: trials of each style in `ik`,
//! `id` and `himc`, with seeded perturbations, and the tip-tracking error of each.
//!
//! A trial: the left stick plays three strokes on the snare, the right stick three on the
//! hi-hat half a period later. Targets are sampled at 250 Hz and interpolated (Algorithm 2).
//! `himc` runs the IK inside every physics step; `id` tracks the joint trajectory the
//! kinematic IK recorded for the same targets at 250 Hz; `ik` is that kinematic run itself.
//! Perturbations per trial: the strike points (+-1 cm), height (+-10 %), fall time and
//! period (+-5 %), and a swaying torque on the trunk (0-4 N m, 0.5-1.5 Hz) that the joint
//! trajectory cannot know about.

use super::contacts::Strike;
use super::ik::ArmTarget;
use super::sim::{Drummer, DrummerError, DrummerSettings, JointTargets, Mode};
use super::skeleton::{JOINTS, TRUNK};
use super::strokes::{interpolate, sample, StrokePlan, Style, TASK_HZ};
use crate::kit::Kit;
use rapier3d::math::{Rotation, Vector};
use serde::Serialize;

/// Physics steps per task frame (10 kHz / 250 Hz).
pub const STEPS_PER_FRAME: usize = 40;
/// Error is measured from this time on (the body settles from its ready pose first).
pub const SETTLE_S: f64 = 0.3;
const FIRST_HIT_S: f64 = 0.5;
const STROKES: usize = 3;

/// What one trial measured.
#[derive(Debug, Clone)]
pub struct TrialResult {
    /// RMS distance of both stick tips from their targets after settling, metres.
    pub rms_m: f64,
    /// The tip-error samples behind it (both tips, every physics step after settling).
    pub errors: ErrorSums,
    pub strikes: Vec<Strike>,
    pub plans: [StrokePlan; 2],
    pub steps: u64,
    pub wall_s: f64,
    /// Joint rotations (w, x, y, z) at 250 Hz, when recorded.
    pub joint_trace: Vec<[[f32; 4]; JOINTS]>,
    /// Worst stick penetration into a piece, metres.
    pub max_penetration_m: f32,
    pub surface_names: Vec<String>,
}

pub use crate::rng::Rng;

/// The two hands' plans for a style, perturbed by `rng` (no perturbation when `None`).
pub fn plans_for(drummer: &Drummer, style: Style, rng: Option<&mut Rng>) -> [StrokePlan; 2] {
    let mut zero = Rng::new(0);
    let (rng, scale) = match rng {
        Some(r) => (r, 1.0),
        None => (&mut zero, 0.0),
    };
    let surfaces = drummer.surfaces();
    let find = |id: &str, fallback: usize| surfaces.iter().position(|s| s.id == id).unwrap_or(fallback);
    let pieces = [find("snare", 0), find("hihat", 1.min(surfaces.len() - 1))];
    std::array::from_fn(|side| {
        let mut p = style.params();
        p.height_m *= 1.0 + 0.10 * scale * rng.sym();
        p.fall_s *= 1.0 + 0.05 * scale * rng.sym();
        p.period_s *= 1.0 + 0.05 * scale * rng.sym();
        let start = FIRST_HIT_S + side as f64 * 0.5 * p.period_s as f64;
        let hits = (0..STROKES).map(|k| start + k as f64 * p.period_s as f64).collect();
        let s = &surfaces[pieces[side]];
        // Strike a third of the way from the centre toward the drummer, as players do.
        let (x, y) = (0.01 * scale * rng.sym(), -0.3 * s.radius_m + 0.01 * scale * rng.sym());
        StrokePlan::on(s, side, x, y, p, hits)
    })
}

/// Run one trial. `seed` None runs the unperturbed trial.
pub fn run_trial(
    kit: &Kit,
    base: &DrummerSettings,
    style: Style,
    mode: Mode,
    seed: Option<u64>,
    record: bool,
) -> Result<TrialResult, DrummerError> {
    let mut settings = base.clone();
    settings.natural_hz = base.natural_hz * style.params().stiffness;
    let mut rng = seed.map(Rng::new);
    let mut drummer = Drummer::new(kit, settings.clone())?;
    let plans = plans_for(&drummer, style, rng.as_mut());
    let end = plans.iter().map(|p| p.hits.last().copied().unwrap_or(0.0)).fold(0.0, f64::max) + 0.3;
    let frames = sample(&plans, end);
    let sway = rng.as_mut().map_or((0.0, 1.0, 0.0, Vector::X), |r| {
        let axis = Vector::new(r.sym(), r.sym(), 0.0).normalize_or(Vector::X);
        (2.0 + 2.0 * r.sym(), 1.0 + 0.5 * r.sym(), std::f32::consts::PI * r.sym(), axis)
    });
    // The joint trajectory `id` tracks: the kinematic IK of the same targets, at 250 Hz.
    let reference = if mode == Mode::Id { Some(kinematic_reference(kit, &settings, &frames)?) } else { None };
    let steps = (end * 1e4) as u64;
    let mut strikes = Vec::with_capacity(16);
    let mut trace = Vec::new();
    let mut sums = ErrorSums::default();
    let started = std::time::Instant::now();
    for k in 0..steps {
        let t = k as f64 * 1e-4;
        let (amp, hz, phase, axis) = sway;
        let torque = axis * (amp * (std::f32::consts::TAU * hz * t as f32 + phase).sin());
        drummer.set_disturbance(TRUNK, torque);
        let targets = interpolate(&frames, t + 1e-4);
        let mut sink = |s: Strike| strikes.push(s);
        match &reference {
            Some(r) => drummer.step_joints(&joint_targets(r, t + 1e-4), &mut sink),
            None => drummer.step_tips(mode, &targets, &mut sink),
        }
        if t + 1e-4 >= SETTLE_S {
            let tips = drummer.tips(mode);
            for side in 0..2 {
                sums.add((tips[side] - targets[side].tip).length() as f64);
            }
        }
        if record && k % STEPS_PER_FRAME as u64 == 0 {
            let q = if mode == Mode::Ik { *drummer.kinematic_joints() } else { drummer.sim_joints() };
            trace.push(q.map(|r| [r.w, r.x, r.y, r.z]));
        }
    }
    let wall_s = started.elapsed().as_secs_f64();
    Ok(TrialResult {
        rms_m: sums.rms_m(),
        errors: sums,
        strikes,
        plans,
        steps,
        wall_s,
        joint_trace: trace,
        max_penetration_m: drummer.max_penetration_m(),
        surface_names: drummer.surfaces().iter().map(|s| s.id.clone()).collect(),
    })
}

/// Joint rotations of the kinematic IK following `frames`, one per task frame.
pub fn kinematic_reference(
    kit: &Kit,
    settings: &DrummerSettings,
    frames: &[[ArmTarget; 2]],
) -> Result<Vec<[Rotation; JOINTS]>, DrummerError> {
    let mut d = Drummer::new(kit, settings.clone())?;
    let mut out = Vec::with_capacity(frames.len());
    out.push(*d.kinematic_joints());
    let steps = (frames.len() - 1) * STEPS_PER_FRAME;
    for k in 0..steps {
        let t = (k + 1) as f64 * 1e-4;
        d.step_tips(Mode::Ik, &interpolate(frames, t), &mut |_| {});
        if (k + 1) % STEPS_PER_FRAME == 0 {
            out.push(*d.kinematic_joints());
        }
    }
    Ok(out)
}

/// Joint targets at time `t` from a 250 Hz joint trajectory: slerp between frames, and the
/// frame-to-frame angular velocity.
pub fn joint_targets(frames: &[[Rotation; JOINTS]], t: f64) -> JointTargets {
    let x = (t * TASK_HZ).max(0.0);
    let k = (x.floor() as usize).min(frames.len() - 1);
    let k1 = (k + 1).min(frames.len() - 1);
    let a = (x - k as f64).clamp(0.0, 1.0) as f32;
    let mut out = JointTargets { rot: [Rotation::IDENTITY; JOINTS], vel: [Vector::ZERO; JOINTS] };
    for j in 0..JOINTS {
        out.rot[j] = frames[k][j].slerp(frames[k1][j], a);
        out.vel[j] = super::ik::rot_error(frames[k1][j], frames[k][j]) * TASK_HZ as f32;
    }
    out
}

/// Running sums of tip-error distances, metres.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ErrorSums {
    pub sum: f64,
    pub sum_sq: f64,
    pub count: u64,
}

impl ErrorSums {
    pub fn add(&mut self, e: f64) {
        self.sum += e;
        self.sum_sq += e * e;
        self.count += 1;
    }

    pub fn merge(&mut self, o: &ErrorSums) {
        self.sum += o.sum;
        self.sum_sq += o.sum_sq;
        self.count += o.count;
    }

    pub fn rms_m(&self) -> f64 {
        (self.sum_sq / self.count.max(1) as f64).sqrt()
    }
}

/// Error and spread of one style and mode over its trials.
///
/// `rms_m` is the RMS tip error over every sample of every trial; `sd_m`, the spread, is the
/// standard deviation of the tip error over those same samples (how widely the error is
/// spread around its mean: rms^2 = mean^2 + sd^2); `trial_sd_m` is the standard deviation
/// of the trials' own RMS errors (how much the perturbations move the error from trial to
/// trial).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ErrorStats {
    pub rms_m: f64,
    pub sd_m: f64,
    pub trial_sd_m: f64,
}

impl ErrorStats {
    pub fn of(trials: &[ErrorSums]) -> ErrorStats {
        let mut all = ErrorSums::default();
        for t in trials {
            all.merge(t);
        }
        let n = all.count.max(1) as f64;
        let mean = all.sum / n;
        let sd_m = (all.sum_sq / n - mean * mean).max(0.0).sqrt();
        let rms: Vec<f64> = trials.iter().map(ErrorSums::rms_m).collect();
        let k = rms.len().max(1) as f64;
        let m = rms.iter().sum::<f64>() / k;
        let var = rms.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (k - 1.0).max(1.0);
        ErrorStats { rms_m: all.rms_m(), sd_m, trial_sd_m: var.sqrt() }
    }
}

/// Per style and mode the trials' error sums; total physics steps; wall seconds spent in them.
pub type TrialSummary = (Vec<(Style, Mode, Vec<ErrorSums>)>, u64, f64);

/// Run `trials` seeded trials of every style in every mode of `modes`, spread over
/// `threads` threads. `progress` is called after each trial. Returns, per style, per mode,
/// the trial RMS errors, plus total physics steps and the wall time spent in them.
pub fn run_all(
    kit: &Kit,
    base: &DrummerSettings,
    modes: &[Mode],
    trials: usize,
    threads: usize,
    progress: &(dyn Fn() + Sync),
) -> Result<TrialSummary, DrummerError> {
    let jobs: Vec<(Style, Mode, u64)> = Style::ALL
        .iter()
        .flat_map(|&s| modes.iter().flat_map(move |&m| (0..trials as u64).map(move |i| (s, m, i))))
        .collect();
    let next = std::sync::atomic::AtomicUsize::new(0);
    // Per thread: (job index, RMS error, physics steps, wall seconds) of each finished job.
    type Done = Vec<(usize, ErrorSums, u64, f64)>;
    let results: Vec<Result<Done, DrummerError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..threads.clamp(1, jobs.len().max(1)))
            .map(|_| {
                scope.spawn(|| {
                    let mut mine = Vec::new();
                    loop {
                        let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(&(style, mode, trial)) = jobs.get(i) else { break };
                        let r = run_trial(kit, base, style, mode, Some(trial + 1), false)?;
                        let physical = if mode == Mode::Ik { 0 } else { r.steps };
                        mine.push((i, r.errors, physical, if mode == Mode::Ik { 0.0 } else { r.wall_s }));
                        progress();
                    }
                    Ok(mine)
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().expect("trial thread panicked")).collect()
    });
    let mut rms = vec![ErrorSums::default(); jobs.len()];
    let (mut steps, mut wall) = (0u64, 0.0f64);
    for r in results {
        for (i, e, s, w) in r? {
            rms[i] = e;
            steps += s;
            wall += w;
        }
    }
    let mut out = Vec::new();
    for &style in &Style::ALL {
        for &mode in modes {
            let v: Vec<ErrorSums> =
                jobs.iter().zip(&rms).filter(|((s, m, _), _)| *s == style && *m == mode).map(|(_, e)| *e).collect();
            out.push((style, mode, v));
        }
    }
    Ok((out, steps, wall))
}
