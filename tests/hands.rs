//! The hand model: our forward pass against burn's, checkpoint loading errors, and a smoke
//! training run on synthetic data whose loss must fall.

use std::path::{Path, PathBuf};

use burn::module::Module;
use burn::nn::{BiLstmConfig, DropoutConfig, LinearConfig};
use burn::tensor::{Device, Tensor, TensorData};
use drumsim::learn::hand_net::HandNet;
use drumsim::learn::{train, Example, TrainConfig};
use drumsim::motion::hands::weights::HandWeights;
use drumsim::motion::hands::{HandModel, HandsError, Kernels, Normalisation, ROLL_COLUMNS};
use drumsim::motion::HAND_VALUES;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("drumsim-hands-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A deterministic pseudo-random stream in [0, 1).
struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn random_roll(frames: usize, density: f32, seed: u64) -> Vec<[f32; ROLL_COLUMNS]> {
    let mut r = Lcg(seed);
    (0..frames).map(|_| std::array::from_fn(|_| if r.next() < density { 1.0 } else { 0.0 })).collect()
}

fn burn_forward(net: &HandNet, roll: &[[f32; ROLL_COLUMNS]]) -> Vec<[f32; HAND_VALUES]> {
    let device = Device::flex();
    let x: Vec<f32> = roll.iter().flatten().copied().collect();
    let x = Tensor::<3>::from_data(TensorData::new(x, [1, roll.len(), ROLL_COLUMNS]), &device);
    let y: Vec<f32> = net.forward(x).into_data().try_into_vec::<f32>().unwrap();
    y.chunks_exact(HAND_VALUES).map(|c| std::array::from_fn(|i| c[i])).collect()
}

/// A randomly initialised network saved to `dir/net.bpk`, and loaded back into our layout.
fn saved_random_net(dir: &Path, hidden: usize, seed: u64) -> (HandNet, HandModel) {
    let device = Device::flex();
    device.seed(seed);
    let net = HandNet::new(hidden, 0.1, &device);
    let path = dir.join("net.bpk");
    net.clone().save_file(&path).unwrap();
    let weights = HandWeights::load(&path).unwrap();
    assert_eq!(weights.hidden, hidden);
    (net, HandModel::new(&weights, Normalisation::identity()))
}

#[test]
fn our_forward_equals_burns_within_1e4() {
    let dir = scratch("equal");
    for (hidden, seed, lengths) in [(12, 1, vec![1, 2, 7, 61]), (128, 2, vec![1, 5, 333])] {
        let (net, ours) = saved_random_net(&dir, hidden, seed);
        for (i, &len) in lengths.iter().enumerate() {
            let roll = random_roll(len, 0.15, seed * 100 + i as u64);
            let expected = burn_forward(&net, &roll);
            let worst = |got: &[[f32; HAND_VALUES]]| {
                assert_eq!(got.len(), len);
                got.iter()
                    .zip(&expected)
                    .flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs()))
                    .fold(0.0f32, f32::max)
            };
            // The f32 pass (one stream, exact) and the fixed-point one the product runs.
            let exact = worst(&ours.forward_streams(&roll, 1, 0));
            let fixed = worst(&ours.forward_normalised(&roll));
            let scale = expected.iter().flatten().map(|v| v.abs()).fold(0.0f32, f32::max);
            println!("hidden {hidden}, {len} frames: max |ours - burn| = {exact:.2e} in f32, {fixed:.2e} in fixed point (outputs up to {scale:.3})");
            assert!(scale > 1e-3, "outputs too small to compare");
            assert!(exact <= 1e-4, "hidden {hidden}, {len} frames: max difference {exact}");
            assert!(fixed <= 1e-3, "hidden {hidden}, {len} frames: fixed point differs by {fixed}");
        }
        assert!(ours.forward_normalised(&[]).is_empty(), "0 frames give an empty output");
    }
}

