//! Strikes found in a piece's own sound (its stem: `live --stems`, `sound --stems`), from the
//! audio alone, with no word from the contacts or the notes.
//!
//! A stem is one voice: between strikes it only rings down, and a strike adds a broadband
//! onset. Two detectors, and an onset is where either fires (the earlier within
//! [`REFRACTORY_S`]):
//! - **slope**: the energy of the stem's first difference (its high partials, which die
//!   within milliseconds) in [`HOP_S`] frames rises [`SLOPE_RISE`] times above every frame of
//!   the last [`SLOPE_LOOKBACK_S`]. It finds a strike on a quiet or low voice (kick, toms).
//! - **prediction**: the error of a linear prediction ([`ORDER`], fitted to the
//!   [`FIT_S`] before each [`BLOCK_S`] block) rises [`PREDICTION_RISE`] times above the last
//!   [`PREDICTION_LOOKBACK_S`], is at least [`PREDICTION_SHARE_DB`] of the stem's own energy
//!   in that frame, and the stem's slope over the next 2 ms is [`PREDICTION_GATE`] times its
//!   mean over the 10 ms before. A ringing voice is predictable, a new strike is not: it
//!   finds a strike under the ring of the one before (ride, hi-hat).
//! - **flux**, where neither found anything within [`FLUX_APART_S`]: the median over the
//!   bins from 1 kHz up of how much each bin's level rose against the frame one window
//!   before (spectral flux, [`FLUX_N`]-sample frames every [`FLUX_HOP`]) reaches
//!   [`FLUX_RISE_DB`] and is the most for a window either side. A ringing open hi-hat
//!   fluctuates from frame to frame in its total, but a new strike raises most of its bins
//!   at once: it finds a soft stroke 80 ms after a loud one on an open hi-hat.
//!
//! Frames quieter than [`FLOOR_DB`] below the stem's loudest are never onsets (a voice
//! falling silent ends with a step far below that). The onset's time is the first sample
//! of the rising frame (or the one before, where the rise began there) within [`EDGE_DB`]
//! of its peak. Measured against the contacts of three offline physical renders
//! (`examples/stem_onsets.rs`, README): onsets within 0.25 ms of their contacts at the 95th
//! percentile; soft strokes under a louder ring on the same piece (a hi-hat or snare ghost
//! note 80 ms after an accent) raise the stem by 1-2 dB and are missed.

/// Frame hop and length, seconds.
pub const HOP_S: f64 = 0.0005;
pub const SLOPE_RISE: f64 = 4.0;
pub const SLOPE_LOOKBACK_S: f64 = 0.012;
pub const ORDER: usize = 96;
pub const FIT_S: f64 = 0.03;
pub const BLOCK_S: f64 = 0.005;
pub const PREDICTION_RISE: f64 = 4.0;
pub const PREDICTION_LOOKBACK_S: f64 = 0.03;
pub const PREDICTION_SHARE_DB: f64 = -20.0;
pub const PREDICTION_GATE: f64 = 1.3;
pub const FLOOR_DB: f64 = -50.0;
pub const REFRACTORY_S: f64 = 0.008;
pub const EDGE_DB: f64 = 20.0;
/// Spectral flux frames: hop and FFT length, samples.
pub const FLUX_HOP: usize = 48;
pub const FLUX_N: usize = 512;
pub const FLUX_RISE_DB: f64 = 3.0;
/// Bins further than this below the stem's loudest bin are held at that floor.
pub const FLUX_RANGE_DB: f64 = 80.0;
pub const FLUX_APART_S: f64 = 0.015;
/// From the end of the first rising frame back to the onset, s (measured on the renders).
pub const FLUX_LEAD_S: f64 = 0.0047;

