//! A cymbal's geometric nonlinearity: the in-plane stress of a plate struck hard enough to
//! move by its own thickness, which passes energy from the struck low modes to the high
//! ones over the first tens of milliseconds (the wash).
//!
//! The von Karman plate in modal form (Ducceschi & Touzé, "Modal approach for nonlinear
//! vibrations of damped impacted plates: application to sound synthesis of gongs and
//! cymbals", JSV 344, 2015): each in-plane stress mode s has an amplitude
//! eta_s = sum_pq H^s_pq q_p q_q, a quadratic form of the transverse modes, the stress energy
//! is 1/2 kappa sum_s eta_s^2, and mode k feels -kappa sum_s eta_s d(eta_s)/dq_k. Here the
//! coupling tensors H^s, which for a real cymbal depend on its shape and hammering, are stood
//! in for by [`CHANNELS`] random rank-two forms, eta_s = A_s B_s with A_s = sum a_sk q_k and
//! B_s = sum b_sk q_k, whose weights have the magnitude of Berger's terms (a_sk = r
//! sqrt(slope2_k), r of unit variance): one mode alone stiffens as Berger's stretch says,
//! and every product of modes drives every other mode, so a hard hit's energy spreads into
//! the dense modes above it. The force costs four multiply-adds per mode and channel a
//! sample.
//!
//! The step conserves energy whatever the amplitude (a discrete gradient after Bilbao's
//! schemes for the von Karman plate): the stress of a half step, eta^(n+1/2) =
//! (A^(n+1) B^n + A^n B^(n+1)) / 2, is linear in the next displacements, so each sample
//! solves a positive definite system of one row a channel instead of stepping the force explicitly (which
//! goes unstable in the plate's stiff high modes long before the stress is audible).

// The channels and lanes are small fixed arrays indexed together, as in the bank.
#![allow(clippy::needless_range_loop)]

use super::bank::{Lane, LANES};
use super::lanes::LaneOps;
use crate::rng::Rng;

/// Stress channels (rank-two forms).
pub const CHANNELS: usize = 2;

/// The coupling stops once it stiffens the stiffest-coupled mode by less than this (1 %:
/// below it the energy still moving changes a crash's tail flatness by under 5 %, and the
/// coupled step costs five times the free one).
const STRESS_OFF: f64 = 1e-2;

/// The weights of one chunk of eight modes in every channel.
#[derive(Debug, Clone)]
struct ChunkWeights {
    /// Weights of each mode's displacement in A_s and B_s.
    a: [Lane; CHANNELS],
    b: [Lane; CHANNELS],
    /// d_k, the change of each mode's next displacement per unit of force.
    d: Lane,
}

/// The stress channels of one plate and their state.
#[derive(Debug, Clone)]
pub struct Stress {
    chunks: Vec<ChunkWeights>,
    kappa: f32,
    /// P_ij = sum_k d_k u_ik u_jk over the weight vectors u_2s = a_s, u_2s+1 = b_s.
    p: [[f32; 2 * CHANNELS]; 2 * CHANNELS],
    /// sum_s A_s^2 + B_s^2 below which the modes run uncoupled.
    off: f32,
    /// A_s and B_s of the last sample, and the stress of the half step before it.
    ab: [[f32; 2]; CHANNELS],
    eta: [f32; CHANNELS],
    /// Each mode's free step a1 y1 - a2 y2 of the next sample, and its forms (A_s and B_s
    /// of it), left by the last step or by [`Stress::prime`].
    free: Vec<Lane>,
    free_forms: [[f32; 2]; CHANNELS],
}

