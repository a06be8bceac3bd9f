//! Whole-body IK: the six targets of a [`MotionFrame`] -> local rotations of all 57 bones of
//! the [`Rig`] and the root position. Analytic and per frame, so deterministic and cheap.
//!
//! Target conventions (kit frame):
//! - chest: `pos` is the top of the spine (the `neck` joint), `rot` the upper chest's
//!   (`spine2`) world rotation. The rotation is shared equally by spine, spine1, spine2; the
//!   hips (which sit on the stool, world rotation identity) slide by the residual between the
//!   target and the reached neck joint, at most [`MAX_HIP_SHIFT_M`].
//! - head: `rot` is the head's world rotation, shared equally by neck and neck1; `pos` (the
//!   head joint) follows from the chest and is not enforced.
//! - hands: grip point and rotation; the hand bone's world rotation is the target's, the
//!   wrist is the grip minus the rotated [`Rig::grip_local`]. Shoulder-elbow-wrist is a
//!   two-bone solve with the elbow towards a pole out, down and a little back; half of the
//!   hand's twist about the forearm goes to the forearm (pronation). Fingers stay closed.
//! - feet: ankle position and the foot's world rotation; hip-knee-ankle two-bone with the
//!   knee forward and a little out.
//!
//! A target out of reach is met as closely as the straightened limb allows (the reach is
//! clamped just short of full extension, so the elbow and knee stay defined); non-finite
//! targets fall back to the rest pose's. No output is ever NaN.

use super::proxies::{segment_distance, Capsule, FOREARM_R, THIGH_R, TORSO_R};
use super::rig::{BodyPose, Rig, FOOT, HAND, HEAD, HIPS, NECK, SHOULDER, SPINE, UPPER_LEG};
use super::shells::{Shell, KNEE_R, SHIN_R};
use super::stick_clear;
use super::track::{Motion, MotionFrame, Pose};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

/// How far the hips may slide on the seat to bring the chest to its target, m.
pub const MAX_HIP_SHIFT_M: f32 = 0.08;

/// The most a forearm's twist (half the hand's twist about it) turns between two frames
/// of a motion, radians: 15 degrees, 900 degrees a second at 60 fps.
pub const MAX_TWIST_STEP_RAD: f32 = 15.0 * std::f32::consts::PI / 180.0;

/// Poses of every frame of a motion. Each forearm's twist continues from the frame before:
/// a hand turning on past half a turn about the forearm keeps turning the same way instead
/// of flipping the forearm by 180 degrees.
pub fn solve_motion(rig: &Rig, motion: &Motion) -> Vec<BodyPose> {
    solve_motion_in(rig, motion, &[])
}

/// [`solve_motion`] with the knees kept out of `shells` (see [`knee_pole`]).
pub fn solve_motion_in(rig: &Rig, motion: &Motion, shells: &[Shell]) -> Vec<BodyPose> {
    let mut carry = Carry { knee: knee_angles(rig, motion, shells), ..Carry::default() };
    let mut poses: Vec<BodyPose> = Vec::with_capacity(motion.frames.len());
    for f in &motion.frames {
        let mut pose = solve_after(rig, f, &mut carry);
        if let Some(before) = poses.last() {
            limit_turns(rig, &mut pose, before);
        }
        poses.push(pose);
    }
    poses
}

/// The most a bone's rotation (in its parent's frame) turns between two frames of a motion,
/// radians: 44 degrees, 2,640 a second at 60 fps, under the 45 an animator's curves allow.
/// A wrist sent 10-17 cm in one frame (a fill's soft hi-hat note 100 ms before the floor
/// tom) bent the elbow by up to 49 degrees in that frame.
pub const MAX_BONE_TURN_RAD: f32 = 44.0 * std::f32::consts::PI / 180.0;

