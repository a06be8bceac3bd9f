//! The modes of a kit piece: frequencies, damping, modal masses and mode shapes.
//!
//! Membranes (fixed edge): mode (m, n) has shape J_m(j_mn r/a) cos(m theta) (and a sin twin for
//! m > 0) and frequency f0 j_mn / j_01, the ideal membrane's Bessel-zero ratios.
//! Plates (free edge, cymbals): shapes J_m(j'_mn r/a) cos(m theta) with j'_mn the zeros of J_m'
//! (antinode at the free edge), frequencies by Chladni's law f ~ (m + 2n)^p with n nodal circles,
//! detuned by a few percent per mode (a hammered cymbal is not a perfect plate).
//! Damping: decay rate sigma_k = (ln 1000 / T60) (f_k / f_0)^exponent, rising with frequency.

use super::bessel::{bessel_j, zeros_where, ZeroKind};
use crate::kit::{Piece, PieceKind};
use std::f64::consts::{LN_10, PI};

/// One modal oscillator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode {
    /// Nodal diameters.
    pub m: usize,
    /// Nodal circles (interior).
    pub n: usize,
    /// The sin twin of a degenerate pair (shape uses sin(m theta) instead of cos).
    pub sin: bool,
    /// Radial wavenumber: shape J_m(zero * r / a).
    pub zero: f64,
    pub freq_hz: f64,
    /// Decay rate (1/s) with no choke or hi-hat closing.
    pub sigma: f64,
    /// Modal mass, kg (areal density times the integral of the squared shape).
    pub mass_kg: f64,
    /// Gain from modal displacement (m) to output, including the pickup and radiation.
    pub out_gain: f64,
    /// How many modes of the piece this one stands for (1, or the stride where a dense band
    /// is thinned: its energy and its share of the head's give at the contact count for all).
    pub stands_for: f64,
    /// Integral of the squared slope of the mode shape over the surface, m^2 (the mode's
    /// share of the in-plane stretch per squared displacement, [`ModeSet::stretch`]).
    pub slope2: f64,
    /// How much of its shape at the strike point a strike drives: its mean over the contact
    /// patch ([`crate::kit::Piece::contact_radius_m`]), 2 J1(k b) / (k b); 1 for a point.
    pub patch: f64,
}

/// The modes of one piece, lowest frequency first.
#[derive(Debug, Clone)]
pub struct ModeSet {
    pub modes: Vec<Mode>,
    pub radius_m: f64,
    pub kind: PieceKind,
    /// The first `contact_modes` modes (a multiple of the bank's lane width, or all) move
    /// with the striker during a contact; the ones above are far above anything a 1-10 ms
    /// contact excites, so at the contact they only give as a static spring (residual
    /// compliance) and are rung afterwards by the contact force they felt.
    pub contact_modes: usize,
    /// The surface's stretch under large motion (Berger's approximation: the in-plane strain
    /// is its mean, (1 / 2A) integral |grad w|^2 = (1 / 2A) sum slope2_k q_k^2). The stretch
    /// energy is stretch / 4 (sum slope2 q^2)^2 and pulls mode k back with
    /// stretch (sum slope2 q^2) slope2_k q_k: a membrane's tension rises (a hard hit starts
    /// sharp, falls in pitch and leaves the stick sooner). Heads only (a plate's is
    /// [`ModeSet::stress`]); 0: linear.
    pub stretch: f64,
    /// A plate's in-plane stress constant (von Karman, [`super::stress::Stress`]): Berger's
    /// constant of the plate, whose `stretch` is then 0. 0: linear.
    pub stress: f64,
    /// J_m(x) for every order the modes have, tabulated every [`BESSEL_STEP`] in x up to the
    /// largest radial wavenumber (row m starts at m * `bessel_len`), so a strike finds a
    /// thousand mode shapes without evaluating a Bessel function.
    bessel: Vec<f32>,
    bessel_len: usize,
}

/// The outermost ring of a head that a strike drives, r / a: the head is clamped over the
/// bearing edge and held by the hoop, so the outer few per cent barely move (every mode
/// shape is 0 at r = a) and a stick landing there sounds the head through the hoop as here.
/// 0.93 is the kit's rim-zone radius; a strike at 0.93 is 5 dB quieter than at the centre.
pub const HEAD_EDGE_RHO: f64 = 0.93;

