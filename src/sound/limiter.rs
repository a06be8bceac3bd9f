//! Master look-ahead peak limiter: the output never exceeds the ceiling and holds no NaN.
//! The signal is delayed by the look-ahead; the gain for each sample is the smallest needed
//! by any sample within the look-ahead window (a sliding maximum over a monotonic queue), so
//! the gain is already down when a peak arrives; it recovers with an exponential release and
//! snaps to 1 once within [`SNAP`] of it.
//!
//! Only peaks above the ceiling enter the queue: a window whose peak is at or below the
//! ceiling asks for no reduction, whatever that peak is. So while the queue is empty and the
//! input stays under the ceiling, a stretch of samples needs no per-sample bookkeeping (and at
//! unity gain is only delayed); the result is the same sample for sample, whatever the blocks.

/// The release ends, and the gain is exactly 1 again, once it is this close to 1 (-120 dB).
pub const SNAP: f32 = 1e-6;

#[derive(Debug, Clone)]
pub struct Limiter {
    ceiling: f32,
    lookahead: usize,
    release: f32,
    gain: f32,
    delay_l: Vec<f32>,
    delay_r: Vec<f32>,
    /// Where the next sample enters the delay lines.
    slot: usize,
    /// Ring of (sample index, peak) over the ceiling with decreasing peaks: the window's
    /// maximum first.
    queue: Vec<(u64, f32)>,
    head: usize,
    len: usize,
    index: u64,
    /// Samples that were not finite and were replaced by silence.
    pub non_finite: u64,
}

/// Samples checked at once for a quiet stretch.
const QUIET_CHUNK: usize = 32;

impl Limiter {
    pub fn new(sample_rate_hz: f32, ceiling: f32, lookahead_s: f32, release_s: f32) -> Limiter {
        let lookahead = ((lookahead_s * sample_rate_hz).round() as usize).max(1);
        Limiter {
            ceiling,
            lookahead,
            release: (-1.0 / (release_s * sample_rate_hz)).exp(),
            gain: 1.0,
            delay_l: vec![0.0; lookahead],
            delay_r: vec![0.0; lookahead],
            slot: 0,
            queue: vec![(0, 0.0); lookahead + 1],
            head: 0,
            len: 0,
            index: 0,
            non_finite: 0,
        }
    }

    /// Samples of delay.
    pub fn latency(&self) -> usize {
        self.lookahead
    }

    /// Limit a stereo block in place.
    pub fn process(&mut self, left: &mut [f32], right: &mut [f32]) {
        let n = left.len().min(right.len());
        let mut i = 0;
        while i < n {
            if self.len == 0 {
                let quiet = self.quiet_run(&left[i..n], &right[i..n]);
                if quiet > 0 {
                    self.pass_quiet(&mut left[i..i + quiet], &mut right[i..i + quiet]);
                    i += quiet;
                    continue;
                }
            }
            self.limit_sample(&mut left[i], &mut right[i]);
            i += 1;
        }
    }

    /// How many samples from the start are finite and at or below the ceiling.
    fn quiet_run(&self, left: &[f32], right: &[f32]) -> usize {
        let c = self.ceiling;
        let quiet = |x: &f32| x.abs() <= c;
        let mut run = 0;
        for (l, r) in left.chunks(QUIET_CHUNK).zip(right.chunks(QUIET_CHUNK)) {
            if l.iter().chain(r).fold(true, |ok, x| ok & quiet(x)) {
                run += l.len();
            } else {
                return run + l.iter().zip(r).position(|(l, r)| !(quiet(l) && quiet(r))).unwrap_or(l.len());
            }
        }
        run
    }

    /// Samples that need no reduction, while no peak over the ceiling is in the window.
    fn pass_quiet(&mut self, left: &mut [f32], right: &mut [f32]) {
        let n = left.len();
        if self.gain == 1.0 {
            // Only the delay: swap each sample with the one that entered `lookahead` ago.
            let mut i = 0;
            while i < n {
                let take = (n - i).min(self.lookahead - self.slot);
                left[i..i + take].swap_with_slice(&mut self.delay_l[self.slot..self.slot + take]);
                right[i..i + take].swap_with_slice(&mut self.delay_r[self.slot..self.slot + take]);
                self.advance_slot(take);
                i += take;
            }
        } else {
            for (l, r) in left.iter_mut().zip(right.iter_mut()) {
                self.release_towards(1.0);
                self.delay_and_apply(l, r);
            }
        }
        self.index += n as u64;
    }

    fn limit_sample(&mut self, l: &mut f32, r: &mut f32) {
        let cap = self.queue.len();
        for x in [&mut *l, &mut *r] {
            if !x.is_finite() {
                *x = 0.0;
                self.non_finite += 1;
            }
        }
        let peak = l.abs().max(r.abs());
        if peak > self.ceiling {
            // Push the new peak, dropping smaller ones behind it.
            while self.len > 0 && self.queue[ring(self.head + self.len - 1, cap)].1 <= peak {
                self.len -= 1;
            }
            self.queue[ring(self.head + self.len, cap)] = (self.index, peak);
            self.len += 1;
        }
        // Drop peaks that left the window [index - lookahead, index].
        while self.len > 0 && self.queue[self.head].0 + (self.lookahead as u64) < self.index {
            self.head = ring(self.head + 1, cap);
            self.len -= 1;
        }
        let target = if self.len > 0 { self.ceiling / self.queue[self.head].1 } else { 1.0 };
        if target < self.gain {
            self.gain = target;
        } else {
            self.release_towards(target);
        }
        self.delay_and_apply(l, r);
        self.index += 1;
    }

