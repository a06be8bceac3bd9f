//! Each hand's corrected trajectory: the predicted tip, moved onto its notes' strike
//! points by a smooth offset, and drawn onto a stroke along each surface's normal through
//! the strike point around each note.

use super::{Assignment, HandNote};
use crate::motion::track::Pose;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrokeSettings {
    /// The tip rests on the surface this long either side of the onset (half a 60 fps
    /// frame: the frame nearest the onset always shows the hit).
    pub dwell_s: f64,
    /// Longest preparation and rebound around a note, seconds.
    pub window_s: f64,
    /// Preparatory lift at velocity 1 and 127, metres (it grows as velocity^1.5).
    pub lift_m: (f32, f32),
    /// Rebound speed as a fraction of the downstroke's.
    pub rebound: f32,
    /// Before a hand's first note and after its last, the offset fades over this long.
    pub fade_s: f64,
}

impl Default for StrokeSettings {
    fn default() -> Self {
        StrokeSettings { dwell_s: 1.0 / 120.0, window_s: 0.25, lift_m: (0.02, 0.25), rebound: 0.6, fade_s: 0.5 }
    }
}

/// The planned hands: evaluate anywhere in time (`tip`, `pose`), or sample at a rate.
#[derive(Debug, Clone)]
pub struct PlannedHands {
    predicted: Vec<[Pose; 2]>,
    fps: f64,
    /// Per hand, its notes in time order with the offset that puts the predicted tip on
    /// the strike point.
    notes: [Vec<(HandNote, [f32; 3])>; 2],
    settings: StrokeSettings,
    /// The time of `predicted`'s first frame, s (0 but for a live window's plan moved onto
    /// the session clock, [`PlannedHands::shifted`]).
    origin_s: f64,
}

fn add(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}
fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn scale(a: [f32; 3], k: f32) -> [f32; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}
/// Minimum-jerk blend 0 -> 1.
fn mj(u: f64) -> f32 {
    let u = u.clamp(0.0, 1.0);
    (u * u * u * (10.0 - 15.0 * u + 6.0 * u * u)) as f32
}

/// The hand poses of `predicted` (at `fps`) at time `t`: positions interpolated,
/// rotations normalised-lerped.
fn predicted_pose(predicted: &[[Pose; 2]], fps: f64, hand: usize, t: f64) -> Pose {
    if predicted.is_empty() {
        return Pose::IDENTITY;
    }
    let x = (t * fps).clamp(0.0, (predicted.len() - 1) as f64);
    let k = x.floor() as usize;
    let k1 = (k + 1).min(predicted.len() - 1);
    let a = (x - k as f64) as f32;
    let (p, q) = (predicted[k][hand], predicted[k1][hand]);
    let sign = if dot4(p.rot, q.rot) < 0.0 { -1.0 } else { 1.0 };
    let mut rot: [f32; 4] = std::array::from_fn(|i| p.rot[i] + (sign * q.rot[i] - p.rot[i]) * a);
    let n = dot4(rot, rot).sqrt();
    rot = if n > 1e-6 { rot.map(|v| v / n) } else { Pose::IDENTITY.rot };
    Pose { pos: add(p.pos, scale(sub(q.pos, p.pos), a)), rot }
}

