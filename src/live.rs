//! Real-time pipeline: live MIDI in -> contact messages -> sound engine -> audio out.
//! Thread wiring only; each stage lives with its data:
//!
//! ```text
//! midir callback   parse, stamp arrival           (midi::live::EventSink)
//!   -> crossbeam bounded channel of LiveEvent
//! interaction      Director, OSC encode           (interaction::direct, message)
//!   -> transport: in-process channel of packets   (interaction::transport; UDP alike)
//! feed             OSC decode, resolve pieces     (sound::output::EventFeed)
//!   -> rtrb ring of TimedEvent (fixed capacity)
//! audio callback   place, Engine::process, out    (sound::output::Renderer)
//! main             status, port watch, counters, --duration-s
//!
//! with --view / --vmc, the interaction thread also try_sends each event to the avatar:
//! avatar planner   the motion stage on the newest notes, every 50 ms   (avatar, motion::window)
//! avatar poser     60 Hz: pose at now - lookahead -> page WebSocket, VMC (avatar, view::live, vmc)
//! ```
//! A MIDI port that disappears (its JACK client closed, the USB cable pulled) does not stop
//! the session: it is reported, and reconnected by name as soon as a port of that name is
//! back (checked every second).

use crate::interaction::direct::Director;
use crate::interaction::transport::{self, PacketSender, TransportError};
use crate::interaction::{encode, Message};
use crate::kit::Kit;
use crate::midi::live::{self as midi_live, EventSink, InputStats, LiveEvent, LiveInput, MessageParser, PortMatch};
use crate::midi::NoteMap;
use crate::sound::device::{self, AudioOutput};
use crate::sound::output::{EventFeed, OutputSettings, OutputStats, PerformanceClock};
use anyhow::Context;
use crossbeam_channel::Receiver;
use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

/// Options of `drumsim live`.
#[derive(Debug, Clone)]
pub struct LiveOptions {
    /// MIDI input port name (or a unique part of it); None: the first port.
    pub midi_port: Option<String>,
    /// Audio output device name (or part of it); None: the host's default.
    pub audio_device: Option<String>,
    /// Delay every event by this much so timing is jitter-free (0: as soon as possible).
    pub lookahead_ms: f32,
    /// Kit config file; None: the built-in default kit.
    pub kit: Option<PathBuf>,
    /// Note map name or file.
    pub map: String,
    /// Drum channel 1..=16; None: the map's channel.
    pub channel: Option<u8>,
    /// Stop after this many seconds (None: until Ctrl-C or end of input).
    pub duration_s: Option<f64>,
    /// Show the drummer (the live page, VMC); its lookahead is the avatar's, the sound stays
    /// immediate.
    pub avatar: Option<crate::avatar::AvatarOptions>,
}

/// Bad `live` options or names (exit code 2).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LiveInputError {
    #[error("no MIDI input port matches {wanted:?}; available: {}", list(available))]
    NoSuchMidiPort { wanted: String, available: Vec<String> },
    #[error("MIDI input {wanted:?} is ambiguous, it matches: {}; give more of the name", list(matches))]
    AmbiguousMidiPort { wanted: String, matches: Vec<String> },
    #[error("there are no {backend} MIDI input ports; connect a device (see `drumsim devices`)")]
    NoMidiPorts { backend: &'static str },
    #[error("no audio output device matches {wanted:?}; available: {}", list(available))]
    NoSuchAudioDevice { wanted: String, available: Vec<String> },
    #[error("--channel {0} is out of range 1..=16")]
    Channel(u8),
    #[error("--lookahead-ms {0} is out of range 0..=1000")]
    Lookahead(f32),
    #[error("--duration-s {0} must be a positive number of seconds")]
    Duration(f64),
}

fn list(names: &[String]) -> String {
    if names.is_empty() {
        "none".into()
    } else {
        names.iter().map(|n| format!("{n:?}")).collect::<Vec<_>>().join(", ")
    }
}

/// Capacities of the queues between the threads (events, not bytes).
const MIDI_QUEUE: usize = 1024;
const PACKET_QUEUE: usize = 1024;
const SOUND_RING: usize = 1024;
/// How often the main thread looks at the MIDI port.
const PORT_CHECK: Duration = Duration::from_secs(1);

