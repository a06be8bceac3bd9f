//! Sticks lifted out of the drums and off the cymbals they would rest under (issue 16).
//!
//! Between strokes the stick follows the hand model's prediction, which knows nothing of
//! this kit's cymbals: an idle left hand after a crash stroke (the next note 9 s later)
//! rested with its tip 2-16 mm under the crash's plane by the edge and its shaft through
//! the plate, on and off for seconds (96 of the 108 frames with a stick through a cymbal
//! over 21 validation takes). And on its way from one drum to another a tip may dip through
//! a head (a right hand 3-4.6 cm into the floor tom 0.14 s after striking it, on its way to
//! the snare). [`lift_clear`] raises such a stick along the plate's or head's normal until
//! its tip is [`CLEAR_M`] over the plane: the stick hovers over the cymbal's edge as a
//! resting hand does, and passes over the drum. The lift is eased in and out over
//! [`EASE_FRAMES`] either side of where it is needed, and held off the frames where the
//! hand strikes, so every strike stays where it was planned.

use super::proxies::{GRIP_TO_BUTT_M, STICK_R};
use super::shells::Shell;
use super::track::Pose;
use crate::kit::{Kit, PieceKind};
use nalgebra::Vector3;

type V3 = Vector3<f32>;

/// A tip deeper than this under a plate is playing what is below it and is left alone, m;
/// so is a stick deeper in a drum.
pub const DEPTH_M: f32 = 0.05;
/// How far a tip may be under a plane before it is lifted, m: with the stick's radius, the
/// 1 cm that `eval::motion_quality` allows (a strike's tip lies on the plane).
pub const TOLERANCE_M: f32 = 0.01 - STICK_R;
/// How far over the plate's plane a lifted tip's centre is, m: the stick's radius and 4 mm.
pub const CLEAR_M: f32 = STICK_R + 0.004;
/// A shaft crossing the plane this far outside the plate's edge still counts, m.
pub const EDGE_CLEARANCE_M: f32 = 0.01;
/// Frames over which a lift eases in and out, and away from a strike (0.1 s at 60 fps).
pub const EASE_FRAMES: usize = 6;

/// A cymbal as a disc: centre, unit normal (up, the struck side), radius.
#[derive(Debug, Clone, Copy)]
pub struct Plate {
    pub centre: V3,
    pub normal: V3,
    pub radius_m: f32,
}

/// The kit's cymbals (plates other than hoops).
pub fn plates(kit: &Kit) -> Vec<Plate> {
    kit.pieces
        .iter()
        .filter(|p| p.kind == PieceKind::Plate && !p.id.ends_with("_rim"))
        .map(|p| Plate { centre: V3::from(p.position_m), normal: V3::from(p.normal).normalize(), radius_m: p.radius_m })
        .collect()
}

/// A stick's tip and butt.
fn ends(hand: &Pose) -> (V3, V3) {
    (V3::from(hand.stick_tip()), V3::from(hand.pos) - hand.rotation() * V3::y() * GRIP_TO_BUTT_M)
}

/// Where `hand`'s stick, butt to tip, crosses `plate`'s plane: the tip's height over the
/// plane and the crossing's distance from the plate's axis; None when it does not cross.
fn crossing(hand: &Pose, plate: &Plate) -> Option<(f32, f32)> {
    let (tip, butt) = ends(hand);
    let (ht, hb) = ((tip - plate.centre).dot(&plate.normal), (butt - plate.centre).dot(&plate.normal));
    if ht * hb >= 0.0 {
        return None;
    }
    let d = tip + (butt - tip) * (ht / (ht - hb)) - plate.centre;
    Some((ht, (d - plate.normal * d.dot(&plate.normal)).norm()))
}

/// How far `hand`'s stick must rise along `plate`'s normal to clear it: its tip just under
/// the plane (over [`TOLERANCE_M`], within [`DEPTH_M`]), its butt over it, and the shaft
/// crossing the plane inside the edge (and [`EDGE_CLEARANCE_M`]); otherwise 0.
pub fn lift_needed(hand: &Pose, plate: &Plate) -> f32 {
    match crossing(hand, plate) {
        Some((ht, radial)) if (-DEPTH_M..-TOLERANCE_M).contains(&ht) && radial < plate.radius_m + EDGE_CLEARANCE_M => {
            CLEAR_M - ht
        }
        _ => 0.0,
    }
}

