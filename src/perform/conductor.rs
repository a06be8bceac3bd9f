//! The conductor: the body driven by 250 Hz tip targets, one task period (40 physics steps
//! at 10 kHz) at a time, Algorithm 2's loop. The offline render calls [`Conductor::period`];
//! the live body (`paced.rs`) calls the same on the wall clock, swapping in newer plans.

use super::feet::PedalTargets;
use super::targets::{TargetSettings, TipTargets};
use crate::body::contacts::Strike;
use crate::body::ik::ArmTarget;
use crate::body::model::{Surface, DT_S};
use crate::body::pedals::{PedalBodies, BEATER};
use crate::body::sim::{Drummer, DrummerError, DrummerSettings, Mode};
use crate::body::strokes::TASK_HZ;
use crate::kit::{Kit, PieceKind};
use crate::midi::{NoteMap, Performance};
use crate::motion::pipeline::Planned;
use crate::motion::plan::PlannedHands;
use rapier3d::math::Vector;

/// Physics steps per task period (10 kHz / 250 Hz).
pub const STEPS_PER_PERIOD: usize = 40;

/// A contact this close to the onset of the note the hand is playing is that note's.
pub const TOUCH_WINDOW_S: f64 = 0.030;

/// Time the body spends settling at its first targets (it starts reaching for them) before
/// the song starts, seconds. Its contacts in that time are not part of the performance.
pub const PREROLL_S: f64 = 0.5;

/// Where the body stands: everything a period changes. A clone is a snapshot the
/// offline rehearsal plays a stroke again from ([`Conductor::snapshot`]).
#[derive(Clone)]
pub struct BodyState {
    drummer: Drummer,
    /// Targets at the start of the current period.
    from: [ArmTarget; 2],
    /// Per hand, the last stroke the stick was felt to land: (the note's onset, contact time).
    touched: [Option<(f64, f64)>; 2],
    /// The kick beater and the hi-hat, when the kit has pedals.
    pedals: Option<PedalBodies>,
    /// The last kick the beater was felt to land: (the note's onset, contact time).
    kick_touched: Option<(f64, f64)>,
    /// Performance time of the next period's start, seconds (negative in the preroll).
    t: f64,
}

/// What tip targets need of the drummer: its stick's bead and how long it is from the tip to
/// the butt. Copied out so that another thread can make targets for the body (live play).
#[derive(Debug, Clone, Copy)]
pub struct TargetShape {
    pub bead_m: f32,
    pub shaft_m: f32,
}

impl TargetShape {
    pub fn of(drummer: &Drummer) -> TargetShape {
        let stick = &drummer.skel.stick;
        TargetShape { bead_m: stick.radius_m, shaft_m: (stick.tip() - stick.butt()).length() }
    }

    /// The tip targets of a plan.
    pub fn targets(&self, hands: &PlannedHands) -> TipTargets {
        self.targets_with(hands, TargetSettings::default())
    }

    /// The tip targets of a plan, made with `settings` (live play's: [`TargetSettings::live`]).
    pub fn targets_with(&self, hands: &PlannedHands, settings: TargetSettings) -> TipTargets {
        TipTargets::new(hands, self.bead_m, self.shaft_m, settings)
    }
}

/// The body, its targets and where the song stands.
pub struct Conductor {
    state: BodyState,
    targets: TipTargets,
    /// The pedals' targets, when the kit has pedals.
    pedal_targets: Option<PedalTargets>,
    /// Surface indices of the cymbals (plates without a drum below them).
    plates: Vec<usize>,
    /// The kit piece each surface belongs to (a hoop's is its drum).
    piece_of: Vec<usize>,
    /// The targets the last period ended on before the learned offsets and clearances: where
    /// the plan wants the tips.
    aims: [Vector; 2],
    /// Live play: when `targets` took over from the plan before ([`Conductor::replan`]),
    /// and the plans before it still fading out, oldest first, each with when it took over.
    since: Taken,
    fading: [Option<(TipTargets, Taken)>; FADING],
}

/// When a live plan took over from the plans before it, and how long each hand's fade
/// lasts, s.
#[derive(Debug, Clone, Copy)]
struct Taken {
    at: f64,
    fade: [f64; 2],
}

