//! MIDI -> whole-body motion on real Groove MIDI validation performances (beats and fills):
//! after strike planning every hand note's stick tip is on its piece's surface within one
//! frame of the note, on the default kit and on a rearranged one, and the motion is whole.

use drumsim::eval::strike::{fraction_on_surface_within, StrikeNote};
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::pipeline::{perform, teacher_hands};
use drumsim::motion::upper::Library;
use std::path::{Path, PathBuf};

const GMD: &str = "../shared/data/gmd";

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
/// hands predicted for the default kit (the teacher's, standing in for the model).
fn on_surface(kit: &Kit) -> (usize, usize, usize) {
    let map = NoteMap::builtin("roland-td").unwrap();
    let default = Kit::builtin_default();
    let lib = Library::load(Path::new("assets/upper-library.bin")).unwrap();
    let (mut on, mut total, mut fills) = (0.0, 0, 0);
    for path in validation_files() {
        let perf = read_file(&path, &ReadOptions { channel: 10 }).unwrap();
        let predicted = teacher_hands(&perf, &map, &default).unwrap();
        let (motion, report) = perform(&perf, &map, kit, &predicted, &lib).unwrap();
        assert_eq!(motion.frames.len(), predicted.len());
        assert!(motion.frames.iter().all(|f| f.face.len() == 52 && f.hihat_openness.is_finite()));
        // The notes as planned: hand, piece centre, normal, radius.
        let (notes, _) = drumsim::motion::corpus::hand_notes(&perf, &map, kit).unwrap();
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
