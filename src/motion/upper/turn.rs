//! The torso turned toward where the hands play: the retrieved chest and head, turned about
//! the vertical by the hands' mean lateral place (smoothed), as a drummer turns toward the
//! floor tom or the hi-hat. The retrieved clips know the notes but not this kit's layout:
//! their own turns are replaced (the chest's) or halved (the head's), their lean, tilt and
//! nods kept.

use super::library::UpperFrame;
use crate::motion::Pose;
use nalgebra::{UnitQuaternion, Vector3};

/// Chest turn per metre of the hands' mean lateral place right of the stool, radians (a
/// reach 30 cm to the right turns the chest 15 degrees).
pub const CHEST_TURN_PER_M: f32 = 0.87;
/// The head turns this much more than the chest (it looks toward the hands).
pub const HEAD_TURN_SCALE: f32 = 1.4;
/// How much of the retrieved chest's and head's own turns about the vertical are kept (their
/// lean and tilt are kept whole): the clip turned toward its own kit's pieces, and with half
/// of the chest's turn kept two of 18 takes with toms had a chest that did not follow the
/// hands (correlation 0.06 and 0.31). The head keeps half of its own look around.
pub const RETRIEVED_CHEST_TURN: f32 = 0.0;
pub const RETRIEVED_HEAD_TURN: f32 = 0.5;
/// Standard deviation of the smoothing of the hands' place, frames (a torso turns slower
/// than a stick).
pub const TURN_SIGMA_FRAMES: f32 = 9.0;

/// Turn `upper`'s chests and heads toward the hands of `hands` (left, right grips per
/// frame).
pub fn turn_toward_hands(upper: &mut [UpperFrame], hands: &[[Pose; 2]]) {
    let n = upper.len().min(hands.len());
    let lateral: Vec<f32> = (0..n).map(|f| 0.5 * (hands[f][0].pos[0] + hands[f][1].pos[0])).collect();
    let reach = (3.0 * TURN_SIGMA_FRAMES).ceil() as isize;
    for (f, u) in upper.iter_mut().enumerate().take(n) {
        let (mut sum, mut total) = (0.0f32, 0.0f32);
        for k in -reach..=reach {
            let g = f as isize + k;
            if g >= 0 && (g as usize) < n && lateral[g as usize].is_finite() {
                let w = (-0.5 * (k as f32 / TURN_SIGMA_FRAMES).powi(2)).exp();
                sum += w * lateral[g as usize];
                total += w;
            }
        }
        if total <= 0.0 {
            continue;
        }
        // Turning toward +x (the drummer's right) from facing +y is a negative turn about +z.
        let yaw = -CHEST_TURN_PER_M * (sum / total);
        u.chest = turned(&u.chest, yaw, RETRIEVED_CHEST_TURN);
        u.head = turned(&u.head, HEAD_TURN_SCALE * yaw, RETRIEVED_HEAD_TURN);
    }
}

/// `p` with its rotation turned by `yaw` about the vertical, its own turn about the vertical
/// scaled by `keep` (its position kept).
fn turned(p: &Pose, yaw: f32, keep: f32) -> Pose {
    let q = p.rotation();
    // Swing-twist about the world vertical: q = twist * swing.
    let n = (q.w * q.w + q.k * q.k).sqrt();
    let own = if n > 1e-6 { 2.0 * q.k.atan2(q.w) } else { 0.0 };
    let twist = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), own);
    let swing = twist.inverse() * q;
    let r = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), yaw + keep * own) * swing;
    Pose { pos: p.pos, rot: [r.w, r.i, r.j, r.k] }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hands_over_the_floor_tom_turn_the_chest_right_and_the_head_further() {
        let still = UpperFrame {
            chest: Pose::IDENTITY,
            head: Pose::IDENTITY,
            face: [0.0; crate::motion::track::ARKIT_NAMES.len()],
        };
        let mut upper = vec![still; 120];
        let right = |x: f32| [Pose { pos: [x, 0.4, 0.8], rot: Pose::IDENTITY.rot }; 2];
        let hands: Vec<[Pose; 2]> = (0..120).map(|f| right(if f < 60 { 0.0 } else { 0.3 })).collect();
        turn_toward_hands(&mut upper, &hands);
        let forward = |p: &Pose| p.rotation() * Vector3::y();
        // Hands centred: facing forward; over the right: the chest's forward swings right.
        assert!(forward(&upper[0].chest).x.abs() < 1e-3);
        let (chest, head) = (forward(&upper[119].chest), forward(&upper[119].head));
        assert!(chest.x > 0.2 && chest.x < 0.3, "{chest:?}");
        assert!(head.x > chest.x, "{head:?} {chest:?}");
        // Smoothly: no frame turns more than 2 degrees.
        for w in upper.windows(2) {
            assert!(w[0].chest.rotation().angle_to(&w[1].chest.rotation()).to_degrees() < 2.0);
        }
    }
}
