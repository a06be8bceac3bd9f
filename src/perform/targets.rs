//! The body's 250 Hz stick-tip targets from the planned hands.
//!
//! The motion stage plans where each stick tip *is*; the body needs where to *aim*. Three
//! things differ:
//! - the tip's bead has a radius: the planned tip on the strike point becomes the bead's
//!   centre that far above it, so the bead touches the surface exactly at the onset;
//! - an impact needs a stick still moving into the surface when it arrives: after the
//!   touch the target carries on down at the stroke's speed for a few millimetres (the drum
//!   stops the stick; the body clamps targets inside a drum to 1 cm below its head);
//! - the planned travel knows nothing of the kit's solids: a tip below a cymbal's plane and
//!   under it is aimed radially out past its edge until it has come up beside it, so a
//!   stick never gets caught under the hi-hat or a crash on its way to strike it, and one
//!   over a cymbal goes out past its edge before it heads below it; targets keep the bead
//!   clear of pieces not being struck, and the whole stick clear of drum heads and hoops
//!   and of the cymbals it lies over; a stick whose tip is below a cymbal's plane and whose
//!   hand is above it swings about its tip until its shaft passes outside the edge.

use crate::body::ik::ArmTarget;
use crate::body::model::Surface;
use crate::body::model::{HOOP_HEIGHT_M, HOOP_RADIUS_M};
use crate::motion::plan::{PlannedHands, StrokeSettings};
use rapier3d::math::Vector;

/// How the targets are made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetSettings {
    /// How far past the touch the target presses into the surface, m, and how long it holds
    /// there for a stick that has not touched yet, s.
    pub press_m: f32,
    pub press_hold_s: f64,
    /// Clearance kept around a plate's edge while the tip is below its plane, m.
    pub plate_clearance_m: f32,
    /// How far below a plate's plane the keep-out reaches, m.
    pub plate_keepout_depth_m: f32,
    /// Height the bead keeps above a piece it is not striking, m.
    pub clearance_m: f32,
    /// How far below a surface a target is still raised by the clearance, m, at least (a
    /// drum's whole depth: a target inside its shell is raised out).
    pub clearance_depth_m: f32,
    /// The struck piece is exempt from the clearance this long before the onset and after.
    pub guard_before_s: f64,
    pub guard_after_s: f64,
    /// The stick's direction is held this long before each onset and after it (then eased
    /// back to the plan's over as long again, within the stroke's window), s: see
    /// [`TipTargets::at`]. 0 offline, where the rehearsal corrects each stroke;
    /// [`LIVE_DIR_HOLD_S`] in live play ([`TargetSettings::live`]).
    pub dir_hold_s: f64,
}

impl Default for TargetSettings {
    fn default() -> Self {
        TargetSettings {
            press_m: 0.010,
            press_hold_s: 0.005,
            plate_clearance_m: 0.03,
            plate_keepout_depth_m: 0.15,
            clearance_m: 0.015,
            clearance_depth_m: 0.02,
            guard_before_s: 0.040,
            guard_after_s: 0.025,
            dir_hold_s: 0.0,
        }
    }
}

impl TargetSettings {
    /// Live play's: the defaults with the stick's angle held over each stroke's last
    /// millimetres ([`LIVE_DIR_HOLD_S`]).
    pub fn live() -> TargetSettings {
        TargetSettings { dir_hold_s: LIVE_DIR_HOLD_S, ..TargetSettings::default() }
    }
}

