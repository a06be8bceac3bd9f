//! Direct mode: MIDI notes become contact messages without a body, exactly the messages a body
//! would send. Velocity sets the striking speed; the note's zone sets the strike point on the
//! piece (a little off centre for a head, near the edge for a rim shot, bell, bow or edge of a
//! cymbal); a rim shot and a cross-stick also strike the piece's hoop (`<piece>_rim`) when the
//! kit has one. Limbs follow a simple sticking: cymbals right hand, snare left hand, toms right
//! hand, the other hand when the preferred one struck less than 40 ms before; kick right foot,
//! hi-hat pedal left foot.

use super::{ContactMessage, Limb, Message};
use crate::kit::{Kit, PieceKind, Zones};
use crate::midi::{DrumEvent, DrumEventKind, NoteMap, Zone};

/// Fastest one hand can strike twice, seconds.
const SAME_HAND_MIN_S: f64 = 0.040;

#[derive(Debug, Clone)]
struct NotePlan {
    piece: String,
    rim_piece: Option<String>,
    zone: Zone,
    radius_m: f32,
    /// Direction of the strike point from the centre, in the piece's (x, y) axes: toward the
    /// drummer, where the motion stage aims ([`crate::kit::strike_point`]).
    aim_angle: f32,
    is_cymbal: bool,
    is_hihat: bool,
    is_kick: bool,
    hihat_openness: Option<f32>,
}

/// Turns drum events into the contact messages a body would send.
pub struct Director {
    plans: Vec<Option<NotePlan>>,
    zones: Zones,
    strike: crate::kit::StrikeSettings,
    /// Emit the hi-hat openness a note implies (when the song has no CC4 pedal data).
    pub note_openness: bool,
    last_hand_s: [f64; 2],
    count: u64,
    /// The hand the motion stage gave each hand note, (onset in microseconds, piece, hand)
    /// sorted by time: a render with motion sends the hand that strikes in SONG.glb, not
    /// the simple rule.
    sticking: Vec<(i64, String, Limb)>,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum DirectError {
    #[error("note map {map:?} sends note {note} to piece {piece:?}, which kit {kit:?} does not have")]
    MissingPiece { map: String, note: u8, piece: String, kit: String },
}

impl Director {
    pub fn new(kit: &Kit, map: &NoteMap) -> Result<Director, DirectError> {
        let mut plans = Vec::with_capacity(128);
        for (note, entry) in map.notes.iter().enumerate() {
            let Some(entry) = entry else {
                plans.push(None);
                continue;
            };
            let piece = kit.piece(&entry.piece).ok_or_else(|| DirectError::MissingPiece {
                map: map.name.clone(),
                note: note as u8,
                piece: entry.piece.clone(),
                kit: kit.name.clone(),
            })?;
            let rim_id = format!("{}_rim", piece.id);
            plans.push(Some(NotePlan {
                piece: piece.id.clone(),
                rim_piece: kit.piece(&rim_id).map(|p| p.id.clone()),
                zone: entry.zone,
                radius_m: piece.radius_m,
                aim_angle: crate::kit::toward_drummer_angle(piece),
                is_cymbal: piece.kind == PieceKind::Plate,
                is_hihat: piece.closed_damping_factor.is_some(),
                is_kick: piece.id == "kick",
                hihat_openness: entry.hihat_openness,
            }));
        }
        Ok(Director {
            plans,
            zones: kit.zones,
            strike: kit.strike,
            note_openness: true,
            last_hand_s: [-1.0; 2],
            count: 0,
            sticking: Vec::new(),
        })
    }

    /// Take each hand note's hand from the motion stage: `(onset s, piece id, hand)`, hand 0
    /// left and 1 right. Notes not listed keep the simple rule.
    pub fn set_sticking(&mut self, hands: impl IntoIterator<Item = (f64, String, usize)>) {
        self.sticking = hands
            .into_iter()
            .map(|(t, piece, hand)| {
                let limb = if hand == 0 { Limb::LeftHand } else { Limb::RightHand };
                ((t * 1e6).round() as i64, piece, limb)
            })
            .collect();
        self.sticking.sort_by_key(|s| s.0);
    }

    /// The motion stage's hand for a note on `piece` at `t`, if it gave one.
    fn planned_hand(&self, t: f64, piece: &str) -> Option<Limb> {
        let us = (t * 1e6).round() as i64;
        let from = self.sticking.partition_point(|s| s.0 < us);
        self.sticking[from..].iter().take_while(|s| s.0 == us).find(|s| s.1 == piece).map(|s| s.2)
    }

    /// True if the map knows this note.
    pub fn knows(&self, note: u8) -> bool {
        self.plans.get(note as usize).is_some_and(|p| p.is_some())
    }

