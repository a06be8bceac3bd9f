//! Feet ("pedal enforcement", DESIGN.md 1a) and hi-hat openness.
//! - Right foot on the kick pedal: for each kick note it rises and tilts back (toe up), eased
//!   over 5-7 frames (seeded), higher for louder notes, then drives down at one speed over the
//!   last [`PRESS_FALL_FRAMES`] and is down at rest exactly at the hit's frame. No frame moves
//!   the foot by more than a third of a full press (a 2-frame blip moved the toe 7 cm).
//! - Left foot on the hi-hat pedal: raised as far as the hi-hat is open. Openness comes from
//!   CC4 when the file has it (1 - value / 127, held until the next value), else from the
//!   notes: an open hi-hat note (its map entry's openness > 0.3) opens it and it stays open
//!   until a closed hi-hat or pedal note, or at most `OPEN_HOLD_FRAMES`. The foot follows
//!   that openness at most [`FOOT_SLEW`] a frame, its ramp centred on each step (CC4's steps
//!   moved the toe up to 8 cm in a frame); the openness itself (what the sound is told) keeps
//!   the data's steps. A hi-hat pedal note ("chick") is a press like the kick's.

use crate::midi::roll::frame_of;
use crate::midi::{DrumEventKind, NoteMap, Performance, Zone};
use crate::motion::Pose;
use crate::rng::Rng;

pub const OPEN_HOLD_FRAMES: usize = 20;
/// Ankles at rest on the hi-hat pedal (left) and the kick pedal (right) of a kit without a
/// `[pedals]` table.
pub const FEET_HOME: [[f32; 3]; 2] = [[-0.28, 0.30, 0.10], [0.10, 0.40, 0.10]];
/// The ankle's place over a pedal: this far in front of its heel, m (the pedals' heels are
/// where the exports draw them: the hi-hat's at `hihat_pedal_m`, the kick's 27 cm behind its
/// axle), at the height of [`FEET_HOME`].
const ANKLE_OVER_HEEL_M: f32 = 0.06;

/// Where the ankles rest on `kit`'s pedals: over each pedal's heel, on its line; the
/// [`FEET_HOME`] of a kit without pedals.
pub fn home_for(kit: &crate::kit::Kit) -> [[f32; 3]; 2] {
    let Some(p) = &kit.pedals else { return FEET_HOME };
    let z = FEET_HOME[0][2];
    [
        [p.hihat_pedal_m[0], p.hihat_pedal_m[1] + ANKLE_OVER_HEEL_M, z],
        [p.kick_axle_m[0], p.kick_axle_m[1] - 0.27 + ANKLE_OVER_HEEL_M, z],
    ]
}
/// How high the foot lifts at the top of a press, metres, and how far it tilts, degrees.
pub const PRESS_LIFT_M: f32 = 0.04;
pub const PRESS_TILT_DEG: f32 = 18.0;

/// Foot poses (left, right) and hi-hat openness per frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Feet {
    pub feet: Vec<[Pose; 2]>,
    pub openness: Vec<f32>,
}

/// Frames over which a press comes down onto its pedal, at one speed.
pub const PRESS_FALL_FRAMES: usize = 3;
/// Most the hi-hat foot's lift (0..1) changes in a frame as it follows the openness.
pub const FOOT_SLEW: f32 = 0.3;

/// Raise `lift` (0..1) for a press whose hit is at frame `hit`: eased up over `rise` frames,
/// at the top `PRESS_FALL_FRAMES` before the hit, straight down to the hit.
fn press(lift: &mut [f32], hit: usize, rise: usize, amount: f32) {
    for k in 1..=PRESS_FALL_FRAMES + rise {
        let Some(f) = hit.checked_sub(k) else { break };
        let up = if k <= PRESS_FALL_FRAMES {
            k as f32 / PRESS_FALL_FRAMES as f32
        } else {
            let u = (k - PRESS_FALL_FRAMES) as f32 / rise as f32;
            0.5 * (1.0 + (std::f32::consts::PI * u).cos())
        };
        if let Some(x) = lift.get_mut(f) {
            *x = x.max(amount * up);
        }
    }
}

/// `x` followed at most `rate` a frame, the ramp centred on each step: the mean of the
/// lagging (forward) and leading (backward) rate-limited followers.
fn centred_slew(x: &[f32], rate: f32) -> Vec<f32> {
    let follow = |order: &mut dyn Iterator<Item = usize>| {
        let mut y = vec![0f32; x.len()];
        let mut last = None::<f32>;
        for i in order {
            let v = match last {
                Some(l) => l + (x[i] - l).clamp(-rate, rate),
                None => x[i],
            };
            (y[i], last) = (v, Some(v));
        }
        y
    };
    let (fwd, bwd) = (follow(&mut (0..x.len())), follow(&mut (0..x.len()).rev()));
    fwd.iter().zip(&bwd).map(|(a, b)| 0.5 * (a + b)).collect()
}

