//! Errors reading MIDI files.

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MidiError {
    #[error("{path}: cannot read: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}: not a usable MIDI file: {message}")]
    Parse { path: PathBuf, message: String },
}