/// Hold each bone of `pose` within [`MAX_BONE_TURN_RAD`] of `before`, parents first; a hand
/// whose forearm was held back keeps its world rotation (its stick's direction) as far as
/// its own limit allows. The wrist, and so the stick, then lags its target for that frame.
pub fn limit_turns(rig: &Rig, pose: &mut BodyPose, before: &BodyPose) {
    if pose.local.iter().zip(&before.local).all(|(q, b)| q.angle_to(b) <= MAX_BONE_TURN_RAD) {
        return;
    }
    let want = rig.world(pose);
    let mut world: Vec<UnitQuaternion<f32>> = Vec::with_capacity(rig.bones.len());
    let mut moved = vec![false; rig.bones.len()];
    for (b, bone) in rig.bones.iter().enumerate() {
        let parent = bone.parent.map_or_else(UnitQuaternion::identity, |p| world[p]);
        let parent_moved = bone.parent.is_some_and(|p| moved[p]);
        let mut local = if parent_moved && HAND.contains(&b) { parent.inverse() * want[b].1 } else { pose.local[b] };
        let angle = local.angle_to(&before.local[b]);
        if angle > MAX_BONE_TURN_RAD {
            local = before.local[b].slerp(&local, MAX_BONE_TURN_RAD / angle);
        }
        moved[b] = parent_moved || local != pose.local[b];
        pose.local[b] = local;
        world.push(parent * local);
    }
}

/// The body pose that meets one frame's targets.
pub fn solve(rig: &Rig, frame: &MotionFrame) -> BodyPose {
    solve_after(rig, frame, &mut Carry::default())
}

/// What one frame's solve hands the next, so that the motion stays continuous: each hand's
/// twist about its forearm, each elbow's direction, and each knee's turn from forward
/// (radians; `None`: forward).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Carry {
    pub twist: [Option<f32>; 2],
    pub knee: [Option<f32>; 2],
    /// Each elbow's direction across its arm (unit), before [`elbow_clear_of`]'s swing.
    pub elbow: [Option<Vector3<f32>>; 2],
    /// Each elbow's swing out of the torso, radians (see [`elbow_clear_of`]).
    pub swing: [f32; 2],
    /// How far each grip was moved out of the body, m (see [`stick_clear`]).
    pub grip_shift: [Vector3<f32>; 2],
}

