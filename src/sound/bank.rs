//! The modal resonator bank: each mode is an exact two-pole recursion of a damped oscillator,
//! y[n] = a1 y[n-1] - a2 y[n-2], a1 = 2 e^(-sigma T) cos(omega_d T), a2 = e^(-2 sigma T).
//! Modes sit in lanes of eight; each lane keeps its own output accumulator per sample, summed
//! across lanes once per block, so the inner loop vectorises, and chunks of eight run four
//! side by side so that one chunk's recursion runs while the others wait on their multiplies.
//! Chunks of eight modes that have decayed below audibility sleep until the next strike.

use super::lanes::{dispatch, LaneFn, LaneOps};
use super::stress::Stress;

/// Modes per chunk.
pub const LANES: usize = 8;
/// Eight modes, one per lane.
pub type Lane = [f32; LANES];

/// A chunk sleeps when every mode's output is below this (-100 dBFS), or below
/// [`BELOW_STRIKE`] of the last strike's level (its contact's RMS) if that is higher ...
const SILENT_OUTPUT: f32 = 1e-5;
/// ... -80 dB: a tail that far under its own attack is masked by it and by anything else
/// that plays.
const BELOW_STRIKE: f32 = 1e-4;
/// ... and its displacement below this (metres), so a quiet but moving head still rattles.
const SILENT_DISPLACEMENT: f32 = 1e-8;

#[derive(Debug, Clone)]
pub struct Bank {
    a1: Vec<Lane>,
    a2: Vec<Lane>,
    gain: Vec<Lane>,
    y1: Vec<Lane>,
    y2: Vec<Lane>,
    active: Vec<bool>,
    /// Weights of the first chunk's modes in the displacement at the centre (for snare wires).
    centre: Lane,
    modes: usize,
    /// Samples rendered so far: chunks may fall asleep only at multiples of [`SLEEP_CHECK`],
    /// so the output does not depend on how the caller splits it into blocks.
    clock: u64,
    /// The stretch nonlinearity (see [`super::modes::ModeSet::stretch`]): each mode's share
    /// of the stretch per squared displacement, and the change of its next displacement per
    /// unit of stretch and of its displacement. Empty when the piece is linear.
    stretch_w: Vec<Lane>,
    stretch_c: Vec<Lane>,
    /// The stretch now, and whether it is large enough to run the coupled recursion.
    stretch: f32,
    coupled: bool,
    /// The largest stretch the recursion stays stable at, the stretch below which the modes
    /// run uncoupled, and how many chunks (from the lowest) the stretch couples.
    max_stretch: f32,
    stretch_off: f32,
    coupled_chunks: usize,
    /// The largest stretch since the last sleep check: the coupling stops only at a check,
    /// so the output does not depend on how the caller splits it into blocks.
    stretch_most: f32,
    /// Output below which a chunk sleeps (see [`SILENT_OUTPUT`]), and whether a chunk that
    /// still moves the surface stays awake (snare wires listen to the head's motion).
    silent_output: f32,
    keep_moving: bool,
    /// A plate's von Karman stress ([`Stress`]), whether it runs now, and its largest level
    /// since the last sleep check.
    stress: Option<Box<Stress>>,
    stressed: bool,
    stress_most: f32,
}

/// The modes run uncoupled once the stretch stiffens them by less than this (a frequency
/// shift of 0.05 %, well under what an ear hears as a glide).
const STRETCH_OFF: f64 = 1e-3;

/// Chunks run side by side in the inner loop.
const GROUP: usize = 4;

/// Samples between checks for chunks that have decayed to silence.
pub const SLEEP_CHECK: u64 = 128;

impl Bank {
    /// A silent bank of `gains.len()` modes with output gains `gains` and centre weights.
    pub fn new(gains: &[f32], centre_weights: &[f32]) -> Bank {
        let chunks = gains.len().div_ceil(LANES);
        let mut gain = vec![[0.0; LANES]; chunks];
        for (k, g) in gains.iter().enumerate() {
            gain[k / LANES][k % LANES] = *g;
        }
        let mut centre = [0.0; LANES];
        for (k, w) in centre_weights.iter().take(LANES).enumerate() {
            centre[k] = *w;
        }
        Bank {
            a1: vec![[0.0; LANES]; chunks],
            a2: vec![[0.0; LANES]; chunks],
            gain,
            y1: vec![[0.0; LANES]; chunks],
            y2: vec![[0.0; LANES]; chunks],
            active: vec![false; chunks],
            centre,
            modes: gains.len(),
            clock: 0,
            stretch_w: Vec::new(),
            stretch_c: Vec::new(),
            stretch: 0.0,
            coupled: false,
            max_stretch: 0.0,
            stretch_off: 0.0,
            coupled_chunks: 0,
            silent_output: SILENT_OUTPUT,
            keep_moving: true,
            stretch_most: 0.0,
            stress: None,
            stressed: false,
            stress_most: 0.0,
        }
    }

