//! `drumsim audition`: every piece of a kit struck alone, at several velocities and in each
//! of its zones, through the same messages direct mode sends and the same sound engine, so
//! a user tuning a kit file can hear and read what changed. Writes one WAV per piece (the
//! hits one after another, [`HIT_SPACING_S`] apart) and `audition.json` with each hit's
//! place in its WAV and its measures ([`crate::eval::timbre`]).

use crate::eval::timbre::{measure_hit, HitMeasures};
use crate::interaction::direct::Director;
use crate::interaction::Message;
use crate::kit::{Kit, PieceKind};
use crate::midi::{DrumEvent, DrumEventKind, MapEntry, NoteMap, Zone};
use crate::outputs::OutputSet;
use crate::sound::wav::WavSink;
use crate::sound::{Engine, EngineSettings, SoundEvent};
use serde::Serialize;
use std::path::{Path, PathBuf};

pub const SAMPLE_RATE_HZ: f32 = 48_000.0;
/// Velocities every hit is played at.
pub const VELOCITIES: [u8; 6] = [20, 40, 64, 90, 110, 127];
/// Time between hits in a piece's WAV, seconds (each hit is measured alone, from silence).
pub const HIT_SPACING_S: f64 = 2.0;
/// Silence before each hit in its window, seconds.
const LEAD_S: f64 = 0.01;

/// One way of playing a piece: its zone, and for a hi-hat how open it is.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Stroke {
    pub piece: String,
    /// `head`, `center`, `rim`, `cross_stick`, `bow`, `edge`, `bell`, `pedal`.
    pub zone: String,
    /// Hi-hat openness (0 closed .. 1 open) while it is struck.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub openness: Option<f32>,
    /// A short name: `snare`, `snare rim`, `hihat closed`, `ride bell`.
    pub name: String,
    #[serde(skip)]
    zone_value: Zone,
}

/// One hit: a stroke at a velocity, where it sits in its piece's WAV, and how it sounds.
#[derive(Debug, Clone, Serialize)]
pub struct Hit {
    #[serde(flatten)]
    pub stroke: Stroke,
    pub velocity: u8,
    /// The piece's WAV and where this hit's window starts in it, seconds.
    pub wav: String,
    pub start_s: f64,
    /// How long the stick (beater, top cymbal) stayed on the struck surface, ms.
    pub contact_ms: f64,
    pub measures: HitMeasures,
}

#[derive(Debug, Serialize)]
pub struct Audition {
    pub kit: String,
    pub sample_rate_hz: f32,
    pub hits: Vec<Hit>,
}

/// The strokes a kit's pieces are played with. A piece named `<drum>_rim` is the drum's
/// hoop, played through its drum's rim shot and cross-stick.
pub fn strokes(kit: &Kit) -> Vec<Stroke> {
    let mut out = Vec::new();
    let mut push = |piece: &str, zone: Zone, zone_name: &str, openness: Option<f32>, name: String| {
        out.push(Stroke { piece: piece.into(), zone: zone_name.into(), openness, name, zone_value: zone });
    };
    for p in &kit.pieces {
        if p.id.ends_with("_rim") && kit.piece(p.id.trim_end_matches("_rim")).is_some() {
            continue;
        }
        let id = p.id.as_str();
        match p.kind {
            PieceKind::Membrane if id == "kick" => push(id, Zone::Pedal, "pedal", None, id.into()),
            PieceKind::Membrane => {
                push(id, Zone::Head, "head", None, id.into());
                if kit.piece(&format!("{id}_rim")).is_some() {
                    push(id, Zone::Rim, "rim", None, format!("{id} rim shot"));
                    push(id, Zone::CrossStick, "cross_stick", None, format!("{id} cross-stick"));
                }
            }
            PieceKind::Plate if p.closed_damping_factor.is_some() => {
                push(id, Zone::Bow, "bow", Some(0.0), format!("{id} closed"));
                push(id, Zone::Bow, "bow", Some(0.8), format!("{id} open"));
                push(id, Zone::Edge, "edge", Some(0.3), format!("{id} half-open edge"));
                push(id, Zone::Pedal, "pedal", Some(0.0), format!("{id} pedal"));
            }
            PieceKind::Plate => {
                for (zone, name) in [(Zone::Bow, "bow"), (Zone::Edge, "edge"), (Zone::Bell, "bell")] {
                    push(id, zone, name, None, format!("{id} {name}"));
                }
            }
        }
    }
    out
}

