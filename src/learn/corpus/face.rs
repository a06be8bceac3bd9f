//! Face: the 52 ARKit weights per frame ([`crate::motion::ARKIT_NAMES`] order).
//! - effort with loud, busy passages: brows down, lips pressed, a slight jaw clench forward;
//! - jaw a little open in fills (runs of drum notes);
//! - brows up on crashes (decaying over half a second);
//! - blinks every 2 to 6 s (seeded) and on accents (snare or crash at velocity >= 115, three in
//!   ten, not within 1.5 s of the last blink); a blink closes in 2 frames and opens in 4;
//! - eyes a little down (on the kit), turned toward the working side.

use super::upper::{smooth, Beat};
use super::{HandNote, PlannedNote, Rng, Role};
use crate::motion::{ARKIT_NAMES, FPS};

/// Weight profile of a blink, frame by frame.
/// Shortest time between two blinks, seconds.
const MIN_BLINK_GAP_S: f64 = 1.5;
const BLINK: [f32; 6] = [0.6, 1.0, 0.8, 0.5, 0.25, 0.08];

fn idx(name: &str) -> usize {
    ARKIT_NAMES.iter().position(|n| *n == name).unwrap_or(0)
}

/// Face weights for each frame.
pub fn face(planned: &[PlannedNote], notes: &[HandNote], _beat: &Beat, frames: usize, rng: &mut Rng) -> Vec<[f32; 52]> {
    let mut loud = vec![0f32; frames];
    let mut crash = vec![0f32; frames];
    let mut drums = vec![0f32; frames];
    let mut accents = Vec::new();
    for n in notes {
        let Some(f) = (n.frame < frames).then_some(n.frame) else { continue };
        let v = n.velocity as f32 / 127.0;
        loud[f] += v * v;
        if n.role == Role::Crash {
            crash[f] = crash[f].max(v);
        }
        if n.role.is_drum() {
            drums[f] += 1.0;
        }
        if n.velocity >= 115 && matches!(n.role, Role::Crash | Role::Snare) {
            accents.push(f);
        }
    }
    // Per-second rates over about a second.
    let effort: Vec<f32> = smooth(&loud, 0.5).iter().map(|x| (x * FPS as f32 / 8.0 - 0.15).clamp(0.0, 1.0)).collect();
    let fill: Vec<f32> = smooth(&drums, 0.25).iter().map(|x| (x * FPS as f32 / 6.0 - 0.4).clamp(0.0, 1.0)).collect();
    let mut brows_up = vec![0f32; frames];
    let decay = (-1.0 / (0.5 * FPS as f32)).exp();
    let mut level = 0f32;
    for f in 0..frames {
        level = (level * decay).max(crash[f]);
        brows_up[f] = level;
    }
    let side: Vec<f32> = {
        let mut x = vec![0f32; frames];
        let mut last = -0.15;
        let mut by_frame = planned.iter().peekable();
        for (f, v) in x.iter_mut().enumerate() {
            while let Some(n) = by_frame.next_if(|n| n.frame <= f) {
                last = n.point[0];
            }
            *v = last;
        }
        smooth(&x, 0.4)
    };
    let blinks = blink_starts(&accents, frames, rng);
    let mut blink = vec![0f32; frames];
    for &s in &blinks {
        for (k, w) in BLINK.iter().enumerate() {
            if let Some(x) = blink.get_mut(s + k) {
                *x = x.max(*w);
            }
        }
    }
    let i = |n| idx(n);
    (0..frames)
        .map(|f| {
            let mut w = [0f32; 52];
            let e = effort[f];
            w[i("browDownLeft")] = 0.55 * e;
            w[i("browDownRight")] = 0.55 * e;
            w[i("mouthPressLeft")] = 0.5 * e;
            w[i("mouthPressRight")] = 0.5 * e;
            w[i("jawForward")] = 0.12 * e;
            w[i("mouthRollLower")] = 0.2 * e;
            w[i("eyeSquintLeft")] = 0.25 * e;
            w[i("eyeSquintRight")] = 0.25 * e;
            w[i("jawOpen")] = 0.05 + 0.25 * fill[f];
            w[i("browInnerUp")] = 0.6 * brows_up[f];
            w[i("browOuterUpLeft")] = 0.5 * brows_up[f];
            w[i("browOuterUpRight")] = 0.5 * brows_up[f];
            w[i("eyeWideLeft")] = 0.3 * brows_up[f];
            w[i("eyeWideRight")] = 0.3 * brows_up[f];
            w[i("eyeBlinkLeft")] = blink[f];
            w[i("eyeBlinkRight")] = blink[f];
            w[i("eyeLookDownLeft")] = 0.25;
            w[i("eyeLookDownRight")] = 0.25;
            // Looking right: the left eye looks in, the right eye out (and the reverse).
            let s = ((side[f] + 0.15) / 0.5).clamp(-1.0, 1.0);
            if s > 0.0 {
                w[i("eyeLookInLeft")] = 0.4 * s;
                w[i("eyeLookOutRight")] = 0.4 * s;
            } else {
                w[i("eyeLookOutLeft")] = -0.4 * s;
                w[i("eyeLookInRight")] = -0.4 * s;
            }
            w.map(|x| x.clamp(0.0, 1.0))
        })
        .collect()
}

/// Frames where blinks start: seeded every 2..6 s, and on three accents in ten, at least
/// [`MIN_BLINK_GAP_S`] apart.
fn blink_starts(accents: &[usize], frames: usize, rng: &mut Rng) -> Vec<usize> {
    let mut starts: Vec<usize> = Vec::new();
    let mut t = (FPS as f32 * (0.5 + 2.0 * rng.unit())) as usize;
    while t < frames {
        starts.push(t);
        t += (FPS as f32 * (2.0 + 4.0 * rng.unit())) as usize;
    }
    starts.extend(accents.iter().filter(|_| rng.unit() < 0.3));
    starts.sort_unstable();
    let mut kept: Vec<usize> = Vec::with_capacity(starts.len());
    for s in starts {
        if kept.last().is_none_or(|&k| s >= k + (MIN_BLINK_GAP_S * FPS) as usize) {
            kept.push(s);
        }
    }
    kept
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blinks_come_every_few_seconds_and_never_too_close() {
        let frames = 60 * 60;
        let b = blink_starts(&[600, 610, 1200], frames, &mut Rng::new(5));
        let n = b.len();
        assert!((10..=35).contains(&n), "{n} blinks a minute");
        assert!(b.windows(2).all(|w| w[1] - w[0] >= 90));
    }

    #[test]
    fn names_exist() {
        for n in ["browDownLeft", "mouthPressRight", "jawOpen", "eyeBlinkLeft", "browInnerUp", "eyeLookInRight"] {
            assert_eq!(ARKIT_NAMES[idx(n)], n);
        }
    }
}
