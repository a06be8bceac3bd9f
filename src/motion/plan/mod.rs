//! Strike planning: which hand plays each hand note, and the correction that makes that
//! hand's stick tip meet the note's strike point on the configured kit at the note's time.
//!
//! The hand model predicts where the hands are; it knows neither the kit the user
//! configured nor where a surface is. Planning takes its predicted tips as the drummer's
//! intention and:
//! 1. assigns every note to a hand (`assign.rs`): the hand whose predicted tip is nearest the
//!    strike point, under a drummer's constraints (two notes at once go to two hands, a
//!    hand needs time to travel between pieces, hands do not cross over), by dynamic
//!    programming over the notes in time order;
//! 2. corrects each hand's trajectory (`stroke.rs`): a smooth offset that moves the
//!    predicted tip onto each of its notes' strike points, and along the surface's normal a
//!    stroke: down at the speed the note's velocity asks, on the surface from half a frame
//!    before to half a frame after the onset (so the 60 fps frame nearest the onset has the
//!    tip on the surface), then the rebound.
//!
//! The stroke is made with the wrist: the grip follows the predicted hand moved by the
//! smooth offset alone, and the stick turns about it until the tip is where the stroke
//! puts it (on the strike point at the hit). So the hand keeps the model's timing rather
//! than stopping with the tip at every contact. The predicted poses are first smoothed
//! (`smooth.rs`), so that a hand never jumps across the kit between two frames. Positions come from the kit, so another
//! layout moves every strike.

pub mod assign;
pub mod smooth;
pub mod stroke;

pub use assign::{assign_hands, assign_hands_kept, AssignSettings, Assignment};
pub use stroke::{plan_hands, PlannedHands, StrokeSettings};

/// A note a stick plays, placed on the kit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HandNote {
    pub time_s: f64,
    /// Kit piece index (notes on the same piece need no travel).
    pub piece: usize,
    /// Strike point and the surface's unit outward normal (kit frame).
    pub point: [f32; 3],
    pub normal: [f32; 3],
    /// MIDI velocity, 1..=127.
    pub velocity: u8,
    /// The tip's speed into the surface at the hit, m/s.
    pub speed_mps: f32,
}
