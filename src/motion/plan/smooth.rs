//! The hand model's poses smoothed where they jump before strikes are planned on them: its
//! output now and then moves a hand 10-17 cm in one 60 fps frame (6-10 m/s at the grip),
//! which the animation showed as a wrist popping across the kit. Only around such jumps: a
//! whole smoothed take also flattened the strokes, and the sticks dipped into the drums in
//! nine times the frames.

use crate::motion::Pose;

/// Standard deviation of the Gaussian the poses are smoothed with, frames. At 1.5 frames a
/// right hand's accent still whipped its grip 12-20 cm a frame and turned it 40-78 degrees
/// between two frames; at 3.5, on 21 validation takes, the hands' turns over 45 degrees
/// fell from 32 to 1 and wrist steps over 6 cm from 404 to 161 (arms in the body 418 ->
/// 451 frames).
pub const SMOOTH_SIGMA_FRAMES: f32 = 3.5;
/// A grip moving further than this between two frames is a jump, m.
pub const JUMP_M: f32 = 0.05;
/// Frames either side of a jump smoothed whole, and over which the smoothing fades out.
const WHOLE_FRAMES: usize = 2;
const FADE_FRAMES: usize = 3;

/// `poses` smoothed (as [`smooth_hands`]) around every jump of a hand's grip: whole within
/// [`WHOLE_FRAMES`] of it, fading to the poses themselves over [`FADE_FRAMES`] more.
pub fn smooth_jumps(poses: &[[Pose; 2]]) -> Vec<[Pose; 2]> {
    let smooth = smooth_hands(poses, SMOOTH_SIGMA_FRAMES);
    let mut out = poses.to_vec();
    for h in 0..2 {
        let mut weight = vec![0.0f32; poses.len()];
        for f in 1..poses.len() {
            let step: f32 = (0..3).map(|i| (poses[f][h].pos[i] - poses[f - 1][h].pos[i]).powi(2)).sum::<f32>().sqrt();
            if step <= JUMP_M {
                continue;
            }
            let reach = WHOLE_FRAMES + FADE_FRAMES;
            let (from, to) = (f.saturating_sub(reach), (f + reach).min(poses.len()));
            for (g, x) in weight.iter_mut().enumerate().take(to).skip(from) {
                let d = if g < f { f - 1 - g } else { g - f };
                let w =
                    if d < WHOLE_FRAMES { 1.0 } else { 1.0 - (d + 1 - WHOLE_FRAMES) as f32 / (FADE_FRAMES + 1) as f32 };
                *x = x.max(w);
            }
        }
        for (f, &w) in weight.iter().enumerate() {
            if w > 0.0 {
                out[f][h] = blend(&poses[f][h], &smooth[f][h], w);
            }
        }
    }
    out
}

/// `a` moved `w` of the way to `b` (positions lerped, rotations normalised-lerped).
fn blend(a: &Pose, b: &Pose, w: f32) -> Pose {
    let sign = if a.rot.iter().zip(&b.rot).map(|(x, y)| x * y).sum::<f32>() < 0.0 { -1.0 } else { 1.0 };
    let rot: [f32; 4] = std::array::from_fn(|i| a.rot[i] + (sign * b.rot[i] - a.rot[i]) * w);
    let n = rot.iter().map(|v| v * v).sum::<f32>().sqrt();
    Pose {
        pos: std::array::from_fn(|i| a.pos[i] + (b.pos[i] - a.pos[i]) * w),
        rot: if n > 1e-6 { rot.map(|v| v / n) } else { a.rot },
    }
}

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
                    for (acc, v) in pos.iter_mut().zip(p.pos) {
                        *acc += w * v;
                    }
                    for (acc, v) in rot.iter_mut().zip(p.rot) {
                        *acc += w * sign * v;
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
    fn only_the_frames_around_a_jump_are_smoothed() {
        let at = |x: f32| [Pose { pos: [x, 0.0, 1.0], rot: [1.0, 0.0, 0.0, 0.0] }; 2];
        // A hand moving 2 cm a frame, then jumping 15 cm between frames 20 and 21.
        let poses: Vec<_> = (0..40).map(|f| at(0.02 * f as f32 + if f > 20 { 0.15 } else { 0.0 })).collect();
        let s = smooth_jumps(&poses);
        let largest = s.windows(2).map(|w| (w[1][0].pos[0] - w[0][0].pos[0]).abs()).fold(0.0, f32::max);
        assert!(largest < 0.07, "largest step {largest}");
        assert_eq!(s[..12], poses[..12]);
        assert_eq!(s[30..], poses[30..]);
    }

    #[test]
    fn a_one_frame_jump_is_spread_and_a_steady_hand_is_left_alone() {
        let at = |x: f32| [Pose { pos: [x, 0.0, 1.0], rot: [1.0, 0.0, 0.0, 0.0] }; 2];
        let steady = vec![at(0.1); 20];
        for (a, b) in smooth_hands(&steady, SMOOTH_SIGMA_FRAMES).iter().zip(&steady) {
            assert!((a[1].pos[0] - b[1].pos[0]).abs() < 1e-6 && a[1].rot == b[1].rot);
        }
        // A 15 cm jump between frames 19 and 20.
        let jump: Vec<_> = (0..40).map(|f| at(if f < 20 { 0.0 } else { 0.15 })).collect();
        let s = smooth_hands(&jump, SMOOTH_SIGMA_FRAMES);
        let steps: Vec<f32> = s.windows(2).map(|w| (w[1][0].pos[0] - w[0][0].pos[0]).abs()).collect();
        let largest = steps.iter().copied().fold(0.0, f32::max);
        assert!(largest < 0.06, "largest step {largest}");
        assert!((s[0][0].pos[0]).abs() < 1e-6 && (s[39][0].pos[0] - 0.15).abs() < 1e-6);
    }
}
