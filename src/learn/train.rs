//! Training the hand network as DRUMS does (paper section 3.3): random crops of 200 frames
//! (shorter sequences zero-padded), batches of 32, masked MSE over valid frames, AdamW at
//! 1e-3, gradient clipping at global norm 1.0, validation after every epoch, and the weights
//! of the best validation loss kept.
//!
//! Checkpoints in the output directory:
//! - `best.bpk` + `best.json`: the best-validation weights and their sidecar (epoch, losses,
//!   normalisation, config); what [`crate::motion::hands::HandModel::load`] reads.
//! - `last.bpk`, `last.optim.bpk`, `last.json`: the latest state, written after every epoch
//!   and when the time budget runs out, from which [`train`] resumes (AdamW's moments
//!   included: burn saves the optimizer state).
//!
//! Crops are drawn from a generator seeded by (seed, epoch), so a resumed run draws the
//! crops an uninterrupted run would have drawn.

use std::path::{Path, PathBuf};
use std::time::Instant;

use burn::module::{Module, ModuleVisitor, Param, ParamId};
use burn::optim::{AdamWConfig, GradientsParams, ModuleOptimizer};
use burn::tensor::{Device, Tensor, TensorData};
use serde::{Deserialize, Serialize};

use super::hand_net::{masked_mse, masked_velocity_mse, HandNet};
use super::{fit_normalisation, Example};
use crate::motion::hands::{HandsError, Normalisation, ROLL_COLUMNS};
use crate::motion::HAND_VALUES;

/// Training settings; the defaults are the paper's, plus drumsim's velocity term
/// (`velocity_weight` 1; 0 gives the paper's loss alone).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainConfig {
    /// Epochs to reach (a resumed run continues up to this count).
    pub epochs: usize,
    /// Crop length in frames (W).
    pub window: usize,
    pub batch: usize,
    pub lr: f64,
    /// AdamW decoupled weight decay (PyTorch's default, 0.01).
    pub weight_decay: f32,
    /// Global gradient-norm limit (as `torch.nn.utils.clip_grad_norm_`).
    pub clip_norm: f32,
    /// Hidden units per LSTM direction.
    pub hidden: usize,
    pub dropout: f64,
    pub seed: u64,
    /// Wall-clock budget of this call; when spent, the state is saved and training stops.
    pub max_minutes: Option<f64>,
    /// Weight of the velocity term added to the masked MSE: the masked MSE of the grip
    /// positions' frame-to-frame differences, each coordinate divided by the standard
    /// deviation of its differences over the training set (0: the paper's loss alone).
    /// Checkpoints written before the term existed read as 0.
    #[serde(default)]
    pub velocity_weight: f32,
}

impl Default for TrainConfig {
    fn default() -> Self {
        Self {
            epochs: 500,
            window: 200,
            batch: 32,
            lr: 1e-3,
            weight_decay: 0.01,
            clip_norm: 1.0,
            hidden: 128,
            dropout: 0.1,
            seed: 0,
            max_minutes: None,
            velocity_weight: 1.0,
        }
    }
}

impl TrainConfig {
    fn validate(&self) -> Result<(), HandsError> {
        let bad = |m: &str| Err(HandsError::Config(m.into()));
        if self.window == 0 || self.batch == 0 || self.hidden == 0 {
            return bad("window, batch and hidden must be at least 1");
        }
        let ok = self.lr > 0.0 && self.lr.is_finite() && self.clip_norm > 0.0 && self.weight_decay >= 0.0;
        if !ok {
            return bad("lr and clip_norm must be positive, weight_decay non-negative");
        }
        if !(self.velocity_weight >= 0.0 && self.velocity_weight.is_finite()) {
            return bad("velocity_weight must be a non-negative number");
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return bad("dropout must lie in [0, 1)");
        }
        Ok(())
    }
}

/// One finished epoch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EpochReport {
    /// 1-based.
    pub epoch: usize,
    pub train_loss: f32,
    pub val_loss: f32,
    /// Whether this epoch became the best checkpoint.
    pub best: bool,
    pub seconds: f64,
}

