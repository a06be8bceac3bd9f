//! The rapier world of the drummer: one rigid body per link, spherical impulse joints with
//! three angular velocity motors each (the PD's implicit damping), the sticks as capsule
//! colliders on the hand bodies, and the kit's pieces as fixed colliders.
//!
//! Only the sticks and the kit collide (collision groups), so the broad and narrow phases
//! see a handful of pairs. Body links carry their mass as `additional_mass_properties`
//! rather than as colliders.

use super::skeleton::{Skeleton, WorldPose, HAND, LINKS};
use crate::kit::{Kit, PieceKind};
use rapier3d::prelude::*;

/// Physics step, seconds (10 kHz).
pub const DT_S: f32 = 1e-4;

/// Membership and filter bits: sticks meet the kit and nothing else.
const STICKS: Group = Group::GROUP_1;
const KIT: Group = Group::GROUP_2;

/// Thickness of a drum's collider below its playing surface (a solid drum: a stick driven
/// through a thin head at 9 m/s ended up trapped under it), and of a cymbal.
const HEAD_DEPTH_M: f32 = 0.15;
const PLATE_THICKNESS_M: f32 = 0.004;

/// Depth of a drum's shell below its head, for clamping targets, m.
const DRUM_DEPTH_M: f32 = 0.35;

/// Coefficients of restitution of a stick on a head and on a cymbal.
const HEAD_RESTITUTION: f32 = 0.5;
const PLATE_RESTITUTION: f32 = 0.3;

/// A kit piece as the body sees it: a collider and its playing surface.
#[derive(Debug, Clone)]
pub struct Surface {
    pub id: String,
    pub collider: ColliderHandle,
    pub center: Vector,
    pub normal: Vector,
    /// Tangent axes of the surface: strike points are (x, y) along them.
    pub u: Vector,
    pub v: Vector,
    pub radius_m: f32,
    /// How deep below the surface the piece is solid, for clamping targets (a drum's shell;
    /// a cymbal's thickness).
    pub depth_m: f32,
}

/// Deepest a tip target may aim below a surface's contact height, metres.
pub const MAX_AIM_DEPTH_M: f32 = 0.010;

impl Surface {
    /// A tip-centre target moved out of the piece: if it lies within the piece (inside its
    /// radius and less than its depth below the surface), it is raised to at most
    /// `MAX_AIM_DEPTH_M` below the height where the bead of radius `tip_r` touches.
    pub fn clamp_target(&self, tip: Vector, tip_r: f32) -> Vector {
        let h = self.height(tip);
        let floor = tip_r - MAX_AIM_DEPTH_M;
        if h >= floor || h < -self.depth_m {
            return tip;
        }
        let d = tip - self.center;
        let planar = d - self.normal * h;
        if planar.length() > self.radius_m + tip_r {
            return tip;
        }
        tip + self.normal * (floor - h)
    }

    /// Strike point in the surface's own coordinates, metres from its centre.
    pub fn local_xy(&self, p: Vector) -> (f32, f32) {
        let d = p - self.center;
        (d.dot(self.u), d.dot(self.v))
    }

    /// Height of `p` above the playing surface (negative below it).
    pub fn height(&self, p: Vector) -> f32 {
        (p - self.center).dot(self.normal)
    }
}

/// Tangent basis of a surface: u is the world +x laid onto the surface (world +y where the
/// surface faces sideways), v = n x u: [`crate::kit::surface_basis`], which direct mode uses too.
pub fn surface_basis(n: Vector) -> (Vector, Vector) {
    let (u, v) = crate::kit::surface_basis(n.into());
    (Vector::from(u), Vector::from(v))
}

/// The built world and the handles the controller needs.
pub struct Model {
    pub world: PhysicsWorld,
    pub bodies: [RigidBodyHandle; LINKS],
    /// `joints[j]` joins link j + 1 to its parent.
    pub joints: Vec<ImpulseJointHandle>,
    pub sticks: [ColliderHandle; 2],
    pub surfaces: Vec<Surface>,
    /// Which surface each kit collider belongs to (a hoop is several colliders).
    pub owners: Vec<(ColliderHandle, usize)>,
}

/// A copy of the world that steps exactly as the original from here on: every set, the
/// broad and narrow phases (with their contact caches) cloned, the pipelines (workspace
/// only) made anew. The offline render rehearses a stroke again from such a copy.
impl Clone for Model {
    fn clone(&self) -> Model {
        let w = &self.world;
        let mut world = PhysicsWorld::new();
        world.gravity = w.gravity;
        world.integration_parameters = w.integration_parameters;
        world.islands = w.islands.clone();
        world.broad_phase = w.broad_phase.clone();
        world.narrow_phase = w.narrow_phase.clone();
        world.bodies = w.bodies.clone();
        world.colliders = w.colliders.clone();
        world.impulse_joints = w.impulse_joints.clone();
        world.multibody_joints = w.multibody_joints.clone();
        world.soft_bodies = w.soft_bodies.clone();
        Model {
            world,
            bodies: self.bodies,
            joints: self.joints.clone(),
            sticks: self.sticks,
            surfaces: self.surfaces.clone(),
            owners: self.owners.clone(),
        }
    }
}

