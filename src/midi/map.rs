//! Note maps: which kit piece and zone each MIDI note strikes, and its DRUMS piano-roll note.
//! Built-in maps live in config/maps/*.toml and are compiled in; users may pass their own file.
//! The file format is documented at the top of config/maps/gm.toml.

use super::file::Performance;
use super::roll::NOTE_NUMS;
use super::DrumEventKind;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The built-in maps: (name for `--map`, TOML text). A map may extend one listed before it.
pub const BUILTIN_MAPS: [(&str, &str); 6] = [
    ("gm", include_str!("../../config/maps/gm.toml")),
    ("gs", include_str!("../../config/maps/gs.toml")),
    ("xg", include_str!("../../config/maps/xg.toml")),
    ("roland-td", include_str!("../../config/maps/roland-td.toml")),
    ("alesis", include_str!("../../config/maps/alesis.toml")),
    ("yamaha-dtx", include_str!("../../config/maps/yamaha-dtx.toml")),
];

/// `--map auto`, the render's default: the built-in map that knows the most of the file's
/// notes ([`NoteMap::auto_for`]).
pub const AUTO_MAP: &str = "auto";

/// The maps `--map auto` chooses among, in the order it prefers on a tie.
const AUTO_MAPS: [&str; 3] = ["gm", "roland-td", "yamaha-dtx"];

/// Where on a piece a note strikes. The kit config gives each zone its radius.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Zone {
    /// Ordinary stroke on a drum head (a little off centre).
    Head,
    /// Dead centre of a head.
    Center,
    /// Rim shot: head near the edge and the hoop at once.
    Rim,
    /// Cross-stick: the stick lies on the head and clicks the hoop.
    CrossStick,
    /// Cymbal bow (between bell and edge).
    Bow,
    /// Cymbal edge (shoulder of the stick on the rim).
    Edge,
    /// Cymbal bell.
    Bell,
    /// A foot: kick beater or hi-hat pedal closing the two cymbals.
    Pedal,
}

impl Zone {
    pub const ALL: [Zone; 8] =
        [Zone::Head, Zone::Center, Zone::Rim, Zone::CrossStick, Zone::Bow, Zone::Edge, Zone::Bell, Zone::Pedal];

    /// The name used in map files ("cross_stick").
    pub fn name(self) -> &'static str {
        match self {
            Zone::Head => "head",
            Zone::Center => "center",
            Zone::Rim => "rim",
            Zone::CrossStick => "cross_stick",
            Zone::Bow => "bow",
            Zone::Edge => "edge",
            Zone::Bell => "bell",
            Zone::Pedal => "pedal",
        }
    }

    pub fn from_name(name: &str) -> Option<Zone> {
        Zone::ALL.into_iter().find(|z| z.name() == name)
    }
}

/// What one note means.
#[derive(Debug, Clone, PartialEq)]
pub struct MapEntry {
    /// Kit piece id ("snare", "tom1", "hihat", ...), checked against the kit when rendering.
    pub piece: String,
    pub zone: Zone,
    /// The note of DRUMS' 16-note piano roll this note becomes (one of [`crate::midi::roll::NOTE_NUMS`]).
    pub roll: u8,
    /// For hi-hat notes when the file has no CC4: the openness (0 closed .. 1 open) the note implies.
    pub hihat_openness: Option<f32>,
}

/// A validated note map.
#[derive(Debug, Clone)]
pub struct NoteMap {
    pub name: String,
    /// Drum channel, 1..=16 (10 for General MIDI).
    pub channel: u8,
    /// Indexed by MIDI note number (128 entries).
    pub notes: Vec<Option<MapEntry>>,
    /// Notes the map knows but leaves out (percussion the kit has no piece for), with the
    /// reason shown in the render's count of them; indexed by note number (128 entries).
    pub skips: Vec<Option<String>>,
    /// The CC4 (hi-hat pedal) value of a closed hi-hat: 127 (Roland, Alesis, Yamaha) or 0.
    /// Pedal values are turned to drumsim's convention (127 closed) as they are read.
    pub cc4_closed: u8,
    /// Where it came from, for messages: "built-in gm" or the file's path.
    pub source: String,
}

