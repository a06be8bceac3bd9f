//! The drummer: the rapier body, its PD joints and joint limits, the kinematic layer and the
//! three control modes, stepped at 10 kHz (Algorithm 2 of Hybrid Inverse Motion Control).
//!
//! Per physics step: read the joint states of the dynamic layer; form joint targets (from
//! the IK in `himc`, from a joint trajectory in `id`); set the PD motors; add joint-limit
//! torques; step rapier; turn new stick-kit contacts into strikes. `ik` moves only the
//! kinematic layer. A step allocates nothing.

use super::anthropometry::{Anthropometry, BodyError, BodySettings};
use super::contacts::{ContactTracker, Strike};
use super::ik::{apply_arm_step, arm_joints, arm_step, rot_error, solve_arm, ArmTarget, IkSettings};
use super::limits::LimitError;
use super::limits::{CompiledLimit, JointLimit};
use super::model::{self, Model, DT_S};
use super::pd::{gains, JointGains};
use super::skeleton::{Skeleton, WorldPose, JOINTS, LINKS};
use crate::kit::Kit;
use rapier3d::prelude::*;

/// How stick-tip targets become motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Mode {
    /// Kinematic IK only: no dynamics, no contacts.
    Ik,
    /// PD tracking of joint-space targets (inverse dynamics baseline).
    Id,
    /// IK inside every physics step, then the same PD (Hybrid Inverse Motion Control).
    Himc,
}

impl Mode {
    pub const ALL: [Mode; 3] = [Mode::Himc, Mode::Id, Mode::Ik];
    pub fn name(self) -> &'static str {
        match self {
            Mode::Ik => "ik",
            Mode::Id => "id",
            Mode::Himc => "himc",
        }
    }
}

/// Settings of the simulated drummer.
#[derive(Debug, Clone)]
pub struct DrummerSettings {
    pub body: BodySettings,
    /// PD natural frequency, Hz, and damping ratio. 36 Hz: with rapier's single substep
    /// per 0.1 ms step the joint motors converge less than with two, and a stiffer PD
    /// gives back the tracking (and is still far inside the stable range at 10 kHz).
    pub natural_hz: f32,
    pub damping_ratio: f32,
    /// Natural frequency of the joint-limit restoring torque, Hz.
    pub limit_hz: f32,
    /// Projected Gauss-Seidel iterations of rapier's solver in its one substep per step.
    pub solver_iterations: usize,
    pub ik: IkSettings,
    /// Gain of HIMC's task-space feedback (fraction of the simulated tip error fed back).
    pub feedback: f32,
    /// One limit per joint; `None` for no limits.
    pub limits: Option<Vec<JointLimit>>,
    /// Skip the stable-range check of the gains and counts (`drumsim check --force`: to see
    /// what the stability checks find past that range). The body is still checked.
    pub unchecked_gains: bool,
}

impl Default for DrummerSettings {
    fn default() -> Self {
        DrummerSettings {
            body: BodySettings::default(),
            natural_hz: 36.0,
            damping_ratio: 1.0,
            limit_hz: 8.0,
            solver_iterations: 2,
            ik: IkSettings::default(),
            feedback: 2.0,
            limits: Some(super::limits_data::shipped()),
            unchecked_gains: false,
        }
    }
}

