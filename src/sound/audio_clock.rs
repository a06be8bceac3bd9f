//! The audio clock: where each block of the output stream starts on this machine's clock,
//! from the stream's own sample count, with the callbacks' entry times filtered by a
//! second-order delay-locked loop (F. Adriaensen, "Using a DLL to filter time", 2005: the
//! loop JACK runs for its own frame time).
//!
//! An event is placed in the stream by where its due instant falls from the block's start
//! (`output::sample_for`). Taking the block's start as the instant the callback was entered
//! makes every callback woken late by a busy machine shift the sounds of its block earlier
//! in the stream by that lateness: jitter straight into the timing. The stream itself runs
//! on the sound card's crystal, one block after the other; the loop follows that count of
//! samples, and corrects slowly (bandwidth [`BANDWIDTH_HZ`]) for the crystal's drift against
//! this machine's clock, so a late wake-up moves nothing. A jump the loop cannot have caused
//! (an xrun, a stream restarted) re-locks it at once, counted.

use std::time::{Duration, Instant};

/// How fast the loop follows the callbacks, Hz: slow against a callback's jitter (a few
/// ms a wake-up), fast against a crystal's drift (tens of ppm).
pub const BANDWIDTH_HZ: f64 = 0.2;

/// The rate the loop may settle on, relative to the nominal one: a real crystal is within
/// 0.1 %; anything further is the loop misled.
const MAX_RATE_ERROR: f64 = 0.005;

/// The loop's estimate of the stream's clock.
#[derive(Debug, Clone)]
pub struct AudioClock {
    nominal: f64,
    b: f64,
    c: f64,
    /// Re-lock when a callback is this far from where the loop put it, s.
    relock_s: f64,
    state: Option<Locked>,
    /// Times the loop re-locked after a jump.
    pub relocks: u64,
}

#[derive(Debug, Clone, Copy)]
struct Locked {
    base: Instant,
    /// Where the current block starts, s after `base`.
    start_s: f64,
    /// The stream's seconds per sample, as the loop measures them.
    rate: f64,
    /// Samples in the current block.
    frames: u64,
}

impl AudioClock {
    /// A clock for a stream at `sample_rate_hz`; the loop is tuned to the length of the
    /// stream's first block.
    pub fn new(sample_rate_hz: f64) -> AudioClock {
        AudioClock { nominal: 1.0 / sample_rate_hz.max(1.0), b: 0.0, c: 0.0, relock_s: 0.0, state: None, relocks: 0 }
    }

    /// Loop gains for blocks of `frames` samples.
    fn tune(&mut self, frames: u64) {
        let period = frames.max(1) as f64 * self.nominal;
        let omega = std::f64::consts::TAU * BANDWIDTH_HZ * period;
        (self.b, self.c) = (std::f64::consts::SQRT_2 * omega, omega * omega);
        self.relock_s = (4.0 * period).max(0.010);
    }

    /// A callback entered at `entered` renders the next `frames` samples: the instant at
    /// which its block starts on the audio clock.
    pub fn block(&mut self, entered: Instant, frames: usize) -> Instant {
        let (frames, nominal) = (frames as u64, self.nominal);
        let relock = |base: Instant| Locked { base, start_s: 0.0, rate: nominal, frames };
        let s = match self.state {
            None => {
                self.tune(frames);
                relock(entered)
            }
            Some(mut s) => {
                let predicted = s.start_s + s.frames as f64 * s.rate;
                let measured = entered.saturating_duration_since(s.base).as_secs_f64();
                let e = measured - predicted;
                if e.abs() > self.relock_s {
                    self.relocks += 1;
                    relock(entered)
                } else {
                    s.start_s = predicted + self.b * e;
                    // An empty block moved no samples: nothing to learn of the rate.
                    if s.frames > 0 {
                        s.rate += self.c * e / s.frames as f64;
                        let (lo, hi) = (self.nominal * (1.0 - MAX_RATE_ERROR), self.nominal * (1.0 + MAX_RATE_ERROR));
                        s.rate = s.rate.clamp(lo, hi);
                    }
                    s.frames = frames;
                    s
                }
            }
        };
        self.state = Some(s);
        s.base + Duration::from_secs_f64(s.start_s.max(0.0))
    }

    /// The stream's sample rate as the loop measures it against this machine's clock, Hz.
    pub fn measured_rate_hz(&self) -> Option<f64> {
        self.state.map(|s| 1.0 / s.rate)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f64 = 48_000.0;
    const N: usize = 256;

    /// Blocks of N samples from a crystal `ppm` off, each callback entered late by
    /// `late(k)` seconds: over the second half, the spread of the loop's block starts against
    /// the true ones (max - min, s) and their largest distance from the lateness's mean.
    fn run(ppm: f64, late: impl Fn(usize) -> f64, mean_late: f64, blocks: usize) -> (f64, f64) {
        let base = Instant::now();
        let mut clock = AudioClock::new(FS);
        let period = N as f64 / (FS * (1.0 + ppm * 1e-6));
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..blocks {
            let truth = k as f64 * period;
            let entered = base + Duration::from_secs_f64(truth + late(k));
            let got = clock.block(entered, N).saturating_duration_since(base).as_secs_f64();
            if k > blocks / 2 {
                lo = lo.min(got - truth);
                hi = hi.max(got - truth);
            }
        }
        (hi - lo, (hi - mean_late).abs().max((lo - mean_late).abs()))
    }

    /// A busy machine wakes callbacks 0-4 ms late at random: the raw entry times spread
    /// over 4 ms, the loop's block starts over well under 1 ms (less a constant, the mean
    /// lateness, the same for every sound).
    #[test]
    fn late_wake_ups_do_not_move_the_blocks() {
        let mut rng = crate::rng::Rng::new(7);
        let lateness: Vec<f64> = (0..20_000).map(|_| 0.004 * rng.unit() as f64).collect();
        let (spread, off) = run(0.0, |k| lateness[k], 0.002, 20_000);
        println!("block starts spread over {:.2} ms, up to {:.2} ms from the mean lateness", spread * 1e3, off * 1e3);
        assert!(spread < 0.001, "block starts spread over {:.2} ms", spread * 1e3);
        assert!(off < 0.001, "block starts up to {:.2} ms from the mean lateness", off * 1e3);
    }

    /// A crystal 100 ppm fast is followed: no drift builds up over 100 s.
    #[test]
    fn a_drifting_crystal_is_followed() {
        let (spread, off) = run(100.0, |_| 0.0005, 0.0005, 18_750);
        assert!(spread < 0.0002 && off < 0.0002, "block starts spread {spread} s, {off} s off");
        let mut clock = AudioClock::new(FS);
        let base = Instant::now();
        let period = N as f64 / (FS * 1.0001);
        for k in 0..18_750 {
            clock.block(base + Duration::from_secs_f64(k as f64 * period), N);
        }
        let rate = clock.measured_rate_hz().unwrap();
        assert!((rate / FS - 1.0001).abs() < 2e-5, "measured {rate} Hz");
    }

    /// A gap (an xrun: the stream stalled 50 ms) re-locks the loop at once.
    #[test]
    fn a_stalled_stream_relocks() {
        let base = Instant::now();
        let mut clock = AudioClock::new(FS);
        let period = N as f64 / FS;
        let mut t = 0.0;
        for k in 0..1000 {
            if k == 500 {
                t += 0.05;
            }
            let got = clock.block(base + Duration::from_secs_f64(t), N);
            if k == 500 {
                assert_eq!(got, base + Duration::from_secs_f64(t), "re-locked where the callback came");
            }
            t += period;
        }
        assert_eq!(clock.relocks, 1);
    }
}
