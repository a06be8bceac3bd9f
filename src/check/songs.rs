//! Songs played physically through the whole pipeline (hand model, strike planning,
//! retrieval, pedals, the rehearsal, the body at 10 kHz): rolls, flams, a fast groove and a
//! fill made here, and the user's own songs.

use super::{Check, CheckOptions, Measure};
use crate::body::sim::DrummerSettings;
use crate::kit::Kit;
use crate::midi::{DrumEvent, DrumEventKind, NoteMap, Performance};
use crate::perform::matching::{match_contacts, onsets};
use std::path::{Path, PathBuf};

/// Notes hit within 10 ms: the physical render's target is 99.5 %; a check fails well below
/// it, where a body or setting has gone wrong rather than a stroke come late.
const RECALL: f64 = 0.90;
/// Contacts that play no note, per contact: flams on the rearranged kit reach 0.2 (its toms
/// sit where the grace note's stick grazes); play that has broken down goes past 0.25.
const SPURIOUS: f64 = 0.25;
/// Deepest a stick may sink into a piece in a song, mm (the strokes checks hold 2 mm; songs
/// reach pieces at angles the rehearsal does not yet keep to 2 mm: issue 13).
const SINK_MM: f64 = 20.0;
/// Range of the mechanical energy of the moving links, J: the made songs swing the body
/// through 150-190 J on the default kit (the torso and both arms); an unstable controller
/// (`--body feedback=30 --force`) passes 300 J in single strokes.
const ENERGY_J: f64 = 300.0;

/// A song made of `(time s, GM note, velocity)` note-ons (each with a note-off 50 ms later).
fn song(name: &str, notes: &[(f64, u8, u8)]) -> Performance {
    let mut events: Vec<DrumEvent> = Vec::new();
    for &(t, note, velocity) in notes {
        let tick = (t * 960.0) as u64;
        events.push(DrumEvent { time_s: t, tick, kind: DrumEventKind::NoteOn { note, velocity } });
        events.push(DrumEvent { time_s: t + 0.05, tick: tick + 48, kind: DrumEventKind::NoteOff { note } });
    }
    events.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let end = events.last().map_or(0.0, |e| e.time_s);
    Performance { path: PathBuf::from(format!("check/{name}")), events, duration_s: end, notes_end_s: end, channel: 10 }
}

/// The songs made here, in General MIDI notes.
fn made_songs() -> Vec<Performance> {
    let beat = |bpm: f64| 60.0 / bpm;
    // A single-stroke roll in 32nd notes at 90 bpm (12 notes a second), crescendo.
    let roll: Vec<(f64, u8, u8)> =
        (0..96).map(|k| (0.5 + k as f64 * beat(90.0) / 8.0, 38, (40 + k * 80 / 96) as u8)).collect();
    // Flams on the snare and toms: a soft grace note 25 ms before each accent.
    let mut flams = Vec::new();
    for k in 0..16 {
        let t = 0.5 + k as f64 * beat(100.0);
        let note = [38, 38, 48, 45][k % 4];
        flams.push((t - 0.025, note, 45));
        flams.push((t, note, 115));
    }
    // A fast groove: eighths on the hi-hat at 200 bpm, kick and snare.
    let mut groove = Vec::new();
    for k in 0..64 {
        let t = 0.5 + k as f64 * beat(200.0) / 2.0;
        groove.push((t, 42, if k % 2 == 0 { 100 } else { 70 }));
        match k % 8 {
            0 | 3 => groove.push((t, 36, 110)),
            2 | 6 => groove.push((t, 38, 115)),
            _ => {}
        }
    }
    // A fill around the toms in sixteenths at 120 bpm into a crash and kick.
    let mut fill = Vec::new();
    for k in 0..32 {
        let t = 0.5 + k as f64 * beat(120.0) / 4.0;
        fill.push((t, [38, 38, 48, 48, 45, 45, 43, 43][(k / 4) % 8], 100));
    }
    let end = 0.5 + 32.0 * beat(120.0) / 4.0;
    fill.push((end, 49, 120));
    fill.push((end, 36, 120));
    vec![song("roll", &roll), song("flams", &flams), song("groove-200bpm", &groove), song("fill", &fill)]
}

/// Play `perf` physically and measure it.
fn check_song(
    name: String,
    perf: &Performance,
    kit: &Kit,
    map: &NoteMap,
    drummer: &DrummerSettings,
) -> anyhow::Result<Check> {
    let hands = crate::render::Hands::Model(
        Box::new(crate::motion::hands::HandModel::shipped()),
        crate::motion::hands::SHIPPED_WEIGHTS_NAME.into(),
    );
    let staged = crate::render::stage_motion(perf, kit, map, &hands)?;
    let settings = crate::perform::rehearsal::RehearsalSettings::default();
    let end = perf.notes_end_s + 0.5;
    let take = match crate::perform::offline::play_as(kit, perf, map, &staged.planned, end, &settings, drummer.clone())
    {
        Ok(t) => t,
        Err(e) => return Ok(Check::failed(name, e.to_string())),
    };
    let all = onsets(perf, map);
    let (of_contact, played) = match_contacts(&all, &take.messages);
    let hit = played.iter().filter(|p| **p).count() as f64 / all.len().max(1) as f64;
    let spurious = of_contact.iter().filter(|o| o.is_none()).count() as f64 / of_contact.len().max(1) as f64;
    Ok(Check::new(
        name,
        end,
        vec![
            Measure::holds("finite", take.finite),
            Measure::below("energy range", (take.max_energy_j - take.min_energy_j) as f64, ENERGY_J, "J"),
            Measure::at_least("notes hit", hit, RECALL, ""),
            Measure::below("spurious contacts", spurious, SPURIOUS, ""),
            Measure::below("deepest", take.max_penetration_m as f64 * 1e3, SINK_MM, "mm"),
        ],
    ))
}

/// The made songs, then the user's.
pub fn check_songs(opts: &CheckOptions) -> anyhow::Result<Vec<Check>> {
    let (kit, map, drummer) = (&opts.kit, &opts.map, &opts.drummer);
    let gm = NoteMap::builtin("gm").expect("built-in map");
    let mut checks = Vec::new();
    for perf in made_songs() {
        let name =
            format!("song/{}", perf.path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned()));
        if opts.runs(&name) {
            checks.push(check_song(name, &perf, kit, &gm, drummer)?);
        }
    }
    for path in &opts.songs {
        let name = format!("song/{}", display(path));
        if opts.runs(&name) {
            let read = crate::render::RenderOptions { map: String::new(), ..Default::default() };
            let perf = crate::render::read_song(path, map, &read)?;
            checks.push(check_song(name, &perf, kit, map, drummer)?);
        }
    }
    Ok(checks)
}

fn display(path: &Path) -> String {
    path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}
