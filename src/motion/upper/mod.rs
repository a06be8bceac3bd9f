//! Upper body and face by MIDI matching (the DRUMS retrieval, DESIGN.md 1a).
//!
//! The query roll is cut into windows of 240 frames. For each, the library window C with
//! the lowest cost `w_miss*M + w_sil*S + w_extra*E` is found, where M counts the query's
//! onsets (frame, note) that C lacks, S the frames silent in the query but not in C, and E
//! the onsets of C the query lacks. An onset matches one in the same roll column up to one
//! frame away (a 60 fps roll quantises the same groove either side of a frame boundary).
//! The search starts strict (missing notes and filled silences weigh most) and accepts a
//! window only under a threshold that scales with the query's notes; if none is under it,
//! the weights relax; if still none, the window is split in halves (down to 60 frames) and
//! each half searched again. The best window found is kept in any case, so every frame gets
//! a pose. The matched window's chest and head poses and 52 face weights are copied, and
//! consecutive windows are cross-faded over a few frames at their seam.
//!
//! The retrieved chest and head are then turned toward where the hands play on this kit
//! (`turn.rs`), and the face blinks at a human rate where the retrieved one stares
//! (`blinks.rs`).
//!
//! The library holds only training material (`library.rs`): windows of the teacher's
//! motion of the Groove MIDI train split, or of loaded mocap, built by
//! [`crate::learn::upper_library`].

pub mod blinks;
pub mod library;
pub mod matching;
pub mod turn;

pub use library::{Clip, Library, LibraryError, UpperFrame};
pub use matching::{retrieve, retrieve_indexed, MatchIndex, MatchReport, MatchSettings};
