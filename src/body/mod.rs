//! The drummer's body: anthropometry, the upper-body skeleton, the rapier model, PD joints,
//! joint limits, DLS IK, contacts, and the 10 kHz HIMC loop.

// Links, joints and sides are parallel fixed-size arrays indexed together; index loops read
// better than zipped iterators here.
#![allow(clippy::needless_range_loop)]

pub mod anthropometry;
pub mod contacts;
pub mod ik;
pub mod legs;
pub mod limits;
pub mod limits_data;
pub mod model;
pub mod pd;
pub mod pedals;
pub mod report;
pub mod sim;
pub mod skeleton;
pub mod strokes;
pub mod trials;