impl Taken {
    fn over_by(&self) -> f64 {
        self.at + self.fade[0].max(self.fade[1])
    }
}

/// At most this many plans given up are still fading out at once (a new plan every 50 ms,
/// each faded in over at most [`MAX_REPLAN_FADE_S`], overlaps the four before it at most).
pub const FADING: usize = 5;

/// A newer plan takes over from the one before it over this long at least, s: a stroke
/// already under way changes course smoothly, not in one period.
pub const REPLAN_FADE_S: f64 = 0.080;

/// A hand whose new plan differs from where its targets are heads for the new plan no
/// faster than this peak acceleration allows (a minimum-jerk move of `d` over `T` peaks at
/// 5.77 d / T^2), m/s^2, over at most [`MAX_REPLAN_FADE_S`]. A note learned of a lookahead
/// before its stroke rewrites the hand's path, and the hand model puts the hand over its
/// piece well before the stroke: over 80 ms, a left hand sent 30 cm from a tom to the
/// snare's cross-stick moved at 7 m/s and overshot by 10 cm, then met the hoop 14 ms late.
pub const REPLAN_ACCEL_MPS2: f64 = 40.0;
/// The longest a plan takes to fade in, s (30 cm at [`REPLAN_ACCEL_MPS2`]).
pub const MAX_REPLAN_FADE_S: f64 = 0.2;

fn lerp(a: &ArmTarget, b: &ArmTarget, x: f32) -> ArmTarget {
    ArmTarget { tip: a.tip.lerp(b.tip, x), dir: a.dir.lerp(b.dir, x).normalize_or(Vector::Y) }
}

/// Keep hand `h`'s `target` at `t` off the pieces it is not striking and round the plates
/// (`TipTargets::clear` and `keep_out`), its simulated tip at `sim_tip`: every target the
/// arms head for, the period's end, a fast stroke's bottom and a rebound retargeted
/// mid-period alike.
#[allow(clippy::too_many_arguments)]
fn guard(
    targets: &TipTargets,
    plates: &[usize],
    piece_of: &[usize],
    surfaces: &[Surface],
    h: usize,
    t: f64,
    target: &mut ArmTarget,
    sim_tip: Vector,
) {
    targets.clear(h, t, target, surfaces, piece_of);
    targets.keep_out(h, t, target, sim_tip, plates.iter().map(|&i| (i, &surfaces[i])), piece_of);
}

/// Hand `h`'s target at `t` from `targets` (which took over at `since`), blended from the
/// plans before them while they fade out (live play).
fn target_at(
    targets: &TipTargets,
    since: Taken,
    fading: &[Option<(TipTargets, Taken)>; FADING],
    h: usize,
    t: f64,
    touched: Option<(f64, f64)>,
) -> ArmTarget {
    // Each plan fades in from the blend of the plans before it: a plan that comes while the
    // one before is still fading in takes over from where the targets are, not from that
    // plan alone (which left a jump of a fifth of the two plans' difference: 6 cm in one
    // period where a new note sent a hand from a tom to the snare).
    let plans = fading.iter().flatten().map(|(p, s)| (p, *s)).chain(std::iter::once((targets, since)));
    // A plan whose fade is over by `t` hides the plans before it: start from the last such.
    let hidden = plans.clone().enumerate().filter(|(_, (_, s))| t >= s.at + s.fade[h]).map(|(k, _)| k).last();
    let mut acc: Option<ArmTarget> = None;
    for (plan, since) in plans.skip(hidden.unwrap_or(0)) {
        let new = plan.at(h, t, touched);
        acc = Some(match acc {
            Some(old) if t < since.at + since.fade[h] => {
                let w = ((t - since.at) / since.fade[h]).clamp(0.0, 1.0) as f32;
                // Minimum-jerk weight: no kink where the fade starts or ends.
                let w = w * w * w * (10.0 - 15.0 * w + 6.0 * w * w);
                lerp(&old, &new, w)
            }
            _ => new,
        });
    }
    acc.unwrap_or_else(|| targets.at(h, t, touched))
}

/// The task period (from the preroll's start) that ends at performance time `t`.
pub fn period_index(t: f64) -> usize {
    ((t + PREROLL_S) * TASK_HZ).round().max(0.0) as usize
}

