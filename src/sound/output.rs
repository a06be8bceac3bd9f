//! Audio out, the real-time side: the audio callback, and the feed that hands it plain
//! events (devices and the cpal stream are in `device.rs`).
//!
//! ```text
//! packets (OSC) -> EventFeed: decode, resolve pieces -> rtrb ring -> audio callback: Engine
//! ```
//! The callback ([`Renderer`]) never allocates, locks, blocks or panics: it pops
//! [`TimedEvent`]s from a fixed-capacity ring, places each at a sample of the engine's clock,
//! renders into preallocated buffers and interleaves them. Problems are counted in
//! [`OutputStats`] for the main thread to report.

use super::{Engine, SoundEvent, SoundEventKind};
use crate::interaction::transport::{PacketReceiver, TransportError};
use crate::interaction::{decode, Message};
use crate::kit::Kit;
use rtrb::{Consumer, Producer};
use std::sync::atomic::{AtomicU64, Ordering::Relaxed};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// A resolved event and when it happened (on this machine's clock).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimedEvent {
    pub arrival: Instant,
    pub kind: SoundEventKind,
}

/// What went wrong on the real-time path, counted where it happened.
#[derive(Debug, Default)]
pub struct OutputStats {
    pub callbacks: AtomicU64,
    /// Events lost: the ring or the engine's queue was full.
    pub dropped_events: AtomicU64,
    /// Events that arrived after their look-ahead had passed (played as soon as possible).
    pub late_events: AtomicU64,
    /// Buffer under- or overruns the host reported.
    pub xruns: AtomicU64,
    /// Callbacks that took longer than the audio they rendered.
    pub overloads: AtomicU64,
    /// Messages the feed could not decode or resolve.
    pub bad_messages: AtomicU64,
    /// Host-reported time from callback to playback, microseconds.
    pub output_latency_us: AtomicU64,
    /// Times the audio clock re-locked after a jump (`audio_clock`: an xrun, a stall).
    pub clock_relocks: AtomicU64,
    /// Times the audio clock moved its phase by a step too small to re-lock.
    pub clock_steps: AtomicU64,
}

/// How to run the output.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputSettings {
    /// Used when the device supports it; otherwise its own rate.
    pub sample_rate_hz: u32,
    /// Asked for when the device allows a choice (JACK's period is the server's).
    pub buffer_frames: u32,
    /// Every event sounds this long after it arrived (0: as soon as possible).
    pub lookahead: Duration,
    /// Frames rendered at once; longer host buffers are rendered in chunks.
    pub max_block: usize,
    pub event_capacity: usize,
    /// Also each kit piece's own dry signal, one channel each after the stereo mix
    /// (`--stems`): channel 3 is the kit's first piece.
    pub stems: bool,
}

impl Default for OutputSettings {
    fn default() -> Self {
        OutputSettings {
            sample_rate_hz: 48_000,
            buffer_frames: 256,
            lookahead: Duration::ZERO,
            max_block: 1024,
            event_capacity: 1024,
            stems: false,
        }
    }
}

/// The sample index at which an event that arrived at `arrival` sounds, in a block that
/// starts at `block_sample` and was entered at `block_instant`: `lookahead` after arrival,
/// never before the block.
pub fn sample_for(arrival: Instant, lookahead: Duration, block_instant: Instant, block_sample: u64, fs: f64) -> u64 {
    let due = arrival.checked_add(lookahead).unwrap_or(arrival);
    match due.checked_duration_since(block_instant) {
        Some(ahead) => block_sample.saturating_add((ahead.as_secs_f64() * fs).round() as u64),
        None => block_sample,
    }
}

/// The audio callback's state.
pub struct Renderer {
    engine: Engine,
    events: Consumer<TimedEvent>,
    left: Box<[f32]>,
    right: Box<[f32]>,
    channels: usize,
    fs: f64,
    lookahead: Duration,
    /// The engine's own delay, samples: taken off each event's sample, so that an event due
    /// at an instant leaves the engine then (where the block still has room: never before it).
    latency: u64,
    stats: Arc<OutputStats>,
}

impl Renderer {
    pub fn new(
        engine: Engine,
        events: Consumer<TimedEvent>,
        channels: usize,
        fs: f64,
        settings: &OutputSettings,
        stats: Arc<OutputStats>,
    ) -> Renderer {
        // No longer than the engine's block, so that each chunk's stems are whole.
        let block = settings.max_block.min(engine.max_block()).max(1);
        Renderer {
            latency: engine.latency_samples() as u64,
            engine,
            events,
            left: vec![0.0; block].into(),
            right: vec![0.0; block].into(),
            channels: channels.max(1),
            fs,
            lookahead: settings.lookahead,
            stats,
        }
    }

