//! The sound server's feed: datagrams from a sender elsewhere -> plain events for the audio
//! callback, each at the moment its bundle's time tag names.
//!
//! ```text
//! UDP datagram -> copy? (ignored) -> decode (bad: counted, named) -> due instant:
//!   time tag (wall clock) or, untimed, arrival + latency -> too far ahead? (refused)
//!   -> already past? (late: played at once, counted) -> EventFeed ring -> callback
//! ```
//! Reordered datagrams need nothing: each event sounds at its own time. Only the counts show
//! them.

use super::output::EventFeed;
use crate::interaction::remote::{Seen, WallClock};
use crate::interaction::transport::{PacketReceiver, TransportError};
use crate::interaction::{decode_timed, Message};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A time tag further ahead than this is refused: it would hold a place in the engine's
/// queue for that long.
pub const MAX_AHEAD: Duration = Duration::from_secs(10);

/// What the network side counted (bad messages and drops are in the output's stats).
#[derive(Debug, Default)]
pub struct NetCounts {
    pub datagrams: AtomicU64,
    /// Messages queued to sound.
    pub messages: AtomicU64,
    /// Copies of a datagram already taken, ignored.
    pub duplicates: AtomicU64,
    /// Messages whose moment had passed when they arrived, played at once.
    pub late: AtomicU64,
    /// Datagrams that arrived after one tagged later.
    pub reordered: AtomicU64,
}

impl NetCounts {
    pub fn report(&self) -> String {
        format!(
            "{} datagrams, {} messages, {} late (played at once), {} duplicates ignored, {} reordered",
            self.datagrams.load(Relaxed),
            self.messages.load(Relaxed),
            self.late.load(Relaxed),
            self.duplicates.load(Relaxed),
            self.reordered.load(Relaxed),
        )
    }
}

pub struct NetFeed {
    feed: EventFeed,
    seen: Seen,
    /// Untimed messages sound this long after they arrive.
    latency: Duration,
    /// The latest time tag so far, as its 64 raw bits (equal tags are not reordered).
    latest: Option<u64>,
    pub counts: Arc<NetCounts>,
}

impl NetFeed {
    pub fn new(feed: EventFeed, latency: Duration) -> NetFeed {
        NetFeed { feed, seen: Seen::default(), latency, latest: None, counts: Arc::default() }
    }

    /// Take one datagram that arrived at `received`; an error describes what was refused
    /// (and counted) in it.
    pub fn take(&mut self, datagram: &[u8], received: Instant) -> Result<(), String> {
        self.counts.datagrams.fetch_add(1, Relaxed);
        if !self.seen.first_time(datagram) {
            self.counts.duplicates.fetch_add(1, Relaxed);
            return Ok(());
        }
        let messages = decode_timed(datagram).map_err(|e| self.feed.bad(e.to_string()))?;
        let clock = WallClock::now();
        let mut refused = None;
        for (tag, msg) in &messages {
            match self.due(tag.map(|t| clock.instant(t)), received) {
                Ok(due) => {
                    let raw = tag.map(|t| (u64::from(t.seconds) << 32) | u64::from(t.fractional));
                    if let Err(e) = self.queue(msg, due, received, raw) {
                        refused.get_or_insert(e);
                    }
                }
                Err(e) => {
                    refused.get_or_insert(self.feed.bad(format!("{e} ({})", describe(msg))));
                }
            }
        }
        refused.map_or(Ok(()), Err)
    }

    /// When a message tagged `tag` (None: untimed; Some(None): a tag this clock cannot hold)
    /// is to sound.
    fn due(&self, tag: Option<Option<Instant>>, received: Instant) -> Result<Instant, String> {
        match tag {
            None => Ok(received + self.latency),
            Some(None) => Err("a time tag out of range".into()),
            Some(Some(due)) if due > received + MAX_AHEAD => Err(format!(
                "a time tag {:.1} s ahead (more than {} s)",
                (due - received).as_secs_f64(),
                MAX_AHEAD.as_secs()
            )),
            Some(Some(due)) => Ok(due),
        }
    }

    fn queue(&mut self, msg: &Message, due: Instant, received: Instant, tag: Option<u64>) -> Result<(), String> {
        if due < received {
            self.counts.late.fetch_add(1, Relaxed);
        }
        if let Some(tag) = tag {
            if self.latest.is_some_and(|l| tag < l) {
                self.counts.reordered.fetch_add(1, Relaxed);
            }
            self.latest = Some(self.latest.map_or(tag, |l| l.max(tag)));
        }
        self.feed.push_at(msg, due.max(received))?;
        self.counts.messages.fetch_add(1, Relaxed);
        Ok(())
    }