impl BodyState {
    /// Performance time of the next period, seconds.
    pub fn time_s(&self) -> f64 {
        self.t
    }
}

impl Conductor {
    /// The body for `perf` as the motion stage `planned` it, on `kit`.
    pub fn new(
        kit: &Kit,
        perf: &Performance,
        map: &NoteMap,
        planned: &Planned,
        settings: DrummerSettings,
    ) -> Result<Conductor, DrummerError> {
        Conductor::new_with(kit, perf, map, planned, settings, TargetSettings::default())
    }

    /// [`Conductor::new`] with the tip targets made with `targets` (the lag model learns
    /// from straight play with live play's, [`TargetSettings::live`]).
    pub fn new_with(
        kit: &Kit,
        perf: &Performance,
        map: &NoteMap,
        planned: &Planned,
        settings: DrummerSettings,
        targets: TargetSettings,
    ) -> Result<Conductor, DrummerError> {
        let ready = Drummer::new(kit, settings.clone())?;
        let targets = TargetShape::of(&ready).targets_with(&planned.hands, targets);
        // The arms start at their first targets, kept clear of the kit as every target is
        // (a take's first frame may lay a tip on the head it strikes at once): the preroll
        // only settles them.
        let first = Conductor::assemble(kit, ready, targets, None, None, -PREROLL_S);
        let start = first.guarded_start();
        let drummer = Drummer::new_at(kit, settings, Some(&start))?;
        let targets = first.targets;
        let bodies = PedalBodies::new(kit);
        let pedal_targets = bodies.as_ref().map(|b| PedalTargets::new(perf, map, kit, b, &planned.motion));
        Ok(Conductor::assemble(kit, drummer, targets, bodies, pedal_targets, -PREROLL_S))
    }

    /// The live body: it starts at session time `t0` on the first window's targets, and
    /// takes each newer window's with [`Self::replan`].
    pub fn live(
        kit: &Kit,
        settings: DrummerSettings,
        targets: TipTargets,
        pedal_targets: Option<PedalTargets>,
        t0: f64,
    ) -> Result<Conductor, DrummerError> {
        let drummer = Drummer::new(kit, settings)?;
        let bodies = PedalBodies::new(kit);
        let pedal_targets = pedal_targets.filter(|_| bodies.is_some());
        Ok(Conductor::assemble(kit, drummer, targets, bodies, pedal_targets, t0))
    }

    fn assemble(
        kit: &Kit,
        drummer: Drummer,
        targets: TipTargets,
        bodies: Option<PedalBodies>,
        pedal_targets: Option<PedalTargets>,
        t: f64,
    ) -> Conductor {
        let plates = drummer
            .surfaces()
            .iter()
            .enumerate()
            .filter(|(i, s)| kit.pieces[*i].kind == PieceKind::Plate && !s.id.ends_with("_rim"))
            .map(|(i, _)| i)
            .collect();
        let piece_of = drummer
            .surfaces()
            .iter()
            .enumerate()
            .map(|(i, s)| s.id.strip_suffix("_rim").and_then(|d| kit.index_of(d)).unwrap_or(i))
            .collect();
        let from = [targets.at(0, t, None), targets.at(1, t, None)];
        let state = BodyState { drummer, from, touched: [None; 2], pedals: bodies, kick_touched: None, t };
        Conductor {
            state,
            targets,
            pedal_targets,
            plates,
            piece_of,
            aims: [from[0].tip, from[1].tip],
            since: Taken { at: f64::NEG_INFINITY, fade: [REPLAN_FADE_S; 2] },
            fading: Default::default(),
        }
    }

    /// The targets the first period starts from, kept clear of the kit ([`guard`]) as if
    /// the tips were already there.
    fn guarded_start(&self) -> [ArmTarget; 2] {
        let surfaces = self.state.drummer.surfaces();
        std::array::from_fn(|h| {
            let mut a = self.state.from[h];
            let tip = a.tip;
            guard(&self.targets, &self.plates, &self.piece_of, surfaces, h, self.state.t, &mut a, tip);
            a
        })
    }