    /// Fill `out` (interleaved, `channels` per frame) with the next frames. Real-time safe.
    pub fn render(&mut self, out: &mut [f32], block_instant: Instant) {
        self.stats.callbacks.fetch_add(1, Relaxed);
        let block_sample = self.engine.sample_time();
        while let Ok(ev) = self.events.pop() {
            if !self.lookahead.is_zero() && ev.arrival.checked_add(self.lookahead).is_some_and(|d| d < block_instant) {
                self.stats.late_events.fetch_add(1, Relaxed);
            }
            let due = sample_for(ev.arrival, self.lookahead, block_instant, block_sample, self.fs);
            let at_sample = due.saturating_sub(self.latency).max(block_sample);
            if !self.engine.push(SoundEvent { at_sample, kind: ev.kind }) {
                self.stats.dropped_events.fetch_add(1, Relaxed);
            }
        }
        let per_chunk = self.left.len() * self.channels;
        for chunk in out.chunks_mut(per_chunk) {
            let frames = chunk.len() / self.channels;
            let (left, right) = (&mut self.left[..frames], &mut self.right[..frames]);
            self.engine.process(left, right);
            interleave(left, right, chunk, self.channels);
            for k in 0..self.engine.stem_count().min(self.channels.saturating_sub(2)) {
                for (frame, s) in chunk.chunks_exact_mut(self.channels).zip(self.engine.stem(k)) {
                    frame[2 + k] = *s;
                }
            }
        }
    }
}

/// Write a stereo pair into `out`: mono gets the mix, channels past the second get silence.
fn interleave(left: &[f32], right: &[f32], out: &mut [f32], channels: usize) {
    let frames = out.chunks_exact_mut(channels);
    for ((frame, l), r) in frames.zip(left).zip(right) {
        match frame {
            [mono] => *mono = 0.5 * (l + r),
            [a, b, rest @ ..] => {
                *a = *l;
                *b = *r;
                rest.fill(0.0);
            }
            [] => {}
        }
    }
    let whole = left.len().min(out.len() / channels) * channels;
    out[whole..].fill(0.0);
}

/// Maps a message's performance time (seconds) to an instant on this machine's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PerformanceClock {
    /// The sender shares this process's clock: time 0 is this instant.
    Epoch(Instant),
    /// A sender elsewhere: time 0 is estimated as the earliest `received - time_s` seen.
    Estimated(Option<Instant>),
}

impl PerformanceClock {
    pub fn arrival(&mut self, time_s: f32, received: Instant) -> Instant {
        let t = Duration::try_from_secs_f64(f64::from(time_s)).unwrap_or(Duration::ZERO);
        let epoch = match self {
            PerformanceClock::Epoch(epoch) => *epoch,
            PerformanceClock::Estimated(epoch) => {
                let candidate = received.checked_sub(t).unwrap_or(received);
                let earliest = epoch.map_or(candidate, |e| e.min(candidate));
                *epoch = Some(earliest);
                earliest
            }
        };
        epoch.checked_add(t).unwrap_or(received)
    }
}

/// Decodes packets, resolves pieces against the kit and queues plain events for the callback.
pub struct EventFeed {
    kit: Kit,
    sample_rate_hz: f32,
    clock: PerformanceClock,
    ring: Producer<TimedEvent>,
    stats: Arc<OutputStats>,
}

impl EventFeed {
    pub fn new(kit: Kit, sample_rate_hz: f32, clock: PerformanceClock, ring: Producer<TimedEvent>) -> EventFeed {
        EventFeed { kit, sample_rate_hz, clock, ring, stats: Arc::default() }
    }

    /// Count into these stats (the output's, so one report covers the whole path).
    pub fn with_stats(mut self, stats: Arc<OutputStats>) -> EventFeed {
        self.stats = stats;
        self
    }

    /// Handle one packet; an error names the message at fault (it is counted and skipped).
    pub fn feed(&mut self, packet: &[u8]) -> Result<(), String> {
        let received = Instant::now();
        let messages = decode(packet).map_err(|e| self.bad(e.to_string()))?;
        for msg in &messages {
            self.push(msg, received)?;
        }
        Ok(())
    }

    fn push(&mut self, msg: &Message, received: Instant) -> Result<(), String> {
        let arrival = self.clock.arrival(msg.time_s(), received);
        self.push_at(msg, arrival)
    }

