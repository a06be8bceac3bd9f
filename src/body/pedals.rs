//! The two pedals as bodies of the simulation, stepped at 10 kHz beside the arms:
//! - the kick beater, a rigid pendulum on its axle (one rotational degree of freedom) whose
//!   ball meets the kick head: a unilateral contact with restitution;
//! - the top hi-hat cymbal, a mass on the pedal's rod (one translational degree of freedom)
//!   that meets the bottom cymbal when the pedal closes.
//!
//! Each is driven toward a target (angle or gap, with its rate and acceleration) by a
//! computed-torque PD, as the foot drives the footboard. A new contact (after
//! [`super::contacts::RELEASE_S`] apart) at a speed of at least
//! [`super::contacts::MIN_STRIKE_SPEED_MPS`] is a [`Strike`]: `side` 2 for the beater (right
//! foot), 3 for the hi-hat (left foot). No allocation.

use super::contacts::{Strike, MIN_STRIKE_SPEED_MPS, RELEASE_S};
use super::model::{surface_basis, DT_S};
use crate::kit::{Kit, Pedals};
use rapier3d::math::Vector;

/// Radius of the beater's ball, m.
pub const BALL_RADIUS_M: f32 = 0.035;
/// Coefficient of restitution of the felt beater on the kick head, and of the two hi-hat
/// cymbals.
const BEATER_RESTITUTION: f32 = 0.3;
const HIHAT_RESTITUTION: f32 = 0.1;
/// How far past closed the foot presses the hi-hat's top cymbal, m (the clutch's spring).
pub const HIHAT_PRESS_M: f32 = 0.003;
/// The foot closes the hi-hat this slowly where no pedal note asks for a chick, m/s: under
/// [`MIN_STRIKE_SPEED_MPS`], so the cymbals settle together without a sound.
pub const MIN_CLOSING_NOTE_FREE_MPS: f32 = 0.6 * MIN_STRIKE_SPEED_MPS;
/// Natural frequency of the pedals' drive, Hz (critically damped).
const DRIVE_HZ: f32 = 60.0;

/// Striker index of the kick beater and of the hi-hat's top cymbal in [`Strike::side`].
pub const BEATER: usize = 2;
pub const HIHAT_FOOT: usize = 3;

/// A target for a one-degree-of-freedom pedal: position, rate, acceleration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PedalTarget {
    pub pos: f32,
    pub vel: f32,
    pub acc: f32,
}

/// One degree of freedom against a stop at `stop` (approached from below), with its contact
/// bookkeeping.
#[derive(Debug, Clone)]
struct Axis {
    pos: f32,
    vel: f32,
    stop: f32,
    restitution: f32,
    /// Time of the last step in contact; NaN when free.
    touching_since: f64,
}

impl Axis {
    /// One step toward `target` with computed-torque PD; returns the approach rate at a new
    /// impact, if one happened.
    fn step(&mut self, target: PedalTarget, time_s: f64) -> Option<f32> {
        let w = std::f32::consts::TAU * DRIVE_HZ;
        let acc = target.acc + w * w * (target.pos - self.pos) + 2.0 * w * (target.vel - self.vel);
        // Semi-implicit Euler (w dt = 0.04: well inside its stable range).
        self.vel += DT_S * acc;
        self.pos += DT_S * self.vel;
        let mut impact = None;
        if self.pos >= self.stop {
            let rate = self.vel.max(0.0);
            self.pos = self.stop;
            if rate > 0.0 {
                if self.touching_since.is_nan() {
                    impact = Some(rate);
                }
                self.vel = -self.restitution * rate;
            }
            self.touching_since = time_s;
        } else if time_s - self.touching_since > RELEASE_S {
            self.touching_since = f64::NAN;
        }
        impact
    }
}

/// The kick beater and the hi-hat's top cymbal.
#[derive(Debug, Clone)]
pub struct PedalBodies {
    pedals: Pedals,
    /// Beater angle from vertical toward the head, radians (the axis' position).
    beater: Axis,
    /// Minus the top cymbal's gap above the bottom one, m (the stop is 0: closed).
    hihat: Axis,
    /// Kick head: surface index, centre, normal, tangent axes.
    kick: Option<(usize, Vector, Vector, Vector, Vector)>,
    /// The hi-hat's surface and where a chick sounds on it (x, y): at the bow's radius on
    /// the drummer's side, where direct mode puts it.
    hihat_surface: Option<(usize, f32, f32)>,
    beater_mass_kg: f32,
    hihat_mass_kg: f32,
}