    #[inline(always)]
    fn release_towards(&mut self, target: f32) {
        let g = target - (target - self.gain) * self.release;
        self.gain = if target - g <= SNAP { target } else { g };
    }

    #[inline(always)]
    fn delay_and_apply(&mut self, l: &mut f32, r: &mut f32) {
        let (dl, dr) = (self.delay_l[self.slot], self.delay_r[self.slot]);
        self.delay_l[self.slot] = *l;
        self.delay_r[self.slot] = *r;
        self.advance_slot(1);
        *l = (dl * self.gain).clamp(-self.ceiling, self.ceiling);
        *r = (dr * self.gain).clamp(-self.ceiling, self.ceiling);
    }

    #[inline(always)]
    fn advance_slot(&mut self, by: usize) {
        self.slot += by;
        if self.slot >= self.lookahead {
            self.slot -= self.lookahead;
        }
    }
}

/// `i` wrapped into a ring of `cap` entries (`i < 2 cap`).
#[inline(always)]
fn ring(i: usize, cap: usize) -> usize {
    if i >= cap {
        i - cap
    } else {
        i
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn loud_input_stays_under_the_ceiling_without_clipping_the_shape() {
        let mut lim = Limiter::new(48_000.0, 0.9, 0.0015, 0.05);
        let mut l: Vec<f32> = (0..4800).map(|i| 3.0 * (i as f32 * 0.05).sin()).collect();
        let mut r = l.clone();
        lim.process(&mut l, &mut r);
        let peak = l.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        assert!(peak <= 0.9 && peak > 0.85, "{peak}");
    }

    #[test]
    fn quiet_input_passes_delayed_and_unchanged() {
        let mut lim = Limiter::new(48_000.0, 0.9, 0.001, 0.05);
        let d = lim.latency();
        let input: Vec<f32> = (0..1000).map(|i| 0.5 * (i as f32 * 0.01).sin()).collect();
        let (mut l, mut r) = (input.clone(), input.clone());
        lim.process(&mut l, &mut r);
        for i in d..1000 {
            assert_eq!(l[i], input[i - d]);
        }
    }

    #[test]
    fn nan_becomes_silence_and_is_counted() {
        let mut lim = Limiter::new(48_000.0, 0.9, 0.001, 0.05);
        let (mut l, mut r) = (vec![f32::NAN; 100], vec![f32::INFINITY; 100]);
        lim.process(&mut l, &mut r);
        assert!(l.iter().chain(r.iter()).all(|v| *v == 0.0));
        assert_eq!(lim.non_finite, 200);
    }

    /// The limiter's definition, sample by sample with a brute-force window maximum.
    fn reference(lim: &Limiter, left: &[f32], right: &[f32]) -> (Vec<f32>, Vec<f32>) {
        let (c, la) = (lim.ceiling, lim.lookahead);
        let clean = |x: f32| if x.is_finite() { x } else { 0.0 };
        let (l, r): (Vec<f32>, Vec<f32>) = left.iter().zip(right).map(|(l, r)| (clean(*l), clean(*r))).unzip();
        let mut gain = 1.0f32;
        let (mut ol, mut or) = (Vec::new(), Vec::new());
        for i in 0..l.len() {
            let peak = (i.saturating_sub(la)..=i).map(|j| l[j].abs().max(r[j].abs())).fold(0.0, f32::max);
            let target = if peak > c { c / peak } else { 1.0 };
            gain = if target < gain {
                target
            } else {
                let g = target - (target - gain) * lim.release;
                if target - g <= SNAP {
                    target
                } else {
                    g
                }
            };
            let (dl, dr) = if i >= la { (l[i - la], r[i - la]) } else { (0.0, 0.0) };
            ol.push((dl * gain).clamp(-c, c));
            or.push((dr * gain).clamp(-c, c));
        }
        (ol, or)
    }

    #[test]
    fn any_blocks_give_the_reference_output() {
        // Quiet stretches, bursts over the ceiling, releases and a NaN.
        let left: Vec<f32> = (0..6000)
            .map(|i| {
                let burst = if (i / 700) % 3 == 1 { 2.5 } else { 0.4 };
                if i == 3333 {
                    f32::NAN
                } else {
                    burst * (i as f32 * 0.031).sin()
                }
            })
            .collect();
        let right: Vec<f32> = left.iter().map(|v| -0.8 * v).collect();
        let lim = Limiter::new(48_000.0, 0.9, 0.0015, 0.002);
        let (want_l, want_r) = reference(&lim, &left, &right);
        for sizes in [&[6000usize][..], &[1], &[5, 1, 97, 512, 3]] {
            let mut lim = lim.clone();
            let (mut l, mut r) = (left.clone(), right.clone());
            let mut i = 0;
            for size in sizes.iter().cycle() {
                if i >= l.len() {
                    break;
                }
                let end = (i + size).min(l.len());
                lim.process(&mut l[i..end], &mut r[i..end]);
                i = end;
            }
            assert!(l == want_l && r == want_r, "blocks {sizes:?} differ from the reference");
            assert_eq!(lim.non_finite, 2);
        }
    }
}
