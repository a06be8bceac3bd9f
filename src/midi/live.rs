//! Live MIDI input: raw messages -> drum events stamped with when they were played.
//!
//! Two backends: ALSA through midir (`alsa.rs`, stamped on arrival), and with the `jack`
//! feature JACK's own MIDI ports (`jack_input.rs`, stamped at their frame in the cycle, so
//! sub-period timing survives). Their callbacks run on the backend's thread (JACK's process
//! thread), so they only parse a few bytes, read the clock and `try_send` into a bounded
//! channel: no allocation, no blocking. Events that do not fit are counted, not queued.
//! [`LiveInput`] also watches its port: when the source goes away it reports it, and it
//! reconnects by name when a port of that name comes back.

use super::{DrumEvent, DrumEventKind};
use crossbeam_channel::{Sender, TrySendError};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// The MIDI backend compiled in.
pub const BACKEND: &str = if cfg!(feature = "jack") { "JACK" } else { "ALSA" };

/// A drum event and the instant its bytes reached us.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LiveEvent {
    pub arrival: Instant,
    /// `time_s` is seconds since the session's epoch; `tick` counts the events received.
    pub event: DrumEvent,
}

/// Parses complete 2-3 byte channel messages (midir delivers whole messages, so there is no
/// running status to track) of one channel into drum events.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MessageParser {
    /// 1..=16.
    pub channel: u8,
    /// The CC4 value of a closed hi-hat on the player's kit (127 or 0; see
    /// [`crate::midi::NoteMap::cc4_closed`]): pedal values are turned to 127 closed.
    pub cc4_closed: u8,
}

impl MessageParser {
    pub fn new(channel: u8) -> MessageParser {
        MessageParser { channel, cc4_closed: 127 }
    }

    /// The drum event in `bytes`, or None for other channels, other messages and malformed data.
    pub fn parse(&self, bytes: &[u8]) -> Option<DrumEventKind> {
        let (&status, data) = bytes.split_first()?;
        if !(0x80..0xF0).contains(&status) || (status & 0x0F) + 1 != self.channel {
            return None;
        }
        let byte = |i: usize| data.get(i).copied().filter(|b| *b < 0x80);
        match status & 0xF0 {
            0x80 => Some(DrumEventKind::NoteOff { note: byte(0)? }),
            0x90 => match (byte(0)?, byte(1)?) {
                (note, 0) => Some(DrumEventKind::NoteOff { note }),
                (note, velocity) => Some(DrumEventKind::NoteOn { note, velocity }),
            },
            0xA0 => Some(DrumEventKind::Aftertouch { note: byte(0)?, pressure: byte(1)? }),
            0xB0 if byte(0)? == 4 => {
                let value = byte(1)?;
                Some(DrumEventKind::HiHatPedal { value: if self.cc4_closed == 0 { 127 - value } else { value } })
            }
            _ => None,
        }
    }
}

/// Counters the input callback keeps (read by the main thread).
#[derive(Debug, Default)]
pub struct InputStats {
    /// Drum events parsed and queued.
    pub received: AtomicU64,
    /// Drum events dropped because the queue was full.
    pub dropped: AtomicU64,
}

/// What the callback does with a message: parse, stamp, queue. Cloned into each connection.
#[derive(Debug, Clone)]
pub struct EventSink {
    pub parser: MessageParser,
    /// `DrumEvent::time_s` is measured from here.
    pub epoch: Instant,
    pub tx: Sender<LiveEvent>,
    pub stats: Arc<InputStats>,
}

impl EventSink {
    /// Handle one raw message, stamped now. Real-time safe: no allocation, no lock, no
    /// blocking.
    pub fn handle(&self, bytes: &[u8]) {
        self.handle_at(bytes, Instant::now());
    }

    /// Handle one raw message played at `arrival`.
    pub fn handle_at(&self, bytes: &[u8], arrival: Instant) {
        let Some(kind) = self.parser.parse(bytes) else { return };
        let tick = self.stats.received.load(Ordering::Relaxed);
        let time_s = arrival.saturating_duration_since(self.epoch).as_secs_f64();
        let ev = LiveEvent { arrival, event: DrumEvent { time_s, tick, kind } };
        match self.tx.try_send(ev) {
            Ok(()) => self.stats.received.fetch_add(1, Ordering::Relaxed),
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                self.stats.dropped.fetch_add(1, Ordering::Relaxed)
            }
        };
    }
}

/// How a wanted port name matched the available ports.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortMatch {
    Found(usize),
    NoPorts,
    NoMatch,
    /// Several ports contain the wanted text and none is named exactly so.
    Ambiguous(Vec<usize>),
}

