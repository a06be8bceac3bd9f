//! Sticking: which hand plays each hand note, for a right-handed drummer.
//!
//! Notes in the same 60 fps frame are simultaneous:
//! - two or more on one piece are one stroke: the loudest is kept, the rest dropped (an e-kit
//!   sends a ride's bow and bell, or a snare's head and rim, in the same instant);
//! - three or more: the least important are dropped until two remain (importance: crash 4,
//!   snare and toms 3, ride 2, hi-hat 1, then the louder note), and counted in `dropped`;
//! - two: one per hand by position, the one further right (strike point x) to the right hand,
//!   except the cross-handed hi-hat: a hi-hat with a piece left of centre (the snare, the
//!   left tom, a left crash) goes to the right hand, crossing over the left.
//!
//! Single notes are assigned by a Viterbi search over the whole song (the teacher, like the
//! network, sees the whole sequence), minimising the sum of these costs (the constants below):
//! - a hand striking again within `MIN_SAME_HAND_S` (70 ms): `W_TOO_FAST` (so fast notes
//!   alternate), and a smaller `W_QUICK` below `COMFORT_S`;
//! - travel: metres per second the hand must move from its last strike point, times `W_TRAVEL`
//!   (so the hand nearer the next piece plays it when moving across toms);
//! - roles: hi-hat or ride with the left hand `W_OSTINATO_LEFT` (the right hand keeps the
//!   ostinato); a snare note outside a fill with the right hand `W_SNARE_RIGHT` (backbeats and
//!   ghost notes are the left hand's);
//! - fills (a run of drum notes under `FILL_GAP_S` apart): the same hand twice in a row costs
//!   `W_ALTERNATE` (RLRL), the first note of a fill with the left hand `W_LEAD` (right lead);
//! - crossing: a grip more than `CROSS_MARGIN_M` on the wrong side of the other hand's grip
//!   (where the other hand last struck) costs `W_CROSS` per 5 cm, full when the other hand
//!   struck within `CROSS_RECENT_S`, a fifth otherwise (crossing slowly is allowed, tangling at
//!   speed is not).

use super::strokes::impact_grip;
use super::{HandNote, Role, LEFT, RIGHT};
use crate::kit::Kit;

pub const MIN_SAME_HAND_S: f64 = 0.070;
pub const COMFORT_S: f64 = 0.110;
pub const FILL_GAP_S: f64 = 0.200;
pub const CROSS_MARGIN_M: f32 = 0.05;
pub const CROSS_RECENT_S: f64 = 0.300;
pub const W_TOO_FAST: f32 = 20.0;
pub const W_QUICK: f32 = 0.05;
pub const W_TRAVEL: f32 = 0.3;
pub const W_OSTINATO_LEFT: f32 = 1.5;
pub const W_SNARE_RIGHT: f32 = 0.5;
pub const W_ALTERNATE: f32 = 2.0;
pub const W_LEAD: f32 = 1.0;
pub const W_CROSS: f32 = 6.0;
/// How many events back the search remembers the other hand's last note.
const MEMORY: usize = 16;

/// The sticking of a note list: a hand per note (None: dropped) and how many were dropped.
#[derive(Debug, Clone, PartialEq)]
pub struct Sticking {
    pub hands: Vec<Option<usize>>,
    pub dropped: usize,
}

/// A frame's notes after dropping: one note, or one per hand.
#[derive(Debug, Clone, Copy)]
enum Event {
    Single(usize),
    Pair { left: usize, right: usize },
}

/// Assign hands to `notes` (time order, as [`super::hand_notes`] gives them).
pub fn assign(notes: &[HandNote], _kit: &Kit) -> Sticking {
    let mut hands = vec![None; notes.len()];
    let mut dropped = 0;
    let mut events = Vec::new();
    let mut start = 0;
    while start < notes.len() {
        let end = start + notes[start..].iter().take_while(|n| n.frame == notes[start].frame).count();
        let mut group: Vec<usize> = (start..end).collect();
        // Two notes on one piece in one frame (an e-kit sending bow and bell, a flat flam):
        // one stroke, the louder.
        group.sort_by(|&a, &b| notes[a].piece.cmp(&notes[b].piece).then(notes[b].velocity.cmp(&notes[a].velocity)));
        let before = group.len();
        group.dedup_by_key(|i| notes[*i].piece);
        dropped += before - group.len();
        group.sort();
        if group.len() > 2 {
            let key = |&i: &usize| notes[i].role.importance() + notes[i].velocity as f32 / 256.0;
            group.sort_by(|a, b| key(b).total_cmp(&key(a)).then(a.cmp(b)));
            dropped += group.len() - 2;
            group.truncate(2);
            group.sort();
        }
        events.push(match group[..] {
            [a, b] => pair(notes, a, b),
            _ => Event::Single(group[0]),
        });
        start = end;
    }
    let who = Search { notes, events: &events }.run();
    for (e, w) in events.iter().zip(who) {
        match *e {
            Event::Single(i) => hands[i] = Some(w),
            Event::Pair { left, right } => {
                hands[left] = Some(LEFT);
                hands[right] = Some(RIGHT);
            }
        }
    }
    Sticking { hands, dropped }
}