/// How long live play holds the stick's angle before each onset and after it, s. Live play
/// has no rehearsal to play a stalled stroke again. Measured on six Groove MIDI validation
/// takes, 30 s each, on the simulated clock (`cargo run --release --example live_physical
/// -- --live-only`): hand strokes under half their note's speed 0-10.5 % per take without
/// the hold, 0-7 % with it; recall 92.33 -> 94.08 %, precision 90.40 -> 92.78 %, timing sd
/// 2.52 -> 2.27 ms. The median speed over the asked one depends on the hold (3 ms: 0.7-1.0,
/// 6 ms: 1.0-1.3, 12 ms: 1.2-1.5); offline (with the rehearsal) over the validation split
/// a 6 ms hold gained recall (99.13 -> 99.25 %) and precision (98.70 -> 98.86 %) but lost
/// strike-point precision (IPD p95 11.1 -> 12.4 mm) and the velocity-speed rank correlation
/// (0.942 -> 0.923), so the offline render does not hold.
pub const LIVE_DIR_HOLD_S: f64 = 0.006;

/// A surface solid this deep below it is a drum (a shell under its head), not a cymbal, m.
const SHELL_MIN_DEPTH_M: f32 = 0.05;

/// Points along the shaft checked against a drum's head and hoop (about 4 cm apart on a
/// 41 cm stick).
const SHAFT_SAMPLES: usize = 10;

/// Tip targets for both hands, evaluated at any time.
pub struct TipTargets {
    planned: PlannedHands,
    bead_m: f32,
    /// From the tip to the butt along the stick, m (the grip is on the way: the butt behind
    /// the hand struck the hi-hat and the toms as well as the shaft before it).
    shaft_m: f32,
    settings: TargetSettings,
    /// Per hand, the rehearsal's learned offset of the target at each task period (from
    /// the preroll's start; empty until the rehearsal writes one).
    offsets: [Vec<Vector>; 2],
    /// Per hand and kit piece, a learned aim correction applied to every stroke there (the
    /// rehearsal's feedforward: a hand that lands short on a piece lands short every time).
    bias: [Vec<Vector>; 2],
}

impl TipTargets {
    /// From the motion stage's plan: the same strokes, touching at the onset itself (no
    /// dwell), aimed for a bead of radius `bead_m` on a stick `shaft_m` long from its tip to its butt.
    pub fn new(planned: &PlannedHands, bead_m: f32, shaft_m: f32, settings: TargetSettings) -> TipTargets {
        let planned = planned.with_settings(StrokeSettings { dwell_s: 0.0, ..StrokeSettings::default() });
        let pieces = [0, 1].into_iter().flat_map(|h| planned.notes(h).map(|n| n.piece + 1)).max().unwrap_or(0);
        let bias = [vec![Vector::ZERO; pieces], vec![Vector::ZERO; pieces]];
        TipTargets { planned, bead_m, shaft_m, settings, offsets: [Vec::new(), Vec::new()], bias }
    }

    /// The plan the targets follow.
    pub fn planned(&self) -> &PlannedHands {
        &self.planned
    }

    /// The learned offset of `hand`'s target at task period `p`.
    pub fn offset(&self, hand: usize, p: usize) -> Vector {
        self.offsets[hand].get(p).copied().unwrap_or(Vector::ZERO)
    }

    /// The learned offsets of `hand`'s targets, one per task period, grown to `periods`.
    pub fn offsets_mut(&mut self, hand: usize, periods: usize) -> &mut [Vector] {
        let o = &mut self.offsets[hand];
        if o.len() < periods {
            o.resize(periods, Vector::ZERO);
        }
        o
    }

    /// The learned aim correction of `hand`'s strokes on kit piece `piece`.
    pub fn bias_mut(&mut self, hand: usize, piece: usize) -> &mut Vector {
        &mut self.bias[hand][piece]
    }

