//! The hand model's poses smoothed before strikes are planned on them: its output now and
//! then moves a hand 10-17 cm in one 60 fps frame (6-10 m/s at the grip), which the
//! animation showed as a wrist popping across the kit.

use crate::motion::Pose;

/// Standard deviation of the Gaussian the poses are smoothed with, frames.
pub const SMOOTH_SIGMA_FRAMES: f32 = 1.5;

/// `poses` smoothed in time by a Gaussian of `sigma` frames (positions averaged, rotations
/// averaged as sign-aligned quaternions and normalised); the ends use what lies inside.
pub fn smooth_hands(poses: &[[Pose; 2]], sigma: f32) -> Vec<[Pose; 2]> {
    let reach = (3.0 * sigma).ceil() as isize;
    let weights: Vec<f32> = (-reach..=reach).map(|k| (-0.5 * (k as f32 / sigma).powi(2)).exp()).collect();
    let n = poses.len() as isize;
    (0..n)
        .map(|f| {
            std::array::from_fn(|h| {
                let centre = poses[f as usize][h];
                let (mut pos, mut rot, mut total) = ([0.0f32; 3], [0.0f32; 4], 0.0f32);
                for (k, &w) in (-reach..=reach).zip(&weights) {
                    let g = f + k;
                    if g < 0 || g >= n {
                        continue;
                    }
                    let p = poses[g as usize][h];
                    let sign =
                        if p.rot.iter().zip(&centre.rot).map(|(a, b)| a * b).sum::<f32>() < 0.0 { -1.0 } else { 1.0 };
                    for i in 0..3 {
                        pos[i] += w * p.pos[i];
                    }
                    for i in 0..4 {
                        rot[i] += w * sign * p.rot[i];
                    }
                    total += w;
                }
                let norm = rot.iter().map(|v| v * v).sum::<f32>().sqrt();
                if !(total > 0.0 && norm > 1e-6 && norm.is_finite() && pos.iter().all(|v| v.is_finite())) {
                    return centre;
                }
                Pose { pos: pos.map(|v| v / total), rot: rot.map(|v| v / norm) }
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_one_frame_jump_is_spread_and_a_steady_hand_is_left_alone() {
        let at = |x: f32| [Pose { pos: [x, 0.0, 1.0], rot: [1.0, 0.0, 0.0, 0.0] }; 2];
        let steady = vec![at(0.1); 20];
        for (a, b) in smooth_hands(&steady, SMOOTH_SIGMA_FRAMES).iter().zip(&steady) {
            assert!((a[1].pos[0] - b[1].pos[0]).abs() < 1e-6 && a[1].rot == b[1].rot);
        }
        // A 15 cm jump between frames 9 and 10.
        let jump: Vec<_> = (0..20).map(|f| at(if f < 10 { 0.0 } else { 0.15 })).collect();
        let s = smooth_hands(&jump, SMOOTH_SIGMA_FRAMES);
        let steps: Vec<f32> = s.windows(2).map(|w| (w[1][0].pos[0] - w[0][0].pos[0]).abs()).collect();
        let largest = steps.iter().copied().fold(0.0, f32::max);
        assert!(largest < 0.06, "largest step {largest}");
        assert!((s[0][0].pos[0]).abs() < 1e-6 && (s[19][0].pos[0] - 0.15).abs() < 1e-6);
    }
}
