//! The ALSA backend of live MIDI input (midir): each message stamped on arrival.

use super::{EventSink, LiveMidiError, PortChange};
use midir::{Ignore, MidiInput, MidiInputConnection};

fn init_hint() -> &'static str {
    if cfg!(feature = "jack") {
        " (is a JACK server running? `jackd -d alsa` or `jackd -d dummy`)"
    } else {
        " (is the ALSA sequencer available? `modprobe snd-seq`)"
    }
}

fn open(client_name: &str) -> Result<MidiInput, LiveMidiError> {
    let mut input = MidiInput::new(client_name).map_err(|_| LiveMidiError::Init { hint: init_hint() })?;
    input.ignore(Ignore::All);
    Ok(input)
}

fn names(input: &MidiInput) -> Vec<String> {
    input.ports().iter().filter_map(|p| input.port_name(p).ok()).collect()
}

/// Names of the MIDI input ports (other programs' outputs, with JACK) that can be used now.
pub fn input_port_names() -> Result<Vec<String>, LiveMidiError> {
    Ok(names(&open("drumsim-list")?))
}

/// One connected input port, watched so that it is reconnected by name when it comes back.
pub struct LiveInput {
    client_name: String,
    /// Lists ports (a connected midir input cannot).
    watcher: MidiInput,
    /// The input to connect with, while not connected.
    idle: Option<MidiInput>,
    connection: Option<MidiInputConnection<()>>,
    port: String,
    /// Whether the port was there at the last check.
    present: bool,
    sink: Option<EventSink>,
}

impl LiveInput {
    /// Open the backend; `client_name` names our client (and our JACK port's owner).
    pub fn new(client_name: &str) -> Result<LiveInput, LiveMidiError> {
        Ok(LiveInput {
            client_name: client_name.to_string(),
            watcher: open(&format!("{client_name}-watch"))?,
            idle: Some(open(client_name)?),
            connection: None,
            port: String::new(),
            present: false,
            sink: None,
        })
    }

    /// The ports that can be connected now.
    pub fn port_names(&self) -> Vec<String> {
        names(&self.watcher)
    }

    /// The connected port's name.
    pub fn port(&self) -> &str {
        &self.port
    }

    /// Connect to the port of this exact name; its messages go to `sink`.
    pub fn connect(&mut self, port: &str, sink: EventSink) -> Result<(), LiveMidiError> {
        self.port = port.to_string();
        self.sink = Some(sink);
        self.reconnect()
    }

    fn reconnect(&mut self) -> Result<(), LiveMidiError> {
        let err = |message: String| LiveMidiError::Connect { port: self.port.clone(), message };
        let input = match (self.idle.take(), self.connection.take()) {
            (Some(input), _) => input,
            (None, Some(conn)) => conn.close().0,
            (None, None) => open(&self.client_name)?,
        };
        let Some(port) = input.ports().into_iter().find(|p| input.port_name(p).ok().as_deref() == Some(&self.port))
        else {
            self.idle = Some(input);
            return Err(err("no such port".into()));
        };
        let sink = self.sink.clone().ok_or_else(|| err("no event sink".into()))?;
        match input.connect(&port, "midi_in", move |_, bytes, _| sink.handle(bytes), ()) {
            Ok(conn) => {
                self.connection = Some(conn);
                self.present = true;
                Ok(())
            }
            Err(e) => {
                let message = e.to_string();
                self.idle = Some(e.into_inner());
                Err(err(message))
            }
        }
    }

    /// Look whether the port is still there (call about once a second): report it gone, or
    /// reconnect when a port of the same name is back.
    pub fn check(&mut self) -> Option<PortChange> {
        let here = names(&self.watcher).contains(&self.port);
        match (self.present, here) {
            (true, false) => {
                self.present = false;
                Some(PortChange::Disappeared(self.port.clone()))
            }
            (false, true) => self.reconnect().ok().map(|()| PortChange::Reconnected(self.port.clone())),
            _ => None,
        }
    }
}
