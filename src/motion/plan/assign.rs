//! Which hand plays each note: dynamic programming over the notes in time order.
//!
//! State after note i: the hand that played it, and the last note the other hand played
//! (within the last `memory` notes; older counts as "free"). A note costs the distance from
//! the assigned hand's predicted tip to its strike point; a hand asked to play two notes
//! faster than it can (`min_gap_s` on one piece, plus travel at `travel_mps` between
//! pieces) pays `infeasible` per violation, but for a rebound: a second stroke on the same
//! piece at least `double_gap_s` after the first (a drag's or a double's, which the stick's
//! bounce plays) pays `double_cost`, so a hand plays one where the other hand cannot take
//! the note. The cheapest path wins; notes on it that still strike faster than a hand can
//! (three notes at once for two hands) are dropped and counted, never played impossibly. A travel faster than `travel_mps` is allowed when no
//! assignment avoids it (a drummer's hand can move faster than the usual pace). Two notes
//! on one piece within `merge_s` (an e-kit's bow and bell, a flam's grace note on one pad)
//! are one stroke: the later is `merged` into the earlier and shares its hand.

use super::HandNote;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AssignSettings {
    /// Shortest time between two strokes of one hand on one piece, seconds.
    pub min_gap_s: f64,
    /// Shortest time between a stroke and its rebound on the same piece (a drag, a double),
    /// seconds, and what the DP pays for one.
    pub double_gap_s: f64,
    pub double_cost: f64,
    /// Extra time a hand needs to leave a piece for another, seconds, plus the distance at
    /// this speed.
    pub switch_s: f64,
    pub travel_mps: f64,
    /// Cost per metre between a hand's predicted tip and the strike point.
    pub per_metre: f64,
    pub infeasible: f64,
    /// How many notes back the other hand's last note is remembered.
    pub memory: usize,
    /// Notes on one piece this close are one stroke, seconds.
    pub merge_s: f64,
}

impl Default for AssignSettings {
    fn default() -> Self {
        AssignSettings {
            min_gap_s: 0.035,
            double_gap_s: 0.018,
            double_cost: 5.0,
            switch_s: 0.030,
            travel_mps: 4.0,
            per_metre: 10.0,
            infeasible: 1000.0,
            memory: 48,
            merge_s: 0.012,
        }
    }
}

/// The hand of every note (0 left, 1 right), `None` for dropped notes.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Assignment {
    pub hands: Vec<Option<usize>>,
    /// True for a note played by the stroke of an earlier note on the same piece.
    pub merged: Vec<bool>,
    pub dropped: usize,
}

fn dist(a: [f32; 3], b: [f32; 3]) -> f64 {
    a.iter().zip(&b).map(|(x, y)| ((x - y) as f64).powi(2)).sum::<f64>().sqrt()
}

/// What it costs one hand to play `a` then `b`: nothing at its usual pace, `double_cost`
/// for a rebound on the same piece, `infeasible` for what it cannot do.
fn pace_cost(a: &HandNote, b: &HandNote, s: &AssignSettings) -> f64 {
    let gap = b.time_s - a.time_s + 1e-9;
    let need = if a.piece == b.piece {
        s.min_gap_s
    } else {
        s.min_gap_s.max(s.switch_s + dist(a.point, b.point) / s.travel_mps)
    };
    if gap >= need {
        0.0
    } else if a.piece == b.piece && gap >= s.double_gap_s {
        s.double_cost
    } else {
        s.infeasible
    }
}

const FREE: usize = usize::MAX;

/// A DP state (hand of the note, other hand's last note), its cost, its parent's index.
type Entry = ((usize, usize), f64, usize);

/// Assign `notes` (sorted by time) to hands. `predicted(hand, time_s)` is the hand model's
/// stick tip.
pub fn assign_hands(notes: &[HandNote], predicted: &dyn Fn(usize, f64) -> [f32; 3], s: &AssignSettings) -> Assignment {
    assign_hands_kept(notes, predicted, &|_| None, s)
}