/// Run the live pipeline.
pub fn run(opts: &LiveOptions) -> anyhow::Result<()> {
    let channel = validate(opts)?;
    let kit = match &opts.kit {
        Some(path) => Kit::load(path)?,
        None => Kit::builtin_default(),
    };
    let map = NoteMap::load(&opts.map)?;
    let channel = channel.unwrap_or(map.channel);
    let director = Director::new(&kit, &map)?;

    let mut input = LiveInput::new("drumsim")?;
    let port = choose_port(&input.port_names(), opts.midi_port.as_deref())?;
    let device = device::find_output(opts.audio_device.as_deref()).map_err(|available| match &opts.audio_device {
        Some(wanted) => anyhow::Error::new(LiveInputError::NoSuchAudioDevice { wanted: wanted.clone(), available }),
        None => anyhow::anyhow!(
            "no default audio output (is JACK or a sound card there?); choose one with --audio, see `drumsim devices`"
        ),
    })?;
    // The avatar loads before the sound starts, so that its loading never holds up the audio.
    let prepared = match &opts.avatar {
        Some(a) => Some(crate::avatar::prepare(&kit, &map, a)?),
        None => None,
    };
    let settings =
        OutputSettings { lookahead: Duration::from_secs_f32(opts.lookahead_ms / 1000.0), ..Default::default() };
    let (ring_tx, ring_rx) = rtrb::RingBuffer::new(SOUND_RING);
    let audio = AudioOutput::start(&device, &kit, &settings, ring_rx)?;

    let epoch = Instant::now();
    let counters = Arc::new(Counters::default());
    let (avatar_tx, avatar) = match prepared {
        Some(p) => {
            let (tx, rx) = crossbeam_channel::bounded(MIDI_QUEUE);
            (Some(tx), Some(crate::avatar::start(p, rx, epoch)?))
        }
        None => (None, None),
    };
    let (event_tx, event_rx) = crossbeam_channel::bounded(MIDI_QUEUE);
    let (packet_tx, mut packet_rx) = transport::channel(PACKET_QUEUE);
    let c = counters.clone();
    let interaction = thread::Builder::new()
        .name("drumsim-interaction".into())
        .spawn(move || interact(director, &event_rx, packet_tx, avatar_tx, &c))?;
    let feed = EventFeed::new(kit, audio.sample_rate_hz as f32, PerformanceClock::Epoch(epoch), ring_tx)
        .with_stats(audio.stats.clone());
    let feeder = thread::Builder::new().name("drumsim-feed".into()).spawn(move || feed.run(&mut packet_rx))?;

    let sink = EventSink {
        parser: MessageParser { cc4_closed: map.cc4_closed, ..MessageParser::new(channel) },
        epoch,
        tx: event_tx,
        stats: counters.input.clone(),
    };
    input.connect(&port, sink)?;
    wait_for_first_callback(&audio.stats);
    eprintln!("{}", status(&port, channel, &opts.map, &audio, opts.lookahead_ms));
    if let (Some(a), Some(options)) = (&avatar, &opts.avatar) {
        announce(a, options);
    }

    let result = supervise(&mut input, &audio, &counters, opts.duration_s);
    drop(input); // closes the MIDI port: the interaction thread ends, then the feed thread
    interaction.join().map_err(|_| anyhow::anyhow!("the interaction thread panicked"))?;
    feeder.join().map_err(|_| anyhow::anyhow!("the feed thread panicked"))?.context("message transport")?;
    eprintln!("drumsim live: stopped after {:.1} s: {}", epoch.elapsed().as_secs_f64(), counters.report(&audio.stats));
    if let Some(a) = avatar {
        let dropped = counters.avatar_dropped.load(Relaxed);
        eprintln!("drumsim live: {}, {dropped} events the avatar had no room for", a.stop());
    }
    result
}

/// Say where the drummer is shown (the page's address on stdout, for scripts).
fn announce(avatar: &crate::avatar::Avatar, options: &crate::avatar::AvatarOptions) {
    use std::io::Write;
    let delay = options.lookahead_s * 1e3;
    if let Some(url) = &avatar.url {
        println!("drumsim live: watch the drummer: {url}  (each stroke lands {delay:.0} ms after its note)");
        let _ = std::io::stdout().flush();
        if options.open && !crate::view::open_browser(url) {
            eprintln!("drumsim live: no browser could be launched; open {url} yourself");
        }
    }
    if let Some(v) = &options.vmc {
        eprintln!("drumsim live: sending the drummer to the VMC receiver at {}, 60 frames a second", v.target);
    }
}

