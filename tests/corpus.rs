//! The corpus teacher on real Groove MIDI files: sticks on the strike points at the notes'
//! frames, no crossed hands at speed, lifts that grow with velocity, a right-hand hi-hat,
//! alternating fills, determinism; and the dataset file round trip. Each test prints the
//! figures it measured (`cargo test --release --test corpus -- --nocapture`).

use drumsim::kit::Kit;
use drumsim::learn::corpus::{build_dataset, load_examples, run_corpus, teach, PlannedNote, Teaching, LEFT, RIGHT};
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use std::path::{Path, PathBuf};

fn gmd() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd")
}

const BEATS: [&str; 5] = [
    "drummer1/session1/1_funk_80_beat_4-4.mid",
    "drummer3/session1/20_rock_120_beat_4-4.mid",
    "drummer1/session3/8_rock_135_beat_4-4.mid",
    "drummer10/session1/6_jazz-swing_215_beat_4-4.mid",
    "drummer1/session1/76_jazz-mediumfast_180_beat_4-4.mid",
];
const FILLS: [&str; 9] = [
    "drummer1/session1/10_jazz-funk_116_fill_4-4.mid",
    "drummer1/session1/127_funk-fast_125_fill_4-4.mid",
    "drummer1/session1/128_funk-fast_125_fill_4-4.mid",
    "drummer1/session1/103_funk_95_fill_4-4.mid",
    "drummer1/session1/104_funk_95_fill_4-4.mid",
    "drummer1/session1/106_funk_95_fill_4-4.mid",
    "drummer1/session1/107_funk_95_fill_4-4.mid",
    "drummer1/session1/108_funk_95_fill_4-4.mid",
    "drummer1/session1/109_funk_95_fill_4-4.mid",
];

fn teach_file(rel: &str, seed: u64) -> Teaching {
    let map = NoteMap::builtin("roland-td").unwrap();
    let perf = read_file(&gmd().join(rel), &ReadOptions { channel: 10 }).unwrap();
    teach(&perf, &map, &Kit::builtin_default(), seed).unwrap()
}

fn all_files() -> impl Iterator<Item = &'static str> {
    BEATS.iter().chain(FILLS.iter()).copied()
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[test]
fn every_kept_note_has_its_tip_on_the_strike_point_at_its_frame() {
    let (mut notes, mut worst, mut dropped) = (0, 0f32, 0);
    for rel in all_files() {
        let t = teach_file(rel, 1);
        assert_eq!(t.motion.frames.len(), t.roll.len(), "{rel}");
        dropped += t.dropped;
        for n in &t.notes {
            let tip = t.motion.frames[n.frame].hands[n.hand].stick_tip();
            let d = dot(sub(tip, n.point), sub(tip, n.point)).sqrt();
            worst = worst.max(d);
            assert!(d < 1e-3, "{rel}: note at {:.3} s ({}, hand {}): tip {d} m off", n.time_s, n.piece, n.hand);
            notes += 1;
        }
    }
    println!("{notes} notes kept, {dropped} dropped; worst tip distance at the note frame {:.4} mm", worst * 1e3);
}

/// Consecutive hand notes (either hand) closer than 1/8 s: the frames between them are "fast".
fn fast_frames(notes: &[PlannedNote]) -> Vec<usize> {
    let mut f = Vec::new();
    for w in notes.windows(2) {
        if w[1].time_s - w[0].time_s < 0.125 {
            f.extend(w[0].frame..=w[1].frame);
        }
    }
    f.sort_unstable();
    f.dedup();
    f
}

#[test]
fn hands_never_cross_during_fast_notes() {
    let (mut checked, mut worst) = (0, f32::MIN);
    for rel in all_files() {
        let t = teach_file(rel, 1);
        for f in fast_frames(&t.notes) {
            let h = &t.motion.frames[f].hands;
            let over = h[LEFT].pos[0] - h[RIGHT].pos[0];
            worst = worst.max(over);
            assert!(over <= 0.05, "{rel}: frame {f}: left grip {over} m right of the right grip");
            checked += 1;
        }
    }
    println!("{checked} fast frames checked; largest left-grip x minus right-grip x: {:.3} m", worst);
    assert!(checked > 500, "the files have fast passages");
}