/// A note of a performance that the map does not know (or knows and skips).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct UnknownNote {
    pub note: u8,
    /// How many note-ons it has.
    pub count: usize,
    pub first_time_s: f64,
    pub first_tick: u64,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MapError {
    /// Not TOML, or not the shape of a map (a missing or unknown key: serde names it and the line).
    #[error("note map {path}: {message}")]
    Invalid { path: PathBuf, message: String },
    /// A value out of range; `key` is its TOML key, e.g. `notes.38.roll`.
    #[error("note map {path}: {key}: {message}")]
    Value { path: PathBuf, key: String, message: String },
    #[error("note map {name:?} is neither a built-in map ({builtins}) nor a readable file: {source}")]
    NotFound { name: String, builtins: String, source: std::io::Error },
    #[error("{}", unknown_message(.midi, .map, .notes, .suggest))]
    UnknownNotes {
        midi: PathBuf,
        /// The map's name and source.
        map: String,
        /// Ascending by note number.
        notes: Vec<UnknownNote>,
        /// Built-in maps that play every note of the file.
        suggest: Vec<&'static str>,
    },
}

fn unknown_message(midi: &Path, map: &str, notes: &[UnknownNote], suggest: &[&str]) -> String {
    const SHOWN: usize = 12;
    let mut list: Vec<String> = notes
        .iter()
        .take(SHOWN)
        .map(|u| {
            let times = if u.count == 1 { "once".to_string() } else { format!("{} times", u.count) };
            format!("note {} ({times}, first at {:.3} s, tick {})", u.note, u.first_time_s, u.first_tick)
        })
        .collect();
    if notes.len() > SHOWN {
        list.push(format!("and {} more", notes.len() - SHOWN));
    }
    let hint = match suggest {
        [] => "use the map of the kit that recorded the file (--map roland-td, --map yamaha-dtx, \
               or your own with --map FILE)"
            .to_string(),
        some => {
            let names = some.join(" and ");
            let maps: Vec<String> = some.iter().map(|m| format!("--map {m}")).collect();
            format!(
                "the built-in map{} {names} play{} them all: use {}, or your own map with --map FILE",
                if some.len() == 1 { "" } else { "s" },
                if some.len() == 1 { "s" } else { "" },
                maps.join(" or ")
            )
        }
    };
    format!(
        "{}: {} note{} not in note map {map}: {}; {hint}, or leave these notes out with --skip-unknown",
        midi.display(),
        notes.len(),
        if notes.len() == 1 { " is" } else { "s are" },
        list.join(", ")
    )
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMap {
    name: String,
    channel: Option<i64>,
    extends: Option<String>,
    cc4_closed: Option<i64>,
    #[serde(default)]
    notes: BTreeMap<String, RawEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEntry {
    piece: Option<String>,
    zone: Option<String>,
    roll: Option<i64>,
    hihat_openness: Option<f64>,
    skip: Option<String>,
}

impl NoteMap {
    /// A built-in map by name ("gm", "roland-td", "yamaha-dtx").
    pub fn builtin(name: &str) -> Option<NoteMap> {
        let (_, text) = BUILTIN_MAPS.iter().find(|(n, _)| *n == name)?;
        let path = format!("config/maps/{name}.toml");
        let mut map = NoteMap::from_toml_str(text, Path::new(&path)).expect("built-in maps are valid (tested)");
        map.source = format!("built-in {name}");
        Some(map)
    }

    /// The built-in map for `perf` when the user named none: General MIDI, Roland TD or
    /// Yamaha DTX, in that order of preference, whichever knows the most of its note-ons,
    /// then leaves out (skips) the fewest, and plays some. GM's 58 is a vibraslap, skipped;
    /// a Roland TD's, the floor tom's rim. (Alesis, which adds two notes to Roland TD, is
    /// left to `--map alesis`: its 39 is GM's hand clap.) Its source says it was chosen
    /// ("auto: built-in roland-td").
    pub fn auto_for(perf: &Performance) -> NoteMap {
        let mut map = AUTO_MAPS
            .iter()
            .map(|name| NoteMap::builtin(name).expect("built-in map"))
            .min_by_key(|m| {
                let count = |u: Vec<UnknownNote>| u.iter().map(|u| u.count).sum::<usize>();
                let plays_none = !perf
                    .events
                    .iter()
                    .any(|e| matches!(e.kind, DrumEventKind::NoteOn { note, .. } if m.entry(note).is_some()));
                (count(m.unknown_notes(perf)), count(m.skipped_notes(perf)), plays_none)
            })
            .expect("three candidates");
        map.source = format!("auto: {}", map.source);
        map
    }

    /// A built-in map's name, else a map file's path (a built-in name wins: write `./gm` for a
    /// file named gm).
    pub fn load(name_or_path: &str) -> Result<NoteMap, MapError> {
        if let Some(map) = NoteMap::builtin(name_or_path) {
            return Ok(map);
        }
        let path = Path::new(name_or_path);
        let text = crate::files::read_to_string_bounded(path, crate::files::MAX_CONFIG_BYTES).map_err(|source| {
            MapError::NotFound {
                name: name_or_path.to_string(),
                builtins: BUILTIN_MAPS.map(|(n, _)| n).join(", "),
                source,
            }
        })?;
        NoteMap::from_toml_str(&text, path)
    }

    /// Parse and validate map TOML; `path` is used in messages and as the map's source.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<NoteMap, MapError> {
        let raw: RawMap =
            toml::from_str(text).map_err(|e| MapError::Invalid { path: path.to_path_buf(), message: e.to_string() })?;
        let fail = |key: &str, message: String| MapError::Value { path: path.to_path_buf(), key: key.into(), message };
        // A built-in map extends only one listed before it, so loading ends.
        let me = BUILTIN_MAPS.iter().position(|(n, _)| Path::new(&format!("config/maps/{n}.toml")) == path);
        let base = match &raw.extends {
            None => None,
            Some(name) => match BUILTIN_MAPS.iter().position(|(n, _)| n == name) {
                Some(at) if me.is_none_or(|me| at < me) => NoteMap::builtin(name),
                _ => {
                    let names: Vec<&str> = BUILTIN_MAPS.iter().map(|(n, _)| *n).collect();
                    return Err(fail(
                        "extends",
                        format!("{name:?} is not a built-in map; allowed: {}", names.join(", ")),
                    ));
                }
            },
        };
        let channel = match raw.channel {
            None => base.as_ref().map_or(10, |b| b.channel),
            Some(c @ 1..=16) => c as u8,
            Some(c) => return Err(fail("channel", format!("{c} is not a MIDI channel; allowed: 1 ..= 16"))),
        };
        let cc4_closed = match raw.cc4_closed {
            None => base.as_ref().map_or(127, |b| b.cc4_closed),
            Some(v @ (0 | 127)) => v as u8,
            Some(v) => return Err(fail("cc4_closed", format!("{v} is neither 127 nor 0"))),
        };
        if raw.notes.is_empty() && base.is_none() {
            return Err(fail("notes", "the map has no notes".into()));
        }
        let (mut notes, mut skips) = match base {
            Some(b) => (b.notes, b.skips),
            None => (vec![None; 128], vec![None; 128]),
        };
        let mut seen = [false; 128];
        for (key, e) in raw.notes {
            let k = |field: &str| format!("notes.{key}.{field}");
            let note = match key.parse::<u8>() {
                Ok(n) if n <= 127 => n,
                _ => {
                    let message = format!("{key:?} is not a MIDI note number; allowed: 0 ..= 127");
                    return Err(fail(&format!("notes.{key}"), message));
                }
            };
            let n = usize::from(note);
            if std::mem::replace(&mut seen[n], true) {
                return Err(fail(&format!("notes.{key}"), format!("note {note} appears twice")));
            }
            if let Some(reason) = e.skip {
                if e.piece.is_some() || e.zone.is_some() || e.roll.is_some() || e.hihat_openness.is_some() {
                    let message = "a skipped note has only `skip = \"why\"`, no piece, zone, roll or openness";
                    return Err(fail(&format!("notes.{key}"), message.into()));
                }
                if reason.trim().is_empty() {
                    return Err(fail(&k("skip"), "say what the note is, e.g. skip = \"hand clap\"".into()));
                }
                (notes[n], skips[n]) = (None, Some(reason));
                continue;
            }
            let (Some(piece), Some(zone), Some(roll)) = (e.piece, e.zone, e.roll) else {
                let message = "a note needs piece, zone and roll (or skip = \"why\" to leave it out)";
                return Err(fail(&format!("notes.{key}"), message.into()));
            };
            if piece.is_empty() || !piece.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-') {
                return Err(fail(
                    &k("piece"),
                    format!("{piece:?} must be a kit piece id (a word of letters, digits, _ or -), such as \"snare\""),
                ));
            }
            let Some(zone) = Zone::from_name(&zone) else {
                let allowed: Vec<&str> = Zone::ALL.iter().map(|z| z.name()).collect();
                return Err(fail(&k("zone"), format!("{zone:?} is not a zone; allowed: {}", allowed.join(", "))));
            };
            let roll = match u8::try_from(roll) {
                Ok(r) if NOTE_NUMS.contains(&r) => r,
                _ => {
                    let allowed: Vec<String> = NOTE_NUMS.iter().map(u8::to_string).collect();
                    let message = format!("{roll} is not a DRUMS roll note; allowed: {}", allowed.join(", "));
                    return Err(fail(&k("roll"), message));
                }
            };
            let hihat_openness = match e.hihat_openness {
                None => None,
                Some(x) if x.is_finite() && (0.0..=1.0).contains(&x) => Some(x as f32),
                Some(x) => return Err(fail(&k("hihat_openness"), format!("{x} is outside the allowed range 0 ..= 1"))),
            };
            (notes[n], skips[n]) = (Some(MapEntry { piece, zone, roll, hihat_openness }), None);
        }
        Ok(NoteMap { name: raw.name, channel, notes, skips, cc4_closed, source: path.display().to_string() })
    }

    /// A CC4 value as drumsim reads it (0 open .. 127 closed), whichever way the kit sends it.
    pub fn hihat_pedal_value(&self, raw: u8) -> u8 {
        if self.cc4_closed == 0 {
            127 - raw.min(127)
        } else {
            raw
        }
    }

    /// Turn the hi-hat pedal values of `perf` to drumsim's convention ([`Self::hihat_pedal_value`]).
    pub fn normalize_pedal(&self, perf: &mut Performance) {
        for e in &mut perf.events {
            if let DrumEventKind::HiHatPedal { value } = &mut e.kind {
                *value = self.hihat_pedal_value(*value);
            }
        }
    }

    /// True when the map plays every note-on of `perf` (none unknown, none skipped).
    pub fn plays_all(&self, perf: &Performance) -> bool {
        perf.events.iter().all(|e| !matches!(e.kind, DrumEventKind::NoteOn { note, .. } if self.entry(note).is_none()))
    }

    /// Why the map leaves `note` out, if it does.
    pub fn skip_reason(&self, note: u8) -> Option<&str> {
        self.skips.get(usize::from(note))?.as_deref()
    }

    /// The note-ons of `perf` that this map knows and leaves out, ascending by note.
    pub fn skipped_notes(&self, perf: &Performance) -> Vec<UnknownNote> {
        self.count_notes(perf, |note| self.skip_reason(note).is_some())
    }

    /// What `note` means, if the map knows it.
    pub fn entry(&self, note: u8) -> Option<&MapEntry> {
        self.notes.get(usize::from(note))?.as_ref()
    }

    /// The notes of `perf`'s note-ons that this map does not know, ascending.
    pub fn unknown_notes(&self, perf: &Performance) -> Vec<UnknownNote> {
        self.count_notes(perf, |note| self.entry(note).is_none() && self.skip_reason(note).is_none())
    }

    fn count_notes(&self, perf: &Performance, wanted: impl Fn(u8) -> bool) -> Vec<UnknownNote> {
        let mut found: BTreeMap<u8, UnknownNote> = BTreeMap::new();
        for e in &perf.events {
            if let DrumEventKind::NoteOn { note, .. } = e.kind {
                if wanted(note) {
                    let u = found.entry(note).or_insert(UnknownNote {
                        note,
                        count: 0,
                        first_time_s: e.time_s,
                        first_tick: e.tick,
                    });
                    u.count += 1;
                }
            }
        }
        found.into_values().collect()
    }

    /// Ok when the map knows every note-on of `perf`; else [`MapError::UnknownNotes`].
    pub fn check_known(&self, perf: &Performance) -> Result<(), MapError> {
        let notes = self.unknown_notes(perf);
        if notes.is_empty() {
            return Ok(());
        }
        let suggest = BUILTIN_MAPS
            .iter()
            .map(|(name, _)| *name)
            .filter(|name| self.source != format!("built-in {name}"))
            .filter(|name| NoteMap::builtin(name).is_some_and(|m| m.plays_all(perf)))
            .collect();
        Err(MapError::UnknownNotes {
            midi: perf.path.clone(),
            map: format!("{:?} ({})", self.name, self.source),
            notes,
            suggest,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kit::Kit;

    const ONE_NOTE: &str =
        "name = \"mine\"\nchannel = 10\n[notes]\n38 = { piece = \"snare\", zone = \"head\", roll = 38 }\n";

    fn err(text: &str) -> String {
        NoteMap::from_toml_str(text, Path::new("my-map.toml")).unwrap_err().to_string()
    }

    #[test]
    fn builtin_maps_use_pieces_of_the_builtin_kit() {
        let kit = Kit::builtin_default();
        for (name, _) in BUILTIN_MAPS {
            let map = NoteMap::builtin(name).unwrap();
            assert_eq!(map.channel, 10, "{name}");
            for (note, e) in map.notes.iter().enumerate().filter_map(|(n, e)| Some((n, e.as_ref()?))) {
                assert!(kit.piece(&e.piece).is_some(), "{name}: note {note}: piece {:?} not in the kit", e.piece);
                assert_ne!(e.piece, "snare_rim", "{name}: note {note}: rim shots are snare zone rim");
                let is_hihat = e.piece == "hihat";
                assert_eq!(e.hihat_openness.is_some(), is_hihat, "{name}: note {note}: openness iff hi-hat");
            }
        }
        assert!(NoteMap::builtin("roland").is_none());
    }

    #[test]
    fn builtin_maps_hold_the_documented_facts() {
        let gm = NoteMap::builtin("gm").unwrap();
        let td = NoteMap::builtin("roland-td").unwrap();
        let dtx = NoteMap::builtin("yamaha-dtx").unwrap();
        fn e(m: &NoteMap, n: u8) -> (&str, Zone, u8) {
            let e = m.entry(n).unwrap_or_else(|| panic!("{}: no note {n}", m.name));
            (e.piece.as_str(), e.zone, e.roll)
        }
        // The DRUMS roll uses the Roland TD meanings: its 16 notes map to themselves.
        for n in NOTE_NUMS {
            assert_eq!(td.entry(n).unwrap().roll, n, "roland-td {n}");
        }
        assert_eq!(e(&td, 22), ("hihat", Zone::Edge, 42));
        assert_eq!(e(&td, 26), ("hihat", Zone::Edge, 46));
        assert_eq!(e(&td, 40), ("snare", Zone::Rim, 38));
        assert_eq!(e(&td, 58), ("floor_tom", Zone::Rim, 58));
        assert_eq!(td.entry(26).unwrap().hihat_openness, Some(0.8));
        assert_eq!(e(&gm, 37), ("snare", Zone::CrossStick, 37));
        assert_eq!(e(&gm, 35), ("kick", Zone::Pedal, 36));
        assert_eq!(e(&gm, 41), ("floor_tom", Zone::Head, 43));
        assert_eq!(e(&gm, 59), ("ride", Zone::Bow, 51));
        assert_eq!(e(&gm, 53), ("ride", Zone::Bell, 51));
        assert_eq!(e(&gm, 52).0, "china");
        assert_eq!(e(&gm, 55).0, "splash");
        assert!(gm.entry(22).is_none() && gm.entry(39).is_none());
        assert_eq!(gm.skip_reason(39), Some("hand clap"));
        assert_eq!(e(&gm, 56), ("ride", Zone::Bell, 51));
        assert_eq!(e(&gm, 64), ("floor_tom", Zone::Head, 43));
        assert_eq!(e(&gm, 75), ("snare", Zone::CrossStick, 37));
        let xg = NoteMap::builtin("xg").unwrap();
        assert_eq!(e(&xg, 31), ("snare", Zone::Head, 38));
        assert_eq!(e(&xg, 33), ("kick", Zone::Pedal, 36));
        assert_eq!(e(&xg, 34), ("snare", Zone::Rim, 38));
        assert_eq!(e(&xg, 56), ("ride", Zone::Bell, 51), "xg extends gm");
        let alesis = NoteMap::builtin("alesis").unwrap();
        assert_eq!(e(&alesis, 41), ("floor_tom", Zone::Head, 43));
        assert_eq!(e(&alesis, 22), ("hihat", Zone::Edge, 42), "alesis extends roland-td");
        assert_eq!(e(&dtx, 31), ("snare", Zone::Head, 38));
        assert_eq!(e(&dtx, 37), ("snare", Zone::CrossStick, 37));
        assert_eq!(e(&dtx, 33), ("kick", Zone::Pedal, 36));
        assert_eq!(e(&dtx, 85), ("hihat", Zone::Pedal, 44));
        assert_eq!(dtx.entry(85).unwrap().hihat_openness, Some(0.6));
    }

    #[test]
    fn every_general_midi_percussion_note_is_played_or_skipped_with_a_name() {
        for name in ["gm", "gs", "xg"] {
            let map = NoteMap::builtin(name).unwrap();
            // GM Level 1's 47 notes; GM2 and GS add 27..34 and 82..87 (XG its own 13..34).
            let notes = if name == "xg" { 13..=84 } else { 27..=87 };
            for note in notes {
                let played = map.entry(note).is_some();
                let skipped = map.skip_reason(note).is_some_and(|r| !r.trim().is_empty());
                assert!(played != skipped, "{name}: note {note}: played {played}, skipped {skipped}");
            }
        }
    }

    #[test]
    fn a_map_extends_a_built_in_one_and_may_replace_its_notes() {
        let text = "name = \"mine\"\nextends = \"gm\"\ncc4_closed = 0\n[notes]\n39 = { piece = \"snare\", zone = \"rim\", roll = 38 }\n42 = { skip = \"not here\" }\n";
        let map = NoteMap::from_toml_str(text, Path::new("m.toml")).unwrap();
        assert_eq!(map.entry(39).unwrap().zone, Zone::Rim);
        assert!(map.entry(42).is_none() && map.skip_reason(42) == Some("not here"));
        assert_eq!(map.entry(38).unwrap().piece, "snare", "kept from gm");
        assert_eq!((map.channel, map.cc4_closed), (10, 0));
        assert_eq!((map.hihat_pedal_value(0), map.hihat_pedal_value(127), map.hihat_pedal_value(27)), (127, 0, 100));
        assert_eq!(NoteMap::builtin("gm").unwrap().hihat_pedal_value(27), 27);
    }

    #[test]
    fn auto_chooses_general_midi_unless_another_map_knows_more_notes() {
        use crate::midi::{DrumEvent, Performance};
        let perf = |notes: &[u8], cc4: bool| {
            let mut events: Vec<DrumEvent> = notes
                .iter()
                .enumerate()
                .map(|(i, &note)| DrumEvent {
                    time_s: i as f64 * 0.25,
                    tick: i as u64 * 120,
                    kind: DrumEventKind::NoteOn { note, velocity: 90 },
                })
                .collect();
            if cc4 {
                events.push(DrumEvent { time_s: 0.0, tick: 0, kind: DrumEventKind::HiHatPedal { value: 100 } });
            }
            Performance { path: "x.mid".into(), events, duration_s: 1.0, notes_end_s: 1.0, channel: 10 }
        };
        let auto = |notes: &[u8], cc4| NoteMap::auto_for(&perf(notes, cc4)).source;
        assert_eq!(auto(&[36, 38, 42, 39, 54], false), "auto: built-in gm", "claps and tambourine are GM");
        assert_eq!(auto(&[36, 38, 42], true), "auto: built-in gm", "a tie goes to General MIDI");
        assert_eq!(auto(&[36, 38, 58], false), "auto: built-in roland-td", "58 played as a rim, not skipped");
        assert_eq!(auto(&[36, 38, 58, 39], false), "auto: built-in gm", "a clap: General MIDI");
        assert_eq!(auto(&[36, 38, 41, 52], true), "auto: built-in gm", "the demo's notes");
        assert_eq!(auto(&[36, 38, 22, 26], false), "auto: built-in roland-td", "hi-hat edges are TD notes");
        assert_eq!(auto(&[33, 31, 85], true), "auto: built-in yamaha-dtx");
        assert_eq!(auto(&[33, 31, 85], false), "auto: built-in yamaha-dtx", "gm knows them but plays none");
        assert_eq!(auto(&[36, 38, 39, 54], true), "auto: built-in gm", "roland-td does not know 39 and 54");
    }

    #[test]
    fn skipped_notes_and_extends_are_checked() {
        let cases = [
            ("38 = { skip = \"x\", piece = \"snare\" }", "notes.38", "only `skip"),
            ("38 = { skip = \" \" }", "notes.38.skip", "say what the note is"),
            ("38 = { piece = \"snare\" }", "notes.38", "needs piece, zone and roll"),
        ];
        for (line, key, want) in cases {
            let msg = err(&format!("name = \"m\"\n[notes]\n{line}\n"));
            assert!(msg.contains(key) && msg.contains(want), "{line}: {msg}");
        }
        let msg = err("name = \"m\"\nextends = \"gm3\"\n");
        assert!(msg.contains("extends") && msg.contains("gm, gs, xg, roland-td"), "{msg}");
        let msg = err("name = \"m\"\nextends = \"gm\"\ncc4_closed = 64\n");
        assert!(msg.contains("cc4_closed") && msg.contains("neither 127 nor 0"), "{msg}");
    }

    #[test]
    fn a_minimal_map_loads_with_the_default_channel() {
        let map = NoteMap::from_toml_str(&ONE_NOTE.replace("channel = 10\n", ""), Path::new("m.toml")).unwrap();
        assert_eq!((map.channel, map.source.as_str()), (10, "m.toml"));
        assert_eq!(map.entry(38).unwrap().zone, Zone::Head);
        assert!(map.entry(36).is_none() && map.entry(200).is_none());
    }

    #[test]
    fn broken_toml_names_the_file() {
        let msg = err("name = [");
        assert!(msg.contains("my-map.toml"), "{msg}");
    }

    #[test]
    fn bad_values_name_the_file_the_key_and_the_allowed_values() {
        let cases = [
            ("roll = 38", "roll = 40", "notes.38.roll", "36, 37, 38, 42"),
            ("roll = 38", "roll = -1", "notes.38.roll", "not a DRUMS roll note"),
            ("zone = \"head\"", "zone = \"middle\"", "notes.38.zone", "head, center, rim, cross_stick, bow"),
            ("channel = 10", "channel = 17", "channel", "1 ..= 16"),
            ("38 =", "200 =", "notes.200", "0 ..= 127"),
            ("38 =", "snare =", "notes.snare", "0 ..= 127"),
            ("piece = \"snare\"", "piece = \"sn are\"", "notes.38.piece", "kit piece id"),
            ("roll = 38", "roll = 38, hihat_openness = 1.5", "notes.38.hihat_openness", "0 ..= 1"),
        ];
        for (from, to, key, allowed) in cases {
            let msg = err(&ONE_NOTE.replace(from, to));
            assert!(msg.contains("my-map.toml") && msg.contains(key) && msg.contains(allowed), "{to}: {msg}");
        }
    }

    #[test]
    fn unknown_keys_are_rejected() {
        let msg = err(&ONE_NOTE.replace("roll = 38", "roll = 38, velocity = 3"));
        assert!(msg.contains("my-map.toml") && msg.contains("velocity"), "{msg}");
        let msg = err(&format!("drums = 1\n{ONE_NOTE}"));
        assert!(msg.contains("drums"), "{msg}");
    }

    #[test]
    fn a_note_written_twice_is_rejected() {
        let msg = err(&format!("{ONE_NOTE}038 = {{ piece = \"snare\", zone = \"rim\", roll = 38 }}\n"));
        assert!(msg.contains("note 38 appears twice"), "{msg}");
    }
}
