//! The drummer's body: anthropometry, the upper-body skeleton, the rapier model, PD joints,
//! joint limits, DLS IK, contacts, and the 10 kHz HIMC loop.

pub mod anthropometry;
pub mod contacts;
pub mod ik;
pub mod limits;
pub mod model;
pub mod pd;
pub mod sim;
pub mod skeleton;
pub mod strokes;
pub mod trials;
