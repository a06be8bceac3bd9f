//! The live physical drummer's lag model: how late the body's stick contacts land against
//! their notes when a song is played straight through (no rehearsal, as live play must), by
//! piece, velocity and the time since the same hand's previous note. Offline the rehearsal
//! corrects each stroke over passes; live cannot, so it aims each stroke this much earlier
//! (or later) instead ([`crate::motion::plan::PlannedHands::aimed`]).
//!
//! Learned by `cargo run --release --example lag_model` from Groove MIDI training takes and
//! shipped as `assets/lag-model.json`. Each class's mean is shrunk toward its piece's, and
//! the piece's toward zero, by `n / (n + SHRINK)` for `n` samples, so that a sparse class
//! moves its strokes little.

use serde::{Deserialize, Serialize};
use std::fmt::Write as _;

/// Velocity bins: below 40, 40-69, 70-99, 100 and over.
pub const VELOCITY_EDGES: [u8; 3] = [40, 70, 100];
/// Bins of the time since the same hand's previous note, s.
pub const SINCE_EDGES_S: [f64; 3] = [0.12, 0.25, 0.5];
/// Samples that count as much as the prior (the piece's mean, or zero).
const SHRINK: f64 = 20.0;
/// The most a stroke is moved, s.
pub const MAX_LAG_S: f64 = 0.008;

/// One hand contact on its note.
#[derive(Debug, Clone)]
pub struct LagSample {
    pub piece: String,
    pub velocity: u8,
    /// Since the same hand's previous note, s (infinite for its first).
    pub since_s: f64,
    /// Contact time minus note time, s.
    pub late_s: f64,
}

/// One piece's lags.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct PieceLag {
    piece: String,
    /// The piece's lag, ms, and its samples.
    lag_ms: f64,
    n: usize,
    /// By velocity bin, then bin of the time since the previous note: lag, ms, and samples.
    classes: Vec<Vec<(f64, usize)>>,
}

/// Lags by piece, velocity and the time since the hand's previous note.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct LagModel {
    velocity_edges: Vec<u8>,
    since_edges_s: Vec<f64>,
    pieces: Vec<PieceLag>,
}

fn velocity_bin(v: u8) -> usize {
    VELOCITY_EDGES.iter().filter(|&&e| v >= e).count()
}

fn since_bin(s: f64) -> usize {
    SINCE_EDGES_S.iter().filter(|&&e| s >= e).count()
}

impl LagModel {
    /// The shipped model.
    pub fn shipped() -> LagModel {
        serde_json::from_str(include_str!("../../assets/lag-model.json")).expect("assets/lag-model.json")
    }

    /// Fit to `samples`.
    pub fn fit(samples: &[LagSample]) -> LagModel {
        let mut names: Vec<&str> = samples.iter().map(|s| s.piece.as_str()).collect();
        names.sort_unstable();
        names.dedup();
        let pieces = names
            .into_iter()
            .map(|piece| {
                let of: Vec<&LagSample> = samples.iter().filter(|s| s.piece == piece).collect();
                let n = of.len();
                let mean = of.iter().map(|s| s.late_s).sum::<f64>() / n.max(1) as f64;
                let lag = mean * n as f64 / (n as f64 + SHRINK);
                let classes = (0..=VELOCITY_EDGES.len())
                    .map(|vb| {
                        (0..=SINCE_EDGES_S.len())
                            .map(|sb| {
                                let c: Vec<f64> = of
                                    .iter()
                                    .filter(|s| velocity_bin(s.velocity) == vb && since_bin(s.since_s) == sb)
                                    .map(|s| s.late_s)
                                    .collect();
                                let m = c.iter().sum::<f64>() / c.len().max(1) as f64;
                                let w = c.len() as f64 / (c.len() as f64 + SHRINK);
                                ((lag + w * (m - lag)) * 1e3, c.len())
                            })
                            .collect()
                    })
                    .collect();
                PieceLag { piece: piece.to_string(), lag_ms: lag * 1e3, n, classes }
            })
            .collect();
        LagModel { velocity_edges: VELOCITY_EDGES.to_vec(), since_edges_s: SINCE_EDGES_S.to_vec(), pieces }
    }

