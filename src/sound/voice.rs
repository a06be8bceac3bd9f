//! One kit piece as an instrument: its modes in a resonator bank, the Hertz contact that
//! excites them, snare wires, and the damping that a closing hi-hat or a grabbing hand adds.
//! A piece is one physical object, so a new strike acts on whatever already rings.

use super::bank::{Bank, Lane, LANES};
use super::contact::{damped, run_contact, ContactReport, ContactScratch, ModalState, StrikeInput, MAX_CONTACT_S};
use super::modes::ModeSet;
use super::stress::Stress;
use super::wires::WireRattle;
use super::Strike;
use crate::kit::Piece;
use std::f64::consts::PI;

/// A membrane's modes coupled through its stretch after the contact (the lowest).
const COUPLED_MEMBRANE_MODES: usize = 64;

/// Per-mode values that depend on the current damping: [cos(wd T), sin(wd T), e^(-sigma T), wd, sigma].
type Discrete = [f64; 5];

#[derive(Debug, Clone)]
pub struct Voice {
    pub modes: ModeSet,
    bank: Bank,
    sample_rate_hz: f64,
    gains: Vec<Lane>,
    centre_weights: Vec<Lane>,
    discrete: Vec<Discrete>,
    sigma: Vec<f64>,
    /// Contact state: displacement and scaled velocity (q' + sigma q) / wd of each mode.
    q: Vec<Lane>,
    v: Vec<Lane>,
    scratch: ContactScratch,
    /// Output of the contact now under way, sample by sample, and how far it has been played.
    pending_out: Vec<f32>,
    pending_centre: Vec<f32>,
    pending_len: usize,
    pending_pos: usize,
    /// A strike that arrived while the previous contact was still under way.
    deferred: Option<Strike>,
    centre_buf: Vec<f32>,
    hertz_k: f64,
    hertz_alpha: f64,
    wires: Option<WireRattle>,
    closed_damping_factor: Option<f64>,
    choke_damping_factor: f64,
    openness_factor: f64,
    damping_factor: (f64, bool),
    choked: bool,
    /// The largest stretch the modes take (see [`super::bank::Bank::set_stretch`]).
    max_stretch: f32,
    /// What the last contact did (for tests and reports).
    pub last_contact: ContactReport,
}

impl Voice {
    pub fn new(piece: &Piece, sample_rate_hz: f32, max_block: usize) -> Voice {
        let modes = ModeSet::for_piece(piece);
        let n = modes.modes.len();
        let gains: Vec<f32> = modes.modes.iter().map(|m| m.out_gain as f32).collect();
        // Displacement at the centre: only axisymmetric modes move it (J_m(0) = 0 for m > 0).
        let centre_weights: Vec<f32> = modes.modes.iter().map(|m| if m.m == 0 { 1.0 } else { 0.0 }).collect();
        let mut bank = Bank::new(&gains, &centre_weights[..n.min(LANES)]);
        let mut max_stretch = 0.0f32;
        bank.set_keep_moving(piece.wires.is_some());
        if modes.stretch > 0.0 {
            // Per sample, mode k's next displacement changes by T sin(w T) / (M w) times the
            // force, and the stretch pulls with stretch * s * slope2_k * y_k.
            let t = 1.0 / sample_rate_hz as f64;
            let w: Vec<f32> = modes.modes.iter().map(|m| (modes.stretch * m.slope2) as f32).collect();
            let c: Vec<f32> = modes
                .modes
                .iter()
                .map(|m| {
                    let w0 = 2.0 * PI * m.freq_hz;
                    (m.slope2 * t * (w0 * t).sin() / (m.mass_kg * w0)) as f32
                })
                .collect();
            // The recursion y = a1 y1 - a2 y2 - s c y1 stays stable while a1 - s c > -(1 + a2):
            // hold s to half of what the stiffest mode allows (a head stretched past that
            // would have torn).
            let max = modes
                .modes
                .iter()
                .zip(&c)
                .map(|(m, c)| (1.0 + (2.0 * PI * m.freq_hz * t).cos()) / (*c as f64).max(1e-30))
                .fold(f64::MAX, f64::min);
            // A head's pitch glide is its low modes' (the high ones ring out within tens of
            // milliseconds and their stretch is small): those couple; a plate's all do.
            let coupled = match modes.kind {
                crate::kit::PieceKind::Membrane => COUPLED_MEMBRANE_MODES.min(modes.modes.len()),
                crate::kit::PieceKind::Plate => modes.modes.len(),
            };
            let stiffness = modes.modes[..coupled]
                .iter()
                .map(|m| m.mass_kg * (2.0 * PI * m.freq_hz).powi(2) / m.slope2.max(1e-30))
                .fold(f64::MAX, f64::min);
            bank.set_stretch(&w, &c, max as f32, coupled, stiffness);
            max_stretch = max as f32;
        }
        if modes.stress > 0.0 {
            let column = |f: fn(&super::modes::Mode) -> f64| modes.modes.iter().map(f).collect::<Vec<f64>>();
            let seed = piece.id.bytes().fold(0u64, |h, b| h.wrapping_mul(0x100_0000_01B3) ^ b as u64);
            bank.set_stress(Stress::new(
                &column(|m| m.mass_kg),
                &column(|m| m.freq_hz),
                &column(|m| m.slope2),
                modes.stress,
                sample_rate_hz as f64,
                seed,
            ));
        }
        let lanes = |v: &[f32]| {
            let mut out = vec![[0.0f32; LANES]; n.div_ceil(LANES)];
            for (k, x) in v.iter().enumerate() {
                out[k / LANES][k % LANES] = *x;
            }
            out
        };
        let contact_cap = (MAX_CONTACT_S * sample_rate_hz as f64).ceil() as usize + 1;
        let mut voice = Voice {
            bank,
            sample_rate_hz: sample_rate_hz as f64,
            gains: lanes(&gains),
            centre_weights: lanes(&centre_weights),
            discrete: vec![[0.0; 5]; n],
            sigma: vec![0.0; n],
            q: vec![[0.0; LANES]; n.div_ceil(LANES)],
            v: vec![[0.0; LANES]; n.div_ceil(LANES)],
            scratch: ContactScratch::new(n, contact_cap),
            pending_out: vec![0.0; contact_cap],
            pending_centre: vec![0.0; contact_cap],
            pending_len: 0,
            pending_pos: 0,
            deferred: None,
            centre_buf: vec![0.0; max_block],
            hertz_k: piece.hertz_k as f64,
            hertz_alpha: piece.hertz_alpha as f64,
            wires: piece.wires.as_ref().map(|w| WireRattle::new(w, sample_rate_hz)),
            closed_damping_factor: piece.closed_damping_factor.map(f64::from),
            choke_damping_factor: piece.choke_damping_factor as f64,
            openness_factor: 1.0,
            damping_factor: (f64::NAN, false),
            choked: false,
            max_stretch,
            last_contact: ContactReport::default(),
            modes,
        };
        voice.set_damping_factor(1.0, false);
        voice
    }

