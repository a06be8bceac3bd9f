//! Input a hostile user would try (issue "The stability suite, and no input that can hurt"):
//! each test is named for a defect that input once caused, and fails on the code before its
//! fix. A clear message and exit code 2, no panic, no abort, no unbounded memory.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fresh_dir(tag: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("hostile-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn drumsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drumsim")).args(args).output().expect("run drumsim")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// The bundled demo song.
fn demo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/demo/demo.mid")
}

/// A standard MIDI file of one track (format 0, 480 ticks per quarter note).
fn smf(track: &[u8]) -> Vec<u8> {
    let mut f = b"MThd\x00\x00\x00\x06\x00\x00\x00\x01\x01\xE0MTrk".to_vec();
    f.extend_from_slice(&(track.len() as u32).to_be_bytes());
    f.extend_from_slice(track);
    f
}

#[test]
fn strokes_with_100000_threads_is_refused_instead_of_aborting() {
    let o = drumsim(&["strokes", "--threads", "100000", "--trials", "1"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--threads") && stderr(&o).contains("100000"), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
}

/// A well-formed file: one kick (note-on, note-off 96 ticks later), then End-of-Track 2^28 - 1
/// ticks after that (77 hours at 120 bpm). 37 bytes.
fn one_note_then_a_77_hour_track() -> Vec<u8> {
    let f = smf(&[0x00, 0x99, 0x24, 0x64, 0x60, 0x89, 0x24, 0x00, 0xFF, 0xFF, 0xFF, 0x7F, 0xFF, 0x2F, 0x00]);
    assert_eq!(f.len(), 37);
    f
}

#[test]
fn a_track_ending_77_hours_after_its_only_note_renders_a_short_motion_not_gigabytes() {
    let dir = fresh_dir("long-track");
    let song = dir.join("lonely.mid");
    std::fs::write(&song, one_note_then_a_77_hour_track()).unwrap();
    let out = dir.join("out");
    let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The piano roll, the hand model and the motion run a second past the last note.
    let motion: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("lonely.motion.json")).unwrap()).unwrap();
    let frames = motion["frames"].as_array().map_or(0, |f| f.len());
    assert!(frames > 0 && frames <= 2 * 60, "{frames} motion frames");
    for ext in ["wav", "bvh", "glb"] {
        let len = std::fs::metadata(out.join(format!("lonely.{ext}"))).unwrap().len();
        assert!(len < 8 << 20, "lonely.{ext}: {len} bytes");
    }
}

#[test]
fn four_thousand_and_ninety_seven_notes_at_one_instant_render_instead_of_overflowing_the_queue() {
    let dir = fresh_dir("burst");
    let mut track = Vec::new();
    for i in 0..4097u32 {
        // Snare, kick and hi-hat notes at tick 0.
        track.extend_from_slice(&[0x00, 0x99, [38u8, 36, 42][i as usize % 3], 0x64]);
    }
    track.extend_from_slice(&[0x83, 0x60, 0x89, 38, 0x00, 0x00, 0xFF, 0x2F, 0x00]);
    let song = dir.join("burst.mid");
    std::fs::write(&song, smf(&track)).unwrap();
    let out = dir.join("out");
    let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-motion"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("burst.contacts.json")).unwrap()).unwrap();
    assert_eq!(json["contacts"].as_array().unwrap().len(), 4097);
    assert!(std::fs::metadata(out.join("burst.wav")).unwrap().len() > 48_000);
}

#[test]
fn a_note_77_hours_in_is_refused_before_anything_is_written_instead_of_a_4_gib_wav() {
    let dir = fresh_dir("late-note");
    // One kick 2^28 - 1 ticks in (77:40:20 at 120 bpm), its note-off 96 ticks later.
    let track = [0xFF, 0xFF, 0xFF, 0x7F, 0x99, 0x24, 0x64, 0x60, 0x89, 0x24, 0x00, 0x00, 0xFF, 0x2F, 0x00];
    let song = dir.join("late.mid");
    std::fs::write(&song, smf(&track)).unwrap();
    let out = dir.join("out");
    let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(e.contains("late.mid") && e.contains("77:40:20") && e.contains("4:00:00"), "{e}");
    assert!(!out.exists() || std::fs::read_dir(&out).unwrap().next().is_none(), "something was written");
}

