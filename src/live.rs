//! Real-time pipeline: live MIDI in -> contact messages -> sound engine -> audio out.
//! Thread wiring only; each stage lives with its data:
//!
//! ```text
//! MIDI callback    parse, stamp (its frame on JACK) (midi::live::EventSink)
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
//! With `--sound-to udp://HOST:PORT` there is no feed or audio callback here: the interaction
//! thread sends each message in a bundle tagged with when it is to sound (the note's arrival
//! plus the lookahead) to `drumsim sound` in another process (interaction::remote).
//!
//! A MIDI port that disappears (its JACK client closed, the USB cable pulled) does not stop
//! the session: it is reported, and reconnected by name as soon as a port of that name is
//! back (checked every second).

use crate::interaction::direct::Director;
use crate::interaction::remote::TimedSender;
use crate::interaction::transport::{self, ChannelSender, PacketSender, TransportError};
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
    /// Send the messages to a sound server there instead of playing them here.
    pub sound_to: Option<std::net::SocketAddr>,
    /// The simulated body plays the notes and its contacts are the sound (`--sound
    /// physical`; `lookahead_ms` is then how long after its note each stroke lands).
    pub physical: bool,
    /// Each kit piece on its own output channel after the mix (`--stems`).
    pub stems: bool,
}

/// The lookahead of `--sound-to` when none is given, ms: room for a local network's jitter.
pub const REMOTE_LOOKAHEAD_MS: f32 = 20.0;

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
/// What the live physical body sends its avatar (hands at 60 a second, the hi-hat, contacts).
const AVATAR_FEED: usize = 1024;
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
    let device = match opts.sound_to {
        Some(_) => None,
        None => Some(find_device(opts)?),
    };
    // The avatar and the body load before the sound starts, so that their loading never
    // holds up the audio.
    let prepared = match &opts.avatar {
        Some(a) => Some(crate::avatar::prepare(&kit, &map, a)?),
        None => None,
    };
    let body = match opts.physical {
        true => Some(crate::live_body::prepare(&kit, &map, f64::from(opts.lookahead_ms) / 1e3)?),
        false => None,
    };
    let lookahead = Duration::from_secs_f32(opts.lookahead_ms / 1000.0);
    let (ring_tx, ring_rx) = rtrb::RingBuffer::new(SOUND_RING);
    let audio = match &device {
        Some(d) => {
            let settings = OutputSettings { lookahead, stems: opts.stems, ..Default::default() };
            let audio = AudioOutput::start(d, &kit, &settings, ring_rx)?;
            if opts.stems {
                eprintln!("drumsim live: {}", crate::sound::device::stem_channels(&kit));
            }
            Some(audio)
        }
        None => None,
    };

    let epoch = Instant::now();
    let counters = Arc::new(Counters::default());
    // The avatar plans from the player's events; with the physical drummer it shows the body.
    let (avatar_tx, avatar, show) = match prepared {
        Some(p) if opts.physical => {
            let (plans_tx, plans_rx) = crossbeam_channel::bounded(4);
            let (feed_tx, feed_rx) = crossbeam_channel::bounded(AVATAR_FEED);
            let a = crate::avatar::start(p, crate::avatar::Source::Body { plans: plans_rx, feed: feed_rx }, epoch)?;
            let show = crate::live_body::ShowTo { plans: plans_tx, feed: feed_tx, stats: a.stats.clone() };
            (None, Some(a), Some(show))
        }
        Some(p) => {
            let (tx, rx) = crossbeam_channel::bounded(MIDI_QUEUE);
            (Some(tx), Some(crate::avatar::start(p, crate::avatar::Source::Events(rx), epoch)?), None)
        }
        None => (None, None, None),
    };
    let (event_tx, event_rx) = crossbeam_channel::bounded(MIDI_QUEUE);
    let (out, feeder) = match (&audio, opts.sound_to) {
        (Some(audio), _) => {
            let (packet_tx, mut packet_rx) = transport::channel(PACKET_QUEUE);
            let feed = EventFeed::new(kit, audio.sample_rate_hz as f32, PerformanceClock::Epoch(epoch), ring_tx)
                .with_stats(audio.stats.clone());
            let feeder = thread::Builder::new().name("drumsim-feed".into()).spawn(move || feed.run(&mut packet_rx))?;
            (Out::Local(packet_tx), Some(feeder))
        }
        (None, Some(to)) => {
            let sender =
                TimedSender::connect(to, epoch, lookahead).with_context(|| format!("sending to udp://{to}"))?;
            (Out::Remote(sender), None)
        }
        (None, None) => unreachable!("an audio output or a sound server"),
    };
    let c = counters.clone();
    let (route, body) = match body {
        None => (Route::Direct(out), None),
        Some(prepared) => {
            let (events_tx, events_rx) = crossbeam_channel::bounded(MIDI_QUEUE);
            let (messages_tx, messages_rx) = crossbeam_channel::bounded(MIDI_QUEUE);
            let (mut out, c, mut buf) = (out, counters.clone(), Vec::with_capacity(256));
            let send = move |msg: &Message| match out.send(msg, &mut buf, &c) {
                Ok(()) => {
                    c.messages.fetch_add(1, Relaxed);
                    true
                }
                Err(_) => {
                    c.transport_dropped.fetch_add(1, Relaxed);
                    false
                }
            };
            let lookahead_s = f64::from(opts.lookahead_ms) / 1e3;
            let body = crate::live_body::start(prepared, events_rx, messages_rx, epoch, lookahead_s, show, send)?;
            (Route::Physical { events: events_tx, messages: messages_tx }, Some(body))
        }
    };
    let interaction = thread::Builder::new()
        .name("drumsim-interaction".into())
        .spawn(move || interact(director, &event_rx, route, avatar_tx, &c))?;

    let sink = EventSink {
        parser: MessageParser { cc4_closed: map.cc4_closed, ..MessageParser::new(channel) },
        epoch,
        tx: event_tx,
        stats: counters.input.clone(),
    };
    input.connect(&port, sink)?;
    match (&audio, opts.sound_to) {
        (Some(audio), _) => {
            wait_for_first_callback(&audio.stats);
            eprintln!("{}", status(&port, channel, &opts.map, audio, opts.lookahead_ms));
        }
        (None, Some(to)) => eprintln!(
            "drumsim live: MIDI {port:?} ({}, channel {channel}, map {}) -> sound server udp://{to}, each message \
             tagged to sound {} ms after its note",
            midi_live::BACKEND,
            opts.map,
            opts.lookahead_ms
        ),
        (None, None) => {}
    }
    if let (Some(a), Some(options)) = (&avatar, &opts.avatar) {
        announce(a, options);
    }

    let stats = audio.as_ref().map(|a| a.stats.clone()).unwrap_or_default();
    // Ctrl-C (or SIGTERM) stops the session as --duration-s does, with its summary; a second
    // one exits at once.
    crate::outputs::stop_gracefully_on_interrupt();
    let result = supervise(&mut input, audio.as_ref(), &counters, opts.duration_s);
    drop(input); // closes the MIDI port: the interaction thread ends, then the feed thread
    interaction.join().map_err(|_| anyhow::anyhow!("the interaction thread panicked"))?;
    let body_report = body.map(|b| b.stop()); // its out thread ends, then the feed thread
    if let Some(feeder) = feeder {
        feeder.join().map_err(|_| anyhow::anyhow!("the feed thread panicked"))?.context("message transport")?;
    }
    eprintln!("drumsim live: stopped after {:.1} s: {}", epoch.elapsed().as_secs_f64(), counters.report(&stats));
    if let Some(to) = opts.sound_to {
        let refused = counters.refused.load(Relaxed);
        let hint =
            if refused > 0 { format!(" (is `drumsim sound --listen udp://{to}` running?)") } else { String::new() };
        eprintln!(
            "drumsim live: {} messages sent to udp://{to}, {refused} refused{hint}",
            counters.messages.load(Relaxed)
        );
    }
    if let Some(report) = body_report {
        eprintln!("drumsim live: {report}");
    }
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