/// How far past its radius a contact point may lie and still be on the piece (the body's
/// contact points are on its colliders, whose edge is the radius to within rounding).
const OUTSIDE_TOLERANCE: f64 = 0.02;

/// Table step in x: linear interpolation errs by at most BESSEL_STEP^2 / 8 (|J''| <= 1).
const BESSEL_STEP: f64 = 1.0 / 16.0;

/// Young's modulus over density of polyester film (Mylar), m^2/s^2: E h from a head's areal
/// density.
const MYLAR_E_OVER_RHO: f64 = 4.5e9 / 1390.0;
/// Poisson's ratio of polyester film.
const MYLAR_POISSON: f64 = 0.38;
/// The same for cymbal bronze (B20).
const BRONZE_E_OVER_RHO: f64 = 110e9 / 8600.0;
const BRONZE_DENSITY: f64 = 8600.0;
/// Longitudinal (plate) wave speed in bronze, sqrt(E / (rho (1 - nu^2))), m/s.
const BRONZE_LONGITUDINAL_SPEED: f64 = 3800.0;
const SPEED_OF_SOUND: f64 = 343.0;
const BRONZE_POISSON: f64 = 0.34;

/// Lowest oscillators of a membrane kept one by one (every mode, each moving with the
/// striker); above them a dense band is thinned to fit `max_modes`.
const MEMBRANE_EXACT_MODES: usize = 320;

/// Where the sound is picked up: a point over the surface (fraction of radius, angle).
const PICKUP_RHO: f64 = 0.68;
const PICKUP_THETA: f64 = 0.93;
/// Output scale from modal velocity (m/s) to full scale. Light heads move far and radiate
/// little; heavy plates move little and radiate much: one constant per kind puts a full-velocity
/// stroke near full scale, and each piece's `gain_db` sets the mix.
pub const MEMBRANE_OUTPUT_SCALE: f64 = 0.042;
pub const PLATE_OUTPUT_SCALE: f64 = 0.045;

impl ModeSet {
    /// The modes of `piece`. Finding a thousand Bessel zeros takes milliseconds, so the
    /// sets of the last pieces asked for are kept (a render, an audition of many hits, or a
    /// test makes engines for the same kit over and over).
    pub fn for_piece(piece: &Piece) -> ModeSet {
        use std::sync::{Arc, Mutex};
        static KEPT: Mutex<Vec<(String, Arc<ModeSet>)>> = Mutex::new(Vec::new());
        const KEEP: usize = 32;
        let key = format!("{piece:?}");
        if let Some((_, set)) = KEPT.lock().unwrap_or_else(|e| e.into_inner()).iter().find(|(k, _)| *k == key) {
            return ModeSet::clone(set);
        }
        let set = Arc::new(ModeSet::build(piece));
        let mut kept = KEPT.lock().unwrap_or_else(|e| e.into_inner());
        if kept.len() >= KEEP {
            kept.remove(0);
        }
        kept.push((key, Arc::clone(&set)));
        ModeSet::clone(&set)
    }

