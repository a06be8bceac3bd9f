//! What an animator checks in a drummer's motion (issue 16): pops, flips, limbs through the
//! body or the kit, a torso that turns with the hands, ghost notes low, blinks.
//!
//! The body is the 57-bone rig posed by the whole-body IK, its solids the capsules of
//! [`crate::motion::proxies`] (a 16-inch stick held 28 cm from its tip; a ball at each knee).
//!
//! The kit's drums are solid cylinders: the head's disc (the kit file's radius) down to the
//! shell depth the exports draw. Cymbals are discs a stick may not pass through.

use crate::kit::{Kit, PieceKind};
use crate::midi::{NoteMap, Performance};
use crate::motion::body_ik::solve_motion_in;
use crate::motion::hands::HandModel;
use crate::motion::pipeline::{model_hands, perform_planned, MotionError};
use crate::motion::rig::{BodyPose, Rig, FOOT, HAND, HIPS, NECK, SPINE, UPPER_LEG};
use crate::motion::shells::{shells, Shell};
use crate::motion::track::ARKIT_NAMES;
use crate::motion::upper::library::Library;
use crate::motion::Motion;
use nalgebra::Vector3;
use serde::Serialize;

type V3 = Vector3<f32>;

use crate::motion::proxies::{Capsule, GRIP_TO_BUTT_M};
pub use crate::motion::proxies::{FOOT_R, FOREARM_R, HAND_R, KNEE_R, SHIN_R, STICK_R, THIGH_R, TORSO_R, UPPER_ARM_R};
/// The arm proxies' names, per side.
const ARM_PARTS: [[&str; 4]; 2] = [
    ["left upper arm", "left forearm", "left hand", "left stick"],
    ["right upper arm", "right forearm", "right hand", "right stick"],
];

/// A hand note as the measures need it: when, which kit piece, how loud, which hand.
#[derive(Debug, Clone, Copy)]
pub struct PlayedNote {
    pub time_s: f64,
    pub piece: usize,
    pub velocity: u8,
    pub hand: usize,
}

/// The figures of one take (or of several, merged with [`MotionQuality::merge`]).
#[derive(Debug, Clone, Default, Serialize)]
pub struct MotionQuality {
    pub frames: usize,
    /// Largest turn of any bone between consecutive frames, degrees, and where.
    pub max_turn_deg: f32,
    pub max_turn_at: String,
    /// Bone-frames turning more than 45 degrees, and by bone.
    pub turns_over_45: usize,
    pub turns_over_45_by_bone: std::collections::BTreeMap<String, usize>,
    /// Largest wrist travel between consecutive frames, m, where, and wrist-frames over 6 cm
    /// and over 10 cm (a pop across the kit).
    pub max_wrist_step_m: f32,
    pub max_wrist_step_at: String,
    pub wrist_steps_over_6cm: usize,
    pub wrist_steps_over_10cm: usize,
    /// Largest travel of a foot (ankle or toe) between consecutive frames, m, where, and
    /// foot-frames over 4 cm (a hi-hat foot following a CC4 step, a kick foot's blip).
    pub max_foot_step_m: f32,
    pub max_foot_step_at: String,
    pub foot_steps_over_4cm: usize,
    /// Deepest stick, hand or arm proxy inside the torso or a thigh, m, where, and frames
    /// with one deeper than 1 cm.
    pub deepest_in_body_m: f32,
    pub deepest_in_body_at: String,
    pub frames_in_body: usize,
    /// Frames with each pair (arm part in body part) deeper than 1 cm.
    pub frames_in_body_by_pair: std::collections::BTreeMap<String, usize>,
    /// Deepest stick, hand or arm proxy inside a drum, m, where, and frames deeper than 1 cm.
    pub deepest_arm_in_kit_m: f32,
    pub deepest_arm_in_kit_at: String,
    pub frames_arm_in_kit: usize,
    /// Frames with a stick through a cymbal (not a drum's hoop) by more than 1 cm, its
    /// proxy measured as against a drum.
    pub frames_stick_through_cymbal: usize,
    /// Deepest knee, shin or foot inside a drum, m, where, and frames with one inside.
    pub deepest_leg_in_kit_m: f32,
    pub deepest_leg_in_kit_at: String,
    pub frames_leg_in_kit: usize,
    /// Pearson correlation of the chest's facing (its forward axis' lateral component) with
    /// the hands' mean lateral position; None without movement in either.
    pub chest_follows_hands: Option<f32>,
    /// Median lift of the stick tip above the struck piece before ghost notes (velocity
    /// under 40) and accents (over 100), m, and their ratio.
    pub ghost_lift_m: Option<f32>,
    pub accent_lift_m: Option<f32>,
    pub ghost_over_accent: Option<f32>,
    /// Blinks per minute (the eyes' blink weight rising through 0.5).
    pub blinks_per_min: f32,
    #[serde(skip)]
    ghost_lifts: Vec<f32>,
    #[serde(skip)]
    accent_lifts: Vec<f32>,
    #[serde(skip)]
    blinks: usize,
    #[serde(skip)]
    seconds: f64,
}

