//! `drumsim render` on real files: Groove MIDI takes, the bundled demo, timing against MIDI,
//! and bad input (exit code 2, a message naming the file, nothing half-written left behind).

use drumsim::kit::Kit;
use drumsim::midi::{read_file, DrumEventKind, NoteMap, ReadOptions};
use drumsim::render::{render_events, score_file, RenderOptions, SAMPLE_RATE_HZ};
use drumsim::sound::{SoundEvent, SoundEventKind};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::atomic::{AtomicUsize, Ordering};

fn gmd(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd").join(name)
}

fn fresh_dir(tag: &str) -> PathBuf {
    static COUNT: AtomicUsize = AtomicUsize::new(0);
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!(
        "render-{tag}-{}-{}",
        std::process::id(),
        COUNT.fetch_add(1, Ordering::Relaxed)
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn drumsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drumsim")).args(args).output().expect("run drumsim")
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    names
}

fn render_cli(song: &Path, out: &Path, extra: &[&str]) -> Output {
    let mut args = vec!["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(extra);
    drumsim(&args)
}

#[test]
fn renders_a_varied_handful_of_groove_midi_takes() {
    let takes = [
        "drummer1/session1/78_jazz-fast_290_beat_4-4.mid",
        "drummer1/session1/10_jazz-funk_116_fill_4-4.mid",
        "drummer1/session2/1_latin-chacarera_157_beat_3-4.mid",
        "drummer3/session2/16_rock_100_beat_4-4.mid",
    ];
    for take in takes {
        let out = fresh_dir("handful");
        let song = gmd(take);
        let result = render_cli(&song, &out, &["--map", "roland-td"]);
        assert!(result.status.success(), "{take}: {}", String::from_utf8_lossy(&result.stderr));
        let stem = song.file_stem().unwrap().to_string_lossy().into_owned();
        let expected: Vec<String> = ["bvh", "contacts.json", "glb", "motion.json", "vrma", "wav"]
            .iter()
            .map(|e| format!("{stem}.{e}"))
            .collect();
        assert_eq!(files_in(&out), expected, "{take}");
        let (l, r, rate) = drumsim::sound::wav::read_stereo(&out.join(format!("{stem}.wav"))).unwrap();
        assert_eq!(rate, 48_000);
        let perf = read_file(&song, &ReadOptions::default()).unwrap();
        assert!(l.len() as f64 >= perf.notes_end_s * 48_000.0, "{take}: WAV shorter than the song");
        assert!(l.iter().chain(r.iter()).all(|v| v.is_finite() && v.abs() <= 1.0));
        // Every hand and foot note made a contact carrying that note.
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join(format!("{stem}.contacts.json"))).unwrap()).unwrap();
        let contacts = json["contacts"].as_array().unwrap();
        let notes = perf.events.iter().filter(|e| matches!(e.kind, DrumEventKind::NoteOn { .. })).count();
        let with_note: std::collections::BTreeSet<String> = contacts
            .iter()
            .filter(|c| !c["note"].is_null())
            .map(|c| format!("{}:{}", c["note"]["time_s"], c["note"]["note"]))
            .collect();
        assert!(contacts.len() >= notes, "{take}: {} contacts for {notes} notes", contacts.len());
        assert!(
            with_note.len() >= notes * 99 / 100,
            "{take}: only {} distinct notes struck of {notes}",
            with_note.len()
        );
        for c in contacts {
            let speed = c["speed_mps"].as_f64().unwrap();
            assert!(speed > 0.0 && speed < 30.0);
            assert!((0..=3).contains(&c["limb"].as_i64().unwrap()));
        }
    }
}

/// Render a song through the library into memory: mono mix (left + right).
fn render_mono(song: &Path, map: &str) -> (Vec<f32>, drumsim::midi::Performance) {
    let kit = Kit::builtin_default();
    let map = NoteMap::load(map).unwrap();
    let opts = RenderOptions::default();
    let score = score_file(song, &kit, &map, &opts).unwrap();
    let mut mono = Vec::new();
    render_events(
        &kit,
        &score.events,
        score.duration_s,
        |l, r| {
            mono.extend(l.iter().zip(r.iter()).map(|(a, b)| a + b));
            Ok(())
        },
        |_| {},
    )
    .unwrap();
    (mono, read_file(song, &ReadOptions::default()).unwrap())
}

