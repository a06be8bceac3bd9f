//! MIDI -> drumming motion (the DRUMS half, DESIGN.md 1a): the shared frame types here;
//! the training corpus, hand model, strike planning, upper-body retrieval, feet, rig and
//! exports in their own modules.

pub mod hands;
pub mod track;

pub use track::{Motion, MotionFrame, Pose, ARKIT_NAMES, FPS, HAND_VALUES, STICK_TIP_LOCAL};
