//! Sound: modal membranes and plates excited by a Hertz contact, a limiter, WAV and audio out.
//! This module knows nothing of rapier or MIDI: strikes arrive as contact messages.

pub mod engine;
pub mod event;
pub mod output;

pub use engine::{Engine, EngineSettings};
pub use event::{SoundEvent, SoundEventKind, Strike};
