//! Note maps: which kit piece and zone each MIDI note strikes, and its DRUMS piano-roll note.
//! Built-in maps live in config/maps/*.toml and are compiled in; users may pass their own file.
//! The file format is documented at the top of config/maps/gm.toml.

use super::file::Performance;
use super::roll::NOTE_NUMS;
use super::DrumEventKind;
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The built-in maps: (name for `--map`, TOML text).
pub const BUILTIN_MAPS: [(&str, &str); 3] = [
    ("gm", include_str!("../../config/maps/gm.toml")),
    ("roland-td", include_str!("../../config/maps/roland-td.toml")),
    ("yamaha-dtx", include_str!("../../config/maps/yamaha-dtx.toml")),
];

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
    /// Where it came from, for messages: "built-in gm" or the file's path.
    pub source: String,
}

/// A note of a performance that the map does not know.
#[derive(Debug, Clone, Copy, PartialEq)]
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
        /// Built-in maps that know every note of the file.
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
                "the built-in map{} {names} know{} them all: use {}, or your own map with --map FILE",
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
    notes: BTreeMap<String, RawEntry>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawEntry {
    piece: String,
    zone: String,
    roll: i64,
    hihat_openness: Option<f64>,
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
        let channel = match raw.channel.unwrap_or(10) {
            c @ 1..=16 => c as u8,
            c => return Err(fail("channel", format!("{c} is not a MIDI channel; allowed: 1 ..= 16"))),
        };
        if raw.notes.is_empty() {
            return Err(fail("notes", "the map has no notes".into()));
        }
        let mut notes: Vec<Option<MapEntry>> = vec![None; 128];
        for (key, e) in raw.notes {
            let k = |field: &str| format!("notes.{key}.{field}");
            let note = match key.parse::<u8>() {
                Ok(n) if n <= 127 => n,
                _ => {
                    let message = format!("{key:?} is not a MIDI note number; allowed: 0 ..= 127");
                    return Err(fail(&format!("notes.{key}"), message));
                }
            };
            if notes[usize::from(note)].is_some() {
                return Err(fail(&format!("notes.{key}"), format!("note {note} appears twice")));
            }
            if e.piece.is_empty() || !e.piece.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-') {
                return Err(fail(
                    &k("piece"),
                    format!(
                        "{:?} must be a kit piece id (a word of letters, digits, _ or -), such as \"snare\"",
                        e.piece
                    ),
                ));
            }
            let Some(zone) = Zone::from_name(&e.zone) else {
                let allowed: Vec<&str> = Zone::ALL.iter().map(|z| z.name()).collect();
                return Err(fail(&k("zone"), format!("{:?} is not a zone; allowed: {}", e.zone, allowed.join(", "))));
            };
            let roll = match u8::try_from(e.roll) {
                Ok(r) if NOTE_NUMS.contains(&r) => r,
                _ => {
                    let allowed: Vec<String> = NOTE_NUMS.iter().map(u8::to_string).collect();
                    let message = format!("{} is not a DRUMS roll note; allowed: {}", e.roll, allowed.join(", "));
                    return Err(fail(&k("roll"), message));
                }
            };
            let hihat_openness = match e.hihat_openness {
                None => None,
                Some(x) if x.is_finite() && (0.0..=1.0).contains(&x) => Some(x as f32),
                Some(x) => return Err(fail(&k("hihat_openness"), format!("{x} is outside the allowed range 0 ..= 1"))),
            };
            notes[usize::from(note)] = Some(MapEntry { piece: e.piece, zone, roll, hihat_openness });
        }
        Ok(NoteMap { name: raw.name, channel, notes, source: path.display().to_string() })
    }

    /// What `note` means, if the map knows it.
    pub fn entry(&self, note: u8) -> Option<&MapEntry> {
        self.notes.get(usize::from(note))?.as_ref()
    }

    /// The notes of `perf`'s note-ons that this map does not know, ascending.
    pub fn unknown_notes(&self, perf: &Performance) -> Vec<UnknownNote> {
        let mut found: BTreeMap<u8, UnknownNote> = BTreeMap::new();
        for e in &perf.events {
            if let DrumEventKind::NoteOn { note, .. } = e.kind {
                if self.entry(note).is_none() {
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
            .filter(|name| NoteMap::builtin(name).is_some_and(|m| m.unknown_notes(perf).is_empty()))
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
        assert_eq!(e(&dtx, 31), ("snare", Zone::Head, 38));
        assert_eq!(e(&dtx, 37), ("snare", Zone::CrossStick, 37));
        assert_eq!(e(&dtx, 33), ("kick", Zone::Pedal, 36));
        assert_eq!(e(&dtx, 85), ("hihat", Zone::Pedal, 44));
        assert_eq!(dtx.entry(85).unwrap().hihat_openness, Some(0.6));
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
