//! MIDI -> whole-body motion on real Groove MIDI validation performances (beats and fills):
//! after strike planning every hand note's stick tip is on its piece's surface within one
//! frame of the note, on the default kit and on a rearranged one, and the motion is whole.

use drumsim::eval::strike::{fraction_on_surface_within, StrikeNote};
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform};
use drumsim::motion::upper::Library;
use std::path::{Path, PathBuf};

const GMD: &str = "data/gmd";

/// Validation files: every 12th row of the split (beats and fills of several drummers).
fn validation_files() -> Vec<PathBuf> {
    let info = std::fs::read_to_string(Path::new(GMD).join("info.csv")).expect("GMD info.csv");
    info.lines()
        .skip(1)
        .filter(|l| l.ends_with(",validation"))
        .step_by(12)
        .map(|l| Path::new(GMD).join(l.split(',').nth(7).unwrap()))
        .collect()
}

/// Share of hand notes on their surface within one frame, over the files, on `kit`, with
/// hands predicted by the shipped hand model (trained on the default kit).
fn on_surface(kit: &Kit) -> (usize, usize, usize) {
    let map = NoteMap::builtin("roland-td").unwrap();
    let model = HandModel::shipped();
    let lib = Library::load(Path::new("assets/upper-library.bin")).unwrap();
    let (mut on, mut total, mut fills) = (0.0, 0, 0);
    for path in validation_files() {
        let perf = read_file(&path, &ReadOptions { channel: 10 }).unwrap();
        let predicted = model_hands(&model, &perf, &map);
        let (motion, report) = perform(&perf, &map, kit, &predicted, &lib).unwrap();
        assert_eq!(motion.frames.len(), predicted.len());
        assert!(motion.frames.iter().all(|f| f.face.len() == 52 && f.hihat_openness.is_finite()));
        // The notes as planned: hand, piece centre, normal, radius.
        let (notes, _) = drumsim::motion::notes::hand_notes(&perf, &map, kit).unwrap();
        let tips = motion.tips();
        assert_eq!(report.hands.len(), notes.len());
        // Played notes with the hand that played them; dropped notes count as misses.
        let strike: Vec<StrikeNote> = notes
            .iter()
            .zip(&report.hands)
            .filter_map(|(n, h)| {
                let piece = &kit.pieces[n.piece];
                Some(StrikeNote {
                    time_s: n.time_s,
                    hand: (*h)?,
                    center: piece.position_m,
                    normal: piece.normal,
                    radius_m: piece.radius_m,
                })
            })
            .collect();
        let share = fraction_on_surface_within(&strike, &tips, 60.0, 1).unwrap();
        on += share * strike.len() as f64;
        total += notes.len();
        fills += path.to_string_lossy().contains("_fill_") as usize;
        eprintln!(
            "{}: {:.2} % of {} played notes, {} dropped",
            path.display(),
            100.0 * share,
            strike.len(),
            report.dropped
        );
    }
    (on.round() as usize, total, fills)
}

#[test]
fn every_hand_note_lands_on_its_piece_within_a_frame_on_the_default_kit() {
    let (on, total, fills) = on_surface(&Kit::builtin_default());
    eprintln!("default kit: {on} of {total} notes on the surface within one frame");
    assert!(fills > 0 && total > 500);
    assert!(on as f64 >= 0.995 * total as f64, "{on} of {total}");
}

#[test]
fn a_rearranged_kit_moves_every_strike_with_it() {
    let kit = Kit::load(Path::new("config/kits/rearranged.toml")).unwrap();
    let (on, total, _) = on_surface(&kit);
    eprintln!("rearranged kit: {on} of {total} notes on the surface within one frame");
    assert!(on as f64 >= 0.995 * total as f64, "{on} of {total}");
}

fn drumsim(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_drumsim")).args(args).output().unwrap()
}