/// [`assign_hands`], with the notes `kept` names a hand for given to that hand (a live
/// window's notes already played, which a newer plan must not give to the other hand).
pub fn assign_hands_kept(
    notes: &[HandNote],
    predicted: &dyn Fn(usize, f64) -> [f32; 3],
    kept: &dyn Fn(&HandNote) -> Option<usize>,
    s: &AssignSettings,
) -> Assignment {
    // One stroke per piece within `merge_s`: the DP sees only the leading notes.
    let mut leader: Vec<usize> = (0..notes.len()).collect();
    for i in 0..notes.len() {
        let earlier = (0..i).rev().take_while(|&j| notes[i].time_s - notes[j].time_s <= s.merge_s);
        if let Some(j) = earlier.filter(|&j| leader[j] == j).find(|&j| notes[j].piece == notes[i].piece) {
            leader[i] = j;
        }
    }
    let lead: Vec<usize> = (0..notes.len()).filter(|&i| leader[i] == i).collect();
    let strokes: Vec<HandNote> = lead.iter().map(|&i| notes[i]).collect();
    let (hands, dropped) = assign_strokes(&strokes, predicted, kept, s);
    let mut out = Assignment { hands: vec![None; notes.len()], merged: vec![false; notes.len()], dropped };
    for (k, &i) in lead.iter().enumerate() {
        out.hands[i] = hands[k];
    }
    for (i, &l) in leader.iter().enumerate() {
        if l != i {
            out.hands[i] = out.hands[l];
            out.merged[i] = true;
            out.dropped += out.hands[i].is_none() as usize;
        }
    }
    out
}

