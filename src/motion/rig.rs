//! The 57-bone humanoid rig that motion is exported through: names, parents, rest offsets
//! scaled from body height, the closed fist around the stick, and forward kinematics.
//!
//! Frame: the kit's (metres, +x the drummer's right, +y forward, +z up, origin on the floor
//! under the stool). In the rest (bind) pose every bone's frame is aligned with the world:
//! the drummer sits facing +y with the spine, neck and head straight up, the arms hanging
//! down, the legs straight down from the hips, the fingers straight, the feet flat pointing
//! +y. A bone's local rotation `q` is its frame relative to its parent's,
//! `R_world = R_parent_world * q`, and its joint sits at `offset` in the parent's frame.
//!
//! The hand bone follows the physical body (`body::skeleton`) and `track.rs`: its frame sits at
//! the wrist; the fingers extend along local -z; the stick lies along local +y through the
//! fist; the grip point (a hand target's position) is [`Rig::grip_local`], 0.35 hand lengths
//! down local -z. With the arm hanging, the palm faces the body's midline (-x for the right
//! hand), the knuckles face out and the thumb is in front. Fingers curl towards the palm
//! (about +y for the right hand, -y for the left), the thumb about +x along the stick.
//!
//! | index | bone | parent |
//! |---|---|---|
//! | 0 | hips (root, the pelvis on the seat) | - |
//! | 1, 2, 3 | spine, spine1, spine2 (upper chest) | hips, spine, spine1 |
//! | 4, 5, 6 | neck, neck1, head | spine2, neck, neck1 |
//! | 7, 8 | head_end (crown), jaw | head |
//! | 9, 10 | left_eye, right_eye | head |
//! | 11..=29 | left arm: shoulder (clavicle), arm, forearm, hand, then thumb1..3, index1..3, middle1..3, ring1..3, pinky1..3 | spine2, chain, hand, each finger a chain |
//! | 30..=48 | right arm, the same 19 bones | |
//! | 49..=52 | left leg: upper_leg, leg, foot (ankle), toe | hips, chain |
//! | 53..=56 | right leg, the same 4 bones | |
//!
//! Names are `left_`/`right_` plus the bone (`left_forearm`, `right_index2`, `left_toe`).
//! Lengths are Winter's fractions of standing height (as `body::anthropometry`): trunk
//! 0.188 H split into three spine bones above a 0.10 H pelvis, neck 0.052 H, head 0.13 H,
//! upper arm 0.186 H, forearm 0.146 H, hand 0.108 H, thigh 0.245 H, shank 0.246 H; the hips
//! sit at a fixed seated height (0.62 m default) whatever the body height.

use nalgebra::{UnitQuaternion, Vector3};

/// Number of bones.
pub const BONES: usize = 57;
pub const HIPS: usize = 0;
pub const SPINE: [usize; 3] = [1, 2, 3];
pub const NECK: [usize; 2] = [4, 5];
pub const HEAD: usize = 6;
/// Shoulder (clavicle) of each side (0 left, 1 right); arm, forearm, hand follow at +1..+3,
/// then the 15 finger bones.
pub const SHOULDER: [usize; 2] = [11, 30];
pub const HAND: [usize; 2] = [14, 33];
/// Upper leg of each side; leg, foot, toe follow at +1..+3.
pub const UPPER_LEG: [usize; 2] = [49, 53];
pub const FOOT: [usize; 2] = [51, 55];

const FINGERS: [&str; 5] = ["thumb", "index", "middle", "ring", "pinky"];

/// Body proportions of the rig, validated by [`Rig::new`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RigSettings {
    /// Standing height, m (1.2..=2.2); every length scales with it.
    pub height_m: f32,
    /// Height of the hips (root) above the floor when seated, m (0.3..=1.0).
    pub hip_height_m: f32,
}

impl Default for RigSettings {
    fn default() -> Self {
        RigSettings { height_m: 1.75, hip_height_m: 0.62 }
    }
}

/// The names the bones go by in the BVH and glTF exports.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RigNames {
    /// drumsim's own (`left_forearm`).
    #[default]
    Drumsim,
    /// Mixamo's (`mixamorig:LeftForeArm`), which retargeting tools recognise.
    Mixamo,
}