/// How deep capsule `c` reaches into capsule `o` (negative: apart).
fn overlap(c: &Capsule, o: &Capsule) -> f32 {
    c.overlap(o)
}

/// A cymbal as a disc.
struct Disc {
    c: V3,
    n: V3,
    r: f32,
}

impl Disc {
    /// True when a stick (segment `a`-`b`, radius `r`) goes through the disc by more than
    /// `tolerance`, as a drum's shell is measured: the segment crosses the disc inside its
    /// radius and its shorter side reaches far enough past the plane that the stick's
    /// surface is over `tolerance` beyond it. A tip resting on a cymbal it strikes (its end
    /// on the plane) is not through it.
    fn crossed_by(&self, a: V3, b: V3, r: f32, tolerance: f32) -> bool {
        let (ha, hb) = ((a - self.c).dot(&self.n), (b - self.c).dot(&self.n));
        if ha * hb >= 0.0 || ha.abs().min(hb.abs()) + r <= tolerance {
            return false;
        }
        let p = a + (b - a) * (ha / (ha - hb));
        (p - self.c).norm() < self.r
    }
}

fn pearson(x: &[f32], y: &[f32]) -> Option<f32> {
    let n = x.len().min(y.len()) as f64;
    if n < 3.0 {
        return None;
    }
    let mx = x.iter().map(|&v| v as f64).sum::<f64>() / n;
    let my = y.iter().map(|&v| v as f64).sum::<f64>() / n;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for (&a, &b) in x.iter().zip(y) {
        let (a, b) = (a as f64 - mx, b as f64 - my);
        sxy += a * b;
        sxx += a * a;
        syy += b * b;
    }
    (sxx > 1e-12 && syy > 1e-12).then(|| (sxy / (sxx * syy).sqrt()) as f32)
}

fn median(v: &mut [f32]) -> Option<f32> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f32::total_cmp);
    Some(v[v.len() / 2])
}

/// How deep the deepest of `parts` reaches into any of `drums` (negative: its clearance),
/// kept in `best` (with its place, `at` of a description) when deeper.
fn into_drums(
    parts: &[Capsule],
    drums: &[Shell],
    best: &mut f32,
    place: &mut String,
    at: &impl Fn(&str) -> String,
) -> f32 {
    let mut worst = f32::NEG_INFINITY;
    for p in parts {
        for d in drums {
            let depth = d.depth_of(p.a, p.b, p.r);
            worst = worst.max(depth);
            set_max(best, place, depth, || at(&format!("{} in {}", p.name, d.id)));
        }
    }
    worst
}

fn set_max(best: &mut f32, at: &mut String, value: f32, place: impl FnOnce() -> String) {
    if value > *best {
        *best = value;
        *at = place();
    }
}

