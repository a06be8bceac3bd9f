//! MIDI files in, drum events out: files built here byte by byte for each case the reader must
//! handle (tempo maps, SMPTE, running status, damaged files), then every Groove MIDI Dataset file.

use drumsim::midi::roll::{column, piano_roll, NOTE_NUMS};
use drumsim::midi::{read_file, DrumEventKind, MapError, MidiError, NoteMap, Performance, ReadOptions};
use midly::num::{u15, u24, u28, u4, u7};
use midly::{Format, Header, MetaMessage, MidiMessage, Smf, Timing, TrackEvent, TrackEventKind};
use std::path::{Path, PathBuf};

const DRUMS: u8 = 10;

fn ev(delta: u32, kind: TrackEventKind<'static>) -> TrackEvent<'static> {
    TrackEvent { delta: u28::new(delta), kind }
}

fn midi(channel: u8, message: MidiMessage) -> TrackEventKind<'static> {
    TrackEventKind::Midi { channel: u4::new(channel - 1), message }
}

fn on(channel: u8, key: u8, vel: u8) -> TrackEventKind<'static> {
    midi(channel, MidiMessage::NoteOn { key: u7::new(key), vel: u7::new(vel) })
}

fn tempo(us: u32) -> TrackEventKind<'static> {
    TrackEventKind::Meta(MetaMessage::Tempo(u24::new(us)))
}

const END: TrackEventKind<'static> = TrackEventKind::Meta(MetaMessage::EndOfTrack);

fn smf_bytes(format: Format, timing: Timing, tracks: Vec<Vec<TrackEvent<'static>>>) -> Vec<u8> {
    let mut smf = Smf::new(Header::new(format, timing));
    smf.tracks = tracks;
    let mut bytes = Vec::new();
    smf.write_std(&mut bytes).unwrap();
    bytes
}

fn metrical(ticks_per_beat: u16) -> Timing {
    Timing::Metrical(u15::new(ticks_per_beat))
}

/// A file in this test binary's scratch folder.
fn write_temp(name: &str, bytes: &[u8]) -> PathBuf {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("midi_files-{name}"));
    std::fs::write(&path, bytes).unwrap();
    path
}

fn read(name: &str, bytes: &[u8]) -> Result<Performance, MidiError> {
    read_file(&write_temp(name, bytes), &ReadOptions::default())
}

fn note_ons(perf: &Performance) -> Vec<(u8, f64)> {
    let mut out = Vec::new();
    for e in &perf.events {
        if let DrumEventKind::NoteOn { note, .. } = e.kind {
            out.push((note, e.time_s));
        }
    }
    out
}

fn assert_close(got: f64, want: f64, what: &str) {
    assert!((got - want).abs() < 1e-6, "{what}: got {got}, want {want}");
}

#[test]
fn type1_tempo_map_from_any_track_gives_hand_computed_seconds() {
    // 480 ticks per beat. Track 0: 120 BPM, then 240 BPM at tick 960. Track 2 (not track 0):
    // 60 BPM at tick 1920. Track 1 holds the notes.
    let conductor = vec![ev(0, tempo(500_000)), ev(960, tempo(250_000)), ev(1920, END)];
    let notes = vec![
        ev(0, on(DRUMS, 36, 100)),
        ev(480, on(DRUMS, 38, 90)),
        ev(480, on(DRUMS, 42, 80)),
        ev(480, on(DRUMS, 36, 70)),
        ev(960, on(DRUMS, 38, 60)),
        ev(0, on(DRUMS, 38, 0)),
        ev(0, END),
    ];
    let late_tempo = vec![ev(1920, tempo(1_000_000)), ev(960, END)];
    let bytes = smf_bytes(Format::Parallel, metrical(480), vec![conductor, notes, late_tempo]);
    let perf = read("tempo-map.mid", &bytes).unwrap();
    // tick 0: 0; 480: 0.5; 960: 1.0; 1440: 1.0 + 1 beat at 0.25 s; 2400: 1.5 + 1 beat at 1 s.
    let want = [(36, 0.0), (38, 0.5), (42, 1.0), (36, 1.25), (38, 2.5)];
    let got = note_ons(&perf);
    assert_eq!(got.len(), want.len(), "{got:?}");
    for ((gn, gt), (wn, wt)) in got.iter().zip(want) {
        assert_eq!(*gn, wn);
        assert_close(*gt, wt, &format!("note {wn}"));
    }
    let last = perf.events.last().unwrap();
    assert_eq!(last.kind, DrumEventKind::NoteOff { note: 38 }, "velocity-0 note-on is a note-off, after its note-on");
    assert_eq!(last.tick, 2400);
    // Track 2 ends last, at tick 2880: 1.5 s + 2 beats at 1 s.
    assert_close(perf.duration_s, 3.5, "duration");
    assert_eq!(perf.channel, DRUMS);
}

