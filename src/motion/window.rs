//! The motion stage on a sliding window, for live play: the notes of the last few seconds go
//! through the same stage as a render (roll, hand model, strike planning, retrieval, feet),
//! and the avatar is shown `lookahead` behind the newest note, so that every stroke is
//! prepared before it lands (the hand model is bidirectional: a stick lifts before its note
//! because it sees the note coming).
//!
//! Times are seconds on the session's clock (the live MIDI epoch). A plan covers the window
//! `[now - lookahead - history, now]`; the avatar at wall time `now` shows the plan at
//! `now - lookahead`. Each new plan is faded in over [`FADE_S`] from the one before, so that
//! a replan never pops the pose.

use super::hands::HandModel;
use super::pipeline::{self, MotionError};
use super::plan::{HandNote, PlannedHands};
use super::track::{Motion, MotionFrame, Pose, FPS};
use super::upper::{Library, MatchIndex};
use crate::kit::Kit;
use crate::midi::{DrumEvent, DrumEventKind, NoteMap, Performance};
use std::collections::VecDeque;

/// How long a new plan takes to replace the one before, s.
pub const FADE_S: f64 = 0.1;
/// Context kept before the shown time, s: the hand model and retrieval see this much past.
pub const HISTORY_S: f64 = 2.0;

/// A note the body strikes before this long after the moment the window ends minus the
/// lookahead keeps the hand the plan before gave it, s: the body runs `LEAD_MS` (25 ms)
/// ahead of its sound, so notes up to 75 ms ahead of the body, whose strokes are under way.
/// A newer plan gave such a note to the other hand now and then (a jazz take's snare note
/// taken from the right hand 150 ms after the body had struck it), and both hands' paths
/// changed course. On 18 validation takes played live: recall 90.21 -> 91.66 %, precision
/// 91.43 -> 90.97 % (kept for notes up to the body's moment only: 90.63 / 91.39 %; 200 ms:
/// 91.45 / 89.59 %).
pub const KEEP_HAND_S: f64 = 0.1;

/// Most events a window holds: a drummer plays well under 100 notes in its 2.25 s, a broken
/// controller may send thousands a second. Events past this are dropped and counted, so a
/// flood cannot make plans ever slower.
pub const MAX_EVENTS: usize = 1024;

/// The sliding-window motion stage.
pub struct WindowMotion {
    kit: Kit,
    map: NoteMap,
    model: HandModel,
    library: Library,
    /// The library's index, made once (none: the library is bad, and each plan says why).
    index: Option<MatchIndex>,
    lookahead_s: f64,
    /// Events in time order (session clock).
    events: VecDeque<DrumEvent>,
    /// The last hi-hat pedal position before the window (carried into it).
    pedal_before: Option<u8>,
    /// Events dropped because the window held [`MAX_EVENTS`].
    flooded: u64,
    /// Plan the upper body, face and animation hands too (false: only what the simulated
    /// body plays from, [`pipeline::perform_planned_for_body`]).
    upper: bool,
    /// The hand each note of the last plan was given: (session time, kit piece, hand).
    sticking: Vec<(f64, usize, usize)>,
}

/// One plan: motion at 60 fps from `start_s` (session clock).
#[derive(Debug, Clone)]
pub struct WindowPlan {
    pub start_s: f64,
    pub motion: Motion,
    /// The notes in the window the kit plays: (session time, piece id, velocity).
    pub notes: Vec<(f64, String, u8)>,
    /// The planned strokes of both hands, on the session clock (for the live physical body).
    pub hands: PlannedHands,
    /// The window's notes and pedal data, times from `start_s` (for the body's pedals).
    pub perf: Performance,
}

impl WindowPlan {
    /// The frame at session time `t` (linear between frames; the nearest end outside).
    pub fn frame_at(&self, t: f64) -> MotionFrame {
        let x = ((t - self.start_s) * self.motion.fps).max(0.0);
        let last = self.motion.frames.len() - 1;
        let i = (x.floor() as usize).min(last);
        let j = (i + 1).min(last);
        blend(&self.motion.frames[i], &self.motion.frames[j], (x - i as f64).clamp(0.0, 1.0) as f32)
    }