/// The messages one stroke at one velocity makes at time `time_s`: direct mode's, from a map
/// that knows only this stroke. `count` strokes were played before (the strike point varies
/// from stroke to stroke as under a player's hand).
pub fn stroke_messages(kit: &Kit, stroke: &Stroke, velocity: u8, time_s: f64, count: usize) -> Vec<Message> {
    let mut notes = vec![None; 128];
    notes[60] = Some(MapEntry {
        piece: stroke.piece.clone(),
        zone: stroke.zone_value,
        roll: 38,
        hihat_openness: stroke.openness,
    });
    let map = NoteMap {
        name: "audition".into(),
        channel: 10,
        notes,
        skips: vec![None; 128],
        cc4_closed: 127,
        source: "audition".into(),
    };
    let mut director = Director::new(kit, &map).expect("the stroke's piece is in the kit");
    let mut out = Vec::new();
    // Earlier strokes advance the director's stroke count (its strike-point jitter).
    for i in 0..count {
        let ev = DrumEvent { time_s: -10.0 - i as f64, tick: 0, kind: DrumEventKind::NoteOn { note: 60, velocity } };
        director.on_event(&ev, &mut Vec::new());
    }
    let ev = DrumEvent { time_s, tick: 0, kind: DrumEventKind::NoteOn { note: 60, velocity } };
    director.on_event(&ev, &mut out);
    out
}

/// Play `messages` (times in seconds from 0) on a fresh engine for `len_s` seconds; returns
/// (left, right) and the contact time of the first strike of `piece`, ms.
pub fn play(kit: &Kit, messages: &[Message], len_s: f64) -> anyhow::Result<(Vec<f32>, Vec<f32>, f64)> {
    let mut engine = Engine::new(kit, EngineSettings { sample_rate_hz: SAMPLE_RATE_HZ, ..Default::default() });
    let first_strike = messages.iter().find_map(|m| match m {
        Message::Contact(c) => kit.index_of(&c.piece),
        _ => None,
    });
    for m in messages {
        engine.push(SoundEvent::from_message(m, kit, SAMPLE_RATE_HZ)?);
    }
    // The limiter's look-ahead delays the output: render that much more and drop it from
    // the front, so the signal lines up with the events and is `len_s` long.
    let n = (len_s * SAMPLE_RATE_HZ as f64) as usize;
    let lat = engine.latency_samples();
    let (mut left, mut right) = (vec![0.0; n + lat], vec![0.0; n + lat]);
    engine.process(&mut left, &mut right);
    // Each audition plays one strike per piece (a rim shot strikes the head and its hoop).
    let contact_ms = match first_strike {
        Some(piece) => engine.voice(piece).last_contact.contact_s * 1e3,
        None => 0.0,
    };
    left.drain(..lat);
    right.drain(..lat);
    Ok((left, right, contact_ms))
}

/// One stroke at one velocity, alone: (left, right, contact ms), `len_s` long, the strike
/// [`LEAD_S`] in.
pub fn hit(
    kit: &Kit,
    stroke: &Stroke,
    velocity: u8,
    len_s: f64,
    count: usize,
) -> anyhow::Result<(Vec<f32>, Vec<f32>, f64)> {
    play(kit, &stroke_messages(kit, stroke, velocity, LEAD_S, count), len_s)
}