/// Measure `motion` (posed as `poses` on `rig`) on `kit`, with its hand `notes`.
pub fn measure(rig: &Rig, motion: &Motion, poses: &[BodyPose], kit: &Kit, notes: &[PlayedNote]) -> MotionQuality {
    let fps = motion.fps as f32;
    let mut q = MotionQuality {
        frames: poses.len(),
        seconds: poses.len() as f64 / motion.fps,
        deepest_in_body_m: f32::NEG_INFINITY,
        deepest_arm_in_kit_m: f32::NEG_INFINITY,
        deepest_leg_in_kit_m: f32::NEG_INFINITY,
        ..Default::default()
    };
    let drums = shells(kit);
    let discs: Vec<Disc> = kit
        .pieces
        .iter()
        .filter(|p| p.kind == PieceKind::Plate && !p.id.ends_with("_rim"))
        .map(|p| Disc { c: V3::from(p.position_m), n: V3::from(p.normal).normalize(), r: p.radius_m })
        .collect();
    let names: Vec<&str> = rig.bones.iter().map(|b| b.name.as_str()).collect();
    let blink = ARKIT_NAMES.iter().position(|n| *n == "eyeBlinkLeft");
    let (mut facing, mut lateral) = (Vec::with_capacity(poses.len()), Vec::with_capacity(poses.len()));
    let mut prev_world: Option<Vec<(V3, nalgebra::UnitQuaternion<f32>)>> = None;
    let mut tips: Vec<[V3; 2]> = Vec::with_capacity(poses.len());
    let mut was_blinking = false;
    for (f, (pose, frame)) in poses.iter().zip(&motion.frames).enumerate() {
        let w = rig.world(pose);
        let at = |what: &str| format!("{what} at frame {f} ({:.2} s)", f as f32 / fps);
        if f > 0 {
            let before = &poses[f - 1];
            for (b, (q1, q0)) in pose.local.iter().zip(&before.local).enumerate() {
                let deg = q1.angle_to(q0).to_degrees();
                if deg > 45.0 {
                    q.turns_over_45 += 1;
                    *q.turns_over_45_by_bone.entry(names[b].to_string()).or_default() += 1;
                }
                set_max(&mut q.max_turn_deg, &mut q.max_turn_at, deg, || at(names[b]));
            }
        }
        if let Some(pw) = &prev_world {
            for side in 0..2 {
                let step = (w[HAND[side]].0 - pw[HAND[side]].0).norm();
                q.wrist_steps_over_6cm += usize::from(step > 0.06);
                q.wrist_steps_over_10cm += usize::from(step > 0.10);
                let wrist = ["left wrist", "right wrist"][side];
                set_max(&mut q.max_wrist_step_m, &mut q.max_wrist_step_at, step, || at(wrist));
                // The ankle and the toe (the bone after the foot).
                let step =
                    [FOOT[side], FOOT[side] + 1].iter().map(|&b| (w[b].0 - pw[b].0).norm()).fold(0.0f32, f32::max);
                q.foot_steps_over_4cm += usize::from(step > 0.04);
                let foot = ["left foot", "right foot"][side];
                set_max(&mut q.max_foot_step_m, &mut q.max_foot_step_at, step, || at(foot));
            }
        }
        // Proxies.
        let p = |i: usize| w[i].0;
        let torso = Capsule { a: p(HIPS), b: p(NECK[0]), r: TORSO_R, name: "torso" };
        let legs: Vec<[Capsule; 3]> = (0..2)
            .map(|s| {
                let (hip, knee, ankle, toe) = (p(UPPER_LEG[s]), p(UPPER_LEG[s] + 1), p(FOOT[s]), p(FOOT[s] + 1));
                [
                    Capsule { a: hip, b: knee, r: THIGH_R, name: ["left thigh", "right thigh"][s] },
                    Capsule { a: knee, b: ankle, r: SHIN_R, name: ["left shin", "right shin"][s] },
                    Capsule { a: ankle, b: toe, r: FOOT_R, name: ["left foot", "right foot"][s] },
                ]
            })
            .collect();
        let mut arms: Vec<Capsule> = Vec::with_capacity(8);
        let mut frame_tips = [V3::zeros(); 2];
        for s in 0..2 {
            let (ball, elbow, wrist) = (p(HAND[s] - 2), p(HAND[s] - 1), p(HAND[s]));
            // The hand as posed (the IK turns a stick in the body about its tip).
            let (hand_at, hand_rot) = w[HAND[s]];
            let grip = &crate::motion::track::Pose {
                pos: (hand_at + hand_rot * rig.grip_local).into(),
                rot: [hand_rot.w, hand_rot.i, hand_rot.j, hand_rot.k],
            };
            let tip = V3::from(grip.stick_tip());
            let butt = V3::from(grip.apply([0.0, -GRIP_TO_BUTT_M, 0.0]));
            let g = V3::from(grip.pos);
            frame_tips[s] = tip;
            let name = ARM_PARTS[s];
            arms.push(Capsule { a: ball, b: elbow, r: UPPER_ARM_R, name: name[0] });
            arms.push(Capsule { a: elbow, b: wrist, r: FOREARM_R, name: name[1] });
            arms.push(Capsule { a: wrist, b: g, r: HAND_R, name: name[2] });
            arms.push(Capsule { a: butt, b: tip, r: STICK_R, name: name[3] });
        }
        tips.push(frame_tips);
        // Arms against the body: the upper arm hangs from the torso, so only the thighs.
        let mut worst_body = f32::NEG_INFINITY;
        for a in &arms {
            let torso_too = !a.name.ends_with("upper arm");
            for o in legs.iter().map(|l| &l[0]).chain(torso_too.then_some(&torso)) {
                let d = overlap(a, o);
                worst_body = worst_body.max(d);
                if d > 0.01 {
                    *q.frames_in_body_by_pair.entry(format!("{} in {}", a.name, o.name)).or_default() += 1;
                }
                set_max(&mut q.deepest_in_body_m, &mut q.deepest_in_body_at, d, || {
                    at(&format!("{} in {}", a.name, o.name))
                });
            }
        }
        if worst_body > 0.01 {
            q.frames_in_body += 1;
        }
        // Arms, hands and sticks against the drums; sticks through cymbals.
        let worst_kit = into_drums(&arms, &drums, &mut q.deepest_arm_in_kit_m, &mut q.deepest_arm_in_kit_at, &at);
        if worst_kit > 0.01 {
            q.frames_arm_in_kit += 1;
        }
        if arms
            .iter()
            .filter(|a| a.name.ends_with("stick"))
            .any(|a| discs.iter().any(|d| d.crossed_by(a.a, a.b, a.r, 0.01)))
        {
            q.frames_stick_through_cymbal += 1;
        }
        // Knees, shins and feet against the drums.
        let below: Vec<Capsule> = legs
            .iter()
            .enumerate()
            .flat_map(|(s, l)| {
                let knee = Capsule { a: l[0].b, b: l[0].b, r: KNEE_R, name: ["left knee", "right knee"][s] };
                [knee, l[1], l[2]]
            })
            .collect();
        let worst_leg = into_drums(&below, &drums, &mut q.deepest_leg_in_kit_m, &mut q.deepest_leg_in_kit_at, &at);
        if worst_leg > 0.0 {
            q.frames_leg_in_kit += 1;
        }
        // The chest's facing and the hands' lateral place.
        let forward = w[SPINE[2]].1 * V3::y();
        facing.push(forward.x);
        lateral.push(0.5 * (w[HAND[0]].0.x + w[HAND[1]].0.x));
        // Blinks.
        if let Some(b) = blink {
            let blinking = frame.face.get(b).is_some_and(|&v| v > 0.5);
            if blinking && !was_blinking {
                q.blinks += 1;
            }
            was_blinking = blinking;
        }
        prev_world = Some(w);
    }
    q.chest_follows_hands = pearson(&facing, &lateral);
    // The lift before each note: the tip's highest point above the struck piece since the
    // hand's previous note (at most 0.5 s back).
    let mut last = [f64::NEG_INFINITY; 2];
    for n in notes {
        let Some(piece) = kit.pieces.get(n.piece) else { continue };
        let (c, nrm) = (V3::from(piece.position_m), V3::from(piece.normal).normalize());
        let from = last[n.hand].max(n.time_s - 0.5);
        last[n.hand] = n.time_s;
        let (f0, f1) = ((from * motion.fps).ceil() as usize, (n.time_s * motion.fps).round() as usize);
        let lift = (f0..=f1.min(tips.len().saturating_sub(1)))
            .map(|f| (tips[f][n.hand] - c).dot(&nrm))
            .fold(f32::NEG_INFINITY, f32::max);
        if !lift.is_finite() {
            continue;
        }
        if n.velocity < 40 {
            q.ghost_lifts.push(lift);
        } else if n.velocity > 100 {
            q.accent_lifts.push(lift);
        }
    }
    q.finish();
    q
}

