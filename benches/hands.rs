//! Hand-model inference over 3 minutes of roll (10,800 frames at 60 fps), hidden 128: our
//! forward pass (`hand_infer/ours`, what drumsim runs: fixed-point streams; `ours_f32`, the
//! same streams in f32; `ours_one_stream`, the exact sequential pass in f32) and
//! burn's (`hand_infer/burn`) in the same process, so the ratio holds on a noisy machine.
//! Run: `cargo bench --bench hands`.

use burn::module::Module;
use burn::tensor::{Device, Tensor, TensorData};
use criterion::{criterion_group, criterion_main, Criterion};
use drumsim::learn::hand_net::HandNet;
use drumsim::motion::hands::streams::plan;
use drumsim::motion::hands::weights::HandWeights;
use drumsim::motion::hands::{HandModel, Normalisation, ROLL_COLUMNS};

const FRAMES: usize = 10_800;

fn roll() -> Vec<[f32; ROLL_COLUMNS]> {
    let mut s = 7u64;
    (0..FRAMES)
        .map(|_| {
            std::array::from_fn(|_| {
                s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                if (s >> 40) % 100 < 3 {
                    1.0
                } else {
                    0.0
                }
            })
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let device = Device::flex();
    device.seed(1);
    let net = HandNet::new(128, 0.1, &device);
    let path = std::env::temp_dir().join(format!("drumsim-bench-hands-{}.bpk", std::process::id()));
    net.clone().save_file(&path).expect("save weights");
    let model = HandModel::new(&HandWeights::load(&path).expect("load weights"), Normalisation::identity());
    let _ = std::fs::remove_file(&path);
    let roll = roll();

    let mut g = c.benchmark_group("hand_infer");
    g.sample_size(10);
    g.bench_function("ours", |b| b.iter(|| model.predict(std::hint::black_box(&roll))));
    // The same streams in f32, for the fixed point's share of the speed-up.
    let (streams, warmup) = plan(FRAMES);
    g.bench_function("ours_f32", |b| b.iter(|| model.forward_streams(std::hint::black_box(&roll), streams, warmup)));
    // The exact sequential pass (one stream, f32), for the streams' share.
    g.bench_function("ours_one_stream", |b| b.iter(|| model.forward_streams(std::hint::black_box(&roll), 1, 0)));
    let flat: Vec<f32> = roll.iter().flatten().copied().collect();
    g.bench_function("burn", |b| {
        b.iter(|| {
            let x = Tensor::<3>::from_data(TensorData::new(flat.clone(), [1, FRAMES, ROLL_COLUMNS]), &device);
            net.forward(x).into_data()
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