#[test]
fn predict_denormalises() {
    let dir = scratch("denorm");
    let (_, plain) = saved_random_net(&dir, 8, 3);
    let weights = HandWeights::load(&dir.join("net.bpk")).unwrap();
    let norm = Normalisation { mean: std::array::from_fn(|c| c as f32), std: [2.0; HAND_VALUES] };
    let scaled = HandModel::new(&weights, norm.clone());
    let roll = random_roll(20, 0.2, 9);
    for (a, b) in plain.forward_normalised(&roll).iter().zip(scaled.predict(&roll)) {
        for c in 0..HAND_VALUES {
            assert!((a[c] * 2.0 + c as f32 - b[c]).abs() < 1e-5);
        }
    }
}

#[test]
fn load_errors_name_the_file_and_never_panic() {
    let dir = scratch("errors");
    let missing = dir.join("nope.bpk");
    let e = HandWeights::load(&missing).unwrap_err();
    assert!(matches!(e, HandsError::Read { .. }) && e.to_string().contains("nope.bpk"), "{e}");

    let corrupt = dir.join("corrupt.bpk");
    std::fs::write(&corrupt, b"this is not a burnpack file at all, just some bytes").unwrap();
    let e = HandModel::load(&corrupt).unwrap_err();
    assert!(e.to_string().contains("corrupt.bpk"), "{e}");

    // A truncated real file.
    let (net, _) = saved_random_net(&dir, 8, 4);
    let bytes = std::fs::read(dir.join("net.bpk")).unwrap();
    let truncated = dir.join("truncated.bpk");
    std::fs::write(&truncated, &bytes[..bytes.len() / 2]).unwrap();
    let e = HandWeights::load(&truncated).unwrap_err();
    assert!(e.to_string().contains("truncated.bpk"), "{e}");

    // Layer 2 narrower than layer 1: a shape error naming the tensor.
    let device = Device::flex();
    let odd = HandNet {
        lstm1: BiLstmConfig::new(ROLL_COLUMNS, 8, true).init(&device),
        dropout: DropoutConfig::new(0.1).init(),
        lstm2: BiLstmConfig::new(16, 6, true).init(&device),
        head: LinearConfig::new(12, HAND_VALUES).init(&device),
    };
    let odd_path = dir.join("odd.bpk");
    odd.save_file(&odd_path).unwrap();
    let e = HandWeights::load(&odd_path).unwrap_err();
    assert!(matches!(e, HandsError::Shape { .. }) && e.to_string().contains("odd.bpk"), "{e}");
    assert!(e.to_string().contains("lstm2."), "{e}");

    // Weights fine but no normalisation sidecar.
    net.save_file(dir.join("alone.bpk")).unwrap();
    let e = HandModel::load(&dir.join("alone.bpk")).unwrap_err();
    assert!(e.to_string().contains("alone.json"), "{e}");
}

/// Synthetic teacher: each hand rests, jumps to a per-note place at each onset of one of
/// its notes (even columns left, odd right) and decays back; the quaternion tilts with the
/// height. A deterministic function of the roll that needs memory of past onsets.
fn synthetic_example(id: usize, frames: usize) -> Example {
    let roll = random_roll(frames, 0.02, 1000 + id as u64);
    let rest = [[-0.2f32, 0.3, 0.8], [0.2, 0.3, 0.8]];
    let place = |n: usize| [(n as f32 - 7.5) * 0.05, 0.4 + (n % 3) as f32 * 0.1, 0.7 + (n % 4) as f32 * 0.05];
    let mut pos = rest;
    let mut hands = Vec::with_capacity(frames);
    for x in &roll {
        for (side, p) in pos.iter_mut().enumerate() {
            for i in 0..3 {
                p[i] = rest[side][i] + (p[i] - rest[side][i]) * 0.9;
            }
            if let Some(n) = (0..ROLL_COLUMNS).filter(|n| n % 2 == side).find(|&n| x[n] > 0.0) {
                *p = place(n);
            }
        }
        let mut v = [0.0f32; HAND_VALUES];
        for side in 0..2 {
            let a = (pos[side][2] - 0.8) * 2.0;
            v[side * 7..side * 7 + 3].copy_from_slice(&pos[side]);
            v[side * 7 + 3..side * 7 + 7].copy_from_slice(&[a.cos(), a.sin(), 0.0, 0.0]);
        }
        hands.push(v);
    }
    Example { id: format!("synthetic-{id}"), roll, hands }
}