/// The sidecar JSON of a checkpoint, and the summary [`train`] returns.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrainReport {
    /// Epochs completed (across resumed runs).
    pub epoch: usize,
    pub best_epoch: usize,
    pub best_val_loss: f32,
    /// Validation loss of the weights this file holds.
    pub val_loss: f32,
    /// Per-epoch mean training and validation loss (normalised units).
    pub train_loss_history: Vec<f32>,
    pub val_loss_history: Vec<f32>,
    pub normalisation: Normalisation,
    pub config: TrainConfig,
    /// Whether the time budget ended this run before `config.epochs`.
    pub stopped_by_budget: bool,
    /// Validation loss of the initial weights (epoch 0).
    pub initial_val_loss: f32,
    /// A digest of the validation targets the losses were measured on ([`data_digest`]).
    #[serde(default)]
    pub data_digest: u64,
    /// Epochs after which training resumed on different material (a changed teacher): the
    /// best checkpoint was measured afresh from there.
    #[serde(default)]
    pub data_changed_after: Vec<usize>,
    /// Epochs after which training resumed with a different loss (`velocity_weight`): the
    /// best checkpoint was measured afresh from there.
    #[serde(default)]
    pub loss_changed_after: Vec<usize>,
}

/// A digest (FNV-1a over the ids and every target value's bits) of a set of examples, so a
/// resumed run can tell that its material changed.
pub fn data_digest(examples: &[Example]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h = (h ^ b as u64).wrapping_mul(0x100_0000_01b3);
        }
    };
    for e in examples {
        eat(e.id.as_bytes());
        for v in e.hands.iter().flatten() {
            eat(&v.to_bits().to_le_bytes());
        }
    }
    h
}

/// A small deterministic generator (SplitMix64) for crops and shuffles.
struct Rng(u64);

