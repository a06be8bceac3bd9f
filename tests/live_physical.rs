//! `drumsim live --sound physical` end to end with a real JACK server (dummy driver): a test
//! client plays a Groove MIDI validation take into drumsim's MIDI port on JACK's clock; the
//! simulated body strikes the kit and its contacts go, as time-tagged OSC bundles over real
//! UDP (`--sound-to`), to this test. Each bundle's tag is when the sound server plays it
//! (`tests/sound_server.rs` shows the server's audio follows the tags within 0.25 ms), so the
//! tags are the sound's times. Contacts are matched to the notes as the offline render
//! matches them (`perform::matching`).
#![cfg(feature = "jack")]

#[allow(dead_code)]
mod jack_rig;

use drumsim::interaction::{decode_timed, ContactMessage, Message};
use drumsim::midi::{read_file, DrumEventKind, NoteMap, ReadOptions};
use drumsim::perform::matching::{match_contacts, onsets, DOUBLE_TRIGGER_S, HIT_WINDOW_S};

/// The recorded-audio test leaves out notes and strikes this long before and after an xrun.
const XRUN_BEFORE_S: f64 = 0.05;
const XRUN_AFTER_S: f64 = 0.3;
use jack_rig::*;
use std::net::UdpSocket;
use std::path::Path;
use std::sync::atomic::Ordering;
use std::thread;
use std::time::{Duration, Instant};

/// The take (validation split: never trained on) and how much of it is played, s.
const TAKE: &str = "drummer1/session2/1_latin-chacarera_157_beat_3-4.mid";
const PLAYED_S: f64 = 60.0;
const LOOKAHEAD_MS: f64 = 250.0;

/// OSC time tag -> Unix seconds.
fn unix(t: rosc::OscTime) -> f64 {
    t.seconds as f64 - 2_208_988_800.0 + t.fractional as f64 / 4_294_967_296.0
}

/// The take's first `PLAYED_S` as (frame, MIDI bytes) from `FIRST_NOTE`, and the frame
/// after its last event plus a second.
fn take() -> (drumsim::midi::Performance, NoteMap, Vec<(u64, [u8; 3])>, u64) {
    let song = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd").join(TAKE);
    let perf = read_file(&song, &ReadOptions::default()).unwrap();
    let map = NoteMap::load("roland-td").unwrap();
    let mut schedule = Vec::new();
    for e in perf.events.iter().filter(|e| e.time_s < PLAYED_S) {
        let bytes = match e.kind {
            DrumEventKind::NoteOn { note, velocity } => [0x99, note, velocity],
            DrumEventKind::NoteOff { note } => [0x89, note, 0],
            DrumEventKind::HiHatPedal { value } => [0xB9, 4, value],
            DrumEventKind::Aftertouch { note, pressure } => [0xA9, note, pressure],
        };
        schedule.push((FIRST_NOTE + (e.time_s * RATE as f64).round() as u64, bytes));
    }
    let total = schedule.last().unwrap().0 + RATE;
    (perf, map, schedule, total)
}

/// `drumsim live --sound physical` playing the take, its sound going where `out` says.
fn take_args(total: u64, out: &[&str]) -> Vec<String> {
    let (seconds, lookahead) = ((total / RATE + 4).to_string(), LOOKAHEAD_MS.to_string());
    let args = ["--midi", "drumsim-test:midi_out", "--map", "roland-td", "--sound", "physical"];
    let timing = ["--lookahead-ms", &lookahead, "--duration-s", &seconds];
    args.iter().chain(out).chain(&timing).map(|a| a.to_string()).collect()
}

