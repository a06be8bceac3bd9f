//! A hand's grip moved out of the body, the stick turning about its tip (issue 16).
//!
//! The hand model and strike planning place the stick tip; the grip follows from the
//! predicted stick direction, and on a kit laid out tighter than the mocap's it lands in the
//! drummer: a crossed right hand on the hi-hat 14 cm in front of the spine with the stick's
//! butt in the chest, a snare hand 3 cm over the head, resting in the thigh. [`clear_of`]
//! turns the stick about its tip, so every strike stays where it was planned, until the
//! hand (wrist to grip), and the stick (butt to tip) are `clearance` off each body capsule:
//! the crossed hand moves forward, the snare hand rises and its stick tilts down to the head
//! as a drummer's does. [`clear_of_with`] clears the forearm too, given where the elbow
//! lands for a wrist. The stick turns at most [`MAX_TURN_RAD`].

use super::proxies::{closest_points, Capsule, FOREARM_R, GRIP_TO_BUTT_M, HAND_R, STICK_R};
use super::track::{Pose, STICK_TIP_LOCAL};
use nalgebra::{UnitQuaternion, Vector3};

type V3 = Vector3<f32>;

/// Projection rounds: each moves the grip out of what it is in, then back onto the sphere
/// about the tip.
const ROUNDS: usize = 12;
/// How far ahead of the grip the stick is kept out of the body, m: the rest, toward the
/// tip, is where the strike is and hardly moves when the stick turns about it.
const STICK_AHEAD_M: f32 = 0.1;
/// The most the stick turns about its tip to clear the body, radians (30 degrees): with
/// the forearm pushing too, a hand deep in the body swung round toward the far side of its
/// tip (bone turns over 45 degrees between frames, 9 -> 199 on the rearranged kit; 39 at
/// 45 degrees, 8 at 30).
const MAX_TURN_RAD: f32 = std::f32::consts::FRAC_PI_6;

/// `hand` (grip position and rotation, the stick along local +y, the wrist at `-grip_local`
/// from the grip in the hand's frame) turned about its stick tip so that hand and stick stay
/// `clearance` off every capsule of `body`. A hand already clear comes back unchanged; one
/// that cannot clear (its tip inside the body) comes back as near as [`ROUNDS`] bring it.
pub fn clear_of(hand: &Pose, grip_local: V3, body: &[Capsule], clearance: f32) -> Pose {
    clear_of_with(hand, grip_local, body, clearance, None)
}

/// [`clear_of`], the forearm too when `elbow` says where the elbow lands for a wrist: a push
/// on a point of the forearm moves the grip by it over the point's share of the way from
/// elbow to wrist (at most three times).
pub fn clear_of_with(
    hand: &Pose,
    grip_local: V3,
    body: &[Capsule],
    clearance: f32,
    elbow: Option<&dyn Fn(V3) -> V3>,
) -> Pose {
    let q0 = hand.rotation();
    let g0 = V3::from(hand.pos);
    let tip = V3::from(hand.stick_tip());
    let length = V3::from(STICK_TIP_LOCAL).norm();
    let axis0 = q0 * V3::y();
    if !(g0.iter().chain(tip.iter()).all(|v| v.is_finite())) || body.is_empty() {
        return *hand;
    }
    let turned = |g: V3| {
        let axis = (tip - g) / length;
        UnitQuaternion::rotation_between(&axis0, &axis).unwrap_or_else(UnitQuaternion::identity) * q0
    };
    let mut g = g0;
    let mut moved_ever = false;
    for _ in 0..ROUNDS {
        let q = turned(g);
        let axis = q * V3::y();
        let wrist = g - q * grip_local;
        let butt = g - axis * GRIP_TO_BUTT_M;
        let mut push = V3::zeros();
        for c in body {
            // The hand: a push on it moves the grip as much.
            let (p, o) = closest_points(wrist, g, c.a, c.b);
            push += out_of(p, o, c.r + HAND_R + clearance, c);
            // The stick: a push at a point turns the stick about the tip.
            let (p, o) = closest_points(butt, g + axis * STICK_AHEAD_M, c.a, c.b);
            let lever = length / (p - tip).norm().max(length - STICK_AHEAD_M);
            push += out_of(p, o, c.r + STICK_R + clearance, c) * lever;
            if let Some(elbow) = elbow {
                let e = elbow(wrist);
                let (p, o) = closest_points(e, wrist, c.a, c.b);
                let share = ((p - e).norm() / (wrist - e).norm().max(1e-6)).max(1.0);
                push += out_of(p, o, c.r + FOREARM_R + clearance, c) / share;
            }
        }
        if push.norm_squared() < 1e-10 {
            break;
        }
        let moved = g + push - tip;
        if moved.norm() < 1e-6 {
            break;
        }
        g = tip + within_turn(moved / moved.norm(), (g0 - tip) / length, MAX_TURN_RAD) * length;
        moved_ever = true;
    }
    if !moved_ever {
        return *hand;
    }
    turned_to(hand, g)
}

