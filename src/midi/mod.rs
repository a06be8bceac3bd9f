//! MIDI in: standard MIDI files (midly), note maps, the 60 fps piano roll, live input (midir for ALSA, the jack crate for JACK).

pub mod error;
pub mod file;
pub mod live;
pub mod map;
pub mod roll;

pub use error::MidiError;
pub use file::{read_file, Performance, ReadOptions};
pub use map::{MapEntry, MapError, NoteMap, Zone};

/// One drum-channel event, at its performance time (tempo map applied).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DrumEvent {
    /// Seconds from the start of the song.
    pub time_s: f64,
    /// Absolute tick in the file (for error messages that name a place).
    pub tick: u64,
    pub kind: DrumEventKind,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DrumEventKind {
    /// A note-on with velocity 1..=127 (note-on with velocity 0 is a [`DrumEventKind::NoteOff`]).
    NoteOn {
        note: u8,
        velocity: u8,
    },
    NoteOff {
        note: u8,
    },
    /// CC4, hi-hat pedal position: 0 open .. 127 closed.
    HiHatPedal {
        value: u8,
    },
    /// Polyphonic aftertouch: a cymbal choke when pressure > 0.
    Aftertouch {
        note: u8,
        pressure: u8,
    },
}