/// Choose a port: the exact name wins, else the one name that contains `wanted` (ignoring
/// case); no `wanted`: the first port.
pub fn find_port(names: &[String], wanted: Option<&str>) -> PortMatch {
    if names.is_empty() {
        return PortMatch::NoPorts;
    }
    let Some(wanted) = wanted else { return PortMatch::Found(0) };
    let lower = wanted.to_lowercase();
    if let Some(i) = names.iter().position(|n| n.to_lowercase() == lower) {
        return PortMatch::Found(i);
    }
    let hits: Vec<usize> = (0..names.len()).filter(|&i| names[i].to_lowercase().contains(&lower)).collect();
    match hits.as_slice() {
        [] => PortMatch::NoMatch,
        [i] => PortMatch::Found(*i),
        _ => PortMatch::Ambiguous(hits),
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LiveMidiError {
    #[error("cannot open {BACKEND} MIDI input{hint}")]
    Init { hint: &'static str },
    #[error("cannot connect to MIDI port {port:?}: {message}")]
    Connect { port: String, message: String },
}

/// A change of the connected port, found by [`LiveInput::check`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PortChange {
    Disappeared(String),
    Reconnected(String),
}

#[cfg(not(feature = "jack"))]
mod alsa;
#[cfg(not(feature = "jack"))]
pub use alsa::{input_port_names, LiveInput};
#[cfg(feature = "jack")]
mod jack_input;
#[cfg(feature = "jack")]
pub use jack_input::{input_port_names, LiveInput};

#[cfg(test)]
mod tests {
    use super::*;

    const DRUMS: MessageParser = MessageParser { channel: 10, cc4_closed: 127 };

    #[test]
    fn note_on_with_velocity_zero_is_a_note_off() {
        assert_eq!(DRUMS.parse(&[0x99, 38, 100]), Some(DrumEventKind::NoteOn { note: 38, velocity: 100 }));
        assert_eq!(DRUMS.parse(&[0x99, 38, 0]), Some(DrumEventKind::NoteOff { note: 38 }));
        assert_eq!(DRUMS.parse(&[0x89, 38, 64]), Some(DrumEventKind::NoteOff { note: 38 }));
    }

    #[test]
    fn hihat_pedal_and_aftertouch() {
        assert_eq!(DRUMS.parse(&[0xB9, 4, 90]), Some(DrumEventKind::HiHatPedal { value: 90 }));
        assert_eq!(DRUMS.parse(&[0xB9, 7, 90]), None, "only CC4 matters");
        let closed_at_0 = MessageParser { channel: 10, cc4_closed: 0 };
        assert_eq!(closed_at_0.parse(&[0xB9, 4, 0]), Some(DrumEventKind::HiHatPedal { value: 127 }));
        assert_eq!(DRUMS.parse(&[0xA9, 49, 127]), Some(DrumEventKind::Aftertouch { note: 49, pressure: 127 }));
    }

    #[test]
    fn other_channels_system_messages_and_garbage_are_ignored() {
        assert_eq!(DRUMS.parse(&[0x90, 38, 100]), None, "channel 1");
        assert!(MessageParser::new(1).parse(&[0x90, 38, 100]).is_some());
        for bytes in [&[][..], &[0xF8], &[0xF0, 1, 2, 0xF7], &[0x99, 38], &[0x99, 0x80, 1], &[38, 100], &[0xC9, 5]] {
            assert_eq!(DRUMS.parse(bytes), None, "{bytes:?}");
        }
    }

    #[test]
    fn sink_stamps_counts_and_drops_when_full() {
        let (tx, rx) = crossbeam_channel::bounded(1);
        let epoch = Instant::now();
        let sink = EventSink { parser: DRUMS, epoch, tx, stats: Arc::default() };
        sink.handle(&[0x99, 36, 127]);
        sink.handle(&[0x99, 38, 90]);
        sink.handle(&[0x90, 38, 90]);
        let ev = rx.try_recv().unwrap();
        assert_eq!(ev.event.kind, DrumEventKind::NoteOn { note: 36, velocity: 127 });
        assert!(ev.arrival >= epoch && ev.event.time_s >= 0.0 && ev.event.time_s < 1.0);
        assert_eq!(sink.stats.received.load(Ordering::Relaxed), 1);
        assert_eq!(sink.stats.dropped.load(Ordering::Relaxed), 1);
    }

    #[test]
    fn ports_match_exactly_then_by_unique_part() {
        let names: Vec<String> = ["a:midi_out", "TD-11:out", "TD-11:out 2"].map(String::from).into();
        assert_eq!(find_port(&names, None), PortMatch::Found(0));
        assert_eq!(find_port(&names, Some("td-11:out")), PortMatch::Found(1), "exact wins over part of another");
        assert_eq!(find_port(&names, Some("out 2")), PortMatch::Found(2));
        assert_eq!(find_port(&names, Some("td-11")), PortMatch::Ambiguous(vec![1, 2]));
        assert_eq!(find_port(&names, Some("roland")), PortMatch::NoMatch);
        assert_eq!(find_port(&[], Some("x")), PortMatch::NoPorts);
    }
}
