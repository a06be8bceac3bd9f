//! Direct mode: MIDI notes become contact messages without a body.

use super::Message;
use crate::kit::Kit;
use crate::midi::{DrumEvent, NoteMap};

/// Turns drum events into the contact messages a body would send.
pub struct Director {}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DirectError {
    #[error("note map {map:?} sends note {note} to piece {piece:?}, which kit {kit:?} does not have")]
    MissingPiece { map: String, note: u8, piece: String, kit: String },
}

impl Director {
    pub fn new(_kit: &Kit, _map: &NoteMap) -> Result<Director, DirectError> {
        Ok(Director {})
    }

    /// Append the messages one drum event makes (none for note-offs or unknown notes).
    pub fn on_event(&mut self, _ev: &DrumEvent, _out: &mut Vec<Message>) {}
}
