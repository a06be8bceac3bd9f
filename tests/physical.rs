//! `render --sound physical`: the sound comes from the simulated body's stick contacts.
//! These hold what the physical render reaches today (the targets are higher; the
//! README lists both): hand notes hit within 10 ms, contacts that play no note, timing,
//! sticks that do not sink, and repeatability.

use drumsim::body::sim::{DrummerSettings, Mode};
use drumsim::interaction::Limb;
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, Performance, ReadOptions, Zone};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library, Planned};
use drumsim::perform::matching::{match_contacts, onsets};
use drumsim::perform::targets::TargetSettings;
use drumsim::perform::{play, play_with, Conductor, RehearsalSettings};
use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fresh_dir(tag: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("physical-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

const FUNK: &str = "drummer1/session1/1_funk_80_beat_4-4.mid";

/// A Groove MIDI take (path under `data/gmd`) planned by the motion stage on the default
/// kit with the Roland TD map.
fn planned_take(take: &str) -> (NoteMap, Kit, Performance, Planned) {
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::builtin_default();
    let perf = read_file(&root().join("data/gmd").join(take), &ReadOptions { channel: 10 }).unwrap();
    let predicted = model_hands(&HandModel::shipped(), &perf, &map);
    let planned = perform_planned(&perf, &map, &kit, &predicted, &shipped_library().unwrap()).unwrap();
    (map, kit, perf, planned)
}

fn mean_sd(v: &[f64]) -> (f64, f64) {
    let m = v.iter().sum::<f64>() / v.len() as f64;
    (m, (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / v.len() as f64).sqrt())
}

#[test]
fn the_demo_rendered_physically_sounds_the_body_s_contacts_on_time_and_repeats_exactly() {
    let song = root().join("assets/demo/demo.mid");
    let mut wavs = Vec::new();
    for run in 0..2 {
        let out = fresh_dir(&format!("demo{run}"));
        let r = Command::new(env!("CARGO_BIN_EXE_drumsim"))
            .args(["render", song.to_str().unwrap(), "--out", out.to_str().unwrap(), "--sound", "physical"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&r.stderr).into_owned();
        assert!(r.status.success(), "{stderr}");
        assert!(stderr.contains("physical: ") && stderr.contains("notes hit within 10 ms"), "{stderr}");
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("demo.contacts.json")).unwrap()).unwrap();
        assert_eq!(json["sound"], "physical");
        let contacts = json["contacts"].as_array().unwrap();
        // Every contact is one the physics measured: an impulse, a limb, a piece; the kicks
        // come from the beater (the right foot).
        assert!(contacts.len() > 100, "{} contacts", contacts.len());
        assert!(contacts.iter().all(|c| c["impulse_ns"].as_f64().unwrap() > 0.0));
        let kicks = contacts.iter().filter(|c| c["piece"] == "kick").count();
        assert!(kicks > 0 && contacts.iter().filter(|c| c["piece"] == "kick").all(|c| c["limb"] == 2));
        // A rim shot's hoop contact is measured at the stick's speed into the hoop (not along
        // the hoop piece's kit-file normal, which only places its sound).
        let kit = Kit::load(Path::new("default")).unwrap();
        let rims: Vec<(f64, f64)> = contacts
            .iter()
            .filter(|c| c["piece"] == "snare_rim" && !c["note"].is_null())
            .map(|c| {
                let planned = kit.strike.speed_for_velocity(c["note"]["velocity"].as_u64().unwrap() as u8);
                (c["speed_mps"].as_f64().unwrap(), planned as f64)
            })
            .collect();
        assert!(!rims.is_empty() && rims.iter().all(|(s, p)| *s >= 0.6 * p), "rim shots (speed, planned): {rims:?}");
        let played: Vec<&serde_json::Value> = contacts.iter().filter(|c| !c["note"].is_null()).collect();
        assert!(
            played.len() * 100 >= contacts.len() * 90,
            "{} of {} contacts played a note",
            played.len(),
            contacts.len()
        );
        let errs: Vec<f64> = played
            .iter()
            .map(|c| 1e3 * (c["time_s"].as_f64().unwrap() - c["note"]["time_s"].as_f64().unwrap()))
            .collect();
        let (mean, sd) = mean_sd(&errs);
        eprintln!(
            "demo: {} contacts, {} played a note, timing {mean:+.2} / sd {sd:.2} ms",
            contacts.len(),
            played.len()
        );
        assert!(mean.abs() <= 2.0 && sd <= 3.0, "timing {mean:+.2} / {sd:.2} ms");
        assert!(errs.iter().all(|e| e.abs() <= 10.0));
        wavs.push(std::fs::read(out.join("demo.wav")).unwrap());
        if run == 0 {
            // `drumsim eval` measures what the physical render carries: the strokes' aims
            // (IPD) and the contact speeds against velocity.
            let r = Command::new(env!("CARGO_BIN_EXE_drumsim"))
                .args(["eval", song.to_str().unwrap(), "--out", out.to_str().unwrap()])
                .output()
                .unwrap();
            assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
            let eval: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
            let ipd_mean = eval["ipd_mm"]["mean"].as_f64().expect("IPD of a physical render");
            let spearman = eval["velocity_speed_spearman"].as_f64().unwrap();
            eprintln!("demo: IPD mean {ipd_mean:.1} mm, velocity-speed Spearman {spearman:.3}");
            assert!(ipd_mean < 15.0 && spearman > 0.85, "{eval}");
            // The motion shows the simulated sticks: near the planned ones (a direct render's),
            // not equal to them.
            let direct = fresh_dir("demo-direct");
            let r = Command::new(env!("CARGO_BIN_EXE_drumsim"))
                .args(["render", song.to_str().unwrap(), "--out", direct.to_str().unwrap()])
                .output()
                .unwrap();
            assert!(r.status.success());
            let tips = |dir: &Path| -> Vec<f64> {
                let m: serde_json::Value =
                    serde_json::from_slice(&std::fs::read(dir.join("demo.motion.json")).unwrap()).unwrap();
                m["frames"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .flat_map(|f| f["tips"].as_array().unwrap().iter().flat_map(|t| t.as_array().unwrap().clone()))
                    .map(|v| v.as_f64().unwrap())
                    .collect()
            };
            let (sim, plan) = (tips(&out), tips(&direct));
            assert_eq!(sim.len(), plan.len());
            let mut d: Vec<f64> = sim
                .chunks(3)
                .zip(plan.chunks(3))
                .map(|(a, b)| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt())
                .collect();
            d.sort_by(f64::total_cmp);
            let median = d[d.len() / 2];
            eprintln!("demo: simulated tips {:.1} mm from the planned ones (median)", median * 1e3);
            assert!(median > 1e-4 && median < 0.03, "median {median} m");
        }
    }
    assert!(wavs[0] == wavs[1], "two physical renders of the demo differ");
}

#[test]
fn a_groove_midi_funk_take_is_played_by_the_body_and_its_pedals() {
    let (map, kit, perf, planned) = planned_take(FUNK);
    let take = play(&kit, &perf, &map, &planned, perf.notes_end_s + 0.5).unwrap();
    let hand = onsets(&perf, &map);
    let (of, played) = match_contacts(&hand, &take.messages);
    let recall = played.iter().filter(|p| **p).count() as f64 / hand.len() as f64;
    let spurious = of.iter().filter(|o| o.is_none()).count() as f64 / of.len() as f64;
    let errs: Vec<f64> = of
        .iter()
        .zip(&take.messages)
        .filter_map(|(o, m)| o.map(|i| 1e3 * (m.time_s as f64 - hand[i].time_s)))
        .collect();
    let (mean, sd) = mean_sd(&errs);
    eprintln!(
        "funk: recall {:.2} %, spurious {:.2} % of {} contacts, timing {mean:+.2} / sd {sd:.2} ms, deepest {:.1} mm, energy <= {:.0} J",
        100.0 * recall,
        100.0 * spurious,
        of.len(),
        take.max_penetration_m * 1e3,
        take.max_energy_j
    );
    assert!(take.finite);
    assert!(recall >= 0.98, "recall {recall}");
    assert!(spurious <= 0.05, "spurious {spurious}");
    // Every kick and hi-hat pedal note is played by its pedal.
    for piece in ["kick", "hihat"] {
        let pedal: Vec<bool> = hand
            .iter()
            .zip(&played)
            .filter(|(o, _)| o.zone == Zone::Pedal && o.piece == piece)
            .map(|(_, p)| *p)
            .collect();
        assert!(!pedal.is_empty() && pedal.iter().all(|p| *p), "{piece}: {pedal:?}");
    }
    assert!(mean.abs() <= 1.0 && sd <= 2.5, "timing {mean:+.2} / {sd:.2} ms");
    // The kit is rigid to the body: no stick sinks into a piece (11.9 mm over the split
    // with rapier's soft default, `body::model::KIT_CONTACT_HZ`).
    assert!(take.max_penetration_m <= 0.002, "sank {} m", take.max_penetration_m);
    // Bounded: the seated body's potential energy plus the strokes' kinetic energy.
    assert!(take.max_energy_j < 1000.0, "{} J", take.max_energy_j);
    // Tips at 60 fps for the whole song.
    assert!((take.tips.len() as f64 - (perf.notes_end_s + 0.5) * 60.0).abs() <= 2.0);
}

#[test]
fn a_kit_without_pedals_plays_the_hands_and_says_so_and_a_bad_live_lookahead_is_refused() {
    let dir = fresh_dir("nopedals");
    let kit = drumsim::kit::DEFAULT_KIT_TOML;
    let no_pedals = dir.join("no-pedals.toml");
    std::fs::write(&no_pedals, &kit[..kit.find("\n[pedals]").unwrap()]).unwrap();
    let song = root().join("assets/demo/demo.mid");
    let out = dir.join("out");
    let r = Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .args(["render", song.to_str().unwrap(), "--out", out.to_str().unwrap(), "--sound", "physical"])
        .args(["--kit", no_pedals.to_str().unwrap(), "--no-motion"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr).into_owned();
    assert!(r.status.success(), "{stderr}");
    assert!(stderr.contains("the kit has no [pedals]: kick and hi-hat pedal notes are not played"), "{stderr}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("demo.contacts.json")).unwrap()).unwrap();
    let contacts = json["contacts"].as_array().unwrap();
    assert!(!contacts.is_empty() && contacts.iter().all(|c| c["limb"].as_i64().unwrap() <= 1));
    // The live physical drummer shown on the page with an impossible lookahead: refused
    // before any device is opened, naming the option.
    let r = Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .args(["live", "--sound", "physical", "--view", "--lookahead-ms", "5000"])
        .output()
        .unwrap();
    assert_eq!(r.status.code(), Some(2), "{}", String::from_utf8_lossy(&r.stderr));
    assert!(String::from_utf8_lossy(&r.stderr).contains("lookahead"), "{}", String::from_utf8_lossy(&r.stderr));
}

/// The rehearsal's premise: a snapshot of the body plays on exactly as the original did, so
/// a stroke played again from one differs only by its corrected targets.
#[test]
fn a_snapshot_of_the_body_plays_on_exactly_as_the_original() {
    let (map, kit, perf, planned) = planned_take(FUNK);
    let mut c = Conductor::new(&kit, &perf, &map, &planned, DrummerSettings::default()).unwrap();
    while c.time_s() < 2.0 {
        c.period(&mut |_| {});
    }
    let snapshot = c.snapshot();
    let run = |c: &mut Conductor| {
        let (mut strikes, mut tips) = (Vec::new(), Vec::new());
        while c.time_s() < 3.5 {
            c.period(&mut |s| strikes.push(s));
            tips.push(c.drummer().tips(Mode::Himc));
        }
        (strikes, tips)
    };
    let first = run(&mut c);
    assert!(first.0.len() >= 8, "{} strikes in 1.5 s of funk", first.0.len());
    c.restore(&snapshot);
    assert_eq!(c.time_s(), snapshot.time_s());
    let again = run(&mut c);
    assert_eq!(first, again);
}

/// The rehearsal lifts the funk take's hits and timing above a straight play, and the
/// straight play (no attempts) is what the conductor alone does.
#[test]
fn the_rehearsal_plays_missed_and_late_strokes_again_until_they_land() {
    let (map, kit, perf, planned) = planned_take(FUNK);
    let end = 30.0;
    let hand: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < end - 0.1).collect();
    let measure = |attempts: u8| {
        let settings = RehearsalSettings { attempts, ..RehearsalSettings::default() };
        let take = play_with(&kit, &perf, &map, &planned, end, &settings).unwrap();
        let (of, played) = match_contacts(&hand, &take.messages);
        // Stick notes whose first contact, the bead on the note's own piece, came down over
        // twice the speed the note's velocity asks.
        let mut seen = vec![false; hand.len()];
        let too_hard = of
            .iter()
            .zip(&take.messages)
            .zip(&take.strikes)
            .filter_map(|((o, m), s)| o.filter(|&i| !std::mem::replace(&mut seen[i], true)).map(|i| (i, m, s)))
            .filter(|(i, m, s)| m.piece == hand[*i].piece && s.side < 2 && s.from_tip_m < 0.012)
            .filter(|(i, m, _)| m.speed_mps > 2.0 * kit.strike.speed_for_velocity(hand[*i].velocity))
            .count();
        (played.iter().filter(|p| **p).count(), take.replays, too_hard, take.reasons[6])
    };
    let (straight, none, hard_straight, _) = measure(0);
    let (rehearsed, replays, hard_rehearsed, speed_replays) = measure(RehearsalSettings::default().attempts);
    eprintln!(
        "first 30 s of funk: {straight} of {} notes hit straight, {rehearsed} rehearsed ({replays} replays, {speed_replays} for speed); over twice their speed: {hard_straight} straight, {hard_rehearsed} rehearsed",
        hand.len()
    );
    assert_eq!(none, 0);
    assert!(replays > 0);
    assert!(rehearsed > straight, "{rehearsed} <= {straight}");
    // Strokes far too hard or soft are played again (fewer land so over the validation split,
    // 1,220 to 1,035; on these 30 s the few there are do not fall: README).
    assert!(speed_replays > 0, "no stroke replayed for its speed");
}

/// A cross-stick's shaft meets the snare's hoop about 12 ms before the tip would reach the
/// head: a stroke that tracks its targets and still lands early. The rehearsal moves such a
/// stroke's last approach by its timing error (`learn_time`), so the cross-sticks of a bomba
/// groove land on their notes and none sounds early on the hoop.
#[test]
fn cross_sticks_that_meet_the_hoop_early_are_played_again_until_they_land_on_time() {
    let (map, kit, perf, planned) = planned_take("drummer1/session3/12_latin-bomba_96_beat_4-4.mid");
    let end = 12.0;
    let notes: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < end - 0.1).collect();
    let take = play(&kit, &perf, &map, &planned, end).unwrap();
    let (of, played) = match_contacts(&notes, &take.messages);
    let cross: Vec<usize> = (0..notes.len()).filter(|&i| notes[i].zone == Zone::CrossStick).collect();
    let missed: Vec<f64> = cross.iter().filter(|&&i| !played[i]).map(|&i| notes[i].time_s).collect();
    let stray_hoop = of.iter().zip(&take.messages).filter(|(o, m)| o.is_none() && m.piece.ends_with("_rim")).count();
    eprintln!(
        "bomba, first {end} s: {} cross-sticks, missed at {missed:?}; {stray_hoop} hoop contacts that played no note",
        cross.len()
    );
    assert!(cross.len() >= 10, "{} cross-sticks", cross.len());
    assert!(missed.is_empty(), "cross-sticks missed at {missed:?}");
    assert!(stray_hoop <= 1, "{stray_hoop} hoop contacts played no note");
}

/// A take that opens on tom 1 finds the left stick already over it. The body used to start
/// in its ready pose (the left stick over the snare) and swing to the first targets in the
/// preroll: the stick was caught under tom 1's shell for 150 ms, 4.7 mm into it.
#[test]
fn a_take_that_opens_on_a_tom_starts_with_the_stick_over_it() {
    let (map, kit, perf, planned) = planned_take("drummer1/session2/107_funk-rock_92_fill_4-4.mid");
    let take = play(&kit, &perf, &map, &planned, 1.5).unwrap();
    assert!(take.max_penetration_m <= 0.002, "sank {} mm at {:?}", take.max_penetration_m * 1e3, take.deepest_at);
    let notes: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < 1.4).collect();
    let (_, played) = match_contacts(&notes, &take.messages);
    assert!(notes.len() >= 3 && played.iter().all(|p| *p), "{played:?}");
}

/// A varied handful of validation takes, each rendered physically (the first 20 s of the
/// longer ones): a fast jazz ride pattern, a fill, a take in 3/4, a take with cross-sticks.
/// Each holds what the physical render reaches today (README, "Physical render"), and
/// together the IPD (p95 within 10 mm).
#[test]
fn a_varied_handful_of_takes_is_played_on_time() {
    let takes = [
        ("drummer3/session1/39_jazz_120_beat_4-4.mid", 0.97, 0.95),
        ("drummer1/session1/17_jazz-funk_116_fill_4-4.mid", 0.95, 0.95),
        ("drummer1/session2/1_latin-chacarera_157_beat_3-4.mid", 0.97, 0.95),
        ("drummer1/session1/145_latin-brazilian-baiao_95_beat_4-4.mid", 0.95, 0.93),
    ];
    let results: Vec<_> = std::thread::scope(|s| {
        let jobs: Vec<_> = takes
            .iter()
            .map(|&(take, min_recall, min_precision)| {
                s.spawn(move || {
                    let (map, kit, perf, planned) = planned_take(take);
                    let end = (perf.notes_end_s + 0.5).min(20.0);
                    let take_ = play(&kit, &perf, &map, &planned, end).unwrap();
                    let notes: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < end - 0.1).collect();
                    let (of, played) = match_contacts(&notes, &take_.messages);
                    let recall = played.iter().filter(|p| **p).count() as f64 / notes.len() as f64;
                    let precision = of.iter().filter(|o| o.is_some()).count() as f64 / of.len().max(1) as f64;
                    let errs: Vec<f64> = of
                        .iter()
                        .zip(&take_.messages)
                        .filter_map(|(o, m)| o.map(|i| 1e3 * (m.time_s as f64 - notes[i].time_s)))
                        .collect();
                    // IPD: each stick note's first contact on its own piece, from the zone's strike point.
                    let mut first = vec![false; notes.len()];
                    let ipd_mm: Vec<f64> = of
                        .iter()
                        .zip(&take_.messages)
                        .filter_map(|(o, m)| {
                            let i = (*o)?;
                            let stick = matches!(m.limb, Limb::LeftHand | Limb::RightHand);
                            let piece = kit.piece(&notes[i].piece).filter(|p| stick && p.id == m.piece)?;
                            (!std::mem::replace(&mut first[i], true)).then_some(())?;
                            Some(
                                1e3 * drumsim::kit::strike_miss(&kit, piece, notes[i].zone, [m.x_m, m.y_m]).distance_m
                                    as f64,
                            )
                        })
                        .collect();
                    (
                        take,
                        notes.len(),
                        recall,
                        precision,
                        mean_sd(&errs),
                        take_.finite,
                        (min_recall, min_precision),
                        ipd_mm,
                    )
                })
            })
            .collect();
        jobs.into_iter().map(|j| j.join().unwrap()).collect()
    });
    for (take, n, recall, precision, (mean, sd), ..) in &results {
        eprintln!(
            "{take}: {n} notes, recall {:.2} %, precision {:.2} %, timing {mean:+.2} / {sd:.2} ms",
            100.0 * recall,
            100.0 * precision
        );
    }
    // The IPD: the strike points' spread, p95 within 10 mm over the handful.
    let mut ipd: Vec<f64> = results.iter().flat_map(|r| r.7.iter().copied()).collect();
    ipd.sort_by(f64::total_cmp);
    let p95 = ipd[((0.95 * ipd.len() as f64).ceil() as usize).clamp(1, ipd.len()) - 1];
    eprintln!(
        "IPD over {} stick notes: mean {:.1} mm, p95 {p95:.1} mm",
        ipd.len(),
        ipd.iter().sum::<f64>() / ipd.len() as f64
    );
    assert!(ipd.len() >= 200 && p95 <= 10.0, "IPD p95 {p95:.1} mm over {} notes", ipd.len());
    for (take, _, recall, precision, (mean, sd), finite, (min_recall, min_precision), _) in results {
        assert!(finite, "{take}");
        assert!(recall >= min_recall, "{take}: recall {recall}");
        assert!(precision >= min_precision, "{take}: precision {precision}");
        // A few dozen notes: the mean is looser than the split's 1 ms.
        assert!(mean.abs() <= 2.5 && sd <= 3.0, "{take}: timing {mean:+.2} / {sd:.2} ms");
    }
}

