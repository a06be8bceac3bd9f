//! Timing by physics, corrected offline (issue 13, item 4): the whole future is known and
//! the simulation is deterministic, so a stroke whose contact fell off its note is played
//! again, better. Shortly after each note of a hand the rehearsal judges the stick's
//! contact ([`judge`]): on time and on the strike point, nothing to do. Otherwise the
//! stroke learns ([`learn`], iterative learning control): each task period's target moves
//! by a share of how far the simulated tip was from where the plan wanted it, a little
//! later in the stroke (along the surface's normal for a stroke off in time, in its plane
//! for one off the point). A stroke on time and on the point whose stick came down much
//! faster or slower than its velocity's speed reshapes its last approach instead
//! ([`learn_speed`]): a soft note after a loud one landed at two to five times its speed,
//! as loud as an accent. The body goes back to a snapshot from before the stroke's
//! preparation and plays on from there. Each note has a few attempts, and keeps its best.

use super::conductor::{period_index, Conductor, PREROLL_S};
use super::matching::DOUBLE_TRIGGER_S;
use super::targets::TargetSettings;
use crate::body::contacts::Strike;
use crate::body::strokes::TASK_HZ;
use crate::motion::plan::HandNote;
use rapier3d::math::Vector;
use std::collections::HashMap;

/// How the rehearsal judges and corrects strokes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RehearsalSettings {
    /// Plays of a stroke after its first (0: the song is played straight through).
    pub attempts: u8,
    /// A contact this near its onset is on time, seconds.
    pub tolerance_s: f64,
    /// A stick contact this near its strike point (in the surface's plane) is on the point, m.
    pub aim_tolerance_m: f32,
    /// A note is judged this long after its onset (its contact has come by then), seconds.
    pub settle_s: f64,
    /// Task periods between snapshots.
    pub snapshot_every: usize,
    /// How the tip targets are made (live play's, [`TargetSettings::live`], to learn the
    /// live drummer's lag model from straight play).
    pub targets: TargetSettings,
}

impl Default for RehearsalSettings {
    fn default() -> Self {
        RehearsalSettings {
            attempts: 4,
            tolerance_s: 0.006,
            aim_tolerance_m: 0.010,
            settle_s: 0.030,
            snapshot_every: 4,
            targets: TargetSettings::default(),
        }
    }
}

/// How a hand's note came out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// On time and on the point.
    Good,
    /// The stick's contact on the note's piece nearest its onset: its time error (contact -
    /// onset, seconds) and how far off the strike point it was in the surface's plane
    /// (world axes, m; zero when the contact was not the tip's bead).
    Off { error_s: f64, miss_m: Vector },
    /// No contact of this stick on the note's piece near the onset.
    Missing,
}

/// The contact a note is judged by: stick `side`'s on the note's piece (or its hoop)
/// nearest the onset within `reach_s` before and after it.
fn judged_contact<'a>(
    note: &HandNote,
    side: usize,
    strikes: &'a [Strike],
    piece_of: &[usize],
    reach_s: (f64, f64),
) -> Option<&'a Strike> {
    strikes
        .iter()
        .filter(|s| s.side == side && piece_of[s.surface] == note.piece)
        .filter(|s| s.time_s >= note.time_s - reach_s.0 && s.time_s <= note.time_s + reach_s.1)
        .min_by(|a, b| (a.time_s - note.time_s).abs().total_cmp(&(b.time_s - note.time_s).abs()))
}

/// The judged contact's time error (contact - onset, seconds) and how far off the strike
/// point it was in the surface's plane (world axes, m; zero when the contact was not the
/// tip's bead on the note's own surface).
fn contact_error(
    note: &HandNote,
    side: usize,
    strikes: &[Strike],
    piece_of: &[usize],
    reach_s: (f64, f64),
) -> Option<(f64, Vector)> {
    let s = judged_contact(note, side, strikes, piece_of, reach_s)?;
    let n = Vector::from(note.normal);
    let miss_m = if s.from_tip_m < BEAD_CONTACT_M && piece_of[s.surface] == s.surface {
        let d = s.point - Vector::from(note.point);
        d - n * d.dot(n)
    } else {
        Vector::ZERO
    };
    Some((s.time_s - note.time_s, miss_m))
}