#[test]
fn smoke_training_lowers_validation_loss_and_resumes() {
    let dir = scratch("train");
    let train_set: Vec<Example> = (0..24).map(|i| synthetic_example(i, 150)).collect();
    let val_set: Vec<Example> = (100..104).map(|i| synthetic_example(i, 150)).collect();
    let cfg = TrainConfig { epochs: 25, window: 60, batch: 8, hidden: 16, lr: 1e-2, ..TrainConfig::default() };
    let mut seen = Vec::new();
    let first = train(&train_set, &val_set, cfg.clone(), &dir, false, |e| seen.push(e.clone())).unwrap();
    assert_eq!(first.epoch, 25);
    assert_eq!(seen.len(), 25);
    println!("initial val {:.4}, per epoch {:?}", first.initial_val_loss, first.val_loss_history);
    assert!(
        first.best_val_loss < 0.7 * first.initial_val_loss,
        "validation loss {} did not fall enough from {}",
        first.best_val_loss,
        first.initial_val_loss
    );

    // Resume to 28 epochs: the history continues rather than restarting.
    let resumed = train(&train_set, &val_set, TrainConfig { epochs: 28, ..cfg.clone() }, &dir, false, |_| {}).unwrap();
    assert_eq!(resumed.epoch, 28);
    assert_eq!(resumed.val_loss_history.len(), 28);
    assert_eq!(resumed.val_loss_history[..25], first.val_loss_history[..]);
    assert!(resumed.best_val_loss <= first.best_val_loss);
    // Already there: nothing to train is an error, not a claim to have written weights.
    let again = train(&train_set, &val_set, TrainConfig { epochs: 28, ..cfg.clone() }, &dir, false, |_| {});
    let Err(msg) = again.map_err(|e| e.to_string()) else { panic!("trained past its epochs") };
    assert!(msg.contains("already at epoch 28") && msg.contains("nothing was trained"), "{msg}");

    // A spent budget stops before any epoch and leaves a resumable state.
    let stopped =
        train(&train_set, &val_set, TrainConfig { epochs: 40, max_minutes: Some(0.0), ..cfg }, &dir, false, |_| {})
            .unwrap();
    assert!(stopped.stopped_by_budget);
    assert_eq!(stopped.epoch, 28);

    // A different loss (the velocity term) resumes the weights but measures the best afresh.
    let relossed = train(
        &train_set,
        &val_set,
        TrainConfig { epochs: 29, velocity_weight: cfg.velocity_weight + 1.0, ..cfg.clone() },
        &dir,
        false,
        |_| {},
    )
    .unwrap();
    assert_eq!(relossed.loss_changed_after, vec![28]);
    assert_eq!(relossed.best_epoch, 29);
    assert!(relossed.val_loss > resumed.val_loss, "a heavier velocity term adds to the loss");

    // The best checkpoint loads for inference and its predictions beat the mean pose.
    let model = HandModel::load(&dir.join("best.bpk")).unwrap();
    let ex = &val_set[0];
    let pred = model.predict(&ex.roll);
    let norm = &resumed.normalisation;
    let err = |p: &[[f32; HAND_VALUES]]| -> f32 {
        p.iter().zip(&ex.hands).map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>()).sum::<f32>()
    };
    let mean_pose = vec![norm.mean; ex.roll.len()];
    assert!(err(&pred) < err(&mean_pose), "trained {} vs mean pose {}", err(&pred), err(&mean_pose));
}