    /// The target of `hand` at `t` (before the clearance and keep-out, which need the body's
    /// state). `contact`: (a note's onset, when the simulated stick touched its piece).
    pub fn at(&self, hand: usize, t: f64, contact: Option<(f64, f64)>) -> ArmTarget {
        let press = (self.settings.press_m, self.settings.press_hold_s);
        let mut tip = Vector::from(self.planned.strike_tip(hand, t, self.bead_m, press, contact));
        if let Some(k) = self.planned.note_index(hand, t) {
            // The piece's aim correction, whole at the hit, easing out to the stroke's edges.
            let n = self.planned.note(hand, k);
            let (from, to) = self.planned.stroke_span(hand, k);
            let x = if t < n.time_s { (n.time_s - t) / (n.time_s - from) } else { (t - n.time_s) / (to - n.time_s) };
            let w = 0.5 * (1.0 + (std::f64::consts::PI * x.clamp(0.0, 1.0)).cos());
            tip += self.bias[hand][n.piece] * w as f32;
        }
        let dir_at = |t: f64| {
            let pose = self.planned.pose(hand, t);
            let y = pose.apply([0.0, 1.0, 0.0]);
            Vector::new(y[0] - pose.pos[0], y[1] - pose.pos[1], y[2] - pose.pos[2]).normalize_or(Vector::Y)
        };
        let mut dir = dir_at(t);
        if let Some(k) = self.planned.note_index(hand, t) {
            // The last millimetres of a stroke come down with the stick's angle held. The
            // plan turns the wrist as the tip nears the surface (the grip's turn toward the
            // strike point); the simulated arm lags that turn by up to a degree, 5 mm at the
            // tip, and the stick stalled above the surface and touched it at a fraction of
            // its speed: on a Groove MIDI take 11 % of hand strokes played straight through
            // landed at under half their note's speed (hi-hat strokes, 0.13 m/s for 1.1).
            // Held from `dir_hold_s` before the onset to as long after, eased in and out over
            // as long again; the holds of neighbouring notes never meet.
            let n = self.planned.note(hand, k);
            let (from, to) = self.planned.stroke_span(hand, k);
            let hold_before = self.settings.dir_hold_s.min(0.5 * (n.time_s - from));
            let hold_after = self.settings.dir_hold_s.min(0.5 * (to - n.time_s));
            let x = if t < n.time_s { (n.time_s - t) / hold_before } else { (t - n.time_s) / hold_after };
            if hold_before > 0.0 && hold_after > 0.0 && x < 2.0 {
                let held = dir_at(n.time_s - hold_before);
                let w = (2.0 - x).clamp(0.0, 1.0);
                // Smoothstep: no kink where the hold is eased in or out.
                let w = (w * w * (3.0 - 2.0 * w)) as f32;
                dir = dir.lerp(held, w).normalize_or(held);
            }
        }
        ArmTarget { tip, dir }
    }

    /// When the stroke of `hand` bottoms out (its press is deepest: the onset plus the time
    /// the press takes at the stroke's speed) between `t0` and `t1`, that time: a fast
    /// stroke's whole press fits inside one task period, and a target interpolated between
    /// the period's ends would never reach down to it.
    pub fn bottom_within(&self, hand: usize, t0: f64, t1: f64) -> Option<f64> {
        let n = self.planned.note_near(hand, 0.5 * (t0 + t1))?;
        // A hair before the press ends (at its end the target turns to the rebound).
        let tb = n.time_s + (self.settings.press_m / n.speed_mps.max(0.1)) as f64 - 1e-5;
        (tb > t0 && tb < t1).then_some(tb)
    }

