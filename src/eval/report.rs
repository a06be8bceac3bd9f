//! `drumsim eval SONG.mid --out DIR [--reference REF.motion.json]`: the measures of
//! DESIGN.md section 5 for what `drumsim render` wrote in DIR, as one JSON object.
//!
//! - Hits: a hand or foot note (every note the map knows) is hit when a contact on its
//!   piece (or that piece's `_rim`) begins within +-10 ms of the onset; recall = notes hit /
//!   notes, precision = contacts that match some note / contacts.
//! - Timing: for each hit note, its first matching contact's start - the onset, ms.
//! - Beat alignment (DRUMS): from the hand bones' positions in DIR/SONG.motion.json.
//! - Hands (only with a reference): L1, DTW and jerk of the hand bones against the
//!   reference's (another SONG.motion.json, e.g. mocap exported through the same rig).
//! - IPD: for contacts that carry their stroke's aim (physical renders), the distance from
//!   the aimed strike point to the contact point, mm: mean and p95.
//! - Velocity fidelity: Spearman correlation of each played note's velocity with its first
//!   contact's speed on the kit's speed map: a hi-hat chick closes at
//!   [`crate::kit::CHICK_SPEED_SCALE`] of the map's speed by design (a foot is slower than a
//!   stick), so the left foot's contacts are divided by it before they are
//!   ranked with the sticks' and the beater's.

use super::motion::{
    hand_onsets_s, mean_sd_median, motion_metrics, spearman, HitRates, IpdMm, MotionMetricError, MotionMetrics,
    TimingMs,
};
use crate::interaction::Limb;
use crate::midi::{read_file, DrumEventKind, NoteMap, ReadOptions};
use crate::motion::rig::HAND;
use crate::motion::{Motion, MotionFrame, Pose};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// A contact and a note match within this, seconds.
pub const HIT_WINDOW_S: f64 = 0.010;