/// The Mixamo name of a drumsim bone (`mixamorig:` + Mixamo's bone name; drumsim's bones
/// without a Mixamo counterpart, `neck1` and `jaw`, keep a name in Mixamo's style).
pub fn mixamo_name(drumsim: &str) -> String {
    let (side, rest) = match drumsim.split_once('_') {
        Some(("left", r)) => ("Left", r),
        Some(("right", r)) => ("Right", r),
        _ => ("", drumsim),
    };
    let finger = |f: &str| rest.strip_prefix(f).filter(|n| n.len() == 1).map(|n| n.to_string());
    let name = match rest {
        "hips" => "Hips".to_string(),
        "spine" => "Spine".to_string(),
        "spine1" => "Spine1".to_string(),
        "spine2" => "Spine2".to_string(),
        "neck" => "Neck".to_string(),
        "neck1" => "Neck1".to_string(),
        "head" => "Head".to_string(),
        "head_end" => "HeadTop_End".to_string(),
        "jaw" => "Jaw".to_string(),
        "eye" => "Eye".to_string(),
        "shoulder" => "Shoulder".to_string(),
        "arm" => "Arm".to_string(),
        "forearm" => "ForeArm".to_string(),
        "hand" => "Hand".to_string(),
        "upper_leg" => "UpLeg".to_string(),
        "leg" => "Leg".to_string(),
        "foot" => "Foot".to_string(),
        "toe" => "ToeBase".to_string(),
        _ => {
            let fingers =
                [("thumb", "Thumb"), ("index", "Index"), ("middle", "Middle"), ("ring", "Ring"), ("pinky", "Pinky")];
            match fingers.iter().find_map(|(d, m)| finger(d).map(|n| format!("Hand{m}{n}"))) {
                Some(n) => n,
                None => rest.to_string(),
            }
        }
    };
    format!("mixamorig:{side}{name}")
}

/// Bad rig settings; the message names the key and the allowed range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum RigError {
    #[error("rig settings: {key} = {value} is outside {min}..={max} m")]
    OutOfRange { key: &'static str, value: f32, min: f32, max: f32 },
}

/// One bone: its joint's place in its parent's frame, and where its own end lies.
#[derive(Debug, Clone, PartialEq)]
pub struct Bone {
    pub name: String,
    pub parent: Option<usize>,
    /// The joint in the parent's frame (the rest pose's world offset from the parent).
    pub offset: Vector3<f32>,
    /// The bone's far end in its own frame (its first child's offset, or the tip of a leaf:
    /// BVH's End Site, the glTF bone shape).
    pub tail: Vector3<f32>,
}

/// The skeleton: bones in an order where every parent comes before its children (and which
/// is also the depth-first order of the hierarchy).
#[derive(Debug, Clone, PartialEq)]
pub struct Rig {
    pub settings: RigSettings,
    pub bones: Vec<Bone>,
    /// Wrist to grip point in the hand's frame.
    pub grip_local: Vector3<f32>,
    /// Local rotations of the 15 finger bones of each hand closed around the stick, in the
    /// order of the bones (thumb1..3, index1..3, ..., pinky1..3).
    pub fist: [[UnitQuaternion<f32>; 15]; 2],
}

/// A whole-body pose: local rotations of every bone and the root's position.
#[derive(Debug, Clone, PartialEq)]
pub struct BodyPose {
    /// World position of the hips joint.
    pub root: Vector3<f32>,
    /// Local rotation of every bone (the hips' is its world rotation).
    pub local: Vec<UnitQuaternion<f32>>,
}

impl Default for Rig {
    fn default() -> Self {
        Rig::build(RigSettings::default())
    }
}

impl Rig {
    /// The rig of a body with these proportions.
    pub fn new(settings: RigSettings) -> Result<Rig, RigError> {
        check("height_m", settings.height_m, 1.2, 2.2)?;
        check("hip_height_m", settings.hip_height_m, 0.3, 1.0)?;
        Ok(Rig::build(settings))
    }

