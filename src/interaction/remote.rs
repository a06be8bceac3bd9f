//! Contact messages between two processes over UDP (`--sound-to`, `drumsim sound --listen`):
//! the address, the wall clock that time tags share, the sender that tags each message with
//! when it is to sound, and the receiver's memory of what it has already played.
//!
//! A sender runs ahead of the sound by its lookahead: each message goes alone in an OSC
//! bundle whose time tag is the wall-clock moment it is to be heard, so network jitter up
//! to the lookahead does not move the sound. On one machine the two processes share the
//! clock; across machines their clocks must agree (NTP), as any time-tagged OSC needs.

use super::transport::{PacketSender, TransportError, UdpSender};
use super::{encode_bundle, Message};
use rosc::OscTime;
use std::net::{SocketAddr, ToSocketAddrs};
use std::time::{Duration, Instant, SystemTime};

/// A bad `udp://HOST:PORT` (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{option} {given:?}: {why} (expected udp://HOST:PORT, for example udp://127.0.0.1:9000)")]
pub struct AddressError {
    pub option: &'static str,
    pub given: String,
    pub why: String,
}

/// Parse and resolve `udp://HOST:PORT` (the scheme may be left out) for `option`.
pub fn udp_address(option: &'static str, given: &str) -> Result<SocketAddr, AddressError> {
    let err = |why: String| AddressError { option, given: given.to_string(), why };
    let rest = match given.split_once("://") {
        Some(("udp", rest)) => rest,
        Some((scheme, _)) => return Err(err(format!("{scheme}:// is not supported, only udp://"))),
        None => given,
    };
    let (host, port) = rest.rsplit_once(':').ok_or_else(|| err("no port".into()))?;
    let port: u16 = port.parse().map_err(|_| err(format!("port {port:?} is not a number 0-65535")))?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    if host.is_empty() {
        return Err(err("no host".into()));
    }
    (host, port)
        .to_socket_addrs()
        .map_err(|e| err(format!("host {host:?} does not resolve: {e}")))?
        .next()
        .ok_or_else(|| err(format!("host {host:?} has no address")))
}

/// This machine's wall clock against its monotonic one, for OSC time tags.
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    wall: SystemTime,
    instant: Instant,
}

impl Default for WallClock {
    fn default() -> Self {
        WallClock::now()
    }
}

impl WallClock {
    pub fn now() -> WallClock {
        WallClock { instant: Instant::now(), wall: SystemTime::now() }
    }

    /// The OSC time tag of `at`.
    pub fn tag(&self, at: Instant) -> OscTime {
        let wall = match at.checked_duration_since(self.instant) {
            Some(ahead) => self.wall + ahead,
            None => self.wall - self.instant.duration_since(at),
        };
        OscTime::try_from(wall).unwrap_or(OscTime { seconds: 0, fractional: 1 })
    }

    /// The instant a time tag names (None for one this clock cannot hold).
    pub fn instant(&self, tag: OscTime) -> Option<Instant> {
        let wall = SystemTime::from(tag);
        match wall.duration_since(self.wall) {
            Ok(ahead) => self.instant.checked_add(ahead),
            Err(e) => self.instant.checked_sub(e.duration()),
        }
    }
}

/// What a [`TimedSender`] counted.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct SendCounts {
    pub sent: u64,
    /// Refused by the network: nobody listening (ICMP port unreachable) or a full buffer.
    pub refused: u64,
}

/// Sends each message alone in a bundle tagged with the moment it is to sound: the
/// performance's time 0 (`epoch`) plus the message's time plus `ahead`.
pub struct TimedSender {
    udp: UdpSender,
    clock: WallClock,
    epoch: Instant,
    ahead: Duration,
    buf: Vec<u8>,
    pub counts: SendCounts,
}

impl TimedSender {
    pub fn connect(to: SocketAddr, epoch: Instant, ahead: Duration) -> std::io::Result<TimedSender> {
        Ok(TimedSender {
            udp: UdpSender::connect(to)?,
            clock: WallClock::now(),
            epoch,
            ahead,
            buf: Vec::with_capacity(256),
            counts: SendCounts::default(),
        })
    }

    /// When a message of performance time `time_s` is to sound.
    pub fn due(&self, time_s: f32) -> Instant {
        let t = Duration::try_from_secs_f64(f64::from(time_s).max(0.0)).unwrap_or(Duration::ZERO);
        self.epoch + t + self.ahead
    }

    /// Send one message. A refusal is counted, not an error: the sound server may come later.
    pub fn send(&mut self, msg: &Message) -> Result<(), TransportError> {
        let tag = self.clock.tag(self.due(msg.time_s()));
        encode_bundle(std::slice::from_ref(msg), tag, &mut self.buf)
            .map_err(|e| TransportError::Io(std::io::Error::other(e.to_string())))?;
        match self.udp.send(&self.buf) {
            Ok(()) => self.counts.sent += 1,
            Err(TransportError::Full) => self.counts.refused += 1,
            Err(e) => return Err(e),
        }
        Ok(())
    }
}