    /// Session time just past the last frame.
    pub fn end_s(&self) -> f64 {
        self.start_s + self.motion.frames.len() as f64 / self.motion.fps
    }
}

fn lerp3(a: [f32; 3], b: [f32; 3], w: f32) -> [f32; 3] {
    std::array::from_fn(|k| a[k] + (b[k] - a[k]) * w)
}

/// `a` moved `w` (0..1) of the way to `b` (positions linear, rotations slerped).
pub fn blend_pose(a: &Pose, b: &Pose, w: f32) -> Pose {
    let rot = a.rotation().slerp(&b.rotation(), w);
    Pose { pos: lerp3(a.pos, b.pos, w), rot: [rot.w, rot.i, rot.j, rot.k] }
}

/// `a` moved `w` (0..1) of the way to `b`.
pub fn blend(a: &MotionFrame, b: &MotionFrame, w: f32) -> MotionFrame {
    MotionFrame {
        hands: [blend_pose(&a.hands[0], &b.hands[0], w), blend_pose(&a.hands[1], &b.hands[1], w)],
        chest: blend_pose(&a.chest, &b.chest, w),
        head: blend_pose(&a.head, &b.head, w),
        feet: [blend_pose(&a.feet[0], &b.feet[0], w), blend_pose(&a.feet[1], &b.feet[1], w)],
        face: a.face.iter().zip(&b.face).map(|(x, y)| x + (y - x) * w).collect(),
        hihat_openness: a.hihat_openness + (b.hihat_openness - a.hihat_openness) * w,
    }
}

impl WindowMotion {
    pub fn new(kit: Kit, map: NoteMap, model: HandModel, library: Library, lookahead_s: f64) -> WindowMotion {
        WindowMotion {
            kit,
            map,
            model,
            index: MatchIndex::of(&library).ok(),
            library,
            lookahead_s,
            events: VecDeque::with_capacity(MAX_EVENTS),
            pedal_before: None,
            flooded: 0,
            upper: true,
            sticking: Vec::new(),
        }
    }

    /// Whether plans carry the upper body, face and animation hands (an avatar shows them),
    /// or only what the simulated body plays from (the planned hands and the feet).
    pub fn plan_upper_body(&mut self, upper: bool) {
        self.upper = upper;
    }

    pub fn lookahead_s(&self) -> f64 {
        self.lookahead_s
    }

    /// A MIDI event as it arrives (its `time_s` on the session clock).
    pub fn push(&mut self, event: DrumEvent) {
        if self.events.len() >= MAX_EVENTS {
            // Room is made only by time: the oldest leave at the next plan.
            self.flooded += 1;
            return;
        }
        self.events.push_back(event);
    }

    /// Events dropped because the window was full (a note flood).
    pub fn flooded(&self) -> u64 {
        self.flooded
    }

    /// Where the window of a plan made at `now_s` starts.
    pub fn window_start(&self, now_s: f64) -> f64 {
        // On a 1/64 s grid: a note's time moved into the window and back onto the session
        // clock ([`crate::motion::plan::PlannedHands::shifted`]) comes back bit for bit.
        ((now_s - self.lookahead_s - HISTORY_S).max(0.0) * 64.0).floor() / 64.0
    }

