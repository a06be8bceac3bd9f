//! Master look-ahead peak limiter: the output never exceeds the ceiling and holds no NaN.
//! The signal is delayed by the look-ahead; the gain for each sample is the smallest needed
//! by any sample within the look-ahead window (a sliding maximum over a monotonic queue), so
//! the gain is already down when a peak arrives; it recovers with an exponential release.

#[derive(Debug, Clone)]
pub struct Limiter {
    ceiling: f32,
    lookahead: usize,
    release: f32,
    gain: f32,
    delay_l: Vec<f32>,
    delay_r: Vec<f32>,
    /// Monotonic queue of (sample index, peak) with decreasing peaks: the window's maximum first.
    queue: Vec<(u64, f32)>,
    head: usize,
    len: usize,
    index: u64,
    /// Samples that were not finite and were replaced by silence.
    pub non_finite: u64,
}

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
        let cap = self.queue.len();
        for (l, r) in left.iter_mut().zip(right.iter_mut()) {
            for x in [&mut *l, &mut *r] {
                if !x.is_finite() {
                    *x = 0.0;
                    self.non_finite += 1;
                }
            }
            let peak = l.abs().max(r.abs());
            // Push the new peak, dropping smaller ones behind it.
            while self.len > 0 && self.queue[(self.head + self.len - 1) % cap].1 <= peak {
                self.len -= 1;
            }
            self.queue[(self.head + self.len) % cap] = (self.index, peak);
            self.len += 1;
            // Drop peaks that left the window [index - lookahead, index].
            while self.queue[self.head].0 + (self.lookahead as u64) < self.index {
                self.head = (self.head + 1) % cap;
                self.len -= 1;
            }
            let window_peak = self.queue[self.head].1;
            let target = if window_peak > self.ceiling { self.ceiling / window_peak } else { 1.0 };
            self.gain = if target < self.gain { target } else { target - (target - self.gain) * self.release };
            let slot = (self.index % self.lookahead as u64) as usize;
            let (dl, dr) = (self.delay_l[slot], self.delay_r[slot]);
            self.delay_l[slot] = *l;
            self.delay_r[slot] = *r;
            *l = (dl * self.gain).clamp(-self.ceiling, self.ceiling);
            *r = (dr * self.gain).clamp(-self.ceiling, self.ceiling);
            self.index += 1;
        }
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
}
