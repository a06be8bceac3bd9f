//! The drummer's body: anthropometry, the upper-body skeleton and its forward kinematics,
//! damped-least-squares IK.

pub mod anthropometry;
pub mod ik;
pub mod skeleton;
