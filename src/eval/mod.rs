//! Measures shared by tests, benches and reports (DESIGN.md section 5).

pub mod audio;
pub mod beat;
pub mod dtw;
pub mod motion;
pub mod motion_quality;
pub mod note_sound;
pub mod onsets;
pub mod report;
pub mod savgol;
pub mod strike;
pub mod timbre;
