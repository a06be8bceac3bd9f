//! Damped-least-squares inverse kinematics of one arm: clavicle, shoulder, elbow and wrist
//! (four 3-DOF joints, 12 unknowns) moving the stick tip to a target.
//!
//! The Jacobian is fixed-size (3 x 12, nalgebra `SMatrix`), built from the world positions of
//! the joints: a world rotation vector `w_j` at joint `j` moves the tip by `w_j x (tip - p_j)`.
//! The stick's direction is a second, weaker task (3 more rows: a rotation `w_j` turns the
//! stick's unit direction by `w_j x dir`), scaled by `dir_weight_m`. One iteration solves the
//! weighted, damped normal equations `dq = W^-1 J^T (J W^-1 J^T + lambda^2 I)^-1 e` (a 6 x 6
//! solve), then pulls every joint
//! toward a rest posture inside the (approximate) null space of the tip task, so a redundant
//! arm does not drift into odd postures. No allocation; about a microsecond per iteration.

use super::skeleton::{Skeleton, WorldPose, ARM_BASE, JOINTS};
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use rapier3d::math::{Rotation, Vector};

/// Tuning of the IK iteration.
#[derive(Debug, Clone, Copy)]
pub struct IkSettings {
    /// Damping lambda, metres: keeps steps bounded near singular (stretched) arms.
    pub damping_m: f32,
    /// Mobility of clavicle, shoulder, elbow, wrist (larger moves more).
    pub mobility: [f32; 4],
    /// Fraction of the posture error removed per iteration, in the null space.
    pub posture_gain: f32,
    /// Largest tip error one iteration acts on, metres: at 10 kHz, 1.5 mm per step caps the
    /// kinematic layer at 15 m/s, so a jumping target cannot fling the arm.
    pub max_step_m: f32,
    /// Weight of the stick-direction task, metres per radian (0 ignores the direction).
    pub dir_weight_m: f32,
}

/// What one arm should do: put the stick tip at `tip`, the stick along `dir` (unit,
/// butt to tip).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ArmTarget {
    pub tip: Vector,
    pub dir: Vector,
}

impl Default for IkSettings {
    fn default() -> Self {
        IkSettings {
            damping_m: 0.02,
            mobility: [0.08, 1.0, 0.8, 0.6],
            posture_gain: 0.002,
            max_step_m: 0.0015,
            dir_weight_m: 0.1,
        }
    }
}

/// Joint indices of an arm's chain (0 left, 1 right), proximal first.
pub fn arm_joints(side: usize) -> [usize; 4] {
    let b = ARM_BASE[side] - 1;
    [b, b + 1, b + 2, b + 3]
}

type Jac = SMatrix<f32, 6, 12>;

fn na(v: Vector) -> Vector3<f32> {
    Vector3::new(v.x, v.y, v.z)
}

fn skew(r: Vector3<f32>) -> Matrix3<f32> {
    Matrix3::new(0.0, -r.z, r.y, r.z, 0.0, -r.x, -r.y, r.x, 0.0)
}

/// Rotation vector `log(a * b^-1)` (shortest arc).
pub fn rot_error(a: Rotation, b: Rotation) -> Vector {
    let mut d = a * b.inverse();
    if d.w < 0.0 {
        d = -d;
    }
    d.to_scaled_axis()
}

/// One IK iteration for arm `side`: world rotation increments for its four joints that move
/// the tip of `pose` toward `target`, with the posture pull toward `rest`.
/// `joints` are the current joint rotations (for the posture error).
pub fn arm_step(
    skel: &Skeleton,
    pose: &WorldPose,
    joints: &[Rotation; JOINTS],
    rest: &[Rotation; JOINTS],
    side: usize,
    target: &ArmTarget,
    s: &IkSettings,
) -> [Vector; 4] {
    let tip = skel.tip(pose, side);
    let dir = pose.rot[super::skeleton::HAND[side]] * skel.stick.dir;
    let wd = s.dir_weight_m;
    let chain = arm_joints(side);
    let mut jac = Jac::zeros();
    let mut w = SVector::<f32, 12>::zeros();
    let mut posture = SVector::<f32, 12>::zeros();
    for (k, &j) in chain.iter().enumerate() {
        let link = j + 1;
        let r = na(tip - pose.pos[link]);
        jac.fixed_view_mut::<3, 3>(0, 3 * k).copy_from(&(-skew(r)));
        jac.fixed_view_mut::<3, 3>(3, 3 * k).copy_from(&(-skew(na(dir)) * wd));
        for c in 0..3 {
            w[3 * k + c] = s.mobility[k];
        }
        // Posture error in world axes (the parent's frame turned to the world).
        let parent = skel.links[link].parent.unwrap_or(0);
        let e = pose.rot[parent] * rot_error(rest[j], joints[j]);
        posture.fixed_view_mut::<3, 1>(3 * k, 0).copy_from(&(na(e) * s.posture_gain));
    }
    let mut ep = na(target.tip - tip);
    let n = ep.norm();
    if n > s.max_step_m {
        ep *= s.max_step_m / n;
    }
    // A zero or non-finite direction means: no direction task.
    let want = target.dir.normalize_or_zero();
    let ed = if want == Vector::ZERO { Vector3::zeros() } else { na(want - dir) };
    let e = SVector::<f32, 6>::new(ep.x, ep.y, ep.z, ed.x * wd, ed.y * wd, ed.z * wd);
    if !e.iter().all(|x| x.is_finite()) {
        return [Vector::ZERO; 4];
    }
    // W^-1 J^T, then A = J W^-1 J^T + lambda^2 I.
    let wjt = SMatrix::<f32, 12, 6>::from_fn(|r, c| w[r] * jac[(c, r)]);
    let a = jac * wjt + SMatrix::<f32, 6, 6>::identity() * (s.damping_m * s.damping_m);
    let Some(a_inv) = a.try_inverse() else {
        return [Vector::ZERO; 4];
    };
    // Task step plus the posture pull with its tip effect removed.
    let dq_task = wjt * (a_inv * e);
    let dq_post = posture - wjt * (a_inv * (jac * posture));
    let dq = dq_task + dq_post;
    let mut out = [Vector::ZERO; 4];
    for (k, o) in out.iter_mut().enumerate() {
        *o = Vector::new(dq[3 * k], dq[3 * k + 1], dq[3 * k + 2]);
    }
    out
}

