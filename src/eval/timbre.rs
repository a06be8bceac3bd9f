//! How one drum hit sounds, as numbers a drummer's ear agrees with: the measures of the
//! "kit that sounds like a drum kit" table, computed the same way on drumsim's hits and on
//! recorded kits (`drumsim audition`, `examples/recorded_kits.rs`).
//!
//! A hit is a stereo signal that starts a little before the sound. Its onset is the first
//! sample within 40 dB of the loudest; every window below is measured from there. Energies
//! add the two channels, so a piece's place in the stereo image does not change them, and
//! spectra are of the sum of the channels (Hann window, zero-padded to a power of two).

use super::audio::{fft, magnitude_spectrum, spectral_centroid};
use serde::{Deserialize, Serialize};

/// The onset: the first sample within this much of the hit's peak, dB.
const ONSET_BELOW_PEAK_DB: f64 = 40.0;

/// The measures of one hit. Those a hit is too short for are `None` (a closed hi-hat has
/// no tail at 0.5-1 s; a hit shorter than 350 ms has no pitch at its end).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
pub struct HitMeasures {
    /// Level: RMS of the first 100 ms, dBFS (both channels' power, as a sine of that RMS).
    pub level_db: f64,
    /// Spectral centroid of the first 50 ms, Hz (magnitude-weighted).
    pub centroid_50ms_hz: f64,
    /// Energy above 2 kHz re all of it, first 50 ms, dB (a tom's attack).
    pub above_2k_50ms_db: f64,
    /// Energy above 2 kHz re energy below 1 kHz, first 100 ms, dB (a snare's wires re body).
    pub hi_lo_100ms_db: f64,
    /// Energy of the first 5 ms re the first 50 ms, dB (a kick's beater click).
    pub first_5ms_db: f64,
    /// From the onset to the loudest millisecond (1 ms RMS), ms.
    pub onset_to_peak_ms: f64,
    /// From the loudest 5 ms until the 5 ms RMS first falls 20 dB below it, ms.
    pub decay_20db_ms: Option<f64>,
    /// Energy above 4 kHz re all of it, 0.5-1 s after the onset, dB (a cymbal's wash).
    pub tail_above_4k_db: Option<f64>,
    /// Spectral flatness (geometric over arithmetic mean of the power) of 0.5-1 s after the
    /// onset, 300 Hz-16 kHz, power averaged over 4096-sample frames: near 0 for a few clean
    /// partials (a gong), higher for a dense wash.
    pub tail_flatness: Option<f64>,
    /// Level of 0.5-1 s after the onset re the first 100 ms, dB (how much tail there is).
    pub tail_level_db: Option<f64>,
    /// The hit's pitch at its start (0-85 ms) and at 265-350 ms: the lowest strong peak
    /// (within 12 dB of the strongest) between 40 Hz and 1 kHz, Hz. No end pitch when the
    /// hit has fallen 40 dB by then.
    pub pitch_start_hz: f64,
    pub pitch_end_hz: Option<f64>,
}

impl HitMeasures {
    /// Relative pitch change over the first 350 ms (-0.2: fell by 20 %).
    pub fn pitch_change(&self) -> Option<f64> {
        self.pitch_end_hz.map(|end| end / self.pitch_start_hz - 1.0)
    }
}

