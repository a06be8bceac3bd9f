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
//! this machine's clock, so a late wake-up moves nothing.
//!
//! The stream's phase can also step: after an xrun a driver restarts its cycle where it
//! stands (JACK's dummy and ALSA drivers both do), a few milliseconds off. The slow loop
//! would take a second to follow, and every sound of that second would be off by what is
//! left. So:
//! - a jump the loop cannot have caused (more than [`relock_s`](AudioClock) off), and the
//!   first block after the host reported an xrun ([`AudioClock::xrun_seen`]), re-lock it,
//!   counted;
//! - for [`SETTLE_BLOCKS`] blocks after a lock the phase follows the earliest callback: a
//!   callback can be woken late, never early, so the one that locked it (late, after an
//!   xrun, by definition) is corrected by the first that comes sooner;
//! - a step too small to re-lock shows as every callback of [`STEP_BLOCKS`] falling on the
//!   same side of the loop's prediction by more than [`STEP_S`] (a wake-up's lateness is
//!   random: it does not hold for 170 ms); the phase moves by the smallest of them.
//!
//! Where the host says how late a callback is, the loop hears it first
//! ([`AudioClock::block_told`]): JACK stamps each cycle's start on its own clock, and cpal
//! hands a callback the instant it was entered and the instant its first sample plays,
//! both on that clock, so their difference is the callback's lateness plus a constant (the
//! port's latency); ALSA's is the samples still queued, which shrink by as much as the
//! callback was late. Its smallest value of late is the constant; what exceeds it is taken
//! off the entry time, so even a machine busy for seconds places its blocks where the
//! stream has them.

use std::time::{Duration, Instant};

/// How fast the loop follows the callbacks, Hz: slow against a callback's jitter (a few
/// ms a wake-up), fast against a crystal's drift (tens of ppm).
pub const BANDWIDTH_HZ: f64 = 0.2;

/// The rate the loop may settle on, relative to the nominal one: a real crystal is within
/// 0.1 %; anything further is the loop misled.
const MAX_RATE_ERROR: f64 = 0.005;

/// Blocks after a lock in which the phase follows the earliest callback.
pub const SETTLE_BLOCKS: u32 = 32;

/// Blocks whose callbacks must all fall on one side of the prediction to move the phase.
pub const STEP_BLOCKS: u32 = 32;

/// How far on one side, s.
pub const STEP_S: f64 = 0.001;

/// The loop's estimate of the stream's clock.
#[derive(Debug, Clone)]
pub struct AudioClock {
    nominal: f64,
    b: f64,
    c: f64,
    /// Re-lock when a callback is this far from where the loop put it, s.
    relock_s: f64,
    state: Option<Locked>,
    /// The host's xrun count as last read.
    xruns: u64,
    /// Re-lock at the next block (an xrun was reported).
    pending: bool,
    /// Times the loop re-locked after a jump or an xrun.
    pub relocks: u64,
    /// Times it moved its phase by a step too small to re-lock.
    pub steps: u64,
    /// The host's smallest lateness measure lately, s (it rises by [`FORGET`] a second: a
    /// port's new latency is learnt in minutes, a busy minute does not wear it away).
    told_floor: f64,
}

/// How fast the host's lateness floor is forgotten, s per s.
const FORGET: f64 = 0.000_01;

#[derive(Debug, Clone, Copy)]
struct Locked {
    base: Instant,
    /// Where the current block starts, s after `base`.
    start_s: f64,
    /// The stream's seconds per sample, as the loop measures them.
    rate: f64,
    /// Samples in the current block.
    frames: u64,
    /// Blocks since the lock.
    age: u32,
    /// The errors' least and greatest over the current step window, s, and its length.
    lo: f64,
    hi: f64,
    window: u32,
}

impl Locked {
    fn new(base: Instant, rate: f64, frames: u64) -> Locked {
        Locked { base, start_s: 0.0, rate, frames, age: 0, lo: f64::INFINITY, hi: f64::NEG_INFINITY, window: 0 }
    }

