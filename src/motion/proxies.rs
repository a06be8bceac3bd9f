//! The body's solids as capsules (a segment and a radius, metres): what the whole-body IK
//! keeps the arms out of and `eval::motion_quality` measures with.
//! - torso: hips joint to neck joint, [`TORSO_R`]; thighs: hip to knee, [`THIGH_R`];
//! - upper arm: shoulder ball to elbow, [`UPPER_ARM_R`]; forearm: elbow to wrist,
//!   [`FOREARM_R`]; hand: wrist to grip, [`HAND_R`]; stick: butt to tip, [`STICK_R`];
//! - knee and shin: [`KNEE_R`], [`SHIN_R`] (in `shells`); foot: ankle to toe, [`FOOT_R`].
//!
//! The drawn body (`export::scene`) is a little narrower in depth: its belly lies 10 cm in
//! front of the spine where the torso capsule's lies 12 cm.

use nalgebra::Vector3;

pub use super::shells::{KNEE_R, SHIN_R};

type V3 = Vector3<f32>;

pub const TORSO_R: f32 = 0.12;
pub const THIGH_R: f32 = 0.075;
pub const UPPER_ARM_R: f32 = 0.045;
pub const FOREARM_R: f32 = 0.035;
pub const HAND_R: f32 = 0.04;
pub const STICK_R: f32 = 0.008;
pub const FOOT_R: f32 = 0.045;
/// From the grip to the stick's butt, m (a 40.6 cm stick held 28 cm from its tip).
pub const GRIP_TO_BUTT_M: f32 = 0.126;

/// A capsule: segment `a`-`b`, radius `r`.
#[derive(Debug, Clone, Copy)]
pub struct Capsule {
    pub a: V3,
    pub b: V3,
    pub r: f32,
    pub name: &'static str,
}

impl Capsule {
    /// How deep this capsule reaches into `o` (negative: how far apart they are).
    pub fn overlap(&self, o: &Capsule) -> f32 {
        self.r + o.r - segment_distance(self.a, self.b, o.a, o.b)
    }
}

/// Closest distance between segments `p0`-`p1` and `q0`-`q1`.
pub fn segment_distance(p0: V3, p1: V3, q0: V3, q1: V3) -> f32 {
    let (p, q) = closest_points(p0, p1, q0, q1);
    (p - q).norm()
}

/// The closest points of segments `p0`-`p1` and `q0`-`q1`, one on each.
pub fn closest_points(p0: V3, p1: V3, q0: V3, q1: V3) -> (V3, V3) {
    let (d1, d2, r) = (p1 - p0, q1 - q0, p0 - q0);
    let (a, e, f) = (d1.dot(&d1), d2.dot(&d2), d2.dot(&r));
    let (s, t) = if a < 1e-12 && e < 1e-12 {
        (0.0, 0.0)
    } else if a < 1e-12 {
        (0.0, (f / e).clamp(0.0, 1.0))
    } else {
        let c = d1.dot(&r);
        if e < 1e-12 {
            ((-c / a).clamp(0.0, 1.0), 0.0)
        } else {
            let b = d1.dot(&d2);
            let denom = a * e - b * b;
            let mut s = if denom > 1e-12 { ((b * f - c * e) / denom).clamp(0.0, 1.0) } else { 0.0 };
            let mut t = (b * s + f) / e;
            if t < 0.0 {
                t = 0.0;
                s = (-c / a).clamp(0.0, 1.0);
            } else if t > 1.0 {
                t = 1.0;
                s = ((b - c) / a).clamp(0.0, 1.0);
            }
            (s, t)
        }
    };
    (p0 + d1 * s, q0 + d2 * t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn capsules_overlap_by_their_radii_less_the_distance_of_their_segments() {
        let v = V3::new;
        // Crossing segments 10 cm apart.
        assert!(
            (segment_distance(v(-1.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.0, -1.0, 0.1), v(0.0, 1.0, 0.1)) - 0.1).abs()
                < 1e-6
        );
        // Parallel, overlapping along their length, 5 cm apart; and end to end.
        assert!(
            (segment_distance(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(0.5, 0.05, 0.0), v(2.0, 0.05, 0.0)) - 0.05).abs()
                < 1e-6
        );
        assert!(
            (segment_distance(v(0.0, 0.0, 0.0), v(1.0, 0.0, 0.0), v(1.3, 0.0, 0.0), v(2.0, 0.0, 0.0)) - 0.3).abs()
                < 1e-6
        );
        // A ball (a point segment) 8 cm from a capsule's axis: 2 cm into a 6 + 4 cm pair.
        let a = Capsule { a: v(0.0, 0.0, 0.0), b: v(1.0, 0.0, 0.0), r: 0.06, name: "a" };
        let b = Capsule { a: v(0.5, 0.08, 0.0), b: v(0.5, 0.08, 0.0), r: 0.04, name: "b" };
        assert!((a.overlap(&b) - 0.02).abs() < 1e-6);
    }
}