/// The judged contact's time and how much faster its stick came down than the note's
/// planned speed, as `ln(contact / planned)`: only for the tip's bead on the note's own
/// surface (a hoop's contact is the shaft's, slower by where it touches).
pub fn speed_error(
    note: &HandNote,
    side: usize,
    strikes: &[Strike],
    piece_of: &[usize],
    reach_s: (f64, f64),
) -> Option<(f64, f32)> {
    let s = judged_contact(note, side, strikes, piece_of, reach_s)?;
    let bead = s.from_tip_m < BEAD_CONTACT_M && piece_of[s.surface] == s.surface;
    (bead && note.speed_mps > 0.0 && s.speed_mps > 0.0).then(|| (s.time_s, (s.speed_mps / note.speed_mps).ln()))
}

/// Judge note `note` of hand `side` from the stick's `strikes` (any order), `piece_of`
/// mapping surfaces to kit pieces. Only contacts within `reach_s` of the onset count (half
/// the time to the hand's neighbouring notes, so a neighbour's contact is not this one's).
pub fn judge(
    note: &HandNote,
    side: usize,
    strikes: &[Strike],
    piece_of: &[usize],
    reach_s: (f64, f64),
    settings: &RehearsalSettings,
) -> Verdict {
    let Some((error_s, miss_m)) = contact_error(note, side, strikes, piece_of, reach_s) else {
        return Verdict::Missing;
    };
    if error_s.abs() <= settings.tolerance_s && miss_m.length() <= settings.aim_tolerance_m {
        Verdict::Good
    } else {
        Verdict::Off { error_s, miss_m }
    }
}

/// Contacts of stick `side` among `strikes` (from the stroke's start) until `until` that
/// play nothing: on another piece, or on the note's piece other than the contact it is
/// judged by (a bounce, or an early graze). Each as (time, surface).
pub fn strays(
    note: &HandNote,
    side: usize,
    strikes: &[Strike],
    piece_of: &[usize],
    until: f64,
    reach_s: (f64, f64),
) -> Vec<(f64, usize)> {
    let judged = judged_contact(note, side, strikes, piece_of, reach_s).map(|j| (j.time_s, j.surface));
    strikes
        .iter()
        .filter(|s| s.side == side && s.time_s <= until)
        .filter(|s| match judged {
            // The judged contact, and its pair on the piece's other surface (a rim shot's head
            // and hoop) within the e-kit's double-trigger window, are the stroke.
            Some((t0, k0)) if piece_of[s.surface] == note.piece => {
                !(s.time_s == t0 || s.surface != k0 && (s.time_s - t0).abs() <= DOUBLE_TRIGGER_S)
            }
            _ => true,
        })
        .map(|s| (s.time_s, s.surface))
        .collect()
}

/// A contact this near the tip's end is the bead's: its point is where the tip was aimed.
const BEAD_CONTACT_M: f32 = 0.012;

impl Verdict {
    /// How far off: 0 when good, the time error in ms plus the miss in units of 4 mm when
    /// off, infinite when missing.
    pub fn score(&self) -> f64 {
        match self {
            Verdict::Good => 0.0,
            Verdict::Off { error_s, miss_m } => 1e3 * error_s.abs() + 250.0 * miss_m.length() as f64,
            Verdict::Missing => f64::INFINITY,
        }
    }

    /// When the stroke's contact came (the onset plus the time it is judged after, when none
    /// did).
    pub fn contact_time(&self, note: &HandNote, settings: &RehearsalSettings) -> f64 {
        match self {
            Verdict::Off { error_s, .. } => note.time_s + error_s.min(settings.settle_s),
            // None came: the approach until the planned touch is what to learn from (after
            // it the plan rebounds while the late stick still falls).
            _ => note.time_s + MISSING_LEARN_S,
        }
    }
}

/// Task periods the learning looks ahead: about the tracking's lag.
const LEARN_LEAD: usize = 2;
/// Share of the tracking error taken into the offsets per attempt.
const LEARN_GAIN: f32 = 0.7;
/// Longest learned offset, m: a stroke that needs more has a problem no aiming solves, and
/// a target driven far through a cymbal would drive the stick into it.
const MAX_OFFSET_M: f32 = 0.02;
/// Periods over which a correction fades in at the start of its stroke.
const LEARN_TAPER: f32 = 5.0;