    /// Make the bank a plate with in-plane stress (see [`Stress`]); its modes run coupled
    /// after a strike hard enough for it to matter.
    pub fn set_stress(&mut self, stress: Stress) {
        self.stress = Some(Box::new(stress));
    }

    /// Make the bank nonlinear: mode k adds `w[k] y_k^2` to the stretch s, and each sample
    /// its next displacement loses `s c[k] y_k`; s is held at or below `max`. Only the
    /// lowest `modes` modes take part (those above ring out too fast to matter); `stiffness`
    /// is the stretch that would double the stiffest-coupled mode's stiffness (the
    /// coupling stops below [`STRETCH_OFF`] of it).
    pub fn set_stretch(&mut self, w: &[f32], c: &[f32], max: f32, modes: usize, stiffness: f64) {
        self.max_stretch = max;
        self.stretch_off = (STRETCH_OFF * stiffness) as f32;
        self.coupled_chunks = modes.div_ceil(LANES).min(self.gain.len());
        let lanes = |v: &[f32]| {
            let mut out = vec![[0.0; LANES]; self.gain.len()];
            for (k, x) in v.iter().enumerate() {
                out[k / LANES][k % LANES] = *x;
            }
            out
        };
        (self.stretch_w, self.stretch_c) = (lanes(w), lanes(c));
    }

    /// After the state was set (a strike): recompute the stretch or the plate's stress and run
    /// coupled if it matters.
    pub fn wake_stretch(&mut self) {
        if let Some(stress) = &mut self.stress {
            if stress.wake(&self.y1, &self.y2) {
                // The stress drives every mode, asleep or not.
                self.stressed = true;
                self.active.fill(true);
                self.stress_most = self.stress_most.max(stress.level());
            }
        }
        if self.stretch_w.is_empty() {
            return;
        }
        let mut s = 0.0;
        for (w, y) in self.stretch_w.iter().zip(&self.y1).take(self.coupled_chunks) {
            for (w, y) in w.iter().zip(y) {
                s += w * y * y;
            }
        }
        self.stretch = s.min(self.max_stretch);
        self.coupled = s > self.stretch_off;
        self.stretch_most = self.stretch_most.max(self.stretch);
    }

    /// Whether chunks that are silent but still move the surface keep running (true unless
    /// told: for snare wires, which rattle on the head's motion).
    pub fn set_keep_moving(&mut self, keep: bool) {
        self.keep_moving = keep;
    }

    /// A strike's level (RMS of its contact) was `level`: modes may sleep [`BELOW_STRIKE`]
    /// under it.
    pub fn set_strike_level(&mut self, level: f32) {
        self.silent_output = SILENT_OUTPUT.max(level * BELOW_STRIKE);
    }

    pub fn modes(&self) -> usize {
        self.modes
    }

    pub fn set_coefficients(&mut self, k: usize, a1: f32, a2: f32) {
        self.a1[k / LANES][k % LANES] = a1;
        self.a2[k / LANES][k % LANES] = a2;
    }

    /// The last two outputs of mode k: (y[n-1], y[n-2]).
    pub fn state(&self, k: usize) -> (f32, f32) {
        (self.y1[k / LANES][k % LANES], self.y2[k / LANES][k % LANES])
    }

    /// Set mode k's last two displacements; its chunk wakes up.
    pub fn set_state(&mut self, k: usize, y1: f32, y2: f32) {
        self.y1[k / LANES][k % LANES] = y1;
        self.y2[k / LANES][k % LANES] = y2;
        self.active[k / LANES] = true;
    }

    pub fn is_silent(&self) -> bool {
        !self.active.iter().any(|a| *a)
    }