    fn build(piece: &Piece) -> ModeSet {
        let mut modes = match piece.kind {
            PieceKind::Membrane => membrane_modes(piece),
            PieceKind::Plate => plate_modes(piece),
        };
        let scale = match piece.kind {
            PieceKind::Membrane => MEMBRANE_OUTPUT_SCALE,
            PieceKind::Plate => PLATE_OUTPUT_SCALE,
        };
        let level = 10f64.powf(piece.gain_db as f64 / 20.0) * scale;
        // Radiation: a head radiates as a piston: below k a = 1 (a wavelength longer than
        // its circumference) the pressure follows the head's acceleration, not its velocity,
        // so a tom's fundamental is weaker against its upper modes than its velocity says;
        // its modes with many nodal diameters radiate little. A plate below its coincidence
        // frequency radiates from its edge, more the higher the mode (efficiency about
        // sqrt(f / f_c), Maidanik), and fully above it.
        let small_source_hz = SPEED_OF_SOUND / (2.0 * PI * piece.radius_m as f64);
        let coincidence_hz = match piece.kind {
            PieceKind::Plate => {
                let h = piece.areal_density_kg_m2 as f64 / BRONZE_DENSITY;
                SPEED_OF_SOUND * SPEED_OF_SOUND / (1.8 * BRONZE_LONGITUDINAL_SPEED * h)
            }
            PieceKind::Membrane => f64::INFINITY,
        };
        for mode in &mut modes {
            let radiation = match piece.kind {
                PieceKind::Membrane => (mode.freq_hz / small_source_hz).min(1.0) / (1.0 + 0.5 * mode.m as f64),
                PieceKind::Plate => (mode.freq_hz / coincidence_hz).sqrt().min(1.0),
            };
            let pickup = shape(mode, PICKUP_RHO, PICKUP_THETA);
            mode.out_gain *= level * radiation * pickup * 2.0 * PI * mode.freq_hz;
        }
        let contact_modes = match piece.kind {
            PieceKind::Membrane => MEMBRANE_EXACT_MODES.min(modes.len()),
            PieceKind::Plate => modes.len(),
        };
        // Berger's approximation: the mean in-plane strain of a head displaced w is
        // (1 / 2A) integral |grad w|^2, and integral |grad w|^2 = sum M w^2 q^2 / T0, so the
        // tension rises by E h / (1 - nu) times the strain: relative rise
        // E h / (2 A (1 - nu) T0^2) sum M w^2 q^2.
        // integral |grad phi|^2 = (zero / a)^2 integral phi^2 (exact for a fixed-edge
        // membrane, close for the free plate's Bessel shapes), and integral phi^2 = M / rho_s.
        let (a, rho_s) = (piece.radius_m as f64, piece.areal_density_kg_m2 as f64);
        // The mean of a solution of the Helmholtz equation over a disc of radius b is its
        // value at the centre times 2 J1(k b) / (k b) (the mean-value theorem of the
        // Helmholtz equation): a membrane mode's radial wavenumber is zero / a.
        let b = match piece.kind {
            PieceKind::Membrane => piece.contact_radius_m as f64,
            PieceKind::Plate => 0.0,
        };
        for mode in &mut modes {
            mode.slope2 = (mode.zero / a).powi(2) * mode.mass_kg / rho_s;
            let x = mode.zero * b / a;
            mode.patch = if x < 1e-6 { 1.0 } else { 2.0 * bessel_j(1, x) / x };
        }
        let (e_over_rho, poisson) = match piece.kind {
            PieceKind::Membrane => (MYLAR_E_OVER_RHO, MYLAR_POISSON),
            PieceKind::Plate => (BRONZE_E_OVER_RHO, BRONZE_POISSON),
        };
        let berger = piece.stretch as f64 * e_over_rho * rho_s / (2.0 * PI * a * a * (1.0 - poisson));
        // A head's stretch is its tension's (Berger); a plate's is the von Karman stress.
        let (stretch, stress) = match piece.kind {
            PieceKind::Membrane => (berger, 0.0),
            PieceKind::Plate => (0.0, berger),
        };
        let m_max = modes.iter().map(|m| m.m).max().unwrap_or(0);
        let x_max = modes.iter().map(|m| m.zero).fold(0.0, f64::max);
        let bessel_len = (x_max / BESSEL_STEP).ceil() as usize + 2;
        let mut bessel = vec![0.0f32; (m_max + 1) * bessel_len];
        let mut row = vec![0.0; m_max + 1];
        for i in 0..bessel_len {
            super::bessel::bessel_j_all(i as f64 * BESSEL_STEP, &mut row);
            for (m, j) in row.iter().enumerate() {
                bessel[m * bessel_len + i] = *j as f32;
            }
        }
        ModeSet {
            modes,
            radius_m: piece.radius_m as f64,
            kind: piece.kind,
            contact_modes,
            stretch,
            stress,
            bessel,
            bessel_len,
        }
    }

    /// Where a strike at (x, y) metres from the centre drives the surface, as r / a: a head
    /// struck on its outer ring, over the bearing edge where the real drum's hoop sits (the
    /// body's head collider ends at the radius, so a stick landing on the drum's edge touches
    /// it there), drives the head as at [`HEAD_EDGE_RHO`]; a plate's free edge as at its edge.
    /// `None` outside the surface.
    fn struck_rho(&self, x_m: f64, y_m: f64) -> Option<f64> {
        let rho = (x_m * x_m + y_m * y_m).sqrt() / self.radius_m;
        if rho > 1.0 + OUTSIDE_TOLERANCE {
            return None;
        }
        Some(match self.kind {
            PieceKind::Membrane => rho.min(HEAD_EDGE_RHO),
            PieceKind::Plate => rho.min(1.0),
        })
    }