fn dot3(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Across a long gap between two strokes on one drum, the tip's lowest height over it, m,
/// and how far across the surface from the strokes' points the floor holds fully and where
/// it has faded out (`PlannedHands::tip`).
const HOVER_M: f32 = 0.03;
const HOVER_OVER_M: f32 = 0.15;
const HOVER_FADE_M: f32 = 0.3;

/// Deceleration a stick's approach may need to reach its note's speed, m/s^2
/// (`PlannedHands::braked`).
const BRAKE_MPS2: f32 = 40.0;

/// Steepest a wrist stroke turns the stick from the predicted pose, radians.
const MAX_WRIST_TURN: f32 = 1.3;

/// The turn of a stick `v` (grip to tip) about the axis `v x n`, by the angle nearest zero
/// that puts the tip `height` above the plane of normal `n` through the point the grip is
/// `from_plane` away from (the nearest height where none reaches).
fn wrist_turn(v: [f32; 3], from_plane: [f32; 3], n: [f32; 3], height: f32) -> nalgebra::UnitQuaternion<f32> {
    use nalgebra::{Unit, UnitQuaternion, Vector3};
    let (v, n) = (Vector3::from(v), Vector3::from(n));
    let Some(axis) = Unit::try_new(v.cross(&n), 1e-6) else { return UnitQuaternion::identity() };
    // Tip height after turning by phi: g + A cos(phi) + B sin(phi).
    let (a, b) = (v.dot(&n), axis.cross(&v).dot(&n));
    let c = height - Vector3::from(from_plane).dot(&n);
    let r = a.hypot(b);
    if r < 1e-6 {
        return UnitQuaternion::identity();
    }
    let (base, spread) = (b.atan2(a), (c / r).clamp(-1.0, 1.0).acos());
    let wrap = |x: f32| (x + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
    let (p, q) = (wrap(base + spread), wrap(base - spread));
    let phi = if p.abs() <= q.abs() { p } else { q };
    UnitQuaternion::from_axis_angle(&axis, phi.clamp(-MAX_WRIST_TURN, MAX_WRIST_TURN))
}

fn dot4(a: [f32; 4], b: [f32; 4]) -> f32 {
    a.iter().zip(&b).map(|(x, y)| x * y).sum()
}

/// Plan both hands: `predicted` are the hand model's poses at `fps`, `notes` sorted by time,
/// `assignment` from [`super::assign_hands`].
pub fn plan_hands(
    predicted: &[[Pose; 2]],
    fps: f64,
    notes: &[HandNote],
    assignment: &Assignment,
    settings: StrokeSettings,
) -> PlannedHands {
    let mut per_hand: [Vec<(HandNote, [f32; 3])>; 2] = [Vec::new(), Vec::new()];
    for ((n, h), merged) in notes.iter().zip(&assignment.hands).zip(&assignment.merged) {
        if let (Some(h), false) = (*h, *merged) {
            let tip = predicted_pose(predicted, fps, h, n.time_s).stick_tip();
            per_hand[h].push((*n, sub(n.point, tip)));
        }
    }
    PlannedHands { predicted: predicted.to_vec(), fps, notes: per_hand, settings, origin_s: 0.0 }
}

impl PlannedHands {
    /// The index among `hand`'s notes of the one whose stroke holds `t`.
    pub fn note_index(&self, hand: usize, t: f64) -> Option<usize> {
        self.nearest(hand, t)
    }

    /// The note of `hand` nearest `t` (the one whose stroke holds `t`).
    pub fn note_near(&self, hand: usize, t: f64) -> Option<&HandNote> {
        self.nearest(hand, t).map(|k| &self.notes[hand][k].0)
    }

    /// The same plan `by` seconds later: every note and every predicted pose (a live
    /// window's plan, made from time 0 at the window's start, put on the session clock).
    pub fn shifted(mut self, by: f64) -> PlannedHands {
        self.origin_s += by;
        for n in self.notes.iter_mut().flatten() {
            n.0.time_s += by;
        }
        self
    }

    /// The same plan with each note's stroke aimed `lag(note, since)` seconds earlier, where
    /// `since` is the time since the same hand's previous note (infinite for its first): a
    /// stroke known to land late is aimed earlier. The offsets onto the strike points are
    /// taken anew at the moved times, and each hand's notes stay in time order.
    pub fn aimed(&self, lag: impl Fn(&HandNote, f64) -> f64) -> PlannedHands {
        let mut out = self.clone();
        for (hand, notes) in out.notes.iter_mut().enumerate() {
            let (mut before, mut placed) = (f64::NEG_INFINITY, f64::NEG_INFINITY);
            for (n, offset) in notes.iter_mut() {
                let since = n.time_s - before;
                before = n.time_s;
                let t = (n.time_s - lag(n, since)).max(placed + 1e-4);
                n.time_s = t;
                *offset = sub(n.point, predicted_pose(&self.predicted, self.fps, hand, t - self.origin_s).stick_tip());
                placed = t;
            }
        }
        out
    }

    /// The same plan with other stroke settings (the offsets onto the strike points stay).
    pub fn with_settings(&self, settings: StrokeSettings) -> PlannedHands {
        PlannedHands { settings, ..self.clone() }
    }

    /// Note `k` of `hand`.
    pub fn note(&self, hand: usize, k: usize) -> &HandNote {
        &self.notes[hand][k].0
    }

    /// The notes each hand plays.
    pub fn notes(&self, hand: usize) -> impl Iterator<Item = &HandNote> {
        self.notes[hand].iter().map(|(n, _)| n)
    }

    /// The offset added to the predicted tip at `t`.
    fn offset(&self, hand: usize, t: f64) -> [f32; 3] {
        let ns = &self.notes[hand];
        let Some(first) = ns.first() else { return [0.0; 3] };
        let i = ns.partition_point(|(n, _)| n.time_s <= t);
        if i == 0 {
            return scale(first.1, mj(1.0 - (first.0.time_s - t) / self.settings.fade_s));
        }
        let (a, oa) = ns[i - 1];
        match ns.get(i) {
            Some(&(b, ob)) => add(oa, scale(sub(ob, oa), mj((t - a.time_s) / (b.time_s - a.time_s).max(1e-9)))),
            None => scale(oa, 1.0 - mj((t - a.time_s) / self.settings.fade_s)),
        }
    }

    /// The stroke's height above note `k`'s surface at `t`, and its weight (1 on the
    /// surface, 0 at the window's edges).
    fn stroke(&self, hand: usize, k: usize, t: f64) -> (f32, f32) {
        let s = &self.settings;
        let n = &self.notes[hand][k].0;
        let (before, after) = self.windows(hand, k);
        let d = self.dwell(before, after);
        let v = (n.velocity.clamp(1, 127) as f32 / 127.0).powf(1.5);
        let lift = s.lift_m.0 + (s.lift_m.1 - s.lift_m.0) * v;
        let dt = t - n.time_s;
        let (tau, span, speed) =
            if dt < 0.0 { (-dt - d, before - d, n.speed_mps) } else { (dt - d, after - d, n.speed_mps * s.rebound) };
        if tau <= 0.0 {
            return (0.0, 1.0);
        }
        // Rises at `speed` from the surface and levels off at the lift the time allows.
        let lift = lift.min(speed * span.max(0.0) as f32);
        let h = if lift > 0.0 { lift * (speed * tau as f32 / lift).tanh() } else { 0.0 };
        let w = 0.5 * (1.0 + (std::f64::consts::PI * (tau / span.max(1e-9)).min(1.0)).cos()) as f32;
        (h, w)
    }

    /// How long the tip rests on the surface either side of an onset whose windows are
    /// `before` and `after` (at most half of either).
    fn dwell(&self, before: f64, after: f64) -> f64 {
        self.settings.dwell_s.min(0.5 * before).min(0.5 * after)
    }

    /// Note `k`'s preparation and rebound windows: half the time to its neighbours, at most
    /// the settings' window.
    fn windows(&self, hand: usize, k: usize) -> (f64, f64) {
        let (ns, w) = (&self.notes[hand], self.settings.window_s);
        let t = ns[k].0.time_s;
        let before = k.checked_sub(1).map_or(w, |j| (0.5 * (t - ns[j].0.time_s)).min(w));
        let after = ns.get(k + 1).map_or(w, |m| (0.5 * (m.0.time_s - t)).min(w));
        (before, after)
    }

    /// The time the stroke of `hand`'s note `k` holds: from the start of its preparation to
    /// the end of its rebound (seconds).
    pub fn stroke_span(&self, hand: usize, k: usize) -> (f64, f64) {
        let (before, after) = self.windows(hand, k);
        let t = self.notes[hand][k].0.time_s;
        (t - before, t + after)
    }

    /// The note whose window holds `t`: the nearer of its neighbours in time.
    fn nearest(&self, hand: usize, t: f64) -> Option<usize> {
        let ns = &self.notes[hand];
        let i = ns.partition_point(|(n, _)| n.time_s <= t);
        match (i.checked_sub(1), ns.get(i)) {
            (Some(a), Some(b)) => Some(if t - ns[a].0.time_s <= b.0.time_s - t { a } else { i }),
            (Some(a), None) => Some(a),
            (None, Some(_)) => Some(0),
            (None, None) => None,
        }
    }

    /// The planned stick tip of `hand` at `t`.
    pub fn tip(&self, hand: usize, t: f64) -> [f32; 3] {
        let p =
            add(predicted_pose(&self.predicted, self.fps, hand, t - self.origin_s).stick_tip(), self.offset(hand, t));
        let Some(k) = self.nearest(hand, t) else { return p };
        // Within the note's window the tip is drawn onto the stroke line, the normal through
        // the strike point (fully at the hit, fading out with the window): the predicted tip
        // may slide across the surface as the stick rebounds.
        let n = &self.notes[hand][k].0;
        let (h, w) = self.stroke(hand, k, t);
        let on_line = add(n.point, scale(n.normal, h));
        // `i`: the hand's next note after `t`.
        let ns = &self.notes[hand];
        let i = ns.partition_point(|(m, _)| m.time_s <= t);
        let tip = self.braked(hand, i, t, add(p, scale(sub(on_line, p), w)));
        // Between two strokes on one piece the tip stays above the lower of their arcs (the
        // rebound of the one, the preparation of the next): far from both hits the weights
        // hand the tip back to the predicted one, which may pass through the head between
        // two fast strokes; the stick then met the head early, or twice.
        if i == 0 || i >= ns.len() || ns[i - 1].0.piece != ns[i].0.piece {
            return tip;
        }
        let floor = self.stroke(hand, i - 1, t).0.min(self.stroke(hand, i, t).0);
        let height = dot3(sub(tip, n.point), n.normal);
        if ns[i].0.time_s - ns[i - 1].0.time_s <= 2.0 * self.settings.window_s {
            return add(tip, scale(n.normal, (floor - height).max(0.0)));
        }
        // Across a longer gap the whole arc would hold an idle hand high (a rack tom's
        // plane, extended, held one 17 cm up for seconds), but the predicted tip may sink
        // through the head between slow soft strokes (a left hand's ghost notes 0.6-0.9 s
        // apart, 1-3 cm inside the snare): over the drum the tip hovers at least
        // `HOVER_M` above it, the floor fading out from `HOVER_OVER_M` to `HOVER_FADE_M`
        // across the surface from both strokes' points.
        let across = |point: [f32; 3]| {
            let d = sub(tip, point);
            let along = dot3(d, n.normal);
            (dot3(d, d) - along * along).max(0.0).sqrt()
        };
        let lateral = across(ns[i - 1].0.point).min(across(ns[i].0.point));
        let fade = 1.0 - mj(((lateral - HOVER_OVER_M) / (HOVER_FADE_M - HOVER_OVER_M)) as f64);
        add(tip, scale(n.normal, (floor.min(HOVER_M) * fade - height).max(0.0)))
    }

    /// `tip` held under the height from which the stick can still brake to the speed of
    /// note `k`, the hand's next: within that note's preparation window the tip is at most
    /// `speed * tau + brake / 2 * tau^2` above the surface (`tau` the time left before the
    /// touch; the stroke's own arc is under it) over the later half of the window, eased in
    /// over the earlier half (none where the window opens), and fading out across the
    /// surface as the hover does. The blend of the stroke with
    /// a predicted tip held high brought a soft stroke down at 3 m/s to brake a few
    /// millimetres over the head, which no stick does: it met the head 10-20 ms early,
    /// several times as hard as its note.
    fn braked(&self, hand: usize, k: usize, t: f64, tip: [f32; 3]) -> [f32; 3] {
        let Some((n, _)) = self.notes[hand].get(k) else { return tip };
        let (_, w) = self.stroke(hand, k, t);
        let (before, after) = self.windows(hand, k);
        let tau = (n.time_s - self.dwell(before, after) - t).max(0.0) as f32;
        let ceiling = n.speed_mps * tau + 0.5 * BRAKE_MPS2 * tau * tau;
        let off = sub(tip, n.point);
        let height = dot3(off, n.normal);
        let lateral = (dot3(off, off) - height * height).max(0.0).sqrt();
        let fade = 1.0 - mj(((lateral - HOVER_OVER_M) / (HOVER_FADE_M - HOVER_OVER_M)) as f64);
        // Eased in: no ceiling where the window opens, the whole of it at the touch.
        let ceiling = ceiling / ((2.0 * w).min(1.0) * fade).max(1e-6);
        add(tip, scale(n.normal, -(height - ceiling).max(0.0)))
    }

    /// The stick tip's *centre* as the simulated body should aim it at `t`: the planned tip
    /// lifted by the bead's radius `bead_m` along the surface's normal around each hit, so
    /// the bead touches the surface exactly when the planned tip does, and after that touch
    /// carried on down at the stroke's speed, up to `press_m` into the surface (the drum
    /// stops the stick; a target pressing into it is what makes a physical impact at that
    /// speed), until the stick is felt to touch: `contact` is (the note's onset, when the
    /// simulated stick touched that note's piece). `press` is that depth and how long the
    /// target holds there for a stick that has not touched yet (a fast stroke's press is
    /// over in a millisecond, less than the tracking's lag). From the touch, or from the end
    /// of the hold when none came, the tip follows the planned rebound. With `dwell_s` 0 in the
    /// settings the planned touch is at the onset.
    pub fn strike_tip(
        &self,
        hand: usize,
        t: f64,
        bead_m: f32,
        press: (f32, f64),
        contact: Option<(f64, f64)>,
    ) -> [f32; 3] {
        let Some(k) = self.nearest(hand, t) else { return self.tip(hand, t) };
        let n = self.notes[hand][k].0;
        let (press_m, hold_s) = press;
        let press_s = (press_m / n.speed_mps.max(0.1)) as f64;
        let dt = t - n.time_s;
        let touched = contact.filter(|&(onset, _)| (onset - n.time_s).abs() < 1e-9).map(|(_, tc)| tc);
        let (t_plan, below) = match touched {
            Some(tc) if t >= tc => (n.time_s + (t - tc), 0.0),
            _ if dt < 0.0 => (t, 0.0),
            _ if dt < press_s => (n.time_s, n.speed_mps * dt as f32),
            _ if dt < press_s + hold_s => (n.time_s, press_m),
            _ => (t - press_s - hold_s, 0.0),
        };
        let p = self.tip(hand, t_plan);
        let (_, w) = self.stroke(hand, k, t_plan);
        add(p, scale(n.normal, bead_m * w - below))
    }

    /// The planned hand pose at `t`. The grip is the predicted one moved by the smooth
    /// offset alone; the stroke is made with the wrist: the stick turns about the grip, in
    /// the plane of the stick and the surface's normal, until the tip is as high above the
    /// surface as [`Self::tip`] (exactly on it at the hit). So the grip keeps the predicted
    /// hand's timing instead of stopping with the tip at every contact.
    pub fn pose(&self, hand: usize, t: f64) -> Pose {
        let pred = predicted_pose(&self.predicted, self.fps, hand, t - self.origin_s);
        let grip = add(pred.pos, self.offset(hand, t));
        let Some(k) = self.nearest(hand, t) else { return Pose { pos: grip, rot: pred.rot } };
        let n = &self.notes[hand][k].0;
        let tip = self.tip(hand, t);
        let height = dot3(sub(tip, n.point), n.normal);
        let turn = wrist_turn(sub(pred.stick_tip(), pred.pos), sub(grip, n.point), n.normal, height);
        let r = turn * pred.rotation();
        let rot = [r.w, r.i, r.j, r.k];
        // Around the hit the grip also slides the little (within the surface's plane) that
        // puts the tip on the strike point itself, not just at its height: the frame nearest
        // the onset shows the tip on the point, a rim's or edge's too.
        let miss = sub(tip, Pose { pos: grip, rot }.stick_tip());
        let in_plane = sub(miss, scale(n.normal, dot3(miss, n.normal)));
        let dwell = self.settings.dwell_s;
        let near = (2.0 - (t - n.time_s).abs() / dwell).clamp(0.0, 1.0) as f32;
        Pose { pos: add(grip, scale(in_plane, near)), rot }
    }

    /// Both hands at `frames` frames of `fps`.
    pub fn sample(&self, fps: f64, frames: usize) -> Vec<[Pose; 2]> {
        (0..frames).map(|f| [0, 1].map(|h| self.pose(h, self.origin_s + f as f64 / fps))).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::plan::{assign_hands, AssignSettings};

    fn still(frames: usize) -> Vec<[Pose; 2]> {
        // Hands held 20 cm over the kit, sticks pointing forward (+y).
        let l = Pose { pos: [-0.2, 0.1, 0.9], rot: [1.0, 0.0, 0.0, 0.0] };
        let r = Pose { pos: [0.2, 0.1, 0.9], rot: [1.0, 0.0, 0.0, 0.0] };
        vec![[l, r]; frames]
    }

    fn note(t: f64, x: f32, velocity: u8) -> HandNote {
        let z = 0.7;
        HandNote {
            time_s: t,
            piece: 0,
            point: [x, 0.45, z],
            normal: [0.0, 0.0, 1.0],
            velocity,
            speed_mps: 1.0 + 4.0 * velocity as f32 / 127.0,
        }
    }

    fn planned(notes: &[HandNote]) -> PlannedHands {
        let pred = still(600);
        let p = |h: usize, t: f64| predicted_pose(&pred, 60.0, h, t).stick_tip();
        let a = assign_hands(notes, &p, &AssignSettings::default());
        plan_hands(&pred, 60.0, notes, &a, StrokeSettings::default())
    }

    #[test]
    fn the_frame_nearest_each_onset_has_the_tip_on_the_strike_point() {
        let notes: Vec<_> = (0..20)
            .map(|k| note(0.5 + k as f64 * 0.137, if k % 3 == 0 { 0.25 } else { -0.15 }, 40 + 4 * k as u8))
            .collect();
        let plan = planned(&notes);
        let frames = plan.sample(60.0, 600);
        for n in &notes {
            let f = (n.time_s * 60.0).round() as usize;
            let ok = (0..2).any(|h| {
                let tip = frames[f][h].stick_tip();
                sub(tip, n.point).iter().all(|d| d.abs() < 1e-3)
            });
            assert!(ok, "note at {} s", n.time_s);
        }
    }

    #[test]
    fn an_aimed_plan_puts_each_tip_on_its_strike_point_at_the_moved_time() {
        let notes: Vec<_> = (0..20)
            .map(|k| note(0.5 + k as f64 * 0.137, if k % 3 == 0 { 0.25 } else { -0.15 }, 40 + 4 * k as u8))
            .collect();
        let plan = planned(&notes);
        // Loud strokes land 5 ms late, soft ones 3 ms early: aim them 5 ms earlier, 3 later.
        let lag = |n: &HandNote| if n.velocity >= 60 { 0.005 } else { -0.003 };
        let aimed = plan.aimed(|n, since| {
            assert!(since > 0.1, "since {since}");
            lag(n)
        });
        for h in 0..2 {
            let times: Vec<f64> = aimed.notes(h).map(|n| n.time_s).collect();
            assert!(times.windows(2).all(|w| w[0] < w[1]));
            for (before, after) in plan.notes(h).zip(aimed.notes(h)) {
                assert!((after.time_s - (before.time_s - lag(before))).abs() < 1e-12);
                let tip = aimed.tip(h, after.time_s);
                assert!(sub(tip, before.point).iter().all(|d| d.abs() < 1e-4), "{tip:?} vs {:?}", before.point);
            }
        }
    }

    #[test]
    fn between_fast_strokes_on_one_drum_the_tip_stays_above_the_head() {
        // The predicted hand below the head (a hand model's tip passing through it between
        // two strokes); one hand, two soft notes 60 ms apart.
        let pred: Vec<[Pose; 2]> = still(600)
            .into_iter()
            .map(|[l, r]| {
                [Pose { pos: [l.pos[0], l.pos[1], 0.55], ..l }, Pose { pos: [r.pos[0], r.pos[1], 0.55], ..r }]
            })
            .collect();
        let notes = [note(1.0, -0.15, 30), note(1.06, -0.15, 30)];
        let a = crate::motion::plan::Assignment { hands: vec![Some(0); 2], merged: vec![false; 2], dropped: 0 };
        let plan = plan_hands(&pred, 60.0, &notes, &a, StrokeSettings::default());
        let height = |t: f64| plan.tip(0, t)[2] - 0.7;
        // Above the head all the way between the fast pair, on the strokes' arcs.
        for k in 1..60 {
            let t = 1.0 + 0.001 * k as f64;
            assert!(height(t) >= -1e-6, "{:.1} mm at {t:.3} s", height(t) * 1e3);
        }
        // Halfway the weights hand the tip back to the prediction (on the head here, its
        // offset putting it on the strike point); the arcs keep it lifted.
        assert!(height(1.03) > 0.005, "{:.1} mm halfway", height(1.03) * 1e3);
    }

    #[test]
    fn between_slow_soft_strokes_on_one_drum_the_tip_hovers_over_it() {
        // As above, but two ghost notes 0.8 s apart: longer than the strokes' windows.
        let sunk = |z: f32| -> Vec<[Pose; 2]> {
            still(600)
                .into_iter()
                .map(|[l, r]| [Pose { pos: [l.pos[0], l.pos[1], z], ..l }, Pose { pos: [r.pos[0], r.pos[1], z], ..r }])
                .collect()
        };
        let notes = [note(1.0, -0.15, 20), note(1.8, -0.15, 20)];
        let a = crate::motion::plan::Assignment { hands: vec![Some(0); 2], merged: vec![false; 2], dropped: 0 };
        let plan = plan_hands(&sunk(0.55), 60.0, &notes, &a, StrokeSettings::default());
        let height = |t: f64| plan.tip(0, t)[2] - 0.7;
        // Never inside the drum, and HOVER_M above it midway (the prediction, offset onto
        // the strike point at each note, sits on the head there).
        for k in 1..800 {
            let t = 1.0 + 0.001 * k as f64;
            assert!(height(t) >= -1e-6, "{:.1} mm at {t:.3} s", height(t) * 1e3);
        }
        assert!((height(1.4) - HOVER_M).abs() < 1e-4, "{:.1} mm midway", height(1.4) * 1e3);
        // A predicted hand that rises between the notes (10 cm midway) is left where it is.
        let rising: Vec<[Pose; 2]> = sunk(0.55)
            .into_iter()
            .enumerate()
            .map(|(f, [l, r])| {
                let u = ((f as f32 / 60.0 - 1.0) / 0.8).clamp(0.0, 1.0);
                let z = 0.55 + 0.1 * (std::f32::consts::PI * u).sin();
                [Pose { pos: [l.pos[0], l.pos[1], z], ..l }, r]
            })
            .collect();
        let lifted = plan_hands(&rising, 60.0, &notes, &a, StrokeSettings::default());
        assert!((lifted.tip(0, 1.4)[2] - plan.tip(0, 1.4)[2] - (0.1 - HOVER_M)).abs() < 0.01);
    }

    #[test]
    fn a_soft_note_is_approached_slowly_enough_to_brake_for_it() {
        // A loud note, then a ghost note 160 ms later, the predicted hand rising 30 cm
        // between them: blended into the stroke, the prediction would bring the tip down
        // fast and stop it just over the head.
        let pred: Vec<[Pose; 2]> = still(600)
            .into_iter()
            .enumerate()
            .map(|(f, [l, r])| {
                let u = ((f as f32 / 60.0 - 1.0) / 0.16).clamp(0.0, 1.0);
                [Pose { pos: [l.pos[0], l.pos[1], 0.55 + 0.3 * (std::f32::consts::PI * u).sin()], ..l }, r]
            })
            .collect();
        let ghost = HandNote { speed_mps: 0.5, ..note(1.16, -0.15, 8) };
        let notes = [note(1.0, -0.15, 110), ghost];
        let a = crate::motion::plan::Assignment { hands: vec![Some(0); 2], merged: vec![false; 2], dropped: 0 };
        let plan = plan_hands(&pred, 60.0, &notes, &a, StrokeSettings::default());
        let touch = 1.16 - StrokeSettings::default().dwell_s;
        // The later half of the ghost note's window (80 ms before the onset).
        for ms in 1..=35 {
            let tau = ms as f32 * 1e-3;
            let height = plan.tip(0, touch - tau as f64)[2] - 0.7;
            let most = 0.5 * tau + 0.5 * BRAKE_MPS2 * tau * tau;
            assert!(
                height <= most + 1e-4,
                "{:.1} mm {ms} ms before the touch (at most {:.1})",
                height * 1e3,
                most * 1e3
            );
        }
        assert!(plan.tip(0, touch)[2] - 0.7 < 1e-6);
    }

    #[test]
    fn the_tip_comes_down_from_above_faster_for_louder_notes() {
        for (vel, min_speed) in [(30u8, 1.0f32), (120, 4.0)] {
            let n = note(1.0, -0.15, vel);
            let plan = planned(&[n]);
            let h = plan.notes(0).count() + plan.notes(1).count();
            assert_eq!(h, 1);
            let hand = if plan.notes(0).count() == 1 { 0 } else { 1 };
            // Above the surface before the hit, and moving down into it.
            let height = |t: f64| plan.tip(hand, t)[2] - n.point[2];
            assert!(height(0.95) > 0.01, "{}", height(0.95));
            let speed = (height(1.0 - 1.0 / 120.0 - 0.004) - height(1.0 - 1.0 / 120.0)) / 0.004;
            assert!(speed > 0.8 * min_speed, "velocity {vel}: {speed} m/s");
            assert!(height(1.0).abs() < 1e-6);
        }
        // The lift grows with velocity.
        let lift = |vel| {
            let plan = planned(&[note(1.0, -0.15, vel)]);
            let hand = if plan.notes(0).count() == 1 { 0 } else { 1 };
            plan.tip(hand, 0.9)[2] - 0.7
        };
        assert!(lift(120) > lift(30) + 0.05, "{} vs {}", lift(120), lift(30));
    }

    #[test]
    fn strokes_are_made_with_the_wrist_and_the_grip_keeps_its_path() {
        // Loud notes on one drum, 0.4 s apart: big lifts for the tip.
        let notes: Vec<_> = (0..6).map(|k| note(0.5 + k as f64 * 0.4, -0.15, 120)).collect();
        let plan = planned(&notes);
        let hand = if plan.notes(0).count() > 0 { 0 } else { 1 };
        let (mut tip_range, mut grip_range) = ((f32::MAX, f32::MIN), (f32::MAX, f32::MIN));
        for k in 0..2400 {
            let t = 0.5 + k as f64 * 1e-3;
            let pose = plan.pose(hand, t);
            let (tip, want) = (pose.stick_tip(), plan.tip(hand, t));
            // The realised tip is as high above the drum as planned, at every instant.
            assert!((tip[2] - want[2]).abs() < 1e-3, "t {t}: tip height {} vs planned {}", tip[2], want[2]);
            tip_range = (tip_range.0.min(tip[2]), tip_range.1.max(tip[2]));
            if t <= 2.5 {
                grip_range = (grip_range.0.min(pose.pos[2]), grip_range.1.max(pose.pos[2]));
            }
        }
        // The tip lifts by many centimetres; from the first note to the last the grip (still
        // predicted hands, one drum: a constant offset) stays where it was.
        assert!(tip_range.1 - tip_range.0 > 0.1, "tip lift {:?}", tip_range);
        assert!(grip_range.1 - grip_range.0 < 1e-3, "grip moved {:?}", grip_range);
        // At each hit the tip is on the strike point itself.
        for n in &notes {
            let tip = plan.pose(hand, n.time_s).stick_tip();
            assert!(sub(tip, n.point).iter().all(|d| d.abs() < 1e-4), "{:?} vs {:?}", tip, n.point);
        }
    }

    #[test]
    fn the_wrist_turn_reaches_the_height_or_stops_short_without_nan() {
        let n = [0.0, 0.0, 1.0];
        // A 28 cm stick pointing forward and 20 degrees down, the grip 10 cm above the plane.
        let v = [0.0, 0.28 * 20f32.to_radians().cos(), -0.28 * 20f32.to_radians().sin()];
        let from_plane = [0.0, 0.0, 0.1];
        let height = |q: nalgebra::UnitQuaternion<f32>| {
            let tip = q * nalgebra::Vector3::from(v);
            from_plane[2] + tip.z
        };
        for want in [0.0f32, 0.05, 0.15, 0.3] {
            let got = height(wrist_turn(v, from_plane, n, want));
            assert!((got - want).abs() < 1e-4, "height {want}: {got}");
        }
        // Out of reach: turned as far as allowed, upward, still finite.
        let q = wrist_turn(v, from_plane, n, 1.0);
        assert!(q.angle() <= MAX_WRIST_TURN + 1e-5 && height(q) > 0.3, "{} {}", q.angle(), height(q));
        // A stick along the normal has no pitch axis: no turn.
        assert_eq!(wrist_turn([0.0, 0.0, -0.28], from_plane, n, 0.05), nalgebra::UnitQuaternion::identity());
    }

    #[test]
    fn a_moved_kit_moves_the_strikes() {
        let a = planned(&[note(1.0, -0.15, 100)]);
        let mut moved = note(1.0, -0.15, 100);
        moved.point = [-0.3, 0.6, 0.8];
        let b = planned(&[moved]);
        let hit = |p: &PlannedHands| (0..2).map(|h| p.tip(h, 1.0)).collect::<Vec<_>>();
        assert!(hit(&a).iter().any(|t| sub(*t, [-0.15, 0.45, 0.7]).iter().all(|d| d.abs() < 1e-4)));
        assert!(hit(&b).iter().any(|t| sub(*t, [-0.3, 0.6, 0.8]).iter().all(|d| d.abs() < 1e-4)));
    }

    #[test]
    fn between_notes_the_path_is_smooth() {
        let notes: Vec<_> = (0..8).map(|k| note(0.5 + k as f64 * 0.3, -0.15 + 0.06 * k as f32, 90)).collect();
        let plan = planned(&notes);
        // No jumps: consecutive 1 ms samples stay within 1 cm (speeds under 10 m/s).
        for h in 0..2 {
            let mut prev = plan.tip(h, 0.0);
            for k in 1..3000 {
                let t = plan.tip(h, k as f64 * 1e-3);
                assert!(sub(t, prev).iter().all(|d| d.abs() < 0.01), "hand {h} at {} ms", k);
                prev = t;
            }
        }
    }
}