impl Rng {
    fn new(seed: u64, epoch: usize) -> Self {
        Self(seed ^ (epoch as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0x5851_F42D_4C95_7F2D)
    }
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (n > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
}

/// A crop: example index and first frame.
type Crop = (usize, usize);

/// Input `[b, w, 16]`, normalised target `[b, w, 14]` and mask `[b, w, 1]` tensors.
fn batch_tensors(
    examples: &[Example],
    crops: &[Crop],
    window: usize,
    norm: &Normalisation,
    device: &Device,
) -> (Tensor<3>, Tensor<3>, Tensor<3>) {
    let b = crops.len();
    let mut x = vec![0.0f32; b * window * ROLL_COLUMNS];
    let mut y = vec![0.0f32; b * window * HAND_VALUES];
    let mut m = vec![0.0f32; b * window];
    for (i, &(e, s)) in crops.iter().enumerate() {
        let ex = &examples[e];
        let n = window.min(ex.roll.len() - s);
        for f in 0..n {
            let o = i * window + f;
            x[o * ROLL_COLUMNS..][..ROLL_COLUMNS].copy_from_slice(&ex.roll[s + f]);
            y[o * HAND_VALUES..][..HAND_VALUES].copy_from_slice(&norm.normalise(&ex.hands[s + f]));
            m[o] = 1.0;
        }
    }
    (
        Tensor::from_data(TensorData::new(x, [b, window, ROLL_COLUMNS]), device),
        Tensor::from_data(TensorData::new(y, [b, window, HAND_VALUES]), device),
        Tensor::from_data(TensorData::new(m, [b, window, 1]), device),
    )
}

/// One random crop per training example, in shuffled order.
fn epoch_crops(examples: &[Example], window: usize, rng: &mut Rng) -> Vec<Crop> {
    let mut order: Vec<usize> = (0..examples.len()).collect();
    for i in (1..order.len()).rev() {
        order.swap(i, rng.below(i + 1));
    }
    order.into_iter().map(|e| (e, rng.below(examples[e].roll.len().saturating_sub(window) + 1))).collect()
}

/// Every example cut into consecutive windows (the last one padded): fixed validation crops
/// that cover every frame once.
fn fixed_crops(examples: &[Example], window: usize) -> Vec<Crop> {
    examples.iter().enumerate().flat_map(|(e, ex)| (0..ex.roll.len()).step_by(window).map(move |s| (e, s))).collect()
}

/// The grip-position channels of the 14 hand values (left x, y, z, right x, y, z).
const POSITION_CHANNELS: [usize; 6] = [0, 1, 2, 7, 8, 9];

/// The per-channel weights of the velocity term: `velocity_weight / var(diff)` on the grip
/// positions, where `diff` is the frame-to-frame difference of the normalised target over
/// the training set; 0 elsewhere.
pub fn velocity_weights(examples: &[Example], norm: &Normalisation, velocity_weight: f32) -> [f32; HAND_VALUES] {
    let mut w = [0.0f32; HAND_VALUES];
    if velocity_weight == 0.0 {
        return w;
    }
    let (mut sq, mut n) = ([0.0f64; HAND_VALUES], 0usize);
    for ex in examples {
        for pair in ex.hands.windows(2) {
            let (a, b) = (norm.normalise(&pair[0]), norm.normalise(&pair[1]));
            for c in POSITION_CHANNELS {
                sq[c] += ((b[c] - a[c]) as f64).powi(2);
            }
            n += 1;
        }
    }
    for c in POSITION_CHANNELS {
        let var = (sq[c] / n.max(1) as f64).max(1e-12);
        w[c] = (velocity_weight as f64 / var) as f32;
    }
    w
}

/// The training objective: masked MSE plus, when `vel` has a non-zero weight, the
/// velocity term ([`velocity_weights`]).
fn objective(pred: Tensor<3>, y: Tensor<3>, m: Tensor<3>, vel: &[f32; HAND_VALUES]) -> Tensor<1> {
    let used = vel.iter().filter(|w| **w > 0.0).count();
    if used == 0 || pred.dims()[1] < 2 {
        return masked_mse(pred, y, m);
    }
    let w = Tensor::from_data(TensorData::new(vel.to_vec(), [1, 1, HAND_VALUES]), &pred.device());
    masked_mse(pred.clone(), y.clone(), m.clone()) + masked_velocity_mse(pred, y, m, w, used)
}

/// The objective over `crops`, frame-weighted, with the module in evaluation mode.
fn evaluate(
    model: &HandNet,
    examples: &[Example],
    crops: &[Crop],
    cfg: &TrainConfig,
    norm: &Normalisation,
    vel: &[f32; HAND_VALUES],
) -> f32 {
    let model = model.valid();
    let device = Device::flex();
    let (mut sum, mut frames) = (0.0f64, 0.0f64);
    for chunk in crops.chunks(cfg.batch) {
        let (x, y, m) = batch_tensors(examples, chunk, cfg.window, norm, &device);
        let n = m.clone().sum().into_scalar::<f32>() as f64;
        let loss = objective(model.forward(x), y, m, vel).into_scalar::<f32>() as f64;
        sum += loss * n;
        frames += n;
    }
    (sum / frames.max(1.0)) as f32
}

/// Squared gradient norms of a module's float parameters.
struct GradNorm<'a> {
    grads: &'a GradientsParams,
    sq: f64,
}

impl ModuleVisitor for GradNorm<'_> {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        if let Some(g) = self.grads.get::<D>(param.id) {
            self.sq += g.square().sum().into_scalar::<f32>() as f64;
        }
    }
}

/// Collects the ids of a module's float parameters and their ranks.
struct ParamIds(Vec<(ParamId, usize)>);

impl ModuleVisitor for ParamIds {
    fn visit_float<const D: usize>(&mut self, param: &Param<Tensor<D>>) {
        self.0.push((param.id, D));
    }
}

