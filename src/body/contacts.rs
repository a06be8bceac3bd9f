//! Stick-kit contacts: onsets found in rapier's narrow phase, turned into strikes.
//!
//! A contact starts in the first step where the solver pushes a stick off a piece (a
//! non-zero normal impulse between the two colliders; a merely predicted contact passing
//! by does not count) and ends after `RELEASE_S` without impulse, so a stroke pressed into a
//! head, or chattering on it, is one contact. The speed is the tip's fastest approach along
//! the normal in the 3 ms before the impulse (the solver's soft contact slows it over the last
//! millimetre), the mass the stick's own effective mass at the point struck along the
//! normal (see [`stick_strike_mass`]), and the impulse the solver's impulse in the onset
//! step. No allocation.

use super::model::{Model, Surface};
use super::skeleton::{Skeleton, StickGeometry, HAND};
use crate::interaction::message::{ContactMessage, Limb};
use rapier3d::prelude::*;

/// Time without impulse that ends a contact, seconds. A stick that leaves a surface and
/// meets it again sooner is still the same impact: a real stick's contact with a head lasts
/// 1-6 ms, and a hi-hat's top cymbal, pushed down by the stick, springs back into it a few
/// ms later. At 3 ms such re-touches of the hi-hat 3.5-4 ms after a stroke came out as a
/// second stroke (live play on six validation takes: precision 83.7 % at 3 ms, 87.7 % at 6).
pub const RELEASE_S: f64 = 0.006;
/// Smallest impulse that counts as touching, N s.
const MIN_IMPULSE_NS: f32 = 1e-6;
/// Slowest approach that is a strike; slower contacts are a stick settling onto a piece
/// (after a bounce, or resting), which make no sound and send no message.
pub const MIN_STRIKE_SPEED_MPS: f32 = 0.05;
/// The same for a stick: a quarter of the slowest note's speed on the shipped kits (0.4 m/s
/// at velocity 1). On a rigid kit (`model::KIT_CONTACT_HZ`) a stick pressed onto a cymbal
/// and lifted a little settles back onto it at about 0.09 m/s (`drumsim check`'s tenuto
/// strokes on the rearranged kit's hi-hat, 53 ms after each stroke).
pub const MIN_STICK_STRIKE_SPEED_MPS: f32 = 0.1;

/// A new contact of a stick tip with a kit piece.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strike {
    /// Index into the drummer's surfaces (the kit's pieces, in kit order).
    pub surface: usize,
    /// 0 left stick, 1 right stick, 2 kick beater (right foot), 3 hi-hat pedal (left foot).
    pub side: usize,
    pub time_s: f64,
    pub speed_mps: f32,
    pub mass_kg: f32,
    /// Strike point in the surface's coordinates, metres from its centre (a hoop's: its
    /// sound plate's centre).
    pub x_m: f32,
    pub y_m: f32,
    pub impulse_ns: f32,
    /// The contact point in world coordinates (on the piece's surface).
    pub point: Vector,
    /// The stick's direction (butt to tip) at contact.
    pub stick_dir: Vector,
    /// Distance of the contact point from the stick's tip end, metres (0: the tip bead).
    pub from_tip_m: f32,
}

impl Strike {
    /// The contact message of DESIGN.md section 6 for this strike.
    pub fn message(&self, surfaces: &[Surface]) -> ContactMessage {
        self.message_named(&surfaces[self.surface].id)
    }

    /// [`Self::message`] with the struck surface's id given.
    pub fn message_named(&self, piece: &str) -> ContactMessage {
        ContactMessage {
            piece: piece.to_string(),
            time_s: self.time_s as f32,
            speed_mps: self.speed_mps,
            mass_kg: self.mass_kg,
            x_m: self.x_m,
            y_m: self.y_m,
            impulse_ns: self.impulse_ns,
            hardness: 1.0,
            limb: match self.side {
                0 => Limb::LeftHand,
                1 => Limb::RightHand,
                2 => Limb::RightFoot,
                _ => Limb::LeftFoot,
            },
        }
    }
}

/// Steps of tip velocity kept to find a contact's impact speed (3 ms at 10 kHz).
const APPROACH_STEPS: usize = 30;

