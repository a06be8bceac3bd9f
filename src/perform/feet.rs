//! The pedals' targets: what the feet ask of the kick beater and the hi-hat.
//!
//! - Kick: for each kick note the beater swings from its rest angle with constant angular
//!   acceleration so that it reaches the head exactly at the onset at the speed the kit's
//!   speed map gives the note's velocity; it then presses on (at most 0.08 rad) until it is
//!   felt to touch, and returns to rest (time constant 30 ms). Notes closer than a full swing
//!   start from where the beater is: the swing is shortened to 70 % of the gap.
//! - Hi-hat: the top cymbal follows the motion stage's hi-hat openness (0 closed .. 1 open:
//!   from CC4 or the notes, the data's own steps; the animated foot eases through them),
//!   interpolated between 60 fps frames. A hi-hat pedal note closes
//!   it at the onset whatever the pedal data says (an e-kit sends the note when its pedal
//!   passes its own closing threshold, which CC4 alone does not show): the foot lifts it
//!   open over 30 ms, shuts it at 0.4 of the stroke speed of its velocity, reaching it at the
//!   onset, and holds it shut 60 ms. The openness is measured from where the cymbals meet,
//!   so the simulated hi-hat is as open as the pedal data says (what direct mode sends);
//!   closed pedal data presses the top cymbal 3 mm onto the bottom one.

use crate::body::pedals::{PedalBodies, PedalTarget, HIHAT_PRESS_M, MIN_CLOSING_NOTE_FREE_MPS};
use crate::kit::{Kit, CHICK_SPEED_SCALE};
use crate::midi::{DrumEventKind, NoteMap, Performance, Zone};
use crate::motion::Motion;

/// Longest the beater presses on after the onset without touching, seconds.
const PRESS_S: f64 = 0.030;
/// Furthest the beater's target goes past the head, radians.
const PRESS_RAD: f32 = 0.08;
/// A hi-hat pedal note holds the hi-hat shut this long.
const CHICK_HOLD_S: f64 = 0.060;
/// How long the foot takes to lift the hi-hat open before a chick, seconds.
const CHICK_LIFT_S: f64 = 0.030;
/// Pedal data this near closed (openness) presses the hi-hat shut.
const CLOSED_BAND: f32 = 0.05;
/// The beater's return to rest, time constant, seconds.
const RETURN_S: f32 = 0.030;

/// The pedal notes on `piece` in time order: onset and `rate(velocity)`.
fn pedal_notes(perf: &Performance, map: &NoteMap, piece: &str, rate: impl Fn(u8) -> f32) -> Vec<(f64, f32)> {
    let mut out: Vec<(f64, f32)> = perf
        .events
        .iter()
        .filter_map(|e| match e.kind {
            DrumEventKind::NoteOn { note, velocity } => map
                .entry(note)
                .filter(|m| m.zone == Zone::Pedal && m.piece == piece)
                .map(|_| (e.time_s, rate(velocity))),
            _ => None,
        })
        .collect();
    out.sort_by(|a, b| a.0.total_cmp(&b.0));
    out
}

/// The feet's targets over a song.
pub struct PedalTargets {
    /// Kick notes: onset, angular speed at the head (rad/s).
    kicks: Vec<(f64, f32)>,
    rest: f32,
    contact: f32,
    /// The left foot's lift per 60 fps frame.
    lift: Vec<f32>,
    /// Hi-hat pedal notes: onset, closing rate (openness per second).
    chicks: Vec<(f64, f32)>,
    /// The hi-hat's travel, m.
    travel: f32,
    fps: f64,
    /// The time of `lift`'s first frame, s ([`PedalTargets::shifted`]).
    origin_s: f64,
}

