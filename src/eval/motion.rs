//! Hand-trajectory measures of DRUMS (MIG 2025, section 4.1.1; DESIGN.md 5) and the
//! `drumsim eval` object (DESIGN.md 7) they fill.
//!
//! Definitions, as the paper states them and where it is silent as chosen here:
//! - **L1** ([`l1_m`]): "mean absolute error between predicted and ground-truth hand
//!   positions over all frames": the mean of `|p - r|` over every frame and each of the
//!   three coordinates (the mean-absolute-error / `L1Loss` reading, not the mean
//!   Euclidean distance), in metres. Unequal lengths: the shorter length is compared.
//! - **DTW** ([`super::dtw::dtw`]): the same per-frame cost under time warping, divided by
//!   the longer length (see `eval::dtw`).
//! - **Jerk RMS** ([`jerk_rms`]): root mean square of the norm of the third derivative of
//!   position, by the third forward difference `x[t+3] - 3x[t+2] + 3x[t+1] - x[t]`.
//!   [`jerk_rms`] scales it by `fps^3` (m/s^3). The paper reports 0.0233 for hands, which
//!   is impossible in m/s^3 (a 5 cm, 5 Hz swing alone has ~1,000 m/s^3) and plausible in
//!   metres per frame^3 at 60 fps (~5,000 m/s^3): its figure is the unscaled difference,
//!   [`jerk_rms_per_frame`], and that is what the eval object's `jerk_rms` reports so that
//!   the two compare. It is the predicted motion's own smoothness, not an error.
//! - Each hand is measured on its grip position (`Pose::pos`) independently and the eval
//!   object reports the mean of the two hands (the paper's "Average" row).

use serde::{Deserialize, Serialize};

use super::beat::{beat_alignment, BeatParams};
use super::dtw::dtw_banded;
use crate::midi::{DrumEventKind, NoteMap, Performance, Zone};
use crate::motion::Motion;

/// Sakoe-Chiba band of the eval object's DTW: 2 s at 60 fps. The prediction and its
/// reference follow the same MIDI, so their alignment never drifts by seconds; the band
/// makes 3 minutes cost 2.6 M cells instead of 117 M.
pub const DTW_BAND_FRAMES: usize = 120;