/// Iterative learning control of one stroke: over `periods` (from its preparation to its
/// contact), each period's target offset takes a share of what was off. A stroke off in
/// time (by more than `settings.tolerance_s`) learns along the surface's normal from the
/// tracking error (`aims - sims`, what the plan wanted minus where the simulated tip was) a
/// little later; one off the strike point (by more than `settings.aim_tolerance_m`) moves
/// across the surface against its miss itself; one that never landed learns the whole
/// tracking error. The miss, not the tracking error, steers the point: the tip tracks its
/// target to a few millimetres at the onset and still lands 1-3 cm up or down a tilted tom
/// head, where the stick came down along its arc.
pub fn learn(
    offsets: &mut [Vector],
    verdict: Verdict,
    note: &HandNote,
    periods: std::ops::RangeInclusive<usize>,
    aims: &[Vector],
    sims: &[Vector],
    settings: &RehearsalSettings,
) {
    let n = Vector::from(note.normal);
    let (p0, p1) = (*periods.start(), *periods.end());
    for q in periods {
        let r = (q + LEARN_LEAD).min(p1);
        let e = aims[r] - sims[r];
        let e = match verdict {
            // Nothing landed: wherever the tip was off, in height or across the surface.
            Verdict::Missing => e,
            Verdict::Good => Vector::ZERO,
            Verdict::Off { error_s, miss_m } => {
                let timing = if error_s.abs() > settings.tolerance_s { n * e.dot(n) } else { Vector::ZERO };
                let point = if miss_m.length() > settings.aim_tolerance_m { -miss_m } else { Vector::ZERO };
                timing + point
            }
        };
        let taper = ((q - p0) as f32 / LEARN_TAPER).min(1.0);
        offsets[q] = (offsets[q] + e * (LEARN_GAIN * taper)).clamp_length_max(MAX_OFFSET_M);
    }
}

/// Reshape the approach of a stroke that came down at `speed_mps` where its note asked
/// `note.speed_mps`, its contact at `contact_s`: over the [`SPEED_RAMP_S`] before the
/// target meets the surface (the tracking's lag before the contact) the target's height
/// falls by a share of the speed's excess times the time left (a flatter last approach
/// for a stroke too fast, a steeper one for a stroke too slow), eased in over as long
/// before. The target meets the surface when it did, so the stroke keeps its time. A
/// target is lowered by at most half its height above the surface (`aims`: the planned
/// targets per period), so the stick is not sent into the head early.
pub fn learn_speed(
    offsets: &mut [Vector],
    note: &HandNote,
    contact_s: f64,
    speed_mps: f32,
    aims: &[Vector],
    last: usize,
) {
    let n = Vector::from(note.normal);
    let excess = speed_mps - note.speed_mps;
    let end = contact_s - LEARN_LEAD as f64 / TASK_HZ;
    let (q0, q1) = (period_index(end - 2.0 * SPEED_RAMP_S), period_index(end).min(last));
    for q in q0..=q1.min(offsets.len() - 1) {
        let before = end - (q as f64 / TASK_HZ - PREROLL_S);
        let left = if before <= SPEED_RAMP_S { before } else { 2.0 * SPEED_RAMP_S - before }.max(0.0) as f32;
        let mut drop = SPEED_GAIN * excess * left;
        if drop > 0.0 {
            let height = (aims[q] - Vector::from(note.point)).dot(n).max(0.0);
            drop = drop.min(0.5 * height);
        }
        offsets[q] = (offsets[q] - n * drop).clamp_length_max(MAX_OFFSET_M);
    }
}

