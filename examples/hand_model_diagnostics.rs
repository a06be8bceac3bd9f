//! Where the shipped hand model departs from the teacher on the validation split: speed
//! peaks of both (DRUMS' beat alignment counts every peak), the histogram of matched
//! delays in frames, and the normalised MSE of each of the 14 output channels.
//! Needs `data/corpus-validation.bin` (`drumsim corpus --split validation`).
//! Run: `cargo run --release --example hand_model_diagnostics [WEIGHTS]` (default
//! `assets/hands/best.bpk`; its `.json` sidecar beside it).

use std::collections::BTreeMap;
use std::path::Path;

use drumsim::eval::beat::{beat_alignment, BeatParams};
use drumsim::motion::corpus::load_examples;
use drumsim::motion::hands::HandModel;
use drumsim::motion::track::values_to_hands;

/// Roll columns of the foot-played notes (kick, hi-hat pedal), left out as DRUMS does.
const FOOT_COLUMNS: [usize; 2] = [0, 5];

fn main() {
    let weights = std::env::args().nth(1).unwrap_or_else(|| "assets/hands/best.bpk".into());
    let model = HandModel::load(Path::new(&weights)).expect("hand model weights");
    let side = Path::new(&weights).with_extension("json");
    let sidecar: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(side).expect("sidecar")).unwrap();
    let std: Vec<f64> =
        sidecar["normalisation"]["std"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    let val = load_examples(Path::new("data/corpus-validation.bin")).expect("data/corpus-validation.bin");
    let (mut peaks, mut matched) = ([0usize; 2], [0usize; 2]);
    let mut hist: [BTreeMap<i64, usize>; 2] = Default::default();
    let (mut se, mut frames) = (vec![0.0f64; std.len()], 0usize);
    for ex in &val {
        let pred = model.predict(&ex.roll);
        let onsets: Vec<f64> = (0..ex.roll.len())
            .filter(|&f| ex.roll[f].iter().enumerate().any(|(c, &v)| v > 0.5 && !FOOT_COLUMNS.contains(&c)))
            .map(|f| f as f64 / 60.0)
            .collect();
        for (who, values) in [(0, &pred), (1, &ex.hands)] {
            let hands: Vec<Vec<[f32; 3]>> =
                (0..2).map(|s| values.iter().map(|v| values_to_hands(v)[s].pos).collect()).collect();
            let b = beat_alignment(&[&hands[0], &hands[1]], &onsets, 60.0, &BeatParams::default()).unwrap();
            peaks[who] += b.peaks;
            matched[who] += b.delays_ms.len();
            for d in &b.delays_ms {
                *hist[who].entry((d * 60.0 / 1000.0).round() as i64).or_default() += 1;
            }
        }
        for (p, t) in pred.iter().zip(&ex.hands) {
            for c in 0..std.len() {
                se[c] += ((p[c] - t[c]) as f64 / std[c]).powi(2);
            }
        }
        frames += pred.len();
    }
    for (who, name) in [(0, "network"), (1, "teacher")] {
        println!("{name}: {} speed peaks, {} matched; delays in frames {:?}", peaks[who], matched[who], hist[who]);
    }
    let mse: Vec<String> = se.iter().map(|s| format!("{:.3}", s / frames as f64)).collect();
    println!("normalised MSE per channel (left x y z w x y z, right x y z w x y z): {}", mse.join(" "));
}