impl PedalBodies {
    /// The pedals of `kit`, at rest (beater back, hi-hat closed); `None` without `[pedals]`.
    pub fn new(kit: &Kit) -> Option<PedalBodies> {
        let pedals = kit.pedals?;
        let kick = kit.index_of("kick").map(|i| {
            let p = &kit.pieces[i];
            let n = Vector::from(p.normal).normalize();
            let (u, v) = surface_basis(n);
            (i, Vector::from(p.position_m), n, u, v)
        });
        // The beater touches the head where the ball's centre is one radius in front of it.
        let contact = kick.map_or(0.3, |(_, c, n, _, _)| {
            let axle = Vector::from(pedals.kick_axle_m);
            let gap = (axle - c).dot(n) - BALL_RADIUS_M;
            (gap / pedals.beater_length_m).clamp(-1.0, 1.0).asin()
        });
        let rest = contact - pedals.beater_rest_deg.to_radians();
        let hihat_surface = kit.index_of("hihat").map(|i| {
            let (r, a) = (kit.pieces[i].radius_m * kit.zones.bow, crate::kit::toward_drummer_angle(&kit.pieces[i]));
            (i, r * a.cos(), r * a.sin())
        });
        Some(PedalBodies {
            pedals,
            beater: Axis {
                pos: rest,
                vel: 0.0,
                stop: contact,
                restitution: BEATER_RESTITUTION,
                touching_since: f64::NAN,
            },
            hihat: Axis { pos: 0.0, vel: 0.0, stop: 0.0, restitution: HIHAT_RESTITUTION, touching_since: f64::NAN },
            kick,
            hihat_surface,
            beater_mass_kg: kit.strike.beater_mass_kg,
            hihat_mass_kg: kit.strike.hihat_foot_mass_kg,
        })
    }

    pub fn pedals(&self) -> &Pedals {
        &self.pedals
    }

    /// The beater's angle where its ball touches the head, and at rest, radians.
    pub fn beater_contact_rad(&self) -> f32 {
        self.beater.stop
    }
    pub fn beater_rest_rad(&self) -> f32 {
        self.beater.stop - self.pedals.beater_rest_deg.to_radians()
    }

    /// The beater's angle now, radians.
    pub fn beater_rad(&self) -> f32 {
        self.beater.pos
    }

    /// How open the hi-hat is now, 0 closed .. 1 the pedal's full travel.
    pub fn hihat_openness(&self) -> f32 {
        (-self.hihat.pos / self.pedals.hihat_travel_m).clamp(0.0, 1.0)
    }

    /// The beater ball's centre, kit frame.
    pub fn ball(&self) -> Vector {
        let a = self.beater.pos;
        let axle = Vector::from(self.pedals.kick_axle_m);
        let toward = self.kick.map_or(Vector::Y, |(_, _, n, _, _)| -n);
        axle + (Vector::Z * a.cos() + toward * a.sin()) * self.pedals.beater_length_m
    }