#[test]
fn two_songs_of_one_name_rendered_at_once_into_one_folder_do_not_mix_their_wavs() {
    let dir = fresh_dir("same-name");
    let gmd = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd");
    let songs = ["drummer1/session1/1_funk_80_beat_4-4.mid", "drummer1/session2/62_punk_144_beat_4-4.mid"];
    // Each song alone, then both at once under the name take.mid, into one folder.
    let mut alone = Vec::new();
    let mut paths = Vec::new();
    for (i, s) in songs.iter().enumerate() {
        let sub = dir.join(format!("song{i}"));
        std::fs::create_dir_all(&sub).unwrap();
        let song = sub.join("take.mid");
        std::fs::copy(gmd.join(s), &song).unwrap();
        let out = sub.join("alone");
        let args =
            ["render", song.to_str().unwrap(), "--out", out.to_str().unwrap(), "--map", "roland-td", "--no-motion"];
        assert!(drumsim(&args).status.success());
        alone.push(std::fs::read(out.join("take.wav")).unwrap());
        paths.push(song);
    }
    assert_ne!(alone[0], alone[1]);
    let shared = dir.join("shared");
    let children: Vec<_> = paths
        .iter()
        .map(|song| {
            Command::new(env!("CARGO_BIN_EXE_drumsim"))
                .args(["render", song.to_str().unwrap(), "--out", shared.to_str().unwrap()])
                .args(["--map", "roland-td", "--no-motion"])
                .spawn()
                .unwrap()
        })
        .collect();
    for mut c in children {
        assert!(c.wait().unwrap().success());
    }
    let wav = std::fs::read(shared.join("take.wav")).unwrap();
    assert!(wav == alone[0] || wav == alone[1], "the WAV is neither song's alone");
    let left: Vec<_> = std::fs::read_dir(&shared)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains("partial"))
        .collect();
    assert!(left.is_empty(), "{left:?}");
}

#[test]
fn a_snare_out_of_reach_under_the_floor_or_inside_the_drummer_is_refused_naming_it() {
    let dir = fresh_dir("reach");
    let song = demo();
    let snare = "position_m = [-0.12, 0.42, 0.62]";
    assert!(drumsim::kit::DEFAULT_KIT_TOML.contains(snare));
    for (tag, at, says) in [
        ("far", "[-0.12, 2.9, 0.62]", "out of the drummer's reach"),
        ("floor", "[-0.12, 0.42, -0.1]", "under the floor"),
        ("inside", "[0.0, 0.05, 1.0]", "inside the drummer"),
    ] {
        let kit = dir.join(format!("{tag}.toml"));
        std::fs::write(&kit, drumsim::kit::DEFAULT_KIT_TOML.replacen(snare, &format!("position_m = {at}"), 1)).unwrap();
        let out = dir.join(tag);
        let o = drumsim(&[
            "render",
            song.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--kit",
            kit.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{tag}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(&format!("{tag}.toml")) && e.contains("(snare)") && e.contains(says), "{tag}: {e}");
        assert!(!out.join("demo.wav").exists());
    }
}

#[test]
fn damaged_track_data_is_an_error_naming_the_track_and_byte_not_a_shorter_song() {
    let dir = fresh_dir("damaged");
    let kick = [0x00, 0x99, 0x24, 0x64];
    let later_kick = [0x83, 0x60, 0x99, 0x24, 0x64, 0x60, 0x89, 0x24, 0x00];
    let end = [0x00, 0xFF, 0x2F, 0x00];
    let cases: [(&str, Vec<u8>); 3] = [
        // A text meta event announcing 127 bytes where 5 remain.
        ("meta-past-end", [&kick[..], &[0x00, 0xFF, 0x01, 0x7F], b"abcde"].concat()),
        // A sysex whose length takes 5 bytes (a MIDI length has at most 4).
        (
            "five-byte-length",
            [&kick[..], &[0x00, 0xF0, 0x81, 0x80, 0x80, 0x80, 0x00, 0xF7], &later_kick, &end].concat(),
        ),
        // End-of-Track in mid-track, the song going on after it.
        ("early-end", [&kick[..], &end, &later_kick, &end].concat()),
    ];
    for (name, track) in cases {
        let song = dir.join(format!("{name}.mid"));
        std::fs::write(&song, smf(&track)).unwrap();
        let out = dir.join(name);
        let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{name}: {e}");
        assert!(e.contains(&format!("{name}.mid")) && e.contains("track 1") && e.contains("byte"), "{name}: {e}");
        assert!(!out.join(format!("{name}.wav")).exists(), "{name}");
    }
}

#[test]
fn a_kit_or_map_of_dev_zero_is_refused_at_4_mib_instead_of_read_until_memory_runs_out() {
    let out = fresh_dir("dev-zero");
    let song = demo();
    for flag in ["--kit", "--map"] {
        let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap(), flag, "/dev/zero"]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{flag}: {e}");
        assert!(e.contains("/dev/zero") && e.contains("4 MiB"), "{flag}: {e}");
    }
}