    /// How late a stroke on `piece` at `velocity`, `since_s` after the hand's previous note,
    /// lands, s (0 for a piece the model does not know), within [`MAX_LAG_S`].
    pub fn lag_s(&self, piece: &str, velocity: u8, since_s: f64) -> f64 {
        let Some(p) = self.pieces.iter().find(|p| p.piece == piece) else { return 0.0 };
        let ms =
            p.classes.get(velocity_bin(velocity)).and_then(|c| c.get(since_bin(since_s))).map_or(p.lag_ms, |c| c.0);
        (ms * 1e-3).clamp(-MAX_LAG_S, MAX_LAG_S)
    }

    /// The sd of the samples' lateness, and of what is left with the model's lag taken off, s.
    pub fn residual_sd(&self, samples: &[LagSample]) -> (f64, f64) {
        let sd = |x: &[f64]| {
            let m = x.iter().sum::<f64>() / x.len().max(1) as f64;
            (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
        };
        let raw: Vec<f64> = samples.iter().map(|s| s.late_s).collect();
        let left: Vec<f64> = samples.iter().map(|s| s.late_s - self.lag_s(&s.piece, s.velocity, s.since_s)).collect();
        (sd(&raw), sd(&left))
    }

    /// The model as a table: per piece, a row per velocity bin, a column per bin of the time
    /// since the previous note (lag ms / samples).
    pub fn table(&self) -> String {
        let mut t = String::from("piece      velocity   since <120 ms   120-250 ms   250-500 ms   >= 500 ms\n");
        for p in &self.pieces {
            let _ = writeln!(t, "{:10} all        {:+.2} ms ({} samples)", p.piece, p.lag_ms, p.n);
            for (vb, row) in p.classes.iter().enumerate() {
                let label = ["< 40", "40-69", "70-99", ">= 100"][vb];
                let _ = write!(t, "{:10} {label:10}", "");
                for (ms, n) in row {
                    let _ = write!(t, " {ms:+6.2} ({n:4})");
                }
                t.push('\n');
            }
        }
        t
    }

    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a lag model is JSON")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_class_with_many_samples_gets_its_own_lag_a_sparse_one_its_pieces() {
        let mut samples = Vec::new();
        for i in 0..2000 {
            // Soft snare notes after a long rest land 4 ms late, loud ones 1 ms early.
            let (velocity, late_s) = if i % 2 == 0 { (30, 0.004) } else { (110, -0.001) };
            samples.push(LagSample { piece: "snare".into(), velocity, since_s: 1.0, late_s });
        }
        samples.push(LagSample { piece: "snare".into(), velocity: 80, since_s: 0.05, late_s: 0.02 });
        let m = LagModel::fit(&samples);
        assert!((m.lag_s("snare", 30, 1.0) - 0.004).abs() < 0.0005, "{}", m.lag_s("snare", 30, 1.0));
        assert!((m.lag_s("snare", 110, 1.0) + 0.001).abs() < 0.0005);
        // One sample: mostly the piece's mean (1.5 ms), not its own 20 ms.
        let sparse = m.lag_s("snare", 80, 0.05);
        assert!(sparse > 0.001 && sparse < 0.003, "{sparse}");
        assert_eq!(m.lag_s("ride", 80, 0.05), 0.0);
        let (before, after) = m.residual_sd(&samples);
        assert!(after < 0.3 * before, "{before} -> {after}");
        let back: LagModel = serde_json::from_str(&m.to_json()).unwrap();
        assert_eq!(back.lag_s("snare", 30, 1.0), m.lag_s("snare", 30, 1.0));
    }
}
