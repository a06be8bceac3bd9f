//! Building the shipped retrieval library from training material: the corpus teacher's
//! motion of a Groove MIDI split (train: retrieval never sees validation or test songs).
//!
//! Every `stride`-th performance (in info.csv order) gives one clip: its busiest stretch of
//! `clip_frames` frames (most onsets; a performance shorter than that gives all of it).
//! Taking performances evenly through the file keeps every drummer, style and tempo of the
//! split; the busiest stretch keeps grooves and fills rather than count-ins and silence.

use crate::kit::Kit;
use crate::learn::corpus::dataset::{read_info, seed_of};
use crate::learn::corpus::{teach, CorpusError};
use crate::midi::{read_file, NoteMap, ReadOptions};
use crate::motion::upper::library::{mask, Clip, Library, UpperFrame};
use std::path::Path;

/// What went into a library.
#[derive(Debug, Clone, PartialEq)]
pub struct BuildSummary {
    pub clips: usize,
    pub frames: usize,
    /// Files of the split that failed to read or teach, with the reason.
    pub skipped: Vec<(String, String)>,
}

/// Build a library from `split` of the Groove MIDI folder `gmd_dir`.
pub fn build_library(
    gmd_dir: &Path,
    split: &str,
    stride: usize,
    clip_frames: usize,
) -> Result<(Library, BuildSummary), CorpusError> {
    let map = NoteMap::builtin("roland-td").expect("built-in map");
    let kit = Kit::builtin_default();
    let rows: Vec<_> = read_info(gmd_dir)?.into_iter().filter(|r| r.split == split).collect();
    let mut lib = Library::default();
    let mut skipped = Vec::new();
    for row in rows.iter().step_by(stride.max(1)) {
        let perf = match read_file(&row.midi, &ReadOptions { channel: map.channel }) {
            Ok(p) => p,
            Err(e) => {
                skipped.push((row.id.clone(), e.to_string()));
                continue;
            }
        };
        let t = match teach(&perf, &map, &kit, seed_of(&row.id)) {
            Ok(t) => t,
            Err(e) => {
                skipped.push((row.id.clone(), e.to_string()));
                continue;
            }
        };
        let roll: Vec<u16> = t.roll.frames.iter().map(mask).collect();
        let len = clip_frames.min(roll.len());
        if len == 0 {
            continue;
        }
        let start = busiest(&roll, len);
        let frames = t.motion.frames[start..start + len]
            .iter()
            .map(|f| UpperFrame {
                chest: f.chest,
                head: f.head,
                face: std::array::from_fn(|k| f.face.get(k).copied().unwrap_or(0.0)),
            })
            .collect();
        lib.clips.push(Clip { id: row.id.clone(), roll: roll[start..start + len].to_vec(), frames });
    }
    if lib.clips.is_empty() {
        return Err(CorpusError::Empty { path: gmd_dir.join("info.csv"), split: split.into(), skipped: skipped.len() });
    }
    let summary = BuildSummary { clips: lib.clips.len(), frames: lib.frames(), skipped };
    Ok((lib, summary))
}

/// Start of the window of `len` frames with the most onsets (the first of equals).
fn busiest(roll: &[u16], len: usize) -> usize {
    let count = |m: &u16| m.count_ones() as usize;
    let mut sum: usize = roll[..len].iter().map(count).sum();
    let (mut best, mut at) = (sum, 0);
    for s in 1..=roll.len() - len {
        sum = sum + count(&roll[s + len - 1]) - count(&roll[s - 1]);
        if sum > best {
            best = sum;
            at = s;
        }
    }
    at
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_busiest_window_is_found() {
        let mut roll = vec![0u16; 100];
        for r in &mut roll[60..70] {
            *r = 0b11;
        }
        roll[5] = 0b1;
        assert_eq!(busiest(&roll, 10), 60);
        assert_eq!(busiest(&roll, 100), 0);
        assert_eq!(busiest(&[0u16; 5], 3), 0);
    }
}