/// The onset times (seconds from the stem's first sample) of the strikes in `stem`.
pub fn stem_onsets(stem: &[f32], sample_rate_hz: f64) -> Vec<f64> {
    if stem.len() < 2 || stem.iter().all(|v| *v == 0.0) {
        return Vec::new();
    }
    let slope: Vec<f32> = stem.windows(2).map(|w| w[1] - w[0]).collect();
    let mut all = rises(&slope, sample_rate_hz, SLOPE_RISE, SLOPE_LOOKBACK_S, None);
    all.extend(rises(
        &residual(stem, sample_rate_hz),
        sample_rate_hz,
        PREDICTION_RISE,
        PREDICTION_LOOKBACK_S,
        Some(stem),
    ));
    all.sort_by(f64::total_cmp);
    let mut out: Vec<f64> = Vec::new();
    for t in all {
        if out.last().is_none_or(|l| t >= l + REFRACTORY_S) {
            out.push(t);
        }
    }
    // The flux detector only adds strikes the others found nothing near.
    let mut extra: Vec<f64> = flux_onsets(stem, sample_rate_hz)
        .into_iter()
        .filter(|t| out.iter().all(|o| (o - t).abs() > FLUX_APART_S))
        .collect();
    out.append(&mut extra);
    out.sort_by(f64::total_cmp);
    out
}

/// Onsets where `signal` (`signal[i]` belongs to sample `i + 1`) rises; with `stem`, the
/// prediction detector's checks against the stem itself.
fn rises(signal: &[f32], sample_rate_hz: f64, rise: f64, lookback_s: f64, stem: Option<&[f32]>) -> Vec<f64> {
    let hop = ((HOP_S * sample_rate_hz).round() as usize).max(1);
    let energy_of = |x: &[f32]| x.iter().map(|&v| f64::from(v) * f64::from(v)).sum::<f64>();
    let energy: Vec<f64> = signal.chunks(hop).map(energy_of).collect();
    let loudest = energy.iter().copied().fold(0.0, f64::max);
    if loudest <= 0.0 {
        return Vec::new();
    }
    let floor = loudest * 10f64.powf(FLOOR_DB / 10.0);
    let share = 10f64.powf(PREDICTION_SHARE_DB / 10.0);
    let back = ((lookback_s / HOP_S).round() as usize).max(2);
    let refractory = (REFRACTORY_S * sample_rate_hz) as usize;
    // Mean squared slope of the stem over samples a..b.
    let slope_power = |x: &[f32], a: usize, b: usize| {
        let (a, b) = (a.min(x.len() - 1), b.min(x.len() - 1));
        (a..b).map(|i| f64::from(x[i + 1] - x[i]).powi(2)).sum::<f64>() / (b - a).max(1) as f64
    };
    let mut out: Vec<f64> = Vec::new();
    let mut last: Option<usize> = None;
    for k in 0..energy.len() {
        if energy[k] < floor {
            continue;
        }
        let before = energy[k.saturating_sub(back)..k.saturating_sub(1)].iter().copied().fold(0.0, f64::max);
        if energy[k] <= rise * before.max(floor / rise) {
            continue;
        }
        if let Some(x) = stem {
            let own = energy_of(&x[(k * hop + 1).min(x.len())..((k + 1) * hop + 1).min(x.len())]);
            let louder = slope_power(x, k * hop, (k + 4) * hop)
                >= PREDICTION_GATE * slope_power(x, (k * hop).saturating_sub(20 * hop), k * hop);
            if energy[k] < share * own || !louder {
                continue;
            }
        }
        // Where the rise starts: the frame before too, when it already rose.
        let from = if k > 0 && energy[k - 1] > rise * before { (k - 1) * hop } else { k * hop };
        let to = ((k + 1) * hop).min(signal.len());
        let peak = signal[from..to].iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let edge = peak * 10f32.powf(-(EDGE_DB as f32) / 20.0);
        let at = from + signal[from..to].iter().position(|v| v.abs() >= edge).unwrap_or(0);
        if last.is_some_and(|l| at < l + refractory) {
            continue;
        }
        last = Some(at);
        out.push((at + 1) as f64 / sample_rate_hz);
    }
    out
}