/// Every stroke of `kit` at every velocity, measured; with `out`, the WAVs and
/// `audition.json` written there (all published together).
pub fn audition(kit: &Kit, out: Option<&Path>) -> anyhow::Result<Audition> {
    let mut hits = Vec::new();
    let mut wavs: Vec<(String, Vec<f32>, Vec<f32>)> = Vec::new();
    for stroke in strokes(kit) {
        let wav = format!("{}.wav", stroke.piece);
        if !wavs.iter().any(|w| w.0 == wav) {
            wavs.push((wav.clone(), Vec::new(), Vec::new()));
        }
        for &velocity in &VELOCITIES {
            let (l, r, contact_ms) = hit(kit, &stroke, velocity, HIT_SPACING_S, 0)?;
            let Some(measures) = measure_hit(&l, &r, SAMPLE_RATE_HZ as f64) else {
                anyhow::bail!("{} at velocity {velocity} made no sound", stroke.name);
            };
            let w = wavs.iter_mut().find(|w| w.0 == wav).expect("pushed above");
            let start_s = w.1.len() as f64 / SAMPLE_RATE_HZ as f64;
            w.1.extend_from_slice(&l);
            w.2.extend_from_slice(&r);
            hits.push(Hit { stroke: stroke.clone(), velocity, wav: wav.clone(), start_s, contact_ms, measures });
        }
    }
    let audition = Audition { kit: kit.name.clone(), sample_rate_hz: SAMPLE_RATE_HZ, hits };
    if let Some(dir) = out {
        std::fs::create_dir_all(dir).map_err(|e| anyhow::anyhow!("cannot create {}: {e}", dir.display()))?;
        let mut set = OutputSet::new();
        for (name, l, r) in &wavs {
            let partial = set.stage(&dir.join(name));
            let mut sink = WavSink::create(&partial, SAMPLE_RATE_HZ as u32)?;
            sink.write(l, r)?;
            sink.finish()?;
        }
        let json: PathBuf = dir.join("audition.json");
        let partial = set.stage(&json);
        crate::outputs::write_synced(&partial, serde_json::to_string_pretty(&audition)?.as_bytes())?;
        set.publish()?;
    }
    Ok(audition)
}

impl Audition {
    /// How many WAVs the audition wrote (one per piece played).
    pub fn wavs(&self) -> usize {
        let mut names: Vec<&str> = self.hits.iter().map(|h| h.wav.as_str()).collect();
        names.dedup();
        names.len()
    }
}

/// The audition as a table: one row per stroke and velocity.
pub fn table(a: &Audition) -> String {
    use std::fmt::Write;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "{:<26} {:>4} {:>7} {:>8} {:>7} {:>7} {:>6} {:>6} {:>7} {:>7} {:>6} {:>7} {:>6}",
        "stroke",
        "vel",
        "level",
        "centr50",
        ">2k50",
        "hi/lo",
        "5ms",
        "peak",
        "dec20",
        "tail4k",
        "flat",
        "pitch",
        "fall"
    );
    let opt = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
    for h in &a.hits {
        let m = &h.measures;
        let _ = writeln!(
            s,
            "{:<26} {:>4} {:>7.1} {:>8.0} {:>7.1} {:>7.1} {:>6.1} {:>6.1} {:>7} {:>7} {:>6} {:>7.1} {:>6} contact {:.1} ms",
            h.stroke.name,
            h.velocity,
            m.level_db,
            m.centroid_50ms_hz,
            m.above_2k_50ms_db,
            m.hi_lo_100ms_db,
            m.first_5ms_db,
            m.onset_to_peak_ms,
            opt(m.decay_20db_ms, 0),
            opt(m.tail_above_4k_db, 1),
            opt(m.tail_flatness, 3),
            m.pitch_start_hz,
            opt(m.pitch_change().map(|c| c * 100.0), 1),
            h.contact_ms,
        );
    }
    s
}
