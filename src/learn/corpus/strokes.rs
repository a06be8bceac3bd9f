//! Strokes: one hand's stick-tip height and grip pose at 60 fps, from the notes the sticking
//! gave it.
//!
//! The grip (the hand pose's position) follows its own path and timing ([`super::grip`]): it
//! is fastest at every contact and waits, still, between. The stick then pivots in the hand
//! so that its tip is at the height `h(t)` above the piece it is over; `h` is cubic Hermite
//! pieces between two contacts (times t0 < t1, the notes' frame times):
//! - rebound: up from the surface at `REBOUND` times the strike speed, to the rest height
//!   (`REST_M`, low over the piece), where it waits;
//! - preparatory lift to a height that grows with the next note's velocity ([`lift_height`]:
//!   3 cm at velocity 1 .. 30 cm at 127), capped by the time since the hand's previous note
//!   (`LIFT_PER_S` metres per second of gap);
//! - downstroke arriving at the surface exactly at t1 (h = 0) with the downward speed of the
//!   kit's velocity curve ([`crate::kit::StrikeSettings::speed_for_velocity`]), capped where a
//!   low lift cannot reach it without overshooting ([`travel::max_slope`]).
//!
//! When the notes are too close for rebound, wait and lift, the stroke is one rise to the
//! (capped) lift and the downstroke. The curves are analytic, so they are evaluated exactly at
//! the frame times (the contact frame is a knot).
//!
//! Orientation: the stick is yawed as from a pivot beside and behind the drummer (the
//! shoulder of that hand, [`grip::PIVOTS`]) toward the point it is over, and pitched so that
//! the tip is at `h` ([`grip::solve_pitch`]); at a contact that is exactly
//! [`grip::PITCH_IMPACT_DEG`] and the tip is exactly on the strike point.
//!
//! Human variation, from the seed: the interior knot times (apex, end of the wait) move by up
//! to 3 ms (never the contact), lift and rest heights by +-10 %, the grip's speed at each
//! contact by +-10 % and the loop's shape by +-0.1.

use super::grip::{self, GripHit, GripTrack};
use super::travel::{hermite, max_slope};
use super::{HandNote, Rng, LEFT};
use crate::kit::Kit;
use crate::midi::Zone;
use crate::motion::{Pose, FPS};

pub use super::grip::impact_grip;

/// Lift at velocity 1 and at 127, metres.
pub const LIFT_MIN_M: f32 = 0.03;
pub const LIFT_MAX_M: f32 = 0.30;
/// Shape of the lift curve: lift = min + (max - min) * (velocity / 127)^LIFT_EXPONENT.
pub const LIFT_EXPONENT: f32 = 1.3;
/// The lift may be at most this many metres per second of time since the hand's last note.
pub const LIFT_PER_S: f32 = 1.5;
/// Height at which the stick waits over the last piece.
pub const REST_M: f32 = 0.04;
/// Rebound speed as a fraction of the strike speed.
pub const REBOUND: f32 = 0.45;
/// Rebound duration, seconds.
pub const REBOUND_S: f64 = 0.07;
/// Largest timing jitter of a knot that is not a contact, seconds.
pub const JITTER_S: f64 = 0.003;

/// The preparatory lift for a velocity, before the time cap and variation.
pub fn lift_height(velocity: u8) -> f32 {
    let v = velocity.clamp(1, 127) as f32 / 127.0;
    LIFT_MIN_M + (LIFT_MAX_M - LIFT_MIN_M) * v.powf(LIFT_EXPONENT)
}

/// One contact of a hand.
#[derive(Debug, Clone, Copy)]
struct Contact {
    t: f64,
    /// Strike speed, and the rebound speed after it (m/s).
    speed: f32,
    rebound: f32,
}

/// A height knot: time, height, slope (m/s).
type Knot = (f64, f32, f32);

/// The stick tip's height from one contact (or rest) to the next.
#[derive(Debug, Clone)]
struct Gap {
    knots: Vec<Knot>,
}

impl Gap {
    fn height(&self, t: f64) -> f32 {
        let k = &self.knots;
        let i = k.partition_point(|x| x.0 <= t);
        if i == 0 {
            return k[0].1;
        }
        if i == k.len() {
            return k[k.len() - 1].1;
        }
        let (a, b) = (k[i - 1], k[i]);
        hermite(a.0, a.1, a.2, b.0, b.1, b.2, t)
    }
}