/// [`solve`], continuing from `carry` (the frame before's twists, and the knees' turns of
/// [`knee_angles`]) and leaving this frame's twists there.
pub fn solve_after(rig: &Rig, frame: &MotionFrame, carry: &mut Carry) -> BodyPose {
    let rest = rig.rest_positions();
    let mut pose = rig.rest_pose();
    let id = UnitQuaternion::identity();

    // Spine: the chest rotation split equally over three bones, then the hips slide.
    let chest_rot = rotation(&frame.chest);
    let step = chest_rot.powf(1.0 / SPINE.len() as f32);
    for &b in &SPINE {
        pose.local[b] = step;
    }
    let neck_reached = rig.world(&pose)[NECK[0]].0;
    let chest_pos = position(&frame.chest, rest[NECK[0]]);
    let shift = chest_pos - neck_reached;
    pose.root += shift * (MAX_HIP_SHIFT_M / shift.norm().max(MAX_HIP_SHIFT_M));

    // Neck and head: the head's rotation relative to the upper chest, split over two bones.
    let head_rel = chest_rot.inverse() * rotation(&frame.head);
    let step = head_rel.powf(1.0 / NECK.len() as f32);
    for &b in &NECK {
        pose.local[b] = step;
    }
    pose.local[HEAD] = id;

    // Legs.
    for side in 0..2 {
        let (hip, foot) = (UPPER_LEG[side], FOOT[side]);
        let world = rig.world(&pose);
        let out = if side == 0 { -1.0 } else { 1.0 };
        let foot_rot = rotation(&frame.feet[side]);
        let mut limb = TwoBone {
            root: world[hip].0,
            lengths: [rig.link_length(hip + 1), rig.link_length(foot)],
            pole: knee_forward(out),
            hinge_rest: -Vector3::x(),
        };
        let ankle = position(&frame.feet[side], rest[foot]);
        if let Some(angle) = carry.knee[side].filter(|a| a.is_finite()) {
            limb.pole = knee_pole_at(&limb, angle, out);
        }
        let (upper_w, lower_w, bend) = limb.solve(ankle);
        pose.local[hip] = world[HIPS].1.inverse() * upper_w;
        pose.local[hip + 1] = bend;
        pose.local[foot] = lower_w.inverse() * foot_rot;
    }
    // Arms.
    for side in 0..2 {
        let sh = SHOULDER[side];
        let (arm, forearm, hand) = (sh + 1, sh + 2, HAND[side]);
        let world = rig.world(&pose);
        // The hand and its stick out of the torso and thighs, turned about the stick's tip.
        let body = [
            Capsule { a: world[HIPS].0, b: world[NECK[0]].0, r: TORSO_R, name: "torso" },
            Capsule { a: world[UPPER_LEG[0]].0, b: world[UPPER_LEG[0] + 1].0, r: THIGH_R, name: "left thigh" },
            Capsule { a: world[UPPER_LEG[1]].0, b: world[UPPER_LEG[1] + 1].0, r: THIGH_R, name: "right thigh" },
        ];
        let grip_rest = rest[hand] + rig.grip_local;
        let r = rotation(&frame.hands[side]);
        let target = Pose { pos: position(&frame.hands[side], grip_rest).into(), rot: [r.w, r.i, r.j, r.k] };
        let out = if side == 0 { -1.0 } else { 1.0 };
        // Out, down and a little back; and toward where the elbow was the frame before,
        // so that a wrist passing near the pole's line does not swing the elbow over.
        let pole = Vector3::new(0.8 * out, -0.3, -1.0).normalize() + carry.elbow[side].unwrap_or_else(Vector3::zeros);
        let mut limb = TwoBone {
            root: world[arm].0,
            lengths: [rig.link_length(forearm), rig.link_length(hand)],
            pole,
            hinge_rest: Vector3::x(),
        };
        let elbow = |wrist: Vector3<f32>| limb.middle(wrist);
        let cleared = stick_clear::clear_of_with(&target, rig.grip_local, &body, ARM_CLEARANCE_M, Some(&elbow));
        // The shift follows at most MAX_GRIP_SHIFT_STEP_M a frame, so a grip meeting the
        // body mid-stroke eases out instead of jumping.
        let want = Vector3::from(cleared.pos) - Vector3::from(target.pos);
        let before = carry.grip_shift[side];
        let step = want - before;
        let shift = before + step * (MAX_GRIP_SHIFT_STEP_M / step.norm().max(MAX_GRIP_SHIFT_STEP_M));
        carry.grip_shift[side] = if shift.iter().all(|v| v.is_finite()) { shift } else { Vector3::zeros() };
        let target = if carry.grip_shift[side].norm() > 0.0 {
            stick_clear::turned_to(&target, Vector3::from(target.pos) + carry.grip_shift[side])
        } else {
            target
        };
        let hand_rot = rotation(&target);
        let wrist = Vector3::from(target.pos) - hand_rot * rig.grip_local;
        carry.elbow[side] = Some(limb.geometry(wrist).1).filter(|p| p.iter().all(|v| v.is_finite()));
        let torso = Capsule { a: world[HIPS].0, b: world[NECK[0]].0, r: TORSO_R, name: "torso" };
        let swing = elbow_clear_of(&limb, wrist, &torso);
        let swing = carry.swing[side] + (swing - carry.swing[side]).clamp(-MAX_SWING_STEP_RAD, MAX_SWING_STEP_RAD);
        carry.swing[side] = if swing.is_finite() { swing } else { 0.0 };
        limb.pole = limb.swung(wrist, carry.swing[side]);
        let (upper_w, lower_w, bend) = limb.solve(wrist);
        let parent_rot = world[sh].1;
        pose.local[arm] = parent_rot.inverse() * upper_w;
        // Split the hand's twist about the forearm axis (local -z) between forearm and hand.
        let hand_local = lower_w.inverse() * hand_rot;
        let t = twist_about_z(&hand_local);
        let mut angle = 2.0 * t.k.atan2(t.w);
        let turn = std::f32::consts::TAU;
        angle = match carry.twist[side] {
            Some(before) if before.is_finite() => {
                // Continuous, and at most MAX_TWIST_STEP_RAD from the frame before: near a
                // wrist bent square to the forearm the twist is ill-defined and swings fast
                // while the hand hardly turns; the hand's own rotation takes up the rest.
                let near = angle + turn * ((before - angle) / turn).round();
                before + (near - before).clamp(-MAX_TWIST_STEP_RAD, MAX_TWIST_STEP_RAD)
            }
            _ => angle - turn * (angle / turn).round(),
        };
        carry.twist[side] = Some(angle);
        let half_twist = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), 0.5 * angle);
        pose.local[forearm] = bend * half_twist;
        pose.local[hand] = (upper_w * pose.local[forearm]).inverse() * hand_rot;
        for k in 0..15 {
            pose.local[hand + 1 + k] = rig.fist[side][k];
        }
    }

    pose
}

