//! `drumsim sound --listen udp://HOST:PORT`: the sound half alone, a server for contact,
//! hi-hat and choke messages from another process (`live --sound-to`, `render --sound-to`,
//! or any OSC sender). Thread wiring only:
//!
//! ```text
//! UDP socket    receive                             (interaction::transport::UdpReceiver)
//! feed          copies, decode, time tags, counts   (sound::net_feed::NetFeed)
//!   -> rtrb ring of TimedEvent (fixed capacity)
//! audio callback   place, Engine::process, out      (sound::output::Renderer)
//! main          status, counts every few seconds, --duration-s
//! ```

use crate::interaction::transport::UdpReceiver;
use crate::kit::Kit;
use crate::live::LiveInputError;
use crate::sound::device::{self, AudioOutput};
use crate::sound::net_feed::{NetCounts, NetFeed};
use crate::sound::output::{EventFeed, OutputSettings, PerformanceClock};
use anyhow::Context;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering::Relaxed};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

/// Options of `drumsim sound`.
#[derive(Debug, Clone)]
pub struct ServerOptions {
    pub listen: SocketAddr,
    pub audio_device: Option<String>,
    /// The kit whose pieces the messages name; None: the built-in default.
    pub kit: Option<PathBuf>,
    /// Untimed messages sound this long after they arrive.
    pub latency_ms: f32,
    /// Each kit piece on its own output channel after the mix (`--stems`).
    pub stems: bool,
    pub duration_s: Option<f64>,
}

const SOUND_RING: usize = 4096;
/// How often the counts are shown when they changed.
const REPORT_EVERY: Duration = Duration::from_secs(2);

pub fn run(opts: &ServerOptions) -> anyhow::Result<()> {
    if !(0.0..=1000.0).contains(&opts.latency_ms) {
        return Err(LiveInputError::Lookahead(opts.latency_ms).into());
    }
    if let Some(d) = opts.duration_s.filter(|d| !(d.is_finite() && *d > 0.0)) {
        return Err(LiveInputError::Duration(d).into());
    }
    let kit = match &opts.kit {
        Some(path) => Kit::load(path)?,
        None => Kit::builtin_default(),
    };
    let mut socket = UdpReceiver::bind(opts.listen).with_context(|| format!("listening on udp://{}", opts.listen))?;
    let listening = socket.local_addr()?;
    let device = device::find_output(opts.audio_device.as_deref()).map_err(|available| match &opts.audio_device {
        Some(wanted) => anyhow::Error::new(LiveInputError::NoSuchAudioDevice { wanted: wanted.clone(), available }),
        None => anyhow::anyhow!("no default audio output (is JACK or a sound card there?); choose one with --audio"),
    })?;
    let (ring_tx, ring_rx) = rtrb::RingBuffer::new(SOUND_RING);
    let audio =
        AudioOutput::start(&device, &kit, &OutputSettings { stems: opts.stems, ..Default::default() }, ring_rx)?;
    if opts.stems {
        eprintln!("drumsim sound: {}", device::stem_channels(&kit));
    }
    let feed = EventFeed::new(kit.clone(), audio.sample_rate_hz as f32, PerformanceClock::Estimated(None), ring_tx)
        .with_stats(audio.stats.clone());
    let net = NetFeed::new(feed, Duration::from_secs_f32(opts.latency_ms / 1000.0));
    let counts = net.counts.clone();
    let stop = Arc::new(AtomicBool::new(false));
    let s = stop.clone();
    let feeder = thread::Builder::new()
        .name("drumsim-net-feed".into())
        .stack_size(8 << 20)
        .spawn(move || net.run(&mut socket, &s))?;
    eprintln!(
        "drumsim sound: listening on udp://{listening} -> {}, {} Hz, kit {}; untimed messages sound {} ms after \
         they arrive, time-tagged ones at their tag",
        audio.label, audio.sample_rate_hz, kit.name, opts.latency_ms
    );
    // Ctrl-C and SIGTERM stop the server as --duration-s does: its last counts are shown and
    // its audio client closes cleanly (JACK keeps no trace of it); then exit code 130.
    crate::outputs::stop_gracefully_on_interrupt();
    let start = Instant::now();
    let result = supervise(&audio, &counts, opts.duration_s);
    stop.store(true, Relaxed);
    feeder.join().map_err(|_| anyhow::anyhow!("the feed thread panicked"))?.context("receiving messages")?;
    eprintln!("drumsim sound: stopped after {:.1} s: {}", start.elapsed().as_secs_f64(), report(&counts, &audio));
    drop(audio);
    if crate::outputs::interrupted() {
        std::process::exit(crate::outputs::INTERRUPTED_EXIT);
    }
    result
}

fn report(counts: &NetCounts, audio: &AudioOutput) -> String {
    let s = &audio.stats;
    format!(
        "{}, {} bad, {} dropped, {} xruns, audio clock re-locked {} times and stepped {}",
        counts.report(),
        s.bad_messages.load(Relaxed),
        s.dropped_events.load(Relaxed),
        s.xruns.load(Relaxed),
        s.clock_relocks.load(Relaxed),
        s.clock_steps.load(Relaxed)
    )
}

/// Until `duration_s` or an interruption: show the counts when they change, stop if the
/// audio output fails.
fn supervise(audio: &AudioOutput, counts: &NetCounts, duration_s: Option<f64>) -> anyhow::Result<()> {
    let start = Instant::now();
    let deadline = duration_s.map(|d| start + Duration::from_secs_f64(d));
    let mut next_report = start + REPORT_EVERY;
    let mut shown = String::new();
    loop {
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) || crate::outputs::interrupted() {
            return Ok(());
        }
        thread::sleep(Duration::from_millis(50));
        if let Some(e) = audio.error() {
            anyhow::bail!("audio output {} stopped: {e}", audio.label);
        }
        if now >= next_report {
            next_report += REPORT_EVERY;
            let line = report(counts, audio);
            if line != shown {
                eprintln!("drumsim sound: {line}");
                shown = line;
            }
        }
    }
}