impl Model {
    /// Whether surface `k` is a drum's hoop (a ring of colliders).
    pub fn is_ring(&self, k: usize) -> bool {
        self.owners.iter().filter(|(_, o)| *o == k).nth(1).is_some()
    }

    /// The surface a kit collider belongs to.
    pub fn surface_of(&self, c: ColliderHandle) -> Option<usize> {
        self.owners.iter().find(|(h, _)| *h == c).map(|(_, k)| *k)
    }
}

/// Segments, height above the head and tube radius of a drum's hoop.
const HOOP_SEGMENTS: usize = 16;
pub const HOOP_HEIGHT_M: f32 = 0.012;
pub const HOOP_RADIUS_M: f32 = 0.004;

/// Mass properties of a link in its own frame (hands include their stick).
pub fn link_mass(skel: &Skeleton, i: usize) -> MassProperties {
    let l = &skel.links[i];
    let mut m = MassProperties::with_principal_inertia_frame(l.com, l.mass_kg, l.inertia, l.inertia_frame);
    if HAND.contains(&i) {
        let s = &skel.stick;
        let len = s.to_tip_m + s.to_butt_m;
        let com = (s.tip() + s.butt()) * 0.5;
        let axial = 0.5 * s.mass_kg * s.radius_m * s.radius_m;
        let transverse = s.mass_kg * len * len / 12.0;
        let frame = Rotation::from_rotation_arc(Vector::Y, s.dir);
        m += MassProperties::with_principal_inertia_frame(
            com,
            s.mass_kg,
            Vector::new(transverse, axial, transverse),
            frame,
        );
    }
    m
}

/// The natural frequency of a stick's contact with the kit, Hz: the kit is rigid to the body
/// (a head's give is the sound engine's Hertz contact). rapier's default for a fixed body
/// (60 Hz, damping ratio 10) is, under a stick and hand of 0.15 kg at 10 kHz, a spring of
/// about 20 kN/m that lets only 43 % of each step's push-back through: a stick pressed into
/// a head or hoop sank up to 11.9 mm, 33 validation takes over 2 mm. Over the split at 2 kHz:
/// 6.2 mm, 16 takes; at 10 kHz: 4.5 mm, 9 takes, the notes hit as before.
pub const KIT_CONTACT_HZ: f32 = 10_000.0;