/// A drummer that cannot be built from its settings.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DrummerError {
    #[error(transparent)]
    Body(#[from] BodyError),
    #[error("joint limits: {0}")]
    Limits(#[from] LimitError),
    #[error("drummer settings: {key} = {value} is outside {range}")]
    Setting { key: &'static str, value: f32, range: &'static str },
}

impl DrummerSettings {
    /// Reject gains and counts that would make no sense (or blow the simulation up).
    pub fn validate(&self) -> Result<(), DrummerError> {
        let check = |key: &'static str, value: f32, min: f32, max: f32, range: &'static str| {
            if (min..=max).contains(&value) || (self.unchecked_gains && value.is_finite() && value >= 0.0) {
                Ok(())
            } else {
                Err(DrummerError::Setting { key, value, range })
            }
        };
        check("natural_hz", self.natural_hz, 0.5, 60.0, "0.5..=60 Hz")?;
        check("damping_ratio", self.damping_ratio, 0.1, 5.0, "0.1..=5")?;
        check("limit_hz", self.limit_hz, 0.0, 30.0, "0..=30 Hz")?;
        // The contact and joint response is tuned at 2: one iteration, and 8 or more, let the
        // sticks bounce (`drumsim check`: 7-18 extra contacts in 16-30 strokes of a style;
        // 3 bounces vertical accents at 250 bpm).
        check("solver_iterations", self.solver_iterations as f32, 2.0, 4.0, "2..=4")?;
        check("feedback", self.feedback, 0.0, 2.0, "0..=2")?;
        check("ik.damping_m", self.ik.damping_m, 1e-4, 0.5, "1e-4..=0.5 m")?;
        check("ik.posture_gain", self.ik.posture_gain, 0.0, 0.5, "0..=0.5")?;
        check("ik.max_step_m", self.ik.max_step_m, 1e-4, 0.5, "1e-4..=0.5 m")?;
        for (i, m) in self.ik.mobility.iter().enumerate() {
            let key = ["ik.mobility[0]", "ik.mobility[1]", "ik.mobility[2]", "ik.mobility[3]"][i];
            check(key, *m, 1e-3, 10.0, "1e-3..=10")?;
        }
        if let Some(l) = &self.limits {
            if l.len() != JOINTS {
                return Err(DrummerError::Setting { key: "limits", value: l.len() as f32, range: "exactly 11 joints" });
            }
        }
        Ok(())
    }
}

/// Fastest relative angular velocity the PD asks of a joint, rad/s (wrist flicks in fast
/// strokes reach about 30).
pub const MAX_JOINT_SPEED_RAD_S: f32 = 40.0;

/// Where the sticks wait between strokes: tip heights above the snare (left) and the
/// hi-hat (right), metres.
pub const READY_HEIGHT_M: f32 = 0.10;

/// The simulated drummer. A clone steps exactly as the original from where it was taken.
#[derive(Clone)]
pub struct Drummer {
    pub skel: Skeleton,
    pub settings: DrummerSettings,
    model: Model,
    gains: [JointGains; JOINTS],
    /// Posture the IK pulls toward, and the PD's target for trunk, neck and head.
    pub rest: [Rotation; JOINTS],
    /// The kinematic layer's joint rotations (IK state).
    kin: [Rotation; JOINTS],
    step: u64,
    contacts: ContactTracker,
    limits: Vec<CompiledLimit>,
    /// Mass and local centre of mass of every link (hands with their sticks).
    link_mass: [(f32, Vector); LINKS],
    /// External torques on links, world axes.
    disturbance: [Vector; LINKS],
    /// `in_subtree[j][i]`: link i hangs from joint j.
    in_subtree: [[bool; LINKS]; JOINTS],
    /// Largest joint-limit violation seen (normalised ellipsoid radius - 1), for tests.
    pub max_limit_excess: f32,
    /// The joint where it was seen.
    pub worst_limit_joint: usize,
    /// The kinematic legs and feet (posed from foot targets, not simulated).
    legs: super::legs::Legs,
}

/// Joint-space targets of one step for `id` mode: rotations and angular velocities
/// (parent frame) for every joint.
#[derive(Debug, Clone, Copy)]
pub struct JointTargets {
    pub rot: [Rotation; JOINTS],
    pub vel: [Vector; JOINTS],
}

impl Drummer {
    /// Build the drummer in its ready pose above `kit`: left tip over the snare, right over
    /// the hi-hat (or the nearest pieces by those names' absence: the first two pieces).
    pub fn new(kit: &Kit, settings: DrummerSettings) -> Result<Drummer, DrummerError> {
        Drummer::new_at(kit, settings, None)
    }

    /// [`Drummer::new`] with the arms already reaching for `tips` (solved from the ready
    /// pose), when given: a performance whose first targets lie over another piece starts
    /// there, not swinging a stick from the snare across the kit to them (a left stick
    /// caught under tom 1's shell for the first 150 ms of a fill, 4.7 mm into it).
    pub fn new_at(
        kit: &Kit,
        settings: DrummerSettings,
        tips: Option<&[ArmTarget; 2]>,
    ) -> Result<Drummer, DrummerError> {
        settings.validate()?;
        let anthro = Anthropometry::new(settings.body)?;
        let skel = Skeleton::new(&anthro);
        let rest = ready_pose(&skel, kit, &settings.ik);
        let mut start = rest;
        for (side, target) in tips.into_iter().flatten().enumerate() {
            solve_arm(&skel, &mut start, &rest, side, target, &settings.ik, 1e-4, 3000);
        }
        let pose = skel.forward(Rotation::IDENTITY, &start);
        let mut model = model::build(&skel, &pose, kit, settings.solver_iterations);
        let legs = super::legs::Legs::new(&anthro);
        let gains = gains(&skel, &pose, settings.natural_hz, settings.damping_ratio);
        for (j, g) in gains.iter().enumerate() {
            if let Some(joint) = model.world.impulse_joints.get_mut(model.joints[j], false) {
                for (axis, ja) in [JointAxis::AngX, JointAxis::AngY, JointAxis::AngZ].into_iter().enumerate() {
                    joint.data.set_motor_velocity(ja, 0.0, g.kd[axis]);
                }
            }
        }
        let contacts = ContactTracker::new(&model, kit.strike.stick_mass_kg);
        let limits = match &settings.limits {
            Some(l) => l.iter().map(|l| l.compile()).collect::<Result<Vec<_>, _>>()?,
            None => Vec::new(),
        };
        let link_mass = std::array::from_fn(|i| {
            let m = model::link_mass(&skel, i);
            (m.mass(), m.local_com)
        });
        let in_subtree = std::array::from_fn(|j| std::array::from_fn(|i| super::pd::descends_from(&skel, i, j + 1)));
        Ok(Drummer {
            skel,
            settings,
            model,
            gains,
            rest,
            kin: start,
            step: 0,
            contacts,
            limits,
            link_mass,
            in_subtree,
            disturbance: [Vector::ZERO; LINKS],
            max_limit_excess: 0.0,
            worst_limit_joint: 0,
            legs,
        })
    }

    pub fn time_s(&self) -> f64 {
        self.step as f64 * DT_S as f64
    }

    pub fn steps(&self) -> u64 {
        self.step
    }

    pub fn surfaces(&self) -> &[model::Surface] {
        &self.model.surfaces
    }

    /// The kinematic layer's joint rotations.
    pub fn kinematic_joints(&self) -> &[Rotation; JOINTS] {
        &self.kin
    }

    /// World pose of the dynamic layer.
    pub fn sim_pose(&self) -> WorldPose {
        let mut pos = [Vector::ZERO; LINKS];
        let mut rot = [Rotation::IDENTITY; LINKS];
        for i in 0..LINKS {
            let b = &self.model.world.bodies[self.model.bodies[i]];
            pos[i] = b.translation();
            rot[i] = *b.rotation();
        }
        WorldPose { pos, rot }
    }

    /// Joint rotations of the dynamic layer.
    pub fn sim_joints(&self) -> [Rotation; JOINTS] {
        joints_of(&self.skel, &self.sim_pose())
    }

    /// Stick tips of the dynamic layer (or of the kinematic layer in `ik` mode).
    pub fn tips(&self, mode: Mode) -> [Vector; 2] {
        let pose = match mode {
            Mode::Ik => self.skel.forward(Rotation::IDENTITY, &self.kin),
            _ => self.sim_pose(),
        };
        [self.skel.tip(&pose, 0), self.skel.tip(&pose, 1)]
    }

    /// Largest separation of a joint's two anchors in the dynamic layer, metres (the
    /// constraint solver's error).
    pub fn joint_gap_m(&self) -> f32 {
        let pose = self.sim_pose();
        (1..LINKS)
            .map(|i| {
                let p = self.skel.links[i].parent.unwrap_or(0);
                (pose.pos[p] + pose.rot[p] * self.skel.links[i].offset - pose.pos[i]).length()
            })
            .fold(0.0, f32::max)
    }

    /// Stick directions of the kinematic layer (unit, butt to tip).
    pub fn stick_dirs(&self) -> [Vector; 2] {
        let pose = self.skel.forward(Rotation::IDENTITY, &self.kin);
        [0, 1].map(|side| pose.rot[super::skeleton::HAND[side]] * self.skel.stick.dir)
    }

    /// Kinetic energy of the moving links plus their potential energy above the floor, J.
    pub fn energy_j(&self) -> f32 {
        let g = 9.81;
        let mut e = 0.0;
        for i in 1..LINKS {
            let b = &self.model.world.bodies[self.model.bodies[i]];
            e += b.kinetic_energy() + b.mass() * g * b.center_of_mass().z;
        }
        e
    }

    /// The surfaces stick `side` (0 left, 1 right) is touching now, struck or resting.
    pub fn touching(&self, side: usize) -> impl Iterator<Item = usize> + '_ {
        self.contacts.touching(side)
    }

    /// Largest penetration of a stick into a kit piece seen so far, metres.
    pub fn max_penetration_m(&self) -> f32 {
        self.contacts.max_penetration_m
    }

    /// When (body time), into which surface and with which stick the deepest penetration was.
    pub fn deepest_penetration_at(&self) -> (f64, usize, usize) {
        self.contacts.deepest_at
    }

    /// Put the feet where the pedals need them (kick: right, hi-hat: left). The legs are
    /// kinematic: they are there at once.
    pub fn set_feet(&mut self, targets: [super::legs::FootTarget; 2]) {
        self.legs.set_targets(targets);
    }

    /// Hip, knee, ankle and toe of each leg (left, right).
    pub fn leg_poses(&self) -> [super::legs::LegPose; 2] {
        [self.legs.pose(0), self.legs.pose(1)]
    }

    /// Push a link with an external torque (world axes), held until changed (perturbation
    /// trials: breathing, a bump).
    pub fn set_disturbance(&mut self, link: usize, torque: Vector) {
        if link < LINKS && torque.is_finite() {
            self.disturbance[link] = torque;
        }
    }

    /// One 10 kHz step toward stick-tip targets (`ik` and `himc`). New strikes go to `sink`.
    pub fn step_tips(&mut self, mode: Mode, tips: &[ArmTarget; 2], sink: &mut impl FnMut(Strike)) {
        let before = self.kin;
        // Targets inside a drum are raised to just below its head: the stroke still presses,
        // the stick is never driven through the kit.
        let mut tips = *tips;
        for t in tips.iter_mut() {
            for s in &self.model.surfaces {
                t.tip = s.clamp_target(t.tip, self.skel.stick.radius_m);
            }
        }
        let tips = &tips;
        // Kinematic layer: one DLS iteration per arm toward the targets.
        let pose_k = self.skel.forward(Rotation::IDENTITY, &self.kin);
        for (side, tip) in tips.iter().enumerate() {
            let mut ik = self.settings.ik;
            let dw = arm_step(&self.skel, &pose_k, &before, &self.rest, side, tip, &ik);
            apply_arm_step(&pose_k, &mut self.kin, side, &dw, &self.skel);
            // A joint the step pushed past its limit is held, and the others take the step
            // without it: clamped afterwards, the step would no longer lead to the target.
            let mut held = false;
            for (k, j) in arm_joints(side).into_iter().enumerate() {
                if !self.limits[j].contains(&nalgebra_quat(self.kin[j])) {
                    ik.mobility[k] = 0.0;
                    held = true;
                }
            }
            if held {
                for j in arm_joints(side) {
                    self.kin[j] = before[j];
                }
                let dw = arm_step(&self.skel, &pose_k, &before, &self.rest, side, tip, &ik);
                apply_arm_step(&pose_k, &mut self.kin, side, &dw, &self.skel);
            }
        }
        clamp_to_limits(&self.limits, &mut self.kin);
        if mode == Mode::Ik {
            self.step += 1;
            return;
        }
        let mut targets = JointTargets { rot: self.kin, vel: [Vector::ZERO; JOINTS] };
        for j in 0..JOINTS {
            targets.vel[j] = rot_error(self.kin[j], before[j]) / DT_S;
        }
        let pose_s = self.sim_pose();
        if mode == Mode::Himc {
            // Task-space feedback: the IK of the simulated arm's tip error, on top of the
            // kinematic targets.
            let joints_s = joints_of(&self.skel, &pose_s);
            let mut fb = self.settings.ik;
            fb.posture_gain = 0.0;
            fb.max_step_m = 0.02;
            for (side, tip) in tips.iter().enumerate() {
                let dw = arm_step(&self.skel, &pose_s, &joints_s, &self.rest, side, tip, &fb);
                for (k, &j) in arm_joints(side).iter().enumerate() {
                    let parent = self.skel.links[j + 1].parent.unwrap_or(0);
                    let local = pose_s.rot[parent].inverse() * (dw[k] * self.settings.feedback);
                    targets.rot[j] = Rotation::from_scaled_axis(local) * targets.rot[j];
                }
            }
        }
        // The PD never aims outside a joint's limit.
        clamp_to_limits(&self.limits, &mut targets.rot);
        self.physics_step(&targets, pose_s, sink);
    }

    /// One 10 kHz step of `id` mode: PD toward joint targets. The kinematic layer follows
    /// the targets.
    pub fn step_joints(&mut self, targets: &JointTargets, sink: &mut impl FnMut(Strike)) {
        self.kin = targets.rot;
        let pose = self.sim_pose();
        self.physics_step(targets, pose, sink);
    }

    /// PD, gravity and limit torques from the dynamic layer's `pose`, then one rapier step.
    fn physics_step(&mut self, targets: &JointTargets, pose: WorldPose, sink: &mut impl FnMut(Strike)) {
        let world = &mut self.model.world;
        let mut torque = [Vector::ZERO; LINKS];
        let limit_k = (std::f32::consts::TAU * self.settings.limit_hz).powi(2);
        let weight: [Vector; LINKS] = std::array::from_fn(|i| {
            let (m, c) = self.link_mass[i];
            (pose.pos[i] + pose.rot[i] * c, m * 9.81)
        })
        .map(|(c, w)| Vector::new(c.x * w, c.y * w, w));
        for j in 0..JOINTS {
            let link = j + 1;
            let parent = self.skel.links[link].parent.unwrap_or(0);
            let q = pose.rot[parent].inverse() * pose.rot[link];
            let g = &self.gains[j];
            let err = rot_error(targets.rot[j], q);
            // Gravity compensation: the torque that holds the subtree's weight about the
            // joint, applied to child and parent as an external torque pair.
            let p = pose.pos[link];
            let mut hold = Vector::ZERO;
            for (i, w) in weight.iter().enumerate() {
                if self.in_subtree[j][i] {
                    // -(c - p) x (0, 0, -W), from the weights w = (W cx, W cy, W).
                    hold += Vector::new(w.y - p.y * w.z, -(w.x - p.x * w.z), 0.0);
                }
            }
            torque[link] += hold;
            torque[parent] -= hold;
            let v = targets.vel[j] + err * g.ks_over_kd;
            // A human joint turns at most a few tens of radians per second; a jumping target
            // must not make the implicit motor fling the link.
            let v = if v.is_finite() { v.clamp_length_max(MAX_JOINT_SPEED_RAD_S) } else { Vector::ZERO };
            if let Some(joint) = world.impulse_joints.get_mut(self.model.joints[j], false) {
                for (axis, (ja, va)) in
                    [JointAxis::AngX, JointAxis::AngY, JointAxis::AngZ].into_iter().zip([v.x, v.y, v.z]).enumerate()
                {
                    joint.data.set_motor_velocity(ja, va, g.kd[axis]);
                }
            }
            if let Some(limit) = self.limits.get(j) {
                let nq = nalgebra_quat(q);
                let excess = limit.normalized_radius(&nq) - 1.0;
                if excess > self.max_limit_excess {
                    self.max_limit_excess = excess;
                    self.worst_limit_joint = j;
                }
                // Inside the ellipsoid (the common case) there is nothing to restore.
                if let Some(r) = if excess > 0.0 { limit.restoring(&nq) } else { None } {
                    let r = Vector::new(r.x, r.y, r.z);
                    let i_mean = (g.inertia[0] + g.inertia[1] + g.inertia[2]) / 3.0;
                    let t = pose.rot[parent] * (r * (limit_k * i_mean));
                    torque[link] += t;
                    torque[parent] -= t;
                }
            }
        }
        for i in 1..LINKS {
            if let Some(b) = world.bodies.get_mut(self.model.bodies[i]) {
                b.reset_torques(false);
                b.add_torque(torque[i] + self.disturbance[i], false);
            }
        }
        world.step();
        self.step += 1;
        let t = self.time_s();
        self.contacts.update(&self.model, &self.skel, t, sink);
    }
}