    /// Take datagrams until `stop` is set; the first `shown` refusals are described on
    /// stderr, the rest only counted.
    pub fn run(mut self, packets: &mut dyn PacketReceiver, stop: &AtomicBool) -> Result<(), TransportError> {
        const SHOWN: u64 = 5;
        let mut described = 0;
        while !stop.load(Relaxed) {
            match packets.recv_timeout(Duration::from_millis(100)) {
                Ok(Some(packet)) => {
                    if let Err(e) = self.take(packet, Instant::now()) {
                        described += 1;
                        if described <= SHOWN {
                            eprintln!("drumsim sound: skipped a message: {e}");
                        }
                        if described == SHOWN {
                            eprintln!("drumsim sound: further bad messages are only counted");
                        }
                    }
                }
                Ok(None) => {}
                // Not fatal: counted, and a pause so that a broken socket does not spin.
                Err(TransportError::Io(e)) => {
                    self.feed.bad(format!("receiving: {e}"));
                    std::thread::sleep(Duration::from_millis(10));
                }
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }
}

fn describe(msg: &Message) -> String {
    match msg {
        Message::Contact(c) => format!("contact on {} at {:.3} s", c.piece, c.time_s),
        Message::HiHat { time_s, .. } => format!("hi-hat at {time_s:.3} s"),
        Message::Choke { piece, time_s } => format!("choke of {piece} at {time_s:.3} s"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interaction::{encode, encode_bundle, ContactMessage, Limb};
    use crate::kit::Kit;
    use crate::sound::output::{OutputStats, PerformanceClock, TimedEvent};
    use rtrb::Consumer;

    fn net() -> (NetFeed, Consumer<TimedEvent>, Arc<OutputStats>) {
        let (tx, rx) = rtrb::RingBuffer::new(16);
        let feed = EventFeed::new(Kit::builtin_default(), 48_000.0, PerformanceClock::Estimated(None), tx);
        let stats = feed.stats().clone();
        (NetFeed::new(feed, Duration::from_millis(5)), rx, stats)
    }

    fn snare(time_s: f32) -> Message {
        Message::Contact(ContactMessage {
            piece: "snare".into(),
            time_s,
            speed_mps: 3.0,
            mass_kg: 0.012,
            x_m: 0.03,
            y_m: 0.0,
            impulse_ns: 0.0,
            hardness: 1.0,
            limb: Limb::LeftHand,
        })
    }

    fn tagged(msg: Message, at: Instant) -> Vec<u8> {
        let mut buf = Vec::new();
        encode_bundle(&[msg], WallClock::now().tag(at), &mut buf).unwrap();
        buf
    }

    fn close(a: Instant, b: Instant) -> bool {
        (if a > b { a - b } else { b - a }) < Duration::from_micros(50)
    }

    #[test]
    fn messages_with_equal_tags_are_not_reordered() {
        let (mut net, _rx, _) = net();
        let now = Instant::now();
        let tag = WallClock::now().tag(now + Duration::from_millis(20));
        for (i, time) in [1.0, 1.004, 1.004].into_iter().enumerate() {
            let mut buf = Vec::new();
            encode_bundle(&[snare(time + i as f32 * 1e-4)], tag, &mut buf).unwrap();
            net.take(&buf, now).unwrap();
        }
        assert_eq!(net.counts.reordered.load(Relaxed), 0);
        assert_eq!(net.counts.messages.load(Relaxed), 3);
    }

    #[test]
    fn each_message_sounds_at_its_tag_and_copies_are_ignored() {
        let (mut net, mut rx, _) = net();
        let now = Instant::now();
        let ms = Duration::from_millis;
        let (a, b) = (tagged(snare(1.0), now + ms(40)), tagged(snare(1.01), now + ms(30)));
        net.take(&a, now).unwrap();
        net.take(&b, now).unwrap(); // tagged earlier than the one before: reordered
        net.take(&a, now).unwrap(); // a copy
        assert!(close(rx.pop().unwrap().arrival, now + ms(40)));
        assert!(close(rx.pop().unwrap().arrival, now + ms(30)));
        assert!(rx.pop().is_err(), "the copy is not played");
        let c = &net.counts;
        assert_eq!(
            [&c.datagrams, &c.messages, &c.duplicates, &c.reordered, &c.late].map(|x| x.load(Relaxed)),
            [3, 2, 1, 1, 0]
        );
    }

    #[test]
    fn a_late_message_plays_at_once_and_an_untimed_one_after_the_latency() {
        let (mut net, mut rx, _) = net();
        let now = Instant::now();
        net.take(&tagged(snare(1.0), now - Duration::from_millis(80)), now).unwrap();
        assert_eq!(rx.pop().unwrap().arrival, now, "late: at once");
        assert_eq!(net.counts.late.load(Relaxed), 1);
        let mut buf = Vec::new();
        encode(&snare(2.0), &mut buf).unwrap();
        net.take(&buf, now).unwrap();
        assert_eq!(rx.pop().unwrap().arrival, now + Duration::from_millis(5));
    }

    #[test]
    fn hostile_datagrams_are_counted_and_named_never_queued() {
        let (mut net, mut rx, stats) = net();
        let now = Instant::now();
        let good = tagged(snare(1.0), now + Duration::from_millis(10));
        let mut nan = Vec::new();
        encode(&Message::HiHat { time_s: 1.0, openness: f32::NAN }, &mut nan).unwrap();
        let far = tagged(snare(1.0), now + Duration::from_secs(3600));
        let mut cowbell = snare(1.0);
        if let Message::Contact(c) = &mut cowbell {
            c.piece = "cowbell".into();
        }
        let mut unknown = Vec::new();
        encode(&cowbell, &mut unknown).unwrap();
        let cases: [(&[u8], &str); 6] = [
            (&good[..good.len() - 3], "decode"),
            (b"/drumsim/contact\0\0\0\0,i\0\0\0\0\0\x01", "expected ,sfffffffi"),
            (&nan, "finite"),
            (&far, "ahead"),
            (&unknown, "cowbell"),
            (&[0u8; 60_000], "decode"),
        ];
        for (datagram, why) in cases {
            let err = net.take(datagram, now).unwrap_err();
            assert!(err.contains(why), "{why}: {err}");
        }
        assert!(rx.pop().is_err());
        assert_eq!(stats.bad_messages.load(Relaxed), 6);
        net.take(&good, now).unwrap();
        assert!(rx.pop().is_ok(), "a good message after them still sounds");
    }
}