    /// The phase step the window shows, if every error in it fell on one side by more
    /// than [`STEP_S`]; the window starts again when it is full.
    fn step(&mut self, e: f64) -> Option<f64> {
        (self.lo, self.hi, self.window) = (self.lo.min(e), self.hi.max(e), self.window + 1);
        if self.window < STEP_BLOCKS {
            return None;
        }
        let step = if self.lo > STEP_S {
            Some(self.lo)
        } else if self.hi < -STEP_S {
            Some(self.hi)
        } else {
            None
        };
        (self.lo, self.hi, self.window) = (f64::INFINITY, f64::NEG_INFINITY, 0);
        step
    }
}

impl AudioClock {
    /// A clock for a stream at `sample_rate_hz`; the loop is tuned to the length of the
    /// stream's first block.
    pub fn new(sample_rate_hz: f64) -> AudioClock {
        AudioClock {
            nominal: 1.0 / sample_rate_hz.max(1.0),
            b: 0.0,
            c: 0.0,
            relock_s: 0.0,
            state: None,
            xruns: 0,
            pending: false,
            relocks: 0,
            steps: 0,
            told_floor: f64::INFINITY,
        }
    }

    /// Loop gains for blocks of `frames` samples.
    fn tune(&mut self, frames: u64) {
        let period = frames.max(1) as f64 * self.nominal;
        let omega = std::f64::consts::TAU * BANDWIDTH_HZ * period;
        (self.b, self.c) = (std::f64::consts::SQRT_2 * omega, omega * omega);
        self.relock_s = (4.0 * period).max(0.010);
    }

    /// The host's count of xruns, read before each block: a new one re-locks the loop at
    /// the next block (the stream restarted somewhere else).
    pub fn xrun_seen(&mut self, xruns: u64) {
        if xruns != self.xruns && self.state.is_some() && !self.pending {
            self.pending = true;
            self.relocks += 1;
        }
        self.xruns = xruns;
    }

    /// As [`AudioClock::block`], with the host's measure of the callback's lateness, up to a
    /// constant, s (cpal: the callback instant less the playback instant).
    ///
    /// The host's figure is heard only while the loop is settled: not in the
    /// [`SETTLE_BLOCKS`] after a lock, not in a block after an xrun, not in one that re-locks.
    /// Around a stall JACK's own frame clock is re-locking too, and its cycle stamps are off
    /// by tens of ms (a 30 ms stall of jackd: one callback told 26 ms early); taken as the
    /// floor, such a figure would make every later callback look late by it, and every
    /// sound late as long as the floor remembers (hours).
    pub fn block_told(&mut self, entered: Instant, frames: usize, told_late_s: f64) -> Instant {
        let settled = matches!(self.state, Some(s) if s.age > SETTLE_BLOCKS) && !self.pending;
        if !told_late_s.is_finite() || !settled {
            return self.block(entered, frames);
        }
        let period = frames as f64 * self.nominal;
        let floor = (self.told_floor + FORGET * period).min(told_late_s);
        // No more than a jump that re-locks: a host's number that large is not lateness.
        let late = (told_late_s - floor).clamp(0.0, self.relock_s.max(0.010));
        let heard = entered.checked_sub(Duration::from_secs_f64(late)).unwrap_or(entered);
        if self.jumps(heard) {
            return self.block(entered, frames);
        }
        self.told_floor = floor;
        self.block(heard, frames)
    }

    /// Whether a callback at `entered` is further from the loop's prediction than a re-lock
    /// (as [`AudioClock::block`] judges it).
    fn jumps(&self, entered: Instant) -> bool {
        self.state.is_some_and(|s| {
            let predicted = s.start_s + s.frames as f64 * s.rate;
            (entered.saturating_duration_since(s.base).as_secs_f64() - predicted).abs() > self.relock_s
        })
    }