#[test]
fn the_physical_demo_sounds_like_the_direct_one_note_by_note() {
    use drumsim::eval::note_sound::{compare, summarize};
    use drumsim::render::{load_hands, load_song, score_performance, score_physical, stage_motion, RenderOptions};
    let opts = RenderOptions::default();
    let kit = Kit::builtin_default();
    let (perf, map) = load_song(&root().join("assets/demo/demo.mid"), &opts).unwrap();
    assert_eq!(map.source, "auto: built-in gm");
    let direct = score_performance(&perf, &kit, &map).unwrap();
    let mut staged = stage_motion(&perf, &kit, &map, &load_hands(&opts).unwrap()).unwrap();
    let (physical, _) = score_physical(&perf, &kit, &map, &mut staged).unwrap();
    let notes = compare(&kit, &direct.contacts, &physical.contacts).unwrap();
    let s = summarize(&notes);
    eprintln!("demo, physical against direct: {s:?}");
    // Each note's strikes sounded alone in both renders: nearly every note is compared.
    let direct_notes: std::collections::HashSet<_> =
        direct.contacts.contacts.iter().filter_map(|c| c.note.map(|n| (n.note, n.time_s.to_bits()))).collect();
    assert!(s.notes as f64 >= 0.97 * direct_notes.len() as f64, "{} of {}", s.notes, direct_notes.len());
    // The level targets: median |difference| <= 2 dB, 95 % within 6 dB.
    assert!(s.level_median_abs_db <= 2.0, "{s:?}");
    assert!(s.level_within_6db >= 0.95, "{s:?}");
    // Not louder or softer overall (the physical render was 10 dB louder when the stick's
    // striking mass included the hand's).
    assert!(s.level_median_db.abs() <= 1.5, "{s:?}");
    // Onsets: the issue asks all within 2 ms; the body's contacts reach 85 % (README).
    assert!(s.onset_within_2ms >= 0.85 && s.onset_p95_abs_ms <= 3.5, "{s:?}");
    // A choke in the song chokes the crash in both renders.
    assert_eq!(physical.contacts.chokes.len(), direct.contacts.chokes.len());
    // Every stick contact on the snare's hoop rings on its own (a hoop contact's point once
    // lay outside the plate that sounds the hoop, and made no sound).
    let rims: Vec<_> = physical.contacts.contacts.iter().filter(|c| c.contact.piece == "snare_rim").collect();
    assert!(!rims.is_empty());
    for c in rims {
        let t0 = c.contact.time_s as f64 - 0.02;
        assert!(drumsim::eval::note_sound::sound(&kit, &[c], &[], t0).unwrap().is_some(), "silent: {c:?}");
    }
}