fn find_device(opts: &LiveOptions) -> anyhow::Result<device::OutputDevice> {
    device::find_output(opts.audio_device.as_deref()).map_err(|available| match &opts.audio_device {
        Some(wanted) => anyhow::Error::new(LiveInputError::NoSuchAudioDevice { wanted: wanted.clone(), available }),
        None => anyhow::anyhow!(
            "no default audio output (is JACK or a sound card there?); choose one with --audio, see `drumsim devices`"
        ),
    })
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
    /// Messages the network refused (`--sound-to` with no server listening).
    refused: AtomicU64,
}

impl Counters {
    fn dropped(&self, out: &OutputStats) -> u64 {
        self.input.dropped.load(Relaxed)
            + self.transport_dropped.load(Relaxed)
            + self.refused.load(Relaxed)
            + out.dropped_events.load(Relaxed)
    }

    fn report(&self, out: &OutputStats) -> String {
        format!(
            "{} MIDI events, {} messages, {} dropped, {} late, {} bad, {} xruns, {} overloads, audio clock re-locked {} times and stepped {}",
            self.input.received.load(Relaxed),
            self.messages.load(Relaxed),
            self.dropped(out),
            out.late_events.load(Relaxed),
            out.bad_messages.load(Relaxed),
            out.xruns.load(Relaxed),
            out.overloads.load(Relaxed),
            out.clock_relocks.load(Relaxed),
            out.clock_steps.load(Relaxed),
        )
    }
}

