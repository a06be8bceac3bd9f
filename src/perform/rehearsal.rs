//! Timing by physics, corrected offline (issue 13, item 4): the whole future is known and
//! the simulation is deterministic, so a stroke whose contact fell off its note is played
//! again, better. Shortly after each note of a hand the rehearsal judges the stick's
//! contact ([`judge`]): on time and on the strike point, nothing to do. Otherwise the
//! stroke learns ([`learn`], iterative learning control): each task period's target moves
//! by a share of how far the simulated tip was from where the plan wanted it, a little
//! later in the stroke (along the surface's normal for a stroke off in time, in its plane
//! for one off the point). The body goes back to a snapshot from before the stroke's
//! preparation and plays on from there. Each note has a few attempts, and keeps its best.

use super::conductor::{period_index, Conductor};
use crate::body::contacts::Strike;
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
}

impl Default for RehearsalSettings {
    fn default() -> Self {
        RehearsalSettings {
            attempts: 4,
            tolerance_s: 0.004,
            aim_tolerance_m: 0.008,
            settle_s: 0.030,
            snapshot_every: 4,
        }
    }
}

/// How a hand's note came out.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// On time and on the point.
    Good,
    /// The stick's first contact on the note's piece: its time error (contact - onset,
    /// seconds) and how far off the strike point it was in the surface's plane (world
    /// axes, m; zero when the contact was not the tip's bead).
    Off { error_s: f64, miss_m: Vector },
    /// No contact of this stick on the note's piece near the onset.
    Missing,
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
    let first = strikes
        .iter()
        .filter(|s| s.side == side && piece_of[s.surface] == note.piece)
        .filter(|s| s.time_s >= note.time_s - reach_s.0 && s.time_s <= note.time_s + reach_s.1)
        .min_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let Some(s) = first else { return Verdict::Missing };
    let error_s = s.time_s - note.time_s;
    let n = Vector::from(note.normal);
    let miss_m = if s.from_tip_m < BEAD_CONTACT_M && piece_of[s.surface] == s.surface {
        let d = s.point - Vector::from(note.point);
        d - n * d.dot(n)
    } else {
        Vector::ZERO
    };
    if error_s.abs() <= settings.tolerance_s && miss_m.length() <= settings.aim_tolerance_m {
        Verdict::Good
    } else {
        Verdict::Off { error_s, miss_m }
    }
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
            _ => note.time_s + settings.settle_s,
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
/// contact), each period's target offset takes a share of the tracking error
/// (`aims - sims`, what the plan wanted minus where the simulated tip was) a little later.
/// A stroke off in time (by more than `tolerance_s`) learns along the surface's normal
/// only; one on time but off the strike point, within the surface's plane only.
pub fn learn(
    offsets: &mut [Vector],
    verdict: Verdict,
    note: &HandNote,
    periods: std::ops::RangeInclusive<usize>,
    aims: &[Vector],
    sims: &[Vector],
    tolerance_s: f64,
) {
    let n = Vector::from(note.normal);
    let timing = !matches!(verdict, Verdict::Off { error_s, .. } if error_s.abs() <= tolerance_s);
    let (p0, p1) = (*periods.start(), *periods.end());
    for q in periods {
        let r = (q + LEARN_LEAD).min(p1);
        let e = aims[r] - sims[r];
        let e = if timing { n * e.dot(n) } else { e - n * e.dot(n) };
        let taper = ((q - p0) as f32 / LEARN_TAPER).min(1.0);
        offsets[q] = (offsets[q] + e * (LEARN_GAIN * taper)).clamp_length_max(MAX_OFFSET_M);
    }
}

/// Learning reaches at least this far before a stroke's contact (an early contact may come
/// from the last stroke's rebound), seconds.
const LEARN_BACK_S: f64 = 0.032;

/// Learning corrects at most this much of a stroke's approach before its onset, seconds
/// (a long preparation's start hardly moves its contact).
const APPROACH_S: f64 = 0.1;