/// Move every joint rotation outside its limit to the nearest allowed rotation.
fn clamp_to_limits(limits: &[CompiledLimit], rots: &mut [Rotation; JOINTS]) {
    for (q, limit) in rots.iter_mut().zip(limits) {
        let nq = nalgebra_quat(*q);
        if !limit.contains(&nq) {
            let n = limit.nearest_allowed(&nq);
            *q = Rotation::from_xyzw(n.i, n.j, n.k, n.w);
        }
    }
}

/// nalgebra's quaternion for a glam one (the joint-limit maths is nalgebra).
pub fn nalgebra_quat(q: Rotation) -> nalgebra::UnitQuaternion<f32> {
    nalgebra::UnitQuaternion::new_unchecked(nalgebra::Quaternion::new(q.w, q.x, q.y, q.z))
}

/// Joint rotations of a world pose.
pub fn joints_of(skel: &Skeleton, pose: &WorldPose) -> [Rotation; JOINTS] {
    let mut q = [Rotation::IDENTITY; JOINTS];
    for (j, qj) in q.iter_mut().enumerate() {
        let link = j + 1;
        let parent = skel.links[link].parent.unwrap_or(0);
        *qj = (pose.rot[parent].inverse() * pose.rot[link]).normalize();
    }
    q
}