fn scale_grad<const D: usize>(grads: &mut GradientsParams, id: ParamId, s: f32) {
    if let Some(g) = grads.remove::<D>(id) {
        grads.register::<D>(id, g.mul_scalar(s));
    }
}

/// Scales all gradients together so their global L2 norm is at most `max_norm` (PyTorch's
/// `clip_grad_norm_`; burn's own clipping works per tensor). Returns the norm before.
fn clip_global_norm(model: &HandNet, grads: &mut GradientsParams, max_norm: f32) -> f32 {
    let mut v = GradNorm { grads, sq: 0.0 };
    model.visit(&mut v);
    let norm = v.sq.sqrt() as f32;
    if norm > max_norm {
        let s = max_norm / (norm + 1e-6);
        let mut ids = ParamIds(Vec::new());
        model.visit(&mut ids);
        for (id, rank) in ids.0 {
            match rank {
                1 => scale_grad::<1>(grads, id, s),
                2 => scale_grad::<2>(grads, id, s),
                _ => scale_grad::<3>(grads, id, s),
            }
        }
    }
    norm
}

fn check_examples(set: &str, examples: &[Example]) -> Result<(), HandsError> {
    if examples.is_empty() {
        return Err(HandsError::Data(format!("the {set} set is empty")));
    }
    for ex in examples {
        if ex.roll.is_empty() || ex.roll.len() != ex.hands.len() {
            return Err(HandsError::Data(format!(
                "{set} example `{}`: {} roll frames and {} hand frames (need equal, at least 1)",
                ex.id,
                ex.roll.len(),
                ex.hands.len()
            )));
        }
        if ex.hands.iter().flatten().chain(ex.roll.iter().flatten()).any(|v| !v.is_finite()) {
            return Err(HandsError::Data(format!("{set} example `{}` has a non-finite value", ex.id)));
        }
    }
    Ok(())
}

fn write_json(path: &Path, report: &TrainReport) -> Result<(), HandsError> {
    let text = serde_json::to_string_pretty(report)
        .map_err(|e| HandsError::Checkpoint { path: path.to_path_buf(), reason: e.to_string() })?;
    let tmp = path.with_extension("json.tmp");
    std::fs::write(&tmp, text)
        .and_then(|_| std::fs::rename(&tmp, path))
        .map_err(|source| HandsError::Io { path: path.to_path_buf(), source })
}

fn save_model(model: &HandNet, path: &Path) -> Result<(), HandsError> {
    model
        .valid()
        .save_file(path)
        .map_err(|e| HandsError::Checkpoint { path: path.to_path_buf(), reason: e.to_string() })
}

/// File names inside a checkpoint directory.
pub struct CheckpointPaths {
    pub best: PathBuf,
    pub best_json: PathBuf,
    pub last: PathBuf,
    pub last_optim: PathBuf,
    pub last_json: PathBuf,
}

impl CheckpointPaths {
    pub fn new(dir: &Path) -> Self {
        Self {
            best: dir.join("best.bpk"),
            best_json: dir.join("best.json"),
            last: dir.join("last.bpk"),
            last_optim: dir.join("last.optim.bpk"),
            last_json: dir.join("last.json"),
        }
    }
}

