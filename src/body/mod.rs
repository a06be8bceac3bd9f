//! The drummer's body. So far: anthropometry (segment masses, lengths and inertias).

pub mod anthropometry;