    pub fn is_hihat(&self) -> bool {
        self.closed_damping_factor.is_some()
    }

    /// True when nothing rings: rendering would add only zeros.
    pub fn is_silent(&self) -> bool {
        self.bank.is_silent()
            && self.pending_pos >= self.pending_len
            && !self.wires.as_ref().is_some_and(|w| w.is_ringing())
    }

    /// Number of modes.
    pub fn modes(&self) -> usize {
        self.bank.modes()
    }

    /// Every mode decays `factor` times faster than its own rate; with `by_pitch`, the
    /// lowest mode takes the whole factor and a mode at f only (f0 / f)^0.3 of its excess (a
    /// closed hi-hat: the cymbals pressed together at their rims stop the slow, wide motion
    /// of the low modes and barely touch the short waves of the high ones).
    fn set_damping_factor(&mut self, factor: f64, by_pitch: bool) {
        if (factor, by_pitch) == self.damping_factor {
            return;
        }
        self.damping_factor = (factor, by_pitch);
        let t = 1.0 / self.sample_rate_hz;
        let f0 = self.modes.modes.first().map_or(1.0, |m| m.freq_hz);
        for (k, mode) in self.modes.modes.iter().enumerate() {
            let weight = if by_pitch { (f0 / mode.freq_hz).min(1.0).powf(0.3) } else { 1.0 };
            let (sigma, wd) = damped(2.0 * PI * mode.freq_hz, mode.sigma * (1.0 + (factor - 1.0) * weight));
            let (s, c) = (wd * t).sin_cos();
            let e = (-sigma * t).exp();
            self.discrete[k] = [c, s, e, wd, sigma];
            self.sigma[k] = sigma;
            self.bank.set_coefficients(k, (2.0 * e * c) as f32, (e * e) as f32);
        }
    }

    fn update_damping(&mut self) {
        if self.choked && self.choke_damping_factor >= self.openness_factor {
            self.set_damping_factor(self.choke_damping_factor, false);
        } else {
            self.set_damping_factor(self.openness_factor, true);
        }
    }

    /// Hi-hat openness, 0 closed .. 1 open (ignored by pieces that are not a hi-hat).
    pub fn set_openness(&mut self, openness: f32) {
        if let Some(closed) = self.closed_damping_factor {
            self.openness_factor = closed.powf(1.0 - openness.clamp(0.0, 1.0) as f64);
            self.update_damping();
        }
    }

    /// A hand grabs the piece: it rings out fast until it is struck again.
    pub fn choke(&mut self) {
        self.choked = true;
        self.update_damping();
    }