/// Render `events` (absolute samples) from `start` for `len` samples: mono mix.
fn render_window(kit: &Kit, events: &[SoundEvent], start: u64, len: usize) -> Vec<f32> {
    let shifted: Vec<SoundEvent> = events
        .iter()
        .filter(|e| (start..start + len as u64).contains(&e.at_sample))
        .map(|e| SoundEvent { at_sample: e.at_sample - start, ..*e })
        .collect();
    let mut mono = Vec::with_capacity(len + 512);
    render_events(
        kit,
        &shifted,
        len as f64 / SAMPLE_RATE_HZ as f64,
        |l, r| {
            mono.extend(l.iter().zip(r.iter()).map(|(a, b)| a + b));
            Ok(())
        },
        |_| {},
    )
    .unwrap();
    mono.truncate(len);
    mono
}

#[test]
fn isolated_notes_sound_within_one_millisecond_of_their_midi_time() {
    // A note's onset in the WAV is the first sample where the WAV differs from the same render
    // without that note: rendering is deterministic, so everything before it is identical,
    // however loudly the kit still rings. Both renders start 1.5 s before the note.
    let fs = SAMPLE_RATE_HZ as f64;
    let kit = Kit::builtin_default();
    let map = NoteMap::load("roland-td").unwrap();
    let (mut checked, mut worst) = (0, 0.0f64);
    for take in ["drummer3/session2/16_rock_100_beat_4-4.mid", "drummer1/session1/1_funk_80_beat_4-4.mid"] {
        let song = gmd(take);
        let score = score_file(&song, &kit, &map, &RenderOptions::default()).unwrap();
        let perf = read_file(&song, &ReadOptions::default()).unwrap();
        let times: Vec<f64> =
            perf.events.iter().filter(|e| matches!(e.kind, DrumEventKind::NoteOn { .. })).map(|e| e.time_s).collect();
        for (i, &t) in times.iter().enumerate() {
            let near = |j: usize| (times[j] - t).abs() < 0.080;
            if (i > 0 && near(i - 1)) || (i + 1 < times.len() && near(i + 1)) || t < 1.5 {
                continue;
            }
            let at = (t * fs).round() as u64;
            let start = at - (1.5 * fs) as u64;
            let len = (1.55 * fs) as usize;
            let with = render_window(&kit, &score.events, start, len);
            let without: Vec<SoundEvent> = score
                .events
                .iter()
                .filter(|e| !(e.at_sample == at && matches!(e.kind, SoundEventKind::Strike(_))))
                .copied()
                .collect();
            assert!(without.len() < score.events.len(), "{take}: the note at {t} s made no strike");
            let without = render_window(&kit, &without, start, len);
            let first = with.iter().zip(without.iter()).position(|(a, b)| a != b);
            let first = first.unwrap_or_else(|| panic!("{take}: the note at {t:.4} s changes nothing in the WAV"));
            let err_ms = ((start + first as u64) as f64 / fs - t) * 1e3;
            assert!(err_ms.abs() <= 1.0, "{take}: the note at {t:.4} s sounds {err_ms:+.3} ms off its MIDI time");
            worst = worst.max(err_ms.abs());
            checked += 1;
        }
    }
    println!("{checked} isolated notes, worst onset error {worst:.3} ms");
    assert!(checked > 50, "only {checked} isolated notes checked");
}

#[test]
fn the_23_minute_take_renders() {
    let (mono, perf) = render_mono(&gmd("drummer2/session1/1_rock_110_beat_4-4.mid"), "roland-td");
    assert!(perf.notes_end_s > 1300.0);
    assert!(mono.len() as f64 >= perf.notes_end_s * SAMPLE_RATE_HZ as f64);
    assert!(mono.iter().all(|v| v.is_finite() && v.abs() <= 2.0));
}

#[test]
fn the_bundled_demo_renders_with_the_default_map_and_repeats_exactly() {
    let demo = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/demo/demo.mid");
    let (a, b) = (fresh_dir("demo"), fresh_dir("demo"));
    for out in [&a, &b] {
        let result = render_cli(&demo, out, &[]);
        assert!(result.status.success(), "{}", String::from_utf8_lossy(&result.stderr));
    }
    let wav_a = std::fs::read(a.join("demo.wav")).unwrap();
    assert_eq!(wav_a, std::fs::read(b.join("demo.wav")).unwrap(), "two renders of the demo differ");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(a.join("demo.contacts.json")).unwrap()).unwrap();
    let pieces: std::collections::BTreeSet<&str> =
        json["contacts"].as_array().unwrap().iter().map(|c| c["piece"].as_str().unwrap()).collect();
    for piece in
        ["kick", "snare", "snare_rim", "tom1", "tom2", "floor_tom", "hihat", "crash", "ride", "splash", "china"]
    {
        assert!(pieces.contains(piece), "the demo never strikes {piece}");
    }
    assert_eq!(json["chokes"].as_array().unwrap().len(), 1);
}