impl PedalTargets {
    pub fn new(perf: &Performance, map: &NoteMap, kit: &Kit, bodies: &PedalBodies, motion: &Motion) -> PedalTargets {
        let (rest, contact) = (bodies.beater_rest_rad(), bodies.beater_contact_rad());
        let arm = bodies.pedals().beater_length_m * contact.cos();
        let mut kicks = pedal_notes(perf, map, "kick", |v| kit.strike.speed_for_velocity(v) / arm.max(0.01));
        // E-kit double triggers: kicks closer than 12 ms are one stroke.
        kicks.dedup_by(|b, a| b.0 - a.0 < 0.012);
        let travel = bodies.pedals().hihat_travel_m;
        let chicks = pedal_notes(perf, map, "hihat", |v| CHICK_SPEED_SCALE * kit.strike.speed_for_velocity(v) / travel);
        // The target is in the pedal's units (0: pressed shut by the clutch's press, `touch`:
        // the cymbals meet, 1 + `touch`: fully open). The lift is the openness the pedal data
        // asks, measured from the touch as the sound engine hears it (direct mode sends the
        // same openness): closed (within the first 5 %) presses shut. (The animated foot
        // eases through the data's steps; the top cymbal follows the data, as a pedal
        // sensor's readings follow the real pedal.)
        let touch = HIHAT_PRESS_M / travel;
        let mut lift: Vec<f32> = motion
            .frames
            .iter()
            .map(|f| {
                let open = f.hihat_openness.clamp(0.0, 1.0);
                open + touch * (open / CLOSED_BAND).min(1.0)
            })
            .collect();
        // Where no pedal note asks for a chick, the foot lets the top cymbal settle onto the
        // bottom one: the last part of a closing, from just above the touch, goes no faster
        // than a contact that makes no sound.
        let (soft, step) = (touch + 0.1, MIN_CLOSING_NOTE_FREE_MPS / travel / motion.fps as f32);
        for f in 1..lift.len() {
            if lift[f] < lift[f - 1] && lift[f] < soft {
                lift[f] = lift[f].max(lift[f - 1].min(soft) - step);
            }
        }
        PedalTargets { kicks, rest, contact, lift, chicks, travel, fps: motion.fps, origin_s: 0.0 }
    }

    /// The same targets `by` seconds later (a live window's, put on the session clock).
    pub fn shifted(mut self, by: f64) -> PedalTargets {
        self.origin_s += by;
        for k in self.kicks.iter_mut().chain(self.chicks.iter_mut()) {
            k.0 += by;
        }
        self
    }

    /// The onset of the kick note the beater is playing at `t` (the next one, or the last
    /// within its press), for the conductor's touch bookkeeping.
    pub fn kick_near(&self, t: f64, window_s: f64) -> Option<f64> {
        let i = self.kicks.partition_point(|k| k.0 < t - window_s);
        self.kicks.get(i).map(|k| k.0).filter(|&on| (on - t).abs() <= window_s)
    }

    /// The beater's target at `t`; `touched`: (a kick's onset, when the beater met the head).
    pub fn beater(&self, t: f64, touched: Option<(f64, f64)>) -> PedalTarget {
        let rest = PedalTarget { pos: self.rest, vel: 0.0, acc: 0.0 };
        let i = self.kicks.partition_point(|k| k.0 <= t);
        // The swing toward the next kick, if it has begun.
        if let Some(&(onset, w)) = self.kicks.get(i) {
            let full = 2.0 * (self.contact - self.rest) / w.max(0.1);
            let gap = if i > 0 { (onset - self.kicks[i - 1].0) as f32 } else { f32::INFINITY };
            let span = full.min(0.7 * gap);
            let dt = (onset - t) as f32;
            if dt <= span {
                let a = w / span;
                return PedalTarget { pos: self.contact - w * dt + 0.5 * a * dt * dt, vel: w - a * dt, acc: a };
            }
        }
        // Pressing on after the last kick, then back to rest.
        let Some(&(onset, w)) = i.checked_sub(1).and_then(|j| self.kicks.get(j)) else { return rest };
        let since = t - onset;
        let tc = match touched {
            Some((on, tc)) if (on - onset).abs() < 1e-9 => tc,
            _ if since < PRESS_S => {
                let pos = (self.contact + w * since as f32).min(self.contact + PRESS_RAD);
                return PedalTarget { pos, vel: if pos < self.contact + PRESS_RAD { w } else { 0.0 }, acc: 0.0 };
            }
            _ => onset + PRESS_S,
        };
        let u = ((t - tc).max(0.0) as f32 / RETURN_S).min(30.0);
        let e = (-u).exp();
        let d = self.contact - self.rest;
        PedalTarget { pos: self.rest + d * e, vel: -d * e / RETURN_S, acc: d * e / (RETURN_S * RETURN_S) }
    }