    /// Keep `target` of `hand` at `t` clear of every surface its stroke is not striking: a
    /// target over a piece (within its radius and the bead's) lower than the bead plus
    /// [`TargetSettings::clearance_m`] above it is raised to that height. The piece of the
    /// hand's nearest note is exempt from `guard_before_s` before its onset to
    /// `guard_after_s` after it (`piece_of[i]`: the kit piece surface `i` belongs to, a hoop's
    /// being its drum's). So a stick neither rests nor grazes where no note is, nor
    /// bounces a second time on the piece it has just struck.
    pub fn clear(&self, hand: usize, t: f64, target: &mut ArmTarget, surfaces: &[Surface], piece_of: &[usize]) {
        let s = &self.settings;
        let note = self.planned.note_near(hand, t);
        let floor = self.bead_m + s.clearance_m;
        for (i, surface) in surfaces.iter().enumerate() {
            if let Some(n) = note {
                let dt = t - n.time_s;
                if piece_of[i] == n.piece && dt > -s.guard_before_s && dt < s.guard_after_s {
                    continue;
                }
            }
            if piece_of[i] != i {
                // A drum's hoop: the bead keeps the clearance off its tube, whichever side.
                self.clear_hoop(target, &surfaces[piece_of[i]]);
                continue;
            }
            // Below a drum's head is inside its shell: out. Deep below a cymbal is under
            // it, which the keep-out handles.
            let deepest = s.clearance_depth_m.max(surface.depth_m);
            let over = |p: Vector| {
                let h = surface.height(p);
                let planar = p - surface.center - surface.normal * h;
                (h < floor && h >= -deepest && planar.length() <= surface.radius_m + self.bead_m).then_some(floor - h)
            };
            if let Some(up) = over(target.tip) {
                target.tip += surface.normal * up;
            }
            if surface.depth_m >= SHELL_MIN_DEPTH_M {
                // A drum's head is solid under the whole shaft too: a stick held low beside
                // a drum, pointing into it, is raised until the shaft clears the head.
                let lift = self.shaft_points(target).filter_map(over).fold(0.0f32, f32::max);
                target.tip += surface.normal * lift;
            } else {
                // A cymbal: a shaft lying over it, or level with its edge, is raised clear of
                // it; one under it is the keep-out's.
                let lift = self
                    .shaft_points(target)
                    .filter(|&p| surface.height(p) >= -self.bead_m)
                    .filter_map(over)
                    .fold(0.0f32, f32::max);
                target.tip += surface.normal * lift;
            }
        }
    }