#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    #[error(transparent)]
    Midi(#[from] crate::midi::MidiError),
    #[error("{path}: cannot read: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}: not a drumsim {what} file: {source}")]
    Parse { path: PathBuf, what: &'static str, source: serde_json::Error },
    #[error("{path}: {message}")]
    Content { path: PathBuf, message: String },
    #[error(transparent)]
    Metric(#[from] MotionMetricError),
    #[error(transparent)]
    Map(#[from] crate::midi::MapError),
}

#[derive(Deserialize)]
struct ContactsFile {
    #[serde(default)]
    song: String,
    /// The drum channel the render read and the fingerprint of its notes (renders before
    /// these fields have neither).
    channel: Option<u8>,
    notes_fingerprint: Option<String>,
    contacts: Vec<Contact>,
}

#[derive(Deserialize)]
struct Contact {
    piece: String,
    time_s: f64,
    #[serde(default)]
    speed_mps: f64,
    #[serde(default)]
    x_m: f64,
    #[serde(default)]
    y_m: f64,
    #[serde(default)]
    note: Option<ContactNote>,
    #[serde(default)]
    aim_m: Option<[f64; 2]>,
    /// The contact message's limb index (0 left hand .. 3 left foot).
    #[serde(default)]
    limb: Option<i32>,
}

impl Contact {
    /// The speed the kit's speed map would give its note's velocity, had this contact
    /// played it at the speed the note asked: a chick's speed scaled back up.
    fn mapped_speed_mps(&self) -> f64 {
        // The left foot plays only the hi-hat.
        if self.limb.and_then(Limb::from_index) == Some(Limb::LeftFoot) {
            self.speed_mps / crate::kit::CHICK_SPEED_SCALE as f64
        } else {
            self.speed_mps
        }
    }
}

#[derive(Deserialize)]
struct ContactNote {
    velocity: u8,
    time_s: f64,
    note: u8,
}

#[derive(Deserialize)]
struct MotionFile {
    fps: f64,
    bones: Vec<BoneName>,
    frames: Vec<MotionFileFrame>,
}

#[derive(Deserialize)]
struct BoneName {
    name: String,
}

#[derive(Deserialize)]
struct MotionFileFrame {
    bones: Vec<[f32; 7]>,
}

fn read_json<T: serde::de::DeserializeOwned>(path: &Path, what: &'static str) -> Result<T, EvalError> {
    let bytes = std::fs::read(path).map_err(|source| EvalError::Read { path: path.into(), source })?;
    serde_json::from_slice(&bytes).map_err(|source| EvalError::Parse { path: path.into(), what, source })
}

/// The hand bones of a SONG.motion.json as a `Motion` whose hands are those bones.
pub fn read_motion_hands(path: &Path) -> Result<Motion, EvalError> {
    let bytes = std::fs::read(path).map_err(|source| EvalError::Read { path: path.into(), source })?;
    parse_motion_hands(&bytes, path)
}

/// [`read_motion_hands`] on the bytes of a file; `path` is only used in messages.
pub fn parse_motion_hands(bytes: &[u8], path: &Path) -> Result<Motion, EvalError> {
    let file: MotionFile = serde_json::from_slice(bytes).map_err(|source| EvalError::Parse {
        path: path.into(),
        what: "motion",
        source,
    })?;
    let names = ["left_hand", "right_hand"];
    let idx: Vec<usize> = names
        .iter()
        .zip(HAND)
        .map(|(n, default)| file.bones.iter().position(|b| b.name == *n).unwrap_or(default))
        .collect();
    let mut frames = Vec::with_capacity(file.frames.len());
    for (i, f) in file.frames.iter().enumerate() {
        let pose = |b: usize| -> Result<Pose, EvalError> {
            let v = f.bones.get(b).ok_or_else(|| EvalError::Content {
                path: path.into(),
                message: format!("frame {i} has {} bones, no bone {b}", f.bones.len()),
            })?;
            Ok(Pose { pos: [v[0], v[1], v[2]], rot: [v[3], v[4], v[5], v[6]] })
        };
        let hands = [pose(idx[0])?, pose(idx[1])?];
        frames.push(MotionFrame {
            hands,
            chest: Pose::IDENTITY,
            head: Pose::IDENTITY,
            feet: [Pose::IDENTITY; 2],
            face: Vec::new(),
            hihat_openness: 0.0,
        });
    }
    Ok(Motion { fps: file.fps, frames })
}

/// Measure DIR/STEM.* of `song`. `map` None: the map `render --map auto` would choose.
pub fn run_eval(
    song: &Path,
    dir: &Path,
    reference: Option<&Path>,
    map: Option<&NoteMap>,
) -> Result<MotionMetrics, EvalError> {
    let stem = song.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let contacts_path = dir.join(format!("{stem}.contacts.json"));
    let motion_path = dir.join(format!("{stem}.motion.json"));
    if !contacts_path.exists() && !motion_path.exists() {
        return Err(EvalError::Content {
            path: dir.to_path_buf(),
            message: format!(
                "holds neither {stem}.contacts.json nor {stem}.motion.json: render the song there first (drumsim render {} --out {})",
                song.display(),
                dir.display()
            ),
        });
    }
    let contacts: Option<ContactsFile> =
        if contacts_path.exists() { Some(read_json(&contacts_path, "contacts")?) } else { None };
    let channel = contacts.as_ref().and_then(|c| c.channel).or(map.map(|m| m.channel)).unwrap_or(10);
    let perf = read_file(song, &ReadOptions { channel })?;
    if let Some(c) = &contacts {
        if c.notes_fingerprint.as_ref().is_some_and(|f| *f != perf.notes_fingerprint()) {
            return Err(EvalError::Content {
                path: contacts_path.clone(),
                message: format!(
                    "is the render of other notes ({}) than {}: render {} again",
                    if c.song.is_empty() { "another song".to_string() } else { c.song.clone() },
                    song.display(),
                    song.display()
                ),
            });
        }
    }
    let auto;
    let map = match map {
        Some(m) => m,
        None => {
            auto = NoteMap::auto_for(&perf);
            &auto
        }
    };
    // Notes (hand and foot) with their pieces.
    let notes: Vec<(f64, &str)> = perf
        .events
        .iter()
        .filter_map(|e| match e.kind {
            DrumEventKind::NoteOn { note, .. } => map.entry(note).map(|m| (e.time_s, m.piece.as_str())),
            _ => None,
        })
        .collect();
    // Notes the map skips or does not know are not measured; they are counted.
    let skipped: usize = map.skipped_notes(&perf).iter().chain(&map.unknown_notes(&perf)).map(|u| u.count).sum();
    let mut out = MotionMetrics { notes: Some(notes.len()), skipped_notes: Some(skipped), ..MotionMetrics::default() };
    if let Some(contacts) = contacts {
        let matches = |c: &Contact, (t, piece): (f64, &str)| {
            (c.time_s - t).abs() <= HIT_WINDOW_S + 1e-6
                && (c.piece == piece || c.piece.strip_suffix("_rim") == Some(piece))
        };
        let mut errors = Vec::new();
        let mut hit = 0;
        for &n in &notes {
            if let Some(c) =
                contacts.contacts.iter().filter(|c| matches(c, n)).min_by(|a, b| a.time_s.total_cmp(&b.time_s))
            {
                hit += 1;
                errors.push(1e3 * (c.time_s - n.0));
            }
        }
        let real = contacts.contacts.iter().filter(|c| notes.iter().any(|&n| matches(c, n))).count();
        out.contacts = Some(contacts.contacts.len());
        out.hits = Some(HitRates {
            recall: if notes.is_empty() { 1.0 } else { hit as f64 / notes.len() as f64 },
            precision: if contacts.contacts.is_empty() { 1.0 } else { real as f64 / contacts.contacts.len() as f64 },
        });
        // IPD: each contact that carries its stroke's aim (physical renders).
        let mut ipd: Vec<f64> = contacts
            .contacts
            .iter()
            .filter_map(|c| c.aim_m.map(|a| 1e3 * (c.x_m - a[0]).hypot(c.y_m - a[1])))
            .collect();
        if !ipd.is_empty() {
            ipd.sort_by(f64::total_cmp);
            let p95 = ipd[((0.95 * ipd.len() as f64).ceil() as usize).clamp(1, ipd.len()) - 1];
            out.ipd_mm = Some(IpdMm { mean: ipd.iter().sum::<f64>() / ipd.len() as f64, p95 });
        }
        // Velocity fidelity: each note's first contact (the file's own note matches).
        let mut seen = std::collections::HashSet::new();
        let (vel, speed): (Vec<f64>, Vec<f64>) = contacts
            .contacts
            .iter()
            .filter_map(|c| c.note.as_ref().map(|n| (n, c.mapped_speed_mps())))
            .filter(|(n, _)| seen.insert((n.time_s.to_bits(), n.note)))
            .map(|(n, s)| (n.velocity as f64, s))
            .unzip();
        out.velocity_speed_spearman = spearman(&vel, &speed);
        out.timing_ms = mean_sd_median(&errors).map(|(mean, sd, median)| {
            let mut abs: Vec<f64> = errors.iter().map(|e| e.abs()).collect();
            abs.sort_by(f64::total_cmp);
            let p95_abs = abs[((0.95 * abs.len() as f64).ceil() as usize).clamp(1, abs.len()) - 1];
            TimingMs { mean, sd, median, p95_abs }
        });
    }
    if motion_path.exists() {
        let pred = read_motion_hands(&motion_path)?;
        let reference = reference.map(read_motion_hands).transpose()?;
        let m = motion_metrics(&pred, reference.as_ref(), &hand_onsets_s(&perf, map))?;
        out.beat_alignment_ms = m.beat_alignment_ms;
        out.hands = m.hands;
    }
    Ok(out)
}