/// Shift the last approach of a stroke whose contact came `error_s` off its note (at
/// `contact_s`) along the surface's normal by a share of the distance the note's speed
/// covers in that time: up for an early contact, down for a late one (by at most half the
/// target's height over the surface), from [`SPEED_RAMP_S`] before the contact (eased in
/// over as long before) to the planned touch, never before `from_s` (the stroke's start: the
/// last stroke's rebound is its own). The tracking error alone does not move a stroke that
/// tracks its target and still meets the head early.
pub fn learn_time(
    offsets: &mut [Vector],
    note: &HandNote,
    from_s: f64,
    contact_s: f64,
    error_s: f64,
    aims: &[Vector],
    last: usize,
) {
    let n = Vector::from(note.normal);
    let shift = -(error_s as f32) * note.speed_mps * TIME_GAIN;
    let lead = LEARN_LEAD as f64 / TASK_HZ;
    let start = contact_s.min(note.time_s) - lead;
    let end = contact_s.max(note.time_s) - lead;
    let q0 = period_index((start - 2.0 * SPEED_RAMP_S).max(from_s));
    let q1 = period_index(end).min(last);
    for q in q0..=q1.min(offsets.len() - 1) {
        let before = start - (q as f64 / TASK_HZ - PREROLL_S);
        let w = if before <= SPEED_RAMP_S { 1.0 } else { (2.0 - before / SPEED_RAMP_S).max(0.0) as f32 };
        let mut d = shift * w;
        if d < 0.0 {
            let height = (aims[q] - Vector::from(note.point)).dot(n).max(0.0);
            d = d.max(-0.5 * height);
        }
        offsets[q] = (offsets[q] + n * d).clamp_length_max(MAX_OFFSET_M);
    }
}

/// Share of the distance an off-time stroke's speed covers in its error taken into its
/// approach per attempt ([`learn_time`]).
const TIME_GAIN: f32 = 0.7;

/// Learning reaches at least this far before a stroke's contact (an early contact may come
/// from the last stroke's rebound), seconds.
const LEARN_BACK_S: f64 = 0.032;

/// A stray contact weighs as much as this many milliseconds off in a stroke's score.
const STRAY_SCORE: f64 = 10.0;
/// A stray contact lifts the stick off its surface by this much per attempt, over this long
/// before it (m, s).
const STRAY_LIFT_M: f32 = 0.006;
const STRAY_LIFT_S: f64 = 0.04;

/// A lift against a stray contact between strokes holds at most this long after it, s.
const GAP_HOLD_S: f64 = 0.5;

/// Share of a stroke's miss across its surface that corrects the hand's aim on that piece,
/// and the largest correction, m.
const BIAS_GAIN: f32 = 0.3;
const MAX_BIAS_M: f32 = 0.04;

/// A contact this much faster or slower than its note's planned speed (as a ratio's log:
/// twice or half, 6 dB of level) is played again when it is on time and on the point (at
/// 1.5 times, 3.5 dB, the replays perturbed the strokes after them: 20 more notes missed
/// and 23 more contacts that played no note on 12 takes' first minutes).
const SPEED_TOLERANCE_LN: f32 = 0.693;
/// A doubled or halved speed weighs as much as this many milliseconds off in a score.
const SPEED_SCORE: f64 = 6.0;
/// Share of a stroke's speed error taken into its approach per attempt.
const SPEED_GAIN: f32 = 0.6;
/// How long before the contact the approach is reshaped, s (and as long again to ease in).
const SPEED_RAMP_S: f64 = 0.03;

/// A stroke that never landed learns until this long after its onset, seconds.
const MISSING_LEARN_S: f64 = 0.004;

/// Learning corrects at most this much of a stroke's approach before its onset, seconds
/// (a long preparation's start hardly moves its contact).
const APPROACH_S: f64 = 0.1;

/// Lift the stick off a surface of `normal` over `offsets` (the periods before a stray
/// contact), easing in.
fn lift(offsets: &mut [Vector], normal: Vector) {
    for (i, o) in offsets.iter_mut().enumerate() {
        let ramp = ((i + 1) as f32 / LEARN_TAPER).min(1.0);
        *o = (*o + normal * (STRAY_LIFT_M * ramp)).clamp_length_max(MAX_OFFSET_M);
    }
}

