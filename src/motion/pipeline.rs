//! The motion stage: a performance and its predicted hands -> whole-body motion on the kit.
//!
//! roll (60 fps) -> hand poses (the hand model, or the teacher when no weights are given)
//! -> strike planning on the configured kit (hands assigned, tips corrected onto the strike
//! points) -> upper body and face by retrieval from the shipped library -> feet by pedal
//! enforcement -> `Motion`, one frame per roll frame.

use super::notes::{hand_notes, NotesError};
use super::plan::{self, AssignSettings, HandNote, StrokeSettings};
use super::track::{Motion, MotionFrame, Pose, FPS};
use super::upper::{self, Library, LibraryError, MatchIndex, MatchReport, MatchSettings};
use crate::kit::Kit;
use crate::midi::roll::{piano_roll, PianoRoll};
use crate::midi::{NoteMap, Performance};
use crate::rng::Rng;

/// The seed of the blinks added where the retrieved face stares ([`upper::blinks`]).
const BLINK_SEED: u64 = 0xB11C;

#[derive(Debug, thiserror::Error)]
pub enum MotionError {
    #[error(transparent)]
    Notes(#[from] NotesError),
    #[error(transparent)]
    Library(#[from] LibraryError),
    #[error("{0}: the performance has no frames (an empty song)")]
    Empty(String),
    #[error("the hand model gave {got} frames for a roll of {want}")]
    HandFrames { got: usize, want: usize },
}

/// What the motion stage did, for the render summary and tests.
#[derive(Debug, Clone, Default)]
pub struct MotionReport {
    pub frames: usize,
    pub hand_notes: usize,
    /// Hand notes no hand could play in time (three at once, impossible speed): not played.
    pub dropped: usize,
    /// The hand of every hand note (in `notes::hand_notes` order), `None` when dropped.
    pub hands: Vec<Option<usize>>,
    pub retrieval: MatchReport,
}

/// Weights that replace the compiled-in hand model without a `--weights` option:
/// `$DRUMSIM_ASSETS/hands/best.bpk`, when that variable is set and the file exists. Renders
/// otherwise use [`super::hands::HandModel::shipped`], wherever the binary is run from.
pub fn override_weights() -> Option<std::path::PathBuf> {
    let dir = std::env::var_os("DRUMSIM_ASSETS")?;
    let path = std::path::Path::new(&dir).join("hands").join("best.bpk");
    path.is_file().then_some(path)
}

/// The shipped retrieval library (compiled in from `assets/upper-library.bin`).
pub fn shipped_library() -> Result<Library, LibraryError> {
    Library::from_bytes(
        include_bytes!("../../assets/upper-library.bin"),
        std::path::Path::new("assets/upper-library.bin"),
    )
}

/// The hand model's poses for `perf`, one per roll frame.
pub fn model_hands(model: &super::hands::HandModel, perf: &Performance, map: &NoteMap) -> Vec<[Pose; 2]> {
    roll_hands(model, &piano_roll(perf, map))
}

/// The hand model's poses for a piano roll (`piano_roll(perf, map)`), one per frame.
pub fn roll_hands(model: &super::hands::HandModel, roll: &PianoRoll) -> Vec<[Pose; 2]> {
    model.predict_roll(roll).iter().map(super::track::values_to_hands).collect()
}

/// Whole-body motion for `perf` on `kit`, from `predicted` hand poses (one per roll frame).
pub fn perform(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
    predicted: &[[Pose; 2]],
    library: &Library,
) -> Result<(Motion, MotionReport), MotionError> {
    perform_planned(perf, map, kit, predicted, library).map(|p| (p.motion, p.report))
}

/// What the motion stage made: the motion, its report, and the planned hands themselves
/// (continuous in time, for the body's 250 Hz targets).
pub struct Planned {
    pub motion: Motion,
    pub report: MotionReport,
    pub hands: plan::PlannedHands,
    /// The hand notes on this kit, in `MotionReport::hands` order.
    pub notes: Vec<HandNote>,
}

/// [`perform`], keeping the planned hands.
pub fn perform_planned(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
    predicted: &[[Pose; 2]],
    library: &Library,
) -> Result<Planned, MotionError> {
    perform_planned_indexed(perf, map, kit, predicted, (library, &MatchIndex::of(library)?), &|_| None)
}

/// [`perform_planned`] on the performance's piano roll made beforehand (`piano_roll(perf,
/// map)`, which the hand model read too): a render makes its roll once.
pub fn perform_planned_roll(
    perf: &Performance,
    map: &NoteMap,
    roll: &PianoRoll,
    kit: &Kit,
    predicted: &[[Pose; 2]],
    library: &Library,
) -> Result<Planned, MotionError> {
    planned_with(perf, map, roll, kit, predicted, Some((library, &MatchIndex::of(library)?)), &|_| None, 0.0)
}

/// [`perform_planned`] with the library's index made beforehand (`MatchIndex::of(library)`):
/// for a caller that plans over and over (the live motion stage), the notes `kept` names a
/// hand for given to that hand ([`plan::assign_hands_kept`]).
pub fn perform_planned_indexed(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
    predicted: &[[Pose; 2]],
    (library, index): (&Library, &MatchIndex),
    kept: &dyn Fn(&HandNote) -> Option<usize>,
) -> Result<Planned, MotionError> {
    perform_planned_indexed_at(perf, map, kit, predicted, (library, index), kept, 0.0)
}

/// [`perform_planned_indexed`] for a performance that starts `origin_s` seconds into the
/// session (a live window), so that the face's added blinks fall where the session's do.
pub fn perform_planned_indexed_at(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
    predicted: &[[Pose; 2]],
    (library, index): (&Library, &MatchIndex),
    kept: &dyn Fn(&HandNote) -> Option<usize>,
    origin_s: f64,
) -> Result<Planned, MotionError> {
    planned_with(perf, map, &piano_roll(perf, map), kit, predicted, Some((library, index)), kept, origin_s)
}

/// What the simulated body plays from, and no more: the planned hands and the feet (the
/// pedals' targets). The animation's hands, upper body and face are left at rest: no
/// smoothing for the animation, no retrieval (the live physical drummer with nothing
/// showing it plans this every 50 ms).
pub fn perform_planned_for_body(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
    predicted: &[[Pose; 2]],
) -> Result<Planned, MotionError> {
    perform_planned_for_body_kept(perf, map, kit, predicted, &|_| None)
}

/// [`perform_planned_for_body`] with the notes `kept` names a hand for given to that hand
/// ([`plan::assign_hands_kept`]).
pub fn perform_planned_for_body_kept(
    perf: &Performance,
    map: &NoteMap,
    kit: &Kit,
    predicted: &[[Pose; 2]],
    kept: &dyn Fn(&HandNote) -> Option<usize>,
) -> Result<Planned, MotionError> {
    planned_with(perf, map, &piano_roll(perf, map), kit, predicted, None, kept, 0.0)
}

#[allow(clippy::too_many_arguments)]
fn planned_with(
    perf: &Performance,
    map: &NoteMap,
    roll: &PianoRoll,
    kit: &Kit,
    predicted: &[[Pose; 2]],
    upper: Option<(&Library, &MatchIndex)>,
    kept: &dyn Fn(&HandNote) -> Option<usize>,
    origin_s: f64,
) -> Result<Planned, MotionError> {
    let frames = roll.len();
    if frames == 0 || perf.events.is_empty() {
        return Err(MotionError::Empty(perf.path.display().to_string()));
    }
    if predicted.len() != frames {
        return Err(MotionError::HandFrames { got: predicted.len(), want: frames });
    }
    // Hands: the notes on this kit, assigned and planned over the prediction.
    let (notes, _unmapped) = hand_notes(perf, map, kit)?;
    let notes: Vec<HandNote> = notes
        .iter()
        .map(|n| HandNote {
            time_s: n.time_s,
            piece: n.piece,
            point: n.point,
            normal: n.normal,
            velocity: n.velocity,
            speed_mps: kit.strike.speed_for_velocity(n.velocity),
        })
        .collect();
    let tip = |h: usize, t: f64| {
        let f = ((t * FPS).round().max(0.0) as usize).min(frames - 1);
        predicted[f][h].stick_tip()
    };
    let assignment = plan::assign_hands_kept(&notes, &tip, kept, &AssignSettings::default());
    let planned = plan::plan_hands(predicted, FPS, &notes, &assignment, StrokeSettings::default());
    let feet = super::feet::feet(perf, map, frames, &mut Rng::new(0), super::feet::home_for(kit));
    // The animation: hands planned the same way over the prediction smoothed where it jumps
    // (the body's targets keep the prediction itself: its strokes were tuned on it, and
    // smoothed ones made 1.8 times the stray contacts on eight validation takes), upper body
    // and face by retrieval. None for the body alone: at rest.
    let animated = match upper {
        Some((library, index)) => {
            let smoothed = plan::smooth::smooth_jumps(predicted);
            let mut hands =
                plan::plan_hands(&smoothed, FPS, &notes, &assignment, StrokeSettings::default()).sample(FPS, frames);
            let strikes: [Vec<usize>; 2] = std::array::from_fn(|side| {
                notes
                    .iter()
                    .zip(&assignment.hands)
                    .filter(|(_, h)| **h == Some(side))
                    .map(|(n, _)| (n.time_s * FPS).round().max(0.0) as usize)
                    .collect()
            });
            // Grips no faster than a wrist moves (the stick turns about its tip instead), and
            // sticks out of the drums and off the cymbals.
            let plates = super::kit_clear::plates(kit);
            let blocked = |h: &Pose| plates.iter().any(|p| super::kit_clear::crosses(h, p));
            super::stick_clear::slew_grips(&mut hands, super::stick_clear::MAX_GRIP_STEP_M, &blocked);
            super::kit_clear::lift_clear(&mut hands, &plates, &super::shells::shells(kit), [&strikes[0], &strikes[1]]);
            let masks: Vec<u16> = roll.frames.iter().map(upper::library::mask).collect();
            let (mut upper, retrieval) = upper::retrieve_indexed(library, index, &masks, &MatchSettings::default())?;
            upper::turn::turn_toward_hands(&mut upper, &hands);
            upper::blinks::keep_blinking(&mut upper, FPS, origin_s, BLINK_SEED);
            Some((hands, upper, retrieval))
        }
        None => None,
    };
    let motion = Motion {
        fps: FPS,
        frames: (0..frames)
            .map(|f| {
                let (hands, chest, head, face) = match &animated {
                    Some((hands, upper, _)) => (hands[f], upper[f].chest, upper[f].head, upper[f].face.to_vec()),
                    None => ([Pose::IDENTITY; 2], Pose::IDENTITY, Pose::IDENTITY, Vec::new()),
                };
                MotionFrame { hands, chest, head, feet: feet.feet[f], face, hihat_openness: feet.openness[f] }
            })
            .collect(),
    };
    let report = MotionReport {
        frames,
        hand_notes: notes.len(),
        dropped: assignment.dropped,
        hands: assignment.hands.clone(),
        retrieval: animated.map(|a| a.2).unwrap_or_default(),
    };
    Ok(Planned { motion, report, hands: planned, notes })
}