/// Live play on a simulated clock (`perform::replay`: the window plans every 50 ms, handed
/// to the body when live play would): deterministic, and it plays a Groove MIDI take about
/// as well as the straight offline play-through (README, "The live physical drummer").
#[test]
fn live_play_on_a_simulated_clock_repeats_exactly_and_strikes_the_notes() {
    use drumsim::perform::replay::{replay, ReplaySettings};
    let take = "drummer1/session2/1_latin-chacarera_157_beat_3-4.mid";
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::builtin_default();
    let perf = read_file(&root().join("data/gmd").join(take), &ReadOptions { channel: 10 }).unwrap();
    let end = 12.0;
    let run = || {
        let r = replay(
            &kit,
            &map,
            HandModel::shipped(),
            shipped_library().unwrap(),
            &perf,
            end,
            &ReplaySettings::default(),
        )
        .unwrap();
        r.strikes
            .iter()
            .filter(|s| s.time_s >= -0.01)
            .map(|s| s.message_named(&r.surfaces[s.surface]))
            .collect::<Vec<_>>()
    };
    let (a, b) = (run(), run());
    assert_eq!(a.len(), b.len());
    assert!(a.iter().zip(&b).all(|(x, y)| x.time_s == y.time_s && x.piece == y.piece), "the same contacts, twice");
    let notes: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < end - 0.1).collect();
    let (of, played) = match_contacts(&notes, &a);
    let recall = played.iter().filter(|p| **p).count() as f64 / notes.len() as f64;
    let precision = of.iter().filter(|o| o.is_some()).count() as f64 / of.len() as f64;
    let errs: Vec<f64> =
        of.iter().zip(&a).filter_map(|(o, m)| o.map(|i| 1e3 * (m.time_s as f64 - notes[i].time_s))).collect();
    let (mean, sd) = mean_sd(&errs);
    eprintln!("{take}, live on a simulated clock: recall {recall:.3}, precision {precision:.3}, timing {mean:+.2} / {sd:.2} ms");
    assert!(recall >= 0.97 && precision >= 0.90, "recall {recall:.3}, precision {precision:.3}");
    assert!(mean.abs() <= 2.0 && sd <= 4.0, "timing {mean:+.2} / {sd:.2} ms");
}