/// The rehearsal's bookkeeping over a song: where the plan wanted the tips and where they
/// were at every task period, which notes are judged, each note's attempts and best take.
pub struct Rehearsal {
    settings: RehearsalSettings,
    notes: [Vec<HandNote>; 2],
    /// Per hand, the next note to judge.
    judged: [usize; 2],
    attempts: [Vec<u8>; 2],
    /// Per hand, the notes whose first take has taught the hand's aim on their piece.
    biased: [Vec<bool>; 2],
    /// (hand, note): the best score so far and the offsets that made it, from a period on.
    best: HashMap<(usize, usize), (f64, usize, Vec<Vector>)>,
    aims: [Vec<Vector>; 2],
    sims: [Vec<Vector>; 2],
    /// Per hand, gaps between strokes (by the next note's index): stray contacts lifted.
    gap_attempts: HashMap<(usize, usize), u8>,
    /// Strikes already looked at for strays between strokes.
    strays_seen: usize,
    /// Strokes played again, and notes that needed it.
    pub replays: usize,
    /// Why: [off in time, off the point, never landed, strays only, the best take again,
    /// strays between strokes, too fast or too slow].
    pub reasons: [usize; 7],
}

impl Rehearsal {
    /// For the conductor's plan, over `periods` task periods.
    pub fn new(c: &Conductor, periods: usize, settings: RehearsalSettings) -> Rehearsal {
        let notes: [Vec<HandNote>; 2] = [0, 1].map(|h| c.targets().planned().notes(h).copied().collect());
        let attempts = [vec![0; notes[0].len()], vec![0; notes[1].len()]];
        let biased = [vec![false; notes[0].len()], vec![false; notes[1].len()]];
        let log = vec![Vector::ZERO; periods];
        Rehearsal {
            settings,
            notes,
            judged: [0; 2],
            attempts,
            biased,
            best: HashMap::new(),
            aims: [log.clone(), log.clone()],
            sims: [log.clone(), log],
            gap_attempts: HashMap::new(),
            strays_seen: 0,
            replays: 0,
            reasons: [0; 7],
        }
    }

    /// Notes that needed another take.
    pub fn rehearsed(&self) -> usize {
        self.best.len()
    }