/// Measure one hit. `left` and `right` are the same length; `None` for a silent signal.
pub fn measure_hit(left: &[f32], right: &[f32], sample_rate_hz: f64) -> Option<HitMeasures> {
    let n = left.len().min(right.len());
    let power: Vec<f64> = (0..n).map(|i| (left[i] as f64).powi(2) + (right[i] as f64).powi(2)).collect();
    let mono: Vec<f32> = (0..n).map(|i| left[i] + right[i]).collect();
    let peak = power.iter().cloned().fold(0.0, f64::max);
    if peak.is_nan() || peak <= 1e-18 {
        return None;
    }
    let threshold = peak * 10f64.powf(-ONSET_BELOW_PEAK_DB / 10.0);
    let onset = power.iter().position(|p| *p >= threshold)?;
    let at = |s: f64| (onset + (s * sample_rate_hz).round() as usize).min(n);
    let energy = |a: f64, b: f64| power[at(a)..at(b)].iter().sum::<f64>();
    let db = |x: f64| 10.0 * x.max(1e-30).log10();
    let level = energy(0.0, 0.1) / (at(0.1) - at(0.0)).max(1) as f64 / 2.0;
    let bands_50 = bands(&mono[at(0.0)..at(0.05)], sample_rate_hz);
    let bands_100 = bands(&mono[at(0.0)..at(0.1)], sample_rate_hz);
    let env_1ms = envelope(&power[onset..], (0.001 * sample_rate_hz) as usize);
    let (peak_i, _) = env_1ms.iter().enumerate().fold((0, f64::MIN), |m, (i, v)| if *v > m.1 { (i, *v) } else { m });
    let env_5ms = envelope(&power[onset..], (0.005 * sample_rate_hz) as usize);
    let (peak5_i, peak5_db) =
        env_5ms.iter().enumerate().fold((0, f64::MIN), |m, (i, v)| if *v > m.1 { (i, *v) } else { m });
    let decay = env_5ms[peak5_i..].iter().position(|v| *v < peak5_db - 20.0).map(|i| i as f64 / sample_rate_hz * 1e3);
    // A tail to measure: long enough, and above -60 dB re the attack (a closed hi-hat has
    // none).
    let tail_level = energy(0.5, 1.0) / energy(0.0, 0.1) * 0.1 / 0.5;
    let has_tail = at(1.0) - at(0.5) >= (0.45 * sample_rate_hz) as usize && tail_level > 1e-6;
    let tail = &mono[at(0.5)..at(1.0)];
    let tail_bands = has_tail.then(|| bands(tail, sample_rate_hz));
    let has_end =
        at(0.35) - at(0.265) >= (0.08 * sample_rate_hz) as usize && energy(0.265, 0.35) / energy(0.0, 0.085) > 1e-4;
    Some(HitMeasures {
        level_db: db(level),
        centroid_50ms_hz: spectral_centroid(&mono[at(0.0)..at(0.05)], sample_rate_hz),
        above_2k_50ms_db: db(bands_50.above(2000.0) / bands_50.total()),
        hi_lo_100ms_db: db(bands_100.above(2000.0) / bands_100.below(1000.0)),
        first_5ms_db: db(energy(0.0, 0.005) / energy(0.0, 0.05)),
        onset_to_peak_ms: peak_i as f64 / sample_rate_hz * 1e3,
        decay_20db_ms: decay,
        tail_above_4k_db: tail_bands.as_ref().map(|b| db(b.above(4000.0) / b.total())),
        tail_flatness: has_tail.then(|| flatness(tail, sample_rate_hz, 300.0, 16_000.0)),
        tail_level_db: (at(1.0) - at(0.5) >= (0.45 * sample_rate_hz) as usize).then(|| db(tail_level)),
        pitch_start_hz: pitch(&mono[at(0.0)..at(0.085)], sample_rate_hz),
        pitch_end_hz: has_end.then(|| pitch(&mono[at(0.265)..at(0.35)], sample_rate_hz)).filter(|p| *p > 0.0),
    })
}

/// A power spectrum with its bin width, for band energies.
struct Bands {
    power: Vec<f64>,
    hz_per_bin: f64,
}

impl Bands {
    fn total(&self) -> f64 {
        self.power.iter().sum::<f64>().max(1e-30)
    }
    fn above(&self, hz: f64) -> f64 {
        let from = (hz / self.hz_per_bin).ceil() as usize;
        self.power.iter().skip(from).sum::<f64>().max(1e-30)
    }
    fn below(&self, hz: f64) -> f64 {
        let to = (hz / self.hz_per_bin).floor() as usize;
        self.power.iter().take(to).sum::<f64>().max(1e-30)
    }
}