/// The most a grip's shift out of the body changes between two frames, m (2 cm, 1.2 m/s at
/// 60 fps).
pub const MAX_GRIP_SHIFT_STEP_M: f32 = 0.02;
/// How far the forearm stays off the torso, and hand and stick off the torso and thighs, m
/// (see [`elbow_clear_of`], [`stick_clear`]).
pub const ARM_CLEARANCE_M: f32 = 0.01;
/// The most an elbow swings out about its shoulder-wrist line, radians: 70 degrees.
pub const MAX_SWING_RAD: f32 = 70.0 * std::f32::consts::PI / 180.0;
/// The most that swing changes between two frames, radians: 8 degrees, 480 a second at 60
/// fps.
pub const MAX_SWING_STEP_RAD: f32 = 8.0 * std::f32::consts::PI / 180.0;

/// How far `limb` (an arm) reaching `wrist` swings its elbow about the shoulder-wrist line,
/// radians, to keep its forearm [`ARM_CLEARANCE_M`] off `torso`: 0 when its own pole
/// does, else the least swing outward (the way that takes the elbow away from the torso's
/// axis) that clears it, at most [`MAX_SWING_RAD`]. A hand crossing in front of the body
/// (the right hand on the hi-hat) lifts its elbow out instead of folding it into the belly.
fn elbow_clear_of(limb: &TwoBone, wrist: Vector3<f32>, torso: &Capsule) -> f32 {
    let depth = |angle: f32| {
        let elbow = TwoBone { pole: limb.swung(wrist, angle), ..*limb }.middle(wrist);
        Capsule { a: elbow, b: wrist, r: FOREARM_R, name: "forearm" }.overlap(torso)
    };
    if depth(0.0) <= -ARM_CLEARANCE_M {
        return 0.0;
    }
    // Outward: the way the elbow leaves the torso's axis.
    let off_axis = |angle: f32| {
        let elbow = TwoBone { pole: limb.swung(wrist, angle), ..*limb }.middle(wrist);
        segment_distance(elbow, elbow, torso.a, torso.b)
    };
    let turn = if off_axis(0.1) >= off_axis(-0.1) { 1.0 } else { -1.0 };
    let steps = 14;
    let step = MAX_SWING_RAD / steps as f32;
    for k in 1..=steps {
        if depth(turn * k as f32 * step) <= -ARM_CLEARANCE_M {
            // The least swing that clears, to a twentieth of a step.
            let (mut lo, mut hi) = ((k - 1) as f32 * step, k as f32 * step);
            for _ in 0..4 {
                let mid = 0.5 * (lo + hi);
                if depth(turn * mid) <= -ARM_CLEARANCE_M {
                    hi = mid;
                } else {
                    lo = mid;
                }
            }
            return turn * hi;
        }
    }
    turn * MAX_SWING_RAD
}

/// How far the knee and shin stay from a drum, m.
pub const KNEE_CLEARANCE_M: f32 = 0.0;

/// The knee's pole for `limb` reaching `ankle`, turned `angle` radians from forward and a
/// little out toward the leg's side (`out`: -1 left, 1 right; negative angles turn in).
fn knee_pole_at(limb: &TwoBone, angle: f32, out: f32) -> Vector3<f32> {
    limb.pole.normalize() * angle.cos() + Vector3::new(out, 0.0, 0.0) * angle.sin()
}

/// How far the knee and shin of `limb` reaching `ankle` with `pole` reach into the
/// deepest of `shells` (negative: their clearance).
fn leg_depth(limb: &TwoBone, ankle: Vector3<f32>, pole: Vector3<f32>, shells: &[Shell]) -> f32 {
    let knee = TwoBone { pole, ..*limb }.middle(ankle);
    shells
        .iter()
        .map(|s| s.depth_of(knee, knee, KNEE_R).max(s.depth_of(knee, ankle, SHIN_R)))
        .fold(f32::NEG_INFINITY, f32::max)
}