/// Assert a failed render: exit code 2, stderr naming `needle`, and no WAV or partial left.
fn assert_bad_input(result: &Output, needle: &str, out: &Path) {
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(result.status.code(), Some(2), "stderr: {stderr}");
    assert!(stderr.contains(needle), "stderr does not name {needle:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    let left: Vec<String> =
        files_in(out).into_iter().filter(|n| n.ends_with(".wav") || n.contains("partial")).collect();
    assert!(left.is_empty(), "left behind: {left:?}");
}

#[test]
fn bad_midi_files_are_refused_with_exit_code_2() {
    let dir = fresh_dir("bad");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let real = std::fs::read(gmd("drummer1/session1/1_funk_80_beat_4-4.mid")).unwrap();
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("empty.mid", Vec::new()),
        ("text.mid", b"this is not a MIDI file at all\n".to_vec()),
        ("truncated.mid", real[..real.len() / 2].to_vec()),
        // One note on channel 1, none on the drum channel.
        ("nodrums.mid", {
            let track = [0x00, 0x90, 0x3C, 0x64, 0x60, 0x80, 0x3C, 0x00, 0x00, 0xFF, 0x2F, 0x00];
            let mut f = b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x01\xE0MTrk".to_vec();
            f.extend_from_slice(&(track.len() as u32).to_be_bytes());
            f.extend_from_slice(&track);
            f
        }),
    ];
    for (name, bytes) in cases {
        let song = dir.join(name);
        std::fs::write(&song, bytes).unwrap();
        assert_bad_input(&render_cli(&song, &out, &[]), name, &out);
    }
    let huge = dir.join("huge.mid");
    std::fs::File::create(&huge).unwrap().set_len(65 << 20).unwrap();
    assert_bad_input(&render_cli(&huge, &out, &[]), "huge.mid", &out);
    let missing = dir.join("missing.mid");
    assert_bad_input(&render_cli(&missing, &out, &[]), "missing.mid", &out);
}

#[test]
fn bad_maps_kits_and_options_are_refused_with_exit_code_2() {
    let dir = fresh_dir("badcfg");
    let out = dir.join("out");
    std::fs::create_dir_all(&out).unwrap();
    let song = gmd("drummer1/session1/78_jazz-fast_290_beat_4-4.mid");
    // A TD-11 take under the General MIDI map: notes 26 and 58 are unknown there.
    assert_bad_input(&render_cli(&song, &out, &["--map", "gm"]), "note 26", &out);
    let broken_kit = dir.join("kit.toml");
    std::fs::write(&broken_kit, "name = \"x\"\n[[pieces]]\nid = 3\n").unwrap();
    assert_bad_input(
        &render_cli(&song, &out, &["--map", "roland-td", "--kit", broken_kit.to_str().unwrap()]),
        "kit.toml",
        &out,
    );
    let no_ride = dir.join("no-ride.toml");
    let kit = drumsim::kit::DEFAULT_KIT_TOML;
    let start = kit.find("[[pieces]]\nid = \"ride\"").unwrap();
    let end = start + kit[start..].find("\n[[pieces]]").unwrap() + 1;
    std::fs::write(&no_ride, format!("{}{}", &kit[..start], &kit[end..])).unwrap();
    assert_bad_input(
        &render_cli(&song, &out, &["--map", "roland-td", "--kit", no_ride.to_str().unwrap()]),
        "\"ride\"",
        &out,
    );
    let bad_map = dir.join("map.toml");
    std::fs::write(&bad_map, "name = \"m\"\n[notes]\n38 = { piece = \"snare\", zone = \"middle\", roll = 38 }\n")
        .unwrap();
    assert_bad_input(&render_cli(&song, &out, &["--map", bad_map.to_str().unwrap()]), "map.toml", &out);
    assert_bad_input(&render_cli(&song, &out, &["--map", "no-such-map"]), "no-such-map", &out);
    assert_bad_input(&render_cli(&song, &out, &["--map", "roland-td", "--channel", "17"]), "17", &out);
    // Unknown notes can be skipped on request.
    let skipped = render_cli(&song, &out, &["--map", "gm", "--skip-unknown"]);
    assert!(skipped.status.success(), "{}", String::from_utf8_lossy(&skipped.stderr));
}