fn validate(opts: &LiveOptions) -> Result<Option<u8>, LiveInputError> {
    if let Some(c) = opts.channel.filter(|c| !(1..=16).contains(c)) {
        return Err(LiveInputError::Channel(c));
    }
    if !(0.0..=1000.0).contains(&opts.lookahead_ms) {
        return Err(LiveInputError::Lookahead(opts.lookahead_ms));
    }
    if let Some(d) = opts.duration_s.filter(|d| !(d.is_finite() && *d > 0.0)) {
        return Err(LiveInputError::Duration(d));
    }
    Ok(opts.channel)
}

fn choose_port(names: &[String], wanted: Option<&str>) -> Result<String, LiveInputError> {
    let wanted_string = || wanted.unwrap_or_default().to_string();
    match midi_live::find_port(names, wanted) {
        PortMatch::Found(i) => Ok(names[i].clone()),
        PortMatch::NoPorts if wanted.is_none() => Err(LiveInputError::NoMidiPorts { backend: midi_live::BACKEND }),
        PortMatch::NoPorts | PortMatch::NoMatch => {
            Err(LiveInputError::NoSuchMidiPort { wanted: wanted_string(), available: names.to_vec() })
        }
        PortMatch::Ambiguous(hits) => Err(LiveInputError::AmbiguousMidiPort {
            wanted: wanted_string(),
            matches: hits.into_iter().map(|i| names[i].clone()).collect(),
        }),
    }
}

/// What the non-audio threads count.
#[derive(Debug, Default)]
struct Counters {
    input: Arc<InputStats>,
    /// Messages the Director made and the transport took.
    messages: AtomicU64,
    /// Messages the transport refused (full).
    transport_dropped: AtomicU64,
    /// Events the avatar's queue had no room for.
    avatar_dropped: AtomicU64,
}

impl Counters {
    fn dropped(&self, out: &OutputStats) -> u64 {
        self.input.dropped.load(Relaxed) + self.transport_dropped.load(Relaxed) + out.dropped_events.load(Relaxed)
    }

    fn report(&self, out: &OutputStats) -> String {
        format!(
            "{} MIDI events, {} messages, {} dropped, {} late, {} bad, {} xruns, {} overloads",
            self.input.received.load(Relaxed),
            self.messages.load(Relaxed),
            self.dropped(out),
            out.late_events.load(Relaxed),
            out.bad_messages.load(Relaxed),
            out.xruns.load(Relaxed),
            out.overloads.load(Relaxed),
        )
    }
}

/// The interaction thread: drum events -> messages -> OSC packets, until the input closes;
/// each event also goes to the avatar, when there is one (never waiting for it).
fn interact(
    mut director: Director,
    events: &Receiver<LiveEvent>,
    mut packets: impl PacketSender,
    avatar: Option<crossbeam_channel::Sender<LiveEvent>>,
    c: &Counters,
) {
    let mut messages: Vec<Message> = Vec::with_capacity(16);
    let mut buf = Vec::with_capacity(256);
    for ev in events.iter() {
        if let Some(a) = &avatar {
            if a.try_send(ev).is_err() {
                c.avatar_dropped.fetch_add(1, Relaxed);
            }
        }
        director.on_event(&ev.event, &mut messages);
        for msg in messages.drain(..) {
            if let Err(e) = encode(&msg, &mut buf) {
                eprintln!("drumsim: {e}");
                continue;
            }
            match packets.send(&buf) {
                Ok(()) => c.messages.fetch_add(1, Relaxed),
                Err(TransportError::Disconnected) => return,
                Err(_) => c.transport_dropped.fetch_add(1, Relaxed),
            };
        }
    }
}

fn wait_for_first_callback(stats: &OutputStats) {
    let start = Instant::now();
    while stats.callbacks.load(Relaxed) == 0 && start.elapsed() < Duration::from_millis(500) {
        thread::sleep(Duration::from_millis(5));
    }
}

