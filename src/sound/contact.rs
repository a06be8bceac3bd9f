//! The Hertz contact at audio rate: a striking mass meets the surface's modal displacement at
//! the strike point, F = k c^alpha while the compression c > 0. The contact is integrated at a
//! multiple of the sample rate with Strang splitting (half kick of the contact force, exact
//! free flight of striker and damped modes, half kick), which is symplectic for the undamped
//! system: the contact creates no energy. Loudness, contact time and brightness all follow
//! from the strike's speed, mass, hardness and place.
//!
//! Each mode is held as (q, v), v = (q' + sigma q) / wd, in which free flight is a damped
//! rotation: two coefficients per mode, and one pass over the modes per sub-step does the
//! kick, the flight and the displacement at the strike point (plus, once per sample, the
//! output). Per-mode arrays are f32 in lanes of eight so the pass vectorises.

use super::bank::{Lane, LANES};
use super::modes::ModeSet;

/// A strike as the contact sees it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrikeInput {
    pub speed_mps: f64,
    pub mass_kg: f64,
    pub x_m: f64,
    pub y_m: f64,
    /// Hertz stiffness k (already scaled by the tip's hardness) and exponent alpha.
    pub k: f64,
    pub alpha: f64,
}

/// What happened during one contact.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ContactReport {
    /// Time the striker and the surface were pressed together, seconds.
    pub contact_s: f64,
    pub peak_force_n: f64,
    /// Integral of the contact force, N s.
    pub impulse_ns: f64,
    /// Striker speed after it left (positive: moving away), m/s.
    pub rebound_mps: f64,
    /// Sub-steps per sample used.
    pub substeps: usize,
    /// From first touch until the striker has left for good, seconds.
    pub span_s: f64,
}

/// Longest a striker may stay on a surface before the player is taken to lift it.
pub const MAX_CONTACT_S: f64 = 0.040;

/// Estimated time a striker would stay on a rigid surface (Hertz theory), seconds.
pub fn rigid_contact_time_s(s: &StrikeInput) -> f64 {
    3.0 * max_compression_m(s) / s.speed_mps.max(1e-3)
}

/// Deepest compression against a rigid surface: all kinetic energy in the contact spring.
fn max_compression_m(s: &StrikeInput) -> f64 {
    let v = s.speed_mps.max(1e-3);
    ((s.alpha + 1.0) * s.mass_kg * v * v / (2.0 * s.k)).powf(1.0 / (s.alpha + 1.0))
}

/// Modal state, per mode in lanes: displacement q (m) and scaled velocity
/// v = (q' + sigma q) / wd (m), the output weights, the centre weights, and each mode's decay
/// rate as [`damped`] caps it.
pub struct ModalState<'a> {
    pub q: &'a mut [Lane],
    pub v: &'a mut [Lane],
    pub sigma: &'a [f64],
    pub out_gain: &'a [Lane],
    /// Weights of the displacement at the centre (for snare wires); `None` writes zeros.
    pub centre_weight: Option<&'a [Lane]>,
    /// The largest stretch ([`ModeSet::stretch`]) the surface takes.
    pub max_stretch: f32,
}

/// Eight modes' coefficients for one contact: free flight over one sub-step as the damped
/// rotation q <- c q + s v, v <- c v - s q; the change of v per newton second of contact
/// impulse; the mode shape at the strike point.
#[derive(Debug, Clone, Copy, Default)]
struct Chunk {
    c: Lane,
    s: Lane,
    kick: Lane,
    phi: Lane,
    /// Change of v per unit of stretch and of q over one sub-step (slope2 h / (M wd)).
    tension: Lane,
    /// The mode's share of the stretch per squared displacement ([`ModeSet::stretch`]
    /// times slope2).
    stretch: Lane,
}

/// Per-mode arrays for one piece, and the contact's impulse per sample, preallocated so a
/// strike does not allocate.
#[derive(Debug, Clone)]
pub struct ContactScratch {
    chunks: Vec<Chunk>,
    impulses: Vec<f32>,
}

impl ContactScratch {
    pub fn new(modes: usize, max_samples: usize) -> ContactScratch {
        ContactScratch { chunks: vec![Chunk::default(); modes.div_ceil(LANES)], impulses: vec![0.0; max_samples] }
    }
}

/// A mode's decay rate, capped at 0.95 w0 as everywhere in the synthesizer, and its damped
/// angular frequency wd.
pub fn damped(w0: f64, sigma: f64) -> (f64, f64) {
    let sigma = sigma.min(0.95 * w0);
    (sigma, (w0 * w0 - sigma * sigma).sqrt())
}