/// Why a measure could not be taken; `what` names the measure and the input at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MotionMetricError {
    #[error("{what}: no frames")]
    Empty { what: &'static str },
    #[error("{what}: frame {frame} is not finite")]
    NotFinite { what: &'static str, frame: usize },
    #[error("{what}: needs at least {needed} frames, has {got}")]
    TooShort { what: &'static str, needed: usize, got: usize },
    #[error("{what}: {message}")]
    Invalid { what: &'static str, message: String },
}

/// Rejects an empty trajectory or one with a NaN or infinite coordinate.
pub fn check_trajectory(traj: &[[f32; 3]], what: &'static str) -> Result<(), MotionMetricError> {
    if traj.is_empty() {
        return Err(MotionMetricError::Empty { what });
    }
    match traj.iter().position(|p| !p.iter().all(|v| v.is_finite())) {
        Some(frame) => Err(MotionMetricError::NotFinite { what, frame }),
        None => Ok(()),
    }
}

/// Mean absolute error per coordinate over the common frames, in metres (module doc).
pub fn l1_m(pred: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<f64, MotionMetricError> {
    check_trajectory(pred, "l1 prediction")?;
    check_trajectory(reference, "l1 reference")?;
    let n = pred.len().min(reference.len());
    let sum: f64 = pred[..n]
        .iter()
        .zip(&reference[..n])
        .map(|(p, r)| (0..3).map(|k| (p[k] as f64 - r[k] as f64).abs()).sum::<f64>())
        .sum();
    Ok(sum / (3 * n) as f64)
}

/// RMS of the jerk's norm in m/s^3: third forward differences times `fps^3`. Needs 4 frames.
pub fn jerk_rms(traj: &[[f32; 3]], fps: f64) -> Result<f64, MotionMetricError> {
    if !(fps.is_finite() && fps > 0.0) {
        return Err(MotionMetricError::Invalid { what: "jerk", message: format!("fps {fps} must be positive") });
    }
    Ok(jerk_rms_per_frame(traj)? * fps.powi(3))
}

/// RMS of the third difference's norm in metres per frame^3: DRUMS' unit (module doc).
pub fn jerk_rms_per_frame(traj: &[[f32; 3]]) -> Result<f64, MotionMetricError> {
    check_trajectory(traj, "jerk trajectory")?;
    if traj.len() < 4 {
        return Err(MotionMetricError::TooShort { what: "jerk trajectory", needed: 4, got: traj.len() });
    }
    let sum: f64 = traj
        .windows(4)
        .map(|w| {
            (0..3)
                .map(|k| {
                    let d = w[3][k] as f64 - 3.0 * w[2][k] as f64 + 3.0 * w[1][k] as f64 - w[0][k] as f64;
                    d * d
                })
                .sum::<f64>()
        })
        .sum();
    Ok((sum / (traj.len() - 3) as f64).sqrt())
}

/// Mean, population standard deviation (numpy's default) and median; None when empty.
/// Ranks (1-based, ties averaged).
fn ranks(x: &[f64]) -> Vec<f64> {
    let mut idx: Vec<usize> = (0..x.len()).collect();
    idx.sort_by(|&a, &b| x[a].total_cmp(&x[b]));
    let mut r = vec![0.0; x.len()];
    let mut i = 0;
    while i < idx.len() {
        let mut j = i;
        while j + 1 < idx.len() && x[idx[j + 1]] == x[idx[i]] {
            j += 1;
        }
        for &k in &idx[i..=j] {
            r[k] = 0.5 * (i + j) as f64 + 1.0;
        }
        i = j + 1;
    }
    r
}

/// Spearman's rank correlation; `None` with fewer than 3 pairs or a constant side.
pub fn spearman(a: &[f64], b: &[f64]) -> Option<f64> {
    if a.len() != b.len() || a.len() < 3 {
        return None;
    }
    let (ra, rb) = (ranks(a), ranks(b));
    let n = a.len() as f64;
    let (ma, mb) = (ra.iter().sum::<f64>() / n, rb.iter().sum::<f64>() / n);
    let cov: f64 = ra.iter().zip(&rb).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let va: f64 = ra.iter().map(|x| (x - ma).powi(2)).sum();
    let vb: f64 = rb.iter().map(|y| (y - mb).powi(2)).sum();
    (va > 0.0 && vb > 0.0).then(|| cov / (va * vb).sqrt())
}

pub fn mean_sd_median(x: &[f64]) -> Option<(f64, f64, f64)> {
    if x.is_empty() {
        return None;
    }
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let sd = (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let mut s = x.to_vec();
    s.sort_by(f64::total_cmp);
    let h = s.len() / 2;
    let median = if s.len() % 2 == 1 { s[h] } else { 0.5 * (s[h - 1] + s[h]) };
    Some((mean, sd, median))
}

/// `drumsim eval`'s object (DESIGN.md 7). Absent parts serialise as `null`; the motion
/// measures fill `beat_alignment_ms` and `hands`, the contact measures the rest.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct MotionMetrics {
    pub notes: Option<usize>,
    /// Notes the map leaves out (percussion no kit piece plays) or does not know: counted
    /// here, not measured.
    pub skipped_notes: Option<usize>,
    pub contacts: Option<usize>,
    pub hits: Option<HitRates>,
    pub timing_ms: Option<TimingMs>,
    pub beat_alignment_ms: Option<BeatAlignmentMs>,
    pub ipd_mm: Option<IpdMm>,
    /// Spearman correlation of note velocity with contact speed (each played note's first
    /// contact).
    pub velocity_speed_spearman: Option<f64>,
    pub hands: Option<HandMetrics>,
}

/// Contacts against hand and foot notes (filled by the contact measures).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HitRates {
    pub recall: f64,
    pub precision: f64,
}

/// Contact start - note time, ms (filled by the contact measures).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TimingMs {
    pub mean: f64,
    pub sd: f64,
    pub median: f64,
    pub p95_abs: f64,
}

/// Impact point deviation, mm (filled by the contact measures).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct IpdMm {
    pub mean: f64,
    pub p95: f64,
}

/// DRUMS beat alignment (speed peak - onset), ms, with its counts; the statistics are
/// null when no peak matched an onset.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct BeatAlignmentMs {
    pub mean: Option<f64>,
    pub sd: Option<f64>,
    pub median: Option<f64>,
    /// Speed peaks (both hands) matched to an onset within the window.
    pub matched: usize,
    /// Speed peaks with no onset within the window.
    pub unmatched_peaks: usize,
    /// Hand-played onsets that no peak matched.
    pub unmatched_onsets: usize,
}

