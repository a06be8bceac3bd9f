//! Note maps: which kit piece and zone each MIDI note strikes, and its DRUMS piano-roll note.
//! Built-in maps live in config/maps/*.toml and are compiled in; users may pass their own file.

use serde::Deserialize;
use std::path::PathBuf;

/// Where on a piece a note strikes. The kit config gives each zone its radius.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Zone {
    /// Ordinary stroke on a drum head (a little off centre).
    Head,
    /// Dead centre of a head.
    Center,
    /// Rim shot: head near the edge and the hoop at once.
    Rim,
    /// Cross-stick: the stick lies on the head and clicks the hoop.
    CrossStick,
    /// Cymbal bow (between bell and edge).
    Bow,
    /// Cymbal edge (shoulder of the stick on the rim).
    Edge,
    /// Cymbal bell.
    Bell,
    /// A foot: kick beater or hi-hat pedal closing the two cymbals.
    Pedal,
}

/// What one note means.
#[derive(Debug, Clone, PartialEq)]
pub struct MapEntry {
    /// Kit piece id ("snare", "tom1", "hihat", ...), checked against the kit when rendering.
    pub piece: String,
    pub zone: Zone,
    /// The note of DRUMS' 16-note piano roll this note becomes (one of [`crate::midi::roll::NOTE_NUMS`]).
    pub roll: u8,
    /// For hi-hat notes when the file has no CC4: the openness (0 closed .. 1 open) the note implies.
    pub hihat_openness: Option<f32>,
}

/// A validated note map.
#[derive(Debug, Clone)]
pub struct NoteMap {
    pub name: String,
    /// Drum channel, 1..=16 (10 for General MIDI).
    pub channel: u8,
    /// Indexed by MIDI note number.
    pub notes: Vec<Option<MapEntry>>,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MapError {
    #[error("note map {path}: {message}")]
    Invalid { path: PathBuf, message: String },
    #[error("note map {name:?} is neither a built-in map ({builtins}) nor a readable file: {source}")]
    NotFound { name: String, builtins: String, source: std::io::Error },
}
