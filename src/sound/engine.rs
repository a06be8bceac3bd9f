//! The sound engine: one voice per kit piece, events applied at their exact sample, a stereo
//! mix placed by each piece's position, and the master limiter; optionally each piece's own
//! dry signal (a stem: unpanned, before the limiter, delayed by the limiter's look-ahead so
//! that it lines up with the mix). `process` never allocates, locks or blocks: everything is
//! sized in `new` and [`Engine::with_stems`].

use super::bank::{Lane, LANES};
use super::limiter::Limiter;
use super::voice::Voice;
use super::{SoundEvent, SoundEventKind};
use crate::kit::Kit;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EngineSettings {
    pub sample_rate_hz: f32,
    /// Largest block `process` works on at once (longer buffers are split).
    pub max_block: usize,
    /// Capacity of the pending-event queue.
    pub event_capacity: usize,
}

impl Default for EngineSettings {
    fn default() -> Self {
        EngineSettings { sample_rate_hz: 48_000.0, max_block: 512, event_capacity: 1024 }
    }
}

/// Limiter ceiling: -0.5 dBFS.
pub const CEILING: f32 = 0.944;

pub struct Engine {
    pub(super) voices: Vec<Voice>,
    pub(super) pans: Vec<(f32, f32)>,
    /// Pending events, latest first (so the next one pops from the end).
    pub(super) queue: Vec<SoundEvent>,
    pub(super) time: u64,
    pub(super) max_block: usize,
    mono: Vec<f32>,
    acc: Vec<Lane>,
    pub(super) limiter: Limiter,
    dropped: u64,
    /// Per piece: the last block's stem, and its delay line (`with_stems`; empty without).
    pub(super) stems: Vec<Box<[f32]>>,
    stem_delays: Vec<Box<[f32]>>,
    /// Where the next sample enters the stems' delay lines.
    stem_slot: usize,
    /// Frames of the last block.
    pub(super) last_block: usize,
}