/// What linear prediction from the samples before could not foresee: `out[i]` is the error
/// at sample `i + 1` (0 in the first [`FIT_S`] and wherever the stem is silent).
pub fn residual(x: &[f32], sample_rate_hz: f64) -> Vec<f32> {
    let block = ((BLOCK_S * sample_rate_hz) as usize).max(1);
    let fit = ((FIT_S * sample_rate_hz) as usize).max(ORDER + 1);
    let mut out = vec![0.0f32; x.len().saturating_sub(1)];
    let mut a = vec![0.0f64; ORDER + 1];
    let window: Vec<f64> =
        (0..fit).map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * (i as f64 + 0.5) / fit as f64).cos()).collect();
    let mut w = vec![0.0f64; fit];
    let mut r = vec![0.0f64; ORDER + 1];
    for start in (fit..x.len()).step_by(block) {
        let end = (start + block).min(x.len());
        if x[start - fit..end].iter().all(|v| *v == 0.0) {
            continue;
        }
        for ((wi, h), &v) in w.iter_mut().zip(&window).zip(&x[start - fit..start]) {
            *wi = h * f64::from(v);
        }
        for (lag, rl) in r.iter_mut().enumerate() {
            *rl = w[lag..].iter().zip(&w[..fit - lag]).map(|(p, q)| p * q).sum();
        }
        // A whisker of white noise keeps the recursion stable on a pure tone.
        r[0] = r[0] * (1.0 + 1e-9) + 1e-30;
        levinson(&r, &mut a);
        for n in start..end {
            let predicted: f64 = (1..=ORDER).map(|i| -a[i] * f64::from(x[n - i])).sum();
            out[n - 1] = (f64::from(x[n]) - predicted) as f32;
        }
    }
    out
}

/// Levinson-Durbin: the prediction error filter `a` (`a[0] = 1`) of autocorrelation `r`.
fn levinson(r: &[f64], a: &mut [f64]) {
    let p = a.len() - 1;
    a.fill(0.0);
    a[0] = 1.0;
    let mut err = r[0];
    let mut before = vec![0.0f64; p + 1];
    for i in 1..=p {
        let acc: f64 = (1..i).map(|j| a[j] * r[i - j]).sum::<f64>() + r[i];
        let k = -acc / err;
        before[..=i].copy_from_slice(&a[..=i]);
        for j in 1..i {
            a[j] = before[j] + k * before[i - j];
        }
        a[i] = k;
        err *= 1.0 - k * k;
        if err <= 0.0 {
            break;
        }
    }
}

/// For each hop: the median over the bins from 1 kHz up of how much the log magnitude (dB)
/// rose against the frame one window earlier.
pub fn flux(x: &[f32], sample_rate_hz: f64) -> Vec<f64> {
    let n = FLUX_N;
    let lo = (1000.0 * n as f64 / sample_rate_hz) as usize;
    let window: Vec<f64> = (0..n).map(|i| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n as f64).cos()).collect();
    let frames = x.len().saturating_sub(n) / FLUX_HOP;
    let mut logs: Vec<Vec<f32>> = Vec::with_capacity(frames);
    let (mut re, mut im) = (vec![0.0; n], vec![0.0; n]);
    for k in 0..frames {
        let seg = &x[k * FLUX_HOP..k * FLUX_HOP + n];
        for i in 0..n {
            re[i] = window[i] * f64::from(seg[i]);
            im[i] = 0.0;
        }
        super::audio::fft(&mut re, &mut im);
        logs.push((lo..n / 2).map(|b| (10.0 * (re[b] * re[b] + im[b] * im[b] + 1e-30).log10()) as f32).collect());
    }
    // Bins far below the loudest anywhere are noise: held at that floor, they do not rise.
    let top = logs.iter().flatten().copied().fold(f32::MIN, f32::max);
    let floor = top - FLUX_RANGE_DB as f32;
    for l in logs.iter_mut().flatten() {
        *l = l.max(floor);
    }
    let d = n / FLUX_HOP;
    let mut rises = vec![0.0f32; n / 2 - lo];
    (0..frames)
        .map(|k| {
            if k < d {
                return 0.0;
            }
            for (r, (a, b)) in rises.iter_mut().zip(logs[k].iter().zip(&logs[k - d])) {
                *r = a - b;
            }
            rises.sort_by(f32::total_cmp);
            f64::from(rises[rises.len() / 2])
        })
        .collect()
}