/// Three minutes of real playing: Groove MIDI validation takes' rolls end to end.
fn gmd_roll(frames: usize) -> Vec<[f32; ROLL_COLUMNS]> {
    use drumsim::midi::roll::piano_roll;
    use drumsim::midi::{read_file, NoteMap, ReadOptions};
    let gmd = Path::new("data/gmd");
    let info = std::fs::read_to_string(gmd.join("info.csv")).expect("GMD info.csv");
    let map = NoteMap::builtin("roland-td").unwrap();
    let mut roll = Vec::new();
    for line in info.lines().skip(1).filter(|l| l.ends_with(",validation")) {
        let perf = read_file(&gmd.join(line.split(',').nth(7).unwrap()), &ReadOptions { channel: 10 }).unwrap();
        roll.extend(piano_roll(&perf, &map).frames.iter().map(|f| f.map(|on| if on { 1.0 } else { 0.0 })));
        if roll.len() >= frames {
            break;
        }
    }
    roll.truncate(frames);
    roll
}

#[test]
fn chunked_inference_matches_the_sequential_pass() {
    // Three minutes of real playing through the shipped model: the parallel streams (each
    // chunk after a warm-up from the zero state) against the one exact sequential pass.
    let model = HandModel::load(Path::new("assets/hands/best.bpk")).unwrap();
    let roll = gmd_roll(10_800);
    assert_eq!(roll.len(), 10_800);
    let (streams, warmup) = drumsim::motion::hands::streams::plan(roll.len());
    assert!(streams > 1, "three minutes run as several streams");
    let exact = model.forward_streams(&roll, 1, 0);
    let worst = |out: &[[f32; HAND_VALUES]]| {
        out.iter().zip(&exact).flat_map(|(a, b)| a.iter().zip(b).map(|(x, y)| (x - y).abs())).fold(0.0f32, f32::max)
    };
    let chunked = worst(&model.forward_streams(&roll, streams, warmup));
    let scale = exact.iter().flatten().map(|v| v.abs()).fold(0.0f32, f32::max);
    println!("{streams} streams, {warmup} frames of warm-up: max |chunked - sequential| = {chunked:.2e} (outputs up to {scale:.2})");
    assert!(scale > 0.5, "outputs too small to compare");
    // 1e-3 of a normalised output is about a tenth of a millimetre of hand position.
    assert!(chunked <= 1e-3, "chunked inference differs by {chunked}");

    // The fixed point rounds every product to 13-15 bits. Measured in what it moves: the
    // grips (millimetres) and the sticks' quaternion components, each worst over the song.
    let std = model.normalisation().std;
    let physical = |out: &[[f32; HAND_VALUES]]| {
        let (mut grip_mm, mut quat) = (0.0f32, 0.0f32);
        for (a, b) in out.iter().zip(&exact) {
            for c in 0..HAND_VALUES {
                let d = (a[c] - b[c]).abs() * std[c];
                if c % 7 < 3 {
                    grip_mm = grip_mm.max(d * 1000.0);
                } else {
                    quat = quat.max(d);
                }
            }
        }
        (grip_mm, quat)
    };
    // The six streams renders use keep their bound of 5e-3 of a normalised output. Fewer
    // streams than a group of six (shorter songs) run their recurrences together too, and
    // chunk edges move the rounding either way; for every count the bound is in what the
    // rounding moves: 1 mm at the grip, and 1.25e-3 of a quaternion component (0.14 degrees:
    // 1 mm at the tip of a 40 cm stick). Measured: at most 0.77 mm and 1.1e-3.
    for few in [6, 1, 2, 3, 4, 5] {
        let out = if few == 6 {
            model.forward_normalised(&roll)
        } else {
            model.forward_with(&roll, few, warmup, Kernels::Fixed)
        };
        let (grip_mm, quat) = physical(&out);
        let normalised = worst(&out);
        println!(
            "{few} fixed-point streams: {normalised:.2e} normalised, grips {grip_mm:.2} mm, quaternions {quat:.2e}"
        );
        assert!(few != 6 || normalised <= 5e-3, "the fixed-point pass differs by {normalised}");
        assert!(grip_mm <= 1.0 && quat <= 1.25e-3, "{few} fixed-point streams: grips {grip_mm} mm, quaternions {quat}");
    }
    // Without the warm-up the chunks' cold starts show.
    let cold = worst(&model.forward_streams(&roll, streams, 0));
    assert!(cold > 10.0 * chunked.max(1e-6), "cold starts {cold} vs warmed {chunked}");
}

