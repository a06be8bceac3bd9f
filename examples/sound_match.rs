//! Physical against direct, note by note by ear (`drumsim::eval::note_sound`), over takes.
//!
//! `cargo run --release --example sound_match -- TAKE.mid ...` prints, per take and over
//! all: notes compared, level difference (median |d|, p95 |d|, share within 6 dB, median
//! signed) and onsets within 2 ms, and per piece; with VERBOSE=1 every note.

use drumsim::eval::note_sound::{compare, summarize, NoteSound};
use drumsim::kit::Kit;
use drumsim::midi::NoteMap;
use drumsim::render::{load_hands, read_song, score_performance, score_physical, stage_motion, RenderOptions};
use std::path::PathBuf;

fn main() -> anyhow::Result<()> {
    let kit = match std::env::var("KIT") {
        Ok(p) => Kit::load(std::path::Path::new(&p))?,
        Err(_) => Kit::builtin_default(),
    };
    // MAP=roland-td for Groove MIDI takes.
    let map = NoteMap::load(&std::env::var("MAP").unwrap_or("gm".into()))?;
    let opts = RenderOptions::default();
    let hands = load_hands(&opts)?;
    let verbose = std::env::var("VERBOSE").is_ok();
    let mut all: Vec<NoteSound> = Vec::new();
    for song in std::env::args().skip(1).map(PathBuf::from) {
        let perf = read_song(&song, &map, &opts)?;
        let direct = score_performance(&perf, &kit, &map)?;
        let mut staged = stage_motion(&perf, &kit, &map, &hands)?;
        let (physical, _) = score_physical(&perf, &kit, &map, &mut staged)?;
        let notes = compare(&kit, &direct.contacts, &physical.contacts)?;
        if verbose {
            for n in &notes {
                println!(
                    "  {:8.3} {:10} v{:<3} onset {:+6.2} ms level {:+6.1} dB",
                    n.note.time_s, n.piece, n.note.velocity, n.onset_diff_ms, n.level_diff_db
                );
            }
        }
        println!("{} {:?}", song.display(), summarize(&notes));
        all.extend(notes);
    }
    println!("all {:?}", summarize(&all));
    let mut pieces: Vec<&str> = all.iter().map(|n| n.piece.as_str()).collect();
    pieces.sort();
    pieces.dedup();
    for p in pieces {
        let of: Vec<NoteSound> = all.iter().filter(|n| n.piece == p).cloned().collect();
        let s = summarize(&of);
        println!(
            "  {p:10} {:4} notes, level median {:+5.1} dB, |d| median {:4.1} p95 {:4.1}, onsets within 2 ms {:5.1} %",
            s.notes,
            s.level_median_db,
            s.level_median_abs_db,
            s.level_p95_abs_db,
            100.0 * s.onset_within_2ms
        );
    }
    Ok(())
}