    /// Follow a newer plan from the next period on (live play), faded in from where the
    /// targets are over [`REPLAN_FADE_S`] or longer (a hand sent far, [`REPLAN_ACCEL_MPS2`]);
    /// the plans given up (those no longer fading, and the pedals') are returned, to be
    /// dropped off the physics thread.
    pub fn replan(&mut self, targets: TipTargets, pedal_targets: Option<PedalTargets>) -> super::paced::Spent {
        let now = self.state.t;
        // Each hand's fade: how far the new plan is from where its targets are, over the
        // fade's first 80 ms.
        let fade: [f64; 2] = std::array::from_fn(|h| {
            let touched = self.state.touched[h];
            let far = [0.0, 0.5, 1.0]
                .map(|x| {
                    let t = now + x * REPLAN_FADE_S;
                    let was = target_at(&self.targets, self.since, &self.fading, h, t, touched);
                    (targets.at(h, t, touched).tip - was.tip).length()
                })
                .into_iter()
                .fold(0.0f32, f32::max);
            (5.77 * f64::from(far) / REPLAN_ACCEL_MPS2).sqrt().clamp(REPLAN_FADE_S, MAX_REPLAN_FADE_S)
        });
        let old = std::mem::replace(&mut self.targets, targets);
        let old_since = std::mem::replace(&mut self.since, Taken { at: now, fade });
        let mut given: [Option<TipTargets>; FADING] = Default::default();
        let mut out = 0;
        if self.fading[FADING - 1].is_some() {
            // Full (plans coming faster than they fade): the oldest goes.
            given[out] = self.fading[0].take().map(|(p, _)| p);
            out += 1;
            self.fading.rotate_left(1);
        }
        if let Some(slot) = self.fading.iter_mut().find(|f| f.is_none()) {
            *slot = Some((old, old_since));
        }
        // A plan whose fade is over hides every plan before it from now on.
        let n = self.fading.iter().filter(|f| f.is_some()).count();
        let done = (1..n).rev().find(|&j| self.fading[j].as_ref().is_some_and(|(_, s)| s.over_by() <= now));
        if let Some(j) = done {
            for k in 0..j {
                let plan = self.fading[k].take().map(|(p, _)| p);
                if let Some(slot) = given.get_mut(out) {
                    *slot = plan;
                    out += 1;
                }
            }
            self.fading.rotate_left(j);
        }
        let old_pedals = match (pedal_targets, &mut self.pedal_targets) {
            (Some(new), Some(current)) => Some(std::mem::replace(current, new)),
            _ => None,
        };
        (given, old_pedals)
    }

    /// Let `n` task periods go by unplayed (a live body that fell behind the wall clock):
    /// the body stays as it is and takes up the targets of the period after them.
    pub fn skip_periods(&mut self, n: usize) {
        self.state.t += n as f64 / TASK_HZ;
    }

    /// A copy of where the body stands, to go back to with [`Self::restore`].
    pub fn snapshot(&self) -> BodyState {
        self.state.clone()
    }

    /// Go back to a [`Self::snapshot`]: the body steps from there exactly as it did then,
    /// but for the targets' corrections made since.
    pub fn restore(&mut self, snapshot: &BodyState) {
        self.state.clone_from(snapshot);
    }

    /// The targets, to correct strokes ([`TipTargets::offsets_mut`]).
    pub fn targets_mut(&mut self) -> &mut TipTargets {
        &mut self.targets
    }

    pub fn targets(&self) -> &TipTargets {
        &self.targets
    }

    /// The kit piece each of the body's surfaces belongs to (a hoop's is its drum).
    pub fn piece_of(&self) -> &[usize] {
        &self.piece_of
    }

    /// Performance time of the next period, seconds.
    pub fn time_s(&self) -> f64 {
        self.state.t
    }

    /// What tip targets for this body need.
    pub fn target_shape(&self) -> TargetShape {
        TargetShape::of(&self.state.drummer)
    }

    pub fn drummer(&self) -> &Drummer {
        &self.state.drummer
    }

    /// The pedal bodies, when the kit has pedals.
    pub fn pedals(&self) -> Option<&PedalBodies> {
        self.state.pedals.as_ref()
    }

    /// Where the plan wanted the tips at the end of the last period (before the learned
    /// offsets and the clearances).
    pub fn aims(&self) -> [Vector; 2] {
        self.aims
    }

