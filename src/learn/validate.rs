//! The hand model against its teacher on held-out performances: the measures.
//!
//! - L1 per hand: mean absolute error of the grip position per coordinate, metres, over
//!   every frame of every performance (`eval::motion::l1_m`).
//! - Beat alignment (DRUMS): speed peaks of the predicted grips matched to the hand-played
//!   onsets of the roll (every column but the kick, 36, and the hi-hat pedal, 44) within +-3
//!   frames, pooled over the performances (`eval::beat`).

use super::Example;
use crate::eval::beat::{beat_alignment, BeatParams};
use crate::eval::motion::{l1_m, mean_sd_median, MotionMetricError};
use crate::midi::roll::NOTE_NUMS;
use crate::motion::hands::HandModel;
use crate::motion::track::values_to_hands;

/// What [`validate`] measured.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Validation {
    pub performances: usize,
    pub frames: usize,
    /// Left, right.
    pub l1_m: [f64; 2],
    /// Beat alignment mean, sd, median, ms (None when no peak matched).
    pub beat_ms: Option<(f64, f64, f64)>,
    pub matched_peaks: usize,
    /// The same beat alignment on the teacher's own hands (the reference's figure).
    pub teacher_beat_ms: Option<(f64, f64, f64)>,
}

fn grips(values: &[[f32; 14]], side: usize) -> Vec<[f32; 3]> {
    values.iter().map(|v| values_to_hands(v)[side].pos).collect()
}

/// Hand-played onset times of a roll.
fn hand_onsets(roll: &[[f32; 16]], fps: f64) -> Vec<f64> {
    let hand_cols: Vec<usize> = (0..16).filter(|&c| NOTE_NUMS[c] != 36 && NOTE_NUMS[c] != 44).collect();
    roll.iter()
        .enumerate()
        .filter(|(_, f)| hand_cols.iter().any(|&c| f[c] > 0.5))
        .map(|(i, _)| i as f64 / fps)
        .collect()
}

/// Measure `model` on `examples` (the teacher's hands as the reference).
pub fn validate(model: &HandModel, examples: &[Example]) -> Result<Validation, MotionMetricError> {
    let fps = crate::motion::FPS;
    let (mut l1, mut frames) = ([0.0f64; 2], 0usize);
    let (mut delays, mut teacher_delays) = (Vec::new(), Vec::new());
    for ex in examples.iter().filter(|e| e.roll.len() >= 8) {
        let pred = model.predict(&ex.roll);
        let onsets = hand_onsets(&ex.roll, fps);
        let (p, t): (Vec<_>, Vec<_>) = (0..2).map(|s| (grips(&pred, s), grips(&ex.hands, s))).unzip();
        for side in 0..2 {
            l1[side] += l1_m(&p[side], &t[side])? * ex.roll.len() as f64;
        }
        frames += ex.roll.len();
        let params = BeatParams::default();
        delays.extend(beat_alignment(&[&p[0], &p[1]], &onsets, fps, &params)?.delays_ms);
        teacher_delays.extend(beat_alignment(&[&t[0], &t[1]], &onsets, fps, &params)?.delays_ms);
    }
    let n = frames.max(1) as f64;
    Ok(Validation {
        performances: examples.len(),
        frames,
        l1_m: [l1[0] / n, l1[1] / n],
        beat_ms: mean_sd_median(&delays),
        matched_peaks: delays.len(),
        teacher_beat_ms: mean_sd_median(&teacher_delays),
    })
}