/// The flux detector: a frame whose median rise is [`FLUX_RISE_DB`] or more and the most
/// within a window either side; the onset is [`FLUX_LEAD_S`] before the end of the first
/// frame of that rise that rose by half as much.
pub fn flux_onsets(x: &[f32], sample_rate_hz: f64) -> Vec<f64> {
    let (rise, lead) = (FLUX_RISE_DB, FLUX_LEAD_S);
    let f = flux(x, sample_rate_hz);
    let d = FLUX_N / FLUX_HOP;
    let mut out = Vec::new();
    for k in 0..f.len() {
        if f[k] < rise || f[k.saturating_sub(d)..(k + d + 1).min(f.len())].iter().any(|&v| v > f[k]) {
            continue;
        }
        let mut first = k;
        while first > 0 && k - first < d && f[first - 1] >= f[k] / 2.0 {
            first -= 1;
        }
        let end = (first * FLUX_HOP + FLUX_N) as f64 / sample_rate_hz;
        out.push(end - lead);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A voice of 40 partials (a head's velocity: each starts at its peak), struck at `at`
    /// (samples) with amplitude `amp`.
    fn ring(len: usize, strikes: &[(usize, f32)]) -> Vec<f32> {
        let mut x = vec![0.0f32; len];
        for &(at, amp) in strikes {
            for (n, v) in x[at..].iter_mut().enumerate() {
                let t = n as f32 / 48_000.0;
                *v += (1..=40)
                    .map(|k| {
                        let f = 180.0 * (k as f32).powf(1.3);
                        amp / k as f32 * (-t * (3.0 + f / 100.0)).exp() * (f * t * std::f32::consts::TAU).cos()
                    })
                    .sum::<f32>();
            }
        }
        x
    }

    #[test]
    fn each_strike_is_found_at_its_sample_even_under_the_ring_of_a_louder_one() {
        // A strike, then one 12 dB softer 100 ms later while the first still rings.
        let x = ring(24_000, &[(4_800, 1.0), (9_600, 0.25)]);
        let found = stem_onsets(&x, 48_000.0);
        assert_eq!(found.len(), 2, "{found:?}");
        assert!((found[0] - 0.1).abs() < 0.0005 && (found[1] - 0.2).abs() < 0.0005, "{found:?}");
        // A ring alone, however it fades out, has one onset.
        assert_eq!(stem_onsets(&ring(24_000, &[(100, 1.0)]), 48_000.0).len(), 1);
        assert!(stem_onsets(&[0.0; 4800], 48_000.0).is_empty());
    }

    /// A cymbal-like voice: 400 partials from 1 to 15 kHz, each ringing 0.5 s.
    fn wash(len: usize, strikes: &[(usize, f32)]) -> Vec<f32> {
        let mut rng = crate::rng::Rng::new(3);
        let partials: Vec<(f32, f32)> = (0..400).map(|_| (1000.0 + 14_000.0 * rng.unit(), rng.unit())).collect();
        let mut x = vec![0.0f32; len];
        for &(at, amp) in strikes {
            for (f, a) in &partials {
                let w = f * std::f32::consts::TAU / 48_000.0;
                for (n, v) in x[at..].iter_mut().enumerate() {
                    *v += amp * a * 0.05 * (-(n as f32) / 24_000.0).exp() * (w * n as f32).cos();
                }
            }
        }
        x
    }

    #[test]
    fn a_soft_stroke_on_a_ringing_wash_is_found() {
        // 6 dB softer, 80 ms after a stroke whose ring is still 1.4 dB under where it began.
        let x = wash(19_200, &[(2_400, 1.0), (6_240, 0.5)]);
        let found = stem_onsets(&x, 48_000.0);
        assert_eq!(found.len(), 2, "{found:?}");
        assert!((found[1] - 0.13).abs() < 0.002, "{found:?}");
        assert_eq!(flux_onsets(&wash(19_200, &[(2_400, 1.0)]), 48_000.0).len(), 1, "one stroke, one rise");
    }
}
