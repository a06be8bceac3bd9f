//! drumsim's 57-bone rig as a Unity humanoid: the 55 `HumanBodyBones` names, the T-pose the
//! VMC protocol's receivers assume, and each frame's local transforms in Unity's frame.
//!
//! Receivers (EVMC4U, VSeeFace, VRM4U, VMC4B) drive a VRM model normalized so that every
//! bone's rotation is the identity in a T-pose: arms straight out to the sides, palms down,
//! thumbs forward, legs straight down. drumsim's rest pose has the arms hanging, palms facing
//! the body. A bone of an arm chain (upper arm, forearm, hand, fingers) is therefore sent as
//! its drumsim world rotation times the turn `C` that lowers the straight arm from the T-pose
//! to drumsim's rest (90 degrees about the forward axis); every other bone's rest already is
//! its T-pose. A bone's local rotation is its parent's world rotation inverted times its own.
//!
//! Unity is left-handed and Y-up: a kit point (x, y, z) (x the drummer's right, y forward,
//! z up) is Unity's (x, z, y), so the drummer faces Unity's +Z with their right on +X. That
//! swap is a reflection, so a rotation keeps its w and its vector part becomes
//! (-x, -z, -y).
//!
//! | Unity bone | drumsim bone |
//! |---|---|
//! | Hips, Spine, Chest, UpperChest | hips, spine, spine1, spine2 |
//! | Neck, Head, Jaw, LeftEye, RightEye | neck, head (with neck1 folded in), jaw, left_eye, right_eye |
//! | LeftShoulder, LeftUpperArm, LeftLowerArm, LeftHand | left_shoulder, left_arm, left_forearm, left_hand |
//! | LeftThumb/Index/Middle/Ring/Little + Proximal/Intermediate/Distal | left_thumb1..3, index, middle, ring, pinky |
//! | LeftUpperLeg, LeftLowerLeg, LeftFoot, LeftToes | left_upper_leg, left_leg, left_foot, left_toe |
//! | the Right bones | the right_ bones |
//!
//! `neck1` and `head_end` have no Unity bone. Neck turns half way from drumsim's neck to
//! neck1 (so the head joint lands within a few millimetres of drumsim's, where both neck bones
//! bend alike), and Head's rotation, relative to Neck, carries the rest.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

/// Bone groups a sender can leave out (a streamer may keep head and face to their own face
/// tracking).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Group {
    /// Hips, Spine, Chest, UpperChest.
    Torso,
    /// Neck, Head, Jaw, eyes.
    Head,
    /// Shoulders, upper and lower arms, hands.
    Arms,
    /// The 30 finger bones.
    Fingers,
    /// Upper and lower legs, feet, toes.
    Legs,
}

/// One Unity bone.
#[derive(Debug, Clone, PartialEq)]
pub struct UnityBone {
    /// The `HumanBodyBones` name.
    pub name: String,
    /// Index of the drumsim bone it follows.
    pub source: usize,
    /// Index of its Unity parent in [`Humanoid::bones`] (none for Hips).
    pub parent: Option<usize>,
    pub group: Group,
    /// Its joint in the T-pose, relative to its parent's, in Unity's frame (m); for Hips, its
    /// place above the floor.
    pub t_pose_local: [f32; 3],
    /// The same in the kit frame (m).
    pub t_pose_kit: Vector3<f32>,
    /// The turn from the T-pose to drumsim's rest (kit frame): 90 degrees about the forward
    /// axis for the arm chains, the identity elsewhere.
    turn: UnitQuaternion<f32>,
    /// A drumsim child with no Unity bone (neck1 for Neck), half of whose turn this bone takes.
    fold: Option<usize>,
}

/// The mapping from a drumsim rig (its bone names, parents and rest offsets) to the 55 Unity
/// humanoid bones, in an order where every parent comes first.
#[derive(Debug, Clone, PartialEq)]
pub struct Humanoid {
    pub bones: Vec<UnityBone>,
}

/// One frame in Unity's frame: per Unity bone, its local position and rotation (x, y, z, w).
#[derive(Debug, Clone, PartialEq)]
pub struct UnityPose {
    /// World position of the hips joint (Unity frame, m).
    pub hips: [f32; 3],
    /// Local rotation of each bone as (x, y, z, w), in [`Humanoid::bones`] order.
    pub local: Vec<[f32; 4]>,
}

/// The rig is missing a bone the mapping needs, or is not a tree of them.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the rig has no bone {0:?} (a drumsim 57-bone rig is needed for VMC)")]
pub struct MissingBone(pub String);

const FINGERS: [(&str, &str); 5] =
    [("thumb", "Thumb"), ("index", "Index"), ("middle", "Middle"), ("ring", "Ring"), ("pinky", "Little")];
