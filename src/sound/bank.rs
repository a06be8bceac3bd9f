//! The modal resonator bank: each mode is an exact two-pole recursion of a damped oscillator,
//! y[n] = a1 y[n-1] - a2 y[n-2], a1 = 2 e^(-sigma T) cos(omega_d T), a2 = e^(-2 sigma T).
//! Modes sit in lanes of eight; each lane keeps its own output accumulator per sample, summed
//! across lanes once per block, so the inner loop vectorises, and chunks of eight run in pairs
//! so that one chunk's recursion runs while the other's waits on its multiply. Chunks of eight modes that have
//! decayed below audibility sleep until the next strike.

/// Modes per chunk.
pub const LANES: usize = 8;
/// Eight modes, one per lane.
pub type Lane = [f32; LANES];

/// A chunk sleeps when every mode's output is below this (about -120 dBFS) ...
const SILENT_OUTPUT: f32 = 1e-6;
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
}

/// Chunks run side by side in the inner loop.
const GROUP: usize = 2;

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
        }
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
    pub fn process(&mut self, out: &mut [f32], mut centre: Option<&mut [f32]>, acc: &mut [Lane]) {
        let mut i = 0;
        while i < out.len() {
            let to_check = (SLEEP_CHECK - self.clock % SLEEP_CHECK) as usize;
            let end = out.len().min(i + to_check);
            self.process_segment(&mut out[i..end], centre.as_deref_mut().map(|c| &mut c[i..end]), acc);
            self.clock += (end - i) as u64;
            if self.clock.is_multiple_of(SLEEP_CHECK) {
                for c in 0..self.active.len() {
                    if self.active[c] {
                        self.sleep_if_silent(c);
                    }
                }
            }
            i = end;
        }
    }

    fn process_segment(&mut self, out: &mut [f32], centre: Option<&mut [f32]>, acc: &mut [Lane]) {
        let n = out.len();
        let acc = &mut acc[..n];
        acc.fill([0.0; LANES]);
        let mut first = 0;
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

    fn sleep_if_silent(&mut self, c: usize) {
        let (y1, y2, g) = (&self.y1[c], &self.y2[c], &self.gain[c]);
        let loud = (0..LANES).any(|l| {
            let y = y1[l].abs().max(y2[l].abs());
            y * g[l].abs() > SILENT_OUTPUT || y > SILENT_DISPLACEMENT
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
