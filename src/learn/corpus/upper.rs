//! Upper body: the chest leans toward where the sticks are working and bounces slightly on
//! the beat; the head follows the chest's turn and nods with the pulse.
//!
//! The beat is estimated from the notes, not taken from any tempo in the file (GMD files are
//! played freely against a click): an onset envelope at 60 fps (kick and snare weigh 1, the
//! rest 0.5, times velocity) is autocorrelated over 60..200 BPM, each lag scored with its
//! double and quadruple (a beat repeats at the half bar and the bar; a dotted beat does not) and
//! a mild preference for tempi near 110 BPM (so a half or double tempo does not win by a
//! hair), the period refined to
//! a twentieth of a frame and the phase chosen to put the most onset weight on the beats.

use super::PlannedNote;
use super::{Rng, LEFT, RIGHT};
use crate::midi::roll::frame_of;
use crate::midi::{DrumEventKind, NoteMap, Performance};
use crate::motion::{Pose, FPS};

/// Seated chest (top of the spine) and head at rest.
pub const CHEST_HOME: [f32; 3] = [0.0, -0.02, 1.12];
pub const HEAD_ABOVE_CHEST_M: f32 = 0.30;
/// Where the sticks work on average (between snare and hi-hat), the lean's zero.
pub const WORK_HOME: [f32; 2] = [-0.15, 0.40];
/// Head nod on the beat, degrees, at full activity.
pub const NOD_DEG: f32 = 6.0;
/// Chest bounce on the beat, metres, at full activity.
pub const BOUNCE_M: f32 = 0.008;

/// The estimated pulse: beat period and the time of one beat.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Beat {
    pub period_s: f64,
    pub phase_s: f64,
}

impl Beat {
    /// Position in beats at time t (integer at each beat).
    pub fn position(&self, t: f64) -> f64 {
        (t - self.phase_s) / self.period_s
    }

    /// 1 on a beat, falling to 0 half-way between beats (a raised cosine).
    pub fn pulse(&self, t: f64) -> f32 {
        (0.5 + 0.5 * (2.0 * std::f64::consts::PI * self.position(t)).cos()) as f32
    }
}

/// Estimate the beat from the note-ons (120 BPM at phase 0 when there are too few notes).
pub fn estimate_beat(perf: &Performance, map: &NoteMap, frames: usize) -> Beat {
    let mut env = vec![0f32; frames.max(1)];
    let mut count = 0;
    for e in &perf.events {
        if let DrumEventKind::NoteOn { note, velocity } = e.kind {
            let Some(m) = map.entry(note) else { continue };
            let w = if m.piece == "kick" || m.piece == "snare" { 1.0 } else { 0.5 };
            let f = frame_of(e.time_s).min(env.len() - 1);
            env[f] += w * velocity as f32 / 127.0;
            count += 1;
        }
    }
    let fallback = Beat { period_s: 0.5, phase_s: 0.0 };
    if count < 8 {
        return fallback;
    }
    // Spread each onset over a few frames so that a period between two integer lags still
    // correlates.
    let env = smooth(&env, 0.03);
    let (min_lag, max_lag) = ((FPS * 60.0 / 200.0) as usize, (FPS * 60.0 / 60.0) as usize);
    let ac = |lag: usize| -> f32 { (0..env.len().saturating_sub(lag)).map(|i| env[i] * env[i + lag]).sum() };
    // A beat repeats at the half bar and the bar too (a dotted beat does not).
    let score = |lag: usize| -> f32 {
        let ac = ac(lag) + 0.5 * ac(2 * lag) + 0.5 * ac(4 * lag);
        let bpm = 60.0 * FPS as f32 / lag as f32;
        let pref = (-(bpm / 110.0).ln().powi(2) / (2.0 * 0.5f32.powi(2))).exp();
        ac * (0.6 + 0.4 * pref)
    };
    let Some(best) = (min_lag..=max_lag).max_by(|&a, &b| score(a).total_cmp(&score(b))) else {
        return fallback;
    };
    // Refine period and phase on the comb of beats.
    let comb = |period: f64, phase: f64| -> f32 {
        let mut s = 0.0;
        let mut t = phase;
        while (t.round() as usize) < env.len() {
            s += env[t.round() as usize];
            t += period;
        }
        s
    };
    let mut top = (f32::MIN, best as f64, 0.0);
    for k in -20..=20 {
        let period = best as f64 + k as f64 * 0.05;
        for phase in 0..best {
            let s = comb(period, phase as f64);
            if s > top.0 {
                top = (s, period, phase as f64);
            }
        }
    }
    Beat { period_s: top.1 / FPS, phase_s: top.2 / FPS }
}

/// A rotation (w, x, y, z) of `yaw` about z after `pitch` about x (radians).
pub fn yaw_pitch(yaw: f32, pitch: f32) -> [f32; 4] {
    let (sy, cy) = ((yaw / 2.0).sin(), (yaw / 2.0).cos());
    let (sp, cp) = ((pitch / 2.0).sin(), (pitch / 2.0).cos());
    [cy * cp, cy * sp, sy * sp, sy * cp]
}