    /// The motion of the window ending at `now_s` (a drummer waiting, while it holds no
    /// note).
    pub fn plan(&mut self, now_s: f64) -> Result<WindowPlan, MotionError> {
        let start = self.window_start(now_s);
        while self.events.front().is_some_and(|e| e.time_s < start) {
            if let Some(DrumEventKind::HiHatPedal { value }) = self.events.pop_front().map(|e| e.kind) {
                self.pedal_before = Some(value);
            }
        }
        let mut events: Vec<DrumEvent> = Vec::with_capacity(self.events.len() + 1);
        events.push(match self.pedal_before {
            Some(value) => DrumEvent { time_s: 0.0, tick: 0, kind: DrumEventKind::HiHatPedal { value } },
            // A window is never empty: a note-off, which nothing plays, stands for silence.
            None => DrumEvent { time_s: 0.0, tick: 0, kind: DrumEventKind::NoteOff { note: 0 } },
        });
        events.extend(self.events.iter().map(|e| DrumEvent { time_s: (e.time_s - start).max(0.0), ..*e }));
        let last_note = events
            .iter()
            .filter(|e| matches!(e.kind, DrumEventKind::NoteOn { .. }))
            .map(|e| e.time_s)
            .fold(0.0, f64::max);
        let length = now_s - start;
        let perf = Performance {
            path: "live".into(),
            events,
            duration_s: length,
            // The roll ends a second after this: the window up to now.
            notes_end_s: last_note.max(length - 1.0),
            channel: self.map.channel,
        };
        let hands = pipeline::model_hands(&self.model, &perf, &self.map);
        // Notes the body has struck, or strikes within the next 75 ms (a stroke under way),
        // keep the hand the plan before gave them.
        let cutoff = now_s - self.lookahead_s + KEEP_HAND_S;
        let sticking = &self.sticking;
        let kept = |n: &HandNote| {
            let t = n.time_s + start;
            (t < cutoff).then(|| sticking.iter().find(|s| (s.0 - t).abs() < 1e-6 && s.1 == n.piece).map(|s| s.2))?
        };
        let planned = match &self.index {
            _ if !self.upper => pipeline::perform_planned_for_body_kept(&perf, &self.map, &self.kit, &hands, &kept)?,
            Some(index) => {
                let at = (&self.library, index);
                pipeline::perform_planned_indexed_at(&perf, &self.map, &self.kit, &hands, at, &kept, start)?
            }
            None => pipeline::perform_planned(&perf, &self.map, &self.kit, &hands, &self.library)?,
        };
        let notes = perf
            .events
            .iter()
            .filter_map(|e| match e.kind {
                DrumEventKind::NoteOn { note, velocity } => {
                    let piece = &self.map.entry(note)?.piece;
                    self.kit.piece(piece).is_some().then(|| (start + e.time_s, piece.clone(), velocity))
                }
                _ => None,
            })
            .collect();
        debug_assert_eq!(planned.motion.fps, FPS);
        self.sticking.clear();
        for h in 0..2 {
            self.sticking.extend(planned.hands.notes(h).map(|n| (n.time_s + start, n.piece, h)));
        }
        Ok(WindowPlan { start_s: start, motion: planned.motion, notes, hands: planned.hands.shifted(start), perf })
    }
}