/// True when `hand`'s stick, butt to tip, crosses `plate`'s plane inside its edge (and
/// [`EDGE_CLEARANCE_M`]).
pub fn crosses(hand: &Pose, plate: &Plate) -> bool {
    crossing(hand, plate).is_some_and(|(_, radial)| radial < plate.radius_m + EDGE_CLEARANCE_M)
}

/// How far `hand`'s stick must rise along `drum`'s normal to come out of it: the most any
/// of nine points from butt to tip lies under the head (over [`TOLERANCE_M`], within
/// [`DEPTH_M`]) inside the shell's radius, to [`CLEAR_M`] over it; otherwise 0.
pub fn lift_out_of(hand: &Pose, drum: &Shell) -> f32 {
    let (tip, butt) = ends(hand);
    (0..=8)
        .map(|i| {
            let p = butt + (tip - butt) * (i as f32 / 8.0);
            let h = (p - drum.center).dot(&drum.normal);
            let radial = ((p - drum.center) - drum.normal * h).norm();
            if (-DEPTH_M..-TOLERANCE_M).contains(&h) && radial < drum.radius_m + STICK_R {
                CLEAR_M - h
            } else {
                0.0
            }
        })
        .fold(0.0, f32::max)
}

/// Minimum-jerk ease from 0 at `u` <= 0 to 1 at `u` >= 1.
fn ease(u: f32) -> f32 {
    let u = u.clamp(0.0, 1.0);
    u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)
}

