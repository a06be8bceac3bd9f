//! `drumsim live` end to end against a real JACK server (dummy driver, 48 kHz, 256 frames).
//!
//! Each test starts its own `jackd` under a unique server name, plays MIDI into the real
//! binary from a JACK client of its own and records what comes out. Needs the `jack`
//! feature, libjack and `jackd` in PATH (Debian: jackd2, libjack-jackd2-dev):
//!
//! ```text
//! cargo test --features jack --test live_jack -- --nocapture
//! ```
#![cfg(feature = "jack")]

#[allow(dead_code)]
mod browser;
#[allow(dead_code)]
mod vmc_receiver;

use jack::{AudioIn, Client, ClientOptions, Control, MidiOut, Port, PortFlags, ProcessHandler, ProcessScope, RawMidi};
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

const RATE: u64 = 48_000;
const PERIOD: u64 = 256;

/// JACK_DEFAULT_SERVER is process-wide: the tests of this file take turns.
fn one_at_a_time() -> MutexGuard<'static, ()> {
    static TURN: Mutex<()> = Mutex::new(());
    TURN.lock().unwrap_or_else(|e| e.into_inner())
}

/// A private jackd, killed when dropped (also when the test panics).
struct JackServer {
    name: String,
    child: Child,
}

impl JackServer {
    fn start() -> JackServer {
        static COUNT: AtomicUsize = AtomicUsize::new(0);
        let name = format!("drumsim-test-{}-{}", std::process::id(), COUNT.fetch_add(1, Ordering::Relaxed));
        let log_path = format!("{}/{name}.log", env!("CARGO_TARGET_TMPDIR"));
        let log = std::fs::File::create(&log_path).unwrap();
        let child = Command::new("jackd")
            .args(["-n", &name, "--no-realtime", "-d", "dummy", "-r", &RATE.to_string(), "-p", &PERIOD.to_string()])
            .stdout(log.try_clone().unwrap())
            .stderr(log)
            .spawn()
            .expect("jackd must be in PATH (Debian: apt-get install jackd2)");
        // SAFETY of set_var: the tests of this file hold `one_at_a_time`, no other thread reads it.
        std::env::set_var("JACK_DEFAULT_SERVER", &name);
        let mut server = JackServer { name, child };
        let start = Instant::now();
        while Client::new("probe", ClientOptions::NO_START_SERVER).is_err() {
            if server.child.try_wait().unwrap().is_some() {
                let log = std::fs::read_to_string(&log_path).unwrap_or_default();
                let hint = if log.contains("Too many servers") {
                    "\nJACK's server registry is full of servers that were killed outright; with no jackd \
                     running, remove /dev/shm/jack-shm-registry and /dev/shm/jack_*"
                } else {
                    ""
                };
                panic!("jackd {} exited:\n{log}{hint}", server.name);
            }
            assert!(start.elapsed() < Duration::from_secs(15), "jackd {} does not accept clients", server.name);
            thread::sleep(Duration::from_millis(50));
        }
        server
    }
}

impl Drop for JackServer {
    /// SIGTERM first: a jackd that is killed outright keeps its slot in JACK's server registry
    /// (/dev/shm/jack-shm-registry, 8 slots), and a later jackd then fails with "Too many
    /// servers already active".
    fn drop(&mut self) {
        let _ = Command::new("kill").args(["-TERM", &self.child.id().to_string()]).status();
        let start = Instant::now();
        while self.child.try_wait().ok().flatten().is_none() && start.elapsed() < Duration::from_secs(5) {
            thread::sleep(Duration::from_millis(20));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The drumsim binary, its stderr collected line by line; killed when dropped.
struct Drumsim {
    child: Child,
    lines: Arc<Mutex<Vec<String>>>,
}

impl Drumsim {
    fn live(server: &JackServer, args: &[&str]) -> Drumsim {
        Drumsim::start(server, args, Stdio::null())
    }

    /// `drumsim live ARGS` on `server`, its stderr collected line by line.
    fn start(server: &JackServer, args: &[&str], stdout: Stdio) -> Drumsim {
        let mut child = Command::new(env!("CARGO_BIN_EXE_drumsim"))
            .arg("live")
            .args(args)
            .env("JACK_DEFAULT_SERVER", &server.name)
            .stdout(stdout)
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let lines = Arc::new(Mutex::new(Vec::new()));
        let (stderr, sink) = (child.stderr.take().unwrap(), lines.clone());
        thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                eprintln!("  [drumsim] {line}");
                sink.lock().unwrap().push(line);
            }
        });
        Drumsim { child, lines }
    }