#[test]
fn a_groove_midi_take_played_live_is_struck_by_the_body_each_note_lookahead_after_it_was_played() {
    let _turn = one_at_a_time();
    let jack = JackServer::start();
    let (perf, map, schedule, total) = take();
    let (client, armed, progress) = player("drumsim-test", schedule, total as usize);

    let inbound = UdpSocket::bind("127.0.0.1:0").unwrap();
    inbound.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    let to = format!("udp://{}", inbound.local_addr().unwrap());
    let args = take_args(total, &["--sound-to", &to]);
    let mut live = Drumsim::live(&jack, &args.iter().map(String::as_str).collect::<Vec<_>>());
    live.wait_for("drumsim live: MIDI", Duration::from_secs(60));
    let receiving = thread::spawn(move || {
        let mut got = Vec::new();
        let mut buf = vec![0u8; 65_536];
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(200) {
            match inbound.recv(&mut buf) {
                Ok(n) => got.extend(decode_timed(&buf[..n]).unwrap()),
                Err(_) if got.is_empty() || start.elapsed() < Duration::from_secs(5) => {}
                Err(_) => {
                    // Quiet for a while after the last message: done.
                    if start.elapsed() > Duration::from_secs_f64(PLAYED_S + 8.0) {
                        break;
                    }
                }
            }
        }
        got
    });
    armed.store(true, Ordering::Release);
    let (start, cpu_before) = (Instant::now(), live.cpu_s());
    while progress.load(Ordering::Acquire) < total {
        assert!(start.elapsed() < Duration::from_secs(120), "JACK is not running the test client");
        thread::sleep(Duration::from_millis(100));
    }
    // The whole process's share of a core while the take played (MIDI input, planner, body
    // and out threads; its sound is the server's here).
    let cpu = cpu_before.zip(live.cpu_s()).map(|(a, b)| 100.0 * (b - a) / start.elapsed().as_secs_f64());
    let (_, _, player) = client.deactivate().unwrap();
    let status = live.wait_exit(Duration::from_secs(30));
    assert!(status.success(), "drumsim live failed ({status}):\n{}", live.stderr());
    let got = receiving.join().unwrap();

    // The wall time of each note: its frame in the period whose callback ran at a known wall
    // time (the player's clock log), so that a JACK driver drifting from the wall clock does
    // not move it. The notes then carry their wall time less the take's time 0 here.
    let wall_of = |frame: u64| {
        let i = player.clock.partition_point(|(f, _)| *f <= frame).saturating_sub(1);
        let (f0, w0) = player.clock[i];
        w0 + (frame as f64 - f0 as f64) / RATE as f64
    };
    let zero = wall_of(FIRST_NOTE);
    let mut contacts: Vec<ContactMessage> = got
        .iter()
        .filter_map(|(tag, m)| match (tag, m) {
            (Some(tag), Message::Contact(c)) => {
                Some(ContactMessage { time_s: (unix(*tag) - LOOKAHEAD_MS / 1e3 - zero) as f32, ..c.clone() })
            }
            _ => None,
        })
        .filter(|c| c.time_s > -0.1 && (c.time_s as f64) < PLAYED_S + 0.05)
        .collect();
    contacts.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let mut notes: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < PLAYED_S).collect();
    for n in &mut notes {
        n.time_s = wall_of(FIRST_NOTE + (n.time_s * RATE as f64).round() as u64) - zero;
    }
    let (of_contact, played) = match_contacts(&notes, &contacts);
    let hit = played.iter().filter(|p| **p).count();
    let matched: Vec<f64> =
        of_contact.iter().zip(&contacts).filter_map(|(o, c)| o.map(|i| c.time_s as f64 - notes[i].time_s)).collect();
    let spurious = of_contact.iter().filter(|o| o.is_none()).count();
    let n = matched.len().max(1) as f64;
    let mean = matched.iter().sum::<f64>() / n;
    let sd = (matched.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n).sqrt();
    let recall = hit as f64 / notes.len() as f64;
    let precision = 1.0 - spurious as f64 / contacts.len().max(1) as f64;
    let stderr = live.stderr();
    let body = stderr.lines().find(|l| l.contains("body:")).unwrap_or_default().to_string();
    println!(
        "{TAKE}, first {PLAYED_S} s, lookahead {LOOKAHEAD_MS} ms: {} notes, {} contacts; recall {:.2} %, precision \
         {:.2} %; contact - note: mean {:+.2} ms, sd {:.2} ms; drumsim live used {} of a core\n{body}",
        notes.len(),
        contacts.len(),
        100.0 * recall,
        100.0 * precision,
        mean * 1e3,
        sd * 1e3,
        cpu.map_or("an unknown share".to_string(), |c| format!("{c:.0} %"))
    );
    if let Ok(path) = std::env::var("DRUMSIM_LIVE_PHYSICAL_JSON") {
        let rows: Vec<String> = contacts
            .iter()
            .zip(&of_contact)
            .map(|(c, o)| format!("[{:.4},{:?},{}]", c.time_s, c.piece, o.map_or(-1, |i| i as i64)))
            .collect();
        let nrows: Vec<String> = notes.iter().map(|o| format!("[{:.4},{:?}]", o.time_s, o.piece)).collect();
        std::fs::write(path, format!("{{\"contacts\":[{}],\"notes\":[{}]}}", rows.join(","), nrows.join(","))).unwrap();
    }
    assert!(!contacts.is_empty(), "no contact arrived:\n{stderr}");
    let count = |what: &str| -> u64 {
        let before = body.split(what).next().unwrap_or_default();
        before.trim_end().rsplit(' ').next().and_then(|n| n.parse().ok()).unwrap_or(u64::MAX)
    };
    assert_eq!(count(" system allocator calls"), 0, "the physics thread called the system allocator: {body}");
    // On this 2-core machine the JACK server, the test's client and drumsim's threads share
    // the cores: a stall of tens of ms now and then is the machine's, not the body's (on an
    // otherwise idle core there are none); the body keeps up everywhere else.
    let periods = count(" periods at 250 Hz");
    let lost = count(" behind (") + count(" dropped to catch up");
    assert!(lost * 100 <= periods, "the body fell behind in {lost} of {periods} periods: {body}");
    // The issue's targets: recall and precision 99 %, mean within 2 ms, sd 3 ms (README, "The
    // live physical drummer").
    assert!(recall >= 0.99 && precision >= 0.99, "recall {recall:.3}, precision {precision:.3}");
    assert!(mean.abs() <= 0.002 && sd <= 0.003, "contact - note: mean {mean:+.4} s, sd {sd:.4} s");
}