#[test]
fn a_kit_normal_of_1e30_is_a_direction_and_an_infinite_one_is_refused_as_not_one() {
    let dir = fresh_dir("normal");
    let snare = "normal = [0.15, -0.25, 0.96]";
    assert!(drumsim::kit::DEFAULT_KIT_TOML.contains(snare));
    let huge = dir.join("huge.toml");
    std::fs::write(&huge, drumsim::kit::DEFAULT_KIT_TOML.replacen(snare, "normal = [1.5e29, -2.5e29, 9.6e29]", 1))
        .unwrap();
    let kit = drumsim::kit::Kit::load(&huge).unwrap();
    let n = kit.piece("snare").unwrap().normal;
    let len = (0.15f32 * 0.15 + 0.25 * 0.25 + 0.96 * 0.96).sqrt();
    let want = [0.15 / len, -0.25 / len, 0.96 / len];
    assert!(n.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-5), "{n:?}");
    let inf = dir.join("inf.toml");
    std::fs::write(&inf, drumsim::kit::DEFAULT_KIT_TOML.replacen(snare, "normal = [0.0, 0.0, inf]", 1)).unwrap();
    let o =
        drumsim(&["render", demo().to_str().unwrap(), "--out", dir.to_str().unwrap(), "--kit", inf.to_str().unwrap()]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(e.contains("inf.toml") && e.contains("normal") && e.contains("not a direction"), "{e}");
}

/// Files in `dir`, sorted, with their lengths.
fn listing(dir: &Path) -> Vec<(String, u64)> {
    let mut v: Vec<(String, u64)> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| {
            let e = e.unwrap();
            (e.file_name().to_string_lossy().into_owned(), e.metadata().unwrap().len())
        })
        .collect();
    v.sort();
    v
}