    /// Mode shape of mode `k` at the point (x, y) metres from the centre, where a strike there
    /// drives it ([`ModeSet::struck_rho`]); 0 outside the surface.
    pub fn shape_at(&self, k: usize, x_m: f64, y_m: f64) -> f64 {
        match self.struck_rho(x_m, y_m) {
            Some(rho) => shape(&self.modes[k], rho, y_m.atan2(x_m)),
            None => 0.0,
        }
    }

    /// Every mode's shape at the point (x, y), in mode order, handed to `f(k, shape)`; 0
    /// outside the surface. [`ModeSet::shape_at`]'s values, the radial factor interpolated
    /// in its table and cos(m theta), sin(m theta) by the angle-addition recurrence.
    pub fn shapes_at(&self, x_m: f64, y_m: f64, mut f: impl FnMut(usize, f64)) {
        let Some(rho) = self.struck_rho(x_m, y_m) else {
            (0..self.modes.len()).for_each(|k| f(k, 0.0));
            return;
        };
        let (s1, c1) = y_m.atan2(x_m).sin_cos();
        // (cos m theta, sin m theta) for m = 0, 1, 2, ... as the modes ask for them.
        let (mut m_now, mut cm, mut sm) = (0usize, 1.0f64, 0.0f64);
        for (k, mode) in self.modes.iter().enumerate() {
            if mode.m < m_now {
                (m_now, cm, sm) = (0, 1.0, 0.0);
            }
            while m_now < mode.m {
                (cm, sm) = (cm * c1 - sm * s1, sm * c1 + cm * s1);
                m_now += 1;
            }
            let pos = mode.zero * rho / BESSEL_STEP;
            let i = (pos as usize).min(self.bessel_len - 2);
            let t = &self.bessel[mode.m * self.bessel_len + i..mode.m * self.bessel_len + i + 2];
            let radial = t[0] as f64 + (pos - i as f64) * (t[1] as f64 - t[0] as f64);
            let angular = if mode.m == 0 {
                1.0
            } else if mode.sin {
                sm
            } else {
                cm
            };
            f(k, radial * angular);
        }
    }
}

/// Mode shape at (rho = r / a, theta).
pub fn shape(mode: &Mode, rho: f64, theta: f64) -> f64 {
    bessel_j(mode.m, mode.zero * rho) * angular(mode, theta)
}

/// The angular factor of a mode shape: 1, cos(m theta) or sin(m theta).
fn angular(mode: &Mode, theta: f64) -> f64 {
    if mode.m == 0 {
        1.0
    } else if mode.sin {
        (mode.m as f64 * theta).sin()
    } else {
        (mode.m as f64 * theta).cos()
    }
}

fn decay_rate(piece: &Piece, freq_hz: f64) -> f64 {
    let sigma0 = 3.0 * LN_10 / piece.decay_s as f64;
    sigma0 * (freq_hz / piece.fundamental_hz as f64).powf(piece.damping_exponent as f64)
}

/// Push a mode, or its cos and sin twins for m > 0, until `max` oscillators.
fn push_twins(out: &mut Vec<Mode>, mode: Mode, max: usize) {
    for sin in [false, true] {
        if out.len() < max && (!sin || mode.m > 0) {
            out.push(Mode { sin, ..mode });
        }
    }
}