/// The same take with the sound in drumsim's own process (`--audio jack --stems`): the test
/// client records drumsim's audio ports, the stereo mix and one channel per kit piece, and
/// finds each strike in the audio alone (`eval::onsets` on each piece's channel). Each
/// note's piece must sound within 10 ms of its note time plus the lookahead, as in the
/// contacts test above, but measured in the recording against the sent MIDI: recall and
/// precision 99 %, mean within 2 ms, sd 3 ms.
#[test]
fn the_take_played_live_sounds_in_the_recorded_audio_of_each_piece_lookahead_after_each_note() {
    use drumsim::eval::onsets::stem_onsets;
    use drumsim::kit::Kit;
    use jack::PortFlags;
    let _turn = one_at_a_time();
    let jack = JackServer::start();
    let (perf, map, schedule, total) = take();
    let kit = Kit::builtin_default();
    let pieces = kit.pieces.len();
    let record = (total + RATE) as usize;
    let (client, armed, progress) = player_with_tracks("drumsim-test", schedule, record, pieces);
    let args = take_args(total, &["--audio", "jack", "--stems"]);
    let mut live = Drumsim::live(&jack, &args.iter().map(String::as_str).collect::<Vec<_>>());
    live.wait_for("drumsim live: MIDI", Duration::from_secs(60));
    let pattern = format!("cpal_client_{}_out:", live.child.id());
    let mut outs = client.as_client().ports(Some(&pattern), Some("32 bit float mono audio"), PortFlags::IS_OUTPUT);
    // out_1, out_2, ... out_13: in channel order.
    outs.sort_by_key(|p| p.rsplit('_').next().and_then(|n| n.parse::<u32>().ok()));
    assert_eq!(outs.len(), 2 + pieces, "the mix and a stem per piece ({pattern}*): {outs:?}");
    let inputs: Vec<String> = ["in_l".to_string(), "in_r".to_string()]
        .into_iter()
        .chain((0..pieces).map(|i| format!("in_{}", i + 3)))
        .map(|p| format!("drumsim-test:{p}"))
        .collect();
    for (out, input) in outs.iter().zip(&inputs) {
        client.as_client().connect_ports_by_name(out, input).unwrap();
    }
    armed.store(true, Ordering::Release);
    let start = Instant::now();
    while progress.load(Ordering::Acquire) < record as u64 {
        assert!(start.elapsed() < Duration::from_secs(120), "JACK is not running the test client");
        thread::sleep(Duration::from_millis(100));
    }
    let (_, xruns, player) = client.deactivate().unwrap();
    let status = live.wait_exit(Duration::from_secs(30));
    assert!(status.success(), "drumsim live failed ({status}):\n{}", live.stderr());

    // Each piece's strikes in its channel, in frames of the test client's clock (the MIDI
    // schedule's), less the lookahead.
    let late = LOOKAHEAD_MS / 1e3;
    let found: Vec<Vec<f64>> = player
        .tracks
        .iter()
        .map(|t| stem_onsets(t, RATE as f64).into_iter().map(|s| s - late - FIRST_NOTE as f64 / RATE as f64).collect())
        .collect();
    // The xruns the test client was told of, in the notes' time (as the strikes). A cycle
    // some client missed on this shared, non-realtime server costs drumsim's audio clock a
    // period and a re-lock: its strikes then sound a period or more off for up to ~250 ms
    // (measured under two busy loops: every note missed and every strike without a note lay
    // 0-200 ms after an xrun). Notes and strikes there are left out and counted.
    let mut xrun_s: Vec<f64> = xruns
        .0
        .iter()
        .filter_map(|&w| player.frame_at(w))
        .map(|f| f as f64 / RATE as f64 - late - FIRST_NOTE as f64 / RATE as f64)
        .collect();
    // JACK tells each client of an xrun, and one late cycle often brings several in a period.
    xrun_s.dedup_by(|a, b| (*a - *b).abs() < 0.01);
    let disturbed = |t: f64| xrun_s.iter().any(|x| (-XRUN_BEFORE_S..=XRUN_AFTER_S).contains(&(t - x)));
    // The notes, one sound per piece where notes on it are within the planner's merge window
    // (an e-kit's double triggers; a hi-hat chick under a stick note).
    let mut notes: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < PLAYED_S).collect();
    notes.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
    let mut sounds: Vec<(f64, String, Vec<usize>)> = Vec::new();
    for (i, n) in notes.iter().enumerate() {
        match sounds.iter_mut().rev().take(8).find(|(t, p, _)| *p == n.piece && n.time_s - *t <= DOUBLE_TRIGGER_S) {
            Some(group) => group.2.push(i),
            None => sounds.push((n.time_s, n.piece.clone(), vec![i])),
        }
    }
    // A piece's sound is in its own channel or its hoop's (a cross-stick, a rim shot).
    let mut heard: Vec<Vec<usize>> = vec![Vec::new(); sounds.len()];
    let mut spurious = 0;
    let mut extra = Vec::new();
    let mut offsets = Vec::new();
    let mut strikes = 0;
    for (k, piece) in kit.pieces.iter().enumerate() {
        let of = piece.id.strip_suffix("_rim").unwrap_or(&piece.id);
        for &t in found[k].iter().filter(|t| (-0.1..PLAYED_S + 0.05).contains(*t)) {
            if disturbed(t) {
                continue;
            }
            strikes += 1;
            let best = (0..sounds.len())
                .filter(|&g| sounds[g].1 == of && (sounds[g].0 - t).abs() <= HIT_WINDOW_S && !heard[g].contains(&k))
                .min_by(|&a, &b| (sounds[a].0 - t).abs().total_cmp(&(sounds[b].0 - t).abs()));
            match best {
                Some(g) => {
                    if heard[g].is_empty() {
                        offsets.push(t - sounds[g].0);
                    }
                    heard[g].push(k);
                }
                None => {
                    spurious += 1;
                    extra.push(format!("{} {t:.3}", piece.id));
                }
            }
        }
    }
    let judged: Vec<bool> = sounds.iter().map(|s| !disturbed(s.0)).collect();
    let judged_notes: usize = sounds.iter().zip(&judged).filter(|(_, j)| **j).map(|(s, _)| s.2.len()).sum();
    let sounded: usize = sounds
        .iter()
        .zip(&heard)
        .zip(&judged)
        .filter(|((_, h), j)| **j && !h.is_empty())
        .map(|((s, _), _)| s.2.len())
        .sum();
    let recall = sounded as f64 / judged_notes.max(1) as f64;
    let precision = 1.0 - spurious as f64 / strikes.max(1) as f64;
    let n = offsets.len().max(1) as f64;
    let mean = offsets.iter().sum::<f64>() / n;
    let sd = (offsets.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / n).sqrt();
    let missed: Vec<String> = sounds
        .iter()
        .zip(&heard)
        .zip(&judged)
        .filter(|((_, h), j)| **j && h.is_empty())
        .map(|((s, _), _)| format!("{} {:.3}", s.1, s.0))
        .collect();
    let stderr = live.stderr();
    let body = stderr.lines().find(|l| l.contains("body:")).unwrap_or_default().to_string();
    println!(
        "{TAKE}, first {PLAYED_S} s, in the recorded audio: {} notes ({} sounds), {} judged (the rest within \
         {XRUN_BEFORE_S} s before to {XRUN_AFTER_S} s after one of {} xruns at {xrun_s:.2?}), {strikes} strikes \
         found; recall {:.2} %, precision {:.2} %; strike - note - lookahead: mean {:+.2} ms, sd {:.2} ms\nmissed: \
         {missed:?}\nno note: {extra:?}\n{body}",
        notes.len(),
        sounds.len(),
        judged_notes,
        xrun_s.len(),
        100.0 * recall,
        100.0 * precision,
        mean * 1e3,
        sd * 1e3,
    );
    if let Ok(dir) = std::env::var("DRUMSIM_LIVE_STEMS_DIR") {
        for (piece, t) in kit.pieces.iter().zip(&player.tracks) {
            save_wav(&Path::new(&dir).join(format!("{}.wav", piece.id)), t);
        }
    }
    // The targets. Measured (README): recall 99.63-99.81 %, precision 99.44-100 %,
    // mean +0.05 to +0.09 ms, sd 1.24-1.32 ms; the notes missed are a hi-hat foot closing a
    // ringing open hat and the soft stroke 33 ms after it.
    // Xruns are this machine's, not drumsim's (drumsim counts them too); the judged notes
    // must still be nine in ten.
    assert!(judged_notes * 10 >= notes.len() * 9, "{judged_notes} of {} notes clear of xruns", notes.len());
    assert!(recall >= 0.99 && precision >= 0.99, "recall {recall:.3}, precision {precision:.3}");
    assert!(mean.abs() <= 0.002 && sd <= 0.003, "strike - note - lookahead: mean {mean:+.4} s, sd {sd:.4} s");
}