    /// After a period: log it, then judge the notes that have settled. Returns the time to
    /// go back to when one must be played again (its targets already corrected).
    pub fn after_period(&mut self, c: &mut Conductor, strikes: &[Strike]) -> Option<f64> {
        let t = c.time_s();
        let p = period_index(t).min(self.aims[0].len() - 1);
        let (aims, sims) = (c.aims(), c.drummer().tips(crate::body::sim::Mode::Himc));
        for h in 0..2 {
            (self.aims[h][p], self.sims[h][p]) = (aims[h], sims[h]);
        }
        let s = self.settings;
        if let Some(back) = self.gap_strays(c, strikes) {
            self.replays += 1;
            self.reasons[5] += 1;
            return Some(back);
        }
        for h in 0..2 {
            while let Some(n) = self.notes[h].get(self.judged[h]).filter(|n| n.time_s + s.settle_s <= t).copied() {
                let k = self.judged[h];
                self.judged[h] += 1;
                if self.attempts[h][k] > s.attempts {
                    continue;
                }
                let (from, to) = c.targets().planned().stroke_span(h, k);
                // The stroke's contact falls between its neighbours' (the later half of the
                // gap only up to when it is judged); a stray contact is any since the hand's
                // last note was judged.
                let reach = (n.time_s - from, (to - n.time_s).min(s.settle_s));
                let since = from;
                let recent = &strikes[strikes.partition_point(|x| x.time_s < since)..];
                let verdict = judge(&n, h, recent, c.piece_of(), reach, &s);
                let surfaces = c.drummer().surfaces();
                let strays: Vec<(f64, Vector)> = strays(&n, h, recent, c.piece_of(), n.time_s + reach.1, reach)
                    .into_iter()
                    .map(|(ts, k)| (ts, surfaces[k].normal))
                    .collect();
                // A stroke on time and on the point may still come down far too hard or soft.
                let off_speed = speed_error(&n, h, recent, c.piece_of(), reach)
                    .filter(|_| verdict == Verdict::Good)
                    .filter(|(_, e)| e.abs() > SPEED_TOLERANCE_LN);
                let speed = off_speed.map(|(_, e)| e);
                let good = verdict == Verdict::Good && strays.is_empty() && speed.is_none();
                if !self.biased[h][k] {
                    // The hand's aim on this piece learns from every stroke's first take.
                    self.biased[h][k] = true;
                    if let Some((error_s, miss_m)) = contact_error(&n, h, recent, c.piece_of(), reach) {
                        if error_s.abs() <= 2.0 * s.tolerance_s {
                            let b = c.targets_mut().bias_mut(h, n.piece);
                            *b = (*b - miss_m * BIAS_GAIN).clamp_length_max(MAX_BIAS_M);
                        }
                    }
                }
                if good && !self.best.contains_key(&(h, k)) {
                    continue;
                }
                // The window a correction of this stroke may touch: its approach, the time
                // before its strays, and what follows until it is judged.
                let approach = from.max(n.time_s - APPROACH_S) - LEARN_BACK_S;
                let start = strays.iter().map(|(ts, _)| ts - STRAY_LIFT_S).fold(approach, f64::min);
                let (p0, p1) = (period_index(start), period_index(n.time_s + s.settle_s).min(p));
                let score = verdict.score()
                    + STRAY_SCORE * strays.len() as f64
                    + speed
                        .map_or(0.0, |e| SPEED_SCORE * (e.abs() - SPEED_TOLERANCE_LN) as f64 / std::f64::consts::LN_2);
                let periods = self.aims[h].len();
                let offsets = c.targets_mut().offsets_mut(h, periods);
                let best = self.best.entry((h, k)).or_insert((f64::INFINITY, 0, Vec::new()));
                if score < best.0 {
                    *best = (score, p0, offsets[p0..=p1].to_vec());
                }
                if good {
                    continue;
                }
                self.attempts[h][k] += 1;
                if self.attempts[h][k] > s.attempts {
                    if score <= best.0 {
                        continue;
                    }
                    // Out of attempts: the best take again, for good.
                    let (b0, b) = (best.1, &best.2);
                    offsets[b0..b0 + b.len()].copy_from_slice(b);
                    self.replays += 1;
                    self.reasons[4] += 1;
                    return Some(start.min(b0 as f64 / TASK_HZ - PREROLL_S));
                } else {
                    let mut changed = !strays.is_empty();
                    if verdict != Verdict::Good {
                        let contact = verdict.contact_time(&n, &s);
                        let periods = period_index(approach.max(contact - APPROACH_S))..=period_index(contact).min(p1);
                        changed |= !periods.is_empty();
                        let (aims, sims) = (&self.aims[h], &self.sims[h]);
                        learn(offsets, verdict, &n, periods, aims, sims, &s);
                        if let Verdict::Off { error_s, .. } = verdict {
                            if error_s.abs() > s.tolerance_s {
                                learn_time(offsets, &n, from, contact, error_s, &self.aims[h], p1);
                            }
                        }
                    }
                    if let Some((contact_s, e)) = off_speed {
                        learn_speed(offsets, &n, contact_s, n.speed_mps * e.exp(), &self.aims[h], p1);
                        changed = true;
                    }
                    if !changed {
                        // Nothing to learn from (a contact long before the stroke): playing
                        // again would play the same.
                        self.attempts[h][k] = s.attempts + 1;
                        continue;
                    }
                    // Lift the stick off what it touched uninvited, over the time before.
                    for &(ts, normal) in &strays {
                        let q1 = period_index(ts).min(p1);
                        lift(&mut offsets[period_index(ts - STRAY_LIFT_S).clamp(p0, q1)..=q1], normal);
                    }
                }
                self.replays += 1;
                self.reasons[match verdict {
                    Verdict::Off { error_s, .. } if error_s.abs() > s.tolerance_s => 0,
                    Verdict::Off { .. } => 1,
                    Verdict::Missing => 2,
                    Verdict::Good if speed.is_some() && strays.is_empty() => 6,
                    Verdict::Good => 3,
                }] += 1;
                return Some(start);
            }
        }
        None
    }