/// The ready pose: IK from a relaxed seated posture to tips `READY_HEIGHT_M` above the
/// snare (left hand) and the hi-hat (right hand, crossed over as most drummers play).
pub fn ready_pose(skel: &Skeleton, kit: &Kit, ik: &IkSettings) -> [Rotation; JOINTS] {
    let relaxed = relaxed_pose();
    let mut joints = relaxed;
    for (side, id) in [(0, "snare"), (1, "hihat")] {
        let Some(piece) = kit.piece(id).or(kit.pieces.get(side)) else { continue };
        let n = Vector::from(piece.normal).normalize();
        let center = Vector::from(piece.position_m);
        let target = ArmTarget { tip: center + n * READY_HEIGHT_M, dir: stick_dir(side, center, n) };
        solve_arm(skel, &mut joints, &relaxed, side, &target, ik, 1e-4, 3000);
    }
    joints
}

/// The direction a stick points when its tip rests on a piece: from the player's shoulder
/// toward the piece, laid on the surface and tilted 17 degrees into it.
pub fn stick_dir(side: usize, center: Vector, normal: Vector) -> Vector {
    let shoulder = Vector::new(if side == 0 { -0.19 } else { 0.19 }, 0.0, center.z);
    let h = (center - shoulder).normalize_or(Vector::Y);
    let t = (h - normal * h.dot(normal)).normalize_or(Vector::Y);
    (t - normal * 0.3).normalize()
}

/// A seated drummer's relaxed posture: elbows bent, forearms forward, sticks toward the kit.
pub fn relaxed_pose() -> [Rotation; JOINTS] {
    use super::skeleton::ARM_BASE;
    let mut q = [Rotation::IDENTITY; JOINTS];
    for (side, &base) in ARM_BASE.iter().enumerate() {
        let s = if side == 0 { -1.0 } else { 1.0 };
        // Shoulder: upper arm a little forward and out; elbow bent ~70 degrees; wrist level.
        q[base] = Rotation::from_rotation_z(-0.2 * s)
            * Rotation::from_rotation_x(0.35)
            * Rotation::from_rotation_y(-0.25 * s);
        q[base + 1] = Rotation::from_rotation_x(1.2);
        q[base + 2] = Rotation::from_rotation_x(-0.1);
    }
    q
}