    /// One 10 kHz step: the beater toward `beater` (radians), the hi-hat toward an openness
    /// `hihat` (0..1 of the travel, with its rates). New contacts go to `sink`.
    pub fn step(&mut self, beater: PedalTarget, hihat: PedalTarget, time_s: f64, sink: &mut impl FnMut(Strike)) {
        if let Some(rate) = self.beater.step(beater, time_s) {
            if let Some((surface, c, n, u, v)) = self.kick {
                let a = self.beater.pos;
                let l = self.pedals.beater_length_m;
                // The ball's velocity is tangential; its part along the head's inward normal.
                let toward = -n;
                let dir = -Vector::Z * a.sin() + toward * a.cos();
                let speed = rate * l * dir.dot(toward);
                let point = self.ball() + toward * BALL_RADIUS_M;
                let d = point - c;
                if speed >= MIN_STRIKE_SPEED_MPS {
                    sink(Strike {
                        surface,
                        side: BEATER,
                        time_s,
                        speed_mps: speed,
                        mass_kg: self.beater_mass_kg,
                        x_m: d.dot(u),
                        y_m: d.dot(v),
                        impulse_ns: self.beater_mass_kg * speed * (1.0 + BEATER_RESTITUTION),
                        point,
                        stick_dir: dir,
                        from_tip_m: 0.0,
                    });
                }
            }
        }
        let travel = self.pedals.hihat_travel_m;
        // Closed is the foot pressing the top cymbal onto the bottom one.
        let target =
            PedalTarget { pos: HIHAT_PRESS_M - hihat.pos * travel, vel: -hihat.vel * travel, acc: -hihat.acc * travel };
        if let Some(rate) = self.hihat.step(target, time_s) {
            if let (Some((surface, x_m, y_m)), true) = (self.hihat_surface, rate >= MIN_STRIKE_SPEED_MPS) {
                sink(Strike {
                    surface,
                    side: HIHAT_FOOT,
                    time_s,
                    speed_mps: rate,
                    mass_kg: self.hihat_mass_kg,
                    x_m,
                    y_m,
                    impulse_ns: self.hihat_mass_kg * rate * (1.0 + HIHAT_RESTITUTION),
                    point: Vector::ZERO,
                    stick_dir: -Vector::Z,
                    from_tip_m: 0.0,
                });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn swing(bodies: &mut PedalBodies, target: impl Fn(f64) -> PedalTarget, secs: f64) -> Vec<Strike> {
        let mut out = Vec::new();
        let steps = (secs / DT_S as f64) as usize;
        for k in 0..steps {
            let t = (k + 1) as f64 * DT_S as f64;
            bodies.step(target(t), PedalTarget::default(), t, &mut |s| out.push(s));
        }
        out
    }

    #[test]
    fn the_beater_strikes_the_kick_head_once_at_the_speed_it_swings() {
        let kit = Kit::builtin_default();
        let mut b = PedalBodies::new(&kit).unwrap();
        let (rest, contact) = (b.beater_rest_rad(), b.beater_contact_rad());
        // A swing from rest reaching the head at 0.5 s at 8 rad/s, pressing on 0.05 rad.
        let w = 8.0f32;
        let span = 2.0 * (contact - rest) / w;
        let target = move |t: f64| {
            let dt = (0.5 - t) as f32;
            if dt > span {
                PedalTarget { pos: rest, vel: 0.0, acc: 0.0 }
            } else if dt > 0.0 {
                let a = w / span;
                PedalTarget { pos: contact - w * dt + 0.5 * a * dt * dt, vel: w - a * dt, acc: a }
            } else {
                PedalTarget { pos: (contact - w * dt).min(contact + 0.05), vel: 0.0, acc: 0.0 }
            }
        };
        let strikes = swing(&mut b, target, 0.8);
        assert_eq!(strikes.len(), 1, "{strikes:?}");
        let s = strikes[0];
        assert_eq!((s.side, kit.pieces[s.surface].id.as_str()), (BEATER, "kick"));
        assert!((s.time_s - 0.5).abs() < 0.002, "{}", s.time_s);
        let expect = w * kit.pedals.unwrap().beater_length_m * contact.cos();
        assert!((s.speed_mps - expect).abs() < 0.15 * expect, "{} vs {expect}", s.speed_mps);
        // Near the head's centre, in its plane.
        assert!(s.x_m.abs() < 0.01 && s.y_m.abs() < 0.1, "{} {}", s.x_m, s.y_m);
    }

    #[test]
    fn the_hi_hat_chicks_when_it_closes_fast_and_not_when_it_closes_slowly() {
        let kit = Kit::builtin_default();
        let mut b = PedalBodies::new(&kit).unwrap();
        let mut out = Vec::new();
        let rest = PedalTarget { pos: b.beater_rest_rad(), ..Default::default() };
        let run = |b: &mut PedalBodies, f: &dyn Fn(f64) -> f32, from: f64, secs: f64, out: &mut Vec<Strike>| {
            for k in 0..(secs / DT_S as f64) as usize {
                let t = from + (k + 1) as f64 * DT_S as f64;
                b.step(rest, PedalTarget { pos: f(t), ..Default::default() }, t, &mut |s| out.push(s));
            }
        };
        // Open over 0.2 s, then shut at once.
        run(&mut b, &|t| if t < 0.3 { (t / 0.2).min(1.0) as f32 } else { 0.0 }, 0.0, 0.5, &mut out);
        assert_eq!(out.len(), 1, "{out:?}");
        assert_eq!(out[0].side, HIHAT_FOOT);
        assert!(out[0].speed_mps > 0.3, "{}", out[0].speed_mps);
        out.clear();
        // Open, then close over a whole second: no chick.
        run(&mut b, &|t| (1.0 - (t - 0.5)).clamp(0.0, 1.0) as f32, 0.5, 1.5, &mut out);
        assert!(out.is_empty(), "{out:?}");
    }
}