/// The same drummer with its sound in this process (`--audio jack`, no `--sound-to`): the
/// test client records drumsim's audio port, and the notes of a short run of drums sound in
/// the recording about the lookahead after they were played (measured: 245-254 ms at 250).
#[test]
fn the_live_physical_drummer_sounds_through_its_own_audio_output() {
    use jack::PortFlags;
    let _turn = one_at_a_time();
    let jack = JackServer::start();
    // Drums only, a second apart: a crash rings too long for the onset detector.
    let notes = [(38u8, 100u8), (36, 110), (45, 90), (38, 120), (48, 100), (36, 100), (38, 80), (43, 110)];
    let starts: Vec<u64> = (0..notes.len() as u64).map(|i| FIRST_NOTE + RATE + i * RATE).collect();
    let schedule = notes.iter().zip(&starts).map(|(&(n, v), &t)| (t, [0x99, n, v])).collect();
    let total = starts.last().unwrap() + RATE;
    let (client, armed, progress) = player("drumsim-test", schedule, total as usize);
    let seconds = (total / RATE + 3).to_string();
    let lookahead = LOOKAHEAD_MS.to_string();
    let args = [
        "--midi",
        "drumsim-test:midi_out",
        "--map",
        "gm",
        "--sound",
        "physical",
        "--audio",
        "jack",
        "--lookahead-ms",
        &lookahead,
        "--duration-s",
        &seconds,
    ];
    let mut live = Drumsim::live(&jack, &args);
    live.wait_for("drumsim live: MIDI", Duration::from_secs(60));
    let pattern = format!("cpal_client_{}_out:", live.child.id());
    let outs = client.as_client().ports(Some(&pattern), Some("32 bit float mono audio"), PortFlags::IS_OUTPUT);
    assert!(outs.len() >= 2, "the audio ports ({pattern}*): {outs:?}");
    for (out, input) in outs.iter().zip(["drumsim-test:in_l", "drumsim-test:in_r"]) {
        client.as_client().connect_ports_by_name(out, input).unwrap();
    }
    armed.store(true, Ordering::Release);
    let start = Instant::now();
    while progress.load(Ordering::Acquire) < total {
        assert!(start.elapsed() < Duration::from_secs(60), "JACK is not running the test client");
        thread::sleep(Duration::from_millis(50));
    }
    let (_, _, player) = client.deactivate().unwrap();
    let status = live.wait_exit(Duration::from_secs(30));
    assert!(status.success(), "drumsim live failed ({status}):\n{}", live.stderr());
    let ms = |m: f64| (m * RATE as f64 / 1000.0) as usize;
    let heard: Vec<Option<f64>> = starts
        .iter()
        .map(|&t| {
            let from = t as usize + ms(LOOKAHEAD_MS - 40.0);
            onset(&player.recorded, from, from + ms(80.0)).map(|at| (at - t as usize) as f64 * 1e3 / RATE as f64)
        })
        .collect();
    println!("each note heard after it was played (ms): {heard:.1?}");
    // The body strikes about 99 % of notes (a tom now and then is missed): all but one here.
    let sounded: Vec<f64> = heard.iter().flatten().copied().collect();
    assert!(sounded.len() + 1 >= notes.len(), "{} of {} notes sounded:\n{}", sounded.len(), notes.len(), live.stderr());
    assert!(
        sounded.iter().all(|h| (h - LOOKAHEAD_MS).abs() <= 10.0),
        "each about the lookahead after its note: {heard:.1?}"
    );
}