#[test]
fn smpte_timing_counts_frames_and_ignores_tempo() {
    let track = vec![ev(0, tempo(250_000)), ev(1500, on(DRUMS, 38, 100)), ev(500, END)];
    let timing = Timing::Timecode(midly::Fps::Fps25, 40); // 1000 ticks per second
    let perf = read("smpte25.mid", &smf_bytes(Format::SingleTrack, timing, vec![track.clone()])).unwrap();
    assert_close(note_ons(&perf)[0].1, 1.5, "25 fps note");
    assert_close(perf.duration_s, 2.0, "25 fps duration");
    let timing = Timing::Timecode(midly::Fps::Fps29, 100); // 29.97 fps
    let perf = read("smpte29.mid", &smf_bytes(Format::SingleTrack, timing, vec![track])).unwrap();
    assert_close(note_ons(&perf)[0].1, 1500.0 * 1001.0 / 3_000_000.0, "29.97 fps note");
}

#[test]
fn running_status_and_velocity_zero_note_off() {
    // Type 0, one track, 96 ticks per beat, written by hand with running status.
    let track: &[u8] = &[
        0x00, 0x99, 36, 100, // note-on kick, channel 10
        0x60, 38, 80, // running status: note-on snare one beat later
        0x00, 36, 0, // running status, velocity 0: kick off
        0x00, 0xB9, 4, 90, // CC4 hi-hat pedal
        0x00, 0xFF, 0x2F, 0x00,
    ];
    let mut bytes = b"MThd\0\0\0\x06\0\0\0\x01\0\x60MTrk".to_vec();
    bytes.extend((track.len() as u32).to_be_bytes());
    bytes.extend(track);
    let perf = read("running-status.mid", &bytes).unwrap();
    let kinds: Vec<(DrumEventKind, u64)> = perf.events.iter().map(|e| (e.kind, e.tick)).collect();
    assert_eq!(
        kinds,
        [
            (DrumEventKind::NoteOn { note: 36, velocity: 100 }, 0),
            (DrumEventKind::NoteOn { note: 38, velocity: 80 }, 96),
            (DrumEventKind::NoteOff { note: 36 }, 96),
            (DrumEventKind::HiHatPedal { value: 90 }, 96),
        ]
    );
    assert_close(perf.events[1].time_s, 0.5, "one beat at 120 BPM");
}

#[test]
fn only_the_drum_channel_is_kept_cc4_and_poly_aftertouch_read() {
    let track = vec![
        ev(0, on(1, 60, 100)), // piano, channel 1
        ev(0, on(DRUMS, 49, 110)),
        ev(10, midi(DRUMS, MidiMessage::Controller { controller: u7::new(4), value: u7::new(127) })),
        ev(0, midi(DRUMS, MidiMessage::Controller { controller: u7::new(7), value: u7::new(50) })), // volume: ignored
        ev(0, midi(1, MidiMessage::Controller { controller: u7::new(4), value: u7::new(3) })),      // other channel
        ev(20, midi(DRUMS, MidiMessage::Aftertouch { key: u7::new(49), vel: u7::new(127) })),
        ev(0, midi(DRUMS, MidiMessage::NoteOff { key: u7::new(49), vel: u7::new(64) })),
        ev(0, on(1, 60, 0)),
        ev(0, END),
    ];
    let bytes = smf_bytes(Format::SingleTrack, metrical(480), vec![track]);
    let perf = read("channels.mid", &bytes).unwrap();
    let kinds: Vec<DrumEventKind> = perf.events.iter().map(|e| e.kind).collect();
    assert_eq!(
        kinds,
        [
            DrumEventKind::NoteOn { note: 49, velocity: 110 },
            DrumEventKind::HiHatPedal { value: 127 },
            DrumEventKind::Aftertouch { note: 49, pressure: 127 },
            DrumEventKind::NoteOff { note: 49 },
        ]
    );
    let path = write_temp("channels.mid", &bytes);
    let piano = read_file(&path, &ReadOptions { channel: 1 }).unwrap();
    assert_eq!(note_ons(&piano), [(60, 0.0)]);
    let err = read_file(&path, &ReadOptions { channel: 17 }).unwrap_err().to_string();
    assert!(err.contains("17") && err.contains("1 ..= 16"), "{err}");
}

