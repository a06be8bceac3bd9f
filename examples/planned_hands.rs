//! The hands drumsim renders (the hand model, then strike planning, through the same
//! `perform` as `drumsim render`) against the teacher on Groove MIDI validation takes: beat
//! alignment of the network's own hands, of the planned hands and of the teacher; L1 of the
//! planned hands against the teacher; strikes on the surface within one frame; how far the
//! planned sticks turn from the predicted rotation.
//! Run: `cargo run --release --example planned_hands [STEP [WEIGHTS]]` (every STEP-th
//! validation take, default 6: 21 takes; weights default `assets/hands/best.bpk`).

use drumsim::eval::beat::{beat_alignment, BeatParams};
use drumsim::eval::motion::{hand_onsets_s, mean_sd_median};
use drumsim::eval::strike::{fraction_on_surface_within, StrikeNote};
use drumsim::kit::Kit;
use drumsim::learn::corpus::teacher_hands;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform};
use drumsim::motion::upper::Library;
use std::path::Path;

const GMD: &str = "data/gmd";

fn main() {
    let step: usize = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(6);
    let info = std::fs::read_to_string(Path::new(GMD).join("info.csv")).unwrap();
    let files: Vec<_> = info
        .lines()
        .skip(1)
        .filter(|l| l.ends_with(",validation"))
        .step_by(step)
        .map(|l| Path::new(GMD).join(l.split(',').nth(7).unwrap()))
        .collect();
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::builtin_default();
    let weights = std::env::args().nth(2).unwrap_or_else(|| "assets/hands/best.bpk".into());
    let model = HandModel::load(Path::new(&weights)).unwrap();
    let lib = Library::load(Path::new("assets/upper-library.bin")).unwrap();
    let (mut raw, mut planned, mut teach) = (Vec::new(), Vec::new(), Vec::new());
    // How far the planned stick turned from the predicted rotation, degrees, every frame.
    let mut turns: Vec<f32> = Vec::new();
    let (mut l1, mut n, mut on, mut total) = ([0.0f64; 2], 0usize, 0.0, 0usize);
    for path in &files {
        let perf = read_file(path, &ReadOptions { channel: 10 }).unwrap();
        let pred = model_hands(&model, &perf, &map);
        let tch = teacher_hands(&perf, &map, &kit).unwrap();
        let (motion, report) = perform(&perf, &map, &kit, &pred, &lib).unwrap();
        let onsets = hand_onsets_s(&perf, &map);
        let pos = |f: &dyn Fn(usize) -> [f32; 3]| -> Vec<[f32; 3]> { (0..pred.len()).map(f).collect() };
        for (hands, out) in [(0, &mut raw), (1, &mut planned), (2, &mut teach)] {
            let tr: Vec<Vec<[f32; 3]>> = (0..2)
                .map(|s| match hands {
                    0 => pos(&|f| pred[f][s].pos),
                    1 => pos(&|f| motion.frames[f].hands[s].pos),
                    _ => pos(&|f| tch[f][s].pos),
                })
                .collect();
            let b = beat_alignment(&[&tr[0], &tr[1]], &onsets, 60.0, &BeatParams::default()).unwrap();
            out.extend(b.delays_ms);
        }
        for s in 0..2 {
            l1[s] += (0..pred.len())
                .map(|f| {
                    (0..3).map(|c| (motion.frames[f].hands[s].pos[c] - tch[f][s].pos[c]).abs() as f64).sum::<f64>()
                        / 3.0
                })
                .sum::<f64>();
        }
        for (a, b) in pred.iter().zip(&motion.frames) {
            for (pa, pb) in a.iter().zip(&b.hands) {
                let d: f32 = pa.rot.iter().zip(&pb.rot).map(|(x, y)| x * y).sum::<f32>().abs().min(1.0);
                turns.push(2.0 * d.acos().to_degrees());
            }
        }
        n += pred.len();
        let (notes, _) = drumsim::motion::notes::hand_notes(&perf, &map, &kit).unwrap();
        let strike: Vec<StrikeNote> = notes
            .iter()
            .zip(&report.hands)
            .filter_map(|(nn, h)| {
                let piece = &kit.pieces[nn.piece];
                Some(StrikeNote {
                    time_s: nn.time_s,
                    hand: (*h)?,
                    center: piece.position_m,
                    normal: piece.normal,
                    radius_m: piece.radius_m,
                })
            })
            .collect();
        let tips = motion.tips();
        on += fraction_on_surface_within(&strike, &tips, 60.0, 1).unwrap() * strike.len() as f64;
        total += notes.len();
    }
    let fmt = |d: &[f64]| match mean_sd_median(d) {
        Some((mean, sd, median)) => format!("mean {mean:+.1} ms, sd {sd:.1} ms, median {median:.0} ms"),
        None => "no matched peaks".to_string(),
    };
    println!("{} takes, beat alignment", files.len());
    println!("  the network's hands: {}", fmt(&raw));
    println!("  planned hands:       {}", fmt(&planned));
    println!("  the teacher:         {}", fmt(&teach));
    turns.sort_by(|a, b| a.total_cmp(b));
    let q = |p: f64| turns[((turns.len() - 1) as f64 * p) as usize];
    println!(
        "wrist turn from the predicted rotation: median {:.1} deg, 90th percentile {:.1}, 99th {:.1}, max {:.1}",
        q(0.5),
        q(0.9),
        q(0.99),
        q(1.0)
    );
    println!(
        "planned hands vs the teacher: L1 {:.4} m left, {:.4} m right; strikes {on:.0} of {total} ({:.2} %)",
        l1[0] / n as f64,
        l1[1] / n as f64,
        100.0 * on / total as f64
    );
}
