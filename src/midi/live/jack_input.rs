//! The JACK backend of live MIDI input: a JACK client of our own with one MIDI input port,
//! connected to the player's port by name. Each event is stamped at its own frame: JACK
//! hands a cycle's events over together, each with its offset in the cycle, and the cycle's
//! times (`jack_get_cycle_times`) turn that offset into an instant. So two notes 1 ms apart
//! stay 1 ms apart whatever the period, where stamping on arrival would put every event of a
//! cycle at the same moment (up to a period, 5.3 ms at 256 frames, of jitter).
//!
//! An event with offset `t` in a cycle is stamped at the cycle's start plus `t`: the callback's
//! entry less the time JACK says has passed since its driver woke for the cycle
//! (`jack_frames_since_cycle_start`), the measure the output stream's blocks are placed by too
//! (`sound::audio_clock`). The moment the callback happened to run does not enter: a callback
//! woken 4 ms late by a busy machine would otherwise make its notes sound 4 ms late.
//!
//! Not `jack_get_cycle_times`: its cycle start comes from JACK's DLL over the driver's
//! wake-ups, which a stall does not reset. Measured after jackd stopped for 40 ms (dummy
//! driver): the DLL put the cycle's start 34 ms too early and took over a second to come
//! back, so every note played in that second sounded up to 19 ms early.

use super::{EventSink, LiveMidiError, PortChange};
use jack::{AsyncClient, Client, ClientOptions, Control, MidiIn, Port, PortFlags, ProcessHandler, ProcessScope};
use std::time::{Duration, Instant};

const MIDI_TYPE: &str = "8 bit raw midi";
const OUR_PORT: &str = "midi_in";
/// A callback later than this after its cycle's start means JACK's figure is not to be
/// believed, s.
const MAX_LATE_S: f64 = 0.1;

fn open(client_name: &str) -> Result<Client, LiveMidiError> {
    Client::new(client_name, ClientOptions::NO_START_SERVER)
        .map(|(c, _)| c)
        .map_err(|_| LiveMidiError::Init { hint: " (is a JACK server running? `jackd -d alsa` or `jackd -d dummy`)" })
}

/// Other clients' MIDI outputs (our own left out).
fn names(client: &Client, ours: &str) -> Vec<String> {
    client
        .ports(None, Some(MIDI_TYPE), PortFlags::IS_OUTPUT)
        .into_iter()
        .filter(|p| p.split(':').next() != Some(ours))
        .collect()
}

/// Names of the MIDI ports (other programs' outputs) that can be used now.
pub fn input_port_names() -> Result<Vec<String>, LiveMidiError> {
    let client = open("drumsim-list")?;
    let ours = client.name().to_string();
    Ok(names(&client, &ours))
}

/// The process callback: stamp and hand on each event of the cycle.
pub struct Handler {
    port: Port<MidiIn>,
    sink: EventSink,
}

impl ProcessHandler for Handler {
    fn process(&mut self, client: &Client, ps: &ProcessScope) -> Control {
        let now = Instant::now();
        // The cycle's start: how long ago JACK says its driver woke for it (the callback's own
        // entry, should it say something no late wake-up explains).
        let (frames, rate) = (ps.n_frames(), f64::from(client.sample_rate().max(1)));
        let since = f64::from(ps.frames_since_cycle_start()) / rate;
        let since = if since < MAX_LATE_S { since } else { 0.0 };
        let start = now.checked_sub(Duration::from_secs_f64(since)).unwrap_or(now);
        for ev in self.port.iter(ps) {
            let later = f64::from(ev.time.min(frames)) / rate;
            self.sink.handle_at(ev.bytes, start + Duration::from_secs_f64(later));
        }
        Control::Continue
    }
}

/// Our JACK client, its MIDI input connected to one port of another client, watched so that
/// it is reconnected by name when it comes back.
pub struct LiveInput {
    /// Not yet active (before [`LiveInput::connect`]).
    idle: Option<Client>,
    active: Option<AsyncClient<(), Handler>>,
    /// Our client's name as JACK gave it.
    ours: String,
    port: String,
    present: bool,
}

impl LiveInput {
    /// Open our JACK client, named `client_name`.
    pub fn new(client_name: &str) -> Result<LiveInput, LiveMidiError> {
        let client = open(client_name)?;
        let ours = client.name().to_string();
        Ok(LiveInput { idle: Some(client), active: None, ours, port: String::new(), present: false })
    }

    fn client(&self) -> &Client {
        match (&self.idle, &self.active) {
            (Some(c), _) => c,
            (None, Some(a)) => a.as_client(),
            (None, None) => unreachable!("a client, idle or active"),
        }
    }

    /// The ports that can be connected now.
    pub fn port_names(&self) -> Vec<String> {
        names(self.client(), &self.ours)
    }

    /// The connected port's name.
    pub fn port(&self) -> &str {
        &self.port
    }

    /// Connect to the port of this exact name; its messages go to `sink`.
    pub fn connect(&mut self, port: &str, sink: EventSink) -> Result<(), LiveMidiError> {
        let err = |message: String| LiveMidiError::Connect { port: port.to_string(), message };
        self.port = port.to_string();
        if let Some(client) = self.idle.take() {
            let midi_in = client.register_port(OUR_PORT, MidiIn::default()).map_err(|e| err(e.to_string()))?;
            let active = client.activate_async((), Handler { port: midi_in, sink }).map_err(|e| err(e.to_string()))?;
            self.active = Some(active);
        }
        self.link()
    }

    fn link(&mut self) -> Result<(), LiveMidiError> {
        let err = |message: String| LiveMidiError::Connect { port: self.port.clone(), message };
        let client = self.client();
        if !names(client, &self.ours).contains(&self.port) {
            return Err(err("no such port".into()));
        }
        let ours = format!("{}:{OUR_PORT}", self.ours);
        client.connect_ports_by_name(&self.port, &ours).map_err(|e| err(e.to_string()))?;
        self.present = true;
        Ok(())
    }

    /// Look whether the port is still there (call about once a second): report it gone, or
    /// reconnect when a port of the same name is back.
    pub fn check(&mut self) -> Option<PortChange> {
        let here = names(self.client(), &self.ours).contains(&self.port);
        match (self.present, here) {
            (true, false) => {
                self.present = false;
                Some(PortChange::Disappeared(self.port.clone()))
            }
            (false, true) => self.link().ok().map(|()| PortChange::Reconnected(self.port.clone())),
            _ => None,
        }
    }
}