/// Hand trajectories against a reference, mean of the two hands (module doc for units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct HandMetrics {
    pub l1_m: f64,
    pub dtw: f64,
    pub jerk_rms: f64,
}

/// Grip positions of hand `side` (0 left, 1 right), one per frame.
pub fn hand_positions(motion: &Motion, side: usize) -> Vec<[f32; 3]> {
    motion.frames.iter().map(|f| f.hands[side].pos).collect()
}

/// Onset times of the hand-played notes: note-ons the map knows and does not put on a
/// pedal (DRUMS leaves the kick out; the hi-hat foot is left out for the same reason).
pub fn hand_onsets_s(perf: &Performance, map: &NoteMap) -> Vec<f64> {
    perf.events
        .iter()
        .filter_map(|e| match e.kind {
            DrumEventKind::NoteOn { note, .. } => map.entry(note).filter(|m| m.zone != Zone::Pedal).map(|_| e.time_s),
            _ => None,
        })
        .collect()
}

/// The motion parts of the eval object: beat alignment of `pred` against the
/// hand-played onsets, and, with a reference, L1, DTW (band [`DTW_BAND_FRAMES`]) and the
/// prediction's jerk RMS (metres per frame^3), each the mean of the two hands.
pub fn motion_metrics(
    pred: &Motion,
    reference: Option<&Motion>,
    hand_onsets_s: &[f64],
) -> Result<MotionMetrics, MotionMetricError> {
    check_fps(pred.fps, "eval prediction")?;
    let left = hand_positions(pred, 0);
    let right = hand_positions(pred, 1);
    let beat = beat_alignment(&[&left, &right], hand_onsets_s, pred.fps, &BeatParams::default())?;
    let stats = mean_sd_median(&beat.delays_ms);
    let beat_alignment_ms = BeatAlignmentMs {
        mean: stats.map(|s| s.0),
        sd: stats.map(|s| s.1),
        median: stats.map(|s| s.2),
        matched: beat.delays_ms.len(),
        unmatched_peaks: beat.unmatched_peaks,
        unmatched_onsets: beat.unmatched_onsets,
    };
    let hands = match reference {
        None => None,
        Some(r) => {
            check_fps(r.fps, "eval reference")?;
            if (r.fps - pred.fps).abs() > 1e-9 {
                return Err(MotionMetricError::Invalid {
                    what: "eval reference",
                    message: format!("{} fps, the prediction has {} fps", r.fps, pred.fps),
                });
            }
            // The measures compare frame by frame: a reference of another length is of
            // another song (a 1-frame reference once gave L1 = 0).
            let (n, m) = (r.frames.len(), pred.frames.len());
            if n.abs_diff(m) as f64 > (0.05 * m as f64).max(r.fps) {
                return Err(MotionMetricError::Invalid {
                    what: "eval reference",
                    message: format!(
                        "{n} frames, the prediction has {m}: they must cover the same song (within 5 % or a second)"
                    ),
                });
            }
            let mut sum = HandMetrics { l1_m: 0.0, dtw: 0.0, jerk_rms: 0.0 };
            for (side, p) in [&left, &right].into_iter().enumerate() {
                let q = hand_positions(r, side);
                sum.l1_m += 0.5 * l1_m(p, &q)?;
                sum.dtw += 0.5 * dtw_banded(p, &q, Some(DTW_BAND_FRAMES))?;
                sum.jerk_rms += 0.5 * jerk_rms_per_frame(p)?;
            }
            Some(sum)
        }
    };
    Ok(MotionMetrics { beat_alignment_ms: Some(beat_alignment_ms), hands, ..MotionMetrics::default() })
}

fn check_fps(fps: f64, what: &'static str) -> Result<(), MotionMetricError> {
    if fps.is_finite() && fps > 0.0 {
        Ok(())
    } else {
        Err(MotionMetricError::Invalid { what, message: format!("fps {fps} must be positive") })
    }
}

#[cfg(test)]
#[path = "motion_tests.rs"]
mod tests;