#[test]
fn a_failed_render_keeps_the_previous_complete_wav() {
    let dir = fresh_dir("keep");
    let out = dir.join("out");
    let song = dir.join("song.mid");
    std::fs::copy(Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/demo/demo.mid"), &song).unwrap();
    assert!(render_cli(&song, &out, &[]).status.success());
    let before = std::fs::read(out.join("song.wav")).unwrap();
    let bytes = std::fs::read(&song).unwrap();
    std::fs::write(&song, &bytes[..bytes.len() - 40]).unwrap();
    let result = render_cli(&song, &out, &[]);
    assert_eq!(result.status.code(), Some(2));
    assert_eq!(std::fs::read(out.join("song.wav")).unwrap(), before, "the earlier WAV was changed");
    assert!(files_in(&out).iter().all(|n| !n.contains("partial")));
}

#[test]
fn a_direct_render_names_the_hand_that_strikes_in_its_motion() {
    use drumsim::render::{load_hands, load_song, stage_motion};
    // A fill around the toms (where the simple sticking rule disagreed with the motion on
    // about half the notes) and a funk take with ghost notes.
    for take in
        ["drummer1/session1/251_funk-purdieshuffle_130_fill_4-4.mid", "drummer1/session1/1_funk_80_beat_4-4.mid"]
    {
        let song = gmd(take);
        let out = fresh_dir("limb");
        let o = render_cli(&song, &out, &[]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let stem = song.file_stem().unwrap().to_str().unwrap();
        let contacts: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join(format!("{stem}.contacts.json"))).unwrap()).unwrap();
        // The hands the motion stage planned (the motion files show them).
        let opts = RenderOptions::default();
        let kit = Kit::builtin_default();
        let (perf, map) = load_song(&song, &opts).unwrap();
        let staged = stage_motion(&perf, &kit, &map, &load_hands(&opts).unwrap()).unwrap();
        let planned: Vec<(i64, String, u64)> = staged
            .planned
            .notes
            .iter()
            .zip(&staged.planned.report.hands)
            .filter_map(|(n, h)| Some(((n.time_s * 1e6).round() as i64, kit.pieces[n.piece].id.clone(), (*h)? as u64)))
            .collect();
        let (mut same, mut compared) = (0, 0);
        for c in contacts["contacts"].as_array().unwrap() {
            let (limb, piece) = (c["limb"].as_u64().unwrap(), c["piece"].as_str().unwrap());
            let Some(t) = c["note"]["time_s"].as_f64().filter(|_| limb <= 1) else { continue };
            let us = (t * 1e6).round() as i64;
            if let Some(p) = planned.iter().find(|p| p.0 == us && p.1 == piece) {
                compared += 1;
                same += usize::from(p.2 == limb);
            }
        }
        eprintln!("{take}: {same} of {compared} hand contacts name the motion's hand");
        assert!(compared >= 10, "{take}: {compared}");
        assert_eq!(same, compared, "{take}");
    }
}

#[test]
fn audition_writes_every_piece_and_its_measures() {
    let out = fresh_dir("audition");
    let o = drumsim(&["audition", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let files = files_in(&out);
    for wav in ["kick.wav", "snare.wav", "hihat.wav", "crash.wav", "ride.wav", "audition.json"] {
        assert!(files.iter().any(|f| f == wav), "no {wav} in {files:?}");
    }
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("audition.json")).unwrap()).unwrap();
    let hits = json["hits"].as_array().unwrap();
    // Every stroke at the six velocities, each with its place in its WAV and its measures.
    let strokes = drumsim::audition::strokes(&Kit::builtin_default()).len();
    assert_eq!(hits.len(), strokes * drumsim::audition::VELOCITIES.len());
    let (l, _, rate) = drumsim::sound::wav::read_stereo(&out.join("snare.wav")).unwrap();
    let snare: Vec<&serde_json::Value> = hits.iter().filter(|h| h["piece"] == "snare").collect();
    let last = snare.iter().map(|h| h["start_s"].as_f64().unwrap()).fold(0.0, f64::max);
    assert!(last + drumsim::audition::HIT_SPACING_S <= l.len() as f64 / rate as f64 + 1e-6);
    assert!(snare.iter().all(|h| h["measures"]["level_db"].as_f64().unwrap() > -90.0));
    // A kit file that is not there: exit 2, naming it.
    let o = drumsim(&["audition", "--kit", "no/such/kit.toml", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no/such/kit.toml"));
}
