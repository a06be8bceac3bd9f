//! Which MIDI note each physical contact played, for SONG.contacts.json and the render
//! summary. The sound never reads this: it is bookkeeping after the fact.
//!
//! A contact plays a note on its piece (or, for a rim shot or cross-stick, on that piece's
//! hoop `<piece>_rim`) whose onset is within [`HIT_WINDOW_S`]; it takes the nearest such note
//! not yet played, and with it every other unplayed note on that piece within
//! [`DOUBLE_TRIGGER_S`] of that one: an e-kit's double triggers (cross-stick and head, head
//! and rim, crosstalk) are one stroke.
//!
//! A pedal note (the kick, the hi-hat's foot chick) is the foot's, every other note a
//! stick's: a foot's contact plays only pedal notes and a stick's only the others, and a
//! hi-hat chick with a stick note on the hi-hat at the same instant are two strokes, not a
//! double trigger (the stick's contact took both, and the chick's counted as spurious).

use crate::interaction::{ContactMessage, Limb};
use crate::midi::{DrumEventKind, NoteMap, Performance, Zone};

/// A contact and a note match within this, seconds (DESIGN.md section 5).
pub const HIT_WINDOW_S: f64 = 0.010;
/// Notes on one piece this close are one stroke, seconds (the planner's merge window).
pub const DOUBLE_TRIGGER_S: f64 = 0.012;

/// A note-on the map knows.
#[derive(Debug, Clone, PartialEq)]
pub struct Onset {
    pub time_s: f64,
    pub note: u8,
    pub velocity: u8,
    pub piece: String,
    pub zone: Zone,
}

/// Every note-on of `perf` the map knows, in time order.
pub fn onsets(perf: &Performance, map: &NoteMap) -> Vec<Onset> {
    let mut out: Vec<Onset> = perf
        .events
        .iter()
        .filter_map(|e| match e.kind {
            DrumEventKind::NoteOn { note, velocity } => map.entry(note).map(|m| Onset {
                time_s: e.time_s,
                note,
                velocity,
                piece: m.piece.clone(),
                zone: m.zone,
            }),
            _ => None,
        })
        .collect();
    out.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    out
}

fn plays(contact: &ContactMessage, onset: &Onset) -> bool {
    let piece = &contact.piece;
    let foot = matches!(contact.limb, Limb::RightFoot | Limb::LeftFoot);
    (piece == &onset.piece || piece.strip_suffix("_rim") == Some(onset.piece.as_str()))
        && foot == (onset.zone == Zone::Pedal)
}

/// For each contact (in time order), the index of the note it played, or `None` (a contact
/// no note asked for); and for each note whether some contact played it. A note already
/// played by a contact on another surface (the head of a rim shot, then its hoop) is played
/// by this one too; a second contact on the same surface (a bounce) is not.
pub fn match_contacts(onsets: &[Onset], contacts: &[ContactMessage]) -> (Vec<Option<usize>>, Vec<bool>) {
    let mut played_by: Vec<Option<usize>> = vec![None; onsets.len()];
    let mut of_contact = Vec::with_capacity(contacts.len());
    for (k, c) in contacts.iter().enumerate() {
        let t = c.time_s as f64;
        let lo = onsets.partition_point(|o| o.time_s < t - HIT_WINDOW_S - 1e-6);
        let near = |free: bool, played_by: &[Option<usize>]| {
            (lo..onsets.len())
                .take_while(|&i| onsets[i].time_s <= t + HIT_WINDOW_S + 1e-6)
                .filter(|&i| plays(c, &onsets[i]))
                .filter(|&i| match played_by[i] {
                    None => free,
                    Some(other) => !free && contacts[other].piece != c.piece,
                })
                .min_by(|&a, &b| (onsets[a].time_s - t).abs().total_cmp(&(onsets[b].time_s - t).abs()))
        };
        let nearest = near(true, &played_by);
        if let Some(i) = nearest {
            let t0 = onsets[i].time_s;
            for j in lo..onsets.len() {
                if onsets[j].time_s > t0 + DOUBLE_TRIGGER_S {
                    break;
                }
                if played_by[j].is_none()
                    && (onsets[j].time_s - t0).abs() <= DOUBLE_TRIGGER_S
                    && onsets[j].piece == onsets[i].piece
                    && (onsets[j].zone == Zone::Pedal) == (onsets[i].zone == Zone::Pedal)
                {
                    played_by[j] = Some(k);
                }
            }
        }
        of_contact.push(nearest.or_else(|| near(false, &played_by)));
    }
    (of_contact, played_by.iter().map(Option::is_some).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn onset(t: f64, note: u8, piece: &str, zone: Zone) -> Onset {
        Onset { time_s: t, note, velocity: 100, piece: piece.into(), zone }
    }

    fn contact(t: f32, piece: &str) -> ContactMessage {
        by(t, piece, Limb::LeftHand)
    }

    fn by(t: f32, piece: &str, limb: Limb) -> ContactMessage {
        ContactMessage {
            piece: piece.into(),
            time_s: t,
            speed_mps: 2.0,
            mass_kg: 0.05,
            x_m: 0.0,
            y_m: 0.0,
            impulse_ns: 0.1,
            hardness: 1.0,
            limb,
        }
    }

    #[test]
    fn double_triggers_are_one_stroke_and_strays_are_spurious() {
        let notes = [
            onset(1.000, 37, "snare", Zone::CrossStick),
            onset(1.004, 38, "snare", Zone::Head),
            onset(2.000, 42, "hihat", Zone::Bow),
            onset(3.000, 38, "snare", Zone::Head),
        ];
        let contacts =
            [contact(1.002, "snare_rim"), contact(1.003, "snare"), contact(2.009, "hihat"), contact(2.5, "snare")];
        let (of, played) = match_contacts(&notes, &contacts);
        // The cross-stick's hoop contact plays both double-triggered notes; its head contact
        // is the same stroke (it names the nearer of them); the stray at 2.5 s is spurious.
        assert_eq!(of, vec![Some(0), Some(1), Some(2), None]);
        let (of, _) = match_contacts(&notes[..2], &[contact(1.002, "snare"), contact(1.006, "snare")]);
        assert_eq!(of, vec![Some(0), None], "a bounce on the same head is not a note");
        assert_eq!(played, vec![true, true, true, false]);
        // 11 ms late is a miss.
        let (of, _) = match_contacts(&notes[2..3], &[contact(2.0111, "hihat")]);
        assert_eq!(of, vec![None]);
    }

    #[test]
    fn a_chick_and_a_stick_on_the_hihat_at_once_are_two_strokes() {
        let notes = [onset(1.000, 44, "hihat", Zone::Pedal), onset(1.001, 42, "hihat", Zone::Bow)];
        // Whichever lands first, each plays its own note.
        let contacts = [by(1.0005, "hihat", Limb::RightHand), by(1.0008, "hihat", Limb::LeftFoot)];
        let (of, played) = match_contacts(&notes, &contacts);
        assert_eq!(of, vec![Some(1), Some(0)]);
        assert_eq!(played, vec![true, true]);
        // A stick on the hi-hat where only the foot was asked for is spurious, and so is a
        // chick where only a stick note was.
        let (of, played) = match_contacts(&notes[..1], &[by(1.0, "hihat", Limb::RightHand)]);
        assert_eq!((of, played), (vec![None], vec![false]));
        let (of, _) = match_contacts(&notes[1..], &[by(1.0, "hihat", Limb::LeftFoot)]);
        assert_eq!(of, vec![None]);
    }
}
