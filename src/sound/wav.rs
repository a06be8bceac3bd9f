//! WAV output: 48 kHz stereo, 24-bit PCM, streamed to a file. A render writes it under a
//! partial name of its output set ([`crate::outputs::OutputSet`]), so a failed render never
//! leaves a WAV that looks finished.
//!
//! The writer packs each block's samples into one reused byte buffer; the file is byte for
//! byte what hound writes for this spec (WAVE_FORMAT_EXTENSIBLE, 24 bits in 3 bytes), and
//! hound reads it back.

use std::fs::File;
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::Path;

pub struct WavSink {
    file: BufWriter<File>,
    data_bytes: u64,
    bytes: Vec<u8>,
}

const FULL_SCALE_24: f32 = 8_388_607.0;
const CHANNELS: u16 = 2;
const BYTES_PER_SAMPLE: u16 = 3;
/// Offset of the data chunk's length field: the header is 68 bytes.
const DATA_LEN_OFFSET: u64 = 64;
/// KSDATAFORMAT_SUBTYPE_PCM.
const SUBTYPE_PCM: [u8; 16] =
    [0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x10, 0x00, 0x80, 0x00, 0x00, 0xaa, 0x00, 0x38, 0x9b, 0x71];

/// RIFF/WAVE header with a WAVEFORMATEXTENSIBLE fmt chunk (as hound writes it for 24-bit
/// samples) and an empty data chunk; the two lengths are filled in by `finish`.
fn header(sample_rate_hz: u32) -> [u8; 68] {
    let block_align = CHANNELS * BYTES_PER_SAMPLE;
    let mut h = Vec::with_capacity(68);
    h.extend_from_slice(b"RIFF");
    h.extend_from_slice(&0u32.to_le_bytes());
    h.extend_from_slice(b"WAVEfmt ");
    h.extend_from_slice(&40u32.to_le_bytes());
    h.extend_from_slice(&0xfffeu16.to_le_bytes());
    h.extend_from_slice(&CHANNELS.to_le_bytes());
    h.extend_from_slice(&sample_rate_hz.to_le_bytes());
    h.extend_from_slice(&(sample_rate_hz * block_align as u32).to_le_bytes());
    h.extend_from_slice(&block_align.to_le_bytes());
    h.extend_from_slice(&(BYTES_PER_SAMPLE * 8).to_le_bytes());
    h.extend_from_slice(&22u16.to_le_bytes());
    h.extend_from_slice(&24u16.to_le_bytes());
    h.extend_from_slice(&3u32.to_le_bytes());
    h.extend_from_slice(&SUBTYPE_PCM);
    h.extend_from_slice(b"data");
    h.extend_from_slice(&0u32.to_le_bytes());
    h.try_into().expect("the header is 68 bytes")
}

/// A sample in -1..1 as a 24-bit integer, rounded half away from zero: the same value as
/// `(x.clamp(-1.0, 1.0) * FULL_SCALE_24).round() as i32`, NaN giving 0. Adding 2^23 to the
/// magnitude (below 2^23) rounds it to an integer, half to even, in the low mantissa bits;
/// a tie rounded down is then moved up. No branch and no saturating conversion, so the
/// batch loop vectorises.
#[inline(always)]
fn to_i24(x: f32) -> i32 {
    const TWO_23: f32 = 8_388_608.0;
    let v = x.clamp(-1.0, 1.0) * FULL_SCALE_24;
    let a = v.abs();
    let big = a + TWO_23;
    let even = big - TWO_23;
    let magnitude = (big.to_bits() - TWO_23.to_bits()) as i32 + (a - even == 0.5) as i32;
    let signed = if v < 0.0 { -magnitude } else { magnitude };
    if v.is_nan() {
        0
    } else {
        signed
    }
}

impl WavSink {
    /// Create `path` (it is written in place: stage it in an output set).
    pub fn create(path: &Path, sample_rate_hz: u32) -> Result<WavSink, hound::Error> {
        let mut file = BufWriter::new(File::create(path)?);
        file.write_all(&header(sample_rate_hz))?;
        Ok(WavSink { file, data_bytes: 0, bytes: Vec::new() })
    }

