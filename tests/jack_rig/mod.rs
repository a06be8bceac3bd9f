//! What the JACK end-to-end tests share: a private jackd, the drumsim binary with its stderr
//! read line by line, a test client that plays MIDI and records audio, and the onset finder.

use jack::{
    AudioIn, Client, ClientOptions, Control, MidiOut, NotificationHandler, Port, ProcessHandler, ProcessScope, RawMidi,
};
use std::io::{BufRead, BufReader};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::{Duration, Instant};

pub const RATE: u64 = 48_000;
pub const PERIOD: u64 = 256;

/// JACK_DEFAULT_SERVER is process-wide: the tests of this file take turns.
pub fn one_at_a_time() -> MutexGuard<'static, ()> {
    static TURN: Mutex<()> = Mutex::new(());
    TURN.lock().unwrap_or_else(|e| e.into_inner())
}

/// A private jackd, killed when dropped (also when the test panics).
pub struct JackServer {
    pub name: String,
    pub child: Child,
}

impl JackServer {
    pub fn start() -> JackServer {
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
pub struct Drumsim {
    pub child: Child,
    pub lines: Arc<Mutex<Vec<String>>>,
}

impl Drumsim {
    /// CPU seconds the process has used so far, all its threads (utime + stime of
    /// `/proc/PID/stat`; None where there is no /proc).
    pub fn cpu_s(&self) -> Option<f64> {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id())).ok()?;
        // Fields after the command's closing parenthesis: state is field 3, utime 14, stime 15.
        let rest = &stat[stat.rfind(')')? + 2..];
        let f: Vec<&str> = rest.split_whitespace().collect();
        let ticks = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
        // Clock ticks a second (100 on Linux; `getconf` says where it is not).
        let hz = Command::new("getconf")
            .arg("CLK_TCK")
            .output()
            .ok()
            .and_then(|o| String::from_utf8_lossy(&o.stdout).trim().parse::<f64>().ok())
            .unwrap_or(100.0);
        Some(ticks / hz.max(1.0))
    }

    pub fn live(server: &JackServer, args: &[&str]) -> Drumsim {
        Drumsim::start(server, args, Stdio::null())
    }

    /// `drumsim live ARGS` on `server`.
    pub fn start(server: &JackServer, args: &[&str], stdout: Stdio) -> Drumsim {
        Drumsim::command(server, "live", args, stdout)
    }

