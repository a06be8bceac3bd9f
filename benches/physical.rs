//! The whole physical render of a real 3-minute performance (Groove MIDI validation,
//! `drummer8/session2/37_rock_112_beat_4-4.mid`, 181 s), through `render_file` as the command
//! line runs it: the motion stage, the body and its pedals at 10 kHz, the contacts as OSC into
//! the sound engine, the WAV, the contacts and the motion files. Its ratio to the song's
//! length is the real-time factor (DESIGN.md section 5). Run: `cargo bench --bench physical`
//! (10 samples of about half a minute each).

use criterion::{criterion_group, criterion_main, Criterion};
use drumsim::render::{render_file, RenderOptions, SoundMode};
use std::hint::black_box;
use std::path::Path;

const SONG: &str = "data/gmd/drummer8/session2/37_rock_112_beat_4-4.mid";

fn bench(c: &mut Criterion) {
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bench-physical");
    let opts =
        RenderOptions { out_dir: out, map: "roland-td".into(), sound: SoundMode::Physical, ..Default::default() };
    let mut g = c.benchmark_group("physical_render");
    g.sample_size(10);
    g.bench_function("rock_181s", |b| b.iter(|| black_box(render_file(Path::new(SONG), &opts).unwrap())));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
