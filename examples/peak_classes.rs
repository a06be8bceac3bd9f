//! Where the hand model's beat-alignment delays come from: every speed peak DRUMS' beat
//! alignment matches (within +-3 frames of a hand-played onset), sorted by
//! - the grip's direction at the peak: `down` (a stroke into a contact) or `up` (an
//!   upstroke, which the teacher makes fastest on another hand's note);
//! - whether the teacher's same hand strikes that onset (`own`: it has a downward speed peak
//!   within a frame of it) or not (`other`);
//! - for the network's own downward peaks, the frames since that hand's previous contact.
//!
//! For each class: the count, the root mean square delay (what it adds to the sd) and the
//! histogram of delays in frames; the teacher's own peaks are sorted the same way.
//! Needs `data/corpus-validation.bin` (`drumsim corpus --split validation`).
//! Run: `cargo run --release --example peak_classes [WEIGHTS]` (default
//! `assets/hands/best.bpk`).

use std::collections::BTreeMap;
use std::path::Path;

use drumsim::eval::beat::{hand_speed, local_maxima, BeatParams};
use drumsim::eval::savgol::savgol_filter;
use drumsim::motion::corpus::load_examples;
use drumsim::motion::hands::HandModel;
use drumsim::motion::track::values_to_hands;
use drumsim::motion::HAND_VALUES;

/// Roll columns of the foot-played notes (kick, hi-hat pedal), left out as DRUMS does.
const FOOT_COLUMNS: [usize; 2] = [0, 5];
const FRAME_MS: f64 = 1000.0 / 60.0;

/// Hand `s`'s speed peaks as DRUMS finds them, each with whether the grip moves down there.
fn peaks(values: &[[f32; HAND_VALUES]], s: usize) -> Vec<(i64, bool)> {
    let p = BeatParams::default();
    let traj: Vec<[f32; 3]> = values.iter().map(|v| values_to_hands(v)[s].pos).collect();
    let speed = savgol_filter(&hand_speed(&traj, 60.0).unwrap(), p.sg_window, p.sg_order).unwrap();
    local_maxima(&speed)
        .into_iter()
        .map(|f| (f as i64, traj[(f + 1).min(traj.len() - 1)][2] < traj[f.saturating_sub(1)][2]))
        .collect()
}

/// Count and root mean square (ms) of a histogram of delays in frames.
fn rms(h: &BTreeMap<i64, usize>) -> (usize, f64) {
    let n: usize = h.values().sum();
    let ss: f64 = h.iter().map(|(d, c)| (*d as f64 * FRAME_MS).powi(2) * *c as f64).sum();
    (n, (ss / n.max(1) as f64).sqrt())
}

fn main() {
    let weights = std::env::args().nth(1).unwrap_or_else(|| "assets/hands/best.bpk".into());
    let model = HandModel::load(Path::new(&weights)).expect("hand model weights");
    let val = load_examples(Path::new("data/corpus-validation.bin")).expect("data/corpus-validation.bin");
    let mut classes: [BTreeMap<String, BTreeMap<i64, usize>>; 2] = Default::default();
    for ex in &val {
        let pred = model.predict(&ex.roll);
        let onsets: Vec<i64> = (0..ex.roll.len())
            .filter(|&f| ex.roll[f].iter().enumerate().any(|(c, &v)| v > 0.5 && !FOOT_COLUMNS.contains(&c)))
            .map(|f| f as i64)
            .collect();
        for s in 0..2 {
            let teacher = peaks(&ex.hands, s);
            let contacts: Vec<i64> = teacher.iter().filter(|p| p.1).map(|p| p.0).collect();
            for (who, found) in [(0, peaks(&pred, s)), (1, teacher.clone())] {
                for (p, down) in found {
                    let near = onsets.iter().map(|&o| o - p).filter(|d| d.abs() <= 3).min_by_key(|d| (d.abs(), *d));
                    let Some(d) = near else { continue };
                    let onset = p + d;
                    let own = contacts.iter().any(|&c| (c - onset).abs() <= 1);
                    let gap = if own && down && who == 0 {
                        match contacts.iter().rev().find(|&&c| c < onset - 1).map_or(i64::MAX, |&c| onset - c) {
                            0..=9 => " after <10 frames",
                            10..=20 => " after 10-20",
                            21..=40 => " after 21-40",
                            _ => " after >40",
                        }
                    } else {
                        ""
                    };
                    let key =
                        format!("{} {}{gap}", if down { "down" } else { "up" }, if own { "own" } else { "other" });
                    *classes[who].entry(key).or_default().entry(-d).or_default() += 1;
                }
            }
        }
    }
    for (who, name) in [(0, "network"), (1, "teacher")] {
        println!("{name}:");
        for (class, h) in &classes[who] {
            let (n, r) = rms(h);
            println!("  {class:30} {n:6} peaks, rms {r:5.1} ms, delays in frames {h:?}");
        }
    }
}