fn status(port: &str, channel: u8, map: &str, audio: &AudioOutput, lookahead_ms: f32) -> String {
    let fs = f64::from(audio.sample_rate_hz);
    let ms = |frames: f64| 1000.0 * frames / fs;
    let buffer = match audio.buffer_frames {
        Some(n) => format!("{n} frames ({:.1} ms)", ms(n.into())),
        None => "buffer size unknown".into(),
    };
    let output_ms = audio.stats.output_latency_us.load(Relaxed) as f64 / 1000.0;
    format!(
        "drumsim live: MIDI {port:?} ({}, channel {channel}, map {map}) -> {}, {} Hz, {} ch, {buffer}; \
         latency: output {output_ms:.1} ms + engine {:.1} ms + lookahead {lookahead_ms} ms",
        midi_live::BACKEND,
        audio.label,
        audio.sample_rate_hz,
        audio.channels,
        ms(audio.engine_latency_samples as f64),
    )
}

/// The main thread's loop: until `duration_s`, watch the port, report problems as they happen.
fn supervise(
    input: &mut LiveInput,
    audio: &AudioOutput,
    counters: &Counters,
    duration_s: Option<f64>,
) -> anyhow::Result<()> {
    let start = Instant::now();
    let deadline = duration_s.map(|d| start + Duration::from_secs_f64(d));
    let mut next_check = start + PORT_CHECK;
    let mut reported = (0, 0);
    loop {
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) {
            return Ok(());
        }
        let until = deadline.map_or(next_check, |d| d.min(next_check));
        thread::sleep(until.saturating_duration_since(now).min(Duration::from_millis(100)));
        if let Some(e) = audio.error() {
            anyhow::bail!("audio output {} stopped: {e}", audio.label);
        }
        if Instant::now() < next_check {
            continue;
        }
        next_check += PORT_CHECK;
        match input.check() {
            Some(midi_live::PortChange::Disappeared(p)) => {
                eprintln!("drumsim live: MIDI input {p:?} disappeared; still running, will reconnect when it is back")
            }
            Some(midi_live::PortChange::Reconnected(p)) => {
                eprintln!("drumsim live: MIDI input {p:?} is back, reconnected")
            }
            None => {}
        }
        let now_counts = (counters.dropped(&audio.stats), audio.stats.xruns.load(Relaxed));
        if now_counts != reported {
            eprintln!("drumsim live: {} dropped events, {} xruns so far", now_counts.0, now_counts.1);
            reported = now_counts;
        }
    }
}

/// Print usable MIDI inputs and audio outputs.
pub fn list_devices() -> anyhow::Result<()> {
    println!("MIDI inputs ({}):", midi_live::BACKEND);
    match midi_live::input_port_names() {
        Ok(names) if names.is_empty() => println!("  (none)"),
        Ok(names) => names.iter().for_each(|n| println!("  {n}")),
        Err(e) => println!("  (unavailable: {e})"),
    }
    println!("Audio outputs:");
    for host in device::hosts() {
        match device::host_outputs(host) {
            Ok(devices) if devices.is_empty() => println!("  {}: (none)", host.name()),
            Ok(devices) => {
                for d in devices {
                    println!("  {}{}", d.label, if d.is_default { "  (default)" } else { "" });
                }
            }
            Err(e) => println!("  {}: (unavailable: {e})", host.name()),
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> LiveOptions {
        LiveOptions {
            midi_port: None,
            audio_device: None,
            lookahead_ms: 0.0,
            kit: None,
            map: "gm".into(),
            channel: None,
            duration_s: None,
            avatar: None,
        }
    }

    #[test]
    fn bad_options_are_input_errors() {
        assert!(matches!(validate(&LiveOptions { channel: Some(17), ..opts() }), Err(LiveInputError::Channel(17))));
        assert!(matches!(validate(&LiveOptions { lookahead_ms: -1.0, ..opts() }), Err(LiveInputError::Lookahead(_))));
        assert!(matches!(validate(&LiveOptions { duration_s: Some(0.0), ..opts() }), Err(LiveInputError::Duration(_))));
        assert_eq!(validate(&LiveOptions { channel: Some(10), ..opts() }).unwrap(), Some(10));
    }

    #[test]
    fn unknown_port_lists_the_available_ones() {
        let names = vec!["kit:out".to_string(), "keys:out".to_string()];
        let err = choose_port(&names, Some("td-11")).unwrap_err().to_string();
        assert!(err.contains("\"td-11\"") && err.contains("\"kit:out\", \"keys:out\""), "{err}");
        assert!(choose_port(&names, Some(":out")).unwrap_err().to_string().contains("ambiguous"));
        assert!(matches!(choose_port(&[], None), Err(LiveInputError::NoMidiPorts { .. })));
        assert_eq!(choose_port(&names, Some("KEYS")).unwrap(), "keys:out");
    }
}