/// The datagrams a receiver has already taken, to ignore copies the network duplicated (the
/// last [`Seen::CAPACITY`], by a 64-bit hash of the whole datagram: two messages a sender
/// made differ at least in their time or their time tag).
pub struct Seen {
    hashes: Box<[u64]>,
    next: usize,
}

impl Default for Seen {
    fn default() -> Self {
        Seen { hashes: vec![0; Seen::CAPACITY].into(), next: 0 }
    }
}

impl Seen {
    pub const CAPACITY: usize = 4096;

    /// True the first time a datagram is seen; false for a copy.
    pub fn first_time(&mut self, datagram: &[u8]) -> bool {
        // FNV-1a; 0 marks an empty slot.
        let h =
            datagram.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3));
        let h = h.max(1);
        if self.hashes.contains(&h) {
            return false;
        }
        self.hashes[self.next] = h;
        self.next = (self.next + 1) % self.hashes.len();
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interaction::decode_timed;
    use crate::interaction::transport::{PacketReceiver, UdpReceiver};

    #[test]
    fn addresses_are_udp_host_port_and_bad_ones_say_why() {
        assert_eq!(udp_address("--sound-to", "udp://127.0.0.1:9000").unwrap(), "127.0.0.1:9000".parse().unwrap());
        assert_eq!(udp_address("--sound-to", "localhost:9000").unwrap().port(), 9000);
        assert_eq!(udp_address("--listen", "udp://[::1]:9").unwrap(), "[::1]:9".parse().unwrap());
        let why = |s| udp_address("--sound-to", s).unwrap_err().to_string();
        assert!(why("tcp://127.0.0.1:9000").contains("only udp://"), "{}", why("tcp://127.0.0.1:9000"));
        assert!(why("udp://127.0.0.1").contains("no port"));
        assert!(why("udp://127.0.0.1:99999").contains("99999"));
        assert!(why("udp://:9000").contains("no host"));
        let e = why("udp://no-such-host.invalid:9000");
        assert!(e.contains("--sound-to") && e.contains("does not resolve"), "{e}");
    }

    #[test]
    fn a_time_tag_names_the_same_instant_back() {
        let clock = WallClock::now();
        for offset_ms in [-3000i64, -1, 0, 7, 250, 10_000] {
            let at = if offset_ms < 0 {
                clock.instant - Duration::from_millis(offset_ms.unsigned_abs())
            } else {
                clock.instant + Duration::from_millis(offset_ms as u64)
            };
            let back = clock.instant(clock.tag(at)).unwrap();
            let err = if back > at { back - at } else { at - back };
            assert!(err < Duration::from_micros(1), "{offset_ms} ms: off by {err:?}");
        }
    }

    #[test]
    fn the_sender_tags_each_message_with_when_it_is_to_sound() {
        let mut rx = UdpReceiver::bind("127.0.0.1:0").unwrap();
        let epoch = Instant::now();
        let mut tx = TimedSender::connect(rx.local_addr().unwrap(), epoch, Duration::from_millis(20)).unwrap();
        let msg = Message::HiHat { time_s: 1.5, openness: 0.25 };
        tx.send(&msg).unwrap();
        let packet = rx.recv_timeout(Duration::from_secs(5)).unwrap().unwrap();
        let [(Some(tag), ref got)] = decode_timed(packet).unwrap()[..] else { panic!("one timed message") };
        assert_eq!(got, &msg);
        let due = WallClock::now().instant(tag).unwrap();
        let want = epoch + Duration::from_millis(1520);
        let err = if due > want { due - want } else { want - due };
        assert!(err < Duration::from_millis(2), "due {err:?} off");
        assert_eq!(tx.counts, SendCounts { sent: 1, refused: 0 });
    }

    #[test]
    fn a_sender_with_nobody_listening_counts_refusals_and_goes_on() {
        let free = std::net::UdpSocket::bind("127.0.0.1:0").unwrap();
        let to = free.local_addr().unwrap();
        drop(free);
        let mut tx = TimedSender::connect(to, Instant::now(), Duration::ZERO).unwrap();
        for i in 0..20 {
            tx.send(&Message::HiHat { time_s: i as f32, openness: 0.0 }).unwrap();
            std::thread::sleep(Duration::from_millis(1));
        }
        assert_eq!(tx.counts.sent + tx.counts.refused, 20);
        assert!(tx.counts.refused > 0, "loopback reports the closed port: {:?}", tx.counts);
    }

    #[test]
    fn copies_are_recognised_and_the_memory_is_bounded() {
        let mut seen = Seen::default();
        assert!(seen.first_time(b"a") && seen.first_time(b"b"));
        assert!(!seen.first_time(b"a"), "a duplicated datagram");
        for i in 0..Seen::CAPACITY as u32 {
            assert!(seen.first_time(&i.to_be_bytes()));
        }
        assert!(seen.first_time(b"a"), "forgotten after CAPACITY others");
    }
}
