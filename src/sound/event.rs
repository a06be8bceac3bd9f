//! Plain, copyable events for the audio thread, made from decoded contact messages.

use crate::interaction::Message;
use crate::kit::Kit;

/// A strike of a piece, resolved to the piece's index in the kit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Strike {
    pub piece: usize,
    pub speed_mps: f32,
    pub mass_kg: f32,
    pub x_m: f32,
    pub y_m: f32,
    pub hardness: f32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SoundEventKind {
    Strike(Strike),
    /// Hi-hat openness 0 closed .. 1 open.
    HiHat {
        openness: f32,
    },
    /// A hand grabs this piece: it rings out fast until struck again.
    Choke {
        piece: usize,
    },
}

/// An event at an absolute sample index of the engine's clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SoundEvent {
    pub at_sample: u64,
    pub kind: SoundEventKind,
}

#[derive(Debug, thiserror::Error)]
#[error("contact message names piece {piece:?}, which the kit {kit:?} does not have")]
pub struct UnknownPiece {
    pub piece: String,
    pub kit: String,
}

impl SoundEvent {
    /// Resolve a message against the kit; its time (seconds) becomes a sample index.
    pub fn from_message(msg: &Message, kit: &Kit, sample_rate_hz: f32) -> Result<SoundEvent, UnknownPiece> {
        let index = |piece: &str| {
            kit.index_of(piece).ok_or_else(|| UnknownPiece { piece: piece.to_string(), kit: kit.name.clone() })
        };
        let at_sample = (msg.time_s().max(0.0) as f64 * sample_rate_hz as f64).round() as u64;
        let kind = match msg {
            Message::Contact(c) => SoundEventKind::Strike(Strike {
                piece: index(&c.piece)?,
                speed_mps: c.speed_mps,
                mass_kg: c.mass_kg,
                x_m: c.x_m,
                y_m: c.y_m,
                hardness: c.hardness,
            }),
            Message::HiHat { openness, .. } => SoundEventKind::HiHat { openness: *openness },
            Message::Choke { piece, .. } => SoundEventKind::Choke { piece: index(piece)? },
        };
        Ok(SoundEvent { at_sample, kind })
    }
}