/// Two simultaneous notes: by position, except the cross-handed hi-hat.
fn pair(notes: &[HandNote], a: usize, b: usize) -> Event {
    let (na, nb) = (&notes[a], &notes[b]);
    let crossed_hat =
        |hat: &HandNote, other: &HandNote| hat.role == Role::HiHat && other.role != Role::HiHat && other.point[0] < 0.0;
    let right_is_a = if crossed_hat(na, nb) {
        true
    } else if crossed_hat(nb, na) {
        false
    } else {
        na.point[0] >= nb.point[0]
    };
    if right_is_a {
        Event::Pair { left: b, right: a }
    } else {
        Event::Pair { left: a, right: b }
    }
}

struct Search<'a> {
    notes: &'a [HandNote],
    events: &'a [Event],
}

/// State after event i: who played it (0 left, 1 right, 2 both) and how many events back the
/// other hand last played (MEMORY: not within memory).
#[derive(Debug, Clone, Copy)]
struct State {
    who: usize,
    back: usize,
}

const STATES: usize = 2 * (MEMORY + 1) + 1;

fn state_index(s: State) -> usize {
    if s.who == 2 {
        STATES - 1
    } else {
        s.who * (MEMORY + 1) + s.back
    }
}

fn state_of(idx: usize) -> State {
    if idx == STATES - 1 {
        State { who: 2, back: 0 }
    } else {
        State { who: idx / (MEMORY + 1), back: idx % (MEMORY + 1) }
    }
}