/// Trains (or resumes training from `dir/last.*`) and returns the latest state's report.
/// `progress` shows an indicatif bar per epoch and prints one validation-curve line per
/// epoch on stderr; `on_epoch` sees every finished epoch.
pub fn train(
    train: &[Example],
    val: &[Example],
    cfg: TrainConfig,
    dir: &Path,
    progress: bool,
    mut on_epoch: impl FnMut(&EpochReport),
) -> Result<TrainReport, HandsError> {
    cfg.validate()?;
    check_examples("training", train)?;
    check_examples("validation", val)?;
    std::fs::create_dir_all(dir).map_err(|source| HandsError::Io { path: dir.to_path_buf(), source })?;
    let paths = CheckpointPaths::new(dir);
    let start = Instant::now();
    let device = Device::flex().autodiff();
    device.seed(cfg.seed);

    let mut model = HandNet::new(cfg.hidden, cfg.dropout, &device);
    let mut optim: ModuleOptimizer = AdamWConfig::new().with_weight_decay(cfg.weight_decay).init();
    let val_crops = fixed_crops(val, cfg.window);

    let mut state = if paths.last_json.is_file() {
        let cerr = |p: &Path, reason: String| HandsError::Checkpoint { path: p.to_path_buf(), reason };
        let text = std::fs::read_to_string(&paths.last_json).map_err(|e| cerr(&paths.last_json, e.to_string()))?;
        let mut st: TrainReport = serde_json::from_str(&text).map_err(|e| cerr(&paths.last_json, e.to_string()))?;
        if st.config.hidden != cfg.hidden {
            return Err(cerr(
                &paths.last_json,
                format!("hidden {} differs from the requested {}", st.config.hidden, cfg.hidden),
            ));
        }
        model = model.try_load_file(&paths.last).map_err(|e| cerr(&paths.last, e.to_string()))?.train();
        optim = optim.load(&paths.last_optim).map_err(|e| cerr(&paths.last_optim, e.to_string()))?;
        if st.config.velocity_weight != cfg.velocity_weight {
            // A different objective: losses measured under the old one do not compare.
            st.loss_changed_after.push(st.epoch);
            st.best_val_loss = f32::MAX;
        }
        st.config = cfg.clone();
        st.stopped_by_budget = false;
        let digest = data_digest(val);
        if st.data_digest != digest {
            // New material (the teacher changed): the old best loss was measured on other
            // targets, so the best checkpoint starts afresh from these weights.
            st.data_changed_after.push(st.epoch);
            st.best_val_loss = f32::MAX;
            st.data_digest = digest;
        }
        st
    } else {
        let normalisation = fit_normalisation(train);
        let vel = velocity_weights(train, &normalisation, cfg.velocity_weight);
        let initial = evaluate(&model, val, &val_crops, &cfg, &normalisation, &vel);
        TrainReport {
            epoch: 0,
            best_epoch: 0,
            best_val_loss: f32::MAX,
            val_loss: initial,
            train_loss_history: Vec::new(),
            val_loss_history: Vec::new(),
            normalisation,
            config: cfg.clone(),
            stopped_by_budget: false,
            initial_val_loss: initial,
            data_digest: data_digest(val),
            data_changed_after: Vec::new(),
            loss_changed_after: Vec::new(),
        }
    };
    let norm = state.normalisation.clone();
    let vel = velocity_weights(train, &norm, cfg.velocity_weight);
    let over_budget = || cfg.max_minutes.is_some_and(|m| start.elapsed().as_secs_f64() > m * 60.0);

    if state.epoch >= cfg.epochs {
        return Err(HandsError::Config(format!(
            "epochs {}: {} is already at epoch {}; nothing was trained or written (raise the epochs to go on)",
            cfg.epochs,
            dir.display(),
            state.epoch
        )));
    }
    while state.epoch < cfg.epochs {
        let epoch = state.epoch + 1;
        let t0 = Instant::now();
        let crops = epoch_crops(train, cfg.window, &mut Rng::new(cfg.seed, epoch));
        let batches: Vec<&[Crop]> = crops.chunks(cfg.batch).collect();
        let bar = if progress {
            indicatif::ProgressBar::new(batches.len() as u64).with_style(
                indicatif::ProgressStyle::with_template(
                    "epoch {prefix} [{bar:30}] {pos}/{len} batches, loss {msg} ({eta})",
                )
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
            )
        } else {
            indicatif::ProgressBar::hidden()
        };
        bar.set_prefix(format!("{epoch}/{}", cfg.epochs));
        let (mut loss_sum, mut n) = (0.0f64, 0usize);
        let mut interrupted = false;
        for batch in batches {
            if over_budget() {
                interrupted = true;
                break;
            }
            let (x, y, m) = batch_tensors(train, batch, cfg.window, &norm, &device);
            let loss = objective(model.forward(x), y, m, &vel);
            let value = loss.clone().into_scalar::<f32>();
            let mut grads = GradientsParams::from_grads(loss.backward(), &model);
            clip_global_norm(&model, &mut grads, cfg.clip_norm);
            model = optim.step(cfg.lr, model, grads);
            loss_sum += value as f64;
            n += 1;
            bar.set_message(format!("{:.4}", loss_sum / n as f64));
            bar.inc(1);
        }
        bar.finish_and_clear();
        if interrupted {
            // The partial epoch's updates are kept in the weights; the epoch itself is
            // redone (with the same crops) on resume.
            save_model(&model, &paths.last)?;
            optim
                .save(&paths.last_optim)
                .map_err(|e| HandsError::Checkpoint { path: paths.last_optim.clone(), reason: e.to_string() })?;
            state.stopped_by_budget = true;
            write_json(&paths.last_json, &state)?;
            return Ok(state);
        }
        let train_loss = (loss_sum / n.max(1) as f64) as f32;
        let val_loss = evaluate(&model, val, &val_crops, &cfg, &norm, &vel);
        if !(train_loss.is_finite() && val_loss.is_finite()) {
            // Diverged: the checkpoints of the last good epoch stay as they are.
            return Err(HandsError::Config(format!(
                "training diverged at epoch {epoch} (train loss {train_loss}, validation loss {val_loss}) with lr {}; \
                 {} and {} keep the last good epoch's weights: lower --lr",
                cfg.lr,
                paths.best.display(),
                paths.last.display()
            )));
        }
        state.epoch = epoch;
        state.val_loss = val_loss;
        state.train_loss_history.push(train_loss);
        state.val_loss_history.push(val_loss);
        let best = val_loss < state.best_val_loss;
        if best {
            state.best_val_loss = val_loss;
            state.best_epoch = epoch;
            save_model(&model, &paths.best)?;
            write_json(&paths.best_json, &state)?;
        }
        save_model(&model, &paths.last)?;
        optim
            .save(&paths.last_optim)
            .map_err(|e| HandsError::Checkpoint { path: paths.last_optim.clone(), reason: e.to_string() })?;
        write_json(&paths.last_json, &state)?;
        let report = EpochReport { epoch, train_loss, val_loss, best, seconds: t0.elapsed().as_secs_f64() };
        if progress {
            eprintln!(
                "epoch {epoch:>4}/{}  train {train_loss:.5}  val {val_loss:.5}{}  ({:.1} s)",
                cfg.epochs,
                if best { "  *best" } else { "" },
                report.seconds
            );
        }
        on_epoch(&report);
    }
    Ok(state)
}