#[test]
fn type2_patterns_play_one_after_another() {
    let a = vec![ev(0, on(DRUMS, 36, 100)), ev(960, END)];
    let b = vec![ev(0, tempo(1_000_000)), ev(480, on(DRUMS, 38, 100)), ev(0, END)];
    let perf = read("type2.mid", &smf_bytes(Format::Sequential, metrical(480), vec![a, b])).unwrap();
    // Pattern b starts at tick 960 = 1.0 s, then one beat at 60 BPM.
    let got = note_ons(&perf);
    assert_eq!(got.len(), 2);
    assert_close(got[1].1, 2.0, "second pattern's note");
    assert_eq!(perf.events[1].tick, 1440);
}

fn small_song() -> Vec<u8> {
    let track = vec![ev(0, tempo(400_000)), ev(0, on(DRUMS, 36, 100)), ev(240, on(DRUMS, 38, 100)), ev(240, END)];
    let extra = vec![ev(100, on(DRUMS, 42, 90)), ev(0, END)];
    smf_bytes(Format::Parallel, metrical(480), vec![track, extra])
}

#[test]
fn every_truncation_is_an_error_naming_the_file() {
    let bytes = small_song();
    assert!(read("whole.mid", &bytes).is_ok());
    for cut in 1..bytes.len() {
        match read("cut.mid", &bytes[..cut]) {
            Err(e @ MidiError::Truncated { .. }) => {
                assert!(e.to_string().contains("midi_files-cut.mid"), "{e}")
            }
            other => panic!("cut at {cut} of {}: {other:?}", bytes.len()),
        }
    }
}

#[test]
fn malformed_event_is_an_error_not_a_shorter_song() {
    let mut bytes = small_song();
    // The first event of track 1 is its tempo at byte 22+1; make its status byte a data byte
    // with no running status to fall back on.
    let at = bytes.windows(3).position(|w| w == [0xFF, 0x51, 0x03]).unwrap();
    bytes[at] = 0x45;
    let err = read("malformed.mid", &bytes).unwrap_err();
    assert!(matches!(err, MidiError::Parse { .. }), "{err:?}");
    let msg = err.to_string();
    assert!(msg.contains("malformed.mid") && msg.contains("track 1") && msg.contains("malformed event"), "{msg}");
}

#[test]
fn empty_non_midi_and_missing_files_are_errors() {
    let err = read("empty.mid", b"").unwrap_err();
    assert!(matches!(err, MidiError::Empty { .. }) && err.to_string().contains("empty.mid"), "{err}");
    let err = read("text.mid", b"this is a text file, not MIDI").unwrap_err();
    assert!(matches!(err, MidiError::NotMidi { .. }), "{err:?}");
    assert!(err.to_string().contains("text.mid") && err.to_string().contains("MThd"), "{err}");
    let err = read_file(Path::new("/nonexistent/song.mid"), &ReadOptions::default()).unwrap_err();
    assert!(matches!(err, MidiError::Read { .. }) && err.to_string().contains("/nonexistent/song.mid"), "{err}");
}

#[test]
fn huge_file_is_refused_before_reading() {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("midi_files-huge.mid");
    let file = std::fs::File::create(&path).unwrap();
    file.set_len(65 * 1024 * 1024).unwrap(); // sparse: no disk used
    let err = read_file(&path, &ReadOptions::default()).unwrap_err();
    std::fs::remove_file(&path).unwrap();
    let msg = err.to_string();
    assert!(matches!(err, MidiError::TooLarge { .. }), "{err:?}");
    assert!(msg.contains("huge.mid") && msg.contains("68157440") && msg.contains("67108864"), "{msg}");
}

#[test]
fn absurd_tempo_is_an_error_naming_the_place() {
    let track = vec![ev(0, on(DRUMS, 36, 100)), ev(960, tempo(0)), ev(0, on(DRUMS, 36, 100)), ev(0, END)];
    let err = read("tempo0.mid", &smf_bytes(Format::SingleTrack, metrical(480), vec![track])).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(err, MidiError::Tempo { tick: 960, .. }), "{err:?}");
    assert!(msg.contains("tempo0.mid") && msg.contains("tick 960") && msg.contains("1.000 s"), "{msg}");
}

