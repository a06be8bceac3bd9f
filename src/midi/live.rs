//! Live MIDI input (midir).
