//! Blinks at a human rate. The retrieved faces blink as the clips they come from did: some
//! windows of the library blink every few seconds, others not for half a minute, so a take
//! matched to quiet windows stared for its whole length (0 blinks on 11 of 21 validation
//! takes, 14.8 a minute pooled). A seated player's spontaneous blinks come every 2-6 s (8-20 a
//! minute, fewer when concentrating); where the retrieved face has none for that long, one is
//! added. Added blinks take the larger of their weight and the retrieved one, so the face
//! never steps: both are 0 away from a blink.

use super::library::UpperFrame;
use crate::rng::Rng;

/// The face weights a blink closes: eyeBlinkLeft and eyeBlinkRight in
/// [`crate::motion::ARKIT_NAMES`] order.
const EYE_BLINK: [usize; 2] = [0, 7];
/// The shortest and longest wait for a blink after the one before, s (uniform).
pub const WAIT_S: (f64, f64) = (2.0, 6.0);
/// A blink's closing, closed and opening times, s (a full spontaneous blink lasts about a
/// quarter of a second, the lid closing faster than it opens).
const CLOSE_S: f64 = 0.075;
const SHUT_S: f64 = 0.035;
const OPEN_S: f64 = 0.150;
/// A retrieved blink is the eyes' weight rising through this.
const BLINKING: f32 = 0.5;

/// A blink's weight `t` seconds after it began (0 before and after it).
fn blink_weight(t: f64) -> f32 {
    let ease = |x: f64| {
        let x = x.clamp(0.0, 1.0);
        x * x * (3.0 - 2.0 * x)
    };
    let w = if t < 0.0 {
        0.0
    } else if t < CLOSE_S {
        ease(t / CLOSE_S)
    } else if t < CLOSE_S + SHUT_S {
        1.0
    } else {
        1.0 - ease((t - CLOSE_S - SHUT_S) / OPEN_S)
    };
    w as f32
}

/// Add blinks to `upper` (frames at `fps`, the first at `origin_s` seconds of the session)
/// and return how many were added. The candidate blinks lie on one schedule of the whole
/// session, waits drawn from [`WAIT_S`] by a generator seeded with `seed`, so that the live
/// motion stage, which plans a window every 50 ms, puts them at the same moments in every
/// window. A candidate is left out where the face blinks by itself from [`WAIT_S`]'s
/// shortest wait before it to half a second after it.
pub fn keep_blinking(upper: &mut [UpperFrame], fps: f64, origin_s: f64, seed: u64) -> usize {
    let n = upper.len();
    let end_s = origin_s + n as f64 / fps;
    let length = CLOSE_S + SHUT_S + OPEN_S;
    let mut was = false;
    let own: Vec<f64> = (0..n)
        .filter(|&f| {
            let blinking = upper[f].face[EYE_BLINK[0]] > BLINKING;
            let onset = blinking && !was;
            was = blinking;
            onset
        })
        .map(|f| origin_s + f as f64 / fps)
        .collect();
    let mut rng = Rng::new(seed);
    let mut at = wait(&mut rng);
    let mut added = 0;
    while at < end_s {
        let quiet = !own.iter().any(|&o| o > at - WAIT_S.0 && o < at + OWN_AFTER_S);
        if quiet && at + length > origin_s {
            let first = ((at - origin_s) * fps).ceil().max(0.0) as usize;
            let last = (((at + length - origin_s) * fps).ceil().max(0.0) as usize).min(n);
            for (f, frame) in upper.iter_mut().enumerate().take(last).skip(first) {
                // Each eye the larger of the blink's weight and its own.
                let w = blink_weight(origin_s + f as f64 / fps - at);
                for &e in &EYE_BLINK {
                    frame.face[e] = frame.face[e].max(w);
                }
            }
            added += 1;
        }
        at += wait(&mut rng);
    }
    added
}

/// A candidate blink is left out where the face's own blink follows it within this, s.
const OWN_AFTER_S: f64 = 0.5;

fn wait(rng: &mut Rng) -> f64 {
    WAIT_S.0 + (WAIT_S.1 - WAIT_S.0) * f64::from(rng.unit())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::{Pose, ARKIT_NAMES};

    fn open_eyes(frames: usize) -> Vec<UpperFrame> {
        vec![UpperFrame { chest: Pose::IDENTITY, head: Pose::IDENTITY, face: [0.0; 52] }; frames]
    }

    fn blinks(upper: &[UpperFrame]) -> Vec<usize> {
        let mut was = false;
        let mut at = Vec::new();
        for (f, u) in upper.iter().enumerate() {
            let b = u.face[EYE_BLINK[0]] > BLINKING;
            if b && !was {
                at.push(f);
            }
            was = b;
        }
        at
    }

    #[test]
    fn the_blinked_weights_are_the_arkit_eyes() {
        assert_eq!(ARKIT_NAMES[EYE_BLINK[0]], "eyeBlinkLeft");
        assert_eq!(ARKIT_NAMES[EYE_BLINK[1]], "eyeBlinkRight");
    }

    #[test]
    fn a_face_that_never_blinks_blinks_at_a_human_rate_without_steps() {
        let fps = 60.0;
        let mut upper = open_eyes(60 * 120);
        let added = keep_blinking(&mut upper, fps, 0.0, 7);
        let at = blinks(&upper);
        assert_eq!(at.len(), added);
        let per_min = added as f64 / 2.0;
        assert!((10.0..=30.0).contains(&per_min), "{per_min} blinks a minute");
        for w in at.windows(2) {
            let gap = (w[1] - w[0]) as f64 / fps;
            assert!(gap >= WAIT_S.0 - 0.02 && gap <= WAIT_S.1 + 0.02, "{gap} s between blinks");
        }
        // Closed at the middle of each blink, and no weight jumps more than a blink's
        // closing allows in one frame (75 ms: under a third of the way).
        for &f in &at {
            assert!(upper[f + 2].face[EYE_BLINK[0]] > 0.99 && upper[f + 2].face[EYE_BLINK[1]] > 0.99);
        }
        let step =
            upper.windows(2).map(|w| (w[1].face[EYE_BLINK[0]] - w[0].face[EYE_BLINK[0]]).abs()).fold(0.0, f32::max);
        assert!(step < 0.35, "a step of {step}");
    }

    #[test]
    fn a_window_of_the_session_blinks_where_the_whole_session_does() {
        let fps = 60.0;
        let mut whole = open_eyes(60 * 60);
        keep_blinking(&mut whole, fps, 0.0, 3);
        // A live window: 8 s of the session from 20.5 s on.
        let mut window = open_eyes(60 * 8);
        keep_blinking(&mut window, fps, 20.5, 3);
        let from = (20.5 * fps) as usize;
        assert!(!blinks(&window).is_empty());
        for (f, w) in window.iter().enumerate() {
            assert!((w.face[EYE_BLINK[0]] - whole[from + f].face[EYE_BLINK[0]]).abs() < 1e-6, "frame {f}");
        }
    }

    #[test]
    fn a_face_that_blinks_often_enough_is_left_as_it_is() {
        let fps = 60.0;
        let mut upper = open_eyes(60 * 60);
        // Its own blinks every 1.5 s, 9 frames closed.
        for start in (30..upper.len() - 10).step_by(90) {
            for u in &mut upper[start..start + 9] {
                u.face[EYE_BLINK[0]] = 1.0;
                u.face[EYE_BLINK[1]] = 1.0;
            }
        }
        let before = upper.clone();
        assert_eq!(keep_blinking(&mut upper, fps, 0.0, 1), 0);
        assert!(upper.iter().zip(&before).all(|(a, b)| a.face == b.face));
    }
}