const PHALANGES: [&str; 3] = ["Proximal", "Intermediate", "Distal"];

/// (Unity name, drumsim name, group) of the 55 bones, parents first.
fn table() -> Vec<(String, String, Group)> {
    let mut t: Vec<(String, String, Group)> = Vec::with_capacity(55);
    let mut add = |u: &str, d: &str, g: Group| t.push((u.to_string(), d.to_string(), g));
    for (u, d) in [("Hips", "hips"), ("Spine", "spine"), ("Chest", "spine1"), ("UpperChest", "spine2")] {
        add(u, d, Group::Torso);
    }
    for (u, d) in
        [("Neck", "neck"), ("Head", "head"), ("Jaw", "jaw"), ("LeftEye", "left_eye"), ("RightEye", "right_eye")]
    {
        add(u, d, Group::Head);
    }
    for (side, s) in [("Left", "left"), ("Right", "right")] {
        for (u, d) in [("Shoulder", "shoulder"), ("UpperArm", "arm"), ("LowerArm", "forearm"), ("Hand", "hand")] {
            add(&format!("{side}{u}"), &format!("{s}_{d}"), Group::Arms);
        }
        for (d, u) in FINGERS {
            for (k, p) in PHALANGES.iter().enumerate() {
                add(&format!("{side}{u}{p}"), &format!("{s}_{d}{}", k + 1), Group::Fingers);
            }
        }
    }
    for (side, s) in [("Left", "left"), ("Right", "right")] {
        for (u, d) in [("UpperLeg", "upper_leg"), ("LowerLeg", "leg"), ("Foot", "foot"), ("Toes", "toe")] {
            add(&format!("{side}{u}"), &format!("{s}_{d}"), Group::Legs);
        }
    }
    t
}

/// A kit-frame point in Unity's frame.
pub fn unity_point(v: &Vector3<f32>) -> [f32; 3] {
    [v.x, v.z, v.y]
}

/// A kit-frame rotation in Unity's frame, as (x, y, z, w).
pub fn unity_rotation(q: &UnitQuaternion<f32>) -> [f32; 4] {
    [-q.i, -q.k, -q.j, q.w]
}

impl Humanoid {
    /// The mapping for a rig given as bone names, parent indices and rest offsets (each
    /// joint in its parent's frame; the rest frames are aligned with the kit).
    pub fn new(names: &[String], parents: &[Option<usize>], offsets: &[Vector3<f32>]) -> Result<Humanoid, MissingBone> {
        let find = |n: &str| names.iter().position(|x| x == n).ok_or_else(|| MissingBone(n.to_string()));
        // Rest positions of every drumsim joint (parents come first in a drumsim rig).
        let mut rest: Vec<Vector3<f32>> = Vec::with_capacity(names.len());
        for i in 0..names.len() {
            let p = match parents[i] {
                Some(p) if p < i => rest[p] + offsets[i],
                Some(_) => return Err(MissingBone(format!("{} (it comes before its parent)", names[i]))),
                None => offsets[i],
            };
            rest.push(p);
        }
        let table = table();
        let sources: Vec<usize> = table.iter().map(|(_, d, _)| find(d)).collect::<Result<_, _>>()?;
        let lowered =
            |sign: f32| UnitQuaternion::from_axis_angle(&Vector3::y_axis(), sign * std::f32::consts::FRAC_PI_2);
        // Where each arm chain starts (its upper arm's joint), and its turn.
        let arm = [find("left_arm")?, find("right_arm")?];
        let turns = [lowered(-1.0), lowered(1.0)];
        let chain_of = |mut i: usize| -> Option<usize> {
            loop {
                if let Some(side) = arm.iter().position(|&a| a == i) {
                    return Some(side);
                }
                i = parents[i]?;
            }
        };
        let t_pose: Vec<Vector3<f32>> = sources
            .iter()
            .map(|&d| match chain_of(d) {
                Some(side) => rest[arm[side]] + turns[side].inverse() * (rest[d] - rest[arm[side]]),
                None => rest[d],
            })
            .collect();
        let mut bones: Vec<UnityBone> = Vec::with_capacity(table.len());
        for (k, ((name, _, group), &source)) in table.into_iter().zip(&sources).enumerate() {
            // The Unity parent: the nearest drumsim ancestor that is a Unity bone.
            let mut parent = None;
            let mut a = parents[source];
            while let Some(i) = a {
                if let Some(u) = sources.iter().position(|&s| s == i) {
                    parent = Some(u);
                    break;
                }
                a = parents[i];
            }
            let local = match parent {
                Some(p) => t_pose[k] - t_pose[p],
                None => t_pose[k],
            };
            let turn = chain_of(source).map_or_else(UnitQuaternion::identity, |side| turns[side]);
            let fold = (name == "Neck").then(|| names.iter().position(|n| n == "neck1")).flatten();
            bones.push(UnityBone {
                name,
                source,
                parent,
                group,
                t_pose_local: unity_point(&local),
                t_pose_kit: local,
                turn,
                fold,
            });
        }
        Ok(Humanoid { bones })
    }

