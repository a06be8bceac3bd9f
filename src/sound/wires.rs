//! Snare wires: when the head's excursion at the centre exceeds the gap, the wires leave the
//! resonant head and slap back; each slap is broadband noise. The rattle's envelope follows the
//! excursion beyond the gap (a peak follower with the wires' own decay), and the noise is
//! band-passed around the wires' ringing. Seeded noise: renders are reproducible.

use crate::kit::Wires;

#[derive(Debug, Clone)]
pub struct WireRattle {
    gap_m: f32,
    gain: f32,
    exponent: f32,
    env: f32,
    env_decay: f32,
    // RBJ band-pass (0 dB peak) coefficients and state.
    b0: f32,
    b2: f32,
    a1: f32,
    a2: f32,
    x1: f32,
    x2: f32,
    y1: f32,
    y2: f32,
    rng: u32,
}

impl WireRattle {
    pub fn new(w: &Wires, sample_rate_hz: f32) -> WireRattle {
        let w0 = 2.0 * std::f32::consts::PI * w.center_hz.min(0.45 * sample_rate_hz) / sample_rate_hz;
        let alpha = w0.sin() / (2.0 * w.q);
        let a0 = 1.0 + alpha;
        WireRattle {
            gap_m: w.gap_m,
            gain: w.gain,
            exponent: w.exponent,
            env: 0.0,
            env_decay: (-6.907_755 / (w.decay_s * sample_rate_hz)).exp(),
            b0: alpha / a0,
            b2: -alpha / a0,
            a1: -2.0 * w0.cos() / a0,
            a2: (1.0 - alpha) / a0,
            x1: 0.0,
            x2: 0.0,
            y1: 0.0,
            y2: 0.0,
            rng: 0x2545_F491,
        }
    }

    /// Add the rattle driven by the centre displacement `centre` into `out`.
    pub fn process(&mut self, centre: &[f32], out: &mut [f32]) {
        for (c, o) in centre.iter().zip(out.iter_mut()) {
            let past = (c.abs() - self.gap_m).max(0.0);
            let drive = if self.exponent == 1.0 {
                past * self.gain
            } else {
                (past * 1e3).powf(self.exponent) * 1e-3 * self.gain
            };
            self.env = drive.max(self.env * self.env_decay);
            if self.env < 1e-7 {
                self.env = 0.0;
                continue;
            }
            // xorshift32 noise in [-1, 1).
            self.rng ^= self.rng << 13;
            self.rng ^= self.rng >> 17;
            self.rng ^= self.rng << 5;
            let x = (self.rng as f32 / u32::MAX as f32) * 2.0 - 1.0;
            let y = self.b0 * x + self.b2 * self.x2 - self.a1 * self.y1 - self.a2 * self.y2;
            self.x2 = self.x1;
            self.x1 = x;
            self.y2 = self.y1;
            self.y1 = y;
            *o += self.env * y;
        }
    }

    /// True while the wires still rattle.
    pub fn is_ringing(&self) -> bool {
        self.env > 0.0
    }
}