#[test]
fn a_changed_teacher_changes_the_data_digest() {
    // A resumed run compares this digest to tell that its material changed (and then
    // measures the best checkpoint afresh).
    use drumsim::learn::train::data_digest;
    let a = vec![synthetic_example(1, 50), synthetic_example(2, 40)];
    let mut b = a.clone();
    assert_eq!(data_digest(&a), data_digest(&b), "the same material, the same digest");
    b[1].hands[7][3] += 1e-6;
    assert_ne!(data_digest(&a), data_digest(&b), "one target moved");
}

/// `[1, t, 14]` tensor of a trajectory.
fn traj_tensor(v: &[[f32; HAND_VALUES]]) -> Tensor<3> {
    let flat: Vec<f32> = v.iter().flatten().copied().collect();
    Tensor::from_data(TensorData::new(flat, [1, v.len(), HAND_VALUES]), &Device::flex())
}

#[test]
fn the_velocity_term_sees_timing_and_not_an_offset() {
    use drumsim::learn::hand_net::{masked_mse, masked_velocity_mse};
    let t = 40;
    // A stroke on the left grip's height (channel 2): a bump centred on frame 20.
    let bump = |shift: f32| -> Vec<[f32; HAND_VALUES]> {
        (0..t)
            .map(|f| {
                let mut v = [0.0; HAND_VALUES];
                v[2] = (-((f as f32 - 20.0 - shift) / 3.0).powi(2)).exp();
                v
            })
            .collect()
    };
    let target = bump(0.0);
    let mut weights = [0.0f32; HAND_VALUES];
    weights[2] = 1.0;
    let w = Tensor::<3>::from_data(TensorData::new(weights.to_vec(), [1, 1, HAND_VALUES]), &Device::flex());
    let mask = |valid: usize| {
        let m: Vec<f32> = (0..t).map(|f| if f < valid { 1.0 } else { 0.0 }).collect();
        Tensor::<3>::from_data(TensorData::new(m, [1, t, 1]), &Device::flex())
    };
    let vel = |pred: &[[f32; HAND_VALUES]], valid: usize| -> f32 {
        masked_velocity_mse(traj_tensor(pred), traj_tensor(&target), mask(valid), w.clone(), 1).into_scalar::<f32>()
    };
    let mse =
        |pred: &[[f32; HAND_VALUES]]| masked_mse(traj_tensor(pred), traj_tensor(&target), mask(t)).into_scalar::<f32>();

    // The whole trajectory 5 cm higher: a position error, no velocity error.
    let raised: Vec<_> = target
        .iter()
        .map(|v| {
            let mut v = *v;
            v[2] += 0.05;
            v
        })
        .collect();
    assert!(mse(&raised) > 1e-4 && vel(&raised, t) < 1e-12, "mse {} vel {}", mse(&raised), vel(&raised, t));

    // The stroke a frame late: the velocity term is the mean squared difference of the
    // frame differences over the 39 pairs, computed here by hand.
    let late = bump(1.0);
    let d = |x: &[[f32; HAND_VALUES]], f: usize| x[f + 1][2] - x[f][2];
    let by_hand: f32 = (0..t - 1).map(|f| (d(&late, f) - d(&target, f)).powi(2)).sum::<f32>() / (t - 1) as f32;
    assert!(by_hand > 1e-3);
    assert!((vel(&late, t) - by_hand).abs() < 1e-6 * by_hand.max(1.0), "{} vs {by_hand}", vel(&late, t));

    // Padding: frames past the mask do not count, whatever they hold.
    let mut padded = target.clone();
    for v in &mut padded[30..] {
        v[2] = 9.0;
    }
    assert!(vel(&padded, 30) < 1e-12, "padded frames leaked: {}", vel(&padded, 30));
}