    /// The hi-hat's target at `t` (0 pressed shut .. 1 + the clutch's press over the travel
    /// fully open), with its rate.
    pub fn hihat(&self, t: f64) -> PedalTarget {
        if self.lift.is_empty() {
            return PedalTarget::default();
        }
        let x = ((t - self.origin_s) * self.fps).clamp(0.0, (self.lift.len() - 1) as f64);
        let k = x.floor() as usize;
        let k1 = (k + 1).min(self.lift.len() - 1);
        let a = (x - k as f64) as f32;
        let (p, q) = (self.lift[k], self.lift[k1]);
        let foot = PedalTarget { pos: p + (q - p) * a, vel: (q - p) * self.fps as f32, acc: 0.0 };
        // A pedal note shuts the hi-hat at its onset, whatever the pedal data said, and holds it.
        let i = self.chicks.partition_point(|c| c.0 + CHICK_HOLD_S < t);
        // The top cymbal touches the bottom one where the target is the clutch's press above
        // closed: there at the onset, then pressed shut.
        let touch = HIHAT_PRESS_M / self.travel;
        match self.chicks.get(i) {
            Some(&(onset, rate)) if t >= onset => {
                PedalTarget { pos: (touch - (t - onset) as f32 * rate).max(0.0), vel: 0.0, acc: 0.0 }
            }
            Some(&(onset, rate)) => {
                // The foot lifts first (as far as the stroke needs, at most fully open) and
                // then shuts the hi-hat at the note's speed, as a drummer's chick does.
                let ramp_s = ((1.0 - touch) / rate.max(1e-3)) as f64;
                let dt = onset - t;
                if dt > ramp_s + CHICK_LIFT_S {
                    foot
                } else if dt > ramp_s {
                    PedalTarget { pos: foot.pos.max(1.0), vel: 0.0, acc: 0.0 }
                } else {
                    PedalTarget { pos: touch + dt as f32 * rate, vel: -rate, acc: 0.0 }
                }
            }
            None => foot,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::model::DT_S;
    use crate::midi::DrumEvent;
    use crate::motion::feet::{FEET_HOME, PRESS_LIFT_M};
    use crate::motion::{MotionFrame, Pose};

    /// A kick at 1.0 s and a hi-hat pedal note at 2.0 s, feet at rest, played by the pedals.
    #[test]
    fn the_pedals_play_a_kick_and_a_chick_on_their_onsets() {
        let kit = Kit::builtin_default();
        let map = NoteMap::builtin("roland-td").unwrap();
        let on =
            |t: f64, note: u8| DrumEvent { time_s: t, tick: 0, kind: DrumEventKind::NoteOn { note, velocity: 100 } };
        let perf = Performance {
            path: "t.mid".into(),
            events: vec![on(1.0, 36), on(2.0, 44)],
            duration_s: 3.0,
            notes_end_s: 3.0,
            channel: 10,
        };
        let rest = |i: usize| Pose { pos: FEET_HOME[i], rot: Pose::IDENTITY.rot };
        let frame = MotionFrame {
            hands: [Pose::IDENTITY; 2],
            chest: Pose::IDENTITY,
            head: Pose::IDENTITY,
            feet: [rest(0), rest(1)],
            face: vec![0.0; 52],
            hihat_openness: 0.0,
        };
        let motion = Motion { fps: 60.0, frames: vec![frame; 181] };
        let mut bodies = PedalBodies::new(&kit).unwrap();
        let targets = PedalTargets::new(&perf, &map, &kit, &bodies, &motion);
        let (mut strikes, mut touched) = (Vec::new(), None);
        for k in 0..30_000 {
            let t = (k + 1) as f64 * DT_S as f64;
            let (beater, hihat) = (targets.beater(t, touched), targets.hihat(t));
            bodies.step(beater, hihat, t, &mut |s| {
                if s.side == crate::body::pedals::BEATER {
                    touched = targets.kick_near(s.time_s, 0.03).map(|on| (on, s.time_s));
                }
                strikes.push(s)
            });
        }
        let kicks: Vec<_> = strikes.iter().filter(|s| kit.pieces[s.surface].id == "kick").collect();
        let chicks: Vec<_> = strikes.iter().filter(|s| kit.pieces[s.surface].id == "hihat").collect();
        assert_eq!((kicks.len(), chicks.len()), (1, 1), "{strikes:?}");
        assert!((kicks[0].time_s - 1.0).abs() < 0.002, "kick at {}", kicks[0].time_s);
        assert!((chicks[0].time_s - 2.0).abs() < 0.002, "chick at {}", chicks[0].time_s);
        // The beater at the speed map's speed; the foot's chick slower, as in direct mode.
        let speed = kit.strike.speed_for_velocity(100);
        assert!((kicks[0].speed_mps - speed).abs() < 0.1 * speed, "{} vs {speed}", kicks[0].speed_mps);
        assert!(chicks[0].speed_mps > 0.2 * speed && chicks[0].speed_mps < 0.45 * speed, "{}", chicks[0].speed_mps);
    }

    /// Pedal data holding the hi-hat 40 % open, then closed: the simulated hi-hat is as open
    /// as the data says (the openness direct mode sends), then shut without a sound.
    #[test]
    fn the_simulated_hi_hat_is_as_open_as_the_pedal_data() {
        let kit = Kit::builtin_default();
        let map = NoteMap::builtin("roland-td").unwrap();
        let perf = Performance { path: "t.mid".into(), events: vec![], duration_s: 3.0, notes_end_s: 3.0, channel: 10 };
        let foot = |open: f32| Pose {
            pos: [FEET_HOME[0][0], FEET_HOME[0][1], FEET_HOME[0][2] + PRESS_LIFT_M * open],
            rot: Pose::IDENTITY.rot,
        };
        let frame = |open: f32| MotionFrame {
            hands: [Pose::IDENTITY; 2],
            chest: Pose::IDENTITY,
            head: Pose::IDENTITY,
            feet: [foot(open), Pose { pos: FEET_HOME[1], rot: Pose::IDENTITY.rot }],
            face: vec![0.0; 52],
            hihat_openness: open,
        };
        let frames = (0..181).map(|f| frame(if f < 90 { 0.4 } else { 0.0 })).collect();
        let motion = Motion { fps: 60.0, frames };
        let mut bodies = PedalBodies::new(&kit).unwrap();
        let targets = PedalTargets::new(&perf, &map, &kit, &bodies, &motion);
        let mut strikes = Vec::new();
        let mut at = |bodies: &mut PedalBodies, from: usize, to: usize| {
            for k in from..to {
                let t = (k + 1) as f64 * DT_S as f64;
                bodies.step(targets.beater(t, None), targets.hihat(t), t, &mut |s| strikes.push(s));
            }
            bodies.hihat_openness()
        };
        let open = at(&mut bodies, 0, 12_000);
        assert!((open - 0.4).abs() < 0.02, "open {open}");
        let shut = at(&mut bodies, 12_000, 30_000);
        assert_eq!(shut, 0.0);
        assert!(strikes.iter().all(|s| kit.pieces[s.surface].id != "hihat"), "{strikes:?}");
    }
}