/// Contact state of both sticks against every surface.
#[derive(Clone)]
pub struct ContactTracker {
    /// Last time each (stick, surface) pair had impulse; NaN when not in contact.
    touching_since: [Vec<f64>; 2],
    /// Tip velocity at the end of each of the last [`APPROACH_STEPS`] steps (a ring).
    recent_tip_vel: [[Vector; APPROACH_STEPS]; 2],
    ring: usize,
    pub max_penetration_m: f32,
    /// Where the deepest penetration was: time, surface, stick.
    pub deepest_at: (f64, usize, usize),
    /// The striking mass of a stick's tip struck square to its axis (the kit's
    /// `strike.stick_mass_kg`), kg.
    tip_mass_kg: f32,
}

impl ContactTracker {
    pub fn new(model: &Model, tip_mass_kg: f32) -> ContactTracker {
        let n = model.surfaces.len();
        ContactTracker {
            touching_since: [vec![f64::NAN; n], vec![f64::NAN; n]],
            recent_tip_vel: [[Vector::ZERO; APPROACH_STEPS]; 2],
            ring: 0,
            max_penetration_m: 0.0,
            deepest_at: (0.0, 0, 0),
            tip_mass_kg,
        }
    }

    /// The surfaces stick `side` is touching now (struck or resting).
    pub fn touching(&self, side: usize) -> impl Iterator<Item = usize> + '_ {
        self.touching_since[side].iter().enumerate().filter(|(_, t)| !t.is_nan()).map(|(k, _)| k)
    }

    /// Look at the contacts after a step ending at `time_s`; report new ones to `sink`.
    pub fn update(&mut self, model: &Model, skel: &Skeleton, time_s: f64, sink: &mut impl FnMut(Strike)) {
        let world = &model.world;
        for side in 0..2 {
            let hand = &world.bodies[model.bodies[HAND[side]]];
            let tip = hand.position().transform_point(skel.stick.tip());
            for pair in world.narrow_phase.contact_pairs_with(model.sticks[side]) {
                let other = if pair.collider1 == model.sticks[side] { pair.collider2 } else { pair.collider1 };
                let Some(k) = model.surface_of(other) else { continue };
                let Some((manifold, c)) = pair.find_deepest_contact() else { continue };
                if -c.dist > self.max_penetration_m {
                    self.max_penetration_m = -c.dist;
                    self.deepest_at = (time_s, k, side);
                }
                let impulse = pair.total_impulse_magnitude();
                if impulse <= MIN_IMPULSE_NS {
                    continue;
                }
                // The contact point on the kit's side.
                let (kit_collider, local) =
                    if pair.collider1 == other { (pair.collider1, c.local_p1) } else { (pair.collider2, c.local_p2) };
                let point = world.colliders.get(kit_collider).map_or(tip, |col| col.position().transform_point(local));
                let last = self.touching_since[side][k];
                // The impact speed: the fastest approach along the normal in the last 3 ms.
                // The solver's speculative, soft contact starts slowing the tip about a
                // millimetre before the first impulse it reports; the stick hit at the speed it
                // had before that.
                // Into the surface where it was struck: a head's or a cymbal's face normal,
                // but a hoop's tube by the contact's own normal (up where a rim shot lands,
                // out where a cross-stick's shaft clicks it; the hoop piece's normal in the
                // kit file only places its sound).
                let face = model.surfaces[k].normal;
                let n = if last.is_nan() && model.is_ring(k) {
                    // The manifold's normal points from collider 1 to collider 2.
                    let n =
                        if pair.collider1 == model.sticks[side] { -manifold.data.normal } else { manifold.data.normal };
                    if n.is_finite() && n.length_squared() > 0.5 {
                        n
                    } else {
                        face
                    }
                } else {
                    face
                };
                let speed_mps = if last.is_nan() {
                    self.recent_tip_vel[side].iter().map(|v| -v.dot(n)).fold(0.0f32, f32::max)
                } else {
                    0.0
                };
                if last.is_nan() && speed_mps >= MIN_STICK_STRIKE_SPEED_MPS {
                    let surface = &model.surfaces[k];
                    // A hoop sounds as a small plate standing for the whole ring: a contact
                    // anywhere on the ring strikes it at its centre, as direct mode does (the
                    // ring point lies outside that plate, where nothing would ring).
                    let (x_m, y_m) = if model.is_ring(k) { (0.0, 0.0) } else { surface.local_xy(point) };
                    let stick_dir = *hand.rotation() * skel.stick.dir;
                    let from_tip_m = (tip - point).dot(stick_dir).max(0.0);
                    sink(Strike {
                        surface: k,
                        side,
                        time_s,
                        speed_mps,
                        mass_kg: self.tip_mass_kg * stick_strike_mass(&skel.stick, stick_dir, tip, point, n),
                        x_m,
                        y_m,
                        impulse_ns: impulse,
                        point,
                        stick_dir,
                        from_tip_m,
                    });
                }
                self.touching_since[side][k] = time_s;
            }
            for last in self.touching_since[side].iter_mut() {
                if time_s - *last > RELEASE_S {
                    *last = f64::NAN;
                }
            }
            self.recent_tip_vel[side][self.ring] = hand.velocity_at_point(tip);
        }
        self.ring = (self.ring + 1) % APPROACH_STEPS;
    }
}