/// Zero-phase exponential smoothing (forward then backward), time constant `tau_s`.
pub fn smooth(x: &[f32], tau_s: f32) -> Vec<f32> {
    let a = 1.0 - (-1.0 / (FPS as f32 * tau_s)).exp();
    let mut y = x.to_vec();
    for i in 1..y.len() {
        y[i] = y[i - 1] + a * (y[i] - y[i - 1]);
    }
    for i in (0..y.len().saturating_sub(1)).rev() {
        y[i] = y[i + 1] + a * (y[i] - y[i + 1]);
    }
    y
}

/// Playing activity per frame, 0..1: hand notes per second over about a second, / 8.
pub fn activity(notes: &[PlannedNote], frames: usize) -> Vec<f32> {
    let mut x = vec![0f32; frames];
    for n in notes {
        if let Some(v) = x.get_mut(n.frame) {
            *v += FPS as f32 / 8.0;
        }
    }
    smooth(&x, 0.5).into_iter().map(|v| v.clamp(0.0, 1.0)).collect()
}

/// Chest and head poses per frame from the stick tips, the notes and the beat.
pub fn upper_body(
    tips: &[[[f32; 3]; 2]],
    notes: &[PlannedNote],
    beat: &Beat,
    frames: usize,
    rng: &mut Rng,
) -> (Vec<Pose>, Vec<Pose>) {
    let work: Vec<[f32; 2]> =
        tips.iter().map(|t| [(t[LEFT][0] + t[RIGHT][0]) / 2.0, (t[LEFT][1] + t[RIGHT][1]) / 2.0]).collect();
    let wx = smooth(&work.iter().map(|w| w[0]).collect::<Vec<_>>(), 0.35);
    let wy = smooth(&work.iter().map(|w| w[1]).collect::<Vec<_>>(), 0.35);
    let act = activity(notes, frames);
    let nod = NOD_DEG.to_radians() * (1.0 + 0.2 * rng.sym());
    let lean0 = 0.01 * rng.sym();
    let mut chest = Vec::with_capacity(frames);
    let mut head = Vec::with_capacity(frames);
    for f in 0..frames {
        let t = f as f64 / FPS;
        let dx = (wx[f] - WORK_HOME[0]).clamp(-0.5, 0.8);
        let dy = (wy[f] - WORK_HOME[1]).clamp(-0.3, 0.4);
        let pulse = beat.pulse(t) * act[f];
        let pos = [
            CHEST_HOME[0] + lean0 + 0.12 * dx,
            CHEST_HOME[1] + 0.15 * dy,
            CHEST_HOME[2] - BOUNCE_M * pulse - 0.03 * dy.max(0.0),
        ];
        // Turn toward the work (yaw: positive turns +y toward -x), lean forward with reach.
        let yaw = -0.5 * dx;
        let pitch = -0.25 * dy.max(0.0) - 0.04;
        let rot = yaw_pitch(yaw, pitch);
        let chest_pose = Pose { pos, rot };
        let up = chest_pose.apply([0.0, 0.04, HEAD_ABOVE_CHEST_M]);
        head.push(Pose { pos: up, rot: yaw_pitch(1.4 * yaw, pitch - 0.25 - nod * pulse) });
        chest.push(chest_pose);
    }
    (chest, head)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::midi::{DrumEvent, DrumEventKind};

    fn perf_at_bpm(bpm: f64, seconds: f64) -> Performance {
        let beat = 60.0 / bpm;
        let mut events = Vec::new();
        let mut t = 0.3;
        let mut i = 0;
        while t < seconds {
            let note = if i % 2 == 0 { 36 } else { 38 };
            events.push(DrumEvent { time_s: t, tick: 0, kind: DrumEventKind::NoteOn { note, velocity: 100 } });
            events.push(DrumEvent { time_s: t, tick: 0, kind: DrumEventKind::NoteOn { note: 42, velocity: 70 } });
            events.push(DrumEvent {
                time_s: t + beat / 2.0,
                tick: 0,
                kind: DrumEventKind::NoteOn { note: 42, velocity: 60 },
            });
            t += beat;
            i += 1;
        }
        Performance { path: "t.mid".into(), events, duration_s: seconds, notes_end_s: seconds, channel: 10 }
    }

    #[test]
    fn the_beat_of_a_steady_groove_is_found() {
        let map = NoteMap::builtin("gm").unwrap();
        for bpm in [80.0, 100.0, 126.0] {
            let p = perf_at_bpm(bpm, 20.0);
            let b = estimate_beat(&p, &map, 1201);
            let est = 60.0 / b.period_s;
            assert!((est - bpm).abs() / bpm < 0.02, "{bpm} BPM estimated as {est}");
            // The phase lands on a note (the first kick at 0.3 s, modulo the period).
            let off = (b.position(0.3) - b.position(0.3).round()).abs();
            assert!(off < 0.08, "phase off by {off} beats");
        }
    }

    #[test]
    fn smoothing_keeps_a_constant_and_spreads_an_impulse_both_ways() {
        assert!(smooth(&[2.0; 50], 0.2).iter().all(|v| (v - 2.0).abs() < 1e-5));
        let mut x = vec![0.0; 61];
        x[30] = 1.0;
        let y = smooth(&x, 0.1);
        assert!((y[25] - y[35]).abs() < 0.02 && y[25] > 0.0);
    }
}
