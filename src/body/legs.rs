//! Legs and feet: kinematic segments that follow foot targets (the kick and hi-hat pedals),
//! so the whole figure exists. The upper body is the simulated part; the legs are posed,
//! not driven: thigh, shank and foot per side, placed by analytic two-bone IK from the hip
//! (on the fixed pelvis) to the ankle target, the knee forward and up as a seated
//! drummer's, the foot pitched as the target asks. They are not rapier bodies: with no
//! mass that moves the simulated part and nothing in the kit struck by a leg (the pedals
//! sound through their notes), bodies in the world would only cost time (measured: 5 % of
//! the 10 kHz loop for six idle kinematic bodies).

use super::anthropometry::{Anthropometry, Segment};
use super::skeleton::HIP_HEIGHT_M;
use rapier3d::math::{Rotation, Vector};

/// Ankles at rest on the hi-hat pedal (left) and the kick pedal (right), and the hips' half
/// width as a fraction of height.
pub const FEET_HOME: [[f32; 3]; 2] = [[-0.28, 0.30, 0.10], [0.10, 0.40, 0.10]];
const HIP_HALF_WIDTH: f32 = 0.05;

/// Where a foot should be: its ankle and how far the toe is raised (radians; 0 flat).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FootTarget {
    pub ankle: Vector,
    pub toe_up_rad: f32,
}

impl FootTarget {
    pub fn home(side: usize) -> FootTarget {
        FootTarget { ankle: Vector::from(FEET_HOME[side]), toe_up_rad: 0.0 }
    }
}

/// The legs' geometry and targets.
#[derive(Debug, Clone)]
pub struct Legs {
    pub hips: [Vector; 2],
    pub thigh_m: f32,
    pub shank_m: f32,
    pub foot_m: f32,
    pub targets: [FootTarget; 2],
}

/// Joint positions of one leg: hip, knee, ankle, toe.
pub type LegPose = [Vector; 4];

impl Legs {
    /// The legs of a body of these proportions, feet on the pedals.
    pub fn new(anthro: &Anthropometry) -> Legs {
        let h = anthro.settings.height_m;
        Legs {
            hips: [-1.0f32, 1.0].map(|s| Vector::new(s * HIP_HALF_WIDTH * h, 0.0, HIP_HEIGHT_M)),
            thigh_m: anthro.length_m(Segment::UpperLeg),
            shank_m: anthro.length_m(Segment::LowerLeg),
            foot_m: anthro.length_m(Segment::Foot),
            targets: [FootTarget::home(0), FootTarget::home(1)],
        }
    }

    /// Joint positions of leg `side` for its current target: the reach is clamped so an
    /// unreachable ankle straightens the leg toward it.
    pub fn pose(&self, side: usize) -> LegPose {
        let t = self.targets[side];
        let hip = self.hips[side];
        let to = t.ankle - hip;
        let (l1, l2) = (self.thigh_m, self.shank_m);
        let d = to.length().clamp((l1 - l2).abs() + 1e-3, l1 + l2 - 1e-4);
        let u = to.normalize_or(-Vector::Z);
        let ankle = hip + u * d;
        // Knee forward and up (a seated drummer's), in the plane of hip, ankle and that pole.
        let pole = Vector::new(0.0, 1.0, 0.4);
        let w = (pole - u * pole.dot(u)).normalize_or(Vector::Y);
        let a = (l1 * l1 - l2 * l2 + d * d) / (2.0 * d);
        let knee = hip + u * a + w * (l1 * l1 - a * a).max(0.0).sqrt();
        // The foot points forward (from the ankle toward the pedal's far end), toe raised.
        let fwd = Vector::new(0.0, 1.0, 0.0);
        let toe = ankle + Rotation::from_axis_angle(Vector::X, t.toe_up_rad) * fwd * self.foot_m;
        [hip, knee, ankle, toe]
    }

    /// Set the feet's targets (non-finite targets are ignored).
    pub fn set_targets(&mut self, targets: [FootTarget; 2]) {
        for (side, t) in targets.into_iter().enumerate() {
            if t.ankle.is_finite() && t.toe_up_rad.is_finite() {
                self.targets[side] = FootTarget { ankle: t.ankle, toe_up_rad: t.toe_up_rad.clamp(-0.6, 0.8) };
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::anthropometry::BodySettings;

    fn legs() -> Legs {
        Legs::new(&Anthropometry::new(BodySettings::default()).unwrap())
    }

    #[test]
    fn feet_reach_the_pedals_with_the_knees_forward_and_the_bones_whole() {
        let legs = legs();
        for side in 0..2 {
            let [hip, knee, ankle, toe] = legs.pose(side);
            assert!((ankle - Vector::from(FEET_HOME[side])).length() < 1e-4);
            assert!(((knee - hip).length() - legs.thigh_m).abs() < 1e-4);
            assert!(((ankle - knee).length() - legs.shank_m).abs() < 1e-4);
            assert!(((toe - ankle).length() - legs.foot_m).abs() < 1e-4);
            // Seated: the knee is in front of the hip and above the ankle.
            assert!(knee.y > hip.y + 0.2 && knee.z > ankle.z + 0.2, "{knee:?}");
        }
    }

    #[test]
    fn a_pressed_pedal_moves_the_foot_and_bad_targets_keep_the_last() {
        let mut legs = legs();
        let lifted = FootTarget { ankle: Vector::new(0.10, 0.40, 0.14), toe_up_rad: 0.3 };
        legs.set_targets([FootTarget::home(0), lifted]);
        let [_, _, ankle, toe] = legs.pose(1);
        assert!((ankle - lifted.ankle).length() < 1e-4, "{ankle:?}");
        assert!(toe.z > ankle.z + 0.05);
        // NaN is ignored, an unreachable ankle straightens the leg toward it, finite.
        let far = FootTarget { ankle: Vector::new(0.1, 3.0, 0.1), toe_up_rad: 0.0 };
        let nan = FootTarget { ankle: Vector::new(f32::NAN, 0.0, 0.0), toe_up_rad: 0.0 };
        legs.set_targets([nan, far]);
        assert_eq!(legs.targets[0], FootTarget::home(0));
        let [hip, _, ankle, _] = legs.pose(1);
        assert!(((ankle - hip).length() - (legs.thigh_m + legs.shank_m)).abs() < 1e-3);
        assert!(legs.pose(0).iter().chain(legs.pose(1).iter()).all(|p| p.is_finite()));
    }
}