#[test]
fn file_without_drums_names_the_channels_it_has() {
    let track = vec![ev(0, on(1, 60, 100)), ev(0, on(3, 40, 100)), ev(10, on(3, 41, 100)), ev(0, END)];
    let err = read("nodrums.mid", &smf_bytes(Format::SingleTrack, metrical(480), vec![track])).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(&err, MidiError::NoDrums { channel: 10, found, .. } if found == &[(1, 1), (3, 2)]), "{err:?}");
    assert!(msg.contains("nodrums.mid") && msg.contains("channel 10") && msg.contains("--channel 3"), "{msg}");
    let silent = vec![ev(0, END)];
    let msg = read("silent.mid", &smf_bytes(Format::SingleTrack, metrical(480), vec![silent])).unwrap_err();
    assert!(msg.to_string().contains("no notes"), "{msg}");
}

#[test]
fn unknown_note_is_named_with_its_place_and_the_map() {
    // 22 and 26 are Roland TD hi-hat edges, unknown to General MIDI.
    let track = vec![
        ev(0, on(DRUMS, 36, 100)),
        ev(480, on(DRUMS, 22, 100)),
        ev(240, on(DRUMS, 22, 90)),
        ev(0, on(DRUMS, 26, 90)),
        ev(0, END),
    ];
    let perf = read("td-notes.mid", &smf_bytes(Format::SingleTrack, metrical(480), vec![track])).unwrap();
    let gm = NoteMap::load("gm").unwrap();
    let err = gm.check_known(&perf).unwrap_err();
    let MapError::UnknownNotes { notes, suggest, .. } = &err else { panic!("{err:?}") };
    assert_eq!(notes.iter().map(|u| (u.note, u.count, u.first_tick)).collect::<Vec<_>>(), [(22, 2, 480), (26, 1, 720)]);
    assert_eq!(suggest, &["roland-td", "alesis"]);
    let msg = err.to_string();
    for part in [
        "td-notes.mid",
        "General MIDI",
        "note 22 (2 times, first at 0.500 s, tick 480)",
        "--map roland-td or --map alesis",
    ] {
        assert!(msg.contains(part), "{part:?} missing from: {msg}");
    }
    assert!(msg.contains("--skip-unknown") && msg.contains("--map FILE"), "{msg}");
    assert!(NoteMap::load("roland-td").unwrap().check_known(&perf).is_ok());
}

#[test]
fn map_that_is_neither_builtin_nor_file_lists_the_builtins() {
    let msg = NoteMap::load("roland").unwrap_err().to_string();
    assert!(msg.contains("gm, gs, xg, roland-td, alesis, yamaha-dtx") && msg.contains("\"roland\""), "{msg}");
    let path =
        write_temp("map.toml", b"name = \"mine\"\n[notes]\n60 = { piece = \"snare\", zone = \"head\", roll = 38 }\n");
    let map = NoteMap::load(path.to_str().unwrap()).unwrap();
    assert_eq!((map.channel, map.entry(60).unwrap().roll), (10, 38));
}

// ---- The Groove MIDI Dataset (data/gmd) ----

fn gmd_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd")
}

fn mid_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            mid_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "mid") {
            out.push(path);
        }
    }
}

/// info.csv: midi_filename -> (duration_s, bpm, time signature, style).
fn gmd_info() -> std::collections::HashMap<String, (f64, f64, String, String)> {
    let text = std::fs::read_to_string(gmd_dir().join("info.csv")).unwrap();
    text.lines()
        .skip(1)
        .map(|line| {
            let f: Vec<&str> = line.split(',').collect();
            (f[7].to_string(), (f[9].parse().unwrap(), f[4].parse().unwrap(), f[6].to_string(), f[3].to_string()))
        })
        .collect()
}

