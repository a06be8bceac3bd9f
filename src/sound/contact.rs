//! The Hertz contact at audio rate: a striking mass meets the surface's modal displacement at
//! the strike point, F = k c^alpha while the compression c > 0. The contact is integrated at a
//! multiple of the sample rate (enough sub-steps to resolve it); each mode is advanced exactly
//! over a sub-step under the constant force of that sub-step. Loudness, contact time and
//! brightness all follow from the strike's speed, mass, hardness and place.

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
    /// Striker speed after it left (negative: moving away), m/s.
    pub rebound_mps: f64,
    /// Sub-steps per sample used.
    pub substeps: usize,
    /// From first touch until the striker has left for good, seconds.
    pub span_s: f64,
}

/// Per-mode arrays for one piece, preallocated so a strike does not allocate.
#[derive(Debug, Clone)]
pub struct ContactScratch {
    /// Mode shape at the strike point.
    phi: Vec<f64>,
    /// phi / (M omega0^2): static displacement of the mode per newton.
    compliance: Vec<f64>,
    /// Exact free propagator over one sub-step: [[m00, m01], [m10, m11]].
    prop: Vec<[f64; 4]>,
}

impl ContactScratch {
    pub fn new(modes: usize) -> ContactScratch {
        ContactScratch { phi: vec![0.0; modes], compliance: vec![0.0; modes], prop: vec![[0.0; 4]; modes] }
    }
}

/// Longest a striker may stay on a surface before the player is taken to lift it.
pub const MAX_CONTACT_S: f64 = 0.025;

/// Estimated time a striker would stay on a rigid surface (Hertz theory), seconds.
pub fn rigid_contact_time_s(s: &StrikeInput) -> f64 {
    let v = s.speed_mps.max(1e-3);
    let c_max = ((s.alpha + 1.0) * s.mass_kg * v * v / (2.0 * s.k)).powf(1.0 / (s.alpha + 1.0));
    3.0 * c_max / v
}

/// Modal state in the contact's own coordinates: displacement q and velocity p per mode.
pub struct ModalState<'a> {
    pub q: &'a mut [f64],
    pub p: &'a mut [f64],
    /// Current decay rate of each mode (damping factor applied).
    pub sigma: &'a [f64],
}

/// Run one contact from the current modal state. Writes the output sample (sum of out_gain q)
/// and the centre displacement (sum of centre q) at each sample instant into `out` / `centre`
/// until the striker has left, and returns how many samples it wrote.
#[allow(clippy::too_many_arguments)]
pub fn run_contact(
    modes: &ModeSet,
    state: ModalState<'_>,
    strike: &StrikeInput,
    sample_rate_hz: f64,
    scratch: &mut ContactScratch,
    out_gain: &[f32],
    centre_weight: &[f32],
    out: &mut [f32],
    centre: &mut [f32],
) -> (usize, ContactReport) {
    let n = modes.modes.len();
    let t = 1.0 / sample_rate_hz;
    let substeps = ((30.0 * t / rigid_contact_time_s(strike)).ceil() as usize).clamp(2, 48);
    let h = t / substeps as f64;
    for k in 0..n {
        let mode = &modes.modes[k];
        let phi = modes.shape_at(k, strike.x_m, strike.y_m);
        let w0 = 2.0 * std::f64::consts::PI * mode.freq_hz;
        scratch.phi[k] = phi;
        scratch.compliance[k] = phi / (mode.mass_kg * w0 * w0);
        scratch.prop[k] = propagator(w0, state.sigma[k], h);
    }
    let (q, p) = (state.q, state.p);
    // Striker: u is its position into the surface (rest plane at 0), v its speed into it.
    let mut u: f64 = (0..n).map(|k| scratch.phi[k] * q[k]).sum();
    let mut v = strike.speed_mps;
    let mut report = ContactReport { substeps, ..ContactReport::default() };
    let max_samples = out.len().min((MAX_CONTACT_S * sample_rate_hz) as usize).max(1);
    let mut written = 0;
    while written < max_samples {
        let mut touching = false;
        for _ in 0..substeps {
            let w: f64 = (0..n).map(|k| scratch.phi[k] * q[k]).sum();
            let c = u - w;
            let force = if c > 0.0 { strike.k * c.powf(strike.alpha) } else { 0.0 };
            if c > 0.0 {
                touching = true;
                report.contact_s += h;
                report.impulse_ns += force * h;
                report.peak_force_n = report.peak_force_n.max(force);
            }
            v -= force / strike.mass_kg * h;
            u += v * h;
            for k in 0..n {
                let qe = force * scratch.compliance[k];
                let [m00, m01, m10, m11] = scratch.prop[k];
                let dq = q[k] - qe;
                let pk = p[k];
                q[k] = m00 * dq + m01 * pk + qe;
                p[k] = m10 * dq + m11 * pk;
            }
        }
        let (mut o, mut cw) = (0.0f64, 0.0f64);
        for k in 0..n {
            o += out_gain[k] as f64 * q[k];
            cw += centre_weight.get(k).copied().unwrap_or(0.0) as f64 * q[k];
        }
        out[written] = o as f32;
        centre[written] = cw as f32;
        written += 1;
        let w: f64 = (0..n).map(|k| scratch.phi[k] * q[k]).sum();
        if !touching && v < 0.0 && u < w {
            break;
        }
    }
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
