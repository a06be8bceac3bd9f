//! Two renders of one song compared by ear, note by note (physical against direct).
//!
//! Each note's strikes in each render (the contact messages matched to it) are sounded alone
//! through the sound engine, with the hi-hat as open as that render had it at the note, and
//! the two sounds are measured: the onset (the first sample within 40 dB of the sound's
//! peak) and the level (RMS over the 100 ms from the onset). Alone, a note's sound is not
//! masked by the ring of what came before, so the level says what the strike itself did.

use crate::interaction::Message;
use crate::kit::Kit;
use crate::render::{ContactRecord, ContactsFile, HiHatRecord, NoteRef};
use crate::sound::{Engine, EngineSettings, SoundEvent};
use std::collections::HashMap;

const SAMPLE_RATE_HZ: f32 = 48_000.0;
/// The sound starts this long after the window opens; strikes this early are still in it.
const LEAD_S: f64 = 0.02;
/// What is measured after the onset.
const LEVEL_S: f64 = 0.1;
/// Window rendered for each note.
const WINDOW_S: f64 = 0.16;
/// The onset: the first sample within this much of the sound's peak, dB.
const ONSET_BELOW_PEAK_DB: f32 = 40.0;

/// One note sounded by both renders.
#[derive(Debug, Clone, PartialEq)]
pub struct NoteSound {
    pub note: NoteRef,
    /// The piece of the first strike of the note in the reference render.
    pub piece: String,
    /// Onset in `other` minus onset in `reference`, ms.
    pub onset_diff_ms: f64,
    /// Level in `other` minus level in `reference`, dB.
    pub level_diff_db: f64,
}

/// Every note that both renders sounded, compared. Notes either render left silent are
/// not compared (recall and precision count those).
pub fn compare(kit: &Kit, reference: &ContactsFile, other: &ContactsFile) -> anyhow::Result<Vec<NoteSound>> {
    let (ours, _) = by_note(reference);
    let (theirs, index) = by_note(other);
    let mut out = Vec::new();
    for (note, strikes) in &ours {
        let Some(&i) = index.get(&(note.note, note.time_s.to_bits())) else { continue };
        let t0 = note.time_s - LEAD_S;
        let a = sound(kit, strikes, &reference.hihat, t0)?;
        let b = sound(kit, &theirs[i].1, &other.hihat, t0)?;
        let (Some(a), Some(b)) = (a, b) else { continue };
        out.push(NoteSound {
            note: *note,
            piece: strikes[0].contact.piece.clone(),
            onset_diff_ms: (b.0 - a.0) * 1e3,
            level_diff_db: b.1 - a.1,
        });
    }
    Ok(out)
}

/// A note and the contacts that played it.
type NoteStrikes<'a> = (NoteRef, Vec<&'a ContactRecord>);

/// A render's contacts by the note they played, in the order of their first contact, and
/// each note's index by (note, onset).
fn by_note(file: &ContactsFile) -> (Vec<NoteStrikes<'_>>, HashMap<(u8, u64), usize>) {
    let mut notes: Vec<NoteStrikes> = Vec::new();
    let mut index = HashMap::new();
    for c in &file.contacts {
        let Some(n) = c.note else { continue };
        let i = *index.entry((n.note, n.time_s.to_bits())).or_insert_with(|| {
            notes.push((n, Vec::new()));
            notes.len() - 1
        });
        notes[i].1.push(c);
    }
    (notes, index)
}

/// The onset (seconds, in the song's time) and level (dB) of `strikes` sounded alone from
/// `t0`; None if silent.
pub fn sound(
    kit: &Kit,
    strikes: &[&ContactRecord],
    hihat: &[HiHatRecord],
    t0: f64,
) -> anyhow::Result<Option<(f64, f64)>> {
    let settings = EngineSettings { sample_rate_hz: SAMPLE_RATE_HZ, max_block: 256, event_capacity: 64 };
    let mut engine = Engine::new(kit, settings);
    let latency = engine.latency_samples();
    let openness = hihat.iter().take_while(|h| (h.time_s as f64) <= t0 + LEAD_S).last().map_or(0.0, |h| h.openness);
    let mut events = vec![SoundEvent::from_message(&Message::HiHat { time_s: 0.0, openness }, kit, SAMPLE_RATE_HZ)?];
    for s in strikes {
        let mut c = s.contact.clone();
        c.time_s = (c.time_s as f64 - t0).max(0.0) as f32;
        events.push(SoundEvent::from_message(&Message::Contact(c), kit, SAMPLE_RATE_HZ)?);
    }
    events.sort_by_key(|e| e.at_sample);
    let n = latency + (WINDOW_S * SAMPLE_RATE_HZ as f64) as usize;
    let mut mono = Vec::with_capacity(n);
    let (mut left, mut right) = (vec![0.0f32; 256], vec![0.0f32; 256]);
    let mut next = 0;
    crate::sound::denormals::with_flush_to_zero(|| {
        while mono.len() < n {
            let block_end = mono.len() as u64 + 256;
            while next < events.len() && events[next].at_sample < block_end {
                engine.push(events[next]);
                next += 1;
            }
            engine.process(&mut left, &mut right);
            mono.extend(left.iter().zip(&right).map(|(l, r)| 0.5 * (l + r)));
        }
    });
    let x = &mono[latency.min(mono.len())..];
    let peak = x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
    if peak <= 0.0 || !peak.is_finite() {
        return Ok(None);
    }
    let floor = peak * 10f32.powf(-ONSET_BELOW_PEAK_DB / 20.0);
    let Some(onset) = x.iter().position(|v| v.abs() >= floor) else { return Ok(None) };
    let end = (onset + (LEVEL_S * SAMPLE_RATE_HZ as f64) as usize).min(x.len());
    let rms = super::audio::rms(&x[onset..end]);
    Ok(Some((t0 + onset as f64 / SAMPLE_RATE_HZ as f64, 20.0 * rms.max(1e-12).log10())))
}

/// The summary of a comparison: median and 95th percentile of |level difference|
/// (dB), share of notes within 6 dB, share of onsets within 2 ms, 95th percentile of
/// |onset difference| (ms).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoteSoundSummary {
    pub notes: usize,
    pub level_median_abs_db: f64,
    pub level_p95_abs_db: f64,
    pub level_within_6db: f64,
    pub level_median_db: f64,
    pub onset_within_2ms: f64,
    pub onset_p95_abs_ms: f64,
}

pub fn summarize(notes: &[NoteSound]) -> NoteSoundSummary {
    let pct = |mut v: Vec<f64>, q: f64| {
        if v.is_empty() {
            return f64::NAN;
        }
        v.sort_by(|a, b| a.total_cmp(b));
        v[((v.len() - 1) as f64 * q).round() as usize]
    };
    let share =
        |f: &dyn Fn(&NoteSound) -> bool| notes.iter().filter(|n| f(n)).count() as f64 / notes.len().max(1) as f64;
    NoteSoundSummary {
        notes: notes.len(),
        level_median_abs_db: pct(notes.iter().map(|n| n.level_diff_db.abs()).collect(), 0.5),
        level_p95_abs_db: pct(notes.iter().map(|n| n.level_diff_db.abs()).collect(), 0.95),
        level_within_6db: share(&|n| n.level_diff_db.abs() <= 6.0),
        level_median_db: pct(notes.iter().map(|n| n.level_diff_db).collect(), 0.5),
        onset_within_2ms: share(&|n| n.onset_diff_ms.abs() <= 2.0),
        onset_p95_abs_ms: pct(notes.iter().map(|n| n.onset_diff_ms.abs()).collect(), 0.95),
    }
}
