//! Offline rendering on several cores: a window of blocks at a time, each voice rendered
//! through the whole window on its own (the voices share nothing but the mix), then mixed
//! and limited block by block as [`Engine::process`] does. The samples are the same bit for
//! bit: a voice's output does not depend on where its render is split, and the mix adds the
//! voices in the kit's order. Allocates and spawns threads: never for the audio thread.

use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

use super::bank::{Lane, LANES};
use super::denormals::with_flush_to_zero;
use super::engine::Engine;
use super::voice::Voice;

/// Threads an offline render and the engine's set-up use: `DRUMSIM_THREADS` if set (1: the
/// calling thread alone), else every core. The samples are the same whatever the number.
pub fn threads() -> usize {
    std::env::var("DRUMSIM_THREADS")
        .ok()
        .and_then(|v| v.trim().parse::<usize>().ok())
        .filter(|n| *n > 0)
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}
use super::SoundEventKind;

/// One voice's share of a window: its events (sample offset in the window, what), its
/// output and whether it was silent after each block.
struct Part<'a> {
    voice: &'a mut Voice,
    events: Vec<(usize, SoundEventKind)>,
    out: Vec<f32>,
    silent: Vec<bool>,
}

impl Engine {
    /// Render the next `left.len()` frames with the voices on up to `threads` threads (the
    /// calling thread alone for 1). `silent[b]` tells whether, after the `b`th block of
    /// `max_block` frames, no queued event was left in the window and every voice was silent
    /// (what [`Engine::is_silent`] would have said then). Engines with stems are not
    /// supported (the stems are the live server's).
    pub fn process_parallel(&mut self, left: &mut [f32], right: &mut [f32], silent: &mut [bool], threads: usize) {
        assert_eq!(left.len(), right.len(), "left and right buffers differ in length");
        assert!(self.stems.is_empty(), "process_parallel does not keep stems");
        let (n, block) = (left.len(), self.max_block);
        let blocks = n.div_ceil(block);
        assert!(silent.len() >= blocks, "one silence flag a block");
        let start = self.time;
        // Every queued event due in the window, to its voices, in the order the engine would
        // apply them (events in the past at the window's first sample).
        let mut parts: Vec<Part> = self
            .voices
            .iter_mut()
            .map(|voice| Part { voice, events: Vec::new(), out: vec![0.0; n], silent: vec![true; blocks] })
            .collect();
        let mut due_in_block = vec![0usize; blocks];
        while let Some(ev) = self.queue.last() {
            if ev.at_sample >= start + n as u64 {
                break;
            }
            let ev = self.queue.pop().expect("queue has a last event");
            let at = ev.at_sample.saturating_sub(start) as usize;
            due_in_block[at / block] += 1;
            match ev.kind {
                SoundEventKind::Strike(s) => {
                    parts.get_mut(s.piece).into_iter().for_each(|p| p.events.push((at, ev.kind)))
                }
                SoundEventKind::HiHat { .. } => {
                    parts.iter_mut().filter(|p| p.voice.is_hihat()).for_each(|p| p.events.push((at, ev.kind)))
                }
                SoundEventKind::Choke { piece } => {
                    parts.get_mut(piece).into_iter().for_each(|p| p.events.push((at, ev.kind)))
                }
            }
        }
        let pending_after = !self.queue.is_empty();
        // Where the engine would split its renders: every event's sample and every block's
        // end. A voice renders silent stretches or skips them as the engine would, which
        // keeps its sleep checks where they fall there.
        let mut cuts: Vec<usize> = parts.iter().flat_map(|p| p.events.iter().map(|(at, _)| *at)).collect();
        cuts.extend((1..=blocks).map(|b| (b * block).min(n)));
        cuts.sort_unstable();
        cuts.dedup();
        // The voices, each claimed once by whichever thread is free (the busy ones differ
        // from window to window).
        let parts: Vec<Mutex<Part>> = parts.into_iter().map(Mutex::new).collect();
        let next = AtomicUsize::new(0);
        let work = || {
            with_flush_to_zero(|| {
                let mut acc: Vec<Lane> = vec![[0.0; LANES]; block];
                loop {
                    let i = next.fetch_add(1, Ordering::Relaxed);
                    let Some(part) = parts.get(i) else { break };
                    let mut part = part.lock().unwrap_or_else(|e| e.into_inner());
                    render_part(&mut part, &cuts, block, &mut acc);
                }
            })
        };
        let threads = threads.clamp(1, parts.len().max(1));
        std::thread::scope(|s| {
            for _ in 1..threads {
                s.spawn(work);
            }
            work();
        });
        let parts: Vec<Part> = parts.into_iter().map(|p| p.into_inner().unwrap_or_else(|e| e.into_inner())).collect();
        // The mix, the limiter and the silence, block by block.
        left.fill(0.0);
        right.fill(0.0);
        let mut due_later = due_in_block.iter().sum::<usize>();
        for b in 0..blocks {
            let range = b * block..((b + 1) * block).min(n);
            for (part, &(gl, gr)) in parts.iter().zip(self.pans.iter()) {
                let mono = &part.out[range.clone()];
                for ((l, r), m) in left[range.clone()].iter_mut().zip(right[range.clone()].iter_mut()).zip(mono) {
                    *l += gl * m;
                    *r += gr * m;
                }
            }
            self.limiter.process(&mut left[range.clone()], &mut right[range]);
            due_later -= due_in_block[b];
            silent[b] = !pending_after && due_later == 0 && parts.iter().all(|p| p.silent[b]);
        }
        self.last_block = n - (blocks - 1) * block;
        self.time += n as u64;
    }
}