/// info.csv's duration is the last event's time (CC4 included) in most takes, the last note's
/// in drummer1/session1 (whose files run on with CC4, up to 276 s after the last note).
#[test]
fn every_gmd_file_parses_with_the_roland_td_map() {
    let mut files = Vec::new();
    mid_files(&gmd_dir(), &mut files);
    let info = gmd_info();
    let td = NoteMap::load("roland-td").unwrap();
    let mut counts = [0usize; 128];
    let mut worst_bpm = (0.0f64, String::new());
    for path in &files {
        let name = path.strip_prefix(gmd_dir()).unwrap().to_string_lossy().into_owned();
        let perf = read_file(path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        td.check_known(&perf).unwrap_or_else(|e| panic!("{e}"));
        for (note, _) in note_ons(&perf) {
            counts[usize::from(note)] += 1;
        }
        assert!(perf.events.windows(2).all(|w| w[0].tick <= w[1].tick && w[0].time_s <= w[1].time_s), "{name}");
        let (duration, bpm, _, _) = &info[&name];
        assert!(
            perf.notes_end_s - 1e-3 <= *duration && *duration <= perf.duration_s + 1e-3,
            "{name}: info.csv {duration} s, notes end {} s, file end {} s",
            perf.notes_end_s,
            perf.duration_s
        );
        // One tempo per file, 480 ticks per beat: seconds per tick gives the BPM of info.csv.
        let last = perf.events.last().unwrap();
        let file_bpm = 60.0 * last.tick as f64 / (480.0 * last.time_s);
        if (file_bpm / bpm - 1.0).abs() > worst_bpm.0 {
            worst_bpm = ((file_bpm / bpm - 1.0).abs(), name);
        }
    }
    let used: Vec<String> =
        counts.iter().enumerate().filter(|(_, n)| **n > 0).map(|(note, n)| format!("{note}:{n}")).collect();
    println!("{} files parsed, none with unknown notes; note-ons per note: {}", files.len(), used.join(" "));
    println!("largest tempo difference from info.csv: {:.2e} ({})", worst_bpm.0, worst_bpm.1);
    assert_eq!(files.len(), 1021);
    assert!(worst_bpm.0 < 1e-3, "{worst_bpm:?}");
}

fn gmd(name: &str) -> Performance {
    read_file(&gmd_dir().join(name), &ReadOptions::default()).unwrap()
}

fn most_played(perf: &Performance) -> u8 {
    let mut counts = [0usize; 128];
    note_ons(perf).iter().for_each(|(n, _)| counts[usize::from(*n)] += 1);
    (0..128u8).max_by_key(|n| counts[usize::from(*n)]).unwrap()
}

#[test]
fn gmd_handful_is_sane() {
    let info = gmd_info();
    // Fast jazz at 290 BPM: ride-led, and its file runs 276 s past the last note on CC4 alone.
    let name = "drummer1/session1/78_jazz-fast_290_beat_4-4.mid";
    let jazz = gmd(name);
    assert_eq!(most_played(&jazz), 51, "ride");
    assert!((jazz.notes_end_s - info[name].0).abs() < 1e-3);
    assert!(jazz.duration_s > 380.0);
    assert!(matches!(jazz.events.last().unwrap().kind, DrumEventKind::HiHatPedal { .. }));
    // A one-bar fill: a few dozen notes in under 2 s, the track padded to 3 s.
    let name = "drummer1/session1/10_jazz-funk_116_fill_4-4.mid";
    let fill = gmd(name);
    let n = note_ons(&fill).len();
    assert!((5..60).contains(&n), "{n} notes");
    assert!((fill.notes_end_s - info[name].0).abs() < 1e-3 && (fill.duration_s - 3.0).abs() < 0.01);
    // 3/4 jazz at 200 BPM.
    let name = "drummer1/session2/5_jazz_200_beat_3-4.mid";
    let waltz = gmd(name);
    assert_eq!(info[name].2, "3-4");
    assert!((waltz.duration_s - info[name].0).abs() < 1e-3);
    // The 23-minute take.
    let name = "drummer2/session1/1_rock_110_beat_4-4.mid";
    let long = gmd(name);
    assert!((long.duration_s - info[name].0).abs() < 1.0, "{} vs {}", long.duration_s, info[name].0);
    assert!(long.duration_s > 23.0 * 60.0 && note_ons(&long).len() > 5_000, "{} notes", note_ons(&long).len());
    let count = |note: u8| note_ons(&long).iter().filter(|(n, _)| *n == note).count();
    assert!(count(36) > 500 && count(38) + count(40) > 1000, "a rock beat has kick and snare");
}

#[test]
fn gmd_piano_roll_runs_a_second_past_the_last_note_and_has_only_mapped_columns() {
    let perf = gmd("drummer1/session2/5_jazz_200_beat_3-4.mid");
    let td = NoteMap::load("roland-td").unwrap();
    let roll = piano_roll(&perf, &td);
    assert_eq!(roll.len(), ((perf.notes_end_s + 1.0) * 60.0).round() as usize + 1);
    let mut want = std::collections::BTreeSet::new();
    let mut cells = std::collections::HashSet::new();
    for (note, t) in note_ons(&perf) {
        let col = column(td.entry(note).unwrap().roll).unwrap();
        want.insert(col);
        cells.insert(((t * 60.0).round() as usize, col));
    }
    let have: std::collections::BTreeSet<usize> = (0..16).filter(|&c| roll.onsets(c) > 0).collect();
    assert_eq!(have, want, "columns with onsets");
    let total: usize = (0..16).map(|c| roll.onsets(c)).sum();
    assert_eq!(total, cells.len());
    println!("{} frames; onsets per roll note: {:?}", roll.len(), NOTE_NUMS.map(|n| roll.onsets(column(n).unwrap())));
}