fn membrane_modes(piece: &Piece) -> Vec<Mode> {
    const J01: f64 = 2.404_825_557_695_773;
    // Every mode up to max_hz: Weyl's law gives about j^2 / 4 oscillators below j.
    let j_max = J01 * piece.max_hz as f64 / piece.fundamental_hz as f64;
    let mut found = zeros_where(ZeroKind::Value, j_max as usize + 1, j_max, |_, _| true);
    found.sort_by(|a, b| a.2.total_cmp(&b.2));
    let (rho_s, a) = (piece.areal_density_kg_m2 as f64, piece.radius_m as f64);
    let mut all = Vec::new();
    for (m, n, j) in found {
        let freq_hz = piece.fundamental_hz as f64 * j / J01;
        let mode = Mode {
            m,
            n,
            sin: false,
            zero: j,
            freq_hz,
            sigma: decay_rate(piece, freq_hz),
            mass_kg: 0.0,
            out_gain: 1.0,
            stands_for: 1.0,
            slope2: 0.0,
            patch: 1.0,
        };
        push_twins(&mut all, mode, usize::MAX);
    }
    // Modal mass, for the modes kept: rho_s a^2 (2 pi or pi) J_(m+1)(j)^2 / 2.
    let with_mass = |mut modes: Vec<Mode>| {
        for mode in &mut modes {
            let angular = if mode.m == 0 { 2.0 * PI } else { PI };
            mode.mass_kg = rho_s * a * a * angular * 0.5 * bessel_j(mode.m + 1, mode.zero).powi(2);
        }
        modes
    };
    // The lowest oscillators one by one; above them every `stride`-th (pairs kept whole),
    // each standing for the modes beside it, so the band up to max_hz stays covered.
    let max = piece.max_modes.max(1);
    let exact = MEMBRANE_EXACT_MODES.min(max).min(all.len());
    let rest = all.len() - exact;
    let room = max - exact;
    if rest <= room {
        return with_mass(all);
    }
    let mut modes: Vec<Mode> = all[..exact].to_vec();
    if room == 0 {
        return with_mass(modes);
    }
    // The oscillators kept with a given stride: every `stride`-th, a cos twin with its sin.
    let pick = |stride: usize| {
        let mut kept = Vec::new();
        let mut i = exact;
        while i < all.len() {
            let group = if all[i].m > 0 && i + 1 < all.len() && all[i + 1].sin { 2 } else { 1 };
            kept.extend(i..i + group);
            i += stride.max(group);
            if i < all.len() && all[i].sin {
                i += 1;
            }
        }
        kept
    };
    let mut stride = rest.div_ceil(room).max(1);
    let mut kept = pick(stride);
    while kept.len() > room {
        stride += 1;
        kept = pick(stride);
    }
    // Each kept oscillator stands for its share of the band it covers.
    let share = rest as f64 / kept.len() as f64;
    modes.extend(kept.into_iter().map(|i| Mode { out_gain: share.sqrt(), stands_for: share, ..all[i] }));
    with_mass(modes)
}

