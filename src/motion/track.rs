//! The motion every part of `motion` reads and writes: 60 fps frames of the six IK targets
//! (two hands, chest, head, two feet), 52 ARKit face weights and hi-hat openness.
//!
//! Frame: the kit's (metres; origin on the floor under the stool seat's centre; +x to the
//! drummer's right, +y forward, +z up). A hand's pose is its grip point and rotation; the
//! stick lies along the hand's local +y, so the tip is `pos + rot * STICK_TIP_LOCAL` (the
//! same convention as the physical body in `body::skeleton`).

use serde::{Deserialize, Serialize};

/// Frames per second of all motion (the piano roll's rate).
pub const FPS: f64 = 60.0;
/// Values per frame of the hand model's output: per hand (left, right) position (3) and
/// rotation quaternion (w, x, y, z).
pub const HAND_VALUES: usize = 14;
/// Grip to stick tip in the hand's frame: 0.7 of a 40 cm stick along +y.
pub const STICK_TIP_LOCAL: [f32; 3] = [0.0, 0.28, 0.0];

/// A position and a unit rotation quaternion (w, x, y, z).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Pose {
    pub pos: [f32; 3],
    pub rot: [f32; 4],
}

impl Pose {
    pub const IDENTITY: Pose = Pose { pos: [0.0; 3], rot: [1.0, 0.0, 0.0, 0.0] };

    /// The rotation as nalgebra's unit quaternion (normalised).
    pub fn rotation(&self) -> nalgebra::UnitQuaternion<f32> {
        let [w, x, y, z] = self.rot;
        nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
    }

    /// A point given in this pose's local frame, in the world.
    pub fn apply(&self, local: [f32; 3]) -> [f32; 3] {
        let p = self.rotation() * nalgebra::Vector3::from(local);
        [self.pos[0] + p.x, self.pos[1] + p.y, self.pos[2] + p.z]
    }

    /// The stick tip of a hand at this pose.
    pub fn stick_tip(&self) -> [f32; 3] {
        self.apply(STICK_TIP_LOCAL)
    }
}

/// The two hands of a frame as the hand model's 14 values, and back.
pub fn hands_to_values(hands: &[Pose; 2]) -> [f32; HAND_VALUES] {
    let mut v = [0.0; HAND_VALUES];
    for (side, h) in hands.iter().enumerate() {
        v[side * 7..side * 7 + 3].copy_from_slice(&h.pos);
        v[side * 7 + 3..side * 7 + 7].copy_from_slice(&h.rot);
    }
    v
}

/// The inverse of [`hands_to_values`]; quaternions are normalised (a network's output is not).
pub fn values_to_hands(v: &[f32; HAND_VALUES]) -> [Pose; 2] {
    std::array::from_fn(|side| {
        let o = side * 7;
        let mut rot = [v[o + 3], v[o + 4], v[o + 5], v[o + 6]];
        let n = rot.iter().map(|x| x * x).sum::<f32>().sqrt();
        rot = if n > 1e-6 && n.is_finite() { rot.map(|x| x / n) } else { Pose::IDENTITY.rot };
        Pose { pos: [v[o], v[o + 1], v[o + 2]], rot }
    })
}

/// One 60 fps frame of whole-body drumming motion: the six IK targets and the face.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MotionFrame {
    /// Left, right hand (grip point; stick along local +y).
    pub hands: [Pose; 2],
    /// Upper chest (top of the spine), and the head.
    pub chest: Pose,
    pub head: Pose,
    /// Left, right foot (ankle), on or above the hi-hat and kick pedals.
    pub feet: [Pose; 2],
    /// The 52 ARKit blendshape weights, 0..1, in [`ARKIT_NAMES`] order.
    pub face: Vec<f32>,
    /// Hi-hat openness, 0 closed .. 1 open.
    pub hihat_openness: f32,
}

/// A whole performance's motion.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Motion {
    pub fps: f64,
    pub frames: Vec<MotionFrame>,
}

impl Motion {
    /// Stick tips of every frame, per hand.
    pub fn tips(&self) -> Vec<[[f32; 3]; 2]> {
        self.frames.iter().map(|f| [f.hands[0].stick_tip(), f.hands[1].stick_tip()]).collect()
    }
}

/// The 52 ARKit face blendshapes, in Apple's order.
pub const ARKIT_NAMES: [&str; 52] = [
    "eyeBlinkLeft",
    "eyeLookDownLeft",
    "eyeLookInLeft",
    "eyeLookOutLeft",
    "eyeLookUpLeft",
    "eyeSquintLeft",
    "eyeWideLeft",
    "eyeBlinkRight",
    "eyeLookDownRight",
    "eyeLookInRight",
    "eyeLookOutRight",
    "eyeLookUpRight",
    "eyeSquintRight",
    "eyeWideRight",
    "jawForward",
    "jawLeft",
    "jawRight",
    "jawOpen",
    "mouthClose",
    "mouthFunnel",
    "mouthPucker",
    "mouthLeft",
    "mouthRight",
    "mouthSmileLeft",
    "mouthSmileRight",
    "mouthFrownLeft",
    "mouthFrownRight",
    "mouthDimpleLeft",
    "mouthDimpleRight",
    "mouthStretchLeft",
    "mouthStretchRight",
    "mouthRollLower",
    "mouthRollUpper",
    "mouthShrugLower",
    "mouthShrugUpper",
    "mouthPressLeft",
    "mouthPressRight",
    "mouthLowerDownLeft",
    "mouthLowerDownRight",
    "mouthUpperUpLeft",
    "mouthUpperUpRight",
    "browDownLeft",
    "browDownRight",
    "browInnerUp",
    "browOuterUpLeft",
    "browOuterUpRight",
    "cheekPuff",
    "cheekSquintLeft",
    "cheekSquintRight",
    "noseSneerLeft",
    "noseSneerRight",
    "tongueOut",
];

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_values_round_trip_and_normalise() {
        let h = [
            Pose { pos: [0.1, 0.2, 0.3], rot: [0.5, 0.5, 0.5, 0.5] },
            Pose { pos: [-0.1, 0.4, 0.9], rot: [1.0, 0.0, 0.0, 0.0] },
        ];
        let v = hands_to_values(&h);
        assert_eq!(values_to_hands(&v), h);
        let mut scaled = v;
        for x in &mut scaled[3..7] {
            *x *= 3.0;
        }
        let back = values_to_hands(&scaled);
        assert!((back[0].rot[0] - 0.5).abs() < 1e-6);
    }

    #[test]
    fn stick_tip_follows_the_hand_rotation() {
        // A quarter turn about z takes the stick from +y to -x.
        let s = std::f32::consts::FRAC_1_SQRT_2;
        let h = Pose { pos: [0.0, 0.0, 1.0], rot: [s, 0.0, 0.0, s] };
        let t = h.stick_tip();
        assert!((t[0] + 0.28).abs() < 1e-5 && t[1].abs() < 1e-5 && (t[2] - 1.0).abs() < 1e-5);
    }

    #[test]
    fn fifty_two_distinct_face_names() {
        let mut names = ARKIT_NAMES.to_vec();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), 52);
    }
}