/// Build the world with the body in `pose` (whose joint rotations are `joint_rot`).
pub fn build(skel: &Skeleton, pose: &WorldPose, kit: &Kit, solver_iterations: usize) -> Model {
    let mut world = PhysicsWorld::new();
    world.gravity = Vector::new(0.0, 0.0, -9.81);
    world.integration_parameters.dt = DT_S;
    // One substep per 0.1 ms step, iterated `solver_iterations` times: at this step size
    // substeps buy little, and each costs a full constraint update (about 15 % of the loop).
    world.integration_parameters.num_solver_iterations = 1;
    world.integration_parameters.num_internal_pgs_iterations = solver_iterations.max(1);
    world.integration_parameters.warmstart_joints = true;
    // Every contact is found afresh each step. rapier otherwise reuses a pair's contact
    // points while the two colliders have moved less than 5 cm relative to each other, and
    // a stick crosses that in 5-50 ms: its separations and impulses went stale through a
    // stroke's last millimetres, so sticks sank into heads (18.7 mm against 4.8 mm on eight
    // validation takes) and contacts were reported late or twice.
    world.integration_parameters.contact_recycling = false;
    // The kit is rigid to the body (its give is the sound engine's Hertz contact).
    world.integration_parameters.static_contact_softness.natural_frequency = KIT_CONTACT_HZ;
    let mut bodies = [RigidBodyHandle::invalid(); LINKS];
    for i in 0..LINKS {
        let builder = if i == 0 { RigidBodyBuilder::fixed() } else { RigidBodyBuilder::dynamic() };
        let rb = builder
            .pose(Pose::from_parts(pose.pos[i], pose.rot[i]))
            .additional_mass_properties(link_mass(skel, i))
            .can_sleep(false)
            .build();
        bodies[i] = world.bodies.insert(rb);
    }
    let mut joints = Vec::with_capacity(LINKS - 1);
    for i in 1..LINKS {
        let parent = skel.links[i].parent.unwrap_or(0);
        let mut joint = SphericalJointBuilder::new()
            .local_anchor1(skel.links[i].offset)
            .local_anchor2(Vector::ZERO)
            .contacts_enabled(false)
            .build();
        for axis in [JointAxis::AngX, JointAxis::AngY, JointAxis::AngZ] {
            joint.data.set_motor_model(axis, MotorModel::ForceBased);
            joint.data.set_motor_velocity(axis, 0.0, 0.0);
        }
        joints.push(world.impulse_joints.insert(bodies[parent], bodies[i], joint, true));
    }
    let s = &skel.stick;
    let mut sticks = [ColliderHandle::invalid(); 2];
    for (side, &h) in HAND.iter().enumerate() {
        let c = ColliderBuilder::capsule_from_endpoints(s.butt(), s.tip(), s.radius_m)
            .density(0.0)
            .friction(0.4)
            .restitution(HEAD_RESTITUTION)
            .collision_groups(InteractionGroups::new(STICKS, KIT, InteractionTestMode::And))
            .build();
        sticks[side] = world.colliders.insert_with_parent(c, bodies[h], &mut world.bodies);
    }
    let kit_body = world.bodies.insert(RigidBodyBuilder::fixed().build());
    let mut surfaces = Vec::with_capacity(kit.pieces.len());
    let mut owners = Vec::with_capacity(kit.pieces.len() + HOOP_SEGMENTS);
    let kit_groups = InteractionGroups::new(KIT, STICKS, InteractionTestMode::And);
    for piece in &kit.pieces {
        let n = Vector::from(piece.normal).normalize();
        let center = Vector::from(piece.position_m);
        let (half, restitution) = match piece.kind {
            PieceKind::Membrane => (0.5 * HEAD_DEPTH_M, HEAD_RESTITUTION),
            PieceKind::Plate => (0.5 * PLATE_THICKNESS_M, PLATE_RESTITUTION),
        };
        let (u, v) = surface_basis(n);
        let drum = piece.id.strip_suffix("_rim").and_then(|d| kit.piece(d)).filter(|d| d.kind == PieceKind::Membrane);
        let k = surfaces.len();
        let collider = if let Some(drum) = drum {
            // A drum's hoop (`<drum>_rim`): a ring of capsules just outside the drum's head
            // and a little above it, where rim shots land. The piece's own position and
            // radius only place its sound.
            let dn = Vector::from(drum.normal).normalize();
            let dc = Vector::from(drum.position_m) + dn * HOOP_HEIGHT_M;
            let (du, dv) = surface_basis(dn);
            let r = drum.radius_m + HOOP_RADIUS_M;
            let at = |i: usize| {
                let a = std::f32::consts::TAU * i as f32 / HOOP_SEGMENTS as f32;
                dc + (du * a.cos() + dv * a.sin()) * r
            };
            let mut first = None;
            for i in 0..HOOP_SEGMENTS {
                let c = ColliderBuilder::capsule_from_endpoints(at(i), at(i + 1), HOOP_RADIUS_M)
                    .friction(0.4)
                    .restitution(PLATE_RESTITUTION)
                    .collision_groups(kit_groups)
                    .build();
                let h = world.colliders.insert_with_parent(c, kit_body, &mut world.bodies);
                owners.push((h, k));
                first.get_or_insert(h);
            }
            first.unwrap_or(ColliderHandle::invalid())
        } else {
            let placed = Pose::from_parts(center - n * half, Rotation::from_rotation_arc(Vector::Y, n));
            let c = ColliderBuilder::cylinder(half, piece.radius_m)
                .position(placed)
                .friction(0.4)
                .restitution(restitution)
                .collision_groups(kit_groups)
                .build();
            let h = world.colliders.insert_with_parent(c, kit_body, &mut world.bodies);
            owners.push((h, k));
            h
        };
        let depth_m = if drum.is_some() {
            0.02
        } else if piece.kind == PieceKind::Membrane {
            DRUM_DEPTH_M
        } else {
            0.02
        };
        surfaces.push(Surface {
            id: piece.id.clone(),
            collider,
            center,
            normal: n,
            u,
            v,
            radius_m: piece.radius_m,
            depth_m,
        });
    }
    Model { world, bodies, joints, sticks, surfaces, owners }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn surface_basis_is_orthonormal_and_faces_the_drummer_on_the_snare() {
        for n in [Vector::Z, Vector::new(0.15, -0.25, 0.96).normalize(), -Vector::Y, Vector::X] {
            let (u, v) = surface_basis(n);
            assert!(u.dot(n).abs() < 1e-6 && v.dot(n).abs() < 1e-6 && u.dot(v).abs() < 1e-6);
            assert!((u.length() - 1.0).abs() < 1e-6 && (v.length() - 1.0).abs() < 1e-6);
        }
        // On a flat drum, +y of the surface is forward, so the direct mode's -y points at the drummer.
        let (u, v) = surface_basis(Vector::Z);
        assert!(u.x > 0.99 && v.y > 0.99);
    }
}