/// Each knee's turn from forward for a whole motion: the smallest (5 degrees at a time, out
/// first, up to straight to either side) with which the knee and shin clear every
/// drum by [`KNEE_CLEARANCE_M`] in every tenth frame; the clearest when none does. One turn
/// per take: a knee that swung over mid-song would pop.
pub fn knee_angles(rig: &Rig, motion: &Motion, shells: &[Shell]) -> [Option<f32>; 2] {
    if shells.is_empty() || motion.frames.is_empty() {
        return [None; 2];
    }
    let rest = rig.rest_positions();
    // Each sampled frame's hip joints (where the chest put the hips) and ankles.
    let legs: Vec<[(Vector3<f32>, Vector3<f32>); 2]> = motion
        .frames
        .iter()
        .step_by(10)
        .map(|f| {
            let world = rig.world(&solve(rig, f));
            std::array::from_fn(|side| (world[UPPER_LEG[side]].0, position(&f.feet[side], rest[FOOT[side]])))
        })
        .collect();
    let step = 5f32.to_radians();
    std::array::from_fn(|side| {
        let out = if side == 0 { -1.0 } else { 1.0 };
        let lengths = [rig.link_length(UPPER_LEG[side] + 1), rig.link_length(FOOT[side])];
        let worst = |angle: f32| {
            legs.iter()
                .map(|l| {
                    let (root, ankle) = l[side];
                    let limb = TwoBone { root, lengths, pole: knee_forward(out), hinge_rest: -Vector3::x() };
                    leg_depth(&limb, ankle, knee_pole_at(&limb, angle, out), shells)
                })
                .fold(f32::NEG_INFINITY, f32::max)
        };
        let mut best = (0.0, f32::INFINITY);
        for k in 0..=18 {
            for turn in [1.0, -1.0] {
                if k == 0 && turn < 0.0 {
                    continue;
                }
                let a = turn * k as f32 * step;
                let depth = worst(a);
                if depth <= -KNEE_CLEARANCE_M {
                    return Some(a);
                }
                if depth < best.1 {
                    best = (a, depth);
                }
            }
        }
        Some(best.0)
    })
}

/// A knee's default pole: forward and a little out to its side `out`.
fn knee_forward(out: f32) -> Vector3<f32> {
    Vector3::new(0.2 * out, 1.0, 0.0)
}

/// A target's rotation, identity when it is not a usable quaternion.
fn rotation(p: &Pose) -> UnitQuaternion<f32> {
    let [w, x, y, z] = p.rot;
    let n = (w * w + x * x + y * y + z * z).sqrt();
    if n > 1e-6 && n.is_finite() {
        p.rotation()
    } else {
        UnitQuaternion::identity()
    }
}

/// A target's position, `fallback` when it is not finite.
fn position(p: &Pose, fallback: Vector3<f32>) -> Vector3<f32> {
    let v = Vector3::from(p.pos);
    if v.iter().all(|x| x.is_finite()) {
        v
    } else {
        fallback
    }
}

/// The twist part of a rotation about the local z axis (swing-twist decomposition).
fn twist_about_z(q: &UnitQuaternion<f32>) -> UnitQuaternion<f32> {
    let (w, z) = (q.w, q.k);
    let n = (w * w + z * z).sqrt();
    if n < 1e-6 {
        UnitQuaternion::identity()
    } else {
        UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(w / n, 0.0, 0.0, z / n))
    }
}

/// A two-bone limb whose bones point down (-z) in the rest pose and bend about
/// `hinge_rest` (a rest-frame axis perpendicular to z).
#[derive(Clone, Copy)]
struct TwoBone {
    /// World position of the first joint (shoulder, hip).
    root: Vector3<f32>,
    /// Upper and lower link lengths.
    lengths: [f32; 2],
    /// World direction the middle joint (elbow, knee) should point towards.
    pole: Vector3<f32>,
    hinge_rest: Vector3<f32>,
}

impl TwoBone {
    /// World rotations of the upper and lower bones that put the end joint at `target` (or
    /// as near as the limb reaches), and the middle joint's local rotation.
    fn solve(&self, target: Vector3<f32>) -> (UnitQuaternion<f32>, UnitQuaternion<f32>, UnitQuaternion<f32>) {
        let (u, perp, dir, d) = self.geometry(target);
        let [a, b] = self.lengths;
        let mid = self.root + u * a;
        let f = (self.root + dir * d - mid) / b;
        let hinge = perp.cross(&dir).normalize();
        let upper = frame_rotation(u, hinge, self.hinge_rest);
        let bend_angle = u.dot(&f).clamp(-1.0, 1.0).acos();
        let axis = nalgebra::Unit::new_normalize(self.hinge_rest);
        let bend = UnitQuaternion::from_axis_angle(&axis, bend_angle);
        (upper, upper * bend, bend)
    }

