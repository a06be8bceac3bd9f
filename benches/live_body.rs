//! Speed of the live physical drummer on one core: the body's 10 kHz physics with the
//! sliding-window planning amortised (a window plan and its body targets every 50 ms), as
//! `drumsim live --sound physical` runs them, played on a simulated clock
//! (`perform::replay`) over a busy Groove MIDI fill and the first 10 s of a fast funk groove.
//!
//! `cargo bench --bench live_body` ends with a summary: simulated seconds per second of one
//! core (the ratio to real time).

use criterion::{Criterion, SamplingMode};
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::shipped_library;
use drumsim::perform::replay::{replay, ReplaySettings};
use std::path::Path;
use std::time::{Duration, Instant};

const TAKES: [(&str, f64); 2] = [
    ("drummer1/session1/17_jazz-funk_116_fill_4-4.mid", 4.0),
    ("drummer1/session1/126_funk-fast_125_beat_4-4.mid", 10.0),
];

fn bench(c: &mut Criterion) {
    let kit = Kit::builtin_default();
    let map = NoteMap::builtin("roland-td").expect("a built-in map");
    let mut group = c.benchmark_group("live_body");
    group.sampling_mode(SamplingMode::Flat).sample_size(10).measurement_time(Duration::from_secs(20));
    let mut summary = Vec::new();
    for (take, seconds) in TAKES {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd").join(take);
        let perf = read_file(&path, &ReadOptions { channel: 10 }).expect("a Groove MIDI take");
        let end = seconds.min(perf.notes_end_s + 0.5);
        let notes = perf.events.iter().filter(|e| e.time_s < end).count();
        let mut best = f64::INFINITY;
        group.bench_function(format!("{take}, {end:.0} s"), |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let (model, library) = (HandModel::shipped(), shipped_library().expect("the library"));
                    let start = Instant::now();
                    let r = replay(&kit, &map, model, library, &perf, end, &ReplaySettings::default()).expect("replay");
                    let took = start.elapsed();
                    std::hint::black_box(r.strikes.len());
                    best = best.min(took.as_secs_f64());
                    total += took;
                }
                total
            })
        });
        // The replay also plays the session's first second before the player starts.
        summary.push((take, end, notes, (end + 1.0) / best));
    }
    group.finish();
    println!("\nlive physical drummer on one core (body at 10 kHz, a window plan every 50 ms):");
    for (take, end, notes, ratio) in summary {
        println!(
            "  {take} ({end:.0} s, {notes} MIDI events): {ratio:.1}x real time ({:.0} % of a core)",
            100.0 / ratio
        );
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench(&mut c);
    c.final_summary();
}
