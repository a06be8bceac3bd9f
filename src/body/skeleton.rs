//! The upper-body skeleton: twelve links, eleven 3-DOF joints, and forward kinematics.
//!
//! Coordinates follow the kit: metres, +x to the drummer's right, +y forward, +z up, origin
//! on the floor under the stool. Every link's frame sits at its proximal joint. In the zero
//! pose (all joint rotations identity) every frame is aligned with the world: the trunk,
//! neck and head point up, the clavicles point sideways, arms and hands hang down, and each
//! stick lies in its fist pointing forward (+y).
//!
//! A joint's rotation `q` is the child's orientation relative to its parent:
//! `R_child = R_parent * q`. The pelvis is the fixed root (the drummer sits).

use super::anthropometry::{Anthropometry, Segment};
use rapier3d::math::{Rotation, Vector};

/// Number of links (pelvis included).
pub const LINKS: usize = 12;
/// Number of joints (every link but the pelvis has one, to its parent).
pub const JOINTS: usize = 11;

pub const PELVIS: usize = 0;
pub const TRUNK: usize = 1;
pub const NECK: usize = 2;
pub const HEAD: usize = 3;
/// First link of each arm: clavicle, then upper arm, forearm, hand (+0..+3).
pub const ARM_BASE: [usize; 2] = [4, 8];
/// The hand link of each arm (0 left, 1 right); the stick is part of the hand body.
pub const HAND: [usize; 2] = [7, 11];

/// Link names, also the joint names of the joint at each link's proximal end.
pub const LINK_NAMES: [&str; LINKS] = [
    "pelvis",
    "trunk",
    "neck",
    "head",
    "l_clavicle",
    "l_upper_arm",
    "l_forearm",
    "l_hand",
    "r_clavicle",
    "r_upper_arm",
    "r_forearm",
    "r_hand",
];

/// Radius of a stick's shaft and tip bead, m.
pub const STICK_RADIUS_M: f32 = 0.007;

/// Height of the hip joints above the floor (stool seat plus the hip's height above it).
pub const HIP_HEIGHT_M: f32 = 0.62;

/// One rigid link: where it hangs from its parent and what it weighs.
#[derive(Debug, Clone, Copy)]
pub struct Link {
    pub parent: Option<usize>,
    /// Position of this link's joint in the parent's frame.
    pub offset: Vector,
    /// Centre of mass in this link's frame.
    pub com: Vector,
    pub mass_kg: f32,
    /// Principal moments about the centre of mass, in the frame `inertia_frame`.
    pub inertia: Vector,
    pub inertia_frame: Rotation,
}

/// The stick held in a hand, in the hand's frame.
#[derive(Debug, Clone, Copy)]
pub struct StickGeometry {
    /// Grip point (fulcrum) in the hand frame.
    pub grip: Vector,
    /// Unit direction from butt to tip in the hand frame.
    pub dir: Vector,
    /// Distance from the grip to the tip and to the butt, m.
    pub to_tip_m: f32,
    pub to_butt_m: f32,
    /// Radius of the stick's shaft and tip bead, m.
    pub radius_m: f32,
    pub mass_kg: f32,
}

impl StickGeometry {
    /// Tip centre in the hand frame.
    pub fn tip(&self) -> Vector {
        self.grip + self.dir * self.to_tip_m
    }
    pub fn butt(&self) -> Vector {
        self.grip - self.dir * self.to_butt_m
    }
}

/// The whole upper body: links and sticks.
#[derive(Debug, Clone)]
pub struct Skeleton {
    pub links: [Link; LINKS],
    pub stick: StickGeometry,
    /// World position of the pelvis frame (the fixed root).
    pub root: Vector,
}

/// World poses of every link frame.
#[derive(Debug, Clone, Copy)]
pub struct WorldPose {
    pub pos: [Vector; LINKS],
    pub rot: [Rotation; LINKS],
}