#[test]
fn louder_notes_are_lifted_higher() {
    // Notes whose hand last struck the same piece at least 0.4 s before (so the lift is not
    // capped by time): the highest the tip rose above the surface in between.
    let mut by_bin = [(0f32, 0usize); 3];
    let mut pairs = Vec::new();
    for rel in all_files() {
        let t = teach_file(rel, 1);
        let mut last: [Option<&PlannedNote>; 2] = [None, None];
        for n in &t.notes {
            if let Some(p) = last[n.hand] {
                if p.piece == n.piece && n.time_s - p.time_s >= 0.4 {
                    let apex = (p.frame + 1..n.frame)
                        .map(|f| dot(sub(t.motion.frames[f].hands[n.hand].stick_tip(), n.point), n.normal))
                        .fold(0f32, f32::max);
                    let bin = match n.velocity {
                        0..50 => 0,
                        50..90 => 1,
                        _ => 2,
                    };
                    by_bin[bin].0 += apex;
                    by_bin[bin].1 += 1;
                    pairs.push((n.velocity as f32, apex));
                }
            }
            last[n.hand] = Some(n);
        }
    }
    let means: Vec<f32> = by_bin.iter().map(|(s, c)| s / (*c).max(1) as f32).collect();
    let n = pairs.len() as f32;
    let (mx, my) = (pairs.iter().map(|p| p.0).sum::<f32>() / n, pairs.iter().map(|p| p.1).sum::<f32>() / n);
    let cov: f32 = pairs.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let (vx, vy): (f32, f32) =
        (pairs.iter().map(|p| (p.0 - mx).powi(2)).sum(), pairs.iter().map(|p| (p.1 - my).powi(2)).sum());
    let r = cov / (vx * vy).sqrt();
    println!(
        "lift by velocity: <50 {:.3} m ({}), 50-89 {:.3} m ({}), >=90 {:.3} m ({}); correlation {r:.2}",
        means[0], by_bin[0].1, means[1], by_bin[1].1, means[2], by_bin[2].1
    );
    assert!(by_bin.iter().all(|b| b.1 >= 5), "{by_bin:?}");
    assert!(means[0] < means[1] && means[1] < means[2], "{means:?}");
    assert!(r > 0.8, "correlation {r}");
}

#[test]
fn the_same_seed_repeats_and_another_seed_varies() {
    let rel = BEATS[1];
    let (a, b, c) = (teach_file(rel, 7), teach_file(rel, 7), teach_file(rel, 8));
    assert_eq!(a.motion, b.motion);
    assert_eq!(a.notes, b.notes);
    assert_ne!(a.motion, c.motion);
    // The notes (and so the contacts) are the same: only the variation differs.
    assert_eq!(a.notes, c.notes);
    let diff = a
        .motion
        .frames
        .iter()
        .zip(&c.motion.frames)
        .map(|(x, y)| dot(sub(x.hands[1].pos, y.hands[1].pos), sub(x.hands[1].pos, y.hands[1].pos)).sqrt())
        .fold(0f32, f32::max);
    println!("largest right-grip difference between seeds 7 and 8: {:.1} mm", diff * 1e3);
    assert!(diff > 0.002 && diff < 0.2, "{diff}");
}

#[test]
fn the_right_hand_plays_the_hi_hat_in_beats() {
    for rel in BEATS {
        let t = teach_file(rel, 1);
        let hat: Vec<_> = t.notes.iter().filter(|n| n.piece == "hihat").collect();
        let ride: Vec<_> = t.notes.iter().filter(|n| n.piece == "ride").collect();
        let right = |v: &[&PlannedNote]| v.iter().filter(|n| n.hand == RIGHT).count() as f32 / v.len().max(1) as f32;
        println!(
            "{rel}: hi-hat {} notes, {:.0} % right; ride {} notes, {:.0} % right",
            hat.len(),
            100.0 * right(&hat),
            ride.len(),
            100.0 * right(&ride)
        );
        if hat.len() >= 20 {
            assert!(right(&hat) > 0.8, "{rel}");
        }
        if ride.len() >= 20 {
            assert!(right(&ride) > 0.8, "{rel}");
        }
    }
}

#[test]
fn fills_alternate() {
    let (mut alt, mut runs) = (0, 0);
    for rel in FILLS {
        let t = teach_file(rel, 1);
        let drum = |n: &PlannedNote| n.piece == "snare" || n.piece.contains("tom");
        for w in t.notes.windows(2) {
            if drum(&w[0]) && drum(&w[1]) && w[1].time_s - w[0].time_s < 0.2 && w[1].frame > w[0].frame {
                runs += 1;
                alt += usize::from(w[0].hand != w[1].hand);
            }
        }
    }
    let share = alt as f32 / runs.max(1) as f32;
    println!("consecutive fill notes on drums: {runs}, alternating {:.0} %", 100.0 * share);
    assert!(runs > 50 && share > 0.75, "{alt} of {runs}");
}