    fn build(settings: RigSettings) -> Rig {
        let h = settings.height_m;
        let s = h / 1.75; // hand and face details are given for a 1.75 m body
        let v = Vector3::new;
        let z = Vector3::z();
        let mut b = Builder::default();
        // Trunk: world rest positions of the joints.
        let hips = v(0.0, 0.0, settings.hip_height_m);
        let trunk = (0.818 - 0.630) * h;
        let spine = hips + z * 0.10 * h;
        let neck = spine + z * trunk;
        let head = neck + z * (0.870 - 0.818) * h;
        b.add("hips", None, hips);
        b.add("spine", Some(0), spine);
        b.add("spine1", Some(1), spine + z * trunk / 3.0);
        b.add("spine2", Some(2), spine + z * trunk * 2.0 / 3.0);
        b.add("neck", Some(3), neck);
        b.add("neck1", Some(4), (neck + head) / 2.0);
        b.add("head", Some(5), head);
        b.add("head_end", Some(HEAD), head + z * (1.0 - 0.870) * h);
        b.add("jaw", Some(HEAD), head + v(0.0, 0.015, 0.005) * s);
        b.add("left_eye", Some(HEAD), head + v(-0.032, 0.085, 0.085) * s);
        b.add("right_eye", Some(HEAD), head + v(0.032, 0.085, 0.085) * s);
        b.tail_of_leaf(7, z * 0.03 * s);
        b.tail_of_leaf(8, v(0.0, 0.085, -0.045) * s);
        b.tail_of_leaf(9, v(0.0, 0.02, 0.0) * s);
        b.tail_of_leaf(10, v(0.0, 0.02, 0.0) * s);
        for (side, name) in ["left", "right"].into_iter().enumerate() {
            // x of the right side; the left is its mirror.
            let out = if side == 0 { -1.0 } else { 1.0 };
            let m = |p: Vector3<f32>| v(p.x * out, p.y, p.z);
            let shoulder = neck - z * 0.03 + m(v(0.02, 0.0, 0.0));
            let arm = shoulder + m(v((0.259 / 2.0 - 0.02) * h, 0.0, 0.0));
            let forearm = arm - z * 0.186 * h;
            let wrist = forearm - z * 0.146 * h;
            b.add(&format!("{name}_shoulder"), Some(3), shoulder);
            b.add(&format!("{name}_arm"), Some(b.len() - 1), arm);
            b.add(&format!("{name}_forearm"), Some(b.len() - 1), forearm);
            b.add(&format!("{name}_hand"), Some(b.len() - 1), wrist);
            let hand = b.len() - 1;
            // Finger joints relative to the wrist, right hand: base, then the three segment
            // lengths (the last is the leaf's tail), all down local -z.
            let fingers: [([f32; 3], [f32; 3]); 5] = [
                ([-0.018, 0.012, -0.045], [0.045, 0.032, 0.027]),
                ([0.024, 0.030, -0.068], [0.045, 0.025, 0.022]),
                ([0.026, 0.010, -0.070], [0.050, 0.030, 0.024]),
                ([0.025, -0.010, -0.069], [0.046, 0.028, 0.022]),
                ([0.020, -0.030, -0.066], [0.036, 0.020, 0.018]),
            ];
            for (finger, (base, len)) in FINGERS.iter().zip(fingers) {
                let mut p = wrist + m(Vector3::from(base) * s);
                let mut parent = hand;
                for (k, &l) in len.iter().enumerate() {
                    b.add(&format!("{name}_{finger}{}", k + 1), Some(parent), p);
                    parent = b.len() - 1;
                    p -= z * l * s;
                }
                b.tail_of_leaf(parent, -z * len[2] * s);
            }
        }
        // Legs (after both arms, so that the order stays depth-first): hip joint below and
        // beside the root, straight down, foot flat pointing forward.
        for (side, name) in ["left", "right"].into_iter().enumerate() {
            let out = if side == 0 { -1.0 } else { 1.0 };
            let hip = hips + v(0.09 * out, 0.0, -0.05) * s;
            let knee = hip - z * 0.245 * h;
            let ankle = knee - z * 0.246 * h;
            b.add(&format!("{name}_upper_leg"), Some(HIPS), hip);
            b.add(&format!("{name}_leg"), Some(b.len() - 1), knee);
            b.add(&format!("{name}_foot"), Some(b.len() - 1), ankle);
            b.add(&format!("{name}_toe"), Some(b.len() - 1), ankle + v(0.0, 0.13, -0.06) * s);
            b.tail_of_leaf(b.len() - 1, Vector3::y() * 0.05 * s);
        }
        let bones = b.finish();
        let grip_local = -z * 0.35 * 0.108 * h;
        Rig { settings, bones, grip_local, fist: [fist(-1.0), fist(1.0)] }
    }

