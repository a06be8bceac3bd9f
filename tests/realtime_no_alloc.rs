//! The audio callback's body never allocates: a counting global allocator watches
//! `Renderer::render` while strikes, hi-hat moves and chokes arrive through the ring, and the
//! engine rings, contacts, sleeps and limits. (Locks and blocking have no allocator to count;
//! the callback only pops from a wait-free rtrb ring and adds to atomics.)

use drumsim::kit::Kit;
use drumsim::sound::output::{OutputSettings, OutputStats, Renderer, TimedEvent};
use drumsim::sound::{Engine, EngineSettings, SoundEventKind, Strike};
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::Arc;
use std::time::Instant;

struct Counting;

thread_local! {
    static WATCHING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

// SAFETY: forwards every call to the system allocator unchanged; only counts, per thread.
#[allow(unsafe_code)]
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if WATCHING.with(|w| w.get()) {
            ALLOCATIONS.with(|a| a.set(a.get() + 1));
        }
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if WATCHING.with(|w| w.get()) {
            ALLOCATIONS.with(|a| a.set(a.get() + 1));
        }
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[test]
fn the_audio_callback_never_allocates() {
    play_a_burst(false);
}

/// With a stem per piece on channels 3.. (`--stems`) too.
#[test]
fn the_audio_callback_with_stems_never_allocates() {
    play_a_burst(true);
}

fn play_a_burst(stems: bool) {
    let kit = Kit::builtin_default();
    let settings = OutputSettings { stems, ..OutputSettings::default() };
    let engine = Engine::new(
        &kit,
        EngineSettings { sample_rate_hz: 48_000.0, max_block: settings.max_block, event_capacity: 1024 },
    );
    let engine = if stems { engine.with_stems() } else { engine };
    let channels = if stems { 2 + kit.pieces.len() } else { 2 };
    let (mut producer, consumer) = rtrb::RingBuffer::<TimedEvent>::new(1024);
    let stats = Arc::new(OutputStats::default());
    let mut renderer = Renderer::new(engine, consumer, channels, 48_000.0, &settings, stats.clone());
    let mut out = vec![0.0f32; channels * 256];
    let start = Instant::now();
    let mut strikes = 0;
    for block in 0..800 {
        // Every few blocks a burst: strikes on several pieces, a hi-hat move, a choke.
        if block % 6 == 0 {
            for (i, piece) in kit.pieces.iter().enumerate().skip(block / 6 % 3).step_by(3) {
                let kind = SoundEventKind::Strike(Strike {
                    piece: i,
                    speed_mps: 1.0 + (block % 9) as f32,
                    mass_kg: 0.045,
                    x_m: 0.0,
                    y_m: -0.4 * piece.radius_m,
                    hardness: 1.0,
                });
                producer.push(TimedEvent { arrival: Instant::now(), kind }).unwrap();
                strikes += 1;
            }
            let openness = (block % 12) as f32 / 12.0;
            producer.push(TimedEvent { arrival: Instant::now(), kind: SoundEventKind::HiHat { openness } }).unwrap();
            producer
                .push(TimedEvent {
                    arrival: Instant::now(),
                    kind: SoundEventKind::Choke { piece: kit.index_of("crash").unwrap() },
                })
                .unwrap();
        }
        WATCHING.with(|w| w.set(true));
        renderer.render(&mut out, start + std::time::Duration::from_micros(block as u64 * 5333));
        WATCHING.with(|w| w.set(false));
    }
    assert!(strikes > 400, "{strikes} strikes");
    assert!(out.iter().all(|v| v.is_finite()));
    if stems {
        let heard = |ch: usize| out.chunks_exact(channels).any(|f| f[ch] != 0.0);
        assert!((2..channels).filter(|&ch| heard(ch)).count() > 1, "the stems carry sound");
    }
    assert_eq!(stats.dropped_events.load(std::sync::atomic::Ordering::Relaxed), 0);
    assert_eq!(ALLOCATIONS.with(|a| a.get()), 0, "the audio callback allocated");
}