/// A broken controller floods drumsim with thousands of notes a second: the flood is
/// counted, the body keeps its pace, and the notes played after it are struck as usual.
#[test]
fn a_note_flood_is_counted_and_the_drummer_plays_on() {
    let _turn = one_at_a_time();
    let jack = JackServer::start();
    let at = |s: f64| FIRST_NOTE + (s * RATE as f64).round() as u64;
    // Notes before the flood, 4,800 snare notes a second for a second, then notes again once
    // the flood has left the planner's window (2 s of history) and the lookahead.
    let before = [(1.0, 38u8), (1.5, 36), (2.0, 45)];
    let after = [(6.5, 38u8), (7.0, 36), (7.5, 45), (8.0, 38), (8.5, 48), (9.0, 38)];
    let mut schedule: Vec<(u64, [u8; 3])> =
        before.iter().chain(&after).map(|&(t, note)| (at(t), [0x99, note, 100])).collect();
    let flood: Vec<(u64, [u8; 3])> = (0..4800u64).map(|i| (at(2.5) + i * 10, [0x99, 38, 90])).collect();
    schedule.extend(&flood);
    schedule.sort_by_key(|(t, _)| *t);
    let total = at(10.0);
    let (client, armed, progress) = player("drumsim-test", schedule, total as usize);

    let inbound = UdpSocket::bind("127.0.0.1:0").unwrap();
    inbound.set_read_timeout(Some(Duration::from_millis(200))).unwrap();
    let to = format!("udp://{}", inbound.local_addr().unwrap());
    let seconds = (total / RATE + 3).to_string();
    let lookahead = LOOKAHEAD_MS.to_string();
    let args = [
        "--midi",
        "drumsim-test:midi_out",
        "--map",
        "gm",
        "--sound",
        "physical",
        "--sound-to",
        &to,
        "--lookahead-ms",
        &lookahead,
        "--duration-s",
        &seconds,
    ];
    let mut live = Drumsim::live(&jack, &args);
    live.wait_for("drumsim live: MIDI", Duration::from_secs(60));
    let receiving = thread::spawn(move || {
        let mut got = Vec::new();
        let mut buf = vec![0u8; 65_536];
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(25) {
            if let Ok(n) = inbound.recv(&mut buf) {
                got.extend(decode_timed(&buf[..n]).unwrap());
            }
        }
        got
    });
    armed.store(true, Ordering::Release);
    let start = Instant::now();
    while progress.load(Ordering::Acquire) < total {
        assert!(start.elapsed() < Duration::from_secs(60), "JACK is not running the test client");
        thread::sleep(Duration::from_millis(100));
    }
    let (_, _, player) = client.deactivate().unwrap();
    let status = live.wait_exit(Duration::from_secs(30));
    let stderr = live.stderr();
    assert!(status.success(), "drumsim live failed ({status}):\n{stderr}");
    let got = receiving.join().unwrap();
    let wall_of = |frame: u64| {
        let i = player.clock.partition_point(|(f, _)| *f <= frame).saturating_sub(1);
        let (f0, w0) = player.clock[i];
        w0 + (frame as f64 - f0 as f64) / RATE as f64
    };
    let contacts: Vec<(f64, String)> = got
        .iter()
        .filter_map(|(tag, m)| match (tag, m) {
            (Some(tag), Message::Contact(c)) => Some((unix(*tag) - LOOKAHEAD_MS / 1e3, c.piece.clone())),
            _ => None,
        })
        .collect();
    let body = stderr.lines().find(|l| l.contains("body:")).unwrap_or_default().to_string();
    println!("{} contacts; {body}", contacts.len());
    let count = |what: &str| -> u64 {
        let before = body.split(what).next().unwrap_or_default();
        before.trim_end().rsplit(' ').next().and_then(|n| n.parse().ok()).unwrap_or(u64::MAX)
    };
    let flooded = count(" dropped in a note flood");
    let dropped_events = stderr
        .lines()
        .filter_map(|l| l.split(" dropped events").next()?.rsplit(' ').next()?.parse::<u64>().ok())
        .max()
        .unwrap_or(0);
    println!("flood: {flooded} events dropped by the planner's window, {dropped_events} by the MIDI queue");
    assert!(flooded + dropped_events > 0, "the flood was not counted:\n{stderr}");
    let periods = count(" periods at 250 Hz");
    let lost = count(" behind (") + count(" dropped to catch up");
    assert!(lost * 100 <= periods, "the body fell behind in {lost} of {periods} periods: {body}");
    // The notes after the flood: each struck on its piece at its time + the lookahead.
    let piece = |note: u8| match note {
        38 => "snare",
        36 => "kick",
        45 => "tom2",
        _ => "tom1",
    };
    for &(t, note) in &after {
        let due = wall_of(at(t));
        let nearest = contacts
            .iter()
            .filter(|c| c.1 == piece(note))
            .map(|c| c.0 - due)
            .min_by(|a, b| a.abs().total_cmp(&b.abs()));
        assert!(
            nearest.is_some_and(|d| d.abs() <= 0.010),
            "the {} note at {t} s after the flood: nearest contact {:?} ms away",
            piece(note),
            nearest.map(|d| d * 1e3)
        );
    }
}

/// The stems are this process's own output: asking for them while the sound goes to a
/// sound server is refused before anything starts, naming both options.
#[test]
fn stems_with_the_sound_sent_elsewhere_are_refused_naming_both_options() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .args(["live", "--stems", "--sound-to", "udp://127.0.0.1:9", "--duration-s", "1"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--stems") && err.contains("--sound-to"), "{err}");
}
