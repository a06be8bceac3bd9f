//! `drumsim strokes` and `drumsim limits`: the stroke evaluation as a report, and the joint
//! limits refitted from motion.

use super::limits_data;
use super::sim::{DrummerSettings, Mode};
use super::skeleton::LINK_NAMES;
use super::strokes::Style;
use super::trials::{run_all, run_trial, ErrorStats};
use crate::kit::Kit;
use nalgebra::{Quaternion, UnitQuaternion};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What `drumsim strokes` runs.
#[derive(Debug, Clone)]
pub struct StrokesOptions {
    pub modes: Vec<Mode>,
    pub trials: usize,
    pub threads: usize,
    pub kit: Option<PathBuf>,
    /// Write joint-angle traces of one trial per style and mode here.
    pub traces: Option<PathBuf>,
    pub progress: bool,
}

/// The JSON object of DESIGN.md section 7.
#[derive(Debug, Clone, Serialize)]
pub struct StrokesReport {
    pub styles: BTreeMap<&'static str, BTreeMap<&'static str, ErrorStats>>,
    /// Physics steps per second of the full loop (IK + PD + rapier step), one thread.
    pub steps_per_second: f64,
}

impl StrokesReport {
    /// A table for people.
    pub fn table(&self) -> String {
        let mut s = String::from("style            mode   tip RMS error   spread (sd)   sd of trial RMS\n");
        for (style, modes) in &self.styles {
            for (mode, e) in modes {
                s += &format!(
                    "{style:16} {mode:5}  {:10.2} mm {:10.2} mm {:14.2} mm\n",
                    e.rms_m * 1e3,
                    e.sd_m * 1e3,
                    e.trial_sd_m * 1e3
                );
            }
        }
        s += &format!(
            "full loop: {:.0} physics steps per second ({:.1}x real time at 10 kHz)\n",
            self.steps_per_second,
            self.steps_per_second / 1e4
        );
        s
    }
}

fn load_kit(path: &Option<PathBuf>) -> anyhow::Result<Kit> {
    Ok(match path {
        Some(p) => Kit::load(p)?,
        None => Kit::builtin_default(),
    })
}

/// Run the stroke evaluation.
pub fn run_strokes(opts: &StrokesOptions) -> anyhow::Result<StrokesReport> {
    let kit = load_kit(&opts.kit)?;
    let settings = DrummerSettings::default();
    let total = (Style::ALL.len() * opts.modes.len() * opts.trials) as u64;
    let bar = if opts.progress { indicatif::ProgressBar::new(total) } else { indicatif::ProgressBar::hidden() };
    let (results, steps, wall) = run_all(&kit, &settings, &opts.modes, opts.trials, opts.threads, &|| bar.inc(1))?;
    bar.finish_and_clear();
    let mut styles: BTreeMap<&'static str, BTreeMap<&'static str, ErrorStats>> = BTreeMap::new();
    for (style, mode, errs) in &results {
        styles.entry(style.name()).or_default().insert(mode.name(), ErrorStats::of(errs));
    }
    if let Some(path) = &opts.traces {
        write_traces(&kit, &settings, &opts.modes, path)?;
    }
    Ok(StrokesReport { styles, steps_per_second: if wall > 0.0 { steps as f64 / wall } else { 0.0 } })
}

#[derive(Serialize)]
struct Trace {
    rate_hz: f64,
    joints: Vec<&'static str>,
    /// Per frame, per joint: rotation (w, x, y, z) relative to the parent.
    frames: Vec<Vec<[f32; 4]>>,
    /// Per frame, per joint: rotation angle from the zero pose, degrees.
    angles_deg: Vec<Vec<f32>>,
}

fn write_traces(kit: &Kit, settings: &DrummerSettings, modes: &[Mode], path: &Path) -> anyhow::Result<()> {
    let mut out: BTreeMap<&str, BTreeMap<&str, Trace>> = BTreeMap::new();
    for style in Style::ALL {
        for &mode in modes {
            let r = run_trial(kit, settings, style, mode, Some(1), true)?;
            let frames: Vec<Vec<[f32; 4]>> = r.joint_trace.iter().map(|f| f.to_vec()).collect();
            let angles_deg = frames
                .iter()
                .map(|f| f.iter().map(|q| 2.0 * q[0].abs().min(1.0).acos().to_degrees()).collect())
                .collect();
            let trace =
                Trace { rate_hz: super::strokes::TASK_HZ, joints: LINK_NAMES[1..].to_vec(), frames, angles_deg };
            out.entry(style.name()).or_default().insert(mode.name(), trace);
        }
    }
    crate::outputs::write_atomically(path, serde_json::to_string(&out)?.as_bytes())?;
    Ok(())
}

/// Joint trajectories as JSON: `{"joints": [[[w, x, y, z], ...] per joint]}`.
#[derive(serde::Deserialize)]
struct TrajectoryFile {
    joints: Vec<Vec<[f32; 4]>>,
}

/// A bad trajectory file for `drumsim limits --from`.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct TrajectoryError {
    pub path: PathBuf,
    pub message: String,
}

/// Refit the joint limits (Algorithm 1) from `from` (joint trajectories as JSON), or from the
/// kinematic drumming on the kit when `None`; write them to `out` as JSON.
pub fn run_limits(from: Option<&Path>, kit: &Option<PathBuf>, out: &Path) -> anyhow::Result<()> {
    let traj = match from {
        Some(path) => {
            let bad = |message: String| TrajectoryError { path: path.to_path_buf(), message };
            let text = crate::files::read_to_string_bounded(path, crate::files::MAX_DATA_BYTES)
                .map_err(|e| bad(format!("cannot read: {e}")))?;
            let file: TrajectoryFile = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
            if file.joints.len() != super::skeleton::JOINTS {
                return Err(
                    bad(format!("\"joints\" has {} trajectories; the body has 11 joints", file.joints.len())).into()
                );
            }
            file.joints
                .iter()
                .map(|j| {
                    j.iter().map(|q| UnitQuaternion::new_unchecked(Quaternion::new(q[0], q[1], q[2], q[3]))).collect()
                })
                .collect()
        }
        None => limits_data::kinematic_drumming(&load_kit(kit)?)?,
    };
    let limits = limits_data::fit(&traj).map_err(|e| TrajectoryError {
        path: from.map_or_else(|| PathBuf::from("(kinematic drumming)"), Path::to_path_buf),
        message: e.to_string(),
    })?;
    crate::outputs::write_atomically(out, serde_json::to_string_pretty(&limits)?.as_bytes())?;
    Ok(())
}
