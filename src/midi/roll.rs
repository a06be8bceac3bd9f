//! The DRUMS piano roll: 60 fps, binary, over 16 notes.

/// The 16 notes of the DRUMS piano roll (DESIGN.md 1a).
pub const NOTE_NUMS: [u8; 16] = [36, 37, 38, 42, 43, 44, 45, 46, 47, 48, 49, 50, 51, 55, 58, 59];
/// Frames per second of the roll.
pub const ROLL_FPS: f64 = 60.0;