/// Exact free flight of q'' + 2 sigma q' + w0^2 q = 0 over time h, acting on (q, v) as
/// q <- c q + s v, v <- c v - s q: returns (c, s) = e^(-sigma h) (cos wd h, sin wd h).
pub fn rotation(w0: f64, sigma: f64, h: f64) -> (f64, f64) {
    let (sigma, wd) = damped(w0, sigma);
    let (s, c) = (wd * h).sin_cos();
    let e = (-sigma * h).exp();
    (e * c, e * s)
}

/// One sub-step of every mode: the kick of the contact impulse `imp` (N s), the free flight,
/// and the displacement at the strike point after it; with `OUT` also the output, with
/// `CENTRE` also the centre displacement. All in one pass over the modes.
#[inline(always)]
fn pass<const OUT: bool, const CENTRE: bool>(
    q: &mut [Lane],
    v: &mut [Lane],
    chunks: &[Chunk],
    gain: &[Lane],
    centre: &[Lane],
    imp: f32,
    rise: f32,
) -> (f32, f32, f32, f32) {
    let (mut at, mut out, mut mid) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
    let mut stretched = [0.0f32; LANES];
    let n = q.len();
    let (v, chunks) = (&mut v[..n], &chunks[..n]);
    let gain = if OUT { &gain[..n] } else { &[][..] };
    let centre = if CENTRE { &centre[..n] } else { &[][..] };
    for i in 0..n {
        let (qi, vi, k) = (&mut q[i], &mut v[i], &chunks[i]);
        for l in 0..LANES {
            let y = vi[l] + imp * k.kick[l] - rise * k.tension[l] * qi[l];
            let x = k.c[l] * qi[l] + k.s[l] * y;
            vi[l] = k.c[l] * y - k.s[l] * qi[l];
            qi[l] = x;
            at[l] += k.phi[l] * x;
            stretched[l] += k.stretch[l] * x * x;
            if OUT {
                out[l] += gain[i][l] * x;
            }
            if CENTRE {
                mid[l] += centre[i][l] * x;
            }
        }
    }
    let sum = |a: [f32; LANES]| a.iter().sum::<f32>();
    (sum(at), sum(out), sum(mid), sum(stretched))
}

