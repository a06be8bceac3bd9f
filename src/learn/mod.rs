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

#[cfg(test)]
mod tests {
    use std::path::Path;

    /// Every `.rs` file under `dir`, recursively.
    fn sources(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                sources(&path, out);
            } else if path.extension().is_some_and(|e| e == "rs") {
                out.push(path);
            }
        }
    }

    #[test]
    fn no_runtime_module_uses_the_training_code() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        sources(&src, &mut files);
        let mut offenders = Vec::new();
        for f in &files {
            let rel = f.strip_prefix(&src).unwrap();
            if rel.starts_with("learn") || rel == Path::new("main.rs") || rel == Path::new("lib.rs") {
                continue;
            }
            let text = std::fs::read_to_string(f).unwrap();
            for (i, line) in text.lines().enumerate() {
                let code = line.split("//").next().unwrap_or("");
                if code.contains("learn::") {
                    offenders.push(format!("{}:{}: {}", rel.display(), i + 1, line.trim()));
                }
            }
        }
        assert!(files.len() > 100, "{} source files found", files.len());
        assert!(offenders.is_empty(), "runtime code uses src/learn/:\n{}", offenders.join("\n"));
    }
}