/// Where the interaction thread's messages go.
enum Out {
    /// The feed thread of this process, as OSC packets.
    Local(ChannelSender),
    /// A sound server elsewhere, as time-tagged bundles.
    Remote(TimedSender),
}

impl Out {
    fn send(&mut self, msg: &Message, buf: &mut Vec<u8>, c: &Counters) -> Result<(), TransportError> {
        match self {
            Out::Local(packets) => {
                encode(msg, buf).map_err(|e| TransportError::Io(std::io::Error::other(e.to_string())))?;
                packets.send(buf)
            }
            Out::Remote(sender) => {
                let refused = sender.counts.refused;
                sender.send(msg)?;
                if sender.counts.refused > refused {
                    c.refused.fetch_add(1, Relaxed);
                }
                Ok(())
            }
        }
    }
}

/// Where the interaction thread's work goes.
enum Route {
    /// Direct mode: the notes' contact messages, to the sound.
    Direct(Out),
    /// Physical mode: the events to the body's planner; only chokes (a hand grabbing a
    /// cymbal, which the body does not do) go to the sound as messages, through the body's
    /// out thread.
    Physical { events: crossbeam_channel::Sender<LiveEvent>, messages: crossbeam_channel::Sender<Message> },
}

/// The interaction thread: drum events -> messages -> OSC packets (or, in physical mode, to
/// the body), until the input closes; each event also goes to the avatar, when there is one
/// (never waiting for it).
fn interact(
    mut director: Director,
    events: &Receiver<LiveEvent>,
    mut route: Route,
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
        match &mut route {
            Route::Direct(out) => {
                for msg in messages.drain(..) {
                    match out.send(&msg, &mut buf, c) {
                        Ok(()) => c.messages.fetch_add(1, Relaxed),
                        Err(TransportError::Disconnected) => return,
                        Err(TransportError::Io(e)) => {
                            eprintln!("drumsim live: a message was not sent: {e}");
                            c.transport_dropped.fetch_add(1, Relaxed)
                        }
                        Err(_) => c.transport_dropped.fetch_add(1, Relaxed),
                    };
                }
            }
            Route::Physical { events, messages: chokes } => {
                if events.try_send(ev).is_err() {
                    c.transport_dropped.fetch_add(1, Relaxed);
                }
                for msg in messages.drain(..).filter(|m| matches!(m, Message::Choke { .. })) {
                    if chokes.try_send(msg).is_err() {
                        c.transport_dropped.fetch_add(1, Relaxed);
                    }
                }
            }
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
    // The engine's delay is taken off each event's sample as far as the lookahead allows.
    let engine_ms = (ms(audio.engine_latency_samples as f64) - f64::from(lookahead_ms)).max(0.0);
    format!(
        "drumsim live: MIDI {port:?} ({}, channel {channel}, map {map}) -> {}, {} Hz, {} ch, {buffer}; \
         latency: output {output_ms:.1} ms + engine {engine_ms:.1} ms + lookahead {lookahead_ms} ms",
        midi_live::BACKEND,
        audio.label,
        audio.sample_rate_hz,
        audio.channels,
    )
}

/// The main thread's loop: until `duration_s` or an interrupt, watch the port, report problems as they happen.
fn supervise(
    input: &mut LiveInput,
    audio: Option<&AudioOutput>,
    counters: &Counters,
    duration_s: Option<f64>,
) -> anyhow::Result<()> {
    let start = Instant::now();
    let deadline = duration_s.map(|d| start + Duration::from_secs_f64(d));
    let mut next_check = start + PORT_CHECK;
    let mut reported = (0, 0);
    loop {
        let now = Instant::now();
        if deadline.is_some_and(|d| now >= d) || crate::outputs::interrupted() {
            return Ok(());
        }
        let until = deadline.map_or(next_check, |d| d.min(next_check));
        thread::sleep(until.saturating_duration_since(now).min(Duration::from_millis(100)));
        if let Some((a, e)) = audio.and_then(|a| Some((a, a.error()?))) {
            anyhow::bail!("audio output {} stopped: {e}", a.label);
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
        let stats = audio.map(|a| a.stats.clone()).unwrap_or_default();
        let now_counts = (counters.dropped(&stats), stats.xruns.load(Relaxed));
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
            sound_to: None,
            physical: false,
            stems: false,
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