/// A take as the motion stage plays it on `kit` (the hand model's prediction, strike
/// planning, retrieval, feet; the rig posed with the knees clear of the drums), measured;
/// and whether it plays a tom (the chest's correlation is judged on those).
pub fn measure_take(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
    model: &HandModel,
    library: &Library,
    rig: &Rig,
) -> Result<(MotionQuality, bool), MotionError> {
    let planned = perform_planned(perf, map, kit, &model_hands(model, perf, map), library)?;
    let notes: Vec<PlayedNote> = planned
        .notes
        .iter()
        .zip(&planned.report.hands)
        .filter_map(|(n, h)| h.map(|hand| PlayedNote { time_s: n.time_s, piece: n.piece, velocity: n.velocity, hand }))
        .collect();
    let poses = solve_motion_in(rig, &planned.motion, &shells(kit));
    let toms = notes.iter().any(|n| kit.pieces[n.piece].id.contains("tom"));
    Ok((measure(rig, &planned.motion, &poses, kit, &notes), toms))
}

impl MotionQuality {
    fn finish(&mut self) {
        self.ghost_lift_m = median(&mut self.ghost_lifts.clone());
        self.accent_lift_m = median(&mut self.accent_lifts.clone());
        self.ghost_over_accent = self.ghost_lift_m.zip(self.accent_lift_m).map(|(g, a)| g / a.max(1e-6));
        self.blinks_per_min = if self.seconds > 0.0 { (self.blinks as f64 * 60.0 / self.seconds) as f32 } else { 0.0 };
    }