/// The rehearsal's bookkeeping over a song: where the plan wanted the tips and where they
/// were at every task period, which notes are judged, each note's attempts and best take.
pub struct Rehearsal {
    settings: RehearsalSettings,
    notes: [Vec<HandNote>; 2],
    /// Per hand, the next note to judge.
    judged: [usize; 2],
    attempts: [Vec<u8>; 2],
    /// (hand, note): the best score so far and the offsets that made it, from its window's
    /// first period.
    best: HashMap<(usize, usize), (f64, Vec<Vector>)>,
    aims: [Vec<Vector>; 2],
    sims: [Vec<Vector>; 2],
    /// Strokes played again, and notes that needed it.
    pub replays: usize,
}

impl Rehearsal {
    /// For the conductor's plan, over `periods` task periods.
    pub fn new(c: &Conductor, periods: usize, settings: RehearsalSettings) -> Rehearsal {
        let notes: [Vec<HandNote>; 2] = [0, 1].map(|h| c.targets().planned().notes(h).copied().collect());
        let attempts = [vec![0; notes[0].len()], vec![0; notes[1].len()]];
        let log = vec![Vector::ZERO; periods];
        Rehearsal {
            settings,
            notes,
            judged: [0; 2],
            attempts,
            best: HashMap::new(),
            aims: [log.clone(), log.clone()],
            sims: [log.clone(), log],
            replays: 0,
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
        for h in 0..2 {
            while let Some(n) = self.notes[h].get(self.judged[h]).filter(|n| n.time_s + s.settle_s <= t).copied() {
                let k = self.judged[h];
                self.judged[h] += 1;
                if self.attempts[h][k] > s.attempts {
                    continue;
                }
                let (from, to) = c.targets().planned().stroke_span(h, k);
                // The stroke's contact falls between its neighbours' (the later half of the
                // gap only up to when it is judged).
                let reach = (n.time_s - from, (to - n.time_s).min(s.settle_s));
                let recent = &strikes[strikes.partition_point(|x| x.time_s < from)..];
                let verdict = judge(&n, h, recent, c.piece_of(), reach, &s);
                if verdict == Verdict::Good && !self.best.contains_key(&(h, k)) {
                    continue;
                }
                // The window a correction of this stroke may touch: its approach.
                let start = from.max(n.time_s - APPROACH_S) - LEARN_BACK_S;
                let (p0, p1) = (period_index(start), period_index(n.time_s + s.settle_s).min(p));
                let score = verdict.score();
                let periods = self.aims[h].len();
                let offsets = c.targets_mut().offsets_mut(h, periods);
                let best = self.best.entry((h, k)).or_insert((f64::INFINITY, Vec::new()));
                if score < best.0 {
                    *best = (score, offsets[p0..=p1].to_vec());
                }
                if verdict == Verdict::Good {
                    continue;
                }
                self.attempts[h][k] += 1;
                if self.attempts[h][k] > s.attempts {
                    if score <= best.0 || best.1.len() != p1 + 1 - p0 {
                        continue;
                    }
                    // Out of attempts: the best take again, for good.
                    offsets[p0..=p1].copy_from_slice(&best.1);
                } else {
                    let contact = verdict.contact_time(&n, &s);
                    let learn_from = period_index(start.max(contact - APPROACH_S).min(contact - LEARN_BACK_S));
                    learn(
                        offsets,
                        verdict,
                        &n,
                        learn_from..=period_index(contact).min(p),
                        &self.aims[h],
                        &self.sims[h],
                        s.tolerance_s,
                    );
                }
                self.replays += 1;
                return Some(start);
            }
        }
        None
    }

    /// After going back to a snapshot at `t`: every note settling later is judged again.
    pub fn restart(&mut self, t: f64) {
        for h in 0..2 {
            self.judged[h] = self.notes[h].partition_point(|n| n.time_s + self.settings.settle_s <= t);
        }
    }
}
