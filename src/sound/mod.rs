//! Sound: modal membranes and plates excited by a Hertz contact, a limiter, WAV and audio out.
//! This module knows nothing of rapier or MIDI: strikes arrive as contact messages.

pub mod audio_clock;
pub mod bank;
pub mod bessel;
pub mod contact;
pub mod denormals;
pub mod device;
pub mod engine;
pub mod event;
pub mod lanes;
pub mod limiter;
pub mod modes;
pub mod net_feed;
pub mod offline;
pub mod output;
pub mod stress;
pub mod voice;
pub mod wav;
pub mod wires;

pub use engine::{Engine, EngineSettings};
pub use event::{SoundEvent, SoundEventKind, Strike};
