//! drumsim: drum MIDI in, a physically simulated drummer and modal synthesis out.
//!
//! Data flows one way: MIDI -> (motion -> physics) -> contact messages -> sound.
//! The sound engine and the body meet only through the contact message of
//! [`interaction::message`]. See ARCHITECTURE.md for the map of the crate.

pub mod audition;
pub mod avatar;
pub mod body;
pub mod check;
pub mod eval;
pub mod files;
pub mod interaction;
pub mod kit;
pub mod learn;
pub mod live;
pub mod live_body;
pub mod midi;
pub mod motion;
pub mod outputs;
pub mod perform;
pub mod render;
pub mod rng;
pub mod rt_alloc;
pub mod rt_priority;
pub mod sound;
pub mod sound_server;
pub mod view;
pub mod vmc;
