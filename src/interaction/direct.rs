//! Direct mode: MIDI notes become contact messages without a body.