/// `drumsim train`: trains on `train` / `val` examples (from the corpus) into `out_dir`,
/// resuming from what is there, for at most `epochs` epochs in total and `max_minutes` of
/// wall-clock time in this call, with a progress bar.
pub fn run_train(
    train_set: &[Example],
    val_set: &[Example],
    out_dir: &Path,
    epochs: usize,
    max_minutes: Option<f64>,
    velocity_weight: Option<f32>,
    lr: Option<f64>,
) -> Result<TrainReport, HandsError> {
    let defaults = TrainConfig::default();
    // Unless asked otherwise, a resumed run keeps the loss and learning rate it had.
    let resumed = std::fs::read_to_string(CheckpointPaths::new(out_dir).last_json)
        .ok()
        .and_then(|text| serde_json::from_str::<TrainReport>(&text).ok())
        .map(|r| r.config);
    let velocity_weight =
        velocity_weight.or(resumed.as_ref().map(|c| c.velocity_weight)).unwrap_or(defaults.velocity_weight);
    let lr = lr.or(resumed.as_ref().map(|c| c.lr)).unwrap_or(defaults.lr);
    let cfg = TrainConfig { epochs, max_minutes, velocity_weight, lr, ..defaults };
    train(train_set, val_set, cfg, out_dir, true, |_| {})
}
