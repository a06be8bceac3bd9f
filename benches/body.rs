//! Speed of the simulated drummer: the full 10 kHz loop (IK of both arms, PD, joint limits,
//! gravity compensation, rapier step with the kit's colliders, contact tracking) while both
//! sticks play legato strokes on the snare and hi-hat, and the same loop in `id` mode and
//! the kinematic IK alone.
//!
//! `cargo bench --bench body` ends with a summary: physics steps per second on one core and
//! the ratio to real time at 10 kHz (10,000 steps per simulated second).

use criterion::{Criterion, SamplingMode};
use drumsim::body::sim::{Drummer, DrummerSettings, Mode};
use drumsim::body::strokes::{interpolate, sample, Style};
use drumsim::body::trials::{joint_targets, kinematic_reference, plans_for};
use drumsim::kit::Kit;
use std::hint::black_box;
use std::time::{Duration, Instant};

/// Physics steps per measured iteration (0.2 s of drumming).
const STEPS: usize = 2000;

fn bench(c: &mut Criterion) {
    let kit = Kit::builtin_default();
    let settings = DrummerSettings::default();
    let mut group = c.benchmark_group("body");
    group.sampling_mode(SamplingMode::Flat).sample_size(10).measurement_time(Duration::from_secs(8));
    let mut summary = Vec::new();
    for mode in [Mode::Himc, Mode::Id, Mode::Ik] {
        let mut best = f64::INFINITY;
        group.bench_function(format!("{} loop, {STEPS} steps", mode.name()), |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let mut d = Drummer::new(&kit, settings.clone()).expect("default drummer");
                    let plans = plans_for(&d, Style::Legato, None);
                    let frames = sample(&plans, 2.0);
                    let reference = kinematic_reference(&kit, &settings, &frames).expect("reference");
                    // Settle into the strokes first, then time 0.2 s around the first hits.
                    let start = 4500;
                    for k in 0..start {
                        let t = (k + 1) as f64 * 1e-4;
                        d.step_tips(Mode::Himc, &interpolate(&frames, t), &mut |_| {});
                    }
                    let t0 = Instant::now();
                    let mut strikes = 0;
                    for k in start..start + STEPS {
                        let t = (k + 1) as f64 * 1e-4;
                        let mut sink = |_| strikes += 1;
                        match mode {
                            Mode::Id => d.step_joints(&joint_targets(&reference, t), &mut sink),
                            _ => d.step_tips(mode, &interpolate(&frames, t), &mut sink),
                        }
                    }
                    let el = t0.elapsed();
                    black_box(strikes);
                    best = best.min(el.as_secs_f64() / STEPS as f64);
                    total += el;
                }
                total
            })
        });
        summary.push((mode, best));
    }
    group.finish();
    println!("\nbody summary (best sample, one core):");
    for (mode, per_step) in summary {
        let sps = 1.0 / per_step;
        println!(
            "  {:5} loop: {:8.0} steps/s, {:5.2} us/step, {:6.1}x real time at 10 kHz",
            mode.name(),
            sps,
            per_step * 1e6,
            sps / 1e4
        );
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c);
    c.final_summary();
}