impl Stress {
    /// Channels for modes of masses `mass_kg`, frequencies `freq_hz` and squared-slope
    /// integrals `slope2` at `sample_rate_hz`; `stretch` is Berger's constant of the plate
    /// ([`super::modes::ModeSet::stretch`]'s formula), `seed` picks the forms.
    pub fn new(
        mass_kg: &[f64],
        freq_hz: &[f64],
        slope2: &[f64],
        stretch: f64,
        sample_rate_hz: f64,
        seed: u64,
    ) -> Stress {
        let n = mass_kg.len();
        let t = 1.0 / sample_rate_hz;
        // One mode alone: 1/2 kappa sum_s (r r' slope2 q^2)^2 = CHANNELS kappa / 2 slope2^2 q^4
        // on average, Berger's stretch / 4 slope2^2 q^4.
        let kappa = stretch / (2.0 * CHANNELS as f64);
        let mut rng = Rng::new(seed);
        let zero = ChunkWeights { a: [[0.0; LANES]; CHANNELS], b: [[0.0; LANES]; CHANNELS], d: [0.0; LANES] };
        let mut chunks = vec![zero; n.div_ceil(LANES)];
        let mut p = [[0.0f64; 2 * CHANNELS]; 2 * CHANNELS];
        let mut most: f64 = 0.0;
        for k in 0..n {
            let w = 2.0 * std::f64::consts::PI * freq_hz[k];
            let d = t * (w * t).sin() / (mass_kg[k] * w);
            let root = slope2[k].max(0.0).sqrt();
            let (c, l) = (k / LANES, k % LANES);
            let mut u = [0.0f64; 2 * CHANNELS];
            for x in u.iter_mut() {
                *x = rng.sym() as f64 * 3f64.sqrt() * root;
            }
            for s in 0..CHANNELS {
                let (a, b) = (u[2 * s], u[2 * s + 1]);
                chunks[c].a[s][l] = a as f32;
                chunks[c].b[s][l] = b as f32;
            }
            chunks[c].d[l] = d as f32;
            for i in 0..2 * CHANNELS {
                for j in 0..2 * CHANNELS {
                    p[i][j] += d * u[i] * u[j];
                }
            }
            // The stiffening of mode k at sum_s A^2 + B^2 = 1, re its own stiffness.
            let ab2 = u.iter().map(|x| x * x).fold(0.0, f64::max);
            most = most.max(2.0 * kappa * ab2 / (mass_kg[k] * w * w));
        }
        let off = STRESS_OFF / most.max(1e-300);
        Stress {
            chunks,
            kappa: kappa as f32,
            p: p.map(|row| row.map(|x| x as f32)),
            off: off as f32,
            ab: [[0.0; 2]; CHANNELS],
            eta: [0.0; CHANNELS],
            free: vec![[0.0; LANES]; n.div_ceil(LANES)],
            free_forms: [[0.0; 2]; CHANNELS],
        }
    }

    /// A_s and B_s of the displacements `y`.
    fn forms(&self, y: &[Lane]) -> [[f32; 2]; CHANNELS] {
        let mut sums = [[[0.0f32; LANES]; 2]; CHANNELS];
        for (w, y) in self.chunks.iter().zip(y) {
            for s in 0..CHANNELS {
                for l in 0..LANES {
                    sums[s][0][l] += w.a[s][l] * y[l];
                    sums[s][1][l] += w.b[s][l] * y[l];
                }
            }
        }
        sums.map(|[a, b]| [a.iter().sum(), b.iter().sum()])
    }

    /// Take the state from the last two displacements `y1` and `y2` (after a strike); whether
    /// the modes should run coupled.
    pub fn wake(&mut self, y1: &[Lane], y2: &[Lane]) -> bool {
        let (now, before) = (self.forms(y1), self.forms(y2));
        for s in 0..CHANNELS {
            self.eta[s] = 0.5 * (now[s][0] * before[s][1] + before[s][0] * now[s][1]);
        }
        self.ab = now;
        self.level() > self.off
    }

    /// sum_s A_s^2 + B_s^2 now.
    pub fn level(&self) -> f32 {
        self.ab.iter().map(|[a, b]| a * a + b * b).sum()
    }

    /// The stress energy of the last half step, 1/2 kappa sum_s eta_s^2, joules (the modes'
    /// energy plus this is what the step keeps).
    pub fn energy_j(&self) -> f64 {
        0.5 * self.kappa as f64 * self.eta.iter().map(|e| (*e as f64).powi(2)).sum::<f64>()
    }

    /// The level under which the modes run uncoupled.
    pub fn off(&self) -> f32 {
        self.off
    }