    fn stderr(&self) -> String {
        self.lines.lock().unwrap().join("\n")
    }

    /// Wait until a line of stderr contains `text`.
    fn wait_for(&mut self, text: &str, timeout: Duration) {
        let start = Instant::now();
        while !self.lines.lock().unwrap().iter().any(|l| l.contains(text)) {
            if let Some(status) = self.child.try_wait().unwrap() {
                thread::sleep(Duration::from_millis(100)); // let the reader catch the last lines
                panic!("drumsim exited ({status}) before printing {text:?}:\n{}", self.stderr());
            }
            assert!(start.elapsed() < timeout, "no {text:?} from drumsim within {timeout:?}:\n{}", self.stderr());
            thread::sleep(Duration::from_millis(20));
        }
    }

    fn wait_exit(&mut self, timeout: Duration) -> std::process::ExitStatus {
        let start = Instant::now();
        loop {
            if let Some(status) = self.child.try_wait().unwrap() {
                thread::sleep(Duration::from_millis(100));
                return status;
            }
            assert!(start.elapsed() < timeout, "drumsim still running after {timeout:?}:\n{}", self.stderr());
            thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drumsim {
    /// `drumsim live` with the page: its stdout is read for the page's address.
    fn live_with_page(server: &JackServer, args: &[&str]) -> (Drumsim, String) {
        let mut drumsim = Drumsim::start(server, args, Stdio::piped());
        let (tx, rx) = std::sync::mpsc::channel();
        let stdout = drumsim.child.stdout.take().unwrap();
        thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if let Some(url) = line.split_whitespace().find(|w| w.starts_with("http://")) {
                    let _ = tx.send(url.to_string());
                }
            }
        });
        let url = rx.recv_timeout(Duration::from_secs(30)).unwrap_or_else(|_| {
            let _ = drumsim.child.kill();
            panic!("drumsim live printed no page address:\n{}", drumsim.stderr())
        });
        (drumsim, url)
    }
}