    /// The pole swung by `angle` radians about the line from the root to `target`.
    fn swung(&self, target: Vector3<f32>, angle: f32) -> Vector3<f32> {
        let (_, perp, dir, _) = self.geometry(target);
        UnitQuaternion::from_axis_angle(&nalgebra::Unit::new_unchecked(dir), angle) * perp
    }

    /// Where the middle joint (elbow, knee) lands for `target`.
    fn middle(&self, target: Vector3<f32>) -> Vector3<f32> {
        self.root + self.geometry(target).0 * self.lengths[0]
    }

    /// The upper bone's direction, the unit pole across the limb, the limb's direction and
    /// its reached length.
    fn geometry(&self, target: Vector3<f32>) -> (Vector3<f32>, Vector3<f32>, Vector3<f32>, f32) {
        let [a, b] = self.lengths;
        let to = target - self.root;
        let dir = if to.norm() > 1e-6 { to.normalize() } else { -Vector3::z() };
        let d = to.norm().clamp((a - b).abs() + 1e-4, (a + b) * (1.0 - 1e-5));
        // The pole's part across the limb; a fallback when the pole lies along it.
        let across = |p: Vector3<f32>| p - dir * p.dot(&dir);
        let mut perp = across(self.pole.normalize());
        if perp.norm() < 1e-3 {
            perp = across(self.hinge_rest.cross(&Vector3::z()));
        }
        if perp.norm() < 1e-3 {
            perp = across(Vector3::y());
        }
        let perp = perp.normalize();
        // Law of cosines: the upper bone leaves `dir` by `alpha` towards the pole.
        let cos_alpha = ((a * a + d * d - b * b) / (2.0 * a * d)).clamp(-1.0, 1.0);
        let alpha = cos_alpha.acos();
        (dir * alpha.cos() + perp * alpha.sin(), perp, dir, d)
    }
}