/// The feet of `perf`, at rest at `home` (left, right ankles: [`home_for`] a kit).
pub fn feet(perf: &Performance, map: &NoteMap, frames: usize, rng: &mut Rng, home: [[f32; 3]; 2]) -> Feet {
    let mut kick = vec![0f32; frames];
    let mut chick = vec![0f32; frames];
    let (mut kick_hits, mut chick_hits) = (Vec::new(), Vec::new());
    let has_cc4 = perf.events.iter().any(|e| matches!(e.kind, DrumEventKind::HiHatPedal { .. }));
    let mut openness = vec![0f32; frames];
    let mut cc = None::<f32>;
    let mut open_from = None::<(usize, f32)>;
    let mut events = perf.events.iter().peekable();
    for (f, open) in openness.iter_mut().enumerate() {
        // Events that fall in this frame.
        while let Some(e) = events.next_if(|e| frame_of(e.time_s) <= f) {
            match e.kind {
                DrumEventKind::HiHatPedal { value } => cc = Some(1.0 - value.min(127) as f32 / 127.0),
                DrumEventKind::NoteOn { note, velocity } => {
                    let Some(m) = map.entry(note) else { continue };
                    let v = velocity as f32 / 127.0;
                    let rise = (6 + (rng.sym() * 1.49).round() as i64).clamp(5, 7) as usize;
                    let hit = frame_of(e.time_s);
                    let is_hat = m.hihat_openness.is_some() || m.piece == "hihat";
                    match (m.zone, is_hat) {
                        (Zone::Pedal, false) => {
                            press(&mut kick, hit, rise, 0.4 + 0.6 * v);
                            kick_hits.push(hit);
                        }
                        (Zone::Pedal, true) => {
                            press(&mut chick, hit, rise, 0.3 + 0.4 * v);
                            chick_hits.push(hit);
                            open_from = None;
                        }
                        (_, true) => match m.hihat_openness {
                            Some(o) if o > 0.3 => open_from = Some((hit, o)),
                            _ => open_from = None,
                        },
                        _ => {}
                    }
                }
                _ => {}
            }
        }
        *open = if has_cc4 {
            cc.unwrap_or(0.0)
        } else {
            match open_from {
                Some((start, o)) if f < start + OPEN_HOLD_FRAMES => o,
                _ => 0.0,
            }
        };
    }
    // Every press is down at its own hit, whatever the next one's rise asked there, and a
    // foot leaves a hit or comes down to one no faster than a press falls: at most d /
    // PRESS_FALL_FRAMES of a full lift d frames from the nearest hit (notes a few frames
    // apart are played low, not with the foot jumping up between them).
    for (lift, hits) in [(&mut kick, &mut kick_hits), (&mut chick, &mut chick_hits)] {
        hits.sort_unstable();
        for (f, x) in lift.iter_mut().enumerate() {
            let i = hits.partition_point(|&h| h < f);
            let near = [i.checked_sub(1).map(|j| hits[j]), hits.get(i).copied()]
                .into_iter()
                .flatten()
                .map(|h| h.abs_diff(f))
                .min();
            if let Some(d) = near {
                *x = x.min(d as f32 / PRESS_FALL_FRAMES as f32);
            }
        }
    }
    let left = centred_slew(&openness, FOOT_SLEW);
    let feet = (0..frames).map(|f| [foot(home[0], left[f].max(chick[f])), foot(home[1], kick[f])]).collect();
    Feet { feet, openness }
}