    /// Contacts since the last look that fall between a hand's strokes (after one is judged,
    /// before the next one's preparation): each lifts its stick off that surface over the
    /// time before it, a few times per gap at most. Returns the time to go back to.
    fn gap_strays(&mut self, c: &mut Conductor, strikes: &[Strike]) -> Option<f64> {
        let settle = self.settings.settle_s;
        let fresh = &strikes[self.strays_seen.min(strikes.len())..];
        self.strays_seen = strikes.len();
        for x in fresh.iter().filter(|x| x.side < 2) {
            let (h, ns) = (x.side, &self.notes[x.side]);
            // The gap before note i: after note i - 1 settled, before note i's preparation.
            let i = ns.partition_point(|n| n.time_s + settle < x.time_s);
            let after_last = i.checked_sub(1).is_none_or(|j| ns[j].time_s + settle < x.time_s);
            let before_next = i >= ns.len() || x.time_s < c.targets().planned().stroke_span(h, i).0;
            if !(after_last && before_next) {
                continue;
            }
            let tries = self.gap_attempts.entry((h, i)).or_insert(0);
            if *tries >= self.settings.attempts {
                continue;
            }
            *tries += 1;
            let normal = c.drummer().surfaces()[x.surface].normal;
            let periods = self.aims[h].len();
            // The stick stays lifted for the rest of the gap (an idle hand sank back onto
            // what it had touched, again and again), easing back before the next stroke's
            // preparation.
            let next = ns.get(i).map_or(x.time_s + GAP_HOLD_S, |_| c.targets().planned().stroke_span(h, i).0);
            let offsets = c.targets_mut().offsets_mut(h, periods);
            let q1 = period_index(x.time_s).min(periods - 1);
            let q2 = period_index(next.min(x.time_s + GAP_HOLD_S)).clamp(q1, periods - 1);
            lift(&mut offsets[period_index(x.time_s - STRAY_LIFT_S).min(q1)..=q1], normal);
            let hold = q2 - q1;
            for (j, o) in offsets[q1 + 1..=q2].iter_mut().enumerate() {
                // Whole until the last few periods, then easing out.
                let ramp = ((hold - j) as f32 / LEARN_TAPER).min(1.0);
                *o = (*o + normal * (STRAY_LIFT_M * ramp)).clamp_length_max(MAX_OFFSET_M);
            }
            return Some(x.time_s - STRAY_LIFT_S);
        }
        None
    }

