//! The training-corpus teacher (DESIGN.md section 3): real drum MIDI in, the drumming motion a
//! drummer would recognise out. It is deterministic given a seed, and documented rule by rule:
//!
//! 1. Notes ([`hand_notes`]): every mapped note-on whose zone is not `Pedal` (the kick and the
//!    hi-hat pedal are feet) is a hand note, struck at a point of its piece set by its zone
//!    ([`strike_point`]).
//! 2. Sticking ([`sticking`]): which hand plays each note (right-handed player, cross-handed
//!    hi-hat, alternating fills, no tangles at speed).
//! 3. Strokes ([`strokes`]): a stick-tip trajectory per hand that meets the strike point exactly
//!    at the note's 60 fps frame, with a velocity-dependent lift, rebound and minimum-jerk
//!    travel; the grip follows from the stick's pitch and yaw.
//! 4. Upper body and face ([`upper`], [`face`]) and feet ([`feet`]).
//!
//! [`dataset`] turns the Groove MIDI Dataset into (piano roll, hand values) training pairs.
//!
//! Timing convention: the motion is sampled at 60 fps, so a note's contact happens at its
//! roll frame, `round(time_s * 60) / 60` (within 8.3 ms of the MIDI onset, the roll's own
//! quantisation): the tip is on the strike point exactly at that frame.

pub mod dataset;
pub mod face;
pub mod grip;
pub mod sticking;
pub mod strokes;
pub mod travel;
pub mod upper;

pub use dataset::{build_dataset, load_examples, run_corpus, save_examples, CorpusSummary, Example};
// The hand notes on the kit are the runtime's (`motion::notes`); the teacher plays them too.
pub use crate::motion::notes::{hand_notes, HandNote, NotesError, Role, LEFT, RIGHT};

use crate::kit::Kit;
use crate::midi::roll::{piano_roll, PianoRoll};
use crate::midi::{NoteMap, Performance, Zone};
use crate::motion::{Motion, MotionFrame, FPS};
use std::path::PathBuf;

/// A hand note the teacher plays: its hand, piece and strike point.
#[derive(Debug, Clone, PartialEq)]
pub struct PlannedNote {
    pub time_s: f64,
    pub frame: usize,
    /// [`LEFT`] or [`RIGHT`].
    pub hand: usize,
    /// Kit piece id.
    pub piece: String,
    pub zone: Zone,
    pub point: [f32; 3],
    pub normal: [f32; 3],
    pub velocity: u8,
}

