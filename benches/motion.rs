//! The whole motion stage on a real 3-minute performance (Groove MIDI validation,
//! `drummer8/session2/37_rock_112_beat_4-4.mid`, 181 s, 10,856 frames): hand-model inference
//! with the shipped weights, strike planning on the default kit, retrieval of upper body and
//! face, feet (`motion_stage/all`), and its parts. Run: `cargo bench --bench motion`.

use criterion::{criterion_group, criterion_main, Criterion};
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform, shipped_library};
use std::hint::black_box;
use std::path::Path;

const SONG: &str = "data/gmd/drummer8/session2/37_rock_112_beat_4-4.mid";

fn bench(c: &mut Criterion) {
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::builtin_default();
    let perf = read_file(Path::new(SONG), &ReadOptions { channel: 10 }).expect("the Groove MIDI file");
    let model = HandModel::shipped();
    let library = shipped_library().unwrap();
    let predicted = model_hands(&model, &perf, &map);
    let mut g = c.benchmark_group("motion_stage");
    g.sample_size(10);
    g.bench_function("all", |b| {
        b.iter(|| {
            let predicted = model_hands(&model, &perf, &map);
            black_box(perform(&perf, &map, &kit, &predicted, &library).unwrap())
        })
    });
    g.bench_function("hands_inference", |b| b.iter(|| black_box(model_hands(&model, &perf, &map))));
    g.bench_function("plan_retrieve_feet", |b| {
        b.iter(|| black_box(perform(&perf, &map, &kit, &predicted, &library).unwrap()))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