    /// The same rig with its bones named the `names` way.
    pub fn named(&self, names: RigNames) -> Rig {
        let mut rig = self.clone();
        if names == RigNames::Mixamo {
            for b in &mut rig.bones {
                b.name = mixamo_name(&b.name);
            }
        }
        rig
    }

    /// Index of the bone with this name.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.bones.iter().position(|b| b.name == name)
    }

    /// The rest pose: hips at their rest position, every rotation identity.
    pub fn rest_pose(&self) -> BodyPose {
        BodyPose { root: self.bones[HIPS].offset, local: vec![UnitQuaternion::identity(); self.bones.len()] }
    }

    /// World position of every joint in the rest pose.
    pub fn rest_positions(&self) -> Vec<Vector3<f32>> {
        self.world(&self.rest_pose()).into_iter().map(|(p, _)| p).collect()
    }

    /// Forward kinematics: world position and rotation of every bone's joint.
    pub fn world(&self, pose: &BodyPose) -> Vec<(Vector3<f32>, UnitQuaternion<f32>)> {
        let mut out: Vec<(Vector3<f32>, UnitQuaternion<f32>)> = Vec::with_capacity(self.bones.len());
        for (i, bone) in self.bones.iter().enumerate() {
            let q = pose.local.get(i).copied().unwrap_or_else(UnitQuaternion::identity);
            out.push(match bone.parent {
                None => (pose.root, q),
                Some(p) => {
                    let (pp, pr) = out[p];
                    (pp + pr * bone.offset, pr * q)
                }
            });
        }
        out
    }

    /// Length of a bone's parent link: the distance from the parent's joint to this one's.
    pub fn link_length(&self, bone: usize) -> f32 {
        self.bones[bone].offset.norm()
    }
}

fn check(key: &'static str, value: f32, min: f32, max: f32) -> Result<(), RigError> {
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(RigError::OutOfRange { key, value, min, max })
    }
}

/// The closed fist of one hand (`curl` +1 right, -1 left): finger joints flexed towards the
/// palm about the hand's y axis (metacarpophalangeal 70, proximal 100, distal 55 degrees), the
/// thumb swung forward about x to lie along the stick (45, 40, 10 degrees).
fn fist(curl: f32) -> [UnitQuaternion<f32>; 15] {
    let deg = |d: f32| d.to_radians();
    std::array::from_fn(|i| {
        let (finger, joint) = (i / 3, i % 3);
        if finger == 0 {
            UnitQuaternion::from_axis_angle(&Vector3::x_axis(), deg([45.0, 40.0, 10.0][joint]))
        } else {
            UnitQuaternion::from_axis_angle(&Vector3::y_axis(), curl * deg([70.0, 100.0, 55.0][joint]))
        }
    })
}

/// Collects bones from world rest positions and turns them into parent offsets.
#[derive(Default)]
struct Builder {
    names: Vec<String>,
    parents: Vec<Option<usize>>,
    world: Vec<Vector3<f32>>,
    leaf_tails: Vec<(usize, Vector3<f32>)>,
}

impl Builder {
    fn len(&self) -> usize {
        self.names.len()
    }

    fn add(&mut self, name: &str, parent: Option<usize>, world: Vector3<f32>) {
        self.names.push(name.to_string());
        self.parents.push(parent);
        self.world.push(world);
    }

    fn tail_of_leaf(&mut self, bone: usize, tail: Vector3<f32>) {
        self.leaf_tails.push((bone, tail));
    }