/// The mass a stick strikes with at `point` along `n`, relative to a strike with its tip
/// square to its axis.
///
/// In the simulation the stick is welded into the hand body, whose effective mass at the
/// tip is 0.11-0.18 kg. A real grip is soft: over the 1-6 ms of a contact the fingers
/// and palm hardly move, and the head meets the stick alone, a free rod about its own
/// centre of mass. Its effective mass `1 / (1/m + s^2 sin^2(theta) / I)` (`s` the point's
/// distance from the centre along the stick, `theta` the angle between `n` and the
/// stick) is here divided by the same at the tip square to the stick (`m / 4`), so the
/// kit's `stick_mass_kg`, the figure the speed map was calibrated with, stays the mass of
/// a plain tip strike; a shaft near the stick's middle strikes with up to four times it.
pub fn stick_strike_mass(stick: &StickGeometry, dir: Vector, tip: Vector, point: Vector, n: Vector) -> f32 {
    let len = stick.to_tip_m + stick.to_butt_m;
    // Along the stick from its centre to the point struck, clamped to the stick.
    let s = ((point - tip).dot(dir) + 0.5 * len).clamp(-0.5 * len, 0.5 * len);
    let sin2 = (1.0 - dir.dot(n).powi(2)).clamp(0.0, 1.0);
    // A uniform rod: I = m len^2 / 12, so s^2 sin^2 / I = 12 s^2 sin^2 / (m len^2).
    4.0 / (1.0 + 12.0 * s * s * sin2 / (len * len))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stick_strikes_with_the_kit_s_mass_at_its_tip_and_more_nearer_its_middle() {
        let stick = StickGeometry {
            grip: Vector::ZERO,
            dir: Vector::Y,
            to_tip_m: 0.28,
            to_butt_m: 0.12,
            radius_m: 0.007,
            mass_kg: 0.375,
        };
        let tip = stick.tip();
        let down = -Vector::Z;
        // The tip square to the stick: the kit's mass.
        assert!((stick_strike_mass(&stick, Vector::Y, tip, tip, down) - 1.0).abs() < 1e-5);
        // The stick's middle, or the tip struck end-on: the whole rod, four times it.
        let middle = tip - Vector::Y * 0.2;
        assert!((stick_strike_mass(&stick, Vector::Y, tip, middle, down) - 4.0).abs() < 1e-4);
        assert!((stick_strike_mass(&stick, Vector::Y, tip, tip, -Vector::Y) - 4.0).abs() < 1e-4);
        // A stick 30 degrees off a head strikes a little heavier than square to it.
        let dir = Vector::new(0.0, 30f32.to_radians().cos(), -30f32.to_radians().sin());
        let m = stick_strike_mass(&stick, dir, tip, tip, down);
        assert!(m > 1.1 && m < 1.4, "{m}");
    }
}