/// The most an animated grip moves between two frames when its stick can turn about its tip
/// instead, m (4 cm, 2.4 m/s at 60 fps). Over 21 validation takes the planned grips moved
/// the wrists over 6 cm in a frame 159 times (353 on the rearranged kit) and left arms in
/// the body on 372 (1,140) frames; with this 108 (192) and 358 (1,102). 3 cm did more for
/// the body (310 frames) but the wrists jumped over 10 cm 11 times on the rearranged kit
/// where a blocked turn let a lagging grip catch up (7 before).
pub const MAX_GRIP_STEP_M: f32 = 0.04;

/// Each hand's grip moved at most `max_step` from the frame before, its stick turned about
/// its tip toward that (at most [`MAX_TURN_RAD`] from its plan) unless the turned stick
/// would be `blocked` where the planned one is not: the tip stays where it was planned.
pub fn slew_grips(hands: &mut [[Pose; 2]], max_step: f32, blocked: &dyn Fn(&Pose) -> bool) {
    let length = V3::from(STICK_TIP_LOCAL).norm();
    for side in 0..2 {
        let mut before: Option<V3> = None;
        for frame in hands.iter_mut() {
            let h = frame[side];
            let g = V3::from(h.pos);
            if let Some(p) = before {
                let d = g - p;
                if d.norm() > max_step && d.iter().all(|v| v.is_finite()) {
                    let want = p + d * (max_step / d.norm());
                    let tip = V3::from(h.stick_tip());
                    let planned = (tip - g).normalize();
                    let axis = within_turn((tip - want).normalize(), planned, MAX_TURN_RAD);
                    let turn = |share: f32| {
                        let angle = planned.dot(&axis).clamp(-1.0, 1.0).acos();
                        turned_to(&h, tip - within_turn(axis, planned, share * angle) * length)
                    };
                    frame[side] = if !blocked(&turn(1.0)) || blocked(&h) {
                        turn(1.0)
                    } else {
                        // The largest share of the turn that is not blocked.
                        let (mut lo, mut hi) = (0.0f32, 1.0f32);
                        for _ in 0..8 {
                            let mid = 0.5 * (lo + hi);
                            if blocked(&turn(mid)) {
                                hi = mid;
                            } else {
                                lo = mid;
                            }
                        }
                        if lo > 0.0 {
                            turn(lo)
                        } else {
                            h
                        }
                    };
                }
            }
            before = Some(V3::from(frame[side].pos));
        }
    }
}

/// `dir` (unit), brought back to at most `max` radians from `from` (unit) about the axis
/// between them.
fn within_turn(dir: V3, from: V3, max: f32) -> V3 {
    let angle = from.dot(&dir).clamp(-1.0, 1.0).acos();
    if angle <= max {
        return dir;
    }
    let axis = from.cross(&dir);
    match nalgebra::Unit::try_new(axis, 1e-6) {
        Some(axis) => UnitQuaternion::from_axis_angle(&axis, max) * from,
        None => from,
    }
}

/// `hand` turned about its stick tip so that its grip lies toward `g` (at the stick's length
/// from the tip, on the line from the tip through `g`).
pub fn turned_to(hand: &Pose, g: V3) -> Pose {
    let q0 = hand.rotation();
    let tip = V3::from(hand.stick_tip());
    let length = V3::from(STICK_TIP_LOCAL).norm();
    let to_tip = tip - g;
    if to_tip.norm().is_nan() || to_tip.norm() <= 1e-6 {
        return *hand;
    }
    let axis = to_tip.normalize();
    let q = UnitQuaternion::rotation_between(&(q0 * V3::y()), &axis).unwrap_or_else(UnitQuaternion::identity) * q0;
    Pose { pos: (tip - axis * length).into(), rot: [q.w, q.i, q.j, q.k] }
}

