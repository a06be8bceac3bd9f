//! How fragile the teacher's beat alignment is to the hand model's errors: the shipped
//! network's error (network minus teacher A, all 14 values per frame) is scaled and added
//! back to a teacher, and DRUMS' beat alignment of the sum is measured. With A = B and scale
//! 1 the sum is the network itself; smaller scales stand for a network that much more accurate,
//! with errors of the same kind; a width > 0 splits the error into its centred
//! moving average over 2 * width + 1 frames (slow errors) and the rest (fast ones); with
//! another teacher B (say the corpus rebuilt with another constant) it asks whether B
//! would tolerate errors like the present ones (a rough question: the network's errors
//! were shaped by A).
//! Needs the datasets (`drumsim corpus --split validation [--out FILE]`).
//! Run: `cargo run --release --example error_transfer A.bin B.bin [SCALE [WIDTH]]`
//! (for example `data/corpus-validation.bin data/corpus-validation.bin 0.25 0`).
use std::path::Path;

use drumsim::eval::beat::{beat_alignment, BeatParams};
use drumsim::eval::motion::mean_sd_median;
use drumsim::motion::corpus::load_examples;
use drumsim::motion::hands::HandModel;
use drumsim::motion::track::values_to_hands;

const FOOT_COLUMNS: [usize; 2] = [0, 5];

fn main() {
    let a: Vec<String> = std::env::args().collect();
    assert!(a.len() >= 3, "usage: error_transfer A.bin B.bin [SCALE [WIDTH]]");
    let model = HandModel::load(Path::new("assets/hands/best.bpk")).expect("weights");
    let ta = load_examples(Path::new(&a[1])).expect("A");
    let tb = load_examples(Path::new(&a[2])).expect("B");
    let scale: f32 = a.get(3).map(|s| s.parse().unwrap()).unwrap_or(1.0);
    let width: usize = a.get(4).map(|s| s.parse().unwrap()).unwrap_or(0);
    let mut d: [Vec<f64>; 5] = Default::default();
    for (ea, eb) in ta.iter().zip(&tb) {
        assert_eq!(ea.roll, eb.roll);
        let pred = model.predict(&ea.roll);
        let onsets: Vec<f64> = (0..ea.roll.len())
            .filter(|&f| ea.roll[f].iter().enumerate().any(|(c, &v)| v > 0.5 && !FOOT_COLUMNS.contains(&c)))
            .map(|f| f as f64 / 60.0)
            .collect();
        let mk = |vals: &dyn Fn(usize) -> [f32; 14]| -> Vec<Vec<[f32; 3]>> {
            (0..2).map(|s| (0..ea.roll.len()).map(|t| values_to_hands(&vals(t))[s].pos).collect()).collect()
        };
        // The error and its centred moving average over 2 * width + 1 frames.
        let n = ea.roll.len();
        let err: Vec<[f32; 14]> = (0..n).map(|t| std::array::from_fn(|c| pred[t][c] - ea.hands[t][c])).collect();
        let low: Vec<[f32; 14]> = (0..n)
            .map(|t| {
                let (lo, hi) = (t.saturating_sub(width), (t + width).min(n - 1));
                std::array::from_fn(|c| (lo..=hi).map(|k| err[k][c]).sum::<f32>() / (hi - lo + 1) as f32)
            })
            .collect();
        let variants: [Vec<Vec<[f32; 3]>>; 5] = [
            mk(&|t| pred[t]),
            mk(&|t| ea.hands[t]),
            mk(&|t| eb.hands[t]),
            mk(&|t| std::array::from_fn(|c| eb.hands[t][c] + scale * low[t][c])),
            mk(&|t| std::array::from_fn(|c| eb.hands[t][c] + scale * (err[t][c] - low[t][c]))),
        ];
        for (k, h) in variants.iter().enumerate() {
            let b = beat_alignment(&[&h[0], &h[1]], &onsets, 60.0, &BeatParams::default()).unwrap();
            d[k].extend(b.delays_ms);
        }
    }
    for (k, name) in
        ["network", "teacher A", "teacher B", "B + scale x slow error", "B + scale x fast error"].iter().enumerate()
    {
        let (m, s, _) = mean_sd_median(&d[k]).unwrap();
        println!("{name:20} {:6} matched, mean {m:+.1} sd {s:.1} ms", d[k].len());
    }
}