/// Live play brings each stroke's last millimetres down with the stick's angle held
/// (`TargetSettings::live`). With the angle free, the plan's wrist turn toward the strike
/// point, which the simulated arm lags by up to a degree, stalls the stick just above the
/// surface: about one hand stroke in ten of this take played straight through (as live play
/// must, with no rehearsal) touches at under half the speed its velocity asks (a hi-hat
/// stroke at 0.13 m/s for 1.1) and is barely heard.
#[test]
fn strokes_played_straight_through_land_at_the_speed_their_velocity_asks() {
    let (map, kit, perf, planned) = planned_take("drummer1/session2/1_latin-chacarera_157_beat_3-4.mid");
    let end = 30.0;
    let notes: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < end - 0.1).collect();
    let straight = |targets: TargetSettings| {
        let settings = RehearsalSettings { attempts: 0, targets, ..Default::default() };
        let take = play_with(&kit, &perf, &map, &planned, end, &settings).unwrap();
        let (of, _) = match_contacts(&notes, &take.messages);
        let mut ratios: Vec<f32> = of
            .iter()
            .zip(&take.messages)
            .zip(&take.strikes)
            .filter(|(_, s)| s.side < 2)
            .filter_map(|((o, m), _)| o.map(|i| m.speed_mps / kit.strike.speed_for_velocity(notes[i].velocity)))
            .collect();
        ratios.sort_by(f32::total_cmp);
        let soft = ratios.iter().filter(|r| **r < 0.5).count();
        (soft, ratios.len(), ratios[ratios.len() / 2])
    };
    let (soft_free, n_free, median_free) = straight(TargetSettings::default());
    let (soft, n, median) = straight(TargetSettings::live());
    eprintln!(
        "hand contacts on their notes, played straight: angle free {soft_free} of {n_free} under half the asked \
         speed (median speed / asked {median_free:.2}); held as live play holds it {soft} of {n} ({median:.2})"
    );
    assert!(soft_free * 20 > n_free, "the take no longer shows the stall: {soft_free} of {n_free}");
    assert!(soft * 50 <= n, "{soft} of {n} strokes under half their speed");
    assert!((0.8..=1.3).contains(&median), "median speed / asked {median:.2}");
}