    /// The free step of the next sample from the last two displacements and the recursion's
    /// coefficients; before the first [`Stress::step`] of a run and whenever either may have
    /// changed since the last step (a strike, a damping change).
    #[inline(always)]
    pub fn prime<O: LaneOps>(&mut self, o: O, a1: &[Lane], a2: &[Lane], y1: &[Lane], y2: &[Lane]) {
        let mut sa = [[0.0f32; LANES]; CHANNELS];
        let mut sb = [[0.0f32; LANES]; CHANNELS];
        for (c, w) in self.chunks.iter().enumerate() {
            let r = o.sub(o.mul(a1[c], y1[c]), o.mul(a2[c], y2[c]));
            self.free[c] = r;
            for s in 0..CHANNELS {
                sa[s] = o.add(sa[s], o.mul(w.a[s], r));
                sb[s] = o.add(sb[s], o.mul(w.b[s], r));
            }
        }
        self.free_forms = std::array::from_fn(|s| [sa[s].iter().sum(), sb[s].iter().sum()]);
    }

    /// One sample of every chunk, coupled: y = a1 y1 - a2 y2 - d F with F the stress force
    /// of the step; returns the sample's output (gains `gain`) and the new level. The new
    /// displacements are written over the oldest and the two vectors swapped (no copy). One
    /// pass over the modes: the free step of the sample after is taken on the way (the
    /// weights are read once a sample; memory, not arithmetic, bounds this loop).
    #[inline(always)]
    #[allow(clippy::ptr_arg)] // swapped whole
    pub fn step<O: LaneOps>(
        &mut self,
        o: O,
        a1: &[Lane],
        a2: &[Lane],
        gain: &[Lane],
        y1: &mut Vec<Lane>,
        y2: &mut Vec<Lane>,
    ) -> (f32, f32) {
        let ar = self.free_forms;
        // The force is -kappa mu(eta) g_s with g_s = a_s B_s + b_s A_s and mu(eta) the mean
        // of the half steps' stresses, eta^(n+1/2) = (g_s . y) / 2: with z_s = g_s . y the
        // system (I + kappa / 4 G) z = g . r - kappa / 2 G eta^(n-1/2), G_ts = g_t^T D g_s.
        let (ab, p, kappa) = (self.ab, &self.p, self.kappa);
        let lam = |s: usize| [ab[s][1], ab[s][0]]; // coefficients of a_s and b_s in g_s
        let mut g = [[0.0f32; CHANNELS]; CHANNELS];
        for t in 0..CHANNELS {
            for s in 0..CHANNELS {
                let (lt, ls) = (lam(t), lam(s));
                let mut v = 0.0;
                for i in 0..2 {
                    for j in 0..2 {
                        v += lt[i] * ls[j] * p[2 * t + i][2 * s + j];
                    }
                }
                g[t][s] = v;
            }
        }
        let mut m = [[0.0f32; CHANNELS]; CHANNELS];
        let mut rhs = [0.0f32; CHANNELS];
        for t in 0..CHANNELS {
            let lt = lam(t);
            rhs[t] = lt[0] * ar[t][0] + lt[1] * ar[t][1];
            for s in 0..CHANNELS {
                m[t][s] = kappa / 4.0 * g[t][s] + if s == t { 1.0 } else { 0.0 };
                rhs[t] -= kappa / 2.0 * g[t][s] * self.eta[s];
            }
        }
        let z = solve_spd(m, rhs);
        let mut coef = [0.0f32; CHANNELS];
        for s in 0..CHANNELS {
            coef[s] = kappa / 4.0 * z[s] + kappa / 2.0 * self.eta[s];
            if !coef[s].is_finite() {
                coef[s] = 0.0;
            }
        }
        // The step, y = r - D sum_s coef_s g_s, and the next sample's free step
        // a1 y - a2 y1 with its forms, whole lanes by value (sums in registers).
        let ca: [f32; CHANNELS] = std::array::from_fn(|s| coef[s] * lam(s)[0]);
        let cb: [f32; CHANNELS] = std::array::from_fn(|s| coef[s] * lam(s)[1]);
        let mut acc = [0.0f32; LANES];
        let mut sa = [[0.0f32; LANES]; CHANNELS];
        let mut sb = [[0.0f32; LANES]; CHANNELS];
        for (c, w) in self.chunks.iter().enumerate() {
            let mut f = [0.0f32; LANES];
            for s in 0..CHANNELS {
                f = o.add(f, o.add(o.mul(o.splat(ca[s]), w.a[s]), o.mul(o.splat(cb[s]), w.b[s])));
            }
            let y = o.sub(self.free[c], o.mul(w.d, f));
            acc = o.add(acc, o.mul(gain[c], y));
            let r = o.sub(o.mul(a1[c], y), o.mul(a2[c], y1[c]));
            self.free[c] = r;
            for s in 0..CHANNELS {
                sa[s] = o.add(sa[s], o.mul(w.a[s], r));
                sb[s] = o.add(sb[s], o.mul(w.b[s], r));
            }
            y2[c] = y;
        }
        std::mem::swap(y1, y2);
        self.free_forms = std::array::from_fn(|s| [sa[s].iter().sum(), sb[s].iter().sum()]);
        // The new forms without a pass: u_i . y = u_i . r - sum_s (ca_s P_i,2s + cb_s P_i,2s+1).
        let mut level = 0.0;
        let mut next = [[0.0f32; 2]; CHANNELS];
        for t in 0..CHANNELS {
            for i in 0..2 {
                let mut v = ar[t][i];
                for s in 0..CHANNELS {
                    v -= ca[s] * p[2 * t + i][2 * s] + cb[s] * p[2 * t + i][2 * s + 1];
                }
                next[t][i] = v;
                level += v * v;
            }
            self.eta[t] = 0.5 * (next[t][0] * ab[t][1] + ab[t][0] * next[t][1]);
        }
        self.ab = next;
        if !level.is_finite() {
            // Rounding can never make the step diverge at a stick's amplitudes; should an
            // absurd input do it, the plate falls silent rather than ring NaN.
            for (a, b) in y1.iter_mut().zip(y2.iter_mut()) {
                (*a, *b) = ([0.0; LANES], [0.0; LANES]);
            }
            (self.ab, self.eta) = ([[0.0; 2]; CHANNELS], [0.0; CHANNELS]);
            self.free.fill([0.0; LANES]);
            self.free_forms = [[0.0; 2]; CHANNELS];
            return (0.0, 0.0);
        }
        (acc.iter().sum(), level)
    }
}