impl Search<'_> {
    fn time(&self, e: usize) -> f64 {
        self.notes[self.first(e)].time_s
    }

    /// The note a hand played at event `e`.
    fn note_of(&self, e: usize, hand: usize) -> &HandNote {
        match self.events[e] {
            Event::Single(i) => &self.notes[i],
            Event::Pair { left, right } => &self.notes[if hand == LEFT { left } else { right }],
        }
    }

    fn first(&self, e: usize) -> usize {
        match self.events[e] {
            Event::Single(i) => i,
            Event::Pair { left, right } => left.min(right),
        }
    }

    fn single_drum(&self, e: usize) -> bool {
        matches!(self.events[e], Event::Single(i) if self.notes[i].role.is_drum())
    }

    /// A drum note with another drum note within [`FILL_GAP_S`] before (`before`) or after.
    fn fill_neighbour(&self, e: usize, before: bool) -> bool {
        let other = if before { e.checked_sub(1) } else { Some(e + 1).filter(|&o| o < self.events.len()) };
        other.is_some_and(|o| self.single_drum(o) && (self.time(o) - self.time(e)).abs() < FILL_GAP_S)
    }

    /// The last events of (left, right) before event `i + 1`, from the state at `i`.
    fn lasts(&self, i: usize, s: State) -> [Option<usize>; 2] {
        let other = if s.back < MEMORY { i.checked_sub(s.back) } else { None };
        match s.who {
            2 => [Some(i), Some(i)],
            h => {
                let mut l = [None; 2];
                l[h] = Some(i);
                l[1 - h] = other;
                l
            }
        }
    }

    /// What striking `n` with `hand` costs, the hand last having struck at event `last`.
    fn motion_cost(&self, n: &HandNote, hand: usize, last: Option<usize>) -> f32 {
        let Some(p) = last else { return 0.0 };
        let prev = self.note_of(p, hand);
        let dt = n.time_s - prev.time_s;
        let mut c = 0.0;
        if dt < MIN_SAME_HAND_S {
            c += W_TOO_FAST * (1.0 + ((MIN_SAME_HAND_S - dt) / MIN_SAME_HAND_S) as f32);
        }
        if dt < COMFORT_S {
            c += W_QUICK * ((COMFORT_S - dt) * 1000.0 / 40.0) as f32;
        }
        let dist = super::norm(std::array::from_fn(|k| n.point[k] - prev.point[k]));
        c + W_TRAVEL * dist / dt.max(0.04) as f32
    }

    fn single_cost(&self, e: usize, hand: usize, lasts: [Option<usize>; 2], prev_same: bool) -> f32 {
        let Event::Single(i) = self.events[e] else { return 0.0 };
        let n = &self.notes[i];
        let mut c = self.motion_cost(n, hand, lasts[hand]);
        let in_fill = n.role.is_drum() && (self.fill_neighbour(e, true) || self.fill_neighbour(e, false));
        match n.role {
            Role::HiHat | Role::Ride if hand == LEFT => c += W_OSTINATO_LEFT,
            Role::Snare if hand == RIGHT && !in_fill => c += W_SNARE_RIGHT,
            _ => {}
        }
        if in_fill && self.fill_neighbour(e, true) && prev_same {
            c += W_ALTERNATE;
        }
        if in_fill && !self.fill_neighbour(e, true) && hand == LEFT {
            c += W_LEAD;
        }
        if let Some(o) = lasts[1 - hand] {
            let other = self.note_of(o, 1 - hand);
            let gx = impact_grip(hand, n.point)[0];
            let ox = impact_grip(1 - hand, other.point)[0];
            let over = if hand == LEFT { gx - ox } else { ox - gx } - CROSS_MARGIN_M;
            if over > 0.0 {
                let recent = if n.time_s - other.time_s < CROSS_RECENT_S { 1.0 } else { 0.2 };
                c += W_CROSS * recent * (1.0 + over / 0.05);
            }
        }
        c
    }

    /// The hand playing each event (2 for a pair), minimising the total cost.
    fn run(&self) -> Vec<usize> {
        let n = self.events.len();
        if n == 0 {
            return Vec::new();
        }
        let mut cost = vec![f32::INFINITY; STATES];
        let mut from = vec![[usize::MAX; STATES]; n];
        // The first event: nobody has played yet.
        let none = [None, None];
        match self.events[0] {
            Event::Pair { .. } => cost[STATES - 1] = 0.0,
            Event::Single(_) => {
                for h in [LEFT, RIGHT] {
                    cost[state_index(State { who: h, back: MEMORY })] = self.single_cost(0, h, none, false);
                }
            }
        }
        for (e, from_e) in from.iter_mut().enumerate().skip(1) {
            let mut next = vec![f32::INFINITY; STATES];
            for (si, &c0) in cost.iter().enumerate() {
                if !c0.is_finite() {
                    continue;
                }
                let s = state_of(si);
                let lasts = self.lasts(e - 1, s);
                let mut relax = |to: State, c: f32| {
                    let ti = state_index(to);
                    if c0 + c < next[ti] {
                        next[ti] = c0 + c;
                        from_e[ti] = si;
                    }
                };
                match self.events[e] {
                    Event::Pair { left, right } => {
                        let c = self.motion_cost(&self.notes[left], LEFT, lasts[LEFT])
                            + self.motion_cost(&self.notes[right], RIGHT, lasts[RIGHT]);
                        relax(State { who: 2, back: 0 }, c);
                    }
                    Event::Single(_) => {
                        for h in [LEFT, RIGHT] {
                            let prev_same = s.who == h;
                            let back = match s.who {
                                2 => 1,
                                w if w == h => (s.back + 1).min(MEMORY),
                                _ => 1,
                            };
                            relax(State { who: h, back }, self.single_cost(e, h, lasts, prev_same));
                        }
                    }
                }
            }
            cost = next;
        }
        let mut si = (0..STATES).min_by(|&a, &b| cost[a].total_cmp(&cost[b])).unwrap_or(0);
        let mut who = vec![0; n];
        for e in (0..n).rev() {
            who[e] = state_of(si).who;
            si = from[e][si];
        }
        who
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::learn::corpus::strike_point;
    use crate::midi::roll::frame_of;
    use crate::midi::Zone;

    fn note(kit: &Kit, id: &str, time_s: f64, velocity: u8) -> HandNote {
        let piece = kit.index_of(id).unwrap();
        let zone = if kit.pieces[piece].kind == crate::kit::PieceKind::Plate { Zone::Bow } else { Zone::Head };
        let (point, normal) = strike_point(kit, &kit.pieces[piece], zone);
        HandNote {
            time_s,
            frame: frame_of(time_s),
            note: 0,
            velocity,
            piece,
            role: Role::of(&kit.pieces[piece]),
            zone,
            point,
            normal,
        }
    }

    fn sorted(mut v: Vec<HandNote>) -> Vec<HandNote> {
        v.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        v
    }

    fn hands_of(notes: &[HandNote], s: &Sticking, id: &str, kit: &Kit) -> Vec<Option<usize>> {
        notes.iter().zip(&s.hands).filter(|(n, _)| kit.pieces[n.piece].id == id).map(|(_, h)| *h).collect()
    }

    #[test]
    fn a_rock_beat_has_the_right_hand_on_the_hi_hat_and_the_left_on_the_backbeat() {
        let kit = Kit::builtin_default();
        let beat = 0.5; // 120 BPM, eighth-note hi-hat, snare on 2 and 4, a ghost note
        let mut v = Vec::new();
        for i in 0..16 {
            v.push(note(&kit, "hihat", i as f64 * beat / 2.0, 90));
        }
        for b in [1, 3, 5, 7] {
            v.push(note(&kit, "snare", b as f64 * beat, 110));
        }
        v.push(note(&kit, "snare", 2.0 * beat + 0.375, 30));
        let v = sorted(v);
        let s = assign(&v, &kit);
        assert_eq!(s.dropped, 0);
        assert!(hands_of(&v, &s, "hihat", &kit).iter().all(|h| *h == Some(RIGHT)));
        assert!(hands_of(&v, &s, "snare", &kit).iter().all(|h| *h == Some(LEFT)));
    }

    #[test]
    fn two_at_once_split_by_position() {
        let kit = Kit::builtin_default();
        let v = sorted(vec![note(&kit, "ride", 1.0, 100), note(&kit, "snare", 1.0, 100)]);
        let s = assign(&v, &kit);
        assert_eq!(hands_of(&v, &s, "ride", &kit), [Some(RIGHT)]);
        assert_eq!(hands_of(&v, &s, "snare", &kit), [Some(LEFT)]);
        let v = sorted(vec![note(&kit, "tom1", 1.0, 100), note(&kit, "floor_tom", 1.0, 100)]);
        let s = assign(&v, &kit);
        assert_eq!(hands_of(&v, &s, "floor_tom", &kit), [Some(RIGHT)]);
    }

    #[test]
    fn a_fill_alternates_from_the_right_hand() {
        let kit = Kit::builtin_default();
        // A groove bar, then 8 snare sixteenths at 100 BPM.
        let mut v: Vec<HandNote> = (0..8).map(|i| note(&kit, "hihat", i as f64 * 0.3, 80)).collect();
        v.extend((0..8).map(|i| note(&kit, "snare", 2.6 + i as f64 * 0.15, 100)));
        let s = assign(&v, &kit);
        let fill = hands_of(&v, &s, "snare", &kit);
        assert_eq!(fill[0], Some(RIGHT), "right-hand lead");
        assert!(fill.windows(2).all(|w| w[0] != w[1]), "{fill:?}");
    }

    #[test]
    fn notes_too_fast_for_one_hand_alternate_even_on_the_hi_hat() {
        let kit = Kit::builtin_default();
        let v: Vec<HandNote> = (0..12).map(|i| note(&kit, "hihat", i as f64 * 0.05, 80)).collect();
        let s = assign(&v, &kit);
        assert!(s.hands.windows(2).all(|w| w[0] != w[1]), "{:?}", s.hands);
    }

    #[test]
    fn a_fast_tom_run_never_crosses_the_hands() {
        let kit = Kit::builtin_default();
        let ids = ["snare", "snare", "tom1", "tom1", "tom2", "tom2", "floor_tom", "floor_tom"];
        let v: Vec<HandNote> =
            ids.iter().enumerate().map(|(i, id)| note(&kit, id, 1.0 + i as f64 * 0.1, 100)).collect();
        let s = assign(&v, &kit);
        let mut at = [None::<[f32; 3]>; 2];
        for (n, h) in v.iter().zip(&s.hands) {
            let h = h.unwrap();
            at[h] = Some(n.point);
            if let [Some(l), Some(r)] = at {
                let (gl, gr) = (impact_grip(LEFT, l)[0], impact_grip(RIGHT, r)[0]);
                assert!(gl <= gr + CROSS_MARGIN_M, "crossed at {}: {:?}", n.time_s, s.hands);
            }
        }
        assert!(s.hands.windows(2).all(|w| w[0] != w[1]), "sixteenths at 150 BPM alternate: {:?}", s.hands);
    }

    #[test]
    fn three_at_once_drop_the_least_important() {
        let kit = Kit::builtin_default();
        let v =
            sorted(vec![note(&kit, "hihat", 1.0, 120), note(&kit, "crash", 1.0, 100), note(&kit, "snare", 1.0, 100)]);
        let s = assign(&v, &kit);
        assert_eq!(s.dropped, 1);
        assert_eq!(hands_of(&v, &s, "hihat", &kit), [None]);
        assert!(hands_of(&v, &s, "crash", &kit)[0].is_some() && hands_of(&v, &s, "snare", &kit)[0].is_some());
    }

    #[test]
    fn two_at_once_on_one_piece_are_one_stroke() {
        let kit = Kit::builtin_default();
        let v = sorted(vec![note(&kit, "ride", 1.0, 70), note(&kit, "ride", 1.001, 90), note(&kit, "snare", 1.0, 60)]);
        let s = assign(&v, &kit);
        assert_eq!(s.dropped, 1);
        let ride = hands_of(&v, &s, "ride", &kit);
        assert_eq!(ride.iter().filter(|h| h.is_some()).count(), 1);
        assert_eq!(ride[1], Some(RIGHT), "the louder one is kept");
    }
}
