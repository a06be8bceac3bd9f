//! PD gains scaled to the inertia each joint moves.
//!
//! A joint's PD torque is `tau = ks * log(q_target q^-1) - kd * (omega - omega_target)`,
//! with the rotation error and angular velocities in the parent's frame. rapier's joint
//! motors apply it: each of the three angular motors gets the damping `kd` (solved
//! implicitly inside the constraint solver, so no gain can make it unstable) and the target
//! velocity `omega_target + (ks / kd) * error`, so the motor's torque
//! `kd * (v_target - omega)` is exactly the PD torque, applied to child and parent alike.
//!
//! Gains come from a natural frequency and damping ratio: per axis, `kd = 2 zeta wn I` and
//! `ks = wn^2 I`, where I is the moment of inertia of everything the joint carries (its
//! subtree, about the joint, at the reference pose) about that parent-frame axis. The
//! stiffness loop is explicit, and stable when `(ks / kd) dt = wn dt / (2 zeta) << 1`.

use super::model::link_mass;
use super::skeleton::{Skeleton, WorldPose, JOINTS, LINKS};
use rapier3d::math::Vector;

/// Gains of one joint.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointGains {
    /// Damping per parent-frame axis, N m s / rad.
    pub kd: [f32; 3],
    /// ks / kd, 1/s (the same for all three axes).
    pub ks_over_kd: f32,
    /// Subtree inertia per parent-frame axis, kg m^2.
    pub inertia: [f32; 3],
}

/// Gains of all joints for natural frequency `wn_hz` and damping ratio `zeta`.
pub fn gains(skel: &Skeleton, pose: &WorldPose, wn_hz: f32, zeta: f32) -> [JointGains; JOINTS] {
    let wn = std::f32::consts::TAU * wn_hz;
    let mut out = [JointGains { kd: [0.0; 3], ks_over_kd: 0.0, inertia: [0.0; 3] }; JOINTS];
    for (j, g) in out.iter_mut().enumerate() {
        let link = j + 1;
        let parent = skel.links[link].parent.unwrap_or(0);
        let inertia = subtree_inertia(skel, pose, link);
        // Diagonal of the world tensor seen along the parent's axes.
        for (axis, i_axis) in g.inertia.iter_mut().enumerate() {
            let a = pose.rot[parent] * [Vector::X, Vector::Y, Vector::Z][axis];
            *i_axis = a.dot(mat_vec(&inertia, a));
        }
        for axis in 0..3 {
            g.kd[axis] = 2.0 * zeta * wn * g.inertia[axis];
        }
        g.ks_over_kd = wn / (2.0 * zeta);
    }
    out
}

fn mat_vec(m: &[[f32; 3]; 3], v: Vector) -> Vector {
    Vector::new(
        m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
        m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
        m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z,
    )
}

/// World inertia tensor of link `root` and everything below it, about `root`'s joint.
pub fn subtree_inertia(skel: &Skeleton, pose: &WorldPose, root: usize) -> [[f32; 3]; 3] {
    let origin = pose.pos[root];
    let mut total = [[0.0f32; 3]; 3];
    for i in 0..LINKS {
        if !descends_from(skel, i, root) {
            continue;
        }
        let mp = link_mass(skel, i);
        let com = pose.pos[i] + pose.rot[i] * mp.local_com;
        let d = com - origin;
        let frame = pose.rot[i] * mp.principal_inertia_local_frame;
        let pi = mp.principal_inertia();
        let axes = [frame * Vector::X, frame * Vector::Y, frame * Vector::Z];
        let dd = [d.x, d.y, d.z];
        for r in 0..3 {
            for c in 0..3 {
                let mut v = 0.0;
                for k in 0..3 {
                    let ak = [axes[k].x, axes[k].y, axes[k].z];
                    v += pi[k] * ak[r] * ak[c];
                }
                let delta = if r == c { d.length_squared() } else { 0.0 };
                total[r][c] += v + mp.mass() * (delta - dd[r] * dd[c]);
            }
        }
    }
    total
}

/// True when `link` is `root` or below it.
pub fn descends_from(skel: &Skeleton, mut link: usize, root: usize) -> bool {
    loop {
        if link == root {
            return true;
        }
        match skel.links[link].parent {
            Some(p) => link = p,
            None => return false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::anthropometry::{Anthropometry, BodySettings};
    use crate::body::skeleton::{zero_joints, ARM_BASE, HAND};
    use rapier3d::math::Rotation;

    #[test]
    fn subtree_inertia_of_the_head_matches_the_parallel_axis_theorem() {
        let s = Skeleton::new(&Anthropometry::new(BodySettings::default()).unwrap());
        let pose = s.forward(Rotation::IDENTITY, &zero_joints());
        let h = crate::body::skeleton::HEAD;
        let i = subtree_inertia(&s, &pose, h);
        let mp = link_mass(&s, h);
        // About the wrist's x axis: own inertia about x through the COM plus m d^2 (d in the y-z plane).
        let d = mp.local_com;
        let own = (mp.principal_inertia_local_frame * Vector::X).dot(Vector::X);
        assert!(own > 0.99);
        let expected = mp.principal_inertia().x + mp.mass() * (d.y * d.y + d.z * d.z);
        assert!((i[0][0] - expected).abs() < 1e-5 * expected.max(1e-3), "{} vs {expected}", i[0][0]);
    }

    #[test]
    fn gains_grow_with_the_load_a_joint_carries() {
        let s = Skeleton::new(&Anthropometry::new(BodySettings::default()).unwrap());
        let pose = s.forward(Rotation::IDENTITY, &zero_joints());
        let g = gains(&s, &pose, 10.0, 1.0);
        let shoulder = g[ARM_BASE[0]]; // joint of the upper arm
        let wrist = g[HAND[0] - 1];
        assert!(shoulder.kd[0] > 10.0 * wrist.kd[0]);
        assert!(g.iter().all(|j| j.kd.iter().all(|k| k.is_finite() && *k > 0.0)));
    }
}
