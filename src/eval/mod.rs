//! Measures shared by tests, benches and reports (DESIGN.md section 5).

pub mod audio;