    /// Fold `other` (another take) into these figures: maxima, counts, pooled medians and
    /// rates; the chest correlation is kept per take by the caller.
    pub fn merge(&mut self, other: &MotionQuality) {
        self.frames += other.frames;
        self.seconds += other.seconds;
        self.turns_over_45 += other.turns_over_45;
        for (bone, n) in &other.turns_over_45_by_bone {
            *self.turns_over_45_by_bone.entry(bone.clone()).or_default() += n;
        }
        self.wrist_steps_over_6cm += other.wrist_steps_over_6cm;
        self.wrist_steps_over_10cm += other.wrist_steps_over_10cm;
        self.foot_steps_over_4cm += other.foot_steps_over_4cm;
        self.frames_in_body += other.frames_in_body;
        for (pair, n) in &other.frames_in_body_by_pair {
            *self.frames_in_body_by_pair.entry(pair.clone()).or_default() += n;
        }
        self.frames_arm_in_kit += other.frames_arm_in_kit;
        self.frames_stick_through_cymbal += other.frames_stick_through_cymbal;
        self.frames_leg_in_kit += other.frames_leg_in_kit;
        self.blinks += other.blinks;
        let take = |mine: &mut f32, at: &mut String, theirs: f32, their_at: &String| {
            if theirs > *mine || at.is_empty() {
                *mine = theirs;
                *at = their_at.clone();
            }
        };
        take(&mut self.max_turn_deg, &mut self.max_turn_at, other.max_turn_deg, &other.max_turn_at);
        take(
            &mut self.deepest_in_body_m,
            &mut self.deepest_in_body_at,
            other.deepest_in_body_m,
            &other.deepest_in_body_at,
        );
        take(
            &mut self.deepest_arm_in_kit_m,
            &mut self.deepest_arm_in_kit_at,
            other.deepest_arm_in_kit_m,
            &other.deepest_arm_in_kit_at,
        );
        take(
            &mut self.deepest_leg_in_kit_m,
            &mut self.deepest_leg_in_kit_at,
            other.deepest_leg_in_kit_m,
            &other.deepest_leg_in_kit_at,
        );
        take(&mut self.max_wrist_step_m, &mut self.max_wrist_step_at, other.max_wrist_step_m, &other.max_wrist_step_at);
        take(&mut self.max_foot_step_m, &mut self.max_foot_step_at, other.max_foot_step_m, &other.max_foot_step_at);
        self.ghost_lifts.extend_from_slice(&other.ghost_lifts);
        self.accent_lifts.extend_from_slice(&other.accent_lifts);
        self.finish();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stick_passes_through_a_cymbal_only_across_its_disc_and_past_the_tolerance() {
        let d = Disc { c: V3::zeros(), n: V3::z(), r: 0.2 };
        let through = |a: V3, b: V3| d.crossed_by(a, b, 0.008, 0.01);
        assert!(through(V3::new(0.1, 0.0, 0.05), V3::new(0.1, 0.0, -0.05)));
        // Beside the edge, or lying above it.
        assert!(!through(V3::new(0.3, 0.0, 0.05), V3::new(0.3, 0.0, -0.05)));
        assert!(!through(V3::new(-0.1, 0.0, 0.01), V3::new(0.1, 0.0, 0.02)));
        // A tip on the cymbal it strikes, 1 mm under its plane: the stick's surface is 9 mm
        // past it, within the 1 cm a proxy may overlap; 3 mm under, it is through.
        let butt = V3::new(0.0, -0.3, 0.15);
        assert!(!through(butt, V3::new(0.1, 0.0, -0.001)));
        assert!(through(butt, V3::new(0.1, 0.0, -0.003)));
    }

    #[test]
    fn pearson_is_one_for_a_line_and_none_for_a_constant() {
        let x = [0.0, 1.0, 2.0, 3.0];
        assert!((pearson(&x, &[1.0, 3.0, 5.0, 7.0]).unwrap() - 1.0).abs() < 1e-6);
        assert!((pearson(&x, &[7.0, 5.0, 3.0, 1.0]).unwrap() + 1.0).abs() < 1e-6);
        assert_eq!(pearson(&x, &[2.0; 4]), None);
    }
}