/// Power spectrum of a whole window (Hann).
fn bands(x: &[f32], sample_rate_hz: f64) -> Bands {
    let n = x.len().max(2).next_power_of_two();
    let power = magnitude_spectrum(x, n).iter().map(|m| m * m).collect();
    Bands { power, hz_per_bin: sample_rate_hz / n as f64 }
}

/// Running level in dB of `power` over `window` samples, one value per sample (the window
/// starting there).
fn envelope(power: &[f64], window: usize) -> Vec<f64> {
    let window = window.max(1);
    let mut out = Vec::with_capacity(power.len().saturating_sub(window) + 1);
    let mut sum: f64 = power[..window.min(power.len())].iter().sum();
    for i in 0..=power.len().saturating_sub(window) {
        out.push(10.0 * (sum / window as f64).max(1e-30).log10());
        if i + window < power.len() {
            sum += power[i + window] - power[i];
        }
    }
    out
}

/// Spectral flatness of `x` between `lo` and `hi` Hz, power averaged over 4096-sample frames
/// hopped by half.
fn flatness(x: &[f32], sample_rate_hz: f64, lo: f64, hi: f64) -> f64 {
    const FRAME: usize = 4096;
    let mut acc = vec![0.0; FRAME / 2];
    let mut frames = 0;
    let mut start = 0;
    while start + FRAME <= x.len() {
        for (a, m) in acc.iter_mut().zip(magnitude_spectrum(&x[start..start + FRAME], FRAME)) {
            *a += m * m;
        }
        frames += 1;
        start += FRAME / 2;
    }
    if frames == 0 {
        return 0.0;
    }
    let hz = sample_rate_hz / FRAME as f64;
    let band: Vec<f64> = acc[(lo / hz).ceil() as usize..((hi / hz) as usize).min(acc.len())].to_vec();
    let mean = band.iter().sum::<f64>() / band.len() as f64;
    let log_mean = band.iter().map(|p| p.max(1e-30).ln()).sum::<f64>() / band.len() as f64;
    log_mean.exp() / mean.max(1e-30)
}

/// The lowest strong spectral peak between 40 Hz and 1 kHz (within 12 dB of the strongest
/// there), Hz, from a spectrum zero-padded to 2^15 points (1.5 Hz bins at 48 kHz) and
/// parabolic interpolation.
fn pitch(x: &[f32], sample_rate_hz: f64) -> f64 {
    const N: usize = 1 << 15;
    let spectrum = magnitude_spectrum(x, N);
    let hz = sample_rate_hz / N as f64;
    let (lo, hi) = ((40.0 / hz) as usize, (1000.0 / hz) as usize);
    let strongest = spectrum[lo..hi].iter().cloned().fold(0.0, f64::max);
    let floor = strongest * 10f64.powf(-12.0 / 20.0);
    for k in lo.max(1)..hi {
        let (a, b, c) = (spectrum[k - 1], spectrum[k], spectrum[k + 1]);
        if b >= floor && b > a && b >= c {
            let (la, lb, lc) = (a.max(1e-30).ln(), b.ln(), c.max(1e-30).ln());
            let offset = 0.5 * (la - lc) / (la - 2.0 * lb + lc);
            return (k as f64 + offset) * hz;
        }
    }
    0.0
}

/// Pairwise spectral distance of two hits: RMS difference of their log power spectra over
/// the first 100 ms from each onset, in 1/3-octave bands from 100 Hz to 16 kHz, dB, after
/// removing the level difference (so it compares timbre, not loudness).
pub fn spectral_distance_db(a: (&[f32], &[f32]), b: (&[f32], &[f32]), sample_rate_hz: f64) -> f64 {
    let third_octaves = |l: &[f32], r: &[f32]| -> Vec<f64> {
        let mono: Vec<f32> = l.iter().zip(r).map(|(x, y)| x + y).collect();
        let onset = onset_of(&mono);
        let end = (onset + (0.1 * sample_rate_hz) as usize).min(mono.len());
        let n = 8192;
        let mut re: Vec<f64> = vec![0.0; n];
        let mut im = vec![0.0; n];
        for (i, v) in mono[onset..end].iter().enumerate().take(n) {
            re[i] = *v as f64;
        }
        fft(&mut re, &mut im);
        let hz = sample_rate_hz / n as f64;
        let mut out = Vec::new();
        let mut f = 100.0f64;
        while f < 16_000.0 {
            let (a, b) = ((f / hz) as usize, ((f * 2f64.powf(1.0 / 3.0)) / hz) as usize);
            let e: f64 = (a..b.max(a + 1)).map(|k| re[k] * re[k] + im[k] * im[k]).sum();
            out.push(10.0 * e.max(1e-30).log10());
            f *= 2f64.powf(1.0 / 3.0);
        }
        out
    };
    let (x, y) = (third_octaves(a.0, a.1), third_octaves(b.0, b.1));
    let d: Vec<f64> = x.iter().zip(&y).map(|(p, q)| p - q).collect();
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    (d.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / d.len() as f64).sqrt()
}