/// How far point `p` must move, away from `o` (its nearest point on `c`'s axis), to lie
/// `need` from it; zero when it already does.
fn out_of(p: V3, o: V3, need: f32, c: &Capsule) -> V3 {
    let d = p - o;
    let dist = d.norm();
    if dist >= need {
        return V3::zeros();
    }
    // On the axis itself: out horizontally, across the capsule.
    let n = if dist > 1e-6 {
        d / dist
    } else {
        let across = (c.b - c.a).cross(&V3::z());
        if across.norm() > 1e-6 {
            across.normalize()
        } else {
            V3::y()
        }
    };
    n * (need - dist)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn torso() -> Capsule {
        Capsule { a: V3::new(0.0, -0.05, 0.61), b: V3::new(0.0, -0.04, 1.12), r: 0.12, name: "torso" }
    }

    fn thigh() -> Capsule {
        Capsule { a: V3::new(-0.1, -0.05, 0.6), b: V3::new(-0.2, 0.35, 0.55), r: 0.075, name: "thigh" }
    }

    /// A hand at `grip` whose stick points at `tip` (level roll).
    fn aiming(grip: V3, tip: V3) -> Pose {
        let axis = (tip - grip).normalize();
        let q = UnitQuaternion::rotation_between(&V3::y(), &axis).unwrap();
        let g = tip - axis * 0.28;
        Pose { pos: g.into(), rot: [q.w, q.i, q.j, q.k] }
    }

    fn depth(hand: &Pose, grip_local: V3, c: &Capsule) -> f32 {
        let q = hand.rotation();
        let g = V3::from(hand.pos);
        let hand_c = Capsule { a: g - q * grip_local, b: g, r: HAND_R, name: "hand" };
        let stick =
            Capsule { a: g - q * V3::y() * GRIP_TO_BUTT_M, b: V3::from(hand.stick_tip()), r: STICK_R, name: "stick" };
        hand_c.overlap(c).max(stick.overlap(c))
    }

    #[test]
    fn a_grip_swung_about_its_tip_moves_at_most_the_step_keeps_its_tip_and_catches_up() {
        // The tip held on a drum while the planned grip swings 7 cm a frame for three frames
        // (the stick turned 43 degrees), then stays.
        let tip = V3::new(0.0, 0.4, 0.7);
        let planned: Vec<[Pose; 2]> = (0..30)
            .map(|f| {
                let a = (f.clamp(5, 8) - 5) as f32 * 0.25;
                let from = tip + V3::new(-0.28 * a.cos(), -0.28 * a.sin(), 0.1);
                [aiming(from, tip), aiming(V3::new(0.3, 0.1, 0.9), V3::new(0.3, 0.4, 0.7))]
            })
            .collect();
        let grip = |h: &Pose| V3::from(h.pos);
        assert!((grip(&planned[6][0]) - grip(&planned[5][0])).norm() > 0.06);
        let mut hands = planned.clone();
        slew_grips(&mut hands, MAX_GRIP_STEP_M, &|_| false);
        for f in 1..hands.len() {
            let step = (grip(&hands[f][0]) - grip(&hands[f - 1][0])).norm();
            // Brought back onto the sphere about the tip, the step may grow a little.
            assert!(step <= 1.05 * MAX_GRIP_STEP_M, "frame {f}: {step} m");
            assert!((V3::from(hands[f][0].stick_tip()) - tip).norm() < 1e-4, "frame {f}: the tip moved");
            assert_eq!(hands[f][1], planned[f][1], "frame {f}: the other hand");
        }
        assert!(grip(&hands[7][0]) != grip(&planned[7][0]), "no lag");
        assert!((grip(&hands[29][0]) - grip(&planned[29][0])).norm() < 1e-3, "never caught up");
        // A stick that would be blocked lagging behind its plan (its grip further back than
        // the plan's at frame 6) turns only as far as it is not.
        let blocked = |h: &Pose| h.pos[0] < -0.2735;
        let mut hands = planned.clone();
        slew_grips(&mut hands, MAX_GRIP_STEP_M, &blocked);
        for (f, (h, p)) in hands.iter().zip(&planned).enumerate() {
            assert!(!blocked(&h[0]) || blocked(&p[0]), "frame {f}: {:?}", h[0].pos);
            assert!((V3::from(h[0].stick_tip()) - tip).norm() < 1e-4, "frame {f}: the tip moved");
        }
        assert!(grip(&hands[6][0]) != grip(&planned[6][0]), "frame 6 turned not at all");
    }

    #[test]
    fn a_crossed_hand_in_the_chest_moves_out_and_keeps_its_tip() {
        let grip_local = V3::new(0.0, 0.0, -0.066);
        // The right hand on the hi-hat's near edge, 14 cm in front of the spine.
        let hand = aiming(V3::new(-0.06, 0.10, 1.0), V3::new(-0.29, 0.25, 1.0));
        let body = [torso(), thigh()];
        assert!(depth(&hand, grip_local, &body[0]) > 0.03, "the test hand starts in the chest");
        let cleared = clear_of(&hand, grip_local, &body, 0.01);
        let tip_moved = (V3::from(cleared.stick_tip()) - V3::from(hand.stick_tip())).norm();
        assert!(tip_moved < 1e-4, "the tip moved {tip_moved} m");
        for c in &body {
            let d = depth(&cleared, grip_local, c);
            assert!(d <= -0.009, "{}: {d} m", c.name);
        }
    }

    #[test]
    fn a_snare_hand_on_the_thigh_rises_and_its_stick_tilts_down() {
        let grip_local = V3::new(0.0, 0.0, -0.066);
        let hand = aiming(V3::new(-0.22, 0.12, 0.65), V3::new(-0.12, 0.38, 0.625));
        let cleared = clear_of(&hand, grip_local, &[torso(), thigh()], 0.01);
        assert!(cleared.pos[2] > hand.pos[2] + 0.03, "the grip stays at {} m", cleared.pos[2]);
        let down = |h: &Pose| -(h.rotation() * V3::y()).z;
        assert!(down(&cleared) > down(&hand) + 0.1, "the stick tilts {} (was {})", down(&cleared), down(&hand));
        let d = depth(&cleared, grip_local, &thigh());
        // Clear, bar the stick's front by the head, which the strike places.
        assert!(d <= -0.005, "{d} m into the thigh, grip {:?}", cleared.pos);
        assert!((V3::from(cleared.stick_tip()) - V3::from(hand.stick_tip())).norm() < 1e-4);
    }

    #[test]
    fn a_forearm_on_the_thigh_lifts_the_grip_when_the_elbow_is_known() {
        let grip_local = V3::new(0.0, 0.0, -0.066);
        // A left hand over the snare's near edge, its forearm sloping up to it from an elbow
        // low by the hip, over the thigh (the forearm moves with the wrist).
        let hand = aiming(V3::new(-0.2, 0.12, 0.72), V3::new(-0.12, 0.38, 0.64));
        let elbow = |wrist: V3| wrist + V3::new(0.03, -0.18, -0.14);
        let forearm = |h: &Pose| {
            let wrist = V3::from(h.pos) - h.rotation() * grip_local;
            Capsule { a: elbow(wrist), b: wrist, r: FOREARM_R, name: "forearm" }.overlap(&thigh())
        };
        assert!(forearm(&hand) > 0.0, "the test forearm starts in the thigh");
        assert_eq!(clear_of(&hand, grip_local, &[thigh()], 0.01), hand, "the hand alone is clear");
        let cleared = clear_of_with(&hand, grip_local, &[thigh()], 0.01, Some(&elbow));
        assert!(forearm(&cleared) < forearm(&hand) - 0.01, "{} m -> {} m", forearm(&hand), forearm(&cleared));
        assert!((V3::from(cleared.stick_tip()) - V3::from(hand.stick_tip())).norm() < 1e-4);
    }

    #[test]
    fn a_stick_turns_at_most_thirty_degrees_about_its_tip() {
        let grip_local = V3::new(0.0, 0.0, -0.066);
        // A grip deep in the chest, its stick pointing straight at the spine's far side.
        let hand = aiming(V3::new(0.0, -0.02, 0.9), V3::new(0.0, 0.26, 0.9));
        let cleared = clear_of(&hand, grip_local, &[torso()], 0.01);
        let axis = |h: &Pose| h.rotation() * V3::y();
        let turned = axis(&hand).dot(&axis(&cleared)).clamp(-1.0, 1.0).acos().to_degrees();
        assert!(turned > 1.0 && turned <= 30.01, "{turned} degrees");
    }

    #[test]
    fn a_hand_clear_of_the_body_is_left_alone() {
        let hand = aiming(V3::new(0.1, 0.3, 0.9), V3::new(0.0, 0.55, 0.8));
        let cleared = clear_of(&hand, V3::new(0.0, 0.0, -0.066), &[torso(), thigh()], 0.01);
        assert_eq!(cleared, hand);
    }
}
