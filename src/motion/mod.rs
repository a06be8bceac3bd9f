//! MIDI -> drumming motion (the DRUMS half, DESIGN.md 1a): the shared frame types here;
//! the hand model, strike planning, upper-body retrieval, feet, rig and exports in their own
//! modules. The training corpus and the hand model's training are in [`crate::learn`].

pub mod body_ik;
pub mod export;
pub mod feet;
pub mod hands;
pub mod humanoid;
pub mod kit_clear;
pub mod notes;
pub mod pipeline;
pub mod plan;
pub mod proxies;
pub mod rig;
pub mod shells;
pub mod stick_clear;
pub mod track;
pub mod upper;
pub mod window;

pub use track::{Motion, MotionFrame, Pose, ARKIT_NAMES, FPS, HAND_VALUES, STICK_TIP_LOCAL};
