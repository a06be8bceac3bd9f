//! WAV output: 48 kHz stereo, 24-bit PCM, written to a `.partial` file and renamed into place
//! only when complete, so a failed render never leaves a WAV that looks finished.

use std::path::{Path, PathBuf};

pub struct WavSink {
    writer: hound::WavWriter<std::io::BufWriter<std::fs::File>>,
    partial: PathBuf,
    path: PathBuf,
}

const FULL_SCALE_24: f32 = 8_388_607.0;

impl WavSink {
    pub fn create(path: &Path, sample_rate_hz: u32) -> Result<WavSink, hound::Error> {
        let partial = partial_path(path);
        let spec = hound::WavSpec {
            channels: 2,
            sample_rate: sample_rate_hz,
            bits_per_sample: 24,
            sample_format: hound::SampleFormat::Int,
        };
        let writer = hound::WavWriter::create(&partial, spec)?;
        Ok(WavSink { writer, partial, path: path.to_path_buf() })
    }

    pub fn write(&mut self, left: &[f32], right: &[f32]) -> Result<(), hound::Error> {
        for (l, r) in left.iter().zip(right.iter()) {
            self.writer.write_sample((l.clamp(-1.0, 1.0) * FULL_SCALE_24).round() as i32)?;
            self.writer.write_sample((r.clamp(-1.0, 1.0) * FULL_SCALE_24).round() as i32)?;
        }
        Ok(())
    }

    /// Finish the file and move it into place.
    pub fn finish(self) -> Result<PathBuf, hound::Error> {
        self.writer.finalize()?;
        std::fs::rename(&self.partial, &self.path)?;
        Ok(self.path)
    }

    /// Give up: remove the partial file.
    pub fn abandon(self) {
        drop(self.writer);
        let _ = std::fs::remove_file(&self.partial);
    }
}

/// `dir/name.ext` -> `dir/.name.ext.partial`.
pub fn partial_path(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.partial"))
}

/// Write a whole file atomically (partial file, then rename).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let partial = partial_path(path);
    std::fs::write(&partial, bytes)?;
    std::fs::rename(&partial, path)
}

/// Read a WAV written by [`WavSink`] back as (left, right) in -1..1.
pub fn read_stereo(path: &Path) -> Result<(Vec<f32>, Vec<f32>, u32), hound::Error> {
    let mut reader = hound::WavReader::open(path)?;
    let spec = reader.spec();
    let scale = match (spec.sample_format, spec.bits_per_sample) {
        (hound::SampleFormat::Int, bits) => 1.0 / ((1i64 << (bits - 1)) - 1) as f32,
        (hound::SampleFormat::Float, _) => 1.0,
    };
    let samples: Vec<f32> = match spec.sample_format {
        hound::SampleFormat::Int => {
            reader.samples::<i32>().map(|s| s.map(|v| v as f32 * scale)).collect::<Result<_, _>>()?
        }
        hound::SampleFormat::Float => reader.samples::<f32>().collect::<Result<_, _>>()?,
    };
    let ch = spec.channels as usize;
    let left = samples.iter().step_by(ch).copied().collect();
    let right = samples.iter().skip(ch.min(2) - 1).step_by(ch).copied().collect();
    Ok((left, right, spec.sample_rate))
}