    fn finish(self) -> Vec<Bone> {
        let n = self.names.len();
        (0..n)
            .map(|i| {
                let offset = match self.parents[i] {
                    Some(p) => self.world[i] - self.world[p],
                    None => self.world[i],
                };
                let first_child = (0..n).find(|&c| self.parents[c] == Some(i));
                let tail = match first_child {
                    Some(c) => self.world[c] - self.world[i],
                    None => self.leaf_tails.iter().find(|(b, _)| *b == i).map(|t| t.1).unwrap_or_default(),
                };
                Bone { name: self.names[i].clone(), parent: self.parents[i], offset, tail }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fifty_seven_uniquely_named_bones_with_parents_first() {
        let rig = Rig::default();
        assert_eq!(rig.bones.len(), BONES);
        let mut names: Vec<&str> = rig.bones.iter().map(|b| b.name.as_str()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), BONES);
        assert_eq!(rig.bones.iter().filter(|b| b.parent.is_none()).count(), 1);
        for (i, b) in rig.bones.iter().enumerate() {
            assert!(b.parent.is_none_or(|p| p < i), "{} comes before its parent", b.name);
        }
        // The named indices point at the bones they claim.
        assert_eq!(rig.index_of("right_hand"), Some(HAND[1]));
        assert_eq!(rig.index_of("left_shoulder"), Some(SHOULDER[0]));
        assert_eq!(rig.index_of("right_foot"), Some(FOOT[1]));
        assert_eq!(rig.index_of("left_upper_leg"), Some(UPPER_LEG[0]));
        assert_eq!(rig.index_of("head"), Some(HEAD));
        assert_eq!(rig.index_of("right_pinky3"), Some(HAND[1] + 15));
    }

    #[test]
    fn mixamo_names() {
        let rig = Rig::default().named(RigNames::Mixamo);
        let name = |i: usize| rig.bones[i].name.as_str();
        assert_eq!(name(HIPS), "mixamorig:Hips");
        assert_eq!(name(HAND[0] - 1), "mixamorig:LeftForeArm");
        assert_eq!(name(HAND[1] + 15), "mixamorig:RightHandPinky3");
        assert_eq!(name(HAND[0] + 1), "mixamorig:LeftHandThumb1");
        assert_eq!(name(UPPER_LEG[1]), "mixamorig:RightUpLeg");
        assert_eq!(name(FOOT[0] + 1), "mixamorig:LeftToeBase");
        assert_eq!(name(9), "mixamorig:LeftEye");
        assert_eq!(name(7), "mixamorig:HeadTop_End");
        let mut names: Vec<&str> = rig.bones.iter().map(|b| b.name.as_str()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), BONES, "names are unique");
    }

    #[test]
    fn rest_pose_is_a_seated_figure_of_the_given_height() {
        let rig = Rig::default();
        let p = rig.rest_positions();
        let top = p[rig.index_of("head_end").unwrap()].z;
        // Seated: hips at 0.62, so the crown is 0.62 + (1 - 0.53) H minus the hip drop.
        assert!((top - (0.62 + 0.47 * 1.75)).abs() < 0.01, "crown at {top}");
        assert!(p[SHOULDER[0] + 1].x < -0.15 && p[SHOULDER[1] + 1].x > 0.15);
        let tall = Rig::new(RigSettings { height_m: 2.0, ..Default::default() }).unwrap();
        let ratio = tall.link_length(HAND[1]) / rig.link_length(HAND[1]);
        assert!((ratio - 2.0 / 1.75).abs() < 1e-5, "forearm scales with height: {ratio}");
        assert!(Rig::new(RigSettings { height_m: f32::NAN, ..Default::default() }).is_err());
    }

    #[test]
    fn closed_fingers_wrap_the_stick() {
        // Every finger joint and tip of the closed hand lies within 3.5 cm of the stick's axis
        // (through the grip along the hand's +y), on both hands.
        let rig = Rig::default();
        let mut pose = rig.rest_pose();
        for (hand, fist) in HAND.iter().zip(&rig.fist) {
            pose.local[hand + 1..hand + 16].copy_from_slice(fist);
        }
        let world = rig.world(&pose);
        for side in 0..2 {
            let (wrist, hr) = world[HAND[side]];
            let grip = wrist + hr * rig.grip_local;
            for k in 0..15 {
                let i = HAND[side] + 1 + k;
                let (p, r) = world[i];
                for q in [p, p + r * rig.bones[i].tail] {
                    let d = q - grip;
                    let off_axis = (d - Vector3::y() * d.y).norm();
                    assert!(off_axis < 0.035, "{} is {off_axis} m off the stick", rig.bones[i].name);
                }
            }
        }
    }
}