/// Move each interior knot by up to [`JITTER_S`], keeping the order (never the contacts: the
/// first and last knots of a gap stay).
fn jitter_knots(knots: &mut [Knot], rng: &mut Rng) {
    for i in 1..knots.len().saturating_sub(1) {
        let room = (knots[i].0 - knots[i - 1].0).min(knots[i + 1].0 - knots[i].0) * 0.2;
        debug_assert!(room >= 0.0, "knots out of order: {knots:?}");
        knots[i].0 += (rng.sym() as f64 * JITTER_S).clamp(-room, room);
    }
}

/// Where a hand with no notes rests: left over the snare, right over the hi-hat (else the
/// first piece), at the head / bow point.
fn rest_place(hand: usize, kit: &Kit) -> ([f32; 3], [f32; 3]) {
    let (id, zone) = if hand == LEFT { ("snare", Zone::Head) } else { ("hihat", Zone::Bow) };
    match kit.piece(id).or(kit.pieces.first()) {
        Some(p) => super::strike_point(kit, p, zone),
        None => ([0.0, 0.4, 0.7], [0.0, 0.0, 1.0]),
    }
}

/// The hand's pose in each of `frames` frames, striking each of `notes` (time order, distinct
/// frames) at its frame.
pub fn hand_track(
    hand: usize,
    notes: &[&HandNote],
    onsets: &[f64],
    kit: &Kit,
    frames: usize,
    rng: &mut Rng,
) -> Vec<Pose> {
    let times: Vec<f64> = notes.iter().map(|n| n.frame as f64 / FPS).collect();
    let contacts: Vec<Contact> = notes
        .iter()
        .zip(&times)
        .map(|(n, &t)| {
            let speed = kit.strike.speed_for_velocity(n.velocity);
            Contact { t, speed, rebound: REBOUND * speed }
        })
        .collect();
    let hits: Vec<GripHit> = notes
        .iter()
        .zip(&contacts)
        .map(|(n, c)| GripHit {
            t: c.t,
            point: n.point,
            normal: n.normal,
            speed: grip::GRIP_SPEED_FRACTION * c.speed * (1.0 + 0.1 * rng.sym()),
        })
        .collect();
    let track = GripTrack::new(hand, hits, onsets, rest_place(hand, kit));
    let mut gaps = Vec::with_capacity(contacts.len() + 1);
    for i in 0..=contacts.len() {
        let prev = i.checked_sub(1).map(|j| contacts[j]);
        let next = contacts.get(i).copied();
        let velocity = notes.get(i).map_or(64, |n| n.velocity);
        gaps.push(make_gap(prev, next, velocity, rng));
    }
    (0..frames)
        .map(|f| {
            let t = f as f64 / FPS;
            let i = contacts.partition_point(|c| c.t <= t);
            let (pos, (base, n, yaw)) = track.at(t);
            let pitch = grip::solve_pitch(pos, base, n, yaw, gaps[i].height(t));
            Pose { pos, rot: grip::rotation(yaw, pitch) }
        })
        .collect()
}

/// The tip's heights between `prev` and `next` (either may be absent: before the first note
/// the stick waits at rest; after the last it rebounds and waits).
fn make_gap(prev: Option<Contact>, next: Option<Contact>, velocity: u8, rng: &mut Rng) -> Gap {
    let rest_h = REST_M * (1.0 + 0.1 * rng.sym());
    let lift = lift_height(velocity) * (1.0 + 0.1 * rng.sym());
    let mut knots = match (prev, next) {
        (None, None) => vec![(0.0, rest_h, 0.0)],
        (Some(a), None) => {
            let w = a.rebound.min(max_slope(rest_h, REBOUND_S));
            vec![(a.t, 0.0, w), (a.t + REBOUND_S, rest_h, 0.0)]
        }
        (None, Some(b)) => {
            let (t_down, v) = downstroke(lift, b.speed, f64::INFINITY);
            let t_lift = lift_time(lift);
            vec![(b.t - t_down - t_lift, rest_h.min(lift), 0.0), (b.t - t_down, lift, 0.0), (b.t, 0.0, -v)]
        }
        (Some(a), Some(b)) => {
            let d = b.t - a.t;
            let lift = lift.min(LIFT_PER_S * d as f32);
            let rest_h = rest_h.min(lift);
            let (t_down, v) = downstroke(lift, b.speed, d);
            let t_lift = lift_time(lift);
            if d >= REBOUND_S + t_lift + t_down {
                let w = a.rebound.min(max_slope(rest_h, REBOUND_S));
                vec![
                    (a.t, 0.0, w),
                    (a.t + REBOUND_S, rest_h, 0.0),
                    (b.t - t_down - t_lift, rest_h, 0.0),
                    (b.t - t_down, lift, 0.0),
                    (b.t, 0.0, -v),
                ]
            } else {
                let apex = b.t - t_down;
                let w = a.rebound.min(max_slope(lift, apex - a.t));
                vec![(a.t, 0.0, w), (apex, lift, 0.0), (b.t, 0.0, -v)]
            }
        }
    };
    jitter_knots(&mut knots, rng);
    Gap { knots }
}