    /// The targets the last period ended on.
    pub fn last_targets(&self) -> &[ArmTarget; 2] {
        &self.state.from
    }

    /// One task period: the targets at its end, then 40 physics steps toward targets
    /// interpolated from the previous period's. New strikes go to `sink` with their time in
    /// performance seconds.
    pub fn period(&mut self, sink: &mut impl FnMut(Strike)) {
        self.period_observed(sink, &mut |_, _, _| {});
    }

    /// [`Self::period`], showing `observe` the body, the step's performance time and its
    /// targets after every physics step (for traces and tests).
    pub fn period_observed(
        &mut self,
        sink: &mut impl FnMut(Strike),
        observe: &mut impl FnMut(&Drummer, f64, &[ArmTarget; 2]),
    ) {
        let st = &mut self.state;
        let t1 = st.t + 1.0 / TASK_HZ;
        let sim = st.drummer.tips(Mode::Himc);
        let p1 = period_index(t1);
        let mut to = [
            target_at(&self.targets, self.since, &self.fading, 0, t1, st.touched[0]),
            target_at(&self.targets, self.since, &self.fading, 1, t1, st.touched[1]),
        ];
        self.aims = to.map(|a| a.tip);
        let surfaces = st.drummer.surfaces();
        for (h, target) in to.iter_mut().enumerate() {
            target.tip += self.targets.offset(h, p1);
            guard(&self.targets, &self.plates, &self.piece_of, surfaces, h, t1, target, sim[h]);
        }
        let offset = st.drummer.time_s() - st.t;
        // A stroke that bottoms out inside the period passes through its deepest target at
        // that step (`via`), before heading for the period's end.
        let via: [Option<(usize, ArmTarget)>; 2] = std::array::from_fn(|h| {
            let tb = self.targets.bottom_within(h, st.t, t1)?;
            let kv = (((tb - st.t) / DT_S as f64).round() as usize).clamp(1, STEPS_PER_PERIOD - 1);
            let mut v = target_at(&self.targets, self.since, &self.fading, h, tb, st.touched[h]);
            v.tip += self.targets.offset(h, p1);
            guard(&self.targets, &self.plates, &self.piece_of, surfaces, h, tb, &mut v, sim[h]);
            Some((kv, v))
        });
        // Each hand's interpolation runs from `start` at step `k0` to `to` at the period's end
        // (through `via` while it lies ahead).
        let mut start = st.from;
        let mut k0 = [0usize; 2];
        for k in 0..STEPS_PER_PERIOD {
            let tg: [ArmTarget; 2] = std::array::from_fn(|h| {
                let (end, k1) = match via[h] {
                    Some((kv, v)) if k < kv && k0[h] < kv => (v, kv),
                    Some((kv, v)) if k0[h] < kv => {
                        // Past the bottom: from it to the period's end.
                        let a = (k + 1 - kv) as f32 / (STEPS_PER_PERIOD - kv) as f32;
                        return lerp(&v, &to[h], a);
                    }
                    _ => (to[h], STEPS_PER_PERIOD),
                };
                lerp(&start[h], &end, (k + 1 - k0[h]) as f32 / (k1 - k0[h]) as f32)
            });
            let before = st.touched;
            let (targets, piece_of, touched) = (&self.targets, &self.piece_of, &mut st.touched);
            st.drummer.step_tips(Mode::Himc, &tg, &mut |mut s: Strike| {
                s.time_s -= offset;
                // The hand feels its stroke land: its targets rebound from here.
                if let Some(onset) = targets.note_touched(s.side, s.time_s, piece_of[s.surface], TOUCH_WINDOW_S) {
                    touched[s.side] = Some((onset, s.time_s));
                }
                sink(s)
            });
            observe(&st.drummer, st.t + (k + 1) as f64 * DT_S as f64, &tg);
            if let (Some(bodies), Some(targets)) = (&mut st.pedals, &self.pedal_targets) {
                let t = st.t + (k + 1) as f64 * DT_S as f64;
                let kick_touched = &mut st.kick_touched;
                let (beater, hihat) = (targets.beater(t, *kick_touched), targets.hihat(t));
                bodies.step(beater, hihat, t, &mut |s: Strike| {
                    if s.side == BEATER {
                        if let Some(onset) = targets.kick_near(s.time_s, TOUCH_WINDOW_S) {
                            *kick_touched = Some((onset, s.time_s));
                        }
                    }
                    sink(s)
                });
            }
            for h in 0..2 {
                if st.touched[h] != before[h] && k + 1 < STEPS_PER_PERIOD {
                    // Mid-period: the rest of the period heads for the rebound at once.
                    to[h] = target_at(&self.targets, self.since, &self.fading, h, t1, st.touched[h]);
                    self.aims[h] = to[h].tip;
                    to[h].tip += self.targets.offset(h, p1);
                    let (surfaces, tip) = (st.drummer.surfaces(), st.drummer.tips(Mode::Himc)[h]);
                    guard(&self.targets, &self.plates, &self.piece_of, surfaces, h, t1, &mut to[h], tip);
                    start[h] = tg[h];
                    k0[h] = k + 1;
                }
            }
        }
        st.from = to;
        st.t = t1;
        debug_assert!((st.drummer.time_s() - offset - st.t).abs() < DT_S as f64);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::plan::{plan_hands, Assignment, StrokeSettings};
    use crate::motion::track::Pose;

    /// Tip targets that hold both hands still, the left one at `left`.
    fn still_at(shape: &TargetShape, left: [f32; 3]) -> TipTargets {
        let l = Pose { pos: left, rot: [1.0, 0.0, 0.0, 0.0] };
        let r = Pose { pos: [0.3, 0.0, 2.0], rot: [1.0, 0.0, 0.0, 0.0] };
        let none = Assignment { hands: Vec::new(), merged: Vec::new(), dropped: 0 };
        shape.targets(&plan_hands(&vec![[l, r]; 60], 60.0, &[], &none, StrokeSettings::default()))
    }

    #[test]
    fn a_plan_that_comes_while_the_one_before_fades_in_takes_over_from_where_the_targets_are() {
        let kit = Kit::builtin_default();
        let settings = DrummerSettings::default();
        let shape = TargetShape::of(&Drummer::new(&kit, settings.clone()).unwrap());
        // High over the kit, clear of every piece: the targets are the plans' own.
        let (a, b) = ([-0.3, 0.0, 2.0], [-0.3, 0.3, 2.0]);
        let mut c = Conductor::live(&kit, settings, still_at(&shape, a), None, 0.0).unwrap();
        let mut tips = vec![c.aims()[0]];
        for p in 0..120 {
            // A plan with the hand 30 cm away, then (50 ms later, the first still fading in)
            // the same plan again: live play's plans every 50 ms.
            if p == 2 || p == 14 {
                let (given, _) = c.replan(still_at(&shape, b), None);
                assert!(given.iter().all(Option::is_none), "the plans before still fade");
            }
            c.period(&mut |_| {});
            tips.push(c.aims()[0]);
        }
        let step = tips.windows(2).map(|w| (w[1] - w[0]).length()).fold(0.0f32, f32::max);
        let dt = 1.0 / TASK_HZ as f32;
        let accel = tips.windows(3).map(|w| (w[2] - 2.0 * w[1] + w[0]).length() / (dt * dt)).fold(0.0f32, f32::max);
        let end = tips[tips.len() - 1];
        eprintln!("largest step {:.2} cm a period, acceleration {accel:.0} m/s^2", step * 100.0);
        // 30 cm, minimum-jerk, the acceleration near the one allowed (two fades overlapping:
        // 1.3 cm a period at most, 58 m/s^2). A plan taking over from the one fading in
        // alone jumped 9.5 cm in a period.
        assert!(step < 0.015, "the target jumped {:.1} cm in a period", step * 100.0);
        assert!(accel < 1.5 * REPLAN_ACCEL_MPS2 as f32, "{accel:.0} m/s^2");
        assert!((end - tips[0] - Vector::new(0.0, 0.3, 0.0)).length() < 1e-3, "ends on the new plan: {end:?}");
        // A third plan, the fades over: the two before are given back.
        let (given, _) = c.replan(still_at(&shape, b), None);
        assert_eq!(given.iter().filter(|g| g.is_some()).count(), 2);
    }
}