#[test]
fn render_writes_the_motion_beside_the_sound() {
    let dir = std::env::temp_dir().join(format!("drumsim-motion-{}", std::process::id()));
    let out = drumsim(&["render", "assets/demo/demo.mid", "--out", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("demo.motion.json")).unwrap()).unwrap();
    assert_eq!(json["bones"].as_array().unwrap().len(), 57);
    assert_eq!(json["face_names"].as_array().unwrap().len(), 52);
    let frames = json["frames"].as_array().unwrap();
    // One frame per roll frame: the demo's duration at 60 fps.
    let perf = read_file(Path::new("assets/demo/demo.mid"), &ReadOptions::default()).unwrap();
    let roll = drumsim::midi::roll::piano_roll(&perf, &NoteMap::builtin("gm").unwrap());
    assert_eq!(frames.len(), roll.len());
    assert_eq!(frames[0]["bones"].as_array().unwrap().len(), 57);
    assert!(std::fs::metadata(dir.join("demo.bvh")).unwrap().len() > 0);
    let glb = std::fs::read(dir.join("demo.glb")).unwrap();
    assert_eq!(&glb[..4], b"glTF");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn missing_or_corrupt_weights_are_refused_naming_the_file() {
    let dir = std::env::temp_dir().join(format!("drumsim-weights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("nothing.bpk");
    let out = drumsim(&[
        "render",
        "assets/demo/demo.mid",
        "--out",
        dir.to_str().unwrap(),
        "--weights",
        missing.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("nothing.bpk"), "{}", String::from_utf8_lossy(&out.stderr));
    let corrupt = dir.join("corrupt.bpk");
    std::fs::write(&corrupt, b"these are not weights").unwrap();
    let out = drumsim(&[
        "render",
        "assets/demo/demo.mid",
        "--out",
        dir.to_str().unwrap(),
        "--weights",
        corrupt.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("corrupt.bpk"), "{}", String::from_utf8_lossy(&out.stderr));
    // Refused before anything was written.
    assert!(!dir.join("demo.motion.json").exists() && !dir.join("demo.wav").exists());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn eval_measures_a_render_against_its_midi_and_a_reference() {
    let dir = std::env::temp_dir().join(format!("drumsim-eval-{}", std::process::id()));
    let out = drumsim(&["render", "assets/demo/demo.mid", "--out", dir.to_str().unwrap()]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let reference = dir.join("demo.motion.json");
    let out = drumsim(&[
        "eval",
        "assets/demo/demo.mid",
        "--out",
        dir.to_str().unwrap(),
        "--reference",
        reference.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let m: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    eprintln!("{m}");
    // Direct mode: every note sounds at its onset.
    assert_eq!(m["hits"]["recall"].as_f64(), Some(1.0));
    assert!(m["timing_ms"]["p95_abs"].as_f64().unwrap() < 1.0);
    // Each note at its velocity's speed on the kit's map: the hi-hat chicks' (a foot closes
    // the hat at 0.4 of it) are scaled back before ranking (0.993 without); only the
    // cross-sticks' hoop clicks (0.7 of it) keep it under 1.
    let spearman = m["velocity_speed_spearman"].as_f64().unwrap();
    assert!(spearman > 0.995, "velocity-speed Spearman {spearman}");
    // The motion against itself: no distance.
    assert_eq!(m["hands"]["l1_m"].as_f64(), Some(0.0));
    assert_eq!(m["hands"]["dtw"].as_f64(), Some(0.0));
    assert!(m["beat_alignment_ms"]["matched"].as_u64().unwrap() > 0);
    assert!(m["ipd_mm"].is_null());
    // A render folder without the files: a clear error, exit 2.
    let out = drumsim(&[
        "eval",
        "assets/demo/demo.mid",
        "--out",
        dir.to_str().unwrap(),
        "--reference",
        "/no/such.motion.json",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("/no/such.motion.json"));
    std::fs::remove_dir_all(&dir).ok();
}