    /// `drumsim SUBCOMMAND ARGS` on `server`, its stderr collected line by line.
    pub fn command(server: &JackServer, subcommand: &str, args: &[&str], stdout: Stdio) -> Drumsim {
        let mut child = Command::new(env!("CARGO_BIN_EXE_drumsim"))
            .arg(subcommand)
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

    pub fn stderr(&self) -> String {
        self.lines.lock().unwrap().join("\n")
    }

    /// Wait until a line of stderr contains `text`.
    pub fn wait_for(&mut self, text: &str, timeout: Duration) {
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

    /// Ctrl-C: drumsim stops as it would at the end of `--duration-s`, printing its summary.
    pub fn interrupt(&mut self, timeout: Duration) -> std::process::ExitStatus {
        let _ = Command::new("kill").args(["-INT", &self.child.id().to_string()]).status();
        self.wait_exit(timeout)
    }

    pub fn wait_exit(&mut self, timeout: Duration) -> std::process::ExitStatus {
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
    pub fn live_with_page(server: &JackServer, args: &[&str]) -> (Drumsim, String) {
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

/// Plays `schedule` (frame, message) once armed, and records max(|left|, |right|) per frame,
/// and each further input (`player_with_tracks`) as it is.
pub struct Player {
    pub midi_out: Port<MidiOut>,
    inputs: [Port<AudioIn>; 2],
    track_inputs: Vec<Port<AudioIn>>,
    pub tracks: Vec<Vec<f32>>,
    armed: Arc<AtomicBool>,
    schedule: Vec<(u64, [u8; 3])>,
    next: usize,
    frame: u64,
    pub recorded: Vec<f32>,
    /// (first frame of a period, wall time as Unix seconds when its callback ran).
    pub clock: Vec<(u64, f64)>,
    progress: Arc<AtomicU64>,
}

impl ProcessHandler for Player {
    fn process(&mut self, _: &Client, ps: &ProcessScope) -> Control {
        let mut writer = self.midi_out.writer(ps);
        if !self.armed.load(Ordering::Acquire) {
            return Control::Continue;
        }
        let (start, n) = (self.frame, u64::from(ps.n_frames()));
        if self.clock.len() < self.clock.capacity() {
            let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
            self.clock.push((start, now.as_secs_f64()));
        }
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
        for (port, track) in self.track_inputs.iter().zip(self.tracks.iter_mut()) {
            let room = track.capacity() - track.len();
            let x = port.as_slice(ps);
            track.extend_from_slice(&x[..x.len().min(room)]);
        }
        self.frame += n;
        self.progress.store(self.frame, Ordering::Release);
        Control::Continue
    }
}

/// The wall times (Unix seconds) of the xruns JACK reported to the test client: a cycle on this
/// shared, non-realtime dummy server that some client did not finish in time.
#[derive(Default)]
pub struct Xruns(pub Vec<f64>);

impl NotificationHandler for Xruns {
    fn xrun(&mut self, _: &Client) -> Control {
        let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
        self.0.push(now.as_secs_f64());
        Control::Continue
    }
}

impl Player {
    /// The frame of the test client's clock at Unix time `t` (the period whose callback ran
    /// last before it), or None before the first armed period.
    pub fn frame_at(&self, t: f64) -> Option<u64> {
        self.clock.iter().take_while(|(_, w)| *w <= t).last().map(|(f, _)| *f)
    }
}

/// A test client with a MIDI output and two audio inputs, activated.
pub fn player(
    name: &str,
    schedule: Vec<(u64, [u8; 3])>,
    record_frames: usize,
) -> (jack::AsyncClient<Xruns, Player>, Arc<AtomicBool>, Arc<AtomicU64>) {
    player_with_tracks(name, schedule, record_frames, 0)
}

/// As `player`, with `tracks` more audio inputs (`in_3`, `in_4`, ...), each recorded alone.
pub fn player_with_tracks(
    name: &str,
    schedule: Vec<(u64, [u8; 3])>,
    record_frames: usize,
    tracks: usize,
) -> (jack::AsyncClient<Xruns, Player>, Arc<AtomicBool>, Arc<AtomicU64>) {
    let (client, _) = Client::new(name, ClientOptions::NO_START_SERVER).unwrap();
    let track_inputs =
        (0..tracks).map(|i| client.register_port(&format!("in_{}", i + 3), AudioIn::default()).unwrap()).collect();
    let midi_out = client.register_port("midi_out", MidiOut::default()).unwrap();
    let inputs = [
        client.register_port("in_l", AudioIn::default()).unwrap(),
        client.register_port("in_r", AudioIn::default()).unwrap(),
    ];
    let (armed, progress) = (Arc::new(AtomicBool::new(false)), Arc::new(AtomicU64::new(0)));
    let p = Player {
        midi_out,
        inputs,
        track_inputs,
        tracks: (0..tracks).map(|_| Vec::with_capacity(record_frames)).collect(),
        armed: armed.clone(),
        schedule,
        next: 0,
        frame: 0,
        recorded: Vec::with_capacity(record_frames),
        clock: Vec::with_capacity(record_frames / PERIOD as usize + 16),
        progress: progress.clone(),
    };
    (client.activate_async(Xruns::default(), p).unwrap(), armed, progress)
}

/// (note, velocity): every kind of piece, loud after long-ringing cymbals.
pub const NOTES: [(u8, u8); 20] = [
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
pub const FIRST_NOTE: u64 = RATE / 2;
pub const SPACING: u64 = RATE / 4;

pub fn note_frames() -> Vec<u64> {
    // Offsets spread the notes over the positions inside a period.
    (0..NOTES.len() as u64).map(|i| FIRST_NOTE + i * SPACING + (i * 97) % PERIOD).collect()
}

/// First frame in `from..to` whose short-window energy is twice (3 dB above) the loudest window
/// of the 30 ms before `from` (previous notes still ring), or None. The energy is of the
/// signal's first difference (a pre-emphasis, +6 dB an octave): a tom's low partials still
/// ringing 250 ms after a hard hit held a closed hi-hat's onset to +2.5 dB over them in
/// plain energy, where the ear hears the hat at once.
pub fn onset(x: &[f32], from: usize, to: usize) -> Option<usize> {
    const W: usize = 64;
    let d = |n: usize| if n == 0 { x[0] } else { x[n] - x[n - 1] };
    let energy = |end: usize| (end.saturating_sub(W)..end).map(|n| d(n) * d(n)).sum::<f32>();
    let before = (from.saturating_sub(RATE as usize * 30 / 1000)..=from).map(energy).fold(0.0, f32::max);
    let floor = W as f32 * 1e-3 * 1e-3;
    let threshold = 2.0 * before + floor;
    let end = (from + 1..to.min(x.len())).find(|&end| energy(end) > threshold)?;
    // The window holds at least one sample above the window's mean threshold: the first is the onset.
    (end.saturating_sub(W).max(from)..end).find(|&n| d(n) * d(n) > threshold / W as f32).or(Some(end - 1))
}

pub fn save_wav(path: &std::path::Path, x: &[f32]) {
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