/// The frame shown at session time `t` from the newest plan, faded in from the one before over
/// [`FADE_S`] after `since_s` (when the newest plan arrived).
pub fn shown_frame(newest: &WindowPlan, before: Option<&WindowPlan>, since_s: f64, now_s: f64, t: f64) -> MotionFrame {
    let new = newest.frame_at(t);
    match before {
        Some(old) if now_s - since_s < FADE_S && t >= old.start_s => {
            let w = ((now_s - since_s) / FADE_S).clamp(0.0, 1.0) as f32;
            blend(&old.frame_at(t), &new, w)
        }
        _ => new,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_note_flood_is_capped_and_counted_and_plans_stay_bounded() {
        let kit = Kit::builtin_default();
        let map = NoteMap::builtin("gm").unwrap();
        let library = crate::motion::pipeline::shipped_library().unwrap();
        let mut w = WindowMotion::new(kit, map, HandModel::shipped(), library, 0.25);
        // A broken controller: 10,000 snare notes a second for a second.
        for i in 0..10_000u64 {
            let kind = DrumEventKind::NoteOn { note: 38, velocity: 100 };
            w.push(DrumEvent { time_s: 1.0 + i as f64 * 1e-4, tick: i, kind });
        }
        assert_eq!(w.flooded(), 10_000 - MAX_EVENTS as u64);
        let start = std::time::Instant::now();
        let plan = w.plan(2.0).unwrap();
        let took = start.elapsed();
        assert!(plan.notes.len() <= MAX_EVENTS && !plan.motion.frames.is_empty());
        eprintln!("a plan of a flooded window: {} notes in {took:?}", plan.notes.len());
        // After the window has moved past the flood, events are taken again.
        let _ = w.plan(10.0).unwrap();
        w.push(DrumEvent { time_s: 10.0, tick: 0, kind: DrumEventKind::NoteOn { note: 38, velocity: 90 } });
        assert_eq!(w.flooded(), 10_000 - MAX_EVENTS as u64);
    }

    /// A plan for the simulated body alone carries the same planned hands and feet as a
    /// plan for an avatar (the body plays the same strokes, the pedals the same feet).
    #[test]
    fn a_note_the_body_has_struck_keeps_the_hand_the_plan_before_gave_it() {
        let kit = Kit::builtin_default();
        let map = NoteMap::builtin("gm").unwrap();
        let library = crate::motion::pipeline::shipped_library().unwrap();
        let mut w = WindowMotion::new(kit, map, HandModel::shipped(), library, 0.25);
        w.plan_upper_body(false);
        for (i, note) in [42u8, 38, 42, 45, 42, 38, 48, 43].iter().cycle().take(40).enumerate() {
            let kind = DrumEventKind::NoteOn { note: *note, velocity: 90 };
            w.push(DrumEvent { time_s: 0.5 + i as f64 * 0.11, tick: i as u64, kind });
        }
        let first = w.plan(3.0).unwrap();
        // Another plan's sticking, every hand swapped: the next plan keeps it for the notes
        // before its cutoff (the body's moment plus 75 ms) and plans the rest afresh.
        let swapped: Vec<(f64, usize, usize)> = w.sticking.iter().map(|&(t, p, h)| (t, p, 1 - h)).collect();
        w.sticking = swapped.clone();
        let now = 3.05;
        let cutoff = now - 0.25 + KEEP_HAND_S;
        let second = w.plan(now).unwrap();
        let mut kept = 0;
        for h in 0..2 {
            for n in second.hands.notes(h) {
                let was = swapped.iter().find(|s| (s.0 - n.time_s).abs() < 1e-6 && s.1 == n.piece).unwrap();
                if n.time_s < cutoff {
                    assert_eq!(was.2, h, "a struck note at {:.3} s changed hands", n.time_s);
                    kept += 1;
                }
            }
        }
        assert!(kept > 10, "{kept} notes kept");
        // Unforced, the same window gives those notes back their first hands.
        let natural = |p: &WindowPlan, t: f64| (0..2).find(|&h| p.hands.notes(h).any(|n| (n.time_s - t).abs() < 1e-6));
        let t = swapped
            .iter()
            .map(|s| s.0)
            .filter(|&t| t < cutoff && t > first.start_s + 0.5)
            .fold(f64::NEG_INFINITY, f64::max);
        assert_ne!(natural(&first, t), natural(&second, t));
    }

    #[test]
    fn a_body_only_plan_plays_what_the_full_plan_plays() {
        let kit = Kit::builtin_default();
        let map = NoteMap::builtin("gm").unwrap();
        let library = crate::motion::pipeline::shipped_library().unwrap();
        let (mut full, mut body) = (
            WindowMotion::new(kit.clone(), map.clone(), HandModel::shipped(), library.clone(), 0.25),
            WindowMotion::new(kit, map, HandModel::shipped(), library, 0.25),
        );
        body.plan_upper_body(false);
        for (i, note) in [36u8, 42, 38, 42, 36, 42, 38, 46, 45, 43].iter().cycle().take(40).enumerate() {
            let e = DrumEvent {
                time_s: 0.5 + i as f64 * 0.11,
                tick: i as u64,
                kind: DrumEventKind::NoteOn { note: *note, velocity: 70 + (i % 5) as u8 * 10 },
            };
            full.push(e);
            body.push(e);
        }
        let (a, b) = (full.plan(4.0).unwrap(), body.plan(4.0).unwrap());
        assert_eq!(a.motion.frames.len(), b.motion.frames.len());
        for (fa, fb) in a.motion.frames.iter().zip(&b.motion.frames) {
            assert_eq!((fa.feet, fa.hihat_openness), (fb.feet, fb.hihat_openness));
        }
        for h in 0..2 {
            assert!(a.hands.notes(h).count() > 5);
            assert!(a.hands.notes(h).eq(b.hands.notes(h)));
            for k in 0..200 {
                let t = a.start_s + k as f64 * 0.0125;
                assert_eq!(a.hands.tip(h, t), b.hands.tip(h, t));
            }
        }
        // The full plan's animation moves its head; the body's leaves it at rest.
        assert!(a.motion.frames.iter().any(|f| f.head != Pose::IDENTITY));
        assert!(b.motion.frames.iter().all(|f| f.head == Pose::IDENTITY && f.face.is_empty()));
    }
}