    /// Queue `msg` to sound at `arrival` (plus the output's lookahead), whatever its time.
    pub fn push_at(&mut self, msg: &Message, arrival: Instant) -> Result<(), String> {
        let ev = SoundEvent::from_message(msg, &self.kit, self.sample_rate_hz).map_err(|e| self.bad(e.to_string()))?;
        if self.ring.push(TimedEvent { arrival, kind: ev.kind }).is_err() {
            self.stats.dropped_events.fetch_add(1, Relaxed);
        }
        Ok(())
    }

    /// The counters this feed adds to.
    pub fn stats(&self) -> &Arc<OutputStats> {
        &self.stats
    }

    /// Count a message refused before it reached the feed; returns its description.
    pub fn bad(&self, message: String) -> String {
        self.stats.bad_messages.fetch_add(1, Relaxed);
        message
    }

    /// Feed every packet that arrives until the sender is gone; bad messages are reported on
    /// stderr and skipped.
    pub fn run(mut self, packets: &mut dyn PacketReceiver) -> Result<(), TransportError> {
        loop {
            match packets.recv_timeout(Duration::from_millis(200)) {
                Ok(Some(packet)) => {
                    if let Err(e) = self.feed(packet) {
                        eprintln!("drumsim: skipped a message: {e}");
                    }
                }
                Ok(None) => {}
                Err(TransportError::Disconnected) => return Ok(()),
                Err(e) => return Err(e),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interaction::{encode, ContactMessage, Limb};
    use crate::sound::{EngineSettings, Strike};

    const FS: f64 = 48_000.0;

    fn snare(kit: &Kit) -> SoundEventKind {
        let piece = kit.index_of("snare").unwrap();
        SoundEventKind::Strike(Strike { piece, speed_mps: 4.0, mass_kg: 0.03, x_m: 0.03, y_m: 0.0, hardness: 1.0 })
    }

    fn renderer(kit: &Kit, max_block: usize, channels: usize) -> (Renderer, Producer<TimedEvent>) {
        let (tx, rx) = rtrb::RingBuffer::new(8);
        let settings = OutputSettings { max_block, ..Default::default() };
        let engine = Engine::new(kit, EngineSettings { sample_rate_hz: FS as f32, max_block, event_capacity: 8 });
        (Renderer::new(engine, rx, channels, FS, &settings, Arc::default()), tx)
    }

    #[test]
    fn arrival_maps_to_a_sample_never_before_the_block() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        assert_eq!(sample_for(t0, ms(0), t0 + ms(3), 1000, FS), 1000, "late events play at the block start");
        assert_eq!(sample_for(t0 + ms(2), ms(0), t0, 1000, FS), 1096);
        assert_eq!(sample_for(t0, ms(10), t0 + ms(4), 1000, FS), 1288, "lookahead 10 ms, 4 ms into it");
    }

    #[test]
    fn interleaving_serves_any_channel_count() {
        let (l, r) = ([1.0, 2.0], [3.0, 4.0]);
        let mut mono = [9.0; 2];
        interleave(&l, &r, &mut mono, 1);
        assert_eq!(mono, [2.0, 3.0]);
        let mut quad = [9.0; 9]; // two frames of four, and a stray sample
        interleave(&l, &r, &mut quad, 4);
        assert_eq!(quad, [1.0, 3.0, 0.0, 0.0, 2.0, 4.0, 0.0, 0.0, 0.0]);
    }

    #[test]
    fn stems_carry_each_piece_alone_and_add_up_to_the_mix() {
        let kit = Kit::builtin_default();
        let (tx, rx) = rtrb::RingBuffer::new(8);
        let settings = OutputSettings { max_block: 64, stems: true, ..Default::default() };
        let engine = Engine::new(&kit, EngineSettings { sample_rate_hz: FS as f32, max_block: 64, event_capacity: 8 })
            .with_stems();
        let channels = 2 + kit.pieces.len();
        let mut r = Renderer::new(engine, rx, channels, FS, &settings, Arc::default());
        let mut tx = tx;
        let block = Instant::now();
        let kick = kit.index_of("kick").unwrap();
        let mut strike = snare(&kit);
        tx.push(TimedEvent { arrival: block, kind: strike }).unwrap();
        if let SoundEventKind::Strike(s) = &mut strike {
            s.piece = kick;
        }
        tx.push(TimedEvent { arrival: block + Duration::from_millis(3), kind: strike }).unwrap();
        let mut out = vec![0.0; channels * 2400];
        r.render(&mut out, block);
        let snare_ch = 2 + kit.index_of("snare").unwrap();
        let first = |ch: usize| out.chunks_exact(channels).position(|f| f[ch].abs() > 1e-6);
        let (l, s, k) = (first(0).unwrap(), first(snare_ch).unwrap(), first(2 + kick).unwrap());
        assert_eq!(s, l, "the snare's stem starts with the mix");
        // The snare was due at the block's start: no room to take the engine's delay off.
        assert!((72..80).contains(&s), "the snare sounds after the limiter's delay: {s}");
        // The kick, due 3 ms in (144 samples), sounds then, its beater's force rising from 0.
        assert!((144..152).contains(&k), "the kick's stem starts when it was due: {k}");
        let silent = (0..kit.pieces.len()).filter(|&p| p != kick && 2 + p != snare_ch);
        assert!(silent.into_iter().all(|p| out.chunks_exact(channels).all(|f| f[2 + p] == 0.0)));
        // Unpanned, unlimited: the mix is the stems panned (the limiter stays at unity here).
        let (gl, gr) = r.engine.pan(kick);
        let (sl, sr) = r.engine.pan(snare_ch - 2);
        for f in out.chunks_exact(channels) {
            assert!((f[0] - (sl * f[snare_ch] + gl * f[2 + kick])).abs() < 1e-4);
            assert!((f[1] - (sr * f[snare_ch] + gr * f[2 + kick])).abs() < 1e-4);
        }
    }

    #[test]
    fn a_strike_sounds_at_its_arrival_sample_through_chunked_blocks() {
        let kit = Kit::builtin_default();
        let (mut r, mut tx) = renderer(&kit, 64, 2);
        let mut out = vec![1.0; 2 * 300]; // longer than max_block: rendered in chunks
        r.render(&mut out, Instant::now());
        assert_eq!(r.engine.sample_time(), 300);
        assert!(out.iter().all(|&s| s == 0.0), "silence before any event");
        let block = Instant::now();
        tx.push(TimedEvent { arrival: block + Duration::from_millis(2), kind: snare(&kit) }).unwrap();
        let mut out = vec![0.0; 2 * 512];
        r.render(&mut out, block);
        let first = out.iter().position(|s| s.abs() > 1e-6).expect("the strike sounds") / 2;
        // 2 ms after the block: the engine's delay (1.5 ms) is taken off where there is room.
        let expected = 96;
        assert!((expected..expected + 48).contains(&first), "first sound at frame {first}, expected {expected}");
        assert_eq!(r.stats.dropped_events.load(Relaxed), 0);
    }

    #[test]
    fn shared_clock_is_exact_and_estimated_clock_keeps_the_earliest_epoch() {
        let t0 = Instant::now();
        let ms = Duration::from_millis;
        assert_eq!(PerformanceClock::Epoch(t0).arrival(1.5, t0 + ms(9000)), t0 + ms(1500));
        let mut clock = PerformanceClock::Estimated(None);
        assert_eq!(clock.arrival(1.0, t0 + ms(1010)), t0 + ms(1010), "first message: 10 ms transit assumed 0");
        assert_eq!(clock.arrival(2.0, t0 + ms(2002)), t0 + ms(2002), "a faster message moves the epoch back");
        assert_eq!(clock.arrival(3.0, t0 + ms(3050)), t0 + ms(3002), "a slow one does not");
        assert_eq!(clock.arrival(f32::NAN, t0), PerformanceClock::Estimated(Some(t0 + ms(2))).arrival(0.0, t0));
    }

    #[test]
    fn feed_resolves_pieces_and_counts_bad_messages() {
        let kit = Kit::builtin_default();
        let (tx, mut rx) = rtrb::RingBuffer::new(4);
        let t0 = Instant::now();
        let mut feed = EventFeed::new(kit.clone(), FS as f32, PerformanceClock::Epoch(t0), tx);
        let mut msg = ContactMessage {
            piece: "snare".into(),
            time_s: 0.25,
            speed_mps: 4.0,
            mass_kg: 0.03,
            x_m: 0.03,
            y_m: 0.0,
            impulse_ns: 0.0,
            hardness: 1.0,
            limb: Limb::LeftHand,
        };
        let mut buf = Vec::new();
        encode(&Message::Contact(msg.clone()), &mut buf).unwrap();
        feed.feed(&buf).unwrap();
        assert_eq!(rx.pop().unwrap(), TimedEvent { arrival: t0 + Duration::from_millis(250), kind: snare(&kit) });
        msg.piece = "cowbell".into();
        encode(&Message::Contact(msg), &mut buf).unwrap();
        assert!(feed.feed(&buf).unwrap_err().contains("cowbell"));
        assert!(feed.feed(b"not osc").is_err());
        assert_eq!(feed.stats.bad_messages.load(Relaxed), 2);
        assert!(rx.pop().is_err());
    }
}