    /// Strike now (at the next sample to be rendered).
    pub fn strike(&mut self, s: &Strike) {
        if !(s.speed_mps.is_finite()
            && s.speed_mps > 0.0
            && s.mass_kg.is_finite()
            && s.x_m.is_finite()
            && s.y_m.is_finite())
        {
            return;
        }
        if self.pending_pos < self.pending_len {
            self.deferred = Some(*s);
            return;
        }
        self.choked = false;
        self.update_damping();
        for k in 0..self.modes.modes.len() {
            let (q, v) = self.displacement_scaled_velocity(k);
            (self.q[k / LANES][k % LANES], self.v[k / LANES][k % LANES]) = (q as f32, v as f32);
        }
        let input = StrikeInput {
            speed_mps: s.speed_mps as f64,
            mass_kg: (s.mass_kg as f64).clamp(1e-3, 5.0),
            x_m: s.x_m as f64,
            y_m: s.y_m as f64,
            k: self.hertz_k * (s.hardness as f64).clamp(0.02, 2.0),
            alpha: self.hertz_alpha,
        };
        let state = ModalState {
            q: &mut self.q,
            v: &mut self.v,
            sigma: &self.sigma,
            out_gain: &self.gains,
            centre_weight: self.wires.is_some().then_some(&self.centre_weights[..]),
            max_stretch: self.max_stretch,
        };
        let (written, report) = run_contact(
            &self.modes,
            state,
            &input,
            self.sample_rate_hz,
            &mut self.scratch,
            &mut self.pending_out,
            &mut self.pending_centre,
        );
        self.last_contact = report;
        // The strike's level: the RMS of its contact (a click's single peak can stand 30 dB
        // over the ring that follows).
        let contact = &self.pending_out[..written];
        let rms = (contact.iter().map(|v| v * v).sum::<f32>() / written.max(1) as f32).sqrt();
        self.bank.set_strike_level(rms);
        self.pending_len = written;
        self.pending_pos = 0;
        // Back to the bank: (q, v) at the last contact sample -> (y[n-1], y[n-2]), the free
        // flight one sample back.
        for k in 0..self.modes.modes.len() {
            let [c, s_, e, _, _] = self.discrete[k];
            let (q, v) = (self.q[k / LANES][k % LANES] as f64, self.v[k / LANES][k % LANES] as f64);
            self.bank.set_state(k, q as f32, ((q * c - v * s_) / e) as f32);
        }
        self.bank.wake_stretch();
    }

    /// Mode k's displacement q and scaled velocity v = (q' + sigma q) / wd at the last rendered
    /// sample, from the bank's (y[n-1], y[n-2]) through the exact free solution.
    fn displacement_scaled_velocity(&self, k: usize) -> (f64, f64) {
        let (y1, y2) = self.bank.state(k);
        let [c, s, e, _, _] = self.discrete[k];
        let (y1, y2) = (y1 as f64, y2 as f64);
        (y1, (y1 * c - y2 * e) / s)
    }

    /// Mode k's displacement and velocity at the last rendered sample.
    fn displacement_velocity(&self, k: usize) -> (f64, f64) {
        let (q, v) = self.displacement_scaled_velocity(k);
        let [_, _, _, wd, sigma] = self.discrete[k];
        (q, wd * v - sigma * q)
    }

    /// Vibrational energy of mode k now, joules: 1/2 M (q'^2 + w0^2 q^2).
    pub fn mode_energy_j(&self, k: usize) -> f64 {
        let (q, p) = self.displacement_velocity(k);
        let mode = &self.modes.modes[k];
        let w0 = 2.0 * PI * mode.freq_hz;
        0.5 * mode.mass_kg * (p * p + w0 * w0 * q * q)
    }

    /// Vibrational energy of the whole surface now, joules.
    pub fn modal_energy_j(&self) -> f64 {
        (0..self.modes.modes.len()).map(|k| self.mode_energy_j(k)).sum()
    }

    /// Write the next `out.len()` samples (at most the engine's max block) into `out`.
    pub fn render(&mut self, out: &mut [f32], acc: &mut [Lane]) {
        let n = out.len();
        out.fill(0.0);
        let mut i = 0;
        while i < n {
            if self.pending_pos < self.pending_len {
                let take = (n - i).min(self.pending_len - self.pending_pos);
                let range = self.pending_pos..self.pending_pos + take;
                out[i..i + take].copy_from_slice(&self.pending_out[range.clone()]);
                self.centre_buf[i..i + take].copy_from_slice(&self.pending_centre[range]);
                self.pending_pos += take;
                i += take;
                if self.pending_pos >= self.pending_len {
                    if let Some(s) = self.deferred.take() {
                        self.strike(&s);
                    }
                }
            } else {
                let centre = self.wires.is_some().then(|| &mut self.centre_buf[i..n]);
                self.bank.process(&mut out[i..n], centre, acc);
                i = n;
            }
        }
        if let Some(wires) = &mut self.wires {
            wires.process(&self.centre_buf[..n], out);
        }
    }
}