    /// A callback entered at `entered` renders the next `frames` samples: the instant at
    /// which its block starts on the audio clock.
    pub fn block(&mut self, entered: Instant, frames: usize) -> Instant {
        let (frames, nominal) = (frames as u64, self.nominal);
        let s = match self.state {
            None => {
                self.tune(frames);
                Locked::new(entered, nominal, frames)
            }
            // After an xrun the rate the loop had learned still holds.
            Some(s) if std::mem::take(&mut self.pending) => Locked::new(entered, s.rate, frames),
            Some(mut s) => {
                let predicted = s.start_s + s.frames as f64 * s.rate;
                let measured = entered.saturating_duration_since(s.base).as_secs_f64();
                let e = measured - predicted;
                if e.abs() > self.relock_s {
                    self.relocks += 1;
                    Locked::new(entered, s.rate, frames)
                } else {
                    s.age = s.age.saturating_add(1);
                    s.start_s = if s.age <= SETTLE_BLOCKS && e < 0.0 {
                        measured
                    } else if let Some(step) = s.step(e) {
                        self.steps += 1;
                        predicted + step
                    } else {
                        predicted + self.b * e
                    };
                    // An empty block moved no samples: nothing to learn of the rate.
                    if s.frames > 0 && s.age > SETTLE_BLOCKS {
                        s.rate += self.c * e / s.frames as f64;
                        let (lo, hi) = (nominal * (1.0 - MAX_RATE_ERROR), nominal * (1.0 + MAX_RATE_ERROR));
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

    /// Blocks of N samples whose true starts step by `step` s at block `at`; each callback
    /// entered `late(k)` s after its true start, the host's xrun count read before each
    /// block being `xruns(k)`: the loop's block starts less the true ones, s.
    fn stepped(
        step: f64,
        at: usize,
        late: impl Fn(usize) -> f64,
        xruns: impl Fn(usize) -> u64,
        blocks: usize,
    ) -> (Vec<f64>, AudioClock) {
        let base = Instant::now();
        let mut clock = AudioClock::new(FS);
        let period = N as f64 / FS;
        let errors = (0..blocks)
            .map(|k| {
                let truth = 0.1 + k as f64 * period + if k >= at { step } else { 0.0 };
                clock.xrun_seen(xruns(k));
                let got = clock.block(base + Duration::from_secs_f64(truth + late(k)), N);
                got.saturating_duration_since(base).as_secs_f64() - truth
            })
            .collect();
        (errors, clock)
    }

    /// After an xrun the stream restarts 3 ms later and its first callback comes 4 ms late
    /// on top: the loop re-locks there and the next, timely, callback corrects it.
    #[test]
    fn an_xrun_relocks_and_the_late_callback_that_locked_is_corrected() {
        let late = |k: usize| if k == 500 { 0.0045 } else { 0.0005 };
        let (errors, clock) = stepped(0.003, 500, late, |k| u64::from(k >= 500), 1000);
        assert_eq!(clock.relocks, 1);
        assert!((errors[499] - 0.0005).abs() < 1e-4, "before: {:.2} ms", errors[499] * 1e3);
        for (k, e) in errors.iter().enumerate().skip(501) {
            assert!((e - 0.0005).abs() < 1e-4, "block {k}: {:.2} ms off", e * 1e3);
        }
    }

    /// The stream's phase steps 4 ms later with no xrun reported (too small to re-lock):
    /// the loop follows within a step window, where alone it would still be off by most of it.
    #[test]
    fn a_small_phase_step_is_followed_within_a_window() {
        let mut rng = crate::rng::Rng::new(3);
        let lateness: Vec<f64> = (0..2000).map(|_| 0.001 * rng.unit() as f64).collect();
        let (errors, clock) = stepped(0.004, 1000, |k| lateness[k], |_| 0, 2000);
        assert_eq!((clock.relocks, clock.steps), (0, 1));
        let after = 1000 + 2 * STEP_BLOCKS as usize;
        let worst = errors[after..].iter().fold(0.0f64, |m, e| m.max((e - 0.0005).abs()));
        println!("{:.2} ms off at most from block {after} on", worst * 1e3);
        assert!(worst < 0.001, "{:.2} ms off after the step", worst * 1e3);
    }

    /// Wake-ups late at random for seconds never look like a step.
    #[test]
    fn random_lateness_is_not_a_step() {
        let mut rng = crate::rng::Rng::new(11);
        let lateness: Vec<f64> = (0..20_000).map(|_| 0.004 * rng.unit() as f64).collect();
        let (_, clock) = stepped(0.0, 0, |k| lateness[k], |_| 0, 20_000);
        assert_eq!((clock.relocks, clock.steps), (0, 0));
    }

    /// A machine busy for two seconds wakes every callback 2-7 ms late; the host says by how
    /// much (plus its port latency, 5.3 ms): the blocks stay where the stream has them.
    #[test]
    fn the_hosts_word_on_lateness_is_taken() {
        let mut rng = crate::rng::Rng::new(5);
        let base = Instant::now();
        let (mut clock, mut alone) = (AudioClock::new(FS), AudioClock::new(FS));
        let period = N as f64 / FS;
        let (mut worst, mut worst_alone) = (0.0f64, 0.0f64);
        for k in 0..4000 {
            let truth = 0.1 + k as f64 * period;
            let late =
                if (1000..1400).contains(&k) { 0.002 + 0.005 * rng.unit() as f64 } else { 0.0003 * rng.unit() as f64 };
            let entered = base + Duration::from_secs_f64(truth + late);
            let told = clock.block_told(entered, N, late - 0.0053).saturating_duration_since(base).as_secs_f64();
            let untold = alone.block(entered, N).saturating_duration_since(base).as_secs_f64();
            if k > 200 {
                worst = worst.max((told - truth).abs());
                worst_alone = worst_alone.max((untold - truth).abs());
            }
        }
        println!("told: {:.2} ms off at most; alone: {:.2} ms", worst * 1e3, worst_alone * 1e3);
        assert!(worst < 0.0005, "told: {:.2} ms off", worst * 1e3);
        assert!(worst_alone > 0.002, "alone the loop cannot know: {:.2} ms off", worst_alone * 1e3);
    }

    /// jackd stalls 30 ms (measured: SIGSTOP on a dummy-driver jackd): the stream resumes
    /// 30 ms later, the callback that comes then is told 26 ms early (JACK's cycle stamp,
    /// re-locking itself), another a few blocks on 32 ms early, the xrun reported a block
    /// late. The blocks after the settle stay where the stream has them; taken as the floor,
    /// the first figure put every later block 21 ms early (every sound 21 ms late) for hours.
    #[test]
    fn the_hosts_figures_around_a_stall_are_not_taken() {
        let mut rng = crate::rng::Rng::new(9);
        let base = Instant::now();
        let mut clock = AudioClock::new(FS);
        let period = N as f64 / FS;
        let mut worst = 0.0f64;
        for k in 0..3000 {
            let truth = 0.1 + k as f64 * period + if k >= 1000 { 0.03 } else { 0.0 };
            let late = 0.0003 * rng.unit() as f64;
            let told = match k {
                1000 => -0.0364,
                1004 => -0.0423,
                _ => late - 0.0106,
            };
            clock.xrun_seen(u64::from(k > 1000));
            let got = clock.block_told(base + Duration::from_secs_f64(truth + late), N, told);
            if k > 1000 + 2 * SETTLE_BLOCKS as usize || (200..1000).contains(&k) {
                worst = worst.max((got.saturating_duration_since(base).as_secs_f64() - truth).abs());
            }
        }
        println!("{:.2} ms off at most, {} re-locks", worst * 1e3, clock.relocks);
        assert!(worst < 0.0005, "{:.2} ms off", worst * 1e3);
    }
}
