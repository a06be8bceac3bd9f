//! Offline pipeline: MIDI file -> contact messages -> sound engine -> WAV and contacts JSON.

use std::path::{Path, PathBuf};

/// Options of `drumsim render`.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub out_dir: PathBuf,
    pub kit: Option<PathBuf>,
    pub map: String,
    pub channel: Option<u8>,
    pub skip_unknown: bool,
    pub progress: bool,
}

/// Bad input found while rendering (exit code 2).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderInputError {
    #[error("{0}")]
    Unsupported(String),
}

pub fn render_file(_song: &Path, _opts: &RenderOptions) -> anyhow::Result<String> {
    anyhow::bail!("not implemented yet")
}