/// Lift each hand's stick off the plates it rests under and out of the drums (see the
/// module's text). `strikes`: each hand's strike frames, where nothing moves.
pub fn lift_clear(hands: &mut [[Pose; 2]], plates: &[Plate], drums: &[Shell], strikes: [&[usize]; 2]) {
    let n = hands.len();
    for side in 0..2 {
        // How far each frame is from this hand's nearest strike, in frames.
        let mut from_strike = vec![usize::MAX; n];
        for &s in strikes[side].iter().filter(|&&s| s < n) {
            let lo = s.saturating_sub(EASE_FRAMES);
            for (f, d) in from_strike.iter_mut().enumerate().take((s + EASE_FRAMES + 1).min(n)).skip(lo) {
                *d = (*d).min(f.abs_diff(s));
            }
        }
        // Each solid's normal and the lift each frame needs along it.
        let needs: Vec<(V3, Vec<f32>)> = plates
            .iter()
            .map(|p| (p.normal, hands.iter().map(|h| lift_needed(&h[side], p)).collect::<Vec<f32>>()))
            .chain(drums.iter().map(|d| (d.normal, hands.iter().map(|h| lift_out_of(&h[side], d)).collect())))
            .filter(|(_, need)| need.iter().any(|&l| l > 0.0))
            .collect();
        for (normal, need) in needs {
            // Each frame takes the most any frame within EASE_FRAMES needs, eased by the
            // distance: at least its own need, and no step between frames larger than an
            // ease of the largest need over EASE_FRAMES.
            for f in 0..n {
                let lo = f.saturating_sub(EASE_FRAMES);
                let hi = (f + EASE_FRAMES + 1).min(n);
                let lift = (lo..hi)
                    .map(|g| need[g] * ease(1.0 - g.abs_diff(f) as f32 / (EASE_FRAMES + 1) as f32))
                    .fold(0.0f32, f32::max);
                let away = ease(from_strike[f] as f32 / EASE_FRAMES as f32);
                let lift = lift * away;
                if lift > 0.0 {
                    let p = &mut hands[f][side].pos;
                    for (k, v) in p.iter_mut().enumerate() {
                        *v += normal[k] * lift;
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    /// A stick along +x tilted down 30 degrees toward its tip, the tip at `tip`.
    fn stick_to(tip: [f32; 3]) -> Pose {
        let q = UnitQuaternion::from_axis_angle(&V3::z_axis(), -std::f32::consts::FRAC_PI_2)
            * UnitQuaternion::from_axis_angle(&V3::x_axis(), -std::f32::consts::FRAC_PI_6);
        let mut p = Pose { pos: [0.0; 3], rot: [q.w, q.i, q.j, q.k] };
        let t = p.stick_tip();
        p.pos = [tip[0] - t[0], tip[1] - t[1], tip[2] - t[2]];
        p
    }

    fn crash() -> Plate {
        Plate { centre: V3::new(0.0, 0.0, 1.0), normal: V3::z(), radius_m: 0.2 }
    }

    #[test]
    fn a_stick_resting_under_a_plates_edge_needs_lifting_and_one_beside_or_deep_under_does_not() {
        let p = crash();
        let under = stick_to([-0.15, 0.0, 0.995]);
        assert!(under.stick_tip()[2] < 1.0 && under.pos[2] > 1.0, "{:?}", under);
        assert!((lift_needed(&under, &p) - (CLEAR_M + 0.005)).abs() < 1e-4);
        // Its tip on the plane or over it: a strike, or a hover.
        assert_eq!(lift_needed(&stick_to([-0.15, 0.0, 1.0]), &p), 0.0);
        // Crossing the plane outside the edge.
        assert_eq!(lift_needed(&stick_to([-0.3, 0.0, 0.995]), &p), 0.0);
        // Playing a drum 30 cm under the plate.
        assert_eq!(lift_needed(&stick_to([-0.15, 0.0, 0.7]), &p), 0.0);
    }

    #[test]
    fn a_stick_dipping_through_a_drums_head_needs_lifting_out_and_a_strike_on_it_does_not() {
        let tom = Shell {
            id: "floor_tom".into(),
            center: V3::new(0.0, 0.0, 0.6),
            normal: V3::z(),
            radius_m: 0.2,
            depth_m: 0.4,
        };
        // The tip 3 cm under the head: up 3 cm and CLEAR_M.
        assert!((lift_out_of(&stick_to([0.05, 0.0, 0.57]), &tom) - (CLEAR_M + 0.03)).abs() < 1e-4);
        // On the head (a strike), or 1 mm under it.
        assert_eq!(lift_out_of(&stick_to([0.05, 0.0, 0.6]), &tom), 0.0);
        assert_eq!(lift_out_of(&stick_to([0.05, 0.0, 0.599]), &tom), 0.0);
        // Beside the drum at that height.
        assert_eq!(lift_out_of(&stick_to([0.35, 0.0, 0.57]), &tom), 0.0);
        // Lifted, it is out.
        let mut hands = vec![[stick_to([0.05, 0.0, 0.57]), stick_to([0.5, 0.0, 1.0])]; 20];
        lift_clear(&mut hands, &[], std::slice::from_ref(&tom), [&[], &[]]);
        assert!(hands.iter().all(|h| lift_out_of(&h[0], &tom) == 0.0
            && tom.depth_of(V3::from(h[0].stick_tip()), V3::from(h[0].pos), STICK_R) < 0.0));
    }

    #[test]
    fn a_resting_stick_is_lifted_clear_eased_in_and_out_and_no_strike_moves() {
        let p = crash();
        // 60 frames: a strike on the plate at frame 5, then the tip sags 8 mm under it
        // from frame 20 to 40, and a strike elsewhere at frame 50.
        let mut hands: Vec<[Pose; 2]> = (0..60)
            .map(|f| {
                let z = if (20..40).contains(&f) {
                    0.992
                } else if f == 5 {
                    1.0
                } else {
                    1.02
                };
                [stick_to([-0.15, 0.0, z]), stick_to([0.5, 0.0, 1.0])]
            })
            .collect();
        let before = hands.clone();
        lift_clear(&mut hands, &[p], &[], [&[5, 50], &[]]);
        for (f, (h, b)) in hands.iter().zip(&before).enumerate() {
            assert_eq!(lift_needed(&h[0], &p), 0.0, "frame {f}");
            assert_eq!(h[1], b[1], "the other hand, frame {f}");
        }
        assert_eq!(hands[5][0], before[5][0]);
        assert_eq!(hands[50][0], before[50][0]);
        let lifts: Vec<f32> = hands.iter().zip(&before).map(|(h, b)| h[0].pos[2] - b[0].pos[2]).collect();
        assert!(lifts[..14].iter().all(|&l| l == 0.0), "{lifts:?}");
        for w in lifts.windows(2) {
            assert!((w[1] - w[0]).abs() < 0.5 * (CLEAR_M + 0.008), "{lifts:?}");
        }
    }
}