/// Deterministic detuning in [-1, 1) for mode (m, n): a hash, so renders are reproducible.
fn detune(m: usize, n: usize) -> f64 {
    let mut h = (m as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ (n as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    h ^= h >> 29;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 32;
    (h % 20_000) as f64 / 10_000.0 - 1.0
}

fn plate_modes(piece: &Piece) -> Vec<Mode> {
    const DETUNE: f64 = 0.03;
    const SPLIT: f64 = 0.015;
    let (f1, p) = (piece.fundamental_hz as f64, piece.chladni_exponent as f64);
    let freq = |m: usize, n: usize| f1 * ((m + 2 * n) as f64 / 2.0).powf(p) * (1.0 + DETUNE * detune(m, n));
    // Every (m, n) of a free plate below max_hz (m + 2n >= 2; (1, 0) is a rigid tilt).
    let mut all: Vec<(usize, usize, f64)> = Vec::new();
    let k_max = (2.0 * (piece.max_hz as f64 / f1).powf(1.0 / p) + 1.0) as usize;
    for k in 2..=k_max {
        for n in 0..=k / 2 {
            let m = k - 2 * n;
            if m == 1 && n == 0 {
                continue;
            }
            let f = freq(m, n);
            if f <= piece.max_hz as f64 {
                all.push((m, n, f));
            }
        }
    }
    all.sort_by(|a, b| a.2.total_cmp(&b.2));
    // Oscillators: twins count twice. Keep every `stride`-th mode so the band stays covered,
    // and let each kept mode stand for the energy of those dropped beside it.
    let oscillators: usize = all.iter().map(|&(m, _, _)| if m > 0 { 2 } else { 1 }).sum();
    let stride = oscillators.div_ceil(piece.max_modes).max(1);
    let kept: Vec<_> = all.into_iter().step_by(stride).collect();
    let m_max = kept.iter().map(|k| k.0).max().unwrap_or(0);
    let n_max = kept.iter().map(|k| k.1).max().unwrap_or(0);
    // Radial wavenumber of n nodal circles: the (n+1)-th positive zero of J_m' (for m = 0 the
    // trivial zero at 0 is not counted, so the n-th).
    let x_max = m_max as f64 + PI * (n_max as f64 + 2.0) + 4.0;
    let wanted: std::collections::HashSet<(usize, usize)> =
        kept.iter().map(|&(m, n, _)| (m, zero_index(m, n))).collect();
    let want = |m: usize, i: usize| wanted.contains(&(m, i));
    let zs = zeros_where(ZeroKind::Slope, m_max, x_max, want);
    let found: std::collections::HashMap<(usize, usize), f64> = zs.iter().map(|&(m, i, z)| ((m, i), z)).collect();
    let (rho_s, a) = (piece.areal_density_kg_m2 as f64, piece.radius_m as f64);
    let mut modes = Vec::new();
    for (m, n, freq_hz) in kept {
        let Some(&zero) = found.get(&(m, zero_index(m, n))) else {
            continue;
        };
        let angular = if m == 0 { 2.0 * PI } else { PI };
        let radial = 0.5 * (1.0 - (m * m) as f64 / (zero * zero)) * bessel_j(m, zero).powi(2);
        let mass_kg = rho_s * a * a * angular * radial;
        let mode = Mode {
            m,
            n,
            sin: false,
            zero,
            freq_hz,
            sigma: decay_rate(piece, freq_hz),
            mass_kg,
            out_gain: (stride as f64).sqrt(),
            stands_for: stride as f64,
            slope2: 0.0,
            patch: 1.0,
        };
        push_twins(&mut modes, mode, usize::MAX);
        // A hammered cymbal is not axisymmetric: the cos and sin twins of a pair split
        // (by up to 1.5 %), so a pair beats and the spectrum fills twice as densely.
        if let Some(last) = modes.last_mut().filter(|m| m.sin) {
            last.freq_hz *= 1.0 + SPLIT * detune(last.n + 101, last.m + 7);
            last.sigma = decay_rate(piece, last.freq_hz);
        }
    }
    modes.truncate(piece.max_modes);
    modes
}

/// Index among the positive zeros of J_m' of the shape with n nodal circles.
fn zero_index(m: usize, n: usize) -> usize {
    if m == 0 {
        n - 1
    } else {
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kit::Kit;

    #[test]
    fn shapes_at_a_point_equal_each_mode_shape() {
        let kit = Kit::builtin_default();
        for id in ["snare", "ride"] {
            let set = ModeSet::for_piece(kit.piece(id).unwrap());
            for (x, y) in [(0.0, 0.0), (0.03, -0.05), (-0.1, 0.02), (0.5, 0.5)] {
                let mut n = 0;
                set.shapes_at(x, y, |k, phi| {
                    // The table's interpolation error bound, plus f32 rounding.
                    let tol = BESSEL_STEP * BESSEL_STEP / 8.0 + 1e-6;
                    let exact = set.shape_at(k, x, y);
                    assert!((phi - exact).abs() <= tol, "{id} mode {k} at ({x}, {y}): {phi} vs {exact}");
                    n += 1;
                });
                assert_eq!(n, set.modes.len());
            }
        }
    }

    /// A mode's patch factor is its shape's mean over the contact disc: the disc average,
    /// summed numerically around an off-centre point of a tom, is the factor times the
    /// shape at the point, for modes from the fundamental to ones shorter than the patch.
    #[test]
    fn a_modes_patch_factor_is_its_mean_over_the_contact_disc() {
        let piece = Piece { contact_radius_m: 0.01, ..Kit::builtin_default().piece("tom1").unwrap().clone() };
        let set = ModeSet::for_piece(&piece);
        let (b, a) = (0.01, set.radius_m);
        let (x0, y0) = (0.03, -0.02);
        let (rings, spokes) = (40, 64);
        for k in (0..set.modes.len()).step_by(37) {
            let mode = &set.modes[k];
            let at = |x: f64, y: f64| shape(mode, (x * x + y * y).sqrt() / a, y.atan2(x));
            // Midpoint rule in r (weight r dr) and theta over the disc.
            let mut sum = 0.0;
            for i in 0..rings {
                let r = b * (i as f64 + 0.5) / rings as f64;
                for j in 0..spokes {
                    let t = 2.0 * PI * j as f64 / spokes as f64;
                    sum += at(x0 + r * t.cos(), y0 + r * t.sin()) * r;
                }
            }
            let mean = sum * (b / rings as f64) * (2.0 * PI / spokes as f64) / (PI * b * b);
            let want = mode.patch * at(x0, y0);
            assert!((mean - want).abs() < 2e-3, "mode {k} ({:.0} Hz): mean {mean}, patch x shape {want}", mode.freq_hz);
        }
        assert!(set.modes.iter().any(|m| m.patch < 0.2), "some modes are shorter than a 1 cm patch");
        assert_eq!(ModeSet::for_piece(Kit::builtin_default().piece("ride").unwrap()).modes[5].patch, 1.0);
    }
}