impl Drop for Drumsim {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Plays `schedule` (frame, message) once armed, and records max(|left|, |right|) per frame.
struct Player {
    midi_out: Port<MidiOut>,
    inputs: [Port<AudioIn>; 2],
    armed: Arc<AtomicBool>,
    schedule: Vec<(u64, [u8; 3])>,
    next: usize,
    frame: u64,
    recorded: Vec<f32>,
    progress: Arc<AtomicU64>,
}

impl ProcessHandler for Player {
    fn process(&mut self, _: &Client, ps: &ProcessScope) -> Control {
        let mut writer = self.midi_out.writer(ps);
        if !self.armed.load(Ordering::Acquire) {
            return Control::Continue;
        }
        let (start, n) = (self.frame, u64::from(ps.n_frames()));
        while let Some((t, bytes)) = self.schedule.get(self.next).filter(|(t, _)| *t < start + n) {
            let _ = writer.write(&RawMidi { time: t.saturating_sub(start) as u32, bytes });
            self.next += 1;
        }
        let [left, right] = &self.inputs;
        for (l, r) in left.as_slice(ps).iter().zip(right.as_slice(ps)) {
            if self.recorded.len() < self.recorded.capacity() {
                self.recorded.push(l.abs().max(r.abs()));
            }
        }
        self.frame += n;
        self.progress.store(self.frame, Ordering::Release);
        Control::Continue
    }
}

/// A test client with a MIDI output and two audio inputs, activated.
fn player(
    name: &str,
    schedule: Vec<(u64, [u8; 3])>,
    record_frames: usize,
) -> (jack::AsyncClient<(), Player>, Arc<AtomicBool>, Arc<AtomicU64>) {
    let (client, _) = Client::new(name, ClientOptions::NO_START_SERVER).unwrap();
    let midi_out = client.register_port("midi_out", MidiOut::default()).unwrap();
    let inputs = [
        client.register_port("in_l", AudioIn::default()).unwrap(),
        client.register_port("in_r", AudioIn::default()).unwrap(),
    ];
    let (armed, progress) = (Arc::new(AtomicBool::new(false)), Arc::new(AtomicU64::new(0)));
    let p = Player {
        midi_out,
        inputs,
        armed: armed.clone(),
        schedule,
        next: 0,
        frame: 0,
        recorded: Vec::with_capacity(record_frames),
        progress: progress.clone(),
    };
    (client.activate_async((), p).unwrap(), armed, progress)
}

/// (note, velocity): every kind of piece, loud after long-ringing cymbals.
const NOTES: [(u8, u8); 20] = [
    (36, 110),
    (42, 70),
    (38, 100),
    (42, 60),
    (36, 120),
    (45, 90),
    (48, 95),
    (38, 127),
    (42, 80),
    (36, 100),
    (51, 70),
    (38, 120),
    (36, 127),
    (45, 110),
    (48, 120),
    (42, 90),
    (38, 90),
    (36, 110),
    (38, 127),
    (49, 127),
];
const FIRST_NOTE: u64 = RATE / 2;
const SPACING: u64 = RATE / 4;

fn note_frames() -> Vec<u64> {
    // Offsets spread the notes over the positions inside a period.
    (0..NOTES.len() as u64).map(|i| FIRST_NOTE + i * SPACING + (i * 97) % PERIOD).collect()
}

/// First frame in `from..to` whose short-window energy is twice (3 dB above) the loudest window
/// of the 30 ms before `from` (previous notes still ring), or None.
fn onset(x: &[f32], from: usize, to: usize) -> Option<usize> {
    const W: usize = 64;
    let energy = |end: usize| x[end.saturating_sub(W)..end].iter().map(|v| v * v).sum::<f32>();
    let before = (from.saturating_sub(RATE as usize * 30 / 1000)..=from).map(energy).fold(0.0, f32::max);
    let floor = W as f32 * 1e-3 * 1e-3;
    let threshold = 2.0 * before + floor;
    let end = (from + 1..to.min(x.len())).find(|&end| energy(end) > threshold)?;
    // The window holds at least one sample above the window's mean threshold: the first is the onset.
    (end.saturating_sub(W).max(from)..end).find(|&n| x[n] * x[n] > threshold / W as f32).or(Some(end - 1))
}

fn save_wav(path: &std::path::Path, x: &[f32]) {
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate: RATE as u32,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut w = hound::WavWriter::create(path, spec).unwrap();
    x.iter().for_each(|&s| w.write_sample(s).unwrap());
    w.finalize().unwrap();
}

#[test]
fn every_note_sounds_within_two_periods() {
    let _turn = one_at_a_time();
    let server = JackServer::start();
    let frames = note_frames();
    let mut schedule = Vec::new();
    for (&(note, velocity), &t) in NOTES.iter().zip(&frames) {
        schedule.push((t, [0x99, note, velocity]));
        schedule.push((t + RATE / 20, [0x99, note, 0])); // note-off as e-kits send it
    }
    schedule.sort_by_key(|(t, _)| *t);
    let total = frames.last().unwrap() + RATE;
    let (client, armed, progress) = player("drumsim-test", schedule, total as usize);

    let mut drumsim = Drumsim::live(
        &server,
        &["--midi", "drumsim-test:midi_out", "--audio", "jack", "--map", "gm", "--duration-s", "12"],
    );
    drumsim.wait_for("drumsim live: MIDI", Duration::from_secs(20));
    let pattern = format!("cpal_client_{}_out:", drumsim.child.id());
    let outs = client.as_client().ports(Some(&pattern), Some("32 bit float mono audio"), PortFlags::IS_OUTPUT);
    assert!(outs.len() >= 2, "drumsim's audio ports ({pattern}*): {outs:?}");
    for (out, input) in outs.iter().zip(["drumsim-test:in_l", "drumsim-test:in_r"]) {
        client.as_client().connect_ports_by_name(out, input).unwrap();
    }
    armed.store(true, Ordering::Release);
    let start = Instant::now();
    while progress.load(Ordering::Acquire) < total {
        assert!(start.elapsed() < Duration::from_secs(30), "JACK is not running the test client");
        thread::sleep(Duration::from_millis(50));
    }
    let (_, _, player) = client.deactivate().unwrap();
    let status = drumsim.wait_exit(Duration::from_secs(20));
    assert!(status.success(), "drumsim live failed ({status}):\n{}", drumsim.stderr());
    assert!(drumsim.stderr().contains(&format!("{} MIDI events", 2 * NOTES.len())), "{}", drumsim.stderr());

    let x = &player.recorded;
    if let Some(path) = std::env::var_os("DRUMSIM_LIVE_WAV") {
        save_wav(path.as_ref(), x); // what the test heard, to look at when it fails
    }
    assert!(onset(x, 0, FIRST_NOTE as usize).is_none(), "sound before the first note");
    let mut latencies_ms = Vec::new();
    let mut per_note = String::new();
    let ms = |frames: usize| frames * RATE as usize / 1000;
    for (i, &t) in frames.iter().enumerate() {
        let (t, next) = (t as usize, frames.get(i + 1).copied().unwrap_or(total) as usize);
        // The detector must not fire on ringing alone, or a missing note would pass unseen.
        assert_eq!(onset(x, t + ms(100), t + ms(150)), None, "onset in the tail of note {i} ({:?})", NOTES[i]);
        let Some(at) = onset(x, t, next.min(t + ms(50))) else {
            panic!("note {i} ({:?}) at frame {t} made no sound within 50 ms", NOTES[i]);
        };
        let latency_ms = (at - t) as f64 * 1000.0 / RATE as f64;
        per_note += &format!(" {}:{latency_ms:.1}", NOTES[i].0);
        latencies_ms.push(latency_ms);
    }
    latencies_ms.sort_by(f64::total_cmp);
    let mean = latencies_ms.iter().sum::<f64>() / latencies_ms.len() as f64;
    let (median, max) = (latencies_ms[latencies_ms.len() / 2], *latencies_ms.last().unwrap());
    println!(
        "MIDI-to-sound latency over {} notes: mean {mean:.2} ms, median {median:.2} ms, max {max:.2} ms",
        NOTES.len()
    );
    println!("per note (note:ms):{per_note}");
    // A note reaches drumsim in the period it was sent and starts sounding in the next one,
    // after the engine's limiter look-ahead (1.5 ms): at most 5.3 + 1.5 ms for a cymbal, plus
    // a few ms of attack for a drum head. Half the notes within two periods; all within 40 ms
    // even on a loaded machine that misses a cycle or two.
    assert!(median < 2.0 * 1000.0 * PERIOD as f64 / RATE as f64 + 1.5, "latencies (ms): {latencies_ms:?}");
    assert!(max < 40.0, "latencies (ms): {latencies_ms:?}");
}

#[test]
fn devices_lists_the_port_and_a_vanished_port_is_reported_and_reconnected() {
    let _turn = one_at_a_time();
    let server = JackServer::start();
    let note = vec![(RATE / 10, [0x99, 38, 100])];
    let (client, _, _) = player("drumsim-src", note.clone(), 0);
    let devices = Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .arg("devices")
        .env("JACK_DEFAULT_SERVER", &server.name)
        .output()
        .unwrap();
    let listing = String::from_utf8_lossy(&devices.stdout);
    assert!(devices.status.success() && listing.contains("  drumsim-src:midi_out\n"), "drumsim devices:\n{listing}");
    assert!(listing.contains("JACK: JACK Output [jack:output]  (default)"), "drumsim devices:\n{listing}");
    let mut drumsim = Drumsim::live(&server, &["--midi", "drumsim-src:midi", "--map", "gm", "--duration-s", "8"]);
    drumsim.wait_for("drumsim live: MIDI", Duration::from_secs(20));

    drop(client.deactivate().unwrap()); // the source closes: its port is gone
    drumsim.wait_for("disappeared", Duration::from_secs(5));
    assert!(drumsim.child.try_wait().unwrap().is_none(), "drumsim must keep running:\n{}", drumsim.stderr());

    let (client, armed, _) = player("drumsim-src", note, 0);
    drumsim.wait_for("reconnected", Duration::from_secs(5));
    armed.store(true, Ordering::Release); // one note through the new connection
    let status = drumsim.wait_exit(Duration::from_secs(20));
    drop(client);
    assert!(status.success(), "drumsim live failed ({status}):\n{}", drumsim.stderr());
    assert!(drumsim.stderr().contains(" 1 MIDI events"), "the note after reconnecting:\n{}", drumsim.stderr());
}

/// The avatar's lookahead in the test, s.
const LOOKAHEAD_S: f64 = 0.25;

#[test]
fn the_live_avatar_strikes_each_note_lookahead_after_it_was_played() {
    let _turn = one_at_a_time();
    let Some(chrome) = browser::chromium() else {
        assert!(
            std::env::var_os("DRUMSIM_REQUIRE_BROWSER").is_none(),
            "DRUMSIM_REQUIRE_BROWSER is set but no chromium"
        );
        println!("no chromium on this machine (scripts/setup-debian.sh installs it): skipping");
        return;
    };
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("live-avatar");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let server = JackServer::start();
    // Hand notes on the snare, two toms and the hi-hat, a kick between some, 0.4 s apart.
    let hands = [(38u8, 100u8), (48, 90), (38, 70), (45, 110), (42, 80), (38, 120)];
    let mut schedule = Vec::new();
    let mut played = Vec::new();
    for i in 0..24u64 {
        let t = RATE + i * RATE * 2 / 5;
        let (note, velocity) = hands[i as usize % hands.len()];
        schedule.push((t, [0x99, note, velocity]));
        schedule.push((t + RATE / 20, [0x99, note, 0]));
        played.push(note);
        if i % 4 == 2 {
            schedule.push((t + RATE / 5, [0x99, 36, 100]));
            schedule.push((t + RATE / 5 + RATE / 20, [0x99, 36, 0]));
            played.push(36);
        }
    }
    schedule.sort_by_key(|(t, _)| *t);
    let total = schedule.last().unwrap().0 + RATE;
    let (client, armed, progress) = player("drumsim-avatar", schedule, 0);
    let receiver = vmc_receiver::python_osc().map(|python| {
        let out = dir.join("vmc.json");
        let (child, port) = vmc_receiver::start_receiver(&python, &out);
        (child, port, out)
    });
    let vmc_target = receiver.as_ref().map(|(_, port, _)| format!("127.0.0.1:{port}"));
    let mut args = vec!["--midi", "drumsim-avatar:midi_out", "--audio", "jack", "--map", "gm", "--duration-s", "30"];
    args.extend(["--view", "--lookahead-ms", "250"]);
    if let Some(t) = &vmc_target {
        args.extend(["--vmc", t.as_str()]);
    }
    let (mut drumsim, url) = Drumsim::live_with_page(&server, &args);
    drumsim.wait_for("drumsim live: MIDI", Duration::from_secs(20));
    let mut b = browser::Browser::launch(&chrome, 640, 360);
    b.navigate(&url);
    assert!(
        b.wait_for(
            "!!(window.drumsim && ((drumsim.ready && drumsim.live.received > 30) || drumsim.errors.length))",
            Duration::from_secs(90)
        ),
        "the live page did not start"
    );
    assert_eq!(b.eval("drumsim.errors"), serde_json::json!([]), "the live page failed");
    // A page that goes and comes back (a reload) is fed again.
    b.navigate(&url);
    assert!(
        b.wait_for("!!(window.drumsim && drumsim.ready && drumsim.live.received > 30)", Duration::from_secs(90)),
        "the reloaded page is not fed"
    );
    armed.store(true, Ordering::Release);
    // The drummer is on the page while it plays: the picture changes where it is hidden.
    thread::sleep(Duration::from_secs(3));
    let with = b.screenshot(Some(&dir.join("live.png")));
    b.eval("drumsim.setVisible('drummer', false)");
    let without = b.screenshot(None);
    b.eval("drumsim.setVisible('drummer', true)");
    let drummer_px = with.differing(&without, (0, 0, 640, 360), 40);
    println!("the drummer covers {drummer_px} pixels of the live page");
    assert!(drummer_px > 5_000, "the drummer covers only {drummer_px} pixels");
    let start = Instant::now();
    while progress.load(Ordering::Acquire) < total {
        assert!(start.elapsed() < Duration::from_secs(40), "JACK is not running the test client");
        thread::sleep(Duration::from_millis(50));
    }
    let log = b.eval("drumsim.live.log");
    let arrivals: Vec<f64> =
        b.eval("drumsim.live.arrivals").as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect();
    b.drain_events();
    assert_eq!(b.eval("drumsim.errors"), serde_json::json!([]), "the live page logged errors");
    drop(b);
    drop(client.deactivate().unwrap());
    let _ = drumsim.child.kill();
    let _ = drumsim.child.wait();

    // 60 frames a second reach the page: over the last 10 s of arrivals.
    let last = *arrivals.last().unwrap();
    let in_window = arrivals.iter().filter(|&&a| a > last - 10_000.0).count();
    println!("the page received {in_window} frames in 10 s");
    assert!(in_window >= 590, "{in_window} frames in 10 s");

    // Every note is struck once, LOOKAHEAD_S after it was played, within one frame, with a
    // stick tip on the piece's surface (the kick by its beater).
    let kit = drumsim::kit::Kit::builtin_default();
    let frames = log.as_array().unwrap();
    let mut strikes = Vec::new();
    for f in frames {
        for s in f["strikes"].as_array().unwrap() {
            strikes.push((
                s["piece"].as_str().unwrap().to_string(),
                s["at"].as_f64().unwrap(),
                f["t"].as_f64().unwrap(),
            ));
        }
    }
    assert_eq!(strikes.len(), played.len(), "strikes shown {strikes:?}");
    let (mut worst_late, mut worst_tip, mut worst_offset) = (0.0f64, 0.0f64, 0.0f64);
    for (piece, at, t) in &strikes {
        let late = t - at - LOOKAHEAD_S;
        assert!((-0.001..=1.0 / 60.0 + 0.003).contains(&late), "{piece} played at {at:.3} s struck at {t:.3} s");
        worst_late = worst_late.max(late);
        if piece == "kick" {
            continue;
        }
        let p = kit.piece(piece).unwrap();
        let (c, n) = (nalgebra::Vector3::from(p.position_m), nalgebra::Vector3::from(p.normal).normalize());
        // The nearer tip's height over the surface in the frames around the strike: its
        // lowest lies within a frame of the note's time.
        let gap = |f: &serde_json::Value| {
            f["tips"]
                .as_array()
                .unwrap()
                .iter()
                .map(|tip| {
                    let v: Vec<f32> = tip.as_array().unwrap().iter().map(|x| x.as_f64().unwrap() as f32).collect();
                    let d = nalgebra::Vector3::new(v[0], v[1], v[2]) - c;
                    let along = d.dot(&n);
                    let across = (d - n * along).norm();
                    if across <= p.radius_m {
                        along.abs() as f64
                    } else {
                        f64::INFINITY
                    }
                })
                .fold(f64::INFINITY, f64::min)
        };
        let (tip_gap, lowest_s) = frames
            .iter()
            .filter(|f| (f["s"].as_f64().unwrap() - at).abs() <= 3.0 / 60.0)
            .map(|f| (gap(f), f["s"].as_f64().unwrap()))
            .fold((f64::INFINITY, 0.0), |a, b| if b.0 < a.0 { b } else { a });
        // At 60 frames a second the frame nearest a stroke's contact can be 8 ms from it: 40
        // mm over the surface for a 5 m/s stroke.
        assert!(
            (lowest_s - at).abs() <= 1.0 / 60.0 + 1e-3 && tip_gap <= 0.04,
            "{piece} at {at:.3} s: the tips come lowest ({:.1} mm over it) {:+.1} ms from the note",
            tip_gap * 1e3,
            (lowest_s - at) * 1e3
        );
        worst_offset = worst_offset.max((lowest_s - at).abs());
        worst_tip = worst_tip.max(tip_gap);
    }
    println!(
        "{} notes struck {:.0} ms after they were played, at most {:.1} ms later; the tips lowest within {:.1} ms of each note, {:.1} mm over the surface at most",
        strikes.len(),
        LOOKAHEAD_S * 1e3,
        worst_late * 1e3,
        worst_offset * 1e3,
        worst_tip * 1e3
    );

    // The same session to a VMC receiver: 60 frames a second, every bone and blendshape.
    if let Some((child, _, out)) = receiver {
        let got = vmc_receiver::finish_receiver(child, &out);
        let n = got.frames.len();
        let span = got.frames[n - 1]["arrival_s"].as_f64().unwrap() - got.frames[0]["arrival_s"].as_f64().unwrap();
        let rate = (n - 1) as f64 / span;
        println!("VMC: {n} frames over {span:.1} s, {rate:.2} a second");
        assert!(span > 10.0 && rate >= 59.0, "{n} VMC frames over {span:.1} s");
        for f in &got.frames {
            assert_eq!(f["bones"].as_object().unwrap().len(), 55);
            assert_eq!(f["blend"].as_object().unwrap().len(), 52);
            assert_eq!(f["ok"].as_i64(), Some(1));
        }
    }
}