    /// Points along `target`'s stick from beside the tip to the butt.
    fn shaft_points(&self, target: &ArmTarget) -> impl Iterator<Item = Vector> + '_ {
        let (tip, dir) = (target.tip, target.dir);
        (1..=SHAFT_SAMPLES).map(move |k| tip - dir * (self.shaft_m * k as f32 / SHAFT_SAMPLES as f32))
    }

    /// Keep `target`'s stick [`TargetSettings::clearance_m`] off the hoop of `drum` (a ring
    /// tube just outside its head and a little above it, as the body's colliders build it):
    /// the bead pushed straight away from the ring's nearest point, then the whole stick
    /// raised along the drum's normal until its shaft, from the tip to the butt, clears the
    /// ring too (a hand low by the drum's edge would otherwise lever the stick on the hoop as
    /// it lifts the tip).
    fn clear_hoop(&self, target: &mut ArmTarget, drum: &Surface) {
        let ring = drum.center + drum.normal * HOOP_HEIGHT_M;
        let ring_r = drum.radius_m + HOOP_RADIUS_M;
        let want = HOOP_RADIUS_M + self.bead_m + self.settings.clearance_m;
        // The point of the ring's centre line nearest `p`.
        let nearest = |p: Vector| {
            let planar = (p - ring).reject_from(drum.normal);
            let r = planar.length();
            (r > 1e-6).then(|| ring + planar * (ring_r / r))
        };
        if let Some(q) = nearest(target.tip) {
            let away = target.tip - q;
            if away.length() < want {
                target.tip = q + away.normalize_or(drum.normal) * want;
            }
        }
        // The shaft: raised by what its closest point to the ring needs.
        let mut lift = 0.0f32;
        for p in self.shaft_points(target) {
            let Some(q) = nearest(p) else { continue };
            let (d, up) = ((p - q).length(), (p - q).dot(drum.normal));
            if d < want {
                // Up until the point is `want` from the ring's centre line, straight above it
                // at most (a point beside the tube needs less).
                let across = (p - q).reject_from(drum.normal).length();
                lift = lift.max((want * want - across * across).max(0.0).sqrt() - up);
            }
        }
        target.tip += drum.normal * lift;
    }

    /// The onset of the note `hand` is playing at `t`, if the stick touching `piece` then
    /// is that note's contact: its piece, within `window_s` of its onset.
    pub fn note_touched(&self, hand: usize, t: f64, piece: usize, window_s: f64) -> Option<f64> {
        let n = self.planned.note_near(hand, t)?;
        (n.piece == piece && (t - n.time_s).abs() <= window_s).then_some(n.time_s)
    }

    /// Keep the stick from passing through a cymbal on its way to or from another piece:
    /// when the simulated tip `sim_tip` and `target` are on opposite sides of a plate's plane
    /// (within [`TargetSettings::plate_keepout_depth_m`] of it), the target is moved radially
    /// out to the plate's edge plus the clearance while the tip is still over or under the
    /// plate, and a target below a plate the tip is above is held up at the clearance height
    /// until the tip is past the edge: the stick goes round the edge, not through it (the
    /// plate of `hand`'s nearest note is struck from above around its onset, as in
    /// [`Self::clear`]; `plates`: each plate's surface index and surface).
    pub fn keep_out<'a>(
        &self,
        hand: usize,
        t: f64,
        target: &mut ArmTarget,
        sim_tip: Vector,
        plates: impl IntoIterator<Item = (usize, &'a Surface)>,
        piece_of: &[usize],
    ) {
        let s = &self.settings;
        let note = self.planned.note_near(hand, t);
        for (i, p) in plates {
            let struck = note.is_some_and(|n| {
                let dt = t - n.time_s;
                piece_of[i] == n.piece && dt > -s.guard_before_s && dt < s.guard_after_s
            });
            let (h_sim, h) = (p.height(sim_tip), p.height(target.tip));
            let depth = s.plate_keepout_depth_m;
            let reach = p.radius_m + s.plate_clearance_m;
            let radial = |v: Vector| {
                let d = v - p.center;
                d - p.normal * d.dot(p.normal)
            };
            let (planar, r_sim) = (radial(target.tip), radial(sim_tip).length());
            // The side to go out on: the target's, or the simulated tip's when the target
            // sits on the plate's axis.
            let side = |planar: Vector| {
                if planar.length() > 1e-4 {
                    planar.normalize()
                } else {
                    radial(sim_tip).normalize_or(p.u)
                }
            };
            if h_sim < 0.0 && h_sim >= -depth && h >= -depth {
                // Under the plate: out to its edge at the target's height.
                if planar.length() < reach {
                    target.tip = p.center + p.normal * h + side(planar) * reach;
                }
            } else if !struck && h_sim >= 0.0 && h < 0.0 && h >= -depth && r_sim < reach {
                // Over the plate with the target below it: out past the edge first, above it.
                let up = self.bead_m + s.clearance_m;
                target.tip = p.center + p.normal * up + side(planar) * planar.length().max(reach);
            }
            if !struck {
                self.shaft_round(target, p);
            }
        }
    }

    /// Swing `target`'s stick about its tip until its shaft passes plate `p` outside its
    /// edge and the clearance, where the tip and the butt are on opposite sides of the
    /// plate's plane and the shaft would cross it inside: a tip on a drum beside or under a
    /// cymbal with the hand over the cymbal's plane lays the shaft across the plate (a left
    /// hand's snare stroke by the hi-hat held the stick on the hat's edge, 10 mm into it,
    /// then let it fall onto a ghost note at 5.7 m/s).
    fn shaft_round(&self, target: &mut ArmTarget, p: &Surface) {
        let reach = p.radius_m + self.settings.plate_clearance_m;
        let butt = target.tip - target.dir * self.shaft_m;
        let (ht, hb) = (p.height(target.tip), p.height(butt));
        if ht * hb >= 0.0 {
            return;
        }
        let crossing = target.tip + (butt - target.tip) * (ht / (ht - hb));
        let radial = |v: Vector| (v - p.center).reject_from(p.normal);
        let out = radial(crossing);
        if out.length() >= reach {
            return;
        }
        let side = out.try_normalize().or_else(|| radial(target.tip).try_normalize()).unwrap_or(p.u);
        let edge = p.center + side * reach;
        target.dir = (target.tip - edge).normalize_or(target.dir);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::plan::{plan_hands, Assignment};
    use rapier3d::geometry::ColliderHandle;

    /// Targets with no notes (nothing is being struck), a 7 mm bead held 30 cm from its tip.
    fn targets() -> TipTargets {
        let planned = plan_hands(&[], 60.0, &[], &Assignment::default(), StrokeSettings::default());
        TipTargets::new(&planned, 0.007, 0.30, TargetSettings::default())
    }

    fn surface(id: &str, center: Vector, radius_m: f32, depth_m: f32) -> Surface {
        Surface {
            id: id.into(),
            collider: ColliderHandle::invalid(),
            center,
            normal: Vector::Z,
            u: Vector::X,
            v: Vector::Y,
            radius_m,
            depth_m,
        }
    }

    #[test]
    fn a_stick_levered_low_across_a_drum_s_hoop_is_raised_until_its_shaft_clears_it() {
        let t = targets();
        // A snare at the origin (its hoop is surface 1) and a stick whose tip is 3 cm above
        // the head near its edge, the grip lower, outside the drum: the shaft lies on the hoop.
        let surfaces = [surface("snare", Vector::ZERO, 0.178, 0.35), surface("snare_rim", Vector::ZERO, 0.03, 0.02)];
        let mut target = ArmTarget { tip: Vector::new(0.0, -0.12, 0.03), dir: Vector::new(0.0, 1.0, 0.12).normalize() };
        let ring_gap = |target: &ArmTarget| {
            (0..=300)
                .map(|k| target.tip - target.dir * (0.001 * k as f32))
                .map(|p| {
                    let r = (p.x * p.x + p.y * p.y).sqrt();
                    (r - (0.178 + HOOP_RADIUS_M)).hypot(p.z - HOOP_HEIGHT_M)
                })
                .fold(f32::INFINITY, f32::min)
        };
        let touching = HOOP_RADIUS_M + 0.007;
        assert!(ring_gap(&target) < touching, "the setup must have the shaft on the hoop");
        let dir = target.dir;
        t.clear(0, 1.0, &mut target, &surfaces, &[0, 0]);
        assert!(ring_gap(&target) >= touching, "shaft {} m from the ring's centre line", ring_gap(&target));
        assert_eq!(target.dir, dir, "the stick keeps its angle; it is raised");
        assert!(target.tip.z < 0.2, "raised no more than it needs: tip at {}", target.tip.z);
    }

    #[test]
    fn a_stick_over_a_cymbal_goes_out_past_its_edge_before_heading_below_it() {
        let t = targets();
        let hihat = surface("hihat", Vector::new(0.0, 0.0, 1.0), 0.18, 0.02);
        let s = TargetSettings::default();
        let reach = 0.18 + s.plate_clearance_m;
        let below = Vector::new(0.05, 0.0, 0.90);
        // The simulated tip above the cymbal, the target under it: out and up first.
        let mut target = ArmTarget { tip: below, dir: Vector::Y };
        t.keep_out(0, 1.0, &mut target, Vector::new(0.10, 0.0, 1.05), [(0, &hihat)], &[0]);
        let planar = (target.tip.x * target.tip.x + target.tip.y * target.tip.y).sqrt();
        assert!(planar >= reach - 1e-5 && target.tip.x > 0.0, "out past the edge on the target's side: {planar}");
        assert!(target.tip.z > 1.0, "above the cymbal while going round: {}", target.tip.z);
        // Once the tip is past the edge, the target below is left alone.
        let mut target = ArmTarget { tip: below, dir: Vector::Y };
        t.keep_out(0, 1.0, &mut target, Vector::new(reach + 0.01, 0.0, 1.02), [(0, &hihat)], &[0]);
        assert_eq!(target.tip, below);
        // Under the cymbal, the target is moved out at its own height.
        let mut target = ArmTarget { tip: below, dir: Vector::Y };
        t.keep_out(0, 1.0, &mut target, Vector::new(0.10, 0.0, 0.95), [(0, &hihat)], &[0]);
        assert!((target.tip.z - below.z).abs() < 1e-6 && target.tip.x >= reach - 1e-5);
    }

    #[test]
    fn a_stick_whose_tip_is_below_a_cymbal_and_hand_above_it_swings_round_its_edge() {
        let t = targets();
        let hihat = surface("hihat", Vector::new(0.0, 0.0, 1.0), 0.18, 0.02);
        let reach = 0.18 + TargetSettings::default().plate_clearance_m;
        // A snare stroke's tip beside the hi-hat and 20 cm below it, the hand up over the hat:
        // the shaft crosses the cymbal 4 cm from its centre.
        let tip = Vector::new(0.22, 0.0, 0.80);
        let mut target = ArmTarget { tip, dir: -Vector::new(-0.20, 0.05, 0.22).normalize() };
        let crossing = |target: &ArmTarget| {
            let butt = target.tip - target.dir * 0.30;
            let (ht, hb) = (target.tip.z - 1.0, butt.z - 1.0);
            (ht * hb < 0.0).then(|| {
                let x = target.tip + (butt - target.tip) * (ht / (ht - hb));
                x.x.hypot(x.y)
            })
        };
        assert!(crossing(&target).is_some_and(|r| r < 0.18), "the setup must cross the cymbal");
        // Not striking the hi-hat (no notes): the stick swings about its tip, outside the edge.
        t.keep_out(0, 1.0, &mut target, tip, [(0, &hihat)], &[0]);
        assert_eq!(target.tip, tip, "the tip keeps its aim");
        assert!(crossing(&target).is_none_or(|r| r >= reach - 1e-4), "crosses at {:?} m", crossing(&target));
        assert!((target.dir.length() - 1.0).abs() < 1e-5);
        // The same stick held over the cymbal's plane on both ends is left alone.
        let level = ArmTarget { tip: Vector::new(0.22, 0.0, 1.05), dir: Vector::X };
        let mut target = level;
        t.keep_out(0, 1.0, &mut target, level.tip, [(0, &hihat)], &[0]);
        assert_eq!(target, level);
    }

    #[test]
    fn a_shaft_lying_on_a_cymbal_is_raised_clear_and_one_under_it_is_left_to_the_keep_out() {
        let t = targets();
        let ride = surface("ride", Vector::new(0.0, 0.0, 1.0), 0.25, 0.01);
        let floor = 0.007 + TargetSettings::default().clearance_m;
        let lowest = |target: &ArmTarget| {
            (1..=SHAFT_SAMPLES)
                .map(|k| target.tip - target.dir * (0.30 * k as f32 / SHAFT_SAMPLES as f32))
                .filter(|p| (p.x * p.x + p.y * p.y).sqrt() <= 0.25)
                .map(|p| p.z - 1.0)
                .fold(f32::INFINITY, f32::min)
        };
        // The tip beyond the ride's edge, the stick sloping down across it: the shaft lies on
        // the cymbal 5 mm above it.
        let dir = Vector::new(1.0, 0.0, 0.02).normalize();
        let mut target = ArmTarget { tip: Vector::new(0.30, 0.0, 1.005 + 0.02 * 0.30), dir };
        assert!(lowest(&target) < floor);
        t.clear(0, 1.0, &mut target, std::slice::from_ref(&ride), &[0]);
        assert!(lowest(&target) >= floor - 1e-4, "shaft {} m above the ride", lowest(&target));
        assert_eq!(target.dir, dir, "the stick keeps its angle; it is raised");
        // A stick under the ride (on its way to a floor tom beneath) is not pulled up through it.
        let under = ArmTarget { tip: Vector::new(0.30, 0.0, 0.95), dir };
        let mut target = under;
        t.clear(0, 1.0, &mut target, &[ride], &[0]);
        assert_eq!(target.tip, under.tip);
    }
}