/// Run one contact from the current modal state. Writes the output sample and the centre
/// displacement at each sample instant into `out` / `centre` until the striker has left, and
/// returns how many samples it wrote.
pub fn run_contact(
    modes: &ModeSet,
    state: ModalState<'_>,
    strike: &StrikeInput,
    sample_rate_hz: f64,
    scratch: &mut ContactScratch,
    out: &mut [f32],
    centre: &mut [f32],
) -> (usize, ContactReport) {
    let t = 1.0 / sample_rate_hz;
    let (q_all, v_all) = (state.q, state.v);
    let chunks_all = &mut scratch.chunks[..q_all.len()];
    // Mode shapes at the strike point. The modes that move with the striker give the
    // surface's mobility there, 1 / m_eff = sum phi^2 / M; the ones above give only as a
    // spring, compliance sum phi^2 / (M w^2) (each thinned mode for those it stands for).
    let split = modes.contact_modes.min(modes.modes.len());
    let dynamic = split.div_ceil(LANES);
    let mut inv_mass = 0.0;
    let mut compliance = 0.0;
    modes.shapes_at(strike.x_m, strike.y_m, |k, phi| {
        let mode = &modes.modes[k];
        // The strike presses a patch, not a point: each mode feels its shape's mean over it.
        let phi = phi * mode.patch;
        chunks_all[k / LANES].phi[k % LANES] = phi as f32;
        if k < split {
            inv_mass += phi * phi / mode.mass_kg;
        } else {
            let w0 = 2.0 * std::f64::consts::PI * mode.freq_hz;
            compliance += mode.stands_for * phi * phi / (mode.mass_kg * w0 * w0);
        }
    });
    // Sub-steps: resolve both the contact's duration and the stiff local oscillation of the
    // striker against the surface's effective mass at its deepest compression (w h <= 1; the
    // leapfrog is stable to w h < 2 and its energy error stays bounded, but at w h = 1.5 a tom's
    // peak force is already 20 % off the converged value). A soft kick needs only one.
    // The residual spring in series softens the contact: both estimates use the pair.
    let c_max = max_compression_m(strike);
    let k_hertz = strike.alpha * strike.k * c_max.powf(strike.alpha - 1.0);
    let k_lin = 1.0 / (1.0 / k_hertz + compliance);
    let w_local = (k_lin * (inv_mass + 1.0 / strike.mass_kg)).sqrt();
    let softened = (k_hertz / k_lin).sqrt();
    let by_duration = 30.0 * t / (rigid_contact_time_s(strike) * softened);
    let substeps = (by_duration.max(t * w_local).ceil() as usize).clamp(1, 64);
    let h = t / substeps as f64;
    for (k, mode) in modes.modes.iter().enumerate() {
        let w0 = 2.0 * std::f64::consts::PI * mode.freq_hz;
        // The modes above the split advance a whole sample at a time, after the contact.
        let step = if k < split { h } else { t };
        let (c, s) = rotation(w0, state.sigma[k], step);
        let wd = damped(w0, state.sigma[k]).1;
        let (chunk, l) = (&mut chunks_all[k / LANES], k % LANES);
        let kick = chunk.phi[l] as f64 / mode.mass_kg / wd;
        (chunk.c[l], chunk.s[l], chunk.kick[l]) = (c as f32, s as f32, kick as f32);
        chunk.tension[l] = (mode.slope2 / mode.mass_kg / wd * step) as f32;
        chunk.stretch[l] = (modes.stretch * mode.slope2) as f32;
    }
    let (q, v_modes) = (&mut q_all[..dynamic], &mut v_all[..dynamic]);
    let chunks = &chunks_all[..dynamic];
    let (gain_all, centre_all) = (state.out_gain, state.centre_weight.unwrap_or(&[]));
    let gain = &gain_all[..dynamic];
    let centre_weight = if centre_all.is_empty() { centre_all } else { &centre_all[..dynamic] };
    // Hertz exponents are usually half-integers (3/2 for a sphere on a plane): then c^alpha is
    // a power of sqrt(c), much cheaper than powf.
    let half_steps = (2.0 * strike.alpha).round();
    let sqrt_power =
        (half_steps == 2.0 * strike.alpha && (1.0..=8.0).contains(&half_steps)).then_some(half_steps as i32);
    let hertz = |c: f64| match (c > 0.0, sqrt_power) {
        (false, _) => 0.0,
        (true, Some(n)) => strike.k * c.sqrt().powi(n),
        (true, None) => strike.k * c.powf(strike.alpha),
    };
    // The Hertz spring in series with the residual spring: the approach c splits into the
    // Hertz compression x and the residual give C F, x + C k x^alpha = c (Newton in x; the
    // left side is convex and increasing, so from above it converges monotonically).
    let force_of = |c: f64| {
        if c <= 0.0 || compliance <= 0.0 {
            return hertz(c);
        }
        let ck = compliance * strike.k;
        let mut x = c.min((c / ck).powf(1.0 / strike.alpha));
        for _ in 0..8 {
            let xa = hertz(x) / strike.k;
            let f = x + ck * xa - c;
            let df = 1.0 + strike.alpha * ck * xa / x.max(1e-30);
            let next = (x - f / df).max(0.0);
            if (next - x).abs() <= 1e-9 * c {
                x = next;
                break;
            }
            x = next;
        }
        hertz(x)
    };
    // Striker: u is its position into the surface (rest plane at 0), v its speed into it.
    let mut u = {
        let mut acc = [0.0f32; LANES];
        for (qi, k) in q.iter().zip(chunks.iter()) {
            for l in 0..LANES {
                acc[l] += k.phi[l] * qi[l];
            }
        }
        acc.iter().sum::<f32>() as f64
    };
    let mut v = strike.speed_mps;
    let mut report = ContactReport { substeps, ..ContactReport::default() };
    let max_samples = out.len().min((MAX_CONTACT_S * sample_rate_hz) as usize).max(1);
    let mut written = 0;
    let (mut c, mut force) = (0.0, 0.0);
    // Leapfrog form of the splitting: the closing half kick of one sub-step and the opening
    // half kick of the next are applied together, fused into the modes' free-flight pass.
    let mut impulse = 0.0;
    // Tension modulation: the head's tension rises with its stretch, sum of the modes'
    // shares (1 + rise times the rest tension); the sum is of the modes that move with the
    // striker, the last sub-step's.
    let mut rise = 0.0f32;
    let impulses = &mut scratch.impulses;
    while written < max_samples {
        let mut touching = false;
        let mut sample_impulse = 0.0;
        for step in 1..=substeps {
            sample_impulse += impulse;
            v -= impulse / strike.mass_kg;
            u += v * h;
            let imp = impulse as f32;
            let at = if step < substeps {
                let (at, _, _, stretched) = pass::<false, false>(q, v_modes, chunks, gain, centre_weight, imp, rise);
                rise = stretched.min(state.max_stretch);
                at
            } else {
                let (at, o, mid, stretched) = if centre_weight.is_empty() {
                    pass::<true, false>(q, v_modes, chunks, gain, centre_weight, imp, rise)
                } else {
                    pass::<true, true>(q, v_modes, chunks, gain, centre_weight, imp, rise)
                };
                rise = stretched.min(state.max_stretch);
                (out[written], centre[written]) = (o, mid);
                at
            };
            let before = force;
            c = u - at as f64;
            force = force_of(c);
            impulse = h * force;
            if force > 0.0 || before > 0.0 {
                touching = true;
                report.contact_s += if force > 0.0 && before > 0.0 { h } else { 0.5 * h };
                report.impulse_ns += 0.5 * h * (force + before);
                report.peak_force_n = report.peak_force_n.max(force);
            }
        }
        impulses[written] = sample_impulse as f32;
        written += 1;
        if !touching && v < 0.0 && c < 0.0 {
            break;
        }
    }
    // The closing half kick (zero unless the player lifted the striker while pressed).
    v -= 0.5 * impulse / strike.mass_kg;
    let half = 0.5 * impulse as f32;
    for (vi, k) in v_modes.iter_mut().zip(chunks.iter()) {
        for (v, kick) in vi.iter_mut().zip(k.kick) {
            *v += half * kick;
        }
    }
    // The modes above the split, rung by the force they felt, a sample at a time: their
    // output (and centre displacement) adds to what the contact wrote.
    let mut high_gain_j = 0.0;
    if dynamic < q_all.len() {
        impulses[written - 1] += 0.5 * impulse as f32;
        let (q, v) = (&mut q_all[dynamic..], &mut v_all[dynamic..]);
        // Their energy, 1/2 M wd^2 (q^2 + v^2) for light damping: what they gain the striker
        // pays (the residual spring itself hands back all it stored).
        let energy = |q: &[Lane], v: &[Lane]| {
            let mut e = 0.0;
            for (k, mode) in modes.modes.iter().enumerate().skip(dynamic * LANES) {
                let (i, l) = (k / LANES - dynamic, k % LANES);
                let w = 2.0 * std::f64::consts::PI * mode.freq_hz;
                e += 0.5 * mode.mass_kg * w * w * ((q[i][l] as f64).powi(2) + (v[i][l] as f64).powi(2));
            }
            e
        };
        let before = energy(q, v);
        let high = &chunks_all[dynamic..];
        let gain = &gain_all[dynamic..];
        for (n, imp) in impulses[..written].iter().enumerate() {
            let (_, o, mid, _) = if centre_all.is_empty() {
                pass::<true, false>(q, v, high, gain, &[], *imp, 0.0)
            } else {
                pass::<true, true>(q, v, high, gain, &centre_all[dynamic..], *imp, 0.0)
            };
            out[n] += o;
            centre[n] += mid;
        }
        high_gain_j = energy(q, v) - before;
    }
    // The striker leaves with what the high modes did not take.
    let kinetic = 0.5 * strike.mass_kg * v * v - high_gain_j;
    report.rebound_mps = -v.signum() * (2.0 * kinetic.max(0.0) / strike.mass_kg).sqrt();
    report.span_s = written as f64 / sample_rate_hz;
    (written, report)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_is_exact_for_free_decay() {
        let (w0, sigma) = (2.0 * std::f64::consts::PI * 440.0, 30.0);
        let (sigma_d, wd) = damped(w0, sigma);
        // Ten small steps equal one big one ...
        let (c, s) = rotation(w0, sigma, 1e-5);
        let (mut q, mut v) = (1.0, 0.0);
        for _ in 0..10 {
            (q, v) = (c * q + s * v, c * v - s * q);
        }
        let (c, s) = rotation(w0, sigma, 1e-4);
        assert!((q - c).abs() < 1e-12 && (v + s).abs() < 1e-12);
        // ... and both follow q(t) = e^(-sigma t) cos(wd t) + sigma / wd e^(-sigma t) sin(wd t),
        // the free decay from rest at q = 1 (v = sigma q / wd).
        let t = 1e-4;
        let exact = (-sigma_d * t).exp() * ((wd * t).cos() + sigma_d / wd * (wd * t).sin());
        let (q, v0) = (1.0, sigma_d / wd);
        assert!((c * q + s * v0 - exact).abs() < 1e-12);
    }

    #[test]
    fn rigid_contact_time_follows_hertz_scaling() {
        let s = StrikeInput { speed_mps: 1.0, mass_kg: 0.04, x_m: 0.0, y_m: 0.0, k: 1e9, alpha: 1.5 };
        let fast = StrikeInput { speed_mps: 32.0, ..s };
        // t ~ v^(-1/5): 32x the speed, half the time.
        let ratio = rigid_contact_time_s(&s) / rigid_contact_time_s(&fast);
        assert!((ratio - 2.0).abs() < 1e-9, "{ratio}");
    }
}