    /// The mapping for drumsim's own rig.
    pub fn of_rig(rig: &crate::motion::rig::Rig) -> Humanoid {
        let names: Vec<String> = rig.bones.iter().map(|b| b.name.clone()).collect();
        let parents: Vec<Option<usize>> = rig.bones.iter().map(|b| b.parent).collect();
        let offsets: Vec<Vector3<f32>> = rig.bones.iter().map(|b| b.offset).collect();
        Humanoid::new(&names, &parents, &offsets).expect("drumsim's rig has every humanoid bone")
    }

    /// An empty pose of the right size, to fill with [`Humanoid::pose_into`].
    pub fn empty_pose(&self) -> UnityPose {
        UnityPose { hips: [0.0; 3], local: vec![[0.0, 0.0, 0.0, 1.0]; self.bones.len()] }
    }

    /// One frame: `hips` is the world position of drumsim's hips joint and `world(i)` the world
    /// rotation of drumsim bone `i` (relative to the rest pose, kit frame). No allocation
    /// once `scratch` has grown.
    pub fn pose_into(
        &self,
        hips: &Vector3<f32>,
        world: impl Fn(usize) -> UnitQuaternion<f32>,
        scratch: &mut Vec<UnitQuaternion<f32>>,
        out: &mut UnityPose,
    ) {
        out.hips = unity_point(hips);
        let n = self.bones.len();
        self.local_into(world, scratch);
        for k in 0..n {
            out.local[k] = unity_rotation(&scratch[n + k]);
        }
    }

    /// Each bone's local rotation from its T-pose, in the kit frame: `out[n + k]` for bone
    /// `k` of `n` (the first `n` are their world rotations).
    pub fn local_into(&self, world: impl Fn(usize) -> UnitQuaternion<f32>, out: &mut Vec<UnitQuaternion<f32>>) {
        let n = self.bones.len();
        out.clear();
        for b in &self.bones {
            let own = world(b.source);
            out.push(match b.fold {
                Some(child) => own.slerp(&world(child), 0.5) * b.turn,
                None => own * b.turn,
            });
        }
        for k in 0..n {
            let local = match self.bones[k].parent {
                Some(p) => out[p].inverse() * out[k],
                None => out[k],
            };
            out.push(local);
        }
    }
}