impl Skeleton {
    /// The skeleton of a body with these proportions.
    pub fn new(anthro: &Anthropometry) -> Skeleton {
        let seg = |s| anthro.segment(s);
        let up = Vector::Z;
        // A segment along `dir` from its joint: centre of mass and inertia frame (capsule axis
        // along local y in the anthropometry, turned onto `dir`).
        let link = |parent: Option<usize>, offset: Vector, s: Segment, dir: Vector| {
            let p = seg(s);
            Link {
                parent,
                offset,
                com: dir * (p.length_m * s.com_fraction()),
                mass_kg: p.mass_kg,
                inertia: Vector::from(p.principal_inertia_y()),
                inertia_frame: Rotation::from_rotation_arc(Vector::Y, dir),
            }
        };
        let pelvis_len = anthro.length_m(Segment::Pelvis);
        let trunk_len = anthro.length_m(Segment::Trunk);
        let neck_len = anthro.length_m(Segment::Neck);
        let clav_len = anthro.length_m(Segment::Clavicle);
        let upper_len = anthro.length_m(Segment::UpperArm);
        let fore_len = anthro.length_m(Segment::Forearm);
        let mut links = [link(None, Vector::ZERO, Segment::Pelvis, up); LINKS];
        links[TRUNK] = link(Some(PELVIS), up * pelvis_len, Segment::Trunk, up);
        links[NECK] = link(Some(TRUNK), up * trunk_len, Segment::Neck, up);
        links[HEAD] = link(Some(NECK), up * neck_len, Segment::Head, up);
        for (side, &base) in ARM_BASE.iter().enumerate() {
            let out = if side == 0 { -Vector::X } else { Vector::X };
            // Sternoclavicular joint: just below the top of the trunk, beside the midline.
            let sc = up * (trunk_len - 0.03) + out * 0.02;
            links[base] = link(Some(TRUNK), sc, Segment::Clavicle, out);
            links[base + 1] = link(Some(base), out * clav_len, Segment::UpperArm, -up);
            links[base + 2] = link(Some(base + 1), -up * upper_len, Segment::Forearm, -up);
            links[base + 3] = link(Some(base + 2), -up * fore_len, Segment::Hand, -up);
        }
        let stick_len = anthro.settings.stick_length_m;
        let stick = StickGeometry {
            // The fulcrum sits in the palm, a third of the hand's length below the wrist.
            grip: -up * (anthro.length_m(Segment::Hand) * 0.35),
            dir: Vector::Y,
            to_tip_m: stick_len * 0.7,
            to_butt_m: stick_len * 0.3,
            radius_m: STICK_RADIUS_M,
            mass_kg: anthro.segment(Segment::Stick).mass_kg,
        };
        Skeleton { links, stick, root: Vector::new(0.0, 0.0, HIP_HEIGHT_M) }
    }

    /// Forward kinematics: world frames of all links from the joint rotations
    /// (`joints[j]` is the rotation of the joint at link `j + 1`) and the pelvis orientation.
    pub fn forward(&self, pelvis: Rotation, joints: &[Rotation; JOINTS]) -> WorldPose {
        let mut pos = [self.root; LINKS];
        let mut rot = [pelvis; LINKS];
        for i in 1..LINKS {
            let p = self.links[i].parent.unwrap_or(PELVIS);
            pos[i] = pos[p] + rot[p] * self.links[i].offset;
            rot[i] = rot[p] * joints[i - 1];
        }
        WorldPose { pos, rot }
    }

    /// World position of a stick tip (0 left, 1 right) in a pose.
    pub fn tip(&self, pose: &WorldPose, side: usize) -> Vector {
        let h = HAND[side];
        pose.pos[h] + pose.rot[h] * self.stick.tip()
    }

    /// Total mass of the simulated upper body (pelvis excluded) plus sticks, kg.
    pub fn moving_mass_kg(&self) -> f32 {
        self.links[1..].iter().map(|l| l.mass_kg).sum::<f32>() + 2.0 * self.stick.mass_kg
    }
}

/// Joint rotations of a pose with every joint at identity.
pub fn zero_joints() -> [Rotation; JOINTS] {
    [Rotation::IDENTITY; JOINTS]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::anthropometry::BodySettings;

    fn skeleton() -> Skeleton {
        Skeleton::new(&Anthropometry::new(BodySettings::default()).unwrap())
    }

    #[test]
    fn zero_pose_hangs_the_arms_and_points_the_sticks_forward() {
        let s = skeleton();
        let pose = s.forward(Rotation::IDENTITY, &zero_joints());
        for side in 0..2 {
            let shoulder = pose.pos[ARM_BASE[side] + 1];
            let hand = pose.pos[HAND[side]];
            // Arms hang straight down from the shoulder: upper arm + forearm lengths.
            assert!((shoulder.z - hand.z - (0.186 + 0.146) * 1.75).abs() < 1e-4);
            assert!((shoulder.x - hand.x).abs() < 1e-6);
            let tip = s.tip(&pose, side);
            assert!((tip.y - 0.28).abs() < 1e-5, "tip forward of the hand: {tip}");
        }
        assert!(pose.pos[ARM_BASE[0] + 1].x < 0.0 && pose.pos[ARM_BASE[1] + 1].x > 0.0);
    }

    #[test]
    fn a_shoulder_rotation_swings_the_whole_arm() {
        let s = skeleton();
        let mut joints = zero_joints();
        // Right shoulder forward flexion by 90 degrees: the arm points forward (+y).
        joints[ARM_BASE[1]] = Rotation::from_axis_angle(Vector::X, std::f32::consts::FRAC_PI_2);
        let pose = s.forward(Rotation::IDENTITY, &joints);
        let shoulder = pose.pos[ARM_BASE[1] + 1];
        let hand = pose.pos[HAND[1]];
        assert!((hand.y - shoulder.y - (0.186 + 0.146) * 1.75).abs() < 1e-4, "{shoulder} {hand}");
        assert!((hand.z - shoulder.z).abs() < 1e-4);
    }

    #[test]
    fn masses_add_up_to_the_upper_body_fractions() {
        let s = skeleton();
        // trunk 44 + neck 4 + head 4 + clavicles 2 + arms 4 + forearms 2 + hands 1 + sticks 1 = 62 %.
        assert!((s.moving_mass_kg() - 0.62 * 75.0).abs() < 1e-3, "{}", s.moving_mass_kg());
    }
}
