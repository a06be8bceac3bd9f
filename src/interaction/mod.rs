//! The one interface between body and sound: contact messages as OSC (DESIGN.md section 6),
//! and the direct mode that makes them from MIDI notes.

pub mod direct;
pub mod message;
pub mod play_to;
pub mod remote;
pub mod transport;

pub use message::{decode, decode_timed, encode, encode_bundle, ContactMessage, Limb, Message, MessageError};
