//! Audio measures: spectrum and its peaks, spectral centroid, level and decay rate.

use std::f64::consts::PI;

/// In-place radix-2 complex FFT; `re.len()` must be a power of two.
pub fn fft(re: &mut [f64], im: &mut [f64]) {
    let n = re.len();
    assert!(n.is_power_of_two() && im.len() == n, "fft needs two equal power-of-two buffers");
    let mut j = 0;
    for i in 1..n {
        let mut bit = n >> 1;
        while j & bit != 0 {
            j ^= bit;
            bit >>= 1;
        }
        j |= bit;
        if i < j {
            re.swap(i, j);
            im.swap(i, j);
        }
    }
    let mut len = 2;
    while len <= n {
        let (ws, wc) = (-2.0 * PI / len as f64).sin_cos();
        for start in (0..n).step_by(len) {
            let (mut cr, mut ci) = (1.0, 0.0);
            for k in 0..len / 2 {
                let (a, b) = (start + k, start + k + len / 2);
                let (tr, ti) = (re[b] * cr - im[b] * ci, re[b] * ci + im[b] * cr);
                re[b] = re[a] - tr;
                im[b] = im[a] - ti;
                re[a] += tr;
                im[a] += ti;
                (cr, ci) = (cr * wc - ci * ws, cr * ws + ci * wc);
            }
        }
        len <<= 1;
    }
}

/// Magnitude spectrum (bins 0..n/2) of the first `n` samples (zero-padded), Hann-windowed.
pub fn magnitude_spectrum(x: &[f32], n: usize) -> Vec<f64> {
    let mut re = vec![0.0; n];
    let mut im = vec![0.0; n];
    let len = x.len().min(n);
    for i in 0..len {
        let w = 0.5 - 0.5 * (2.0 * PI * i as f64 / len as f64).cos();
        re[i] = x[i] as f64 * w;
    }
    fft(&mut re, &mut im);
    (0..n / 2).map(|k| (re[k] * re[k] + im[k] * im[k]).sqrt()).collect()
}

/// Spectral peaks (Hz, magnitude) above `floor_db` relative to the largest, sorted by frequency,
/// located by parabolic interpolation on the log magnitude.
pub fn spectral_peaks(spectrum: &[f64], sample_rate_hz: f64, floor_db: f64) -> Vec<(f64, f64)> {
    let n = spectrum.len() * 2;
    let max = spectrum.iter().cloned().fold(0.0, f64::max);
    let floor = max * 10f64.powf(floor_db / 20.0);
    let mut peaks = Vec::new();
    for k in 2..spectrum.len() - 1 {
        let (a, b, c) = (spectrum[k - 1], spectrum[k], spectrum[k + 1]);
        if b > floor && b > a && b >= c {
            let (la, lb, lc) = (a.max(1e-30).ln(), b.ln(), c.max(1e-30).ln());
            let offset = 0.5 * (la - lc) / (la - 2.0 * lb + lc);
            peaks.push(((k as f64 + offset) * sample_rate_hz / n as f64, b));
        }
    }
    peaks
}

/// Magnitude-weighted mean frequency of the spectrum, Hz.
pub fn spectral_centroid(x: &[f32], sample_rate_hz: f64) -> f64 {
    let n = x.len().next_power_of_two();
    let s = magnitude_spectrum(x, n);
    let (mut num, mut den) = (0.0, 0.0);
    for (k, m) in s.iter().enumerate() {
        num += k as f64 * sample_rate_hz / n as f64 * m;
        den += m;
    }
    num / den.max(1e-30)
}

pub fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

pub fn peak(x: &[f32]) -> f32 {
    x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

/// Decay rate in dB per second: a least-squares line through the level (dB) of 10 ms frames,
/// over the frames between `from_db` and `to_db` below the loudest frame.
pub fn decay_db_per_s(x: &[f32], sample_rate_hz: f64, from_db: f64, to_db: f64) -> f64 {
    let frame = (0.01 * sample_rate_hz) as usize;
    let levels: Vec<f64> = x.chunks(frame).map(|c| 20.0 * rms(c).max(1e-12).log10()).collect();
    let top = levels.iter().cloned().fold(f64::MIN, f64::max);
    let start = levels.iter().position(|l| *l >= top).unwrap_or(0);
    let pts: Vec<(f64, f64)> = levels
        .iter()
        .enumerate()
        .skip(start)
        .filter(|(_, l)| **l <= top - from_db && **l >= top - to_db)
        .map(|(i, l)| (i as f64 * 0.01, *l))
        .collect();
    let n = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x, b + y));
    let (sxx, sxy) = pts.iter().fold((0.0, 0.0), |(a, b), (x, y)| (a + x * x, b + x * y));
    -(n * sxy - sx * sy) / (n * sxx - sx * sx)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spectrum_finds_a_sine_to_a_fraction_of_a_bin() {
        let fs = 48_000.0;
        let x: Vec<f32> = (0..16384).map(|i| (2.0 * PI * 1234.5 * i as f64 / fs).sin() as f32).collect();
        let s = magnitude_spectrum(&x, 16384);
        let peaks = spectral_peaks(&s, fs, -20.0);
        assert_eq!(peaks.len(), 1);
        assert!((peaks[0].0 - 1234.5).abs() < 0.5, "{:?}", peaks);
    }

    #[test]
    fn decay_rate_of_an_exponential() {
        let fs = 48_000.0;
        // 60 dB in 0.5 s = 120 dB/s.
        let x: Vec<f32> = (0..48_000)
            .map(|i| {
                let t = i as f64 / fs;
                ((2.0 * PI * 500.0 * t).sin() * 10f64.powf(-6.0 * t)) as f32
            })
            .collect();
        let d = decay_db_per_s(&x, fs, 5.0, 40.0);
        assert!((d - 120.0).abs() < 3.0, "{d}");
    }
}
