//! The hand model of DRUMS (DESIGN.md 1a): a 2-layer bidirectional LSTM (hidden 128 per
//! direction, dropout 0.1 between the layers) and a linear layer, from the 60 fps piano roll
//! (16 binary columns) to 14 hand values per frame (per hand position 3 + quaternion w,x,y,z,
//! [`crate::motion::HAND_VALUES`]).
//!
//! - [`weights`]: a saved burnpack checkpoint read into plain `f32` arrays.
//! - [`infer`]: our own forward pass on those arrays, several times faster than burn's on one
//!   core; [`HandModel`] is what the rest of drumsim calls.
//!
//! Training (the network as a burn module, the training loop, validation against the
//! teacher) is training-only code, in [`crate::learn`].

pub mod infer;
pub mod kernels;
pub mod quant;
pub mod streams;
pub mod weights;

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::motion::HAND_VALUES;

pub use infer::{HandModel, SHIPPED_WEIGHTS_NAME};
pub use streams::Kernels;

/// Piano-roll columns (`midi::roll::NOTE_NUMS`), the network's input width.
pub const ROLL_COLUMNS: usize = 16;

/// Per-channel normalisation of the 14 targets: the network predicts `(v - mean) / std`, so
/// that the MSE weighs centimetres of position and quaternion components alike.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Normalisation {
    pub mean: [f32; HAND_VALUES],
    pub std: [f32; HAND_VALUES],
}

impl Normalisation {
    /// Smallest standard deviation used, so a constant channel does not divide by zero.
    pub const MIN_STD: f32 = 1e-3;

    /// Identity (mean 0, std 1).
    pub fn identity() -> Self {
        Self { mean: [0.0; HAND_VALUES], std: [1.0; HAND_VALUES] }
    }

    pub fn normalise(&self, v: &[f32; HAND_VALUES]) -> [f32; HAND_VALUES] {
        std::array::from_fn(|c| (v[c] - self.mean[c]) / self.std[c])
    }

    pub fn denormalise(&self, v: &[f32; HAND_VALUES]) -> [f32; HAND_VALUES] {
        std::array::from_fn(|c| v[c] * self.std[c] + self.mean[c])
    }
}

/// Everything that can go wrong loading, training or running the hand model.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum HandsError {
    #[error("hand model weights {path}: cannot read: {reason}")]
    Read { path: PathBuf, reason: String },
    #[error("hand model weights {path}: tensor `{name}` is missing")]
    MissingTensor { path: PathBuf, name: String },
    #[error("hand model weights {path}: tensor `{name}` has shape {found:?}, expected {expected:?}")]
    Shape { path: PathBuf, name: String, found: Vec<usize>, expected: Vec<usize> },
    #[error("hand model weights {path}: {reason}")]
    Invalid { path: PathBuf, reason: String },
    #[error("hand model checkpoint {path}: {reason}")]
    Checkpoint { path: PathBuf, reason: String },
    #[error("hand model training data: {0}")]
    Data(String),
    #[error("hand model training config: {0}")]
    Config(String),
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}
