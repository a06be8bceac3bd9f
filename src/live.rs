//! Real-time pipeline: live MIDI in -> contact messages -> sound engine -> audio out.

use std::path::PathBuf;

/// Options of `drumsim live`.
#[derive(Debug, Clone)]
pub struct LiveOptions {
    /// MIDI input port name (or a unique part of it); None: the first port.
    pub midi_port: Option<String>,
    /// Audio output device name (or part of it); None: the host's default.
    pub audio_device: Option<String>,
    /// Delay every event by this much so timing is jitter-free (0: as soon as possible).
    pub lookahead_ms: f32,
    /// Kit config file; None: the built-in default kit.
    pub kit: Option<PathBuf>,
    /// Note map name or file.
    pub map: String,
    /// Drum channel 1..=16; None: the map's channel.
    pub channel: Option<u8>,
    /// Stop after this many seconds (None: until Ctrl-C or end of input).
    pub duration_s: Option<f64>,
}

/// Run the live pipeline.
pub fn run(_opts: &LiveOptions) -> anyhow::Result<()> {
    anyhow::bail!("live mode is not implemented yet")
}

/// Print usable MIDI inputs and audio outputs.
pub fn list_devices() -> anyhow::Result<()> {
    anyhow::bail!("devices is not implemented yet")
}