/// What the teacher makes of one performance.
#[derive(Debug, Clone)]
pub struct Teaching {
    /// The DRUMS 60 fps piano roll (the model's input), `roll.len()` frames.
    pub roll: PianoRoll,
    /// The whole-body motion, as many frames as the roll.
    pub motion: Motion,
    /// Hand notes played, in time order.
    pub notes: Vec<PlannedNote>,
    /// Hand notes left out: a second note on the same piece in the same frame, or a third (or
    /// more) hand note at once (see [`sticking`]).
    pub dropped: usize,
    /// Note-ons the map does not know (not played, not in the roll).
    pub unmapped: usize,
    /// The beat period the upper body nods to, seconds.
    pub beat_s: f64,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CorpusError {
    #[error(transparent)]
    Notes(#[from] NotesError),
    #[error("{path}: cannot read: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}: cannot write: {source}")]
    Write { path: PathBuf, source: std::io::Error },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    #[error("{path}: line {line}: {message}")]
    Csv { path: PathBuf, line: usize, message: String },
    #[error("{path}: no examples of split {split:?} ({skipped} files failed to parse)")]
    Empty { path: PathBuf, split: String, skipped: usize },
}

/// Teach one performance: sticking, strokes, upper body, face and feet, deterministic in `seed`.
pub fn teach(perf: &Performance, map: &NoteMap, kit: &Kit, seed: u64) -> Result<Teaching, CorpusError> {
    let roll = piano_roll(perf, map);
    let frames = roll.len();
    let (notes, unmapped) = hand_notes(perf, map, kit)?;
    let plan = sticking::assign(&notes, kit);
    let mut planned: Vec<PlannedNote> = Vec::with_capacity(notes.len());
    let mut per_hand: [Vec<&HandNote>; 2] = [Vec::new(), Vec::new()];
    for (n, hand) in notes.iter().zip(&plan.hands) {
        if let Some(h) = *hand {
            per_hand[h].push(n);
            planned.push(PlannedNote {
                time_s: n.time_s,
                frame: n.frame,
                hand: h,
                piece: kit.pieces[n.piece].id.clone(),
                zone: n.zone,
                point: n.point,
                normal: n.normal,
                velocity: n.velocity,
            });
        }
    }
    let mut rng = Rng::new(seed);
    let mut onsets: Vec<f64> = planned.iter().map(|n| n.frame as f64 / FPS).collect();
    onsets.dedup();
    let hands: [Vec<_>; 2] = std::array::from_fn(|h| {
        strokes::hand_track(h, &per_hand[h], &onsets, kit, frames, &mut rng.fork(h as u64 + 1))
    });
    let beat = upper::estimate_beat(perf, map, frames);
    let tips: Vec<[[f32; 3]; 2]> = (0..frames).map(|f| [hands[0][f].stick_tip(), hands[1][f].stick_tip()]).collect();
    let (chest, head) = upper::upper_body(&tips, &planned, &beat, frames, &mut rng.fork(11));
    let face = face::face(&planned, &notes, &beat, frames, &mut rng.fork(12));
    let feet = crate::motion::feet::feet(perf, map, frames, &mut rng.fork(13), crate::motion::feet::FEET_HOME);
    let motion_frames = (0..frames)
        .map(|f| MotionFrame {
            hands: [hands[0][f], hands[1][f]],
            chest: chest[f],
            head: head[f],
            feet: feet.feet[f],
            face: face[f].to_vec(),
            hihat_openness: feet.openness[f],
        })
        .collect();
    Ok(Teaching {
        roll,
        motion: Motion { fps: FPS, frames: motion_frames },
        notes: planned,
        dropped: plan.dropped,
        unmapped,
        beat_s: beat.period_s,
    })
}

/// Where a zone of a piece is struck (the kit's geometry, shared with the body and direct mode).
pub use crate::kit::strike_point;

pub(crate) use crate::kit::geometry::{norm, normalize};

pub use crate::rng::Rng;

/// The teacher's hands for `perf`, one per roll frame (`render --teacher`, and the
/// comparisons of `examples/planned_hands.rs`).
pub fn teacher_hands(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
) -> Result<Vec<[crate::motion::track::Pose; 2]>, CorpusError> {
    let t = teach(perf, map, kit, 0)?;
    Ok(t.motion.frames.iter().map(|f| f.hands).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kit::geometry::dot;

    #[test]
    fn strike_points_lie_in_the_piece_plane_at_the_zone_radius() {
        let kit = Kit::builtin_default();
        for p in &kit.pieces {
            for (zone, frac) in [(Zone::Head, kit.zones.head), (Zone::Rim, kit.zones.rim), (Zone::Bow, kit.zones.bow)] {
                let (pt, n) = strike_point(&kit, p, zone);
                let d = [pt[0] - p.position_m[0], pt[1] - p.position_m[1], pt[2] - p.position_m[2]];
                assert!(dot(d, n).abs() < 1e-5, "{} {zone:?} off the plane", p.id);
                assert!((norm(d) - p.radius_m * frac).abs() < 1e-5);
            }
        }
        // The snare's head point is on the drummer's side of its centre.
        let snare = kit.piece("snare").unwrap();
        let (pt, _) = strike_point(&kit, snare, Zone::Head);
        assert!(pt[1] < snare.position_m[1]);
    }

    #[test]
    fn rng_is_deterministic_and_forks_differ() {
        let mut a = Rng::new(7);
        let mut b = Rng::new(7);
        assert_eq!(a.next_u64(), b.next_u64());
        let mut fa = a.fork(1);
        let mut fb = b.fork(2);
        assert_ne!(fa.next_u64(), fb.next_u64());
        let u: Vec<f32> = (0..1000).map(|_| a.unit()).collect();
        assert!(u.iter().all(|x| (0.0..1.0).contains(x)));
        let mean = u.iter().sum::<f32>() / 1000.0;
        assert!((mean - 0.5).abs() < 0.05);
    }
}