#[test]
fn a_small_dataset_builds_skips_bad_files_and_round_trips() {
    let dir = std::env::temp_dir().join(format!("drumsim-corpus-test-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("broken.mid"), b"MThd not really").unwrap();
    let mut csv = String::from("id,midi_filename,split\n");
    for rel in &FILLS[..3] {
        csv += &format!("{rel},{},train\n", gmd().join(rel).display());
    }
    csv += "bad/1,broken.mid,train\n";
    csv += &format!("v/1,{},validation\n", gmd().join(BEATS[1]).display());
    std::fs::write(dir.join("info.csv"), csv).unwrap();
    let data = build_dataset(&dir, "train").unwrap();
    assert_eq!(data.examples.len(), 3);
    assert_eq!(data.skipped.len(), 1);
    assert!(data.skipped[0].0.ends_with("broken.mid"));
    for ex in &data.examples {
        assert_eq!(ex.roll.len(), ex.hands.len());
        assert!(ex.roll.iter().flatten().any(|&x| x == 1.0));
    }
    let out = dir.join("train.bin");
    let summary = run_corpus(&dir, &out, "train").unwrap();
    assert_eq!(summary.examples, 3);
    assert_eq!(summary.bytes, std::fs::metadata(&out).unwrap().len());
    assert_eq!(load_examples(&out).unwrap(), data.examples);
    let err = run_corpus(&dir, &dir.join("none.bin"), "test").unwrap_err().to_string();
    assert!(err.contains("info.csv") && err.contains("\"test\""), "{err}");
}

#[test]
fn the_example_mocap_file_loads_into_an_example() {
    use drumsim::learn::mocap::{load_mocap, JointNames};
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/mocap-example.json");
    let take = load_mocap(&path, &JointNames::default(), None).unwrap();
    assert_eq!(take.motion.frames.len(), 4);
    assert_eq!(take.roll.len(), 4);
    // The left stick tip of the file is on the snare at frame 1, where the snare note is.
    let tip = take.motion.frames[1].hands[LEFT].stick_tip();
    assert!((tip[2] - 0.625).abs() < 1e-4, "{tip:?}");
    let ex = take.example("mocap-example");
    assert_eq!(ex.roll.iter().map(|r| r.iter().sum::<f32>()).collect::<Vec<_>>(), [1.0, 1.0, 0.0, 1.0]);
    assert_eq!(ex.hands.len(), 4);
}

#[test]
fn the_body_follows_the_tempo_and_stays_in_range() {
    // GMD names the tempo the drummer played to (in the file name): the nod's estimate from
    // the notes alone should find it (or its half or double).
    for (rel, bpm) in [(BEATS[0], 80.0), (BEATS[1], 120.0), (BEATS[2], 135.0)] {
        let t = teach_file(rel, 1);
        let est = 60.0 / t.beat_s;
        let ratio = [0.5, 1.0, 2.0].into_iter().map(|k| (est * k / bpm - 1.0f64).abs()).fold(f64::MAX, f64::min);
        println!("{rel}: played at {bpm} BPM, estimated {est:.1} BPM");
        assert!(ratio < 0.03, "{rel}: {est} BPM");
        for (f, fr) in t.motion.frames.iter().enumerate() {
            assert_eq!(fr.face.len(), 52);
            assert!(fr.face.iter().all(|w| (0.0..=1.0).contains(w)), "{rel}: frame {f}");
            let all = [fr.chest, fr.head, fr.feet[0], fr.feet[1], fr.hands[0], fr.hands[1]];
            assert!(all.iter().flat_map(|p| p.pos.iter().chain(&p.rot)).all(|x| x.is_finite()));
            assert!((0.0..=1.0).contains(&fr.hihat_openness));
            assert!(fr.head.pos[2] > fr.chest.pos[2] + 0.2, "{rel}: frame {f}: head above chest");
        }
        let blinks = t.motion.frames.windows(2).filter(|w| w[0].face[0] < 0.5 && w[1].face[0] >= 0.5).count();
        let minutes = t.motion.frames.len() as f32 / 3600.0;
        println!("  {:.1} blinks a minute", blinks as f32 / minutes);
        assert!((5.0..=40.0).contains(&(blinks as f32 / minutes)), "{rel}: {blinks} blinks in {minutes} min");
    }
}

#[test]
fn the_teachers_hands_are_fastest_on_the_notes() {
    // DRUMS' beat alignment (hand-speed peaks matched to hand-played onsets within +-3
    // frames) on the teacher's own grips: the paper's mocap shows -16.3 / 31.7 ms; the
    // teacher's hands are built to peak on the notes.
    use drumsim::eval::beat::{beat_alignment, BeatParams};
    use drumsim::eval::motion::mean_sd_median;
    let mut delays = Vec::new();
    let mut notes = 0;
    for rel in all_files() {
        let t = teach_file(rel, 3);
        let onsets: Vec<f64> = t.notes.iter().map(|n| n.frame as f64 / 60.0).collect();
        notes += onsets.len();
        let grips: Vec<Vec<[f32; 3]>> =
            (0..2).map(|h| t.motion.frames.iter().map(|f| f.hands[h].pos).collect()).collect();
        let b = beat_alignment(&[&grips[0], &grips[1]], &onsets, 60.0, &BeatParams::default()).unwrap();
        delays.extend(b.delays_ms);
    }
    let (mean, sd, median) = mean_sd_median(&delays).unwrap();
    eprintln!("teacher beat alignment over {notes} notes: {} peaks matched, mean {mean:.2} ms, sd {sd:.2} ms, median {median:.1} ms", delays.len());
    assert!(delays.len() * 2 > notes, "most notes have a matched speed peak");
    assert!(mean.abs() <= 5.0 && sd <= 10.0, "mean {mean} sd {sd}");
}