/// Apply world rotation increments `dw` to an arm's joint rotations: each joint turns by its
/// increment expressed in its parent's frame (`q <- exp(R_parent^-1 w) q`).
pub fn apply_arm_step(
    pose: &WorldPose,
    joints: &mut [Rotation; JOINTS],
    side: usize,
    dw: &[Vector; 4],
    skel: &Skeleton,
) {
    for (k, &j) in arm_joints(side).iter().enumerate() {
        let parent = skel.links[j + 1].parent.unwrap_or(0);
        let local = pose.rot[parent].inverse() * dw[k];
        joints[j] = (Rotation::from_scaled_axis(local) * joints[j]).normalize();
    }
}

/// Solve the arm kinematically: iterate until the tip is within `tol_m` of `target` or
/// `max_iter` iterations are spent. Returns the remaining tip error, metres.
#[allow(clippy::too_many_arguments)]
pub fn solve_arm(
    skel: &Skeleton,
    joints: &mut [Rotation; JOINTS],
    rest: &[Rotation; JOINTS],
    side: usize,
    target: &ArmTarget,
    s: &IkSettings,
    tol_m: f32,
    max_iter: usize,
) -> f32 {
    let mut err = f32::INFINITY;
    if !target.tip.is_finite() || !target.dir.is_finite() {
        return err;
    }
    for _ in 0..max_iter {
        let pose = skel.forward(Rotation::IDENTITY, joints);
        err = (skel.tip(&pose, side) - target.tip).length();
        if err <= tol_m {
            break;
        }
        let dw = arm_step(skel, &pose, joints, rest, side, target, s);
        apply_arm_step(&pose, joints, side, &dw, skel);
    }
    let pose = skel.forward(Rotation::IDENTITY, joints);
    err.min((skel.tip(&pose, side) - target.tip).length())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::anthropometry::{Anthropometry, BodySettings};
    use crate::body::skeleton::zero_joints;

    fn skeleton() -> Skeleton {
        Skeleton::new(&Anthropometry::new(BodySettings::default()).unwrap())
    }

    #[test]
    fn jacobian_predicts_small_motions() {
        let s = skeleton();
        let mut joints = zero_joints();
        joints[arm_joints(0)[2]] = Rotation::from_axis_angle(Vector::X, 1.2);
        let pose = s.forward(Rotation::IDENTITY, &joints);
        let tip0 = s.tip(&pose, 0);
        // A small world rotation at the elbow about an oblique axis.
        let w = Vector::new(0.3, -0.2, 0.5).normalize() * 1e-3;
        let mut moved = joints;
        let mut dw = [Vector::ZERO; 4];
        dw[2] = w;
        apply_arm_step(&pose, &mut moved, 0, &dw, &s);
        let tip1 = s.tip(&s.forward(Rotation::IDENTITY, &moved), 0);
        let predicted = w.cross(tip0 - pose.pos[arm_joints(0)[2] + 1]);
        assert!(((tip1 - tip0) - predicted).length() < 1e-3 * predicted.length() + 1e-6);
    }

    #[test]
    fn reaches_the_snare_and_the_ride_within_a_millimetre() {
        let s = skeleton();
        let rest = zero_joints();
        for (side, tip) in [(0, Vector::new(-0.12, 0.40, 0.70)), (1, Vector::new(0.45, 0.55, 1.10))] {
            let mut joints = zero_joints();
            let dir = Vector::new(0.0, 1.0, -0.3).normalize();
            let target = ArmTarget { tip, dir };
            let err = solve_arm(&s, &mut joints, &rest, side, &target, &IkSettings::default(), 1e-4, 600);
            assert!(err < 1e-3, "side {side}: {err} m left");
            let pose = s.forward(Rotation::IDENTITY, &joints);
            let got = pose.rot[crate::body::skeleton::HAND[side]] * s.stick.dir;
            assert!(got.dot(dir) > 0.98, "stick direction {got} vs {dir}");
        }
    }

    #[test]
    fn an_unreachable_target_leaves_a_finite_stretched_arm() {
        let s = skeleton();
        let rest = zero_joints();
        let mut joints = zero_joints();
        let target = ArmTarget { tip: Vector::new(3.0, 3.0, 3.0), dir: Vector::Y };
        let err = solve_arm(&s, &mut joints, &rest, 1, &target, &IkSettings::default(), 1e-4, 300);
        assert!(err.is_finite() && err > 2.0);
        assert!(joints.iter().all(|q| q.is_finite()));
        let nan = ArmTarget { tip: Vector::new(f32::NAN, 0.0, 0.0), dir: Vector::Y };
        let before = joints;
        solve_arm(&s, &mut joints, &rest, 1, &nan, &IkSettings::default(), 1e-4, 10);
        assert_eq!(before, joints, "a NaN target leaves the arm where it was");
    }
}
