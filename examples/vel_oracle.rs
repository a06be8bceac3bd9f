//! Whether the binary roll (DRUMS' input: onsets without velocity) hides the teacher's
//! stroke timing. The teacher plays every third validation take K times with its
//! velocities shuffled among the notes of each note number (or all set to that number's
//! mean), and the K grip trajectories are averaged: what an MSE predictor that cannot see
//! velocity would converge to, were velocity unpredictable within an instrument. Prints
//! DRUMS' beat alignment of the teacher, of one changed teacher and of the average, and
//! how far a shuffle moves the grips. `seed` keeps the velocities and gives each of the K
//! teachers another seed of human variation instead (which no input shows either); `both`
//! does both.
//! Run: `cargo run --release --example vel_oracle [K [STEP [shuffle|mean|seed|both]]]`
//! (8, 3, shuffle).
use drumsim::eval::beat::{beat_alignment, BeatParams};
use drumsim::eval::motion::mean_sd_median;
use drumsim::kit::Kit;
use drumsim::midi::{read_file, DrumEventKind, NoteMap, ReadOptions};
use drumsim::motion::corpus::dataset::seed_of;
use drumsim::motion::corpus::teach;
use std::path::Path;

const GMD: &str = "data/gmd";

fn main() {
    let k: usize = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(8);
    let step: usize = std::env::args().nth(2).map(|s| s.parse().unwrap()).unwrap_or(3);
    let mode: String = std::env::args().nth(3).unwrap_or("shuffle".into());
    let info = std::fs::read_to_string(Path::new(GMD).join("info.csv")).unwrap();
    let rows: Vec<(String, String)> = info
        .lines()
        .skip(1)
        .filter(|l| l.ends_with(",validation"))
        .step_by(step)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[2].to_string(), f[7].to_string())
        })
        .collect();
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::builtin_default();
    let (mut orig, mut one, mut avg, mut moved) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut rng = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        rng
    };
    for (id, midi) in &rows {
        let perf = read_file(&Path::new(GMD).join(midi), &ReadOptions { channel: map.channel }).unwrap();
        let seed = seed_of(id);
        let t0 = teach(&perf, &map, &kit, seed).unwrap();
        let onsets: Vec<f64> = (0..t0.roll.len())
            .filter(|&f| (0..16).any(|c| c != 0 && c != 5 && t0.roll.frames[f][c]))
            .map(|f| f as f64 / 60.0)
            .collect();
        let grips = |t: &drumsim::motion::corpus::Teaching, s: usize| -> Vec<[f32; 3]> {
            t.motion.frames.iter().map(|f| f.hands[s].pos).collect()
        };
        let p = BeatParams::default();
        let g0 = [grips(&t0, 0), grips(&t0, 1)];
        orig.extend(beat_alignment(&[&g0[0], &g0[1]], &onsets, 60.0, &p).unwrap().delays_ms);
        let n = t0.motion.frames.len();
        let mut sum = vec![[[0.0f64; 3]; 2]; n];
        for r in 0..k {
            let mut pk = perf.clone();
            // Velocities of each note number, shuffled among that number's notes.
            let mut by_note: std::collections::BTreeMap<u8, Vec<usize>> = Default::default();
            for (i, e) in pk.events.iter().enumerate() {
                if let DrumEventKind::NoteOn { note, .. } = e.kind {
                    by_note.entry(note).or_default().push(i);
                }
            }
            for idx in by_note.values() {
                let mut vels: Vec<u8> = idx
                    .iter()
                    .map(|&i| match pk.events[i].kind {
                        DrumEventKind::NoteOn { velocity, .. } => velocity,
                        _ => unreachable!(),
                    })
                    .collect();
                if mode == "seed" {
                    continue;
                }
                if mode == "shuffle" || mode == "both" {
                    for j in (1..vels.len()).rev() {
                        vels.swap(j, (next() % (j as u64 + 1)) as usize);
                    }
                } else {
                    let m = (vels.iter().map(|&v| v as u32).sum::<u32>() / vels.len() as u32) as u8;
                    vels.iter_mut().for_each(|v| *v = m.max(1));
                }
                for (&i, &v) in idx.iter().zip(&vels) {
                    if let DrumEventKind::NoteOn { note, .. } = pk.events[i].kind {
                        pk.events[i].kind = DrumEventKind::NoteOn { note, velocity: v };
                    }
                }
            }
            let seed_r = if mode == "seed" || mode == "both" { seed ^ next() } else { seed };
            let t = teach(&pk, &map, &kit, seed_r).unwrap();
            assert_eq!(t.motion.frames.len(), n);
            let g = [grips(&t, 0), grips(&t, 1)];
            if r == 0 {
                let d: f64 = (0..n)
                    .map(|f| {
                        (0..2)
                            .map(|s| (0..3).map(|c| (g[s][f][c] - g0[s][f][c]).abs() as f64).sum::<f64>())
                            .sum::<f64>()
                    })
                    .sum::<f64>()
                    / (6 * n) as f64;
                moved.push(d);
                one.extend(beat_alignment(&[&g[0], &g[1]], &onsets, 60.0, &p).unwrap().delays_ms);
            }
            for f in 0..n {
                for s in 0..2 {
                    for c in 0..3 {
                        sum[f][s][c] += g[s][f][c] as f64 / k as f64;
                    }
                }
            }
        }
        let a: [Vec<[f32; 3]>; 2] = std::array::from_fn(|s| sum.iter().map(|v| v[s].map(|x| x as f32)).collect());
        avg.extend(beat_alignment(&[&a[0], &a[1]], &onsets, 60.0, &p).unwrap().delays_ms);
    }
    let show = |name: &str, d: &[f64]| {
        let (m, sd, med) = mean_sd_median(d).unwrap();
        println!("{name:40} n {:6}  mean {m:+.1} sd {sd:.1} median {med:.1} ms", d.len());
    };
    println!("{} takes, K = {k}, {mode}", rows.len());
    show("teacher, true velocities", &orig);
    show("one changed teacher", &one);
    show("average of K teachers", &avg);
    println!(
        "grip moved by a shuffle: mean {:.2} mm per coordinate",
        1000.0 * moved.iter().sum::<f64>() / moved.len() as f64
    );
}