/// Downstroke duration and arrival speed for a lift, a strike speed and the gap: about 1.5
/// lifts' worth of travel at the strike speed, at most 40 % of the gap, and the speed capped
/// by [`max_slope`].
fn downstroke(lift: f32, speed: f32, gap: f64) -> (f64, f32) {
    let t = ((1.5 * lift / speed.max(0.1)) as f64).clamp(0.02, 0.15).min(0.4 * gap);
    (t, speed.min(max_slope(lift, t)))
}

/// How long the lift from rest to the apex takes.
fn lift_time(lift: f32) -> f64 {
    0.12 + 0.4 * lift as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::corpus::{strike_point, Role, RIGHT};
    use crate::midi::roll::frame_of;

    fn note(kit: &Kit, id: &str, time_s: f64, velocity: u8) -> HandNote {
        let piece = kit.index_of(id).unwrap();
        let (point, normal) = strike_point(kit, &kit.pieces[piece], Zone::Head);
        let role = Role::of(&kit.pieces[piece]);
        HandNote { time_s, frame: frame_of(time_s), note: 38, velocity, piece, role, zone: Zone::Head, point, normal }
    }

    fn dist(a: [f32; 3], b: [f32; 3]) -> f32 {
        super::super::norm([a[0] - b[0], a[1] - b[1], a[2] - b[2]])
    }

    #[test]
    fn the_tip_is_on_the_strike_point_at_every_note_frame() {
        let kit = Kit::builtin_default();
        let ids = ["snare", "tom1", "tom2", "floor_tom", "ride", "crash", "snare"];
        // Gaps from 50 ms to 1 s, velocities 20..137.
        let mut t = 0.2;
        let notes: Vec<HandNote> = (0..40)
            .map(|i| {
                t += [0.05, 0.09, 0.13, 0.3, 1.0][i % 5];
                note(&kit, ids[i % ids.len()], t, (20 + i * 3) as u8)
            })
            .collect();
        let refs: Vec<&HandNote> = notes.iter().collect();
        let track = hand_track(RIGHT, &refs, &[], &kit, 900, &mut Rng::new(3));
        for n in &notes {
            let tip = track[n.frame].stick_tip();
            assert!(dist(tip, n.point) < 1e-3, "frame {}: {tip:?} vs {:?}", n.frame, n.point);
        }
    }

    #[test]
    fn louder_notes_lift_higher_and_the_tip_stays_above_the_surface() {
        let kit = Kit::builtin_default();
        let mut apex = Vec::new();
        for v in [20u8, 60, 100, 127] {
            let n = [note(&kit, "snare", 0.5, 64), note(&kit, "snare", 1.5, v)];
            let refs: Vec<&HandNote> = n.iter().collect();
            let track = hand_track(LEFT, &refs, &[], &kit, 120, &mut Rng::new(1));
            let heights: Vec<f32> = track
                .iter()
                .map(|p| {
                    crate::kit::geometry::dot(p.stick_tip(), n[0].normal)
                        - crate::kit::geometry::dot(n[0].point, n[0].normal)
                })
                .collect();
            assert!(heights.iter().all(|&h| h > -1e-4), "tip below the head");
            apex.push(heights[31..90].iter().cloned().fold(0.0, f32::max));
        }
        assert!(apex.windows(2).all(|w| w[1] > w[0]), "{apex:?}");
        assert!(apex[3] > 0.2 && apex[0] < 0.1, "{apex:?}");
    }

    #[test]
    fn the_stick_points_down_at_impact_and_the_grip_moves_less_than_the_tip() {
        let kit = Kit::builtin_default();
        let n = [note(&kit, "snare", 0.5, 64), note(&kit, "snare", 1.5, 127)];
        let refs: Vec<&HandNote> = n.iter().collect();
        let track = hand_track(LEFT, &refs, &[], &kit, 120, &mut Rng::new(1));
        let at = track[90];
        assert!(at.stick_tip()[2] < at.pos[2], "stick points down at impact");
        let (tips, grips): (Vec<f32>, Vec<f32>) = track[31..90].iter().map(|p| (p.stick_tip()[2], p.pos[2])).unzip();
        let range = |v: &[f32]| v.iter().cloned().fold(f32::MIN, f32::max) - v.iter().cloned().fold(f32::MAX, f32::min);
        assert!(range(&grips) < 0.5 * range(&tips));
    }
}