/// A (x, y, z, w) rotation as a unit quaternion (normalized).
pub fn from_xyzw(q: [f32; 4]) -> UnitQuaternion<f32> {
    UnitQuaternion::from_quaternion(Quaternion::new(q[3], q[0], q[1], q[2]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::rig::Rig;

    fn humanoid() -> (Rig, Humanoid) {
        let rig = Rig::default();
        let h = Humanoid::of_rig(&rig);
        (rig, h)
    }

    #[test]
    fn fifty_five_unity_bones_parents_first() {
        let (_, h) = humanoid();
        assert_eq!(h.bones.len(), 55);
        let mut names: Vec<&str> = h.bones.iter().map(|b| b.name.as_str()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), 55);
        for (i, b) in h.bones.iter().enumerate() {
            assert!(b.parent.is_none_or(|p| p < i), "{}", b.name);
        }
        let parent = |n: &str| {
            let b = h.bones.iter().find(|b| b.name == n).unwrap();
            b.parent.map(|p| h.bones[p].name.as_str())
        };
        assert_eq!(parent("Head"), Some("Neck"));
        assert_eq!(parent("LeftShoulder"), Some("UpperChest"));
        assert_eq!(parent("RightLittleProximal"), Some("RightHand"));
        assert_eq!(parent("LeftToes"), Some("LeftFoot"));
        assert_eq!(parent("Hips"), None);
    }

    #[test]
    fn the_t_pose_has_arms_out_and_palms_down() {
        let (_, h) = humanoid();
        let local = |n: &str| Vector3::from(h.bones.iter().find(|b| b.name == n).unwrap().t_pose_local);
        // Unity: +x the avatar's right, +y up, +z forward.
        for (side, sign) in [("Left", -1.0), ("Right", 1.0)] {
            for bone in ["LowerArm", "Hand"] {
                let v = local(&format!("{side}{bone}"));
                assert!(v.x * sign > 0.2 && v.y.abs() < 0.01 && v.z.abs() < 0.01, "{side}{bone} {v}");
            }
            // Fingers continue along the arm; the thumb sits forward of the hand.
            let middle = local(&format!("{side}MiddleProximal"));
            assert!(middle.x * sign > 0.05, "{side} middle finger {middle}");
            assert!(local(&format!("{side}ThumbProximal")).z > 0.0);
            // The legs hang straight down.
            let knee = local(&format!("{side}LowerLeg"));
            assert!(knee.y < -0.35 && knee.x.abs() < 0.01, "{knee}");
        }
        assert!(local("Head").y > 0.05 && local("Spine").y > 0.0);
    }

    #[test]
    fn rest_pose_is_the_t_pose_with_arms_lowered() {
        // In drumsim's rest pose the trunk, head and legs are the identity and each arm's
        // upper arm is turned 90 degrees down; its children are unturned relative to it.
        let (rig, h) = humanoid();
        let mut out = h.empty_pose();
        let mut scratch = Vec::new();
        h.pose_into(&rig.bones[0].offset, |_| UnitQuaternion::identity(), &mut scratch, &mut out);
        for (b, q) in h.bones.iter().zip(&out.local) {
            let angle = from_xyzw(*q).angle().to_degrees();
            let expected = if b.name.ends_with("UpperArm") { 90.0 } else { 0.0 };
            assert!((angle - expected).abs() < 1e-3, "{} turned {angle} degrees", b.name);
        }
        assert!((out.hips[1] - 0.62).abs() < 1e-6, "{:?}", out.hips);
    }

    #[test]
    fn received_pose_puts_every_joint_where_drumsim_has_it() {
        // Forward kinematics of the Unity rig (T-pose offsets, received local rotations) meets
        // drumsim's own joints for an arbitrary pose of every bone.
        let (rig, h) = humanoid();
        let mut pose = rig.rest_pose();
        let mut seed = 3u64;
        for q in pose.local.iter_mut() {
            let mut r = || {
                seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((seed >> 33) as f32 / (1u64 << 31) as f32 - 0.5) * 1.5
            };
            *q = UnitQuaternion::from_euler_angles(r(), r(), r());
        }
        // neck1 straight: its turn is folded into Neck and Head, exactly only then.
        pose.local[rig.index_of("neck1").unwrap()] = UnitQuaternion::identity();
        let world = rig.world(&pose);
        let mut out = h.empty_pose();
        let mut scratch = Vec::new();
        h.pose_into(&world[0].0, |i| world[i].1, &mut scratch, &mut out);
        let mut unity: Vec<(Vector3<f32>, UnitQuaternion<f32>)> = Vec::new();
        for (k, b) in h.bones.iter().enumerate() {
            let q = from_xyzw(out.local[k]);
            let entry = match b.parent {
                None => (Vector3::from(out.hips), q),
                Some(p) => {
                    let (pp, pr) = unity[p];
                    (pp + pr * Vector3::from(b.t_pose_local), pr * q)
                }
            };
            unity.push(entry);
            let expected = Vector3::from(unity_point(&world[b.source].0));
            assert!((entry.0 - expected).norm() < 1e-4, "{}: {} vs {}", b.name, entry.0, expected);
        }
    }

    #[test]
    fn a_bent_neck_puts_the_head_within_millimetres() {
        // Both neck bones bent alike by 20 degrees (the whole-body IK spreads the neck so):
        // the head joint lands within 2 mm of drumsim's and turns exactly as drumsim's.
        let (rig, h) = humanoid();
        let mut pose = rig.rest_pose();
        let bend = UnitQuaternion::from_euler_angles(0.25, 0.1, 0.2);
        for n in ["neck", "neck1"] {
            pose.local[rig.index_of(n).unwrap()] = bend;
        }
        let world = rig.world(&pose);
        let mut out = h.empty_pose();
        h.pose_into(&world[0].0, |i| world[i].1, &mut Vec::new(), &mut out);
        let k = |n: &str| h.bones.iter().position(|b| b.name == n).unwrap();
        let (neck, head) = (k("Neck"), k("Head"));
        let mut rot = UnitQuaternion::identity();
        let mut pos = Vector3::from(out.hips);
        for i in [k("Hips"), k("Spine"), k("Chest"), k("UpperChest"), neck, head] {
            if i != k("Hips") {
                pos += rot * Vector3::from(h.bones[i].t_pose_local);
            }
            rot *= from_xyzw(out.local[i]);
        }
        let head_d = rig.index_of("head").unwrap();
        let expected = Vector3::from(unity_point(&world[head_d].0));
        assert!((pos - expected).norm() < 0.002, "head joint {} mm off", (pos - expected).norm() * 1e3);
        let expected_rot = from_xyzw(unity_rotation(&world[head_d].1));
        assert!(rot.angle_to(&expected_rot) < 1e-4);
    }
}