/// Every piece's voice, built on every core (a membrane's Bessel zeros and a plate's modes
/// take tens of milliseconds each), in the kit's order.
fn build_voices(kit: &Kit, sample_rate_hz: f32, max_block: usize) -> Vec<Voice> {
    let threads = super::offline::threads().clamp(1, kit.pieces.len().max(1));
    let build = |t: usize| -> Vec<(usize, Voice)> {
        (t..kit.pieces.len())
            .step_by(threads)
            .map(|i| (i, Voice::new(&kit.pieces[i], sample_rate_hz, max_block)))
            .collect()
    };
    let mut built: Vec<(usize, Voice)> = std::thread::scope(|s| {
        let others: Vec<_> = (1..threads).map(|t| s.spawn(move || build(t))).collect();
        let mut all = build(0);
        for h in others {
            all.extend(h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
        }
        all
    });
    built.sort_by_key(|(i, _)| *i);
    built.into_iter().map(|(_, v)| v).collect()
}

impl Engine {
    pub fn new(kit: &Kit, settings: EngineSettings) -> Engine {
        let max_block = settings.max_block.max(1);
        let voices = build_voices(kit, settings.sample_rate_hz, max_block);
        // Drummer's view: pieces to the drummer's right sound on the right.
        let pans = kit
            .pieces
            .iter()
            .map(|p| {
                let pan = (p.position_m[0] / 0.7).clamp(-1.0, 1.0);
                let angle = (pan + 1.0) * std::f32::consts::FRAC_PI_4;
                (angle.cos(), angle.sin())
            })
            .collect();
        Engine {
            voices,
            pans,
            queue: Vec::with_capacity(settings.event_capacity.max(1)),
            time: 0,
            max_block,
            mono: vec![0.0; max_block],
            acc: vec![[0.0; LANES]; max_block],
            limiter: Limiter::new(settings.sample_rate_hz, CEILING, 0.0015, 0.08),
            dropped: 0,
            stems: Vec::new(),
            stem_delays: Vec::new(),
            stem_slot: 0,
            last_block: 0,
        }
    }

    /// Also keep each piece's stem of every block (read with [`Engine::stem`]).
    pub fn with_stems(mut self) -> Engine {
        let n = self.voices.len();
        self.stems = (0..n).map(|_| vec![0.0; self.max_block].into()).collect();
        self.stem_delays = (0..n).map(|_| vec![0.0; self.limiter.latency()].into()).collect();
        self
    }

    /// The most frames one block holds (a stem covers the last block, at most this).
    pub fn max_block(&self) -> usize {
        self.max_block
    }

    /// Pieces with a stem: the kit's pieces after `with_stems`, else none.
    pub fn stem_count(&self) -> usize {
        self.stems.len()
    }

    /// Piece `piece`'s dry signal over the last block `process` rendered (at most `max_block`
    /// frames: the last chunk of a longer call), aligned with the mix.
    pub fn stem(&self, piece: usize) -> &[f32] {
        &self.stems[piece][..self.last_block]
    }

    /// The sample index the next `process` call starts at.
    pub fn sample_time(&self) -> u64 {
        self.time
    }

    /// Queue an event; false if the queue is full (the event is dropped and counted).
    /// Events in the past are applied at the start of the next block.
    pub fn push(&mut self, ev: SoundEvent) -> bool {
        if self.queue.len() == self.queue.capacity() {
            self.dropped += 1;
            return false;
        }
        // Latest first; equal times keep arrival order (the earlier arrival pops first).
        let at = self.queue.partition_point(|e| e.at_sample > ev.at_sample);
        self.queue.insert(at, ev);
        true
    }

    /// Events dropped because the queue was full.
    pub fn dropped_events(&self) -> u64 {
        self.dropped
    }

    /// Samples by which the output trails the events (the limiter's look-ahead).
    pub fn latency_samples(&self) -> usize {
        self.limiter.latency()
    }

    /// Samples the limiter found not finite (and silenced).
    pub fn non_finite_samples(&self) -> u64 {
        self.limiter.non_finite
    }

    /// True when no event is pending and nothing rings.
    pub fn is_silent(&self) -> bool {
        self.queue.is_empty() && self.voices.iter().all(|v| v.is_silent())
    }

    /// A piece's (left, right) gains in the mix.
    pub fn pan(&self, piece: usize) -> (f32, f32) {
        self.pans[piece]
    }

    pub fn voice(&self, piece: usize) -> &Voice {
        &self.voices[piece]
    }

    /// Render `left.len()` samples (left and right have equal length).
    pub fn process(&mut self, left: &mut [f32], right: &mut [f32]) {
        assert_eq!(left.len(), right.len(), "left and right buffers differ in length");
        for (l, r) in left.chunks_mut(self.max_block).zip(right.chunks_mut(self.max_block)) {
            self.process_block(l, r);
        }
    }

    fn process_block(&mut self, left: &mut [f32], right: &mut [f32]) {
        let n = left.len();
        left.fill(0.0);
        right.fill(0.0);
        let start = self.time;
        let mut pos = 0;
        while pos < n {
            while let Some(ev) = self.queue.last() {
                if ev.at_sample > start + pos as u64 {
                    break;
                }
                let ev = self.queue.pop().expect("queue has a last event");
                self.apply(&ev);
            }
            let next = match self.queue.last() {
                Some(ev) => ((ev.at_sample - start) as usize).min(n),
                None => n,
            };
            self.mix(&mut left[pos..next], &mut right[pos..next], pos);
            pos = next;
        }
        self.limiter.process(left, right);
        self.delay_stems(n);
        self.last_block = n;
        self.time += n as u64;
    }

    /// Delay the block's stems by the limiter's look-ahead, as the mix is.
    fn delay_stems(&mut self, n: usize) {
        let Some(len) = self.stem_delays.first().map(|d| d.len()) else { return };
        for (stem, delay) in self.stems.iter_mut().zip(self.stem_delays.iter_mut()) {
            let mut slot = self.stem_slot;
            for s in stem[..n].iter_mut() {
                std::mem::swap(s, &mut delay[slot]);
                slot = if slot + 1 == len { 0 } else { slot + 1 };
            }
        }
        self.stem_slot = (self.stem_slot + n) % len;
    }

    fn apply(&mut self, ev: &SoundEvent) {
        match ev.kind {
            SoundEventKind::Strike(s) => {
                if let Some(v) = self.voices.get_mut(s.piece) {
                    v.strike(&s);
                }
            }
            SoundEventKind::HiHat { openness } => {
                for v in self.voices.iter_mut().filter(|v| v.is_hihat()) {
                    v.set_openness(openness);
                }
            }
            SoundEventKind::Choke { piece } => {
                if let Some(v) = self.voices.get_mut(piece) {
                    v.choke();
                }
            }
        }
    }

    /// Mix the voices into `left` and `right`, which start `pos` frames into the block.
    fn mix(&mut self, left: &mut [f32], right: &mut [f32], pos: usize) {
        let n = left.len();
        for (k, (voice, &(gl, gr))) in self.voices.iter_mut().zip(self.pans.iter()).enumerate() {
            let stem = self.stems.get_mut(k).map(|s| &mut s[pos..pos + n]);
            if voice.is_silent() {
                if let Some(stem) = stem {
                    stem.fill(0.0);
                }
                continue;
            }
            let mono = &mut self.mono[..n];
            voice.render(mono, &mut self.acc);
            if let Some(stem) = stem {
                stem.copy_from_slice(mono);
            }
            for ((l, r), m) in left.iter_mut().zip(right.iter_mut()).zip(mono.iter()) {
                *l += gl * m;
                *r += gr * m;
            }
        }
    }
}