/// The DP over strokes (notes sorted by time, one per stroke).
fn assign_strokes(
    notes: &[HandNote],
    predicted: &dyn Fn(usize, f64) -> [f32; 3],
    kept: &dyn Fn(&HandNote) -> Option<usize>,
    s: &AssignSettings,
) -> (Vec<Option<usize>>, usize) {
    let n = notes.len();
    if n == 0 {
        return (Vec::new(), 0);
    }
    // Per step, the live states: (hand of note i, other hand's last note or FREE), their
    // cost and their parent state's index in the previous step.
    let mut steps: Vec<Vec<Entry>> = Vec::with_capacity(n);
    // Each stroke's kept hand, asked once (the DP prices a stroke for every state).
    let keep: Vec<Option<usize>> = notes.iter().map(kept).collect();
    let here = |i: usize, h: usize| {
        let other = keep[i].is_some_and(|k| k != h);
        s.per_metre * dist(predicted(h, notes[i].time_s), notes[i].point) + if other { s.infeasible } else { 0.0 }
    };
    steps.push((0..2).map(|h| ((h, FREE), here(0, h), 0)).collect());
    let mut slot = vec![usize::MAX; 2 * (s.memory + 1)];
    for i in 1..n {
        let mut next: Vec<Entry> = Vec::new();
        // Where each state sits in `next`: per hand, the other hand's last note i-1-d for
        // d < memory, or FREE in the last slot.
        slot.iter_mut().for_each(|x| *x = usize::MAX);
        let mut put = |state: (usize, usize), cost: f64, parent: usize| {
            let d = if state.1 == FREE { s.memory } else { (i - 1 - state.1).min(s.memory) };
            let at = &mut slot[state.0 * (s.memory + 1) + d];
            match next.get_mut(*at) {
                Some(e) if e.1 <= cost => {}
                Some(e) => *e = (state, cost, parent),
                None => {
                    *at = next.len();
                    next.push((state, cost, parent));
                }
            }
        };
        for (pi, &((h, k), cost, _)) in steps[i - 1].iter().enumerate() {
            // The same hand again: the other hand's last note stays (or is forgotten).
            let k_same = if k != FREE && i - k > s.memory { FREE } else { k };
            let pen = pace_cost(&notes[i - 1], &notes[i], s);
            put((h, k_same), cost + here(i, h) + pen, pi);
            // The other hand: it last played note k.
            let pen = if k == FREE { 0.0 } else { pace_cost(&notes[k], &notes[i], s) };
            put((1 - h, i - 1), cost + here(i, 1 - h) + pen, pi);
        }
        steps.push(next);
    }
    // Walk back from the cheapest end state.
    let mut hands = vec![None; n];
    let last = &steps[n - 1];
    let mut at = (0..last.len()).min_by(|&a, &b| last[a].1.total_cmp(&last[b].1)).unwrap_or(0);
    for i in (0..n).rev() {
        let ((h, _), _, parent) = steps[i][at];
        hands[i] = Some(h);
        at = parent;
    }
    // Drop what a hand still cannot strike: two strokes closer than `min_gap_s`, or than
    // `double_gap_s` for a rebound on the same piece (keep the earlier). Travel faster than
    // the usual pace is left to the hand.
    let mut last_of: [Option<usize>; 2] = [None, None];
    let mut dropped = 0;
    for i in 0..n {
        let Some(h) = hands[i] else { continue };
        if let Some(p) = last_of[h] {
            let gap = if notes[i].piece == notes[p].piece { s.double_gap_s } else { s.min_gap_s };
            if notes[i].time_s - notes[p].time_s + 1e-9 < gap {
                hands[i] = None;
                dropped += 1;
                continue;
            }
        }
        last_of[h] = Some(i);
    }
    (hands, dropped)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn note(t: f64, piece: usize, x: f32) -> HandNote {
        HandNote { time_s: t, piece, point: [x, 0.4, 0.7], normal: [0.0, 0.0, 1.0], velocity: 90, speed_mps: 3.0 }
    }

    /// `notes` sorted and assigned with the right hand predicted on the hi-hat (x = -0.3),
    /// the left on the snare (x = -0.1).
    fn hihat_right_snare_left(mut notes: Vec<HandNote>) -> (Vec<HandNote>, Assignment) {
        notes.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        let pred = |h: usize, _t: f64| if h == 1 { [-0.3, 0.4, 0.75] } else { [-0.1, 0.4, 0.75] };
        let a = assign_hands(&notes, &pred, &AssignSettings::default());
        (notes, a)
    }

    /// No note dropped, the hi-hat's (piece 1) on the right hand, the rest on the left.
    fn each_on_its_predicted_hand(notes: &[HandNote], a: &Assignment) {
        assert_eq!(a.dropped, 0);
        for (n, h) in notes.iter().zip(&a.hands) {
            assert_eq!(*h, Some(if n.piece == 1 { 1 } else { 0 }), "{n:?}");
        }
    }

    #[test]
    fn each_note_goes_to_the_hand_predicted_nearest() {
        // Hi-hat (x = -0.3) eighths predicted for the right hand, snare (x = -0.1) backbeats
        // predicted for the left.
        let mut notes = Vec::new();
        for k in 0..16 {
            notes.push(note(k as f64 * 0.25, 1, -0.3));
            if k % 4 == 2 {
                notes.push(note(k as f64 * 0.25, 0, -0.1));
            }
        }
        let (notes, a) = hihat_right_snare_left(notes);
        each_on_its_predicted_hand(&notes, &a);
    }

    #[test]
    fn a_note_kept_for_a_hand_goes_to_it_and_the_rest_follow_the_prediction() {
        // Snare backbeats the left hand is predicted on; the third was given to the right hand
        // by an earlier plan (live play), which keeps it.
        let mut notes: Vec<_> = (0..8).map(|k| note(k as f64 * 0.25, 1, -0.3)).collect();
        notes.extend((0..4).map(|k| note(0.125 + k as f64 * 0.5, 0, -0.1)));
        notes.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        let pred = |h: usize, _t: f64| if h == 1 { [-0.3, 0.4, 0.75] } else { [-0.1, 0.4, 0.75] };
        let kept = |n: &HandNote| (n.piece == 0 && (n.time_s - 1.125).abs() < 1e-9).then_some(1);
        let a = assign_hands_kept(&notes, &pred, &kept, &AssignSettings::default());
        assert_eq!(a.dropped, 0);
        for (n, h) in notes.iter().zip(&a.hands) {
            let want = if n.piece == 1 || kept(n).is_some() { 1 } else { 0 };
            assert_eq!(*h, Some(want), "{n:?}");
        }
        // Without it, the left hand.
        let free = assign_hands(&notes, &pred, &AssignSettings::default());
        let third = notes.iter().position(|n| n.piece == 0 && (n.time_s - 1.125).abs() < 1e-9).unwrap();
        assert_eq!(free.hands[third], Some(0));
    }

    #[test]
    fn a_roll_too_fast_for_one_hand_alternates() {
        // 32nd notes at 120 BPM (62.5 ms) on the snare are fine for one hand; at 25 ms they
        // are not, even though the prediction says "right hand" every time.
        let notes: Vec<_> = (0..12).map(|k| note(k as f64 * 0.025, 0, -0.1)).collect();
        let pred = |_h: usize, _t: f64| [-0.1, 0.4, 0.75];
        let a = assign_hands(&notes, &pred, &AssignSettings::default());
        assert_eq!(a.dropped, 0);
        let hands: Vec<usize> = a.hands.iter().map(|h| h.unwrap()).collect();
        assert!(hands.windows(2).all(|w| w[0] != w[1]), "{hands:?}");
    }

    #[test]
    fn a_drag_under_a_busy_other_hand_is_a_rebound_of_one_hand() {
        // Hi-hat eighths for the right hand; on the snare a grace note 25 ms before a
        // backbeat: the right hand cannot leave the hi-hat that fast, so the left plays both,
        // the backbeat as the grace note's rebound.
        let drag = |grace_s: f64| {
            let mut notes: Vec<_> = (0..8).map(|k| note(k as f64 * 0.25, 1, -0.3)).collect();
            notes.extend([note(grace_s, 0, -0.1), note(0.5, 0, -0.1)]);
            hihat_right_snare_left(notes)
        };
        let (notes, a) = drag(0.475);
        each_on_its_predicted_hand(&notes, &a);
        // 15 ms apart no stick bounces back in time (nor is it one stroke, as at 12 ms).
        let (_, a) = drag(0.485);
        assert_eq!(a.dropped, 1);
    }

    #[test]
    fn travel_time_splits_a_fast_move_across_the_kit() {
        // Floor tom (x = 0.5) then hi-hat (x = -0.35) 60 ms later: one hand cannot travel
        // 0.85 m in that time, so the two notes go to different hands even if both are
        // predicted right.
        let notes = vec![note(0.0, 3, 0.5), note(0.06, 1, -0.35)];
        let pred = |_h: usize, _t: f64| [0.0, 0.4, 0.75];
        let a = assign_hands(&notes, &pred, &AssignSettings::default());
        assert_ne!(a.hands[0], a.hands[1]);
    }

    #[test]
    fn two_notes_on_one_piece_at_once_are_one_stroke() {
        // Ride bow and bell 3 ms apart, with a snare note on the other hand.
        let notes = vec![note(0.0, 5, 0.5), note(0.003, 5, 0.5), note(0.003, 0, -0.1)];
        let pred = |h: usize, _t: f64| if h == 1 { [0.5, 0.4, 0.75] } else { [-0.1, 0.4, 0.75] };
        let a = assign_hands(&notes, &pred, &AssignSettings::default());
        assert_eq!(a.dropped, 0);
        assert_eq!(a.merged, vec![false, true, false]);
        assert_eq!(a.hands, vec![Some(1), Some(1), Some(0)]);
    }

    #[test]
    fn three_notes_at_once_drop_one_and_say_so() {
        let notes = vec![note(0.0, 0, -0.1), note(0.0, 1, -0.3), note(0.0, 2, 0.3), note(0.5, 0, -0.1)];
        let pred = |h: usize, _t: f64| if h == 1 { [0.3, 0.4, 0.75] } else { [-0.1, 0.4, 0.75] };
        let a = assign_hands(&notes, &pred, &AssignSettings::default());
        assert_eq!(a.dropped, 1);
        assert_eq!(a.hands.iter().filter(|h| h.is_none()).count(), 1);
        assert!(a.hands[3].is_some());
        // The two kept at time 0 are on different hands.
        let kept: Vec<usize> = a.hands[..3].iter().flatten().copied().collect();
        assert_eq!(kept.len(), 2);
        assert_ne!(kept[0], kept[1]);
    }
}