    /// Number of chunks now ringing.
    pub fn active_chunks(&self) -> usize {
        self.active.iter().filter(|a| **a).count()
    }

    /// Add the next `out.len()` samples of every ringing mode into `out`; if `centre` is given,
    /// also write the centre displacement of the first chunk into it. `acc` is scratch of at
    /// least `out.len()` lanes.
    pub fn process(&mut self, out: &mut [f32], centre: Option<&mut [f32]>, acc: &mut [Lane]) {
        // Compiled again for AVX2 where the processor has it (see `lanes`); every loop below
        // is inlined into it.
        struct Run<'a> {
            bank: &'a mut Bank,
            out: &'a mut [f32],
            centre: Option<&'a mut [f32]>,
            acc: &'a mut [Lane],
        }
        impl LaneFn<()> for Run<'_> {
            #[inline(always)]
            fn call<O: LaneOps>(self, o: O) {
                self.bank.process_inner(o, self.out, self.centre, self.acc)
            }
        }
        dispatch(Run { bank: self, out, centre, acc })
    }

    #[inline(always)]
    fn process_inner<O: LaneOps>(&mut self, o: O, out: &mut [f32], mut centre: Option<&mut [f32]>, acc: &mut [Lane]) {
        let mut i = 0;
        while i < out.len() {
            let to_check = (SLEEP_CHECK - self.clock % SLEEP_CHECK) as usize;
            let end = out.len().min(i + to_check);
            if self.stressed {
                self.process_stressed(o, &mut out[i..end], centre.as_deref_mut().map(|c| &mut c[i..end]));
            } else if self.coupled {
                self.process_coupled(o, &mut out[i..end], centre.as_deref_mut().map(|c| &mut c[i..end]));
                self.process_segment(&mut out[i..end], None, acc, self.coupled_chunks);
            } else {
                self.process_segment(&mut out[i..end], centre.as_deref_mut().map(|c| &mut c[i..end]), acc, 0);
            }
            self.clock += (end - i) as u64;
            if self.clock.is_multiple_of(SLEEP_CHECK) {
                if self.coupled && self.stretch_most < self.stretch_off {
                    self.coupled = false;
                }
                self.stretch_most = 0.0;
                if self.stressed && self.stress.as_ref().is_some_and(|s| self.stress_most < s.off()) {
                    self.stressed = false;
                }
                self.stress_most = 0.0;
                // While the stress runs it drives every mode: none sleeps.
                for c in 0..if self.stressed { 0 } else { self.active.len() } {
                    if self.active[c] {
                        self.sleep_if_silent(c);
                    }
                }
            }
            i = end;
        }
    }

    /// Add the chunks from `from` on over `out.len()` samples into `out`.
    #[inline(always)]
    fn process_segment(&mut self, out: &mut [f32], centre: Option<&mut [f32]>, acc: &mut [Lane], from: usize) {
        let n = out.len();
        let acc = &mut acc[..n];
        acc.fill([0.0; LANES]);
        let mut first = from;
        if let Some(centre) = centre {
            let centre = &mut centre[..n];
            centre.fill(0.0);
            if self.active.first() == Some(&true) {
                self.process_first_with_centre(acc, centre);
            }
            first = 1;
        }
        // Chunks in groups of GROUP: their recursions are independent, so the processor
        // overlaps their latencies. Each lane still adds the chunks in ascending order.
        let mut group = [0usize; GROUP];
        let mut len = 0;
        for c in first..self.active.len() {
            if self.active[c] {
                group[len] = c;
                len += 1;
                if len == GROUP {
                    self.run_chunks(group, acc);
                    len = 0;
                }
            }
        }
        for &c in &group[..len] {
            self.run_chunks([c], acc);
        }
        for (o, a) in out.iter_mut().zip(acc.iter()) {
            *o += a.iter().sum::<f32>();
        }
    }

    /// Advance the chunks `idx` over `acc.len()` samples, adding their outputs into `acc`.
    #[inline(always)]
    fn run_chunks<const N: usize>(&mut self, idx: [usize; N], acc: &mut [Lane]) {
        let a1 = idx.map(|c| self.a1[c]);
        let a2 = idx.map(|c| self.a2[c]);
        let g = idx.map(|c| self.gain[c]);
        let mut y1 = idx.map(|c| self.y1[c]);
        let mut y2 = idx.map(|c| self.y2[c]);
        for acc_s in acc.iter_mut() {
            for j in 0..N {
                for l in 0..LANES {
                    let y = a1[j][l] * y1[j][l] - a2[j][l] * y2[j][l];
                    acc_s[l] += g[j][l] * y;
                    y2[j][l] = y1[j][l];
                    y1[j][l] = y;
                }
            }
        }
        for (j, &c) in idx.iter().enumerate() {
            self.y1[c] = y1[j];
            self.y2[c] = y2[j];
        }
    }

    /// The modes coupled through the stretch, a sample at a time over every ringing chunk
    /// (the stretch of one sample pulls on the next); back to [`Bank::process_segment`] once
    /// the stretch has fallen below [`STRETCH_OFF`] for a whole segment.
    #[inline(always)]
    fn process_coupled<O: LaneOps>(&mut self, o: O, out: &mut [f32], mut centre: Option<&mut [f32]>) {
        let mut stretch = self.stretch;
        let mut most = 0.0f32;
        for (s, sample) in out.iter_mut().enumerate() {
            // Whole lanes by value, as in `Stress::step`.
            let mut acc = [0.0f32; LANES];
            let mut next = [0.0f32; LANES];
            let mut mid = 0.0f32;
            for c in 0..self.coupled_chunks {
                if !self.active[c] {
                    continue;
                }
                let (y1, y2) = (self.y1[c], self.y2[c]);
                let y = o.sub(
                    o.sub(o.mul(self.a1[c], y1), o.mul(self.a2[c], y2)),
                    o.mul(o.mul(o.splat(stretch), self.stretch_c[c]), y1),
                );
                acc = o.add(acc, o.mul(self.gain[c], y));
                next = o.add(next, o.mul(o.mul(self.stretch_w[c], y), y));
                self.y2[c] = y1;
                self.y1[c] = y;
                if c == 0 && centre.is_some() {
                    mid = (0..LANES).map(|l| self.centre[l] * y[l]).sum();
                }
            }
            *sample += acc.iter().sum::<f32>();
            if let Some(centre) = centre.as_deref_mut() {
                centre[s] = mid;
            }
            stretch = next.iter().sum::<f32>().min(self.max_stretch);
            most = most.max(stretch);
        }
        self.stretch = stretch;
        self.stretch_most = self.stretch_most.max(most);
    }

    /// Every chunk a sample at a time, coupled through the plate's stress.
    #[inline(always)]
    fn process_stressed<O: LaneOps>(&mut self, o: O, out: &mut [f32], mut centre: Option<&mut [f32]>) {
        let Some(stress) = self.stress.as_mut() else {
            return;
        };
        // A strike or a damping change may have come since the last step.
        stress.prime(o, &self.a1, &self.a2, &self.y1, &self.y2);
        let mut most = 0.0f32;
        for (s, sample) in out.iter_mut().enumerate() {
            let (sum, level) = stress.step(o, &self.a1, &self.a2, &self.gain, &mut self.y1, &mut self.y2);
            *sample += sum;
            most = most.max(level);
            if let Some(centre) = centre.as_deref_mut() {
                centre[s] = (0..LANES).map(|l| self.centre[l] * self.y1[0][l]).sum();
            }
        }
        self.stress_most = self.stress_most.max(most);
    }

    #[inline(always)]
    fn process_first_with_centre(&mut self, acc: &mut [Lane], centre: &mut [f32]) {
        let (a1, a2, g, w) = (self.a1[0], self.a2[0], self.gain[0], self.centre);
        let (mut y1, mut y2) = (self.y1[0], self.y2[0]);
        for (acc_s, c_s) in acc.iter_mut().zip(centre.iter_mut()) {
            let mut y = [0.0f32; LANES];
            let mut c = 0.0;
            for l in 0..LANES {
                y[l] = a1[l] * y1[l] - a2[l] * y2[l];
                acc_s[l] += g[l] * y[l];
                c += w[l] * y[l];
            }
            *c_s = c;
            y2 = y1;
            y1 = y;
        }
        self.y1[0] = y1;
        self.y2[0] = y2;
    }

    #[inline(always)]
    fn sleep_if_silent(&mut self, c: usize) {
        let (y1, y2, g) = (&self.y1[c], &self.y2[c], &self.gain[c]);
        let (a1, a2) = (&self.a1[c], &self.a2[c]);
        let loud = (0..LANES).any(|l| {
            // The mode's amplitude, not its value now (a slow mode can be near a zero
            // crossing for both samples): y[n] = A cos(n theta + phi) gives
            // y1^2 + y2^2 - 2 cos(theta) y1 y2 = A^2 sin^2(theta) (damping within a sample
            // left out).
            let cos = a1[l] / (2.0 * a2[l].sqrt().max(1e-12));
            let sin2 = (1.0 - cos * cos).max(1e-12);
            let amp = ((y1[l] * y1[l] + y2[l] * y2[l] - 2.0 * cos * y1[l] * y2[l]).max(0.0) / sin2).sqrt();
            amp * g[l].abs() > self.silent_output || (self.keep_moving && amp > SILENT_DISPLACEMENT)
        });
        if !loud {
            self.active[c] = false;
            self.y1[c] = [0.0; LANES];
            self.y2[c] = [0.0; LANES];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sound::lanes::Portable;

    #[test]
    fn the_processors_own_lanes_and_plain_arrays_give_the_same_samples() {
        // A plate of 96 modes struck hard enough that its stress runs, then rings free.
        let n = 96;
        let freq: Vec<f64> = (0..n).map(|k| 200.0 * (80.0f64).powf(k as f64 / (n - 1) as f64)).collect();
        let slope2: Vec<f64> = freq.iter().map(|f| 0.06 * f).collect();
        let gains: Vec<f32> = (0..n).map(|k| 1.0 / (k as f32 + 1.0)).collect();
        let mut a = Bank::new(&gains, &[]);
        a.set_stress(Stress::new(&vec![0.2; n], &freq, &slope2, 5e8, 48_000.0, 3));
        for (k, f) in freq.iter().enumerate() {
            let th = 2.0 * std::f64::consts::PI * f / 48_000.0;
            let r = 0.9995f64;
            a.set_coefficients(k, (2.0 * r * th.cos()) as f32, (r * r) as f32);
            a.set_state(k, if k < 8 { 1e-3 } else { 0.0 }, 0.0);
        }
        a.wake_stretch();
        assert!(a.stressed, "the strike runs the stress");
        let mut b = a.clone();
        let mut acc = vec![[0.0; LANES]; 512];
        let (mut out_a, mut out_b) = (vec![0.0f32; 4096], vec![0.0f32; 4096]);
        for (oa, ob) in out_a.chunks_mut(512).zip(out_b.chunks_mut(512)) {
            a.process(oa, None, &mut acc);
            b.process_inner(Portable, ob, None, &mut acc);
        }
        assert!(out_a.iter().any(|v| v.abs() > 1e-4));
        assert_eq!(out_a, out_b);
    }

    #[test]
    fn block_size_does_not_change_the_output() {
        let gains: Vec<f32> = (0..19).map(|k| 1.0 / (k as f32 + 1.0)).collect();
        let mut a = Bank::new(&gains, &[]);
        for k in 0..19 {
            let (w, r) = (0.01 + 0.03 * k as f32, 0.9995f32);
            a.set_coefficients(k, 2.0 * r * w.cos(), r * r);
            a.set_state(k, 0.01, 0.0);
        }
        let mut b = a.clone();
        let mut acc = vec![[0.0; LANES]; 256];
        let mut out_a = vec![0.0; 1000];
        a.process(&mut out_a, None, &mut acc);
        let mut out_b = vec![0.0; 1000];
        for chunk in out_b.chunks_mut(7) {
            b.process(chunk, None, &mut acc);
        }
        assert_eq!(out_a, out_b);
        assert!(out_a.iter().any(|v| v.abs() > 1e-3));
    }

    #[test]
    fn decayed_modes_sleep_and_output_zero() {
        let mut bank = Bank::new(&[1.0; 8], &[]);
        for k in 0..8 {
            bank.set_coefficients(k, 2.0 * 0.9 * 0.3f32.cos(), 0.81);
            bank.set_state(k, 1e-3, 0.0);
        }
        let mut acc = vec![[0.0; LANES]; 512];
        let mut out = vec![0.0; 512];
        bank.process(&mut out, None, &mut acc);
        assert!(bank.is_silent());
        assert!(out[SLEEP_CHECK as usize * 3..].iter().all(|v| *v == 0.0));
    }
}