/// Solve m x = b for a symmetric positive definite m (Cholesky).
#[inline(always)]
fn solve_spd(m: [[f32; CHANNELS]; CHANNELS], b: [f32; CHANNELS]) -> [f32; CHANNELS] {
    let mut l = [[0.0f32; CHANNELS]; CHANNELS];
    for i in 0..CHANNELS {
        for j in 0..=i {
            let mut v = m[i][j];
            for k in 0..j {
                v -= l[i][k] * l[j][k];
            }
            l[i][j] = if i == j { v.max(1e-30).sqrt() } else { v / l[j][j] };
        }
    }
    let mut y = [0.0f32; CHANNELS];
    for i in 0..CHANNELS {
        let mut v = b[i];
        for k in 0..i {
            v -= l[i][k] * y[k];
        }
        y[i] = v / l[i][i];
    }
    let mut x = [0.0f32; CHANNELS];
    for i in (0..CHANNELS).rev() {
        let mut v = y[i];
        for k in i + 1..CHANNELS {
            v -= l[k][i] * x[k];
        }
        x[i] = v / l[i][i];
    }
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    const RATE: f64 = 48_000.0;
    const MODES: usize = 96;
    /// Berger's constant of an 18" bronze plate 1 mm thick, E h / (2 pi a^2 (1 - nu)), N/m.
    const STRETCH: f64 = 5e8;
    /// The struck modes' amplitude: a plate's thickness.
    const AMP: f32 = 1e-3;

    /// Undamped modes from 200 Hz to 16 kHz, a plate's masses and slopes, the lowest eight
    /// displaced by `amp` (metres); returns (stress, a1, a2, y1, y2, freq, mass).
    #[allow(clippy::type_complexity)]
    fn plate(stretch: f64, amp: f32) -> (Stress, Vec<Lane>, Vec<Lane>, Vec<Lane>, Vec<Lane>, Vec<f64>, Vec<f64>) {
        let freq: Vec<f64> = (0..MODES).map(|k| 200.0 * (80.0f64).powf(k as f64 / (MODES - 1) as f64)).collect();
        let mass = vec![0.2; MODES];
        // An 18" bronze plate's: slope2 = (wavenumber)^2 M / rho_s, the wavenumber squared
        // rising with frequency.
        let slope2: Vec<f64> = freq.iter().map(|f| 0.06 * f).collect();
        let stress = Stress::new(&mass, &freq, &slope2, stretch, RATE, 7);
        let chunks = MODES / LANES;
        let (mut a1, a2) = (vec![[0.0; LANES]; chunks], vec![[1.0; LANES]; chunks]);
        let (mut y1, mut y2) = (vec![[0.0; LANES]; chunks], vec![[0.0; LANES]; chunks]);
        for k in 0..MODES {
            let th = 2.0 * std::f64::consts::PI * freq[k] / RATE;
            a1[k / LANES][k % LANES] = (2.0 * th.cos()) as f32;
            if k < 8 {
                y1[0][k] = amp;
                y2[0][k] = amp * th.cos() as f32;
            }
        }
        (stress, a1, a2, y1, y2, freq, mass)
    }

    /// Each mode's energy from its last two displacements, as the step keeps it:
    /// (y1^2 + y2^2 - 2 cos(w T) y1 y2) / 2d with d = T sin(w T) / (M w): for slow modes
    /// 1/2 M (v^2 + w^2 q^2); fast ones weigh a little differently, as the recursion maps a
    /// force.
    fn energies(y1: &[Lane], y2: &[Lane], freq: &[f64], mass: &[f64]) -> Vec<f64> {
        (0..MODES)
            .map(|k| {
                let w = 2.0 * std::f64::consts::PI * freq[k];
                let th = w / RATE;
                let d = th.sin() / (RATE * mass[k] * w);
                let (a, b) = (y1[k / LANES][k % LANES] as f64, y2[k / LANES][k % LANES] as f64);
                (a * a + b * b - 2.0 * th.cos() * a * b) / (2.0 * d)
            })
            .collect()
    }

    /// The modes' energies before and after, the total energy (modes and stress) before and
    /// after, and the largest total on the way.
    fn run(stretch: f64, amp: f32, samples: usize) -> (Vec<f64>, Vec<f64>, f64, f64, f64) {
        let (mut stress, a1, a2, mut y1, mut y2, freq, mass) = plate(stretch, amp);
        let coupled = stress.wake(&y1, &y2);
        assert_eq!(coupled, stretch > 0.0);
        stress.prime(crate::sound::lanes::Portable, &a1, &a2, &y1, &y2);
        let before = energies(&y1, &y2, &freq, &mass);
        let e0 = before.iter().sum::<f64>() + stress.energy_j();
        let gain = vec![[1.0; LANES]; MODES / LANES];
        let mut most: f64 = 0.0;
        for _ in 0..samples {
            let (out, _) = stress.step(crate::sound::lanes::Portable, &a1, &a2, &gain, &mut y1, &mut y2);
            assert!(out.is_finite());
            most = most.max(energies(&y1, &y2, &freq, &mass).iter().sum::<f64>() + stress.energy_j());
        }
        let after = energies(&y1, &y2, &freq, &mass);
        let e1 = after.iter().sum::<f64>() + stress.energy_j();
        (before, after, e0, e1, most)
    }

    #[test]
    fn a_hard_hit_spreads_its_energy_into_the_high_modes_and_makes_none() {
        // Linear: the struck modes keep their energy and nothing reaches the others.
        let (before, after, _, _, _) = run(0.0, AMP, 4_800);
        let high = |e: &[f64]| e[16..].iter().sum::<f64>();
        assert!(high(&after) < 1e-12 * before.iter().sum::<f64>());
        // Stressed: a third or more of the energy passes above the struck band within 0.1 s,
        // and the total, modes and stress, stays what the strike gave to 1 %.
        let (_, after, e0, e1, most) = run(STRETCH, AMP, 4_800);
        eprintln!("high {:.3e} of {e1:.3e}, from {e0:.3e}, most {most:.3e}", high(&after));
        assert!(high(&after) > 0.3 * e1, "{:.3e} of {e1:.3e} above the struck modes", high(&after));
        assert!((e1 / e0 - 1.0).abs() < 0.01, "energy {e0:.4e} -> {e1:.4e}");
        assert!(most < 1.01 * e0, "energy rose to {most:.4e} from {e0:.4e}");
    }

    #[test]
    fn a_much_harder_hit_stays_bounded() {
        // Thirty times the thickness (3 cm, a plate bent far past any stick's doing): the
        // explicit step would explode in the stiff high modes; this one keeps its energy.
        let (_, _, e0, _, most) = run(STRETCH, 30.0 * AMP, 4_800);
        assert!(most.is_finite() && most < 1.5 * e0, "energy rose to {most:.4e} from {e0:.4e}");
    }
}