    pub fn write(&mut self, left: &[f32], right: &[f32]) -> Result<(), hound::Error> {
        const FRAME: usize = (CHANNELS * BYTES_PER_SAMPLE) as usize;
        const BATCH: usize = 64;
        let n = left.len().min(right.len());
        self.bytes.resize(n * FRAME, 0);
        let frames = self.bytes.chunks_mut(FRAME * BATCH);
        for ((out, l), r) in frames.zip(left.chunks(BATCH)).zip(right.chunks(BATCH)) {
            // Convert a batch in a loop that vectorises, then pack each frame's two 24-bit
            // samples into six bytes.
            let (mut li, mut ri) = ([0i32; BATCH], [0i32; BATCH]);
            for (i, x) in li.iter_mut().zip(l) {
                *i = to_i24(*x);
            }
            for (i, x) in ri.iter_mut().zip(r) {
                *i = to_i24(*x);
            }
            for ((o, l), r) in out.chunks_exact_mut(FRAME).zip(li).zip(ri) {
                let both = (l as u32 & 0xff_ffff) as u64 | ((r as u32 & 0xff_ffff) as u64) << 24;
                o.copy_from_slice(&both.to_le_bytes()[..FRAME]);
            }
        }
        self.data_bytes += self.bytes.len() as u64;
        if self.data_bytes + DATA_LEN_OFFSET > u32::MAX as u64 {
            return Err(hound::Error::FormatError("a WAV file cannot hold more than 4 GiB of samples"));
        }
        self.file.write_all(&self.bytes)?;
        Ok(())
    }

    /// Fill in the lengths and sync the file to disk.
    pub fn finish(mut self) -> Result<(), hound::Error> {
        let data = self.data_bytes as u32;
        self.file.seek(SeekFrom::Start(4))?;
        self.file.write_all(&(data + DATA_LEN_OFFSET as u32 - 4).to_le_bytes())?;
        self.file.seek(SeekFrom::Start(DATA_LEN_OFFSET))?;
        self.file.write_all(&data.to_le_bytes())?;
        let file = self.file.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        Ok(())
    }
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounding_equals_f32_round() {
        let unit = 1.0 / FULL_SCALE_24;
        let mut xs: Vec<f32> = vec![0.0, -0.0, 1.0, -1.0, 2.0, -2.0, f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
        // Every quarter unit near zero and near full scale, where ties sit.
        for k in -400..=400 {
            xs.push(k as f32 * 0.25 * unit);
            xs.push((FULL_SCALE_24 - 100.0 + k as f32 * 0.25) / FULL_SCALE_24);
            xs.push(-(FULL_SCALE_24 - 100.0 + k as f32 * 0.25) / FULL_SCALE_24);
        }
        // And a spread of bit patterns.
        let mut h = 0x2545_F491u32;
        for _ in 0..200_000 {
            h ^= h << 13;
            h ^= h >> 17;
            h ^= h << 5;
            xs.push(f32::from_bits(h));
            xs.push(f32::from_bits(h) * unit);
        }
        for x in xs {
            let want = (x.clamp(-1.0, 1.0) * FULL_SCALE_24).round() as i32;
            assert_eq!(to_i24(x), want, "{x:e}");
        }
    }

    #[test]
    fn files_match_hound_byte_for_byte() {
        let dir = std::env::temp_dir().join(format!("drumsim-wav-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        // Halfway cases, the clamp, zeros of both signs, NaN, and a sweep of ordinary values.
        let half = 0.5 / FULL_SCALE_24;
        let mut left = vec![0.0, -0.0, 1.0, -1.0, 1.5, -7.0, f32::NAN, half, -half, 3.0 * half, -3.0 * half];
        left.extend((0..5000).map(|i| ((i as f32 * 0.37).sin() * 1.1).powi(3)));
        let right: Vec<f32> = left.iter().rev().map(|v| v * 0.7).collect();
        let ours = dir.join("ours.wav");
        let mut sink = WavSink::create(&ours, 48_000).unwrap();
        for (l, r) in left.chunks(777).zip(right.chunks(777)) {
            sink.write(l, r).unwrap();
        }
        sink.finish().unwrap();
        let theirs = dir.join("hound.wav");
        let spec = hound::WavSpec {
            channels: 2,
            sample_rate: 48_000,
            bits_per_sample: 24,
            sample_format: hound::SampleFormat::Int,
        };
        let mut w = hound::WavWriter::create(&theirs, spec).unwrap();
        for (l, r) in left.iter().zip(right.iter()) {
            w.write_sample((l.clamp(-1.0, 1.0) * FULL_SCALE_24).round() as i32).unwrap();
            w.write_sample((r.clamp(-1.0, 1.0) * FULL_SCALE_24).round() as i32).unwrap();
        }
        w.finalize().unwrap();
        let (a, b) = (std::fs::read(&ours).unwrap(), std::fs::read(&theirs).unwrap());
        let _ = std::fs::remove_dir_all(&dir);
        assert_eq!(a.len(), b.len());
        assert!(a == b, "first difference at byte {:?}", a.iter().zip(&b).position(|(x, y)| x != y));
    }
}