/// A foot at `home` raised by `lift` (0..1): up and toe tilted back.
fn foot(home: [f32; 3], lift: f32) -> Pose {
    let pitch = (PRESS_TILT_DEG * lift).to_radians();
    Pose {
        pos: [home[0], home[1], home[2] + PRESS_LIFT_M * lift],
        rot: [(pitch / 2.0).cos(), (pitch / 2.0).sin(), 0.0, 0.0],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::midi::DrumEvent;

    fn perf(events: Vec<(f64, DrumEventKind)>) -> Performance {
        let events = events.into_iter().map(|(time_s, kind)| DrumEvent { time_s, tick: 0, kind }).collect();
        Performance { path: "t.mid".into(), events, duration_s: 3.0, notes_end_s: 3.0, channel: 10 }
    }

    #[test]
    fn the_kick_foot_lifts_before_the_hit_and_is_down_at_it() {
        let map = NoteMap::builtin("roland-td").unwrap();
        let p = perf(vec![(1.0, DrumEventKind::NoteOn { note: 36, velocity: 120 })]);
        let ft = feet(&p, &map, 181, &mut Rng::new(1), FEET_HOME);
        let z = |f: usize| ft.feet[f][1].pos[2];
        let rest = FEET_HOME[1][2];
        assert!((z(60) - rest).abs() < 1e-6, "down at the hit");
        let lifted: Vec<usize> = (0..181).filter(|&f| z(f) > rest + 1e-4).collect();
        assert!(
            !lifted.is_empty() && lifted.len() <= 10 && lifted.iter().all(|&f| (50..60).contains(&f)),
            "{lifted:?}"
        );
        // No blip: it comes down over three frames, no frame moving it a third of the way.
        let top = (0..181).map(z).fold(rest, f32::max);
        assert!(z(57) == top && top > rest + 0.5 * PRESS_LIFT_M, "at the top three frames before");
        let most = (1..181).map(|f| (z(f) - z(f - 1)).abs()).fold(0.0, f32::max);
        assert!(most <= PRESS_LIFT_M / 3.0 + 1e-6, "{most}");
    }

    #[test]
    fn two_kicks_a_frame_apart_are_each_down_at_their_hit() {
        let map = NoteMap::builtin("roland-td").unwrap();
        let kick = DrumEventKind::NoteOn { note: 36, velocity: 127 };
        let p = perf(vec![(1.0, kick), (1.0 + 2.0 / 60.0, kick)]);
        let ft = feet(&p, &map, 181, &mut Rng::new(1), FEET_HOME);
        let rest = FEET_HOME[1][2];
        assert!((ft.feet[60][1].pos[2] - rest).abs() < 1e-6 && (ft.feet[62][1].pos[2] - rest).abs() < 1e-6);
        assert!(ft.feet[61][1].pos[2] > rest, "up between them");
    }

    #[test]
    fn the_hi_hat_foot_ramps_through_a_cc4_step_the_openness_keeps() {
        let map = NoteMap::builtin("roland-td").unwrap();
        let p =
            perf(vec![(0.0, DrumEventKind::HiHatPedal { value: 127 }), (1.0, DrumEventKind::HiHatPedal { value: 0 })]);
        let ft = feet(&p, &map, 121, &mut Rng::new(1), FEET_HOME);
        assert_eq!((ft.openness[59], ft.openness[60]), (0.0, 1.0), "the data's step");
        let z = |f: usize| ft.feet[f][0].pos[2];
        let most = (1..121).map(|f| (z(f) - z(f - 1)).abs()).fold(0.0, f32::max);
        assert!(most <= FOOT_SLEW * PRESS_LIFT_M + 1e-6, "{most}");
        // Centred: half way up about the step, fully open and shut away from it.
        let half = FEET_HOME[0][2] + 0.5 * PRESS_LIFT_M;
        assert!(z(58) < half && z(61) > half, "{} {}", z(58), z(61));
        assert!((z(50) - FEET_HOME[0][2]).abs() < 1e-6 && (z(70) - FEET_HOME[0][2] - PRESS_LIFT_M).abs() < 1e-6);
    }

    #[test]
    fn an_open_hi_hat_holds_until_closed_or_twenty_frames() {
        let map = NoteMap::builtin("roland-td").unwrap();
        let on = |note| DrumEventKind::NoteOn { note, velocity: 90 };
        let p = perf(vec![(0.5, on(46)), (0.7, on(42)), (1.5, on(46))]);
        let ft = feet(&p, &map, 181, &mut Rng::new(1), FEET_HOME);
        assert!(ft.openness[30] > 0.5 && ft.openness[41] > 0.5);
        assert_eq!(ft.openness[42], 0.0, "closed at 0.7 s");
        assert!(ft.openness[90 + 19] > 0.5 && ft.openness[90 + 20] == 0.0, "released after 20 frames");
        assert!(ft.feet[30][0].pos[2] > ft.feet[50][0].pos[2], "left foot raised while open");
    }

    #[test]
    fn cc4_sets_the_openness_when_present() {
        let map = NoteMap::builtin("roland-td").unwrap();
        let p =
            perf(vec![(0.0, DrumEventKind::HiHatPedal { value: 127 }), (1.0, DrumEventKind::HiHatPedal { value: 0 })]);
        let ft = feet(&p, &map, 121, &mut Rng::new(1), FEET_HOME);
        assert_eq!(ft.openness[30], 0.0);
        assert_eq!(ft.openness[90], 1.0);
    }
}