    /// After going back to a snapshot at `t` (keeping the first `strikes_kept` strikes): every
    /// note settling later is judged again.
    pub fn restart(&mut self, t: f64, strikes_kept: usize) {
        for h in 0..2 {
            self.judged[h] = self.notes[h].partition_point(|n| n.time_s + self.settings.settle_s <= t);
        }
        self.strays_seen = strikes_kept;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn note(speed_mps: f32) -> HandNote {
        HandNote { time_s: 1.0, piece: 0, point: [0.0, 0.0, 0.6], normal: [0.0, 0.0, 1.0], velocity: 20, speed_mps }
    }

    #[test]
    fn a_stroke_too_fast_flattens_its_last_approach_and_one_too_slow_steepens_it() {
        let periods = period_index(1.2);
        // The planned targets 5 cm over the head throughout.
        let aims = vec![Vector::new(0.0, 0.0, 0.65); periods];
        let n = note(1.0);
        let end = period_index(1.0 - LEARN_LEAD as f64 / TASK_HZ);
        let start = period_index(1.0 - LEARN_LEAD as f64 / TASK_HZ - 2.0 * SPEED_RAMP_S);
        let mut fast = vec![Vector::ZERO; periods];
        learn_speed(&mut fast, &n, 1.0, 1.5, &aims, periods - 1);
        // Lowered along the normal only, most a ramp before the target meets the head, not
        // at all where it meets it, before the ease-in or after.
        assert!(fast.iter().all(|o| o.x == 0.0 && o.y == 0.0 && o.z <= 0.0));
        let deepest = (0..periods).min_by(|&a, &b| fast[a].z.total_cmp(&fast[b].z)).unwrap();
        assert!(fast[deepest].z < -0.008, "{}", fast[deepest].z);
        assert!(deepest.abs_diff(period_index(1.0 - LEARN_LEAD as f64 / TASK_HZ - SPEED_RAMP_S)) <= 1);
        assert!(fast[end].z.abs() < 1e-6);
        assert!(fast[..start].iter().chain(&fast[end + 1..]).all(|o| *o == Vector::ZERO));
        // Too slow: raised over the same periods.
        let mut slow = vec![Vector::ZERO; periods];
        learn_speed(&mut slow, &n, 1.0, 0.4, &aims, periods - 1);
        assert!(slow.iter().all(|o| o.z >= 0.0) && slow.iter().any(|o| o.z > 0.005));
        // A target 1 cm over the head is lowered by half that at most, whatever the excess.
        let low = vec![Vector::new(0.0, 0.0, 0.61); periods];
        let mut capped = vec![Vector::ZERO; periods];
        learn_speed(&mut capped, &n, 1.0, 5.0, &low, periods - 1);
        assert!(capped.iter().all(|o| o.z >= -0.005 - 1e-6));
    }

    #[test]
    fn a_stroke_that_met_the_head_early_starts_its_last_approach_higher_and_a_late_one_lower() {
        let periods = period_index(1.2);
        let aims = vec![Vector::new(0.0, 0.0, 0.65); periods];
        let n = note(1.0);
        let lead = LEARN_LEAD as f64 / TASK_HZ;
        // 12 ms early: raised along the normal by about 0.7 x 12 mm over the last approach,
        // up to the planned touch, never before the stroke's start.
        let mut early = vec![Vector::ZERO; periods];
        learn_time(&mut early, &n, 0.95, 0.988, -0.012, &aims, periods - 1);
        assert!(early.iter().all(|o| o.x == 0.0 && o.y == 0.0 && o.z >= 0.0));
        let top = early.iter().map(|o| o.z).fold(0.0, f32::max);
        assert!((top - 0.0084).abs() < 1e-4, "{top}");
        assert!(early[period_index(1.0 - lead)].z > 0.008);
        assert!(early[..period_index(0.95)].iter().chain(&early[period_index(1.0 - lead) + 1..]).all(|o| o.z == 0.0));
        // 12 ms late: lowered, by at most half the target's height (a target 1 cm over the
        // head, 5 mm), up to the late contact.
        let low = vec![Vector::new(0.0, 0.0, 0.61); periods];
        let mut late = vec![Vector::ZERO; periods];
        learn_time(&mut late, &n, 0.9, 1.012, 0.012, &low, periods - 1);
        assert!(late.iter().all(|o| o.z <= 0.0 && o.z >= -0.005 - 1e-6));
        assert!(late[period_index(1.012 - lead)].z < -0.004);
    }

    #[test]
    fn a_stroke_on_time_but_off_the_point_moves_against_its_miss_even_when_it_tracked_its_target() {
        let periods = period_index(1.2);
        let (p0, p1) = (period_index(0.9), period_index(1.0));
        // The tip followed its targets exactly, and still met the head 15 mm along +y.
        let aims = vec![Vector::new(0.0, 0.0, 0.62); periods];
        let miss = Vector::new(0.0, 0.015, 0.0);
        let settings = RehearsalSettings::default();
        let mut offsets = vec![Vector::ZERO; periods];
        learn(
            &mut offsets,
            Verdict::Off { error_s: 0.002, miss_m: miss },
            &note(1.0),
            p0..=p1,
            &aims,
            &aims,
            &settings,
        );
        // Across the surface only, against the miss: 0.7 of it once eased in, nothing outside.
        assert!(offsets.iter().all(|o| o.x == 0.0 && o.z == 0.0 && o.y <= 0.0));
        assert!((offsets[p1].y + 0.7 * 0.015).abs() < 1e-6, "{}", offsets[p1].y);
        assert!(offsets[p0].y == 0.0 && offsets[p0 + 1].y < 0.0);
        assert!(offsets[..p0].iter().chain(&offsets[p1 + 1..]).all(|o| *o == Vector::ZERO));
        // Within the aim's tolerance and on time: nothing to learn.
        let mut none = vec![Vector::ZERO; periods];
        let near = Verdict::Off { error_s: 0.002, miss_m: Vector::new(0.0, 0.008, 0.0) };
        learn(&mut none, near, &note(1.0), p0..=p1, &aims, &aims, &settings);
        assert!(none.iter().all(|o| *o == Vector::ZERO));
    }
}
