//! The hand notes of a performance on a kit: every mapped note-on whose zone is not
//! `Pedal` (the kick and the hi-hat pedal are feet), struck at the point of its piece its
//! zone sets (`kit::strike_point`), with what a piece is to a drummer ([`Role`]). Strike
//! planning plays them at render time; the training teacher (`learn::corpus`) sticks and
//! plays the same notes.

use crate::kit::{strike_point, Kit, Piece, PieceKind};
use crate::midi::roll::frame_of;
use crate::midi::{DrumEventKind, NoteMap, Performance, Zone};
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum NotesError {
    #[error("{midi}: note map {map:?} sends note {note} to piece {piece:?}, which kit {kit:?} does not have")]
    MissingPiece { midi: PathBuf, map: String, note: u8, piece: String, kit: String },
}

/// Which hand: index into [`MotionFrame::hands`].
pub const LEFT: usize = 0;
pub const RIGHT: usize = 1;

/// What a piece is to a drummer, for the sticking rules.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    HiHat,
    Ride,
    /// Crash, splash, china.
    Crash,
    Snare,
    /// Toms and any other drum.
    Tom,
}

impl Role {
    /// Of a kit piece: hi-hat by its closed damping, ride and snare by id, else by kind.
    pub fn of(piece: &Piece) -> Role {
        match piece.kind {
            PieceKind::Plate if piece.closed_damping_factor.is_some() => Role::HiHat,
            PieceKind::Plate if piece.id.contains("ride") => Role::Ride,
            PieceKind::Plate => Role::Crash,
            PieceKind::Membrane if piece.id.contains("snare") => Role::Snare,
            PieceKind::Membrane => Role::Tom,
        }
    }

    /// Drums (not cymbals): the pieces fills are played on.
    pub fn is_drum(self) -> bool {
        matches!(self, Role::Snare | Role::Tom)
    }

    /// How much a drummer keeps this note when three fall at once (higher keeps).
    pub fn importance(self) -> f32 {
        match self {
            Role::Crash => 4.0,
            Role::Snare | Role::Tom => 3.0,
            Role::Ride => 2.0,
            Role::HiHat => 1.0,
        }
    }
}

/// One hand note before sticking: where and how hard it is struck.
#[derive(Debug, Clone, PartialEq)]
pub struct HandNote {
    pub time_s: f64,
    /// The 60 fps frame of its onset (the roll's).
    pub frame: usize,
    pub note: u8,
    pub velocity: u8,
    /// Index into `kit.pieces`.
    pub piece: usize,
    pub role: Role,
    pub zone: Zone,
    /// Strike point and surface normal (kit frame, metres).
    pub point: [f32; 3],
    pub normal: [f32; 3],
}

/// The hand notes of a performance in time order (ties: note number), and the count of
/// note-ons the map does not know.
pub fn hand_notes(perf: &Performance, map: &NoteMap, kit: &Kit) -> Result<(Vec<HandNote>, usize), NotesError> {
    let mut notes = Vec::new();
    let mut unmapped = 0;
    for e in &perf.events {
        let DrumEventKind::NoteOn { note, velocity } = e.kind else { continue };
        let Some(entry) = map.entry(note) else {
            unmapped += 1;
            continue;
        };
        if entry.zone == Zone::Pedal {
            continue;
        }
        let piece = kit.index_of(&entry.piece).ok_or_else(|| NotesError::MissingPiece {
            midi: perf.path.clone(),
            map: map.name.clone(),
            note,
            piece: entry.piece.clone(),
            kit: kit.name.clone(),
        })?;
        let p = &kit.pieces[piece];
        let (point, normal) = strike_point(kit, p, entry.zone);
        notes.push(HandNote {
            time_s: e.time_s,
            frame: frame_of(e.time_s),
            note,
            velocity,
            piece,
            role: Role::of(p),
            zone: entry.zone,
            point,
            normal,
        });
    }
    notes.sort_by(|a, b| a.time_s.total_cmp(&b.time_s).then(a.note.cmp(&b.note)));
    Ok((notes, unmapped))
}