fn onset_of(x: &[f32]) -> usize {
    let peak = x.iter().fold(0.0f32, |m, v| m.max(v.abs())) as f64;
    let threshold = peak * 10f64.powf(-ONSET_BELOW_PEAK_DB / 20.0);
    x.iter().position(|v| (v.abs() as f64) >= threshold).unwrap_or(0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    const FS: f64 = 48_000.0;

    fn decaying_sine(hz: f64, t60_s: f64, len_s: f64) -> Vec<f32> {
        let n = (len_s * FS) as usize;
        (0..n)
            .map(|i| {
                let t = i as f64 / FS;
                ((2.0 * PI * hz * t).sin() * (-6.9 * t / t60_s).exp() * 0.5) as f32
            })
            .collect()
    }

    #[test]
    fn a_decaying_sine_measures_as_itself() {
        let mut x = vec![0.0f32; 480];
        x.extend(decaying_sine(200.0, 0.6, 1.2));
        let m = measure_hit(&x, &x, FS).unwrap();
        assert!((m.pitch_start_hz - 200.0).abs() < 2.0, "{m:?}");
        assert!(m.pitch_change().unwrap().abs() < 0.01, "{m:?}");
        // 20 dB of a 60 dB-in-0.6 s decay: 0.2 s.
        assert!((m.decay_20db_ms.unwrap() - 200.0).abs() < 10.0, "{m:?}");
        assert!(m.above_2k_50ms_db < -40.0 && m.hi_lo_100ms_db < -40.0, "{m:?}");
        assert!(m.tail_flatness.unwrap() < 0.01, "{m:?}");
        assert!(m.onset_to_peak_ms < 3.0, "{m:?}");
    }

    #[test]
    fn noise_is_flat_and_bright() {
        let mut rng = 1u32;
        let x: Vec<f32> = (0..60_000)
            .map(|i| {
                rng ^= rng << 13;
                rng ^= rng >> 17;
                rng ^= rng << 5;
                ((rng as f64 / u32::MAX as f64 - 0.5) * (-(i as f64) / 40_000.0).exp()) as f32
            })
            .collect();
        let m = measure_hit(&x, &x, FS).unwrap();
        assert!(m.tail_flatness.unwrap() > 0.8, "{m:?}");
        assert!(m.centroid_50ms_hz > 9000.0, "{m:?}");
        assert!(m.tail_above_4k_db.unwrap() > -2.0, "{m:?}");
    }

    #[test]
    fn a_falling_pitch_is_measured() {
        // 160 Hz falling to 128 Hz (-20 %) over 350 ms.
        let n = (0.6 * FS) as usize;
        let mut phase = 0.0;
        let x: Vec<f32> = (0..n)
            .map(|i| {
                let t = i as f64 / FS;
                let f = 128.0 + 32.0 * (-t / 0.12).exp();
                phase += 2.0 * PI * f / FS;
                (phase.sin() * (-t / 0.5).exp()) as f32
            })
            .collect();
        let m = measure_hit(&x, &x, FS).unwrap();
        let change = m.pitch_change().unwrap();
        assert!((-0.25..-0.1).contains(&change), "{m:?}");
    }
}