/// Render one voice through the window: its events at their samples, its renders split
/// at `cuts` (ascending, the last the window's end).
fn render_part(part: &mut Part, cuts: &[usize], block: usize, acc: &mut [Lane]) {
    let mut ev = 0;
    let mut pos = 0;
    for &next in cuts {
        while let Some(&(_, kind)) = part.events.get(ev).filter(|(at, _)| *at <= pos) {
            match kind {
                SoundEventKind::Strike(s) => part.voice.strike(&s),
                SoundEventKind::HiHat { openness } => part.voice.set_openness(openness),
                SoundEventKind::Choke { .. } => part.voice.choke(),
            }
            ev += 1;
        }
        if next > pos && !part.voice.is_silent() {
            part.voice.render(&mut part.out[pos..next], acc);
        }
        pos = next;
        if pos > 0 && (pos.is_multiple_of(block) || pos == part.out.len()) {
            part.silent[(pos - 1) / block] = part.voice.is_silent();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kit::Kit;
    use crate::sound::{EngineSettings, SoundEvent, Strike};

    /// A few seconds of every piece struck, the hi-hat opening and closing, a choke.
    fn events(kit: &Kit) -> Vec<SoundEvent> {
        let mut evs = Vec::new();
        for k in 0..40u64 {
            let piece = (k as usize * 7) % kit.pieces.len();
            let radius = kit.pieces[piece].radius_m;
            let strike = Strike {
                piece,
                speed_mps: 1.0 + (k % 5) as f32,
                mass_kg: 0.012,
                x_m: 0.1 * radius,
                y_m: -0.4 * radius,
                hardness: 1.0,
            };
            evs.push(SoundEvent { at_sample: 3_000 * k + (k * 37) % 700, kind: SoundEventKind::Strike(strike) });
            if k % 6 == 0 {
                let openness = (k % 12) as f32 / 12.0;
                evs.push(SoundEvent { at_sample: 3_000 * k + 1_111, kind: SoundEventKind::HiHat { openness } });
            }
        }
        evs.push(SoundEvent { at_sample: 61_000, kind: SoundEventKind::Choke { piece: 0 } });
        evs.sort_by_key(|e| e.at_sample);
        evs
    }

    #[test]
    fn voices_on_several_threads_give_the_samples_of_one() {
        let kit = Kit::builtin_default();
        let settings = EngineSettings { sample_rate_hz: 48_000.0, max_block: 512, event_capacity: 4096 };
        let evs = events(&kit);
        let frames = 160 * 512;
        // One block at a time, as the audio thread does.
        let mut one = Engine::new(&kit, settings);
        evs.iter().for_each(|e| assert!(one.push(*e)));
        let (mut l1, mut r1) = (vec![0.0f32; frames], vec![0.0f32; frames]);
        with_flush_to_zero(|| {
            for (l, r) in l1.chunks_mut(512).zip(r1.chunks_mut(512)) {
                one.process(l, r);
            }
        });
        // Windows of 24 blocks (the last one short) on three threads.
        let mut many = Engine::new(&kit, settings);
        evs.iter().for_each(|e| assert!(many.push(*e)));
        let (mut l2, mut r2) = (vec![0.0f32; frames], vec![0.0f32; frames]);
        let mut silent = vec![false; 24];
        for (l, r) in l2.chunks_mut(24 * 512).zip(r2.chunks_mut(24 * 512)) {
            many.process_parallel(l, r, &mut silent, 3);
        }
        assert!(l1.iter().any(|v| v.abs() > 1e-3));
        assert!(l1 == l2 && r1 == r2, "the threaded render differs");
        assert_eq!(silent[(frames % (24 * 512)) / 512 - 1], one.is_silent());
    }
}
