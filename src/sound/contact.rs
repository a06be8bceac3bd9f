//! The Hertz contact at audio rate: a striking mass meets the surface's modal displacement at
//! the strike point, F = k c^alpha while the compression c > 0. The contact is integrated at a
//! multiple of the sample rate with Strang splitting (half kick of the contact force, exact
//! free flight of striker and damped modes, half kick), which is symplectic for the undamped
//! system: the contact creates no energy. Loudness, contact time and brightness all follow
//! from the strike's speed, mass, hardness and place. Per-mode arrays are f32 in lanes of
//! eight so the inner loops vectorise.

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

/// Modal state, per mode in lanes: displacement q, velocity p, and the output and centre
/// weights, plus the current decay rate of each mode.
pub struct ModalState<'a> {
    pub q: &'a mut [Lane],
    pub p: &'a mut [Lane],
    pub sigma: &'a [f64],
    pub out_gain: &'a [Lane],
    pub centre_weight: &'a [Lane],
}

/// Per-mode arrays for one piece, preallocated so a strike does not allocate.
#[derive(Debug, Clone)]
pub struct ContactScratch {
    phi: Vec<Lane>,
    /// phi / M: the mode's acceleration per newton at the strike point.
    accel: Vec<Lane>,
    /// Exact free propagator over one sub-step, [[m00, m01], [m10, m11]].
    m00: Vec<Lane>,
    m01: Vec<Lane>,
    m10: Vec<Lane>,
    m11: Vec<Lane>,
}

impl ContactScratch {
    pub fn new(modes: usize) -> ContactScratch {
        let z = vec![[0.0; LANES]; modes.div_ceil(LANES)];
        ContactScratch { phi: z.clone(), accel: z.clone(), m00: z.clone(), m01: z.clone(), m10: z.clone(), m11: z }
    }
}

fn dot(a: &[Lane], b: &[Lane]) -> f32 {
    let mut acc = [0.0f32; LANES];
    for i in 0..a.len().min(b.len()) {
        for l in 0..LANES {
            acc[l] += a[i][l] * b[i][l];
        }
    }
    acc.iter().sum()
}

fn kick(p: &mut [Lane], accel: &[Lane], impulse: f32) {
    for (pk, a) in p.iter_mut().zip(accel.iter()) {
        for l in 0..LANES {
            pk[l] += impulse * a[l];
        }
    }
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
    // Mode shapes at the strike point, and the surface's mobility there: 1 / m_eff = sum phi^2 / M.
    let mut inv_mass = 0.0;
    for (k, mode) in modes.modes.iter().enumerate() {
        let phi = modes.shape_at(k, strike.x_m, strike.y_m);
        scratch.phi[k / LANES][k % LANES] = phi as f32;
        scratch.accel[k / LANES][k % LANES] = (phi / mode.mass_kg) as f32;
        inv_mass += phi * phi / mode.mass_kg;
    }
    // Sub-steps: resolve both the contact's duration and the stiff local oscillation of the
    // striker against the surface's effective mass at its deepest compression (w h <= 1; the
    // leapfrog is stable to w h < 2 and its energy error stays bounded).
    let c_max = max_compression_m(strike);
    let k_lin = strike.alpha * strike.k * c_max.powf(strike.alpha - 1.0);
    let w_local = (k_lin * (inv_mass + 1.0 / strike.mass_kg)).sqrt();
    let by_duration = 30.0 * t / rigid_contact_time_s(strike);
    let substeps = (by_duration.max(t * w_local).ceil() as usize).clamp(2, 64);
    let h = t / substeps as f64;
    for (k, mode) in modes.modes.iter().enumerate() {
        let w0 = 2.0 * std::f64::consts::PI * mode.freq_hz;
        let [a, b, c, d] = propagator(w0, state.sigma[k], h);
        let (i, l) = (k / LANES, k % LANES);
        (scratch.m00[i][l], scratch.m01[i][l], scratch.m10[i][l], scratch.m11[i][l]) =
            (a as f32, b as f32, c as f32, d as f32);
    }
    let (q, p) = (state.q, state.p);
    let force_of = |c: f64| if c > 0.0 { strike.k * c.powf(strike.alpha) } else { 0.0 };
    // Striker: u is its position into the surface (rest plane at 0), v its speed into it.
    let mut u = dot(&scratch.phi, q) as f64;
    let mut v = strike.speed_mps;
    let mut report = ContactReport { substeps, ..ContactReport::default() };
    let max_samples = out.len().min((MAX_CONTACT_S * sample_rate_hz) as usize).max(1);
    let mut written = 0;
    let (mut c, mut force) = (0.0, 0.0);
    // Leapfrog form of the splitting: the closing half kick of one sub-step and the opening
    // half kick of the next are applied together, fused into the modes' free-flight pass.
    let mut impulse = 0.0;
    while written < max_samples {
        let mut touching = false;
        for _ in 0..substeps {
            v -= impulse / strike.mass_kg;
            u += v * h;
            let imp = impulse as f32;
            for i in 0..q.len() {
                let (qi, pi) = (&mut q[i], &mut p[i]);
                let (a, b, cc, d, acc) =
                    (&scratch.m00[i], &scratch.m01[i], &scratch.m10[i], &scratch.m11[i], &scratch.accel[i]);
                for l in 0..LANES {
                    let (x, y) = (qi[l], pi[l] + imp * acc[l]);
                    qi[l] = a[l] * x + b[l] * y;
                    pi[l] = cc[l] * x + d[l] * y;
                }
            }
            let before = force;
            c = u - dot(&scratch.phi, q) as f64;
            force = force_of(c);
            impulse = h * force;
            if force > 0.0 || before > 0.0 {
                touching = true;
                report.contact_s += if force > 0.0 && before > 0.0 { h } else { 0.5 * h };
                report.impulse_ns += 0.5 * h * (force + before);
                report.peak_force_n = report.peak_force_n.max(force);
            }
        }
        out[written] = dot(state.out_gain, q);
        centre[written] = dot(state.centre_weight, q);
        written += 1;
        if !touching && v < 0.0 && c < 0.0 {
            break;
        }
    }
    // The closing half kick (zero unless the player lifted the striker while pressed).
    v -= 0.5 * impulse / strike.mass_kg;
    kick(p, &scratch.accel, 0.5 * impulse as f32);
    report.rebound_mps = -v;
    report.span_s = written as f64 / sample_rate_hz;
    (written, report)
}

/// Exact propagator of q'' + 2 sigma q' + w0^2 q = 0 over time h, acting on (q, q').
pub fn propagator(w0: f64, sigma: f64, h: f64) -> [f64; 4] {
    let sigma = sigma.min(0.95 * w0);
    let wd = (w0 * w0 - sigma * sigma).sqrt();
    let (s, c) = (wd * h).sin_cos();
    let e = (-sigma * h).exp();
    [e * (c + sigma * s / wd), e * s / wd, -e * w0 * w0 * s / wd, e * (c - sigma * s / wd)]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn propagator_is_exact_for_free_decay() {
        // Ten small steps equal one big one.
        let (w0, sigma) = (2.0 * std::f64::consts::PI * 440.0, 30.0);
        let small = propagator(w0, sigma, 1e-5);
        let (mut q, mut p) = (1.0, 0.0);
        for _ in 0..10 {
            (q, p) = (small[0] * q + small[1] * p, small[2] * q + small[3] * p);
        }
        let big = propagator(w0, sigma, 1e-4);
        assert!((q - big[0]).abs() < 1e-12 && (p - big[2]).abs() < 1e-8);
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