    /// Append the messages one drum event makes (none for note-offs or unknown notes).
    pub fn on_event(&mut self, ev: &DrumEvent, out: &mut Vec<Message>) {
        let time_s = ev.time_s as f32;
        match ev.kind {
            DrumEventKind::NoteOn { note, velocity } => self.on_note(ev.time_s, note, velocity, out),
            DrumEventKind::NoteOff { .. } => {}
            DrumEventKind::HiHatPedal { value } => {
                out.push(Message::HiHat { time_s, openness: 1.0 - value.min(127) as f32 / 127.0 });
            }
            DrumEventKind::Aftertouch { note, pressure } => {
                if let (true, Some(Some(plan))) = (pressure > 0, self.plans.get(note as usize)) {
                    out.push(Message::Choke { piece: plan.piece.clone(), time_s });
                }
            }
        }
    }

    fn on_note(&mut self, t: f64, note: u8, velocity: u8, out: &mut Vec<Message>) {
        let Some(Some(plan)) = self.plans.get(note as usize) else {
            return;
        };
        let plan = plan.clone();
        self.count += 1;
        let time_s = t as f32;
        let speed = self.strike.speed_for_velocity(velocity);
        let (limb, mass_kg) = match (plan.zone, plan.is_kick, plan.is_hihat) {
            (Zone::Pedal, true, _) => (Limb::RightFoot, self.strike.beater_mass_kg),
            (Zone::Pedal, _, true) => (Limb::LeftFoot, self.strike.hihat_foot_mass_kg),
            _ => {
                let hand = match self.planned_hand(t, &plan.piece) {
                    Some(limb) => {
                        self.last_hand_s[limb as usize] = t;
                        limb
                    }
                    None => self.pick_hand(t, &plan),
                };
                (hand, self.strike.stick_mass_kg)
            }
        };
        if plan.is_hihat {
            let openness =
                if plan.zone == Zone::Pedal { Some(0.0) } else { plan.hihat_openness.filter(|_| self.note_openness) };
            if let Some(openness) = openness {
                out.push(Message::HiHat { time_s, openness });
            }
        }
        let zone = if plan.zone == Zone::Pedal && plan.is_hihat { Zone::Bow } else { plan.zone };
        let fraction = self.zones.fraction(zone);
        // Strike point: on the side toward the drummer, where the body's stick aims, varied a
        // little from stroke to stroke as a player's hand does (deterministic, so renders
        // repeat).
        let angle = plan.aim_angle + 0.35 * jitter(self.count);
        let r = plan.radius_m * fraction * (1.0 + 0.04 * jitter(self.count.wrapping_mul(31)));
        let r = r.min(plan.radius_m * 0.995);
        let contact = |piece: &str, speed_mps: f32, mass_kg: f32, r: f32| ContactMessage {
            piece: piece.to_string(),
            time_s,
            speed_mps,
            mass_kg,
            x_m: r * angle.cos(),
            y_m: r * angle.sin(),
            impulse_ns: 0.0,
            hardness: 1.0,
            limb,
        };
        let foot_speed = if plan.zone == Zone::Pedal && plan.is_hihat { crate::kit::CHICK_SPEED_SCALE } else { 1.0 };
        match (plan.zone, &plan.rim_piece) {
            (Zone::CrossStick, Some(rim)) => {
                // The stick lies on the head and its shoulder clicks the hoop.
                out.push(Message::Contact(contact(rim, speed * 0.7, mass_kg, 0.0)));
                out.push(Message::Contact(contact(&plan.piece, speed * 0.15, mass_kg, r)));
            }
            (Zone::Rim, Some(rim)) => {
                out.push(Message::Contact(contact(&plan.piece, speed, mass_kg, r)));
                out.push(Message::Contact(contact(rim, speed, mass_kg, 0.0)));
            }
            _ => out.push(Message::Contact(contact(&plan.piece, speed * foot_speed, mass_kg, r))),
        }
    }

    fn pick_hand(&mut self, t: f64, plan: &NotePlan) -> Limb {
        let preferred = if plan.is_cymbal || plan.piece.contains("tom") { 1 } else { 0 };
        let hand = if t - self.last_hand_s[preferred] < SAME_HAND_MIN_S { 1 - preferred } else { preferred };
        self.last_hand_s[hand] = t;
        if hand == 0 {
            Limb::LeftHand
        } else {
            Limb::RightHand
        }
    }
}

/// A deterministic value in [-1, 1) for stroke number `i`.
fn jitter(i: u64) -> f32 {
    let mut h = i.wrapping_mul(0x9E37_79B9_7F4A_7C15);
    h ^= h >> 31;
    h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
    h ^= h >> 29;
    (h % 20_000) as f32 / 10_000.0 - 1.0
}
