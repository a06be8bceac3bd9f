//! The performer: the planned motion played by the simulated body (DESIGN.md section 2's
//! `MIDI -> motion targets -> physics -> contact events -> sound`).
//!
//! - `targets.rs`: the body's 250 Hz stick-tip targets from the planned hands (the bead's
//!   radius, a press into the surface at the onset, a keep-out under cymbals).
//! - `conductor.rs`: one task period of Algorithm 2 (40 physics steps toward interpolated
//!   targets); the step function the offline render and the live body (`paced.rs`) share.
//! - `feet.rs`: the pedals' targets (the kick beater's swing to each kick note, the hi-hat
//!   following the left foot); the pedal bodies themselves are in `body/pedals.rs`.
//! - `paced.rs`: the live body: the conductor's periods on the wall clock, plans from the
//!   sliding-window motion stage swapped in between periods, contacts out as plain values.
//! - `offline.rs`: a whole song, its contacts as contact messages, the simulated tips.
//! - `rehearsal.rs`: the offline correction: each note's contact judged, a stroke that fell
//!   off its note played again from a snapshot with corrected targets.
//! - `lag.rs`: the live body's lag model (how late a stroke lands, by piece, velocity and
//!   the time since the hand's previous note), learned offline, aimed against live.
//! - `matching.rs`: which note each contact played (bookkeeping for files and reports; the
//!   sound never reads it).

pub mod conductor;
pub mod feet;
pub mod lag;
pub mod matching;
pub mod offline;
pub mod paced;
pub mod rehearsal;
pub mod replay;
pub mod targets;

pub use conductor::{Conductor, PREROLL_S, STEPS_PER_PERIOD};
pub use offline::{play, play_with, PhysicalTake};
pub use rehearsal::RehearsalSettings;
