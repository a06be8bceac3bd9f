//! Beat alignment as DRUMS measures it (MIG 2025, section 4.1.2; DESIGN.md 5).
//!
//! The paper's procedure, step by step, and what this module does at each:
//! 1. "Hand velocity is computed from 3D trajectories": per hand, velocity by central
//!    differences (one-sided at the two ends, numpy's `gradient`), so the speed of frame t
//!    belongs to frame t and not half a frame later; speed is its norm, in m/s.
//! 2. "smoothed using a Savitzky-Golay filter": the speed, window 7 and order 2 (the
//!    paper gives neither; these are [`BeatParams::default`]), ends by `mode="interp"`.
//! 3. "Local maxima in speed are detected as candidate impact points": samples above both
//!    neighbours; a flat top counts once, at its middle (scipy's `find_peaks`); no
//!    height or prominence threshold unless [`BeatParams::min_peak_speed_mps`] sets one.
//! 4. "Only hand-played instruments ... are considered; foot-triggered notes (e.g. kick)
//!    are excluded": the caller passes hand-played onsets
//!    (`eval::motion::hand_onsets_s`), put on frames as `round(t * fps)` like the
//!    paper's 60 fps MIDI JSON; notes sharing a frame are one onset.
//! 5. "Each motion peak is matched with the nearest MIDI onset within a frame window
//!    +-3": the direction is peak -> onset, each hand's peaks separately, both hands'
//!    matches pooled (the paper evaluates each hand and reports one set of figures).
//!    Equidistant onsets: the earlier one. A peak with no onset within the window is
//!    unmatched; an onset that no peak chose is counted as unmatched too.
//! 6. "delay = (t_peak - t_onset) * 1000 / fps" in ms: negative means the speed peak
//!    comes before the onset. The caller reports mean, sd and median
//!    (`eval::motion::mean_sd_median`).

use super::motion::{check_trajectory, MotionMetricError};
use super::savgol::savgol_filter;

/// Settings of the beat alignment; `Default` is the paper's (window +-3 frames) with
/// Savitzky-Golay window 7, order 2 and no peak threshold.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BeatParams {
    pub sg_window: usize,
    pub sg_order: usize,
    /// A peak matches an onset at most this many frames away.
    pub match_frames: usize,
    /// Peaks of smoothed speed below this are ignored (0: every local maximum counts).
    pub min_peak_speed_mps: f64,
}

impl Default for BeatParams {
    fn default() -> Self {
        BeatParams { sg_window: 7, sg_order: 2, match_frames: 3, min_peak_speed_mps: 0.0 }
    }
}

/// The matched delays and the counts of what did not match.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BeatAlignment {
    /// `(peak frame - onset frame) * 1000 / fps` of every matched peak, both hands.
    pub delays_ms: Vec<f64>,
    /// Speed peaks found, both hands.
    pub peaks: usize,
    pub unmatched_peaks: usize,
    /// Distinct onset frames.
    pub onsets: usize,
    pub unmatched_onsets: usize,
}

/// Speed (m/s) of every frame, from central differences of the positions.
pub fn hand_speed(traj: &[[f32; 3]], fps: f64) -> Result<Vec<f64>, MotionMetricError> {
    check_trajectory(traj, "beat alignment hand")?;
    let n = traj.len();
    if n < 2 {
        return Err(MotionMetricError::TooShort { what: "beat alignment hand", needed: 2, got: n });
    }
    let norm = |a: [f32; 3], b: [f32; 3], span: f64| {
        (0..3).map(|k| (a[k] as f64 - b[k] as f64).powi(2)).sum::<f64>().sqrt() * fps / span
    };
    Ok((0..n)
        .map(|t| match t {
            0 => norm(traj[1], traj[0], 1.0),
            t if t == n - 1 => norm(traj[t], traj[t - 1], 1.0),
            t => norm(traj[t + 1], traj[t - 1], 2.0),
        })
        .collect())
}

/// Indices of the local maxima of `x`: above the left neighbour and above the right one
/// after any flat run, a flat top reported at its middle (rounded down). Ends never count.
pub fn local_maxima(x: &[f64]) -> Vec<usize> {
    let mut peaks = Vec::new();
    let mut i = 1;
    while i + 1 < x.len() {
        if x[i] > x[i - 1] {
            let mut j = i;
            while j + 1 < x.len() && x[j + 1] == x[i] {
                j += 1;
            }
            if j + 1 < x.len() && x[j + 1] < x[i] {
                peaks.push((i + j) / 2);
            }
            i = j + 1;
        } else {
            i += 1;
        }
    }
    peaks
}

/// Beat alignment of one or more hands' positions against hand-played onset times
/// (seconds); see the module doc for every step.
pub fn beat_alignment(
    hands: &[&[[f32; 3]]],
    onsets_s: &[f64],
    fps: f64,
    params: &BeatParams,
) -> Result<BeatAlignment, MotionMetricError> {
    if !(fps.is_finite() && fps > 0.0) {
        return Err(MotionMetricError::Invalid {
            what: "beat alignment",
            message: format!("fps {fps} must be positive"),
        });
    }
    if let Some(i) = onsets_s.iter().position(|t| !t.is_finite()) {
        return Err(MotionMetricError::Invalid {
            what: "beat alignment onsets",
            message: format!("onset {i} is not a finite time"),
        });
    }
    let mut onsets: Vec<i64> = onsets_s.iter().map(|t| (t * fps).round() as i64).collect();
    onsets.sort_unstable();
    onsets.dedup();
    let mut chosen = vec![false; onsets.len()];
    let mut out = BeatAlignment { onsets: onsets.len(), ..BeatAlignment::default() };
    for traj in hands {
        let speed = savgol_filter(&hand_speed(traj, fps)?, params.sg_window, params.sg_order)?;
        for p in local_maxima(&speed).into_iter().filter(|&p| speed[p] >= params.min_peak_speed_mps) {
            out.peaks += 1;
            match nearest(&onsets, p as i64, params.match_frames as i64) {
                Some(k) => {
                    chosen[k] = true;
                    out.delays_ms.push((p as i64 - onsets[k]) as f64 * 1000.0 / fps);
                }
                None => out.unmatched_peaks += 1,
            }
        }
    }
    out.unmatched_onsets = chosen.iter().filter(|c| !**c).count();
    Ok(out)
}

/// Index of the onset nearest `frame` within `window` frames (the earlier one on a tie).
fn nearest(sorted: &[i64], frame: i64, window: i64) -> Option<usize> {
    let after = sorted.partition_point(|&o| o < frame);
    let candidates = [after.checked_sub(1), (after < sorted.len()).then_some(after)];
    candidates
        .into_iter()
        .flatten()
        .filter(|&k| (sorted[k] - frame).abs() <= window)
        .min_by_key(|&k| ((sorted[k] - frame).abs(), sorted[k]))
}

#[cfg(test)]
#[path = "beat_tests.rs"]
mod tests;