/// The rotation taking the rest frame (bone along -z, hinge along `hinge_rest`) onto the
/// bone direction `u` and the hinge `hinge` (both unit, perpendicular).
fn frame_rotation(u: Vector3<f32>, hinge: Vector3<f32>, hinge_rest: Vector3<f32>) -> UnitQuaternion<f32> {
    let rest_axis = -Vector3::z();
    let from = Matrix3::from_columns(&[rest_axis, hinge_rest, rest_axis.cross(&hinge_rest)]);
    let to = Matrix3::from_columns(&[u, hinge, u.cross(&hinge)]);
    UnitQuaternion::from_rotation_matrix(&Rotation3::from_matrix_unchecked(to * from.transpose()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::track::ARKIT_NAMES;
    use crate::motion::track::STICK_TIP_LOCAL;

    /// A frame built from the rest pose, with the hands and feet moved to the given places.
    fn frame(rig: &Rig, hands: [[f32; 3]; 2], feet: [[f32; 3]; 2]) -> MotionFrame {
        let rest = rig.rest_positions();
        let tilt = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -0.3);
        let q = |r: UnitQuaternion<f32>| [r.w, r.i, r.j, r.k];
        let lean = UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.1);
        MotionFrame {
            hands: hands.map(|pos| Pose { pos, rot: q(tilt) }),
            chest: Pose { pos: rest[NECK[0]].into(), rot: q(lean) },
            head: Pose { pos: rest[HEAD].into(), rot: q(lean) },
            feet: feet.map(|pos| Pose { pos, rot: [1.0, 0.0, 0.0, 0.0] }),
            face: vec![0.0; ARKIT_NAMES.len()],
            hihat_openness: 0.0,
        }
    }

    fn grips(rig: &Rig, pose: &BodyPose) -> [Vector3<f32>; 2] {
        let w = rig.world(pose);
        HAND.map(|h| w[h].0 + w[h].1 * rig.grip_local)
    }

    #[test]
    fn reachable_hands_and_feet_are_met_within_a_millimetre() {
        let rig = Rig::default();
        let hands = [[-0.25, 0.25, 0.75], [0.1, 0.3, 0.8]];
        let feet = [[-0.3, 0.35, 0.1], [0.1, 0.55, 0.1]];
        let mut f = frame(&rig, hands, feet);
        // A hand rolled about the stick and turned inwards: the forearm takes part of it.
        let r = UnitQuaternion::from_euler_angles(-0.4, 0.9, -0.5);
        f.hands[1].rot = [r.w, r.i, r.j, r.k];
        let pose = solve(&rig, &f);
        for (side, g) in grips(&rig, &pose).iter().enumerate() {
            let err = (g - Vector3::from(hands[side])).norm();
            assert!(err < 1e-3, "hand {side} misses by {err} m");
        }
        let w = rig.world(&pose);
        for side in 0..2 {
            let err = (w[FOOT[side]].0 - Vector3::from(feet[side])).norm();
            assert!(err < 1e-3, "foot {side} misses by {err} m");
            // The hand and foot bones take the targets' rotations.
            assert!(w[HAND[side]].1.angle_to(&f.hands[side].rotation()) < 1e-3);
            assert!(w[FOOT[side]].1.angle_to(&f.feet[side].rotation()) < 1e-3);
            // Elbows out and down, knees forward: the middle joint lies on the pole's side of
            // the line from the root joint to the end.
            let out = if side == 0 { -1.0 } else { 1.0 };
            for (root, pole) in
                [(SHOULDER[side] + 1, Vector3::new(out, 0.0, -1.0)), (UPPER_LEG[side], Vector3::new(0.0, 1.0, 0.0))]
            {
                let (r, m, e) = (w[root].0, w[root + 1].0, w[root + 2].0);
                let dir = (e - r).normalize();
                let across = pole - dir * pole.dot(&dir);
                assert!((m - r).dot(&across) > 0.05, "{} bends the wrong way", rig.bones[root + 1].name);
            }
        }
        // The chest and head take their rotations; the chest target is met by the spine.
        assert!(w[SPINE[2]].1.angle_to(&f.chest.rotation()) < 1e-4);
        assert!(w[HEAD].1.angle_to(&f.head.rotation()) < 1e-4);
        assert!((w[NECK[0]].0 - Vector3::from(f.chest.pos)).norm() < 1e-3);
    }

    #[test]
    fn a_hand_crossing_in_front_of_the_body_swings_its_elbow_out_of_the_torso() {
        let rig = Rig::default();
        let feet = [[-0.3, 0.35, 0.1], [0.1, 0.55, 0.1]];
        // The right hand sweeps from over the floor tom to in front of the chest (a crossed
        // hi-hat stroke's upswing), one frame at a time.
        let frames: Vec<MotionFrame> = (0..=40)
            .map(|i| {
                let t = i as f32 / 40.0;
                let right = Vector3::new(0.25, 0.35, 0.8).lerp(&Vector3::new(-0.09, 0.11, 1.0), t);
                frame(&rig, [[-0.2, 0.13, 0.71], right.into()], feet)
            })
            .collect();
        let motion = Motion { fps: 60.0, frames: frames.clone() };
        let poses = solve_motion(&rig, &motion);
        let mut swung = false;
        for (f, pose) in poses.iter().enumerate() {
            let w = rig.world(pose);
            let torso = Capsule { a: w[HIPS].0, b: w[NECK[0]].0, r: TORSO_R, name: "torso" };
            let (elbow, wrist) = (w[HAND[1] - 1].0, w[HAND[1]].0);
            let forearm = Capsule { a: elbow, b: wrist, r: FOREARM_R, name: "forearm" };
            let depth = forearm.overlap(&torso);
            // The swing aims for ARM_CLEARANCE_M; its rate limit may eat some of that margin on
            // a fast sweep, never all of it.
            assert!(depth <= 0.0, "frame {f}: the forearm is {depth} m into the torso");
            // The grip may move out of the chest (stick_clear), the stick's tip stays.
            let tip = grips(&rig, pose)[1] + w[HAND[1]].1 * Vector3::from(STICK_TIP_LOCAL);
            let err = (tip - Vector3::from(frames[f].hands[1].stick_tip())).norm();
            assert!(err < 1e-3, "frame {f}: the stick tip misses by {err} m");
            swung |= elbow.x > wrist.x + 0.1;
            if f > 0 {
                for (b, (q1, q0)) in pose.local.iter().zip(&poses[f - 1].local).enumerate() {
                    let deg = q1.angle_to(q0).to_degrees();
                    assert!(deg < 20.0, "frame {f}: {} turns {deg} degrees", rig.bones[b].name);
                }
            }
        }
        assert!(swung, "the elbow stays in front of the belly");
    }

    #[test]
    fn a_wrist_sent_across_the_kit_in_one_frame_turns_no_bone_over_the_limit_and_catches_up() {
        let rig = Rig::default();
        let feet = [[-0.3, 0.35, 0.1], [0.1, 0.55, 0.1]];
        // The right hand from a high hi-hat stroke by the left knee to low over the floor
        // tom in one frame (60 cm), held there three frames.
        let (from, to) = ([-0.15, 0.35, 0.95], [0.45, 0.3, 0.6]);
        let frames: Vec<MotionFrame> =
            [from, from, to, to, to].iter().map(|&r| frame(&rig, [[-0.2, 0.13, 0.71], r], feet)).collect();
        let unlimited: Vec<BodyPose> = {
            let mut carry = Carry::default();
            frames.iter().map(|f| solve_after(&rig, f, &mut carry)).collect()
        };
        let worst = |poses: &[BodyPose]| {
            poses
                .windows(2)
                .flat_map(|w| w[1].local.iter().zip(&w[0].local).map(|(a, b)| a.angle_to(b)))
                .fold(0.0, f32::max)
        };
        assert!(worst(&unlimited) > MAX_BONE_TURN_RAD, "{} degrees: no jump to limit", worst(&unlimited).to_degrees());
        let poses = solve_motion(&rig, &Motion { fps: 60.0, frames: frames.clone() });
        assert!(worst(&poses) <= MAX_BONE_TURN_RAD + 1e-4, "{} degrees", worst(&poses).to_degrees());
        // The frames before the jump are as solved; two frames after it the hand is there.
        assert_eq!(poses[1].local, unlimited[1].local);
        let wrist = |p: &BodyPose| rig.world(p)[HAND[1]].0;
        assert!((wrist(&poses[4]) - wrist(&unlimited[4])).norm() < 1e-3);
    }

    #[test]
    fn link_lengths_are_preserved() {
        let rig = Rig::default();
        let f = frame(&rig, [[-0.2, 0.4, 0.7], [0.2, 0.5, 0.9]], [[-0.25, 0.3, 0.1], [0.1, 0.5, 0.1]]);
        let pose = solve(&rig, &f);
        let w = rig.world(&pose);
        for (i, bone) in rig.bones.iter().enumerate() {
            if let Some(p) = bone.parent {
                let len = (w[i].0 - w[p].0).norm();
                assert!((len - rig.link_length(i)).abs() < 1e-5, "{}: {len}", bone.name);
            }
        }
    }

    #[test]
    fn unreachable_and_broken_targets_stay_finite() {
        let rig = Rig::default();
        let far = [[-3.0, 5.0, 4.0], [0.0, 0.0, 0.0]];
        let mut f = frame(&rig, far, [[0.0, 9.0, -5.0], [f32::NAN, 0.0, 0.0]]);
        f.hands[1].rot = [0.0; 4];
        f.chest.pos = [1e9, 0.0, 0.0];
        let pose = solve(&rig, &f);
        assert!(pose.root.iter().all(|x| x.is_finite()));
        assert!(pose.local.iter().all(|q| q.coords.iter().all(|x| x.is_finite())));
        assert!((pose.root - rig.rest_pose().root).norm() <= MAX_HIP_SHIFT_M + 1e-5);
        // The far left hand: the arm is straight and points at the target.
        let w = rig.world(&pose);
        let shoulder = w[SHOULDER[0] + 1].0;
        let wrist = w[HAND[0]].0;
        let reach = rig.link_length(SHOULDER[0] + 2) + rig.link_length(HAND[0]);
        assert!(((wrist - shoulder).norm() - reach).abs() < 1e-3);
    }

    #[test]
    fn same_frame_same_pose() {
        let rig = Rig::default();
        let f = frame(&rig, [[-0.2, 0.4, 0.7], [0.2, 0.5, 0.9]], [[-0.25, 0.3, 0.1], [0.1, 0.5, 0.1]]);
        assert_eq!(solve(&rig, &f), solve(&rig, &f));
    }
}