/// A short song of a few snare notes, rendered as `groove` into `out`: the older set.
fn older_set(dir: &Path, out: &Path) {
    let mut track = Vec::new();
    for _ in 0..4 {
        track.extend_from_slice(&[0x00, 0x99, 38, 0x50, 0x83, 0x60, 0x89, 38, 0x00]);
    }
    track.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
    let song = dir.join("older").join("groove.mid");
    std::fs::create_dir_all(song.parent().unwrap()).unwrap();
    std::fs::write(&song, smf(&track)).unwrap();
    let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn a_render_whose_motion_export_hits_a_full_disk_publishes_nothing_and_exits_1() {
    let dir = fresh_dir("full-disk");
    // The sizes of the demo's files decide where the limit falls: the contacts fit, the glb
    // (the first motion file, written next) does not.
    let probe = dir.join("probe");
    let o = drumsim(&["render", demo().to_str().unwrap(), "--sound", "direct", "--out", probe.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let size = |ext: &str| std::fs::metadata(probe.join(format!("demo.{ext}"))).unwrap().len();
    let (contacts, glb) = (size("contacts.json"), size("glb"));
    assert!(contacts < glb, "{contacts} {glb}");
    let limit_kib = (contacts + glb) / 2 / 1024;

    let out = dir.join("out");
    older_set(&dir, &out);
    let before = listing(&out);
    assert_eq!(before.len(), 6, "{before:?}");
    let song = dir.join("groove.mid");
    std::fs::copy(demo(), &song).unwrap();
    // A file-size limit is a full disk to the writer (EFBIG); SIGXFSZ is ignored, as a
    // shell's trap leaves it for the program it starts.
    let script = format!(
        "trap '' XFSZ; ulimit -f {limit_kib}; exec '{}' render '{}' --sound direct --out '{}'",
        env!("CARGO_BIN_EXE_drumsim"),
        song.display(),
        out.display()
    );
    let o = Command::new("bash").args(["-c", &script]).output().unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains(&out.join("groove.glb").display().to_string()), "{}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    assert_eq!(listing(&out), before, "the older set must stand whole, with no partial file");
}

#[test]
fn ctrl_c_during_a_render_removes_its_partial_files_and_publishes_nothing() {
    let dir = fresh_dir("ctrl-c");
    let out = dir.join("out");
    older_set(&dir, &out);
    let before = listing(&out);
    // Half an hour of quarter-note snares: the WAV is written for seconds.
    let mut track = Vec::new();
    for _ in 0..3600 {
        track.extend_from_slice(&[0x00, 0x99, 38, 0x50, 0x83, 0x60, 0x89, 38, 0x00]);
    }
    track.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
    let song = dir.join("groove.mid");
    std::fs::write(&song, smf(&track)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .args(["render", song.to_str().unwrap(), "--sound", "direct", "--out", out.to_str().unwrap()])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    let is_partial_wav = |(name, _): &(String, u64)| name.starts_with(".groove.wav.") && name.ends_with(".partial");
    while !listing(&out).iter().any(is_partial_wav) {
        assert!(started.elapsed().as_secs() < 120, "no partial WAV appeared: {:?}", listing(&out));
        assert!(child.try_wait().unwrap().is_none(), "the render ended before it could be interrupted");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let _ = Command::new("kill").args(["-INT", &child.id().to_string()]).status();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130), "{}", stderr(&o));
    assert!(stderr(&o).contains("interrupted"), "{}", stderr(&o));
    assert_eq!(listing(&out), before, "no partial left, the older set untouched");
}

/// A song of the given note-ons on channel 10, a quarter note apart.
fn song_of(notes: &[u8]) -> Vec<u8> {
    let mut track = Vec::new();
    for &n in notes {
        track.extend_from_slice(&[0x00, 0x99, n, 0x60, 0x83, 0x60, 0x89, n, 0x00]);
    }
    track.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
    smf(&track)
}

#[test]
fn general_midi_percussion_renders_by_default_and_what_is_left_out_is_counted() {
    let dir = fresh_dir("gm-percussion");
    // Snare, kick, two claps, a cowbell (played on the ride bell), a triangle, a low conga.
    let song = dir.join("latin.mid");
    std::fs::write(&song, song_of(&[38, 36, 39, 39, 56, 81, 64])).unwrap();
    let out = dir.join("out");
    let o = drumsim(&["render", song.to_str().unwrap(), "--no-motion", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("3 notes left out: 2 x note 39 (hand clap), 1 x note 81 (open triangle)"),
        "{}",
        stderr(&o)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("latin.contacts.json")).unwrap()).unwrap();
    let skipped: Vec<(u64, u64)> = json["skipped_notes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["note"].as_u64().unwrap(), s["count"].as_u64().unwrap()))
        .collect();
    assert_eq!(skipped, [(39, 2), (81, 1)]);
    let pieces: Vec<&str> = json["contacts"].as_array().unwrap().iter().map(|c| c["piece"].as_str().unwrap()).collect();
    assert!(pieces.contains(&"ride") && pieces.contains(&"floor_tom"), "{pieces:?}");
}

#[test]
fn a_song_whose_notes_are_all_unknown_or_skipped_is_an_error_not_a_silent_wav() {
    let dir = fresh_dir("all-unknown");
    let out = dir.join("out");
    let song = dir.join("whistles.mid");
    std::fs::write(&song, song_of(&[71, 72, 71])).unwrap();
    let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("whistles.mid") && stderr(&o).contains("short whistle"), "{}", stderr(&o));
    let song = dir.join("high.mid");
    std::fs::write(&song, song_of(&[100, 101])).unwrap();
    let o = drumsim(&["render", song.to_str().unwrap(), "--skip-unknown", "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("high.mid") && stderr(&o).contains("2 x note") || stderr(&o).contains("1 x note 100"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists() || listing(&out).is_empty(), "{:?}", listing(&out));
}

#[test]
fn a_kit_that_sends_cc4_0_for_closed_is_read_the_right_way_round() {
    let dir = fresh_dir("cc4-closed-0");
    // A closed hi-hat note under a pedal held at CC4 = 0, which this kit sends for closed.
    let track = [0x00, 0xB9, 0x04, 0x00, 0x00, 0x99, 42, 0x60, 0x83, 0x60, 0x89, 42, 0x00, 0x00, 0xFF, 0x2F, 0x00];
    let song = dir.join("hats.mid");
    std::fs::write(&song, smf(&track)).unwrap();
    let map = dir.join("closed-at-0.toml");
    std::fs::write(&map, "name = \"closed at 0\"\nextends = \"gm\"\ncc4_closed = 0\n").unwrap();
    let openness = |map: &str, tag: &str| {
        let out = dir.join(tag);
        let o =
            drumsim(&["render", song.to_str().unwrap(), "--map", map, "--no-motion", "--out", out.to_str().unwrap()]);
        assert!(o.status.success(), "{}", stderr(&o));
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("hats.contacts.json")).unwrap()).unwrap();
        json["hihat"][0]["openness"].as_f64().unwrap()
    };
    assert_eq!(openness("gm", "gm"), 1.0, "CC4 0 is open to General MIDI and Roland");
    assert_eq!(openness(map.to_str().unwrap(), "mine"), 0.0);
}

/// Songs from Debian's game music packages (installed by scripts/setup-debian.sh): GM files
/// from the wild, with claps, shakers, triangles and GS extras.
const DEBIAN_SONGS: [&str; 20] = [
    "/usr/share/planetblupi/music/music000.mid",
    "/usr/share/planetblupi/music/music001.mid",
    "/usr/share/planetblupi/music/music002.mid",
    "/usr/share/planetblupi/music/music003.mid",
    "/usr/share/planetblupi/music/music004.mid",
    "/usr/share/planetblupi/music/music005.mid",
    "/usr/share/planetblupi/music/music006.mid",
    "/usr/share/planetblupi/music/music007.mid",
    "/usr/share/planetblupi/music/music008.mid",
    "/usr/share/planetblupi/music/music009.mid",
    "/usr/share/games/openttd/baseset/openmsx/be_sharp_bw_redfarn.mid",
    "/usr/share/games/openttd/baseset/openmsx/busy_schedule.mid",
    "/usr/share/games/openttd/baseset/openmsx/chuggachugga.mid",
    "/usr/share/games/openttd/baseset/openmsx/linns_basket.mid",
    "/usr/share/games/openttd/baseset/openmsx/mighty_giant_run.mid",
    "/usr/share/games/openttd/baseset/openmsx/modern_motion.mid",
    "/usr/share/games/openttd/baseset/openmsx/mosey_along_redfarn.mid",
    "/usr/share/games/openttd/baseset/openmsx/run_for_your_life.mid",
    "/usr/share/games/openttd/baseset/openmsx/the_hobo_redfarn.mid",
    "/usr/share/games/openttd/baseset/openmsx/ttsong_iii_imuh3.mid",
];

#[test]
fn twenty_general_midi_songs_from_debian_render_by_default_and_count_every_note() {
    use drumsim::midi::{read_file, DrumEventKind, ReadOptions};
    let missing: Vec<&str> = DEBIAN_SONGS.iter().copied().filter(|p| !Path::new(p).exists()).collect();
    assert!(
        missing.is_empty(),
        "install openttd-openmsx and planetblupi-music-midi (scripts/setup-debian.sh): {missing:?}"
    );
    let dir = fresh_dir("debian-gm");
    let out = dir.join("out");
    let mut left_out = 0u64;
    // Two at a time (two cores), each song's files removed once checked: the twenty write
    // 7 GB in all.
    for chunk in DEBIAN_SONGS.chunks(2) {
        let runs: Vec<_> = chunk
            .iter()
            .map(|song| {
                let out = out.clone();
                std::thread::spawn(move || drumsim(&["render", song, "--out", out.to_str().unwrap()]))
            })
            .collect();
        for (song, run) in chunk.iter().zip(runs) {
            let o = run.join().unwrap();
            assert!(o.status.success(), "{song}: {}", stderr(&o));
            assert!(stderr(&o).contains("note map General MIDI (auto: built-in gm)"), "{song}: {}", stderr(&o));
            // Every note-on is played (it has contacts) or counted as left out; a note struck
            // twice at one instant (these songs have a few) is one stroke.
            let perf = read_file(Path::new(song), &ReadOptions { channel: 10 }).unwrap();
            let mut notes: Vec<(u64, u8)> = perf
                .events
                .iter()
                .filter_map(|e| match e.kind {
                    DrumEventKind::NoteOn { note, .. } => Some(((e.time_s * 1e6).round() as u64, note)),
                    _ => None,
                })
                .collect();
            let all_notes = notes.len() as u64;
            notes.sort();
            notes.dedup();
            let stem = Path::new(song).file_stem().unwrap().to_str().unwrap();
            let json: serde_json::Value =
                serde_json::from_slice(&std::fs::read(out.join(format!("{stem}.contacts.json"))).unwrap()).unwrap();
            let mut played: Vec<(String, u64)> = json["contacts"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|c| !c["note"].is_null())
                .map(|c| (c["note"]["time_s"].to_string(), c["note"]["note"].as_u64().unwrap()))
                .collect();
            played.sort();
            played.dedup();
            let skipped: u64 =
                json["skipped_notes"].as_array().unwrap().iter().map(|s| s["count"].as_u64().unwrap()).sum();
            left_out += skipped;
            let counted = played.len() as u64 + skipped;
            assert!(counted >= notes.len() as u64 && counted <= all_notes, "{song}: {counted} of {all_notes} notes");
            assert!(out.join(format!("{stem}.glb")).exists(), "{song}");
            for ext in ["wav", "contacts.json", "motion.json", "bvh", "glb"] {
                let _ = std::fs::remove_file(out.join(format!("{stem}.{ext}")));
            }
        }
    }
    assert!(left_out > 0, "these songs have claps, shakers and triangles");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn eval_on_an_empty_folder_is_an_error_naming_what_is_missing_not_null_metrics() {
    let dir = fresh_dir("eval-empty");
    let o = drumsim(&["eval", demo().to_str().unwrap(), "--out", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stdout));
    assert!(stderr(&o).contains("demo.contacts.json") && stderr(&o).contains("drumsim render"), "{}", stderr(&o));
}

#[test]
fn eval_refuses_another_songs_outputs_under_the_same_name() {
    let dir = fresh_dir("eval-other");
    let out = dir.join("out");
    older_set(&dir, &out); // a few snare notes, rendered as groove
    let song = dir.join("groove.mid");
    std::fs::copy(demo(), &song).unwrap();
    let o = drumsim(&["eval", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stdout));
    assert!(stderr(&o).contains("groove.contacts.json") && stderr(&o).contains("other notes"), "{}", stderr(&o));
    // Its own render measures.
    let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = drumsim(&["eval", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(m["hits"]["recall"], 1.0, "{m}");
}

#[test]
fn eval_against_a_one_frame_reference_is_refused_instead_of_l1_zero() {
    let dir = fresh_dir("eval-one-frame");
    let out = dir.join("out");
    let o = drumsim(&["render", demo().to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    // The render's own motion cut to its first frame.
    let motion: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("demo.motion.json")).unwrap()).unwrap();
    let mut one = motion.clone();
    one["frames"] = serde_json::Value::Array(vec![motion["frames"][0].clone()]);
    let reference = dir.join("one.motion.json");
    std::fs::write(&reference, serde_json::to_vec(&one).unwrap()).unwrap();
    let o = drumsim(&[
        "eval",
        demo().to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--reference",
        reference.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", String::from_utf8_lossy(&o.stdout));
    assert!(stderr(&o).contains("1 frames") && stderr(&o).contains("same song"), "{}", stderr(&o));
}

#[test]
fn train_with_lr_1e30_or_zero_epochs_is_refused_before_any_work() {
    let dir = fresh_dir("train-args");
    let o = drumsim(&["train", "--lr", "1e30", "--out", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--lr 1e30") && stderr(&o).contains("0 < lr <= 1"), "{}", stderr(&o));
    let o = drumsim(&["train", "--epochs", "0", "--out", dir.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("--epochs"), "{}", stderr(&o));
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "nothing written");
}

#[test]
fn a_kit_position_of_four_numbers_is_refused_naming_the_line() {
    let dir = fresh_dir("kit-four");
    let kit = std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("config/kits/default.toml")).unwrap();
    let four = kit.replacen("position_m = [0.0, 0.62, 0.28]", "position_m = [0.0, 0.62, 0.28, 7.0]", 1);
    assert_ne!(four, kit);
    let path = dir.join("four.toml");
    std::fs::write(&path, four).unwrap();
    let o = drumsim(&[
        "render",
        demo().to_str().unwrap(),
        "--kit",
        path.to_str().unwrap(),
        "--out",
        dir.join("out").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("four.toml") && stderr(&o).contains("expected 3 numbers (x, y, z), found 4"),
        "{}",
        stderr(&o)
    );
}

/// Peak memory of `drumsim render SONG --out OUT` (with motion), kB, by GNU time.
fn render_peak_kb(song: &Path, out: &Path) -> f64 {
    let o = Command::new("/usr/bin/time")
        .args(["-f", "peak %M kB", env!("CARGO_BIN_EXE_drumsim"), "render", song.to_str().unwrap()])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let err = stderr(&o);
    err.lines()
        .find_map(|l| l.strip_prefix("peak ")?.strip_suffix(" kB")?.parse().ok())
        .unwrap_or_else(|| panic!("no peak in: {err}"))
}

#[test]
fn a_render_s_memory_grows_with_the_song_at_under_2_gb_for_two_hours() {
    // Ten minutes of eighth-note hi-hats, kick and snare at 120 bpm, with motion. The fixed
    // part (the demo's peak: hand model, library, engine) plus the ten minutes' growth
    // times twelve must stay under 2 GB (a 2-hour render measured 1.48 GB).
    assert!(Path::new("/usr/bin/time").exists(), "install GNU time (scripts/setup-debian.sh)");
    let dir = fresh_dir("memory");
    let mut track = Vec::new();
    for beat in 0..1200u32 {
        let drum = if beat % 2 == 0 { 36 } else { 38 };
        // Two eighths (240 ticks each, VLQ 0x81 0x70) a beat.
        track.extend_from_slice(&[
            0x00, 0x99, 42, 90, 0x00, 0x99, drum, 110, 0x81, 0x70, 0x89, 42, 0x00, 0x00, 0x89, drum, 0x00,
        ]);
        track.extend_from_slice(&[0x00, 0x99, 42, 60, 0x81, 0x70, 0x89, 42, 0x00]);
    }
    track.extend_from_slice(&[0x00, 0xFF, 0x2F, 0x00]);
    let song = dir.join("ten.mid");
    std::fs::write(&song, smf(&track)).unwrap();
    let base_kb = render_peak_kb(&demo(), &dir.join("demo"));
    let ten_kb = render_peak_kb(&song, &dir.join("out"));
    let two_hours_gb = (base_kb + (ten_kb - base_kb).max(0.0) * 12.0) * 1e3 / 1e9;
    let _ = std::fs::remove_dir_all(&dir);
    eprintln!("demo {:.0} MB, ten minutes {:.0} MB: two hours {two_hours_gb:.2} GB", base_kb / 1e3, ten_kb / 1e3);
    assert!(two_hours_gb < 2.0, "demo {:.0} MB, ten minutes {:.0} MB", base_kb / 1e3, ten_kb / 1e3);
}

#[test]
fn eval_counts_notes_the_map_does_not_know_instead_of_dropping_them_silently() {
    let dir = fresh_dir("eval-unknown");
    let out = dir.join("out");
    let song = dir.join("odd.mid");
    // A snare, then note 100, which no map knows.
    std::fs::write(&song, song_of(&[38, 100, 38])).unwrap();
    let o = drumsim(&["render", song.to_str().unwrap(), "--skip-unknown", "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("1 x note 100 (not in the map)"), "{}", stderr(&o));
    let o = drumsim(&["eval", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((m["notes"].as_u64(), m["skipped_notes"].as_u64()), (Some(2), Some(1)), "{m}");
    // Notes the map skips on purpose are counted the same way.
    let song = dir.join("clap.mid");
    std::fs::write(&song, song_of(&[38, 39, 38])).unwrap();
    let o = drumsim(&["render", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = drumsim(&["eval", song.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    let m: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!((m["notes"].as_u64(), m["skipped_notes"].as_u64()), (Some(2), Some(1)), "{m}");
    assert_eq!(m["hits"]["recall"], 1.0, "{m}");
}
