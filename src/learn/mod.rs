//! Training-only code (DESIGN.md section 2): the corpus teacher that makes the hand model's
//! training material from Groove MIDI, mocap loading, the hand network as a burn module and
//! its training loop, validation against the teacher, and the build of the shipped retrieval
//! library. The runtime (render, live, the motion stage) never depends on it; the `corpus`,
//! `train` and `library` commands and `render --teacher` reach it from `main.rs`.

pub mod corpus;
pub mod hand_net;
pub mod mocap;
pub mod train;
pub mod upper_library;
pub mod validate;

use crate::motion::hands::{Normalisation, ROLL_COLUMNS};
use crate::motion::HAND_VALUES;
use serde::{Deserialize, Serialize};

pub use train::{run_train, train, EpochReport, TrainConfig, TrainReport};

/// One training sequence: a 60 fps piano roll and the hand values of the same frames.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Example {
    /// Where it came from (file name), for reports.
    pub id: String,
    /// Binary piano roll, one row per frame.
    pub roll: Vec<[f32; ROLL_COLUMNS]>,
    /// Target hand values, one row per frame (same length as `roll`).
    pub hands: Vec<[f32; HAND_VALUES]>,
}

/// Mean and standard deviation per channel over every frame of `examples`.
pub fn fit_normalisation(examples: &[Example]) -> Normalisation {
    let mut sum = [0.0f64; HAND_VALUES];
    let mut sq = [0.0f64; HAND_VALUES];
    let mut n = 0usize;
    for v in examples.iter().flat_map(|e| e.hands.iter()) {
        for c in 0..HAND_VALUES {
            sum[c] += v[c] as f64;
            sq[c] += (v[c] as f64).powi(2);
        }
        n += 1;
    }
    if n == 0 {
        return Normalisation::identity();
    }
    let mean = sum.map(|s| s / n as f64);
    let std = std::array::from_fn(|c| {
        ((sq[c] / n as f64 - mean[c] * mean[c]).max(0.0).sqrt() as f32).max(Normalisation::MIN_STD)
    });
    Normalisation { mean: mean.map(|m| m as f32), std }
}
