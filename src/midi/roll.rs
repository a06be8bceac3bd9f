//! The DRUMS piano roll: 60 fps, binary, over 16 notes.

use super::file::Performance;
use super::map::NoteMap;
use super::DrumEventKind;

/// The 16 notes of the DRUMS piano roll (DESIGN.md 1a).
pub const NOTE_NUMS: [u8; 16] = [36, 37, 38, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 55, 58, 59];
/// Frames per second of the roll.
pub const ROLL_FPS: f64 = 60.0;

/// A binary piano roll X in {0,1}^{T x 16}: `frames[t][c]` is true when roll note
/// `NOTE_NUMS[c]` has an onset in frame t.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct PianoRoll {
    pub frames: Vec<[bool; 16]>,
}

impl PianoRoll {
    /// Number of frames, T.
    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Frames with an onset in column `col`.
    pub fn onsets(&self, col: usize) -> usize {
        self.frames.iter().filter(|f| f[col]).count()
    }
}

/// The roll column of a DRUMS note (an index into [`NOTE_NUMS`]).
pub fn column(note: u8) -> Option<usize> {
    NOTE_NUMS.iter().position(|&n| n == note)
}

/// How long the roll (and so the motion) runs on after the last note: the sticks rebound
/// and the arms come to rest, seconds.
pub const ROLL_TAIL_S: f64 = 1.0;

/// The frame a time falls in: round(time_s * 60).
pub fn frame_of(time_s: f64) -> usize {
    (time_s.max(0.0) * ROLL_FPS).round() as usize
}

/// Quantise the note-ons of `perf` at 60 fps through `map`. Frame t holds the onsets at
/// times that round to t; the roll ends [`ROLL_TAIL_S`] after the last note
/// (`perf.notes_end_s`), so T = round((notes_end_s + 1) * 60) + 1, whatever the file says
/// after it: a track that ends hours after its last note (or pedal data that runs on) makes
/// no longer a roll, and no longer a motion. Notes the map does not know are skipped.
pub fn piano_roll(perf: &Performance, map: &NoteMap) -> PianoRoll {
    let mut frames = vec![[false; 16]; frame_of(perf.notes_end_s + ROLL_TAIL_S) + 1];
    for e in &perf.events {
        if let DrumEventKind::NoteOn { note, .. } = e.kind {
            let col = map.entry(note).and_then(|m| column(m.roll));
            if let (Some(col), Some(row)) = (col, frames.get_mut(frame_of(e.time_s))) {
                row[col] = true;
            }
        }
    }
    PianoRoll { frames }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::midi::DrumEvent;

    fn perf(events: &[(f64, DrumEventKind)], duration_s: f64) -> Performance {
        let events = events.iter().map(|&(time_s, kind)| DrumEvent { time_s, tick: 0, kind }).collect();
        Performance { path: "t.mid".into(), events, duration_s, notes_end_s: duration_s, channel: 10 }
    }

    #[test]
    fn columns_follow_note_nums() {
        for (i, n) in NOTE_NUMS.iter().enumerate() {
            assert_eq!(column(*n), Some(i));
        }
        assert_eq!(column(40), None);
        assert_eq!(column(22), None);
    }

    #[test]
    fn onsets_land_in_rounded_frames_of_their_roll_notes() {
        let on = |note| DrumEventKind::NoteOn { note, velocity: 100 };
        let td = NoteMap::builtin("roland-td").unwrap();
        let p = perf(
            &[
                (0.0, on(36)),
                (0.5, on(22)),                              // closed hi-hat edge -> 42
                (0.5 + 0.49 / 60.0, on(40)),                // snare rim -> 38, rounds down to frame 30
                (1.0, DrumEventKind::NoteOff { note: 36 }), // not an onset
                (1.2, on(100)),                             // unknown: skipped
                (1.99, on(59)),                             // frame 119
            ],
            2.0,
        );
        let roll = piano_roll(&p, &td);
        // The last note ends at 2 s; a second of tail.
        assert_eq!(roll.len(), 181);
        let mut cells = Vec::new();
        for (t, frame) in roll.frames.iter().enumerate() {
            cells.extend((0..16).filter(|&c| frame[c]).map(|c| (t, c)));
        }
        let col = |n| column(n).unwrap();
        assert_eq!(cells, [(0, col(36)), (30, col(38)), (30, col(42)), (119, col(59))]);
    }

    #[test]
    fn empty_song_has_only_the_tail() {
        let roll = piano_roll(&perf(&[], 0.0), &NoteMap::builtin("gm").unwrap());
        assert_eq!(roll.len(), 61);
        assert!(roll.frames[0].iter().all(|x| !x));
    }
}
