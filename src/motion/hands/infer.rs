//! Our own forward pass of the hand network on plain arrays: the same function as
//! [`super::model::HandNet::forward`] (within 1e-4 in `f32`, `tests/hands.rs`), ten times
//! faster on one core, with no burn tensors at run time.
//!
//! Two paths compute it:
//! - On x86-64 with AVX2 + FMA (pulp's `V3`) and a hidden size that is a multiple of 8, the
//!   kernels of [`super::kernels`] run through [`super::streams`]: the recurrence as parallel
//!   warmed-up streams, layer 2's input projection made block by block, the output layer
//!   over all of layer 2's states at the end. [`HandModel::predict`] does the three big
//!   products in 16-bit fixed point ([`super::quant`], hidden a multiple of 16): 3 minutes
//!   (10,800 frames) take about 130-150 ms here, against 170-195 ms in `f32`
//!   ([`HandModel::forward_streams`]), and differ from the exact `f32` pass by 4.7e-3 of a
//!   normalised output with six streams and the shipped weights, at most 0.77 mm of grip
//!   with fewer (`tests/hands.rs`).
//! - Elsewhere, the portable path below: plain loops over fixed-size arrays that LLVM
//!   vectorises for the default target (SSE2 on x86-64), the sequence run as one stream.
//!   - Layer-1 input projection: the roll is binary and sparse, so it is the bias plus the
//!     weight rows of the active notes (nearly free).
//!   - Layer-2 input projection `[T, 2H] x [2H, 8H]` (both directions at once): a blocked
//!     matrix product, 4 frames x 16 outputs per register tile, weights packed per tile.
//!   - The recurrence `W_hh h` (a 4H x H matvec per frame and direction, gates fused): 64
//!     outputs per register tile, weights packed tile by tile so each streams contiguously.
//!   - Sigmoid and tanh through one branch-free, vectorisable `exp` (Cephes' polynomial,
//!     about 1 ulp), applied to whole gate vectors.

use std::path::Path;

use serde::Deserialize;

use super::streams::{plan, Forward, Kernels, SimdNet};
use super::weights::HandWeights;
use super::{HandsError, Normalisation, ROLL_COLUMNS};
use crate::midi::roll::PianoRoll;
use crate::motion::HAND_VALUES;

/// Output columns per register tile of the batched matrix product.
const MM_TILE: usize = 16;
/// Frames per register tile of the batched matrix product.
const MM_ROWS: usize = 4;
/// Frames per cache block of the batched matrix product (its inputs stay in L2).
const MM_BLOCK: usize = 64;
/// Gate pre-activations per register tile of the recurrent matvec.
const REC_TILE: usize = 64;

/// A `[k][n]` matrix packed as column tiles of [`MM_TILE`] (zero-padded), `[tile][k][16]`,
/// plus the bias padded the same way.
#[derive(Debug, Clone)]
struct PackedMat {
    k: usize,
    tiles: Vec<f32>,
    bias: Vec<f32>,
}

impl PackedMat {
    /// `w` is `[k][n]` row-major.
    fn new(w: &[f32], bias: &[f32], k: usize, n: usize) -> Self {
        let nt = n.div_ceil(MM_TILE);
        let mut tiles = vec![0.0; nt * k * MM_TILE];
        let mut b = vec![0.0; nt * MM_TILE];
        for c in 0..n {
            let (tile, j) = (c / MM_TILE, c % MM_TILE);
            for r in 0..k {
                tiles[(tile * k + r) * MM_TILE + j] = w[r * n + c];
            }
            b[c] = bias[c];
        }
        Self { k, tiles, bias: b }
    }

    /// Padded output width.
    fn n_pad(&self) -> usize {
        self.bias.len()
    }
}

/// One direction's recurrent weights `[H][4H]`, packed as column tiles of [`REC_TILE`]
/// (`[tile][H][64]`), the last tile as narrow as what is left.
#[derive(Debug, Clone)]
struct PackedRec {
    hidden: usize,
    tiles: Vec<f32>,
}

impl PackedRec {
    fn new(w_hh: &[f32], hidden: usize) -> Self {
        let g4 = 4 * hidden;
        let mut tiles = Vec::with_capacity(g4 * hidden);
        for c0 in (0..g4).step_by(REC_TILE) {
            let width = REC_TILE.min(g4 - c0);
            for k in 0..hidden {
                tiles.extend_from_slice(&w_hh[k * g4 + c0..][..width]);
            }
        }
        Self { hidden, tiles }
    }
}

/// The network, laid out for the kernels below.
#[derive(Debug, Clone)]
struct Packed {
    hidden: usize,
    /// Layer 1, both directions: `[16][8H]` and `[8H]` (forward gates, then reverse).
    l1_w: Vec<f32>,
    l1_b: Vec<f32>,
    /// Recurrent weights `[layer][direction]`.
    rec: [[PackedRec; 2]; 2],
    /// Layer-2 input projection, both directions: `[2H] x [8H]`.
    l2: PackedMat,
    /// Output layer `[2H] x [14]`.
    head: PackedMat,
}

impl Packed {
    fn new(w: &HandWeights) -> Self {
        let h = w.hidden;
        let g4 = 4 * h;
        let cat = |a: &[f32], b: &[f32], rows: usize| -> Vec<f32> {
            (0..rows).flat_map(|r| a[r * g4..][..g4].iter().chain(&b[r * g4..][..g4]).copied()).collect()
        };
        let [l1f, l1r] = &w.layers[0];
        let [l2f, l2r] = &w.layers[1];
        Self {
            hidden: h,
            l1_w: cat(&l1f.w_ih, &l1r.w_ih, ROLL_COLUMNS),
            l1_b: cat(&l1f.bias, &l1r.bias, 1),
            rec: [
                [PackedRec::new(&l1f.w_hh, h), PackedRec::new(&l1r.w_hh, h)],
                [PackedRec::new(&l2f.w_hh, h), PackedRec::new(&l2r.w_hh, h)],
            ],
            l2: PackedMat::new(&cat(&l2f.w_ih, &l2r.w_ih, 2 * h), &cat(&l2f.bias, &l2r.bias, 1), 2 * h, 8 * h),
            head: PackedMat::new(&w.head_w, &w.head_b, 2 * h, HAND_VALUES),
        }
    }
}

/// How the compiled-in weights are named in render summaries and errors.
pub const SHIPPED_WEIGHTS_NAME: &str = "compiled-in assets/hands/best.bpk";

/// The trained hand model, ready to run: weights in the kernels' layout and the target
/// normalisation.
#[derive(Debug, Clone)]
pub struct HandModel {
    packed: Packed,
    /// The layout for the AVX2 + FMA kernels, where the hidden size allows.
    simd: Option<SimdNet>,
    norm: Normalisation,
    fma: bool,
}

/// The part of a checkpoint's JSON sidecar that inference needs.
#[derive(Deserialize)]
struct Sidecar {
    normalisation: Normalisation,
}

impl HandModel {
    /// Loads a checkpoint written by [`super::train`]: the burnpack weights at `path` and the
    /// normalisation from the JSON beside it (`path` with extension `json`).
    pub fn load(path: &Path) -> Result<Self, HandsError> {
        let weights = HandWeights::load(path)?;
        let side = path.with_extension("json");
        let text = std::fs::read_to_string(&side)
            .map_err(|e| HandsError::Read { path: side.clone(), reason: e.to_string() })?;
        Self::with_sidecar(&weights, &text, &side)
    }

    /// The shipped model, compiled into the binary from `assets/hands/best.bpk` and its JSON
    /// sidecar: what a render uses unless `--weights` or `$DRUMSIM_ASSETS` says otherwise.
    pub fn shipped() -> Self {
        let path = Path::new(SHIPPED_WEIGHTS_NAME);
        let weights = HandWeights::from_bytes(include_bytes!("../../../assets/hands/best.bpk"), path)
            .expect("the compiled-in hand model weights are valid (checked by a unit test)");
        Self::with_sidecar(&weights, include_str!("../../../assets/hands/best.json"), &path.with_extension("json"))
            .expect("the compiled-in hand model sidecar is valid (checked by a unit test)")
    }

    /// The model of `weights` with the normalisation of a checkpoint's JSON sidecar (`side` names it
    /// in errors).
    pub fn with_sidecar(weights: &HandWeights, sidecar_json: &str, side: &Path) -> Result<Self, HandsError> {
        let err = |reason: String| HandsError::Read { path: side.to_path_buf(), reason };
        let sidecar: Sidecar = serde_json::from_str(sidecar_json).map_err(|e| err(e.to_string()))?;
        if sidecar.normalisation.std.iter().chain(&sidecar.normalisation.mean).any(|v| !v.is_finite())
            || sidecar.normalisation.std.iter().any(|&s| s <= 0.0)
        {
            return Err(err("normalisation has a non-finite mean or a non-positive std".into()));
        }
        Ok(Self::new(weights, sidecar.normalisation))
    }

    /// A model from weights already in memory.
    pub fn new(weights: &HandWeights, norm: Normalisation) -> Self {
        Self { packed: Packed::new(weights), simd: SimdNet::new(weights), norm, fma: fma_available() }
    }

    /// The per-channel mean and standard deviation the outputs are normalised by.
    pub fn normalisation(&self) -> &Normalisation {
        &self.norm
    }

    /// Hidden units per direction.
    pub fn hidden(&self) -> usize {
        self.packed.hidden
    }

    /// Hand values (metres, unit-ish quaternions) for every frame of `roll`; empty for an
    /// empty roll.
    pub fn predict(&self, roll: &[[f32; ROLL_COLUMNS]]) -> Vec<[f32; HAND_VALUES]> {
        self.forward_normalised(roll).iter().map(|v| self.norm.denormalise(v)).collect()
    }

    /// [`Self::predict`] for a [`PianoRoll`].
    pub fn predict_roll(&self, roll: &PianoRoll) -> Vec<[f32; HAND_VALUES]> {
        let x: Vec<[f32; ROLL_COLUMNS]> = roll.frames.iter().map(|f| f.map(|on| if on { 1.0 } else { 0.0 })).collect();
        self.predict(&x)
    }

    /// The network's raw (normalised) output, what burn's `HandNet::forward` computes, to
    /// within the fixed point's rounding where AVX2 runs it (long sequences as parallel
    /// streams, see [`super::streams`]; [`Self::forward_streams`] is the `f32` pass).
    pub fn forward_normalised(&self, roll: &[[f32; ROLL_COLUMNS]]) -> Vec<[f32; HAND_VALUES]> {
        let (streams, warmup) = plan(roll.len());
        self.forward_with(roll, streams, warmup, Kernels::Fixed)
    }

    /// [`Self::forward_normalised`] in `f32` with a chosen number of streams and warm-up
    /// (one stream is the exact sequential pass).
    pub fn forward_streams(
        &self,
        roll: &[[f32; ROLL_COLUMNS]],
        streams: usize,
        warmup: usize,
    ) -> Vec<[f32; HAND_VALUES]> {
        self.forward_with(roll, streams, warmup, Kernels::F32)
    }

    /// The forward pass with chosen streams, warm-up and kernels (the portable path, where
    /// there is no AVX2, ignores all three).
    pub fn forward_with(
        &self,
        roll: &[[f32; ROLL_COLUMNS]],
        streams: usize,
        warmup: usize,
        kernels: Kernels,
    ) -> Vec<[f32; HAND_VALUES]> {
        if roll.is_empty() {
            return Vec::new();
        }
        #[cfg(target_arch = "x86_64")]
        if let (Some(net), Some(v3)) = (&self.simd, pulp::x86::V3::try_new()) {
            let op = Forward { v3, net, roll, streams, warmup, kernels };
            return <pulp::x86::V3 as pulp::Simd>::vectorize(v3, op);
        }
        let p = &self.packed;
        if self.fma {
            pulp::Arch::new().dispatch(|| forward::<true>(p, roll))
        } else {
            pulp::Arch::new().dispatch(|| forward::<false>(p, roll))
        }
    }
}

/// Fused multiply-add only where the build targets it (`-C target-cpu=native` on a CPU with
/// FMA); elsewhere `f32::mul_add` is a libm call (see the module doc).
fn fma_available() -> bool {
    cfg!(target_feature = "fma")
}

/// `a * b + c`, fused where the CPU has FMA (a libm call otherwise, hence the switch).
#[inline(always)]
fn madd<const FMA: bool>(a: f32, b: f32, c: f32) -> f32 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

#[inline(always)]
fn forward<const FMA: bool>(p: &Packed, roll: &[[f32; ROLL_COLUMNS]]) -> Vec<[f32; HAND_VALUES]> {
    let h = p.hidden;
    let t = roll.len();
    let rows = t.div_ceil(MM_ROWS) * MM_ROWS;
    // Gate pre-activations of both directions, [t][8H]; reused for layer 2.
    let mut pre = vec![0.0f32; rows * 8 * h];
    for (x, row) in roll.iter().zip(pre.chunks_exact_mut(8 * h)) {
        row.copy_from_slice(&p.l1_b);
        for (n, &v) in x.iter().enumerate() {
            if v != 0.0 {
                for (r, w) in row.iter_mut().zip(&p.l1_w[n * 8 * h..][..8 * h]) {
                    *r = madd::<FMA>(v, *w, *r);
                }
            }
        }
    }
    // Layer outputs [rows][2H] (padding rows stay zero).
    let mut z = vec![0.0f32; rows * 2 * h];
    for (d, rec) in p.rec[0].iter().enumerate() {
        lstm_direction::<FMA>(rec, &pre, d, t, &mut z);
    }
    matmul::<FMA>(&z, &p.l2, &mut pre);
    for (d, rec) in p.rec[1].iter().enumerate() {
        lstm_direction::<FMA>(rec, &pre, d, t, &mut z);
    }
    let mut out = vec![0.0f32; rows * p.head.n_pad()];
    matmul::<FMA>(&z, &p.head, &mut out);
    out.chunks_exact(p.head.n_pad()).take(t).map(|r| std::array::from_fn(|c| r[c])).collect()
}

/// Runs one direction (`d` 0 forward, 1 reverse) of an LSTM layer over `t` frames: gate
/// pre-activations from `pre` (`[t][8H]`, this direction's at column `4H d`), hidden states
/// into `z` (`[t][2H]`, at column `H d`). Zero initial state.
#[inline(always)]
fn lstm_direction<const FMA: bool>(rec: &PackedRec, pre: &[f32], d: usize, t: usize, z: &mut [f32]) {
    let h = rec.hidden;
    let g4 = 4 * h;
    let mut hid = vec![0.0f32; h];
    let mut cell = vec![0.0f32; h];
    let mut gates = vec![0.0f32; g4];
    for step in 0..t {
        let f = if d == 0 { step } else { t - 1 - step };
        let p = &pre[f * 8 * h + d * g4..][..g4];
        recurrent_matvec::<FMA>(rec, &hid, p, &mut gates);
        let (gi, rest) = gates.split_at_mut(h);
        let (gf, rest) = rest.split_at_mut(h);
        let (gg, go) = rest.split_at_mut(h);
        for j in 0..h {
            let i = sigmoid(gi[j]);
            let fo = sigmoid(gf[j]);
            let g = tanh(gg[j]);
            let o = sigmoid(go[j]);
            let c = madd::<FMA>(fo, cell[j], i * g);
            cell[j] = c;
            hid[j] = o * tanh(c);
        }
        z[f * 2 * h + d * h..][..h].copy_from_slice(&hid);
    }
}

/// `gates = pre + W_hh^T h`, tile by tile with the tile's sums held in registers.
#[inline(always)]
fn recurrent_matvec<const FMA: bool>(rec: &PackedRec, hid: &[f32], pre: &[f32], gates: &mut [f32]) {
    let h = rec.hidden;
    let g4 = 4 * h;
    let full = g4 / REC_TILE;
    for tile in 0..full {
        let w = &rec.tiles[tile * h * REC_TILE..][..h * REC_TILE];
        let mut acc = [0.0f32; REC_TILE];
        acc.copy_from_slice(&pre[tile * REC_TILE..][..REC_TILE]);
        for (&hk, row) in hid.iter().zip(w.chunks_exact(REC_TILE)) {
            for (a, &wv) in acc.iter_mut().zip(row) {
                *a = madd::<FMA>(hk, wv, *a);
            }
        }
        gates[tile * REC_TILE..][..REC_TILE].copy_from_slice(&acc);
    }
    let c0 = full * REC_TILE;
    let width = g4 - c0;
    if width > 0 {
        let w = &rec.tiles[c0 * h..];
        let acc = &mut gates[c0..];
        acc.copy_from_slice(&pre[c0..]);
        for (&hk, row) in hid.iter().zip(w.chunks_exact(width)) {
            for (a, &wv) in acc.iter_mut().zip(row) {
                *a = madd::<FMA>(hk, wv, *a);
            }
        }
    }
}

/// `out[r] = x[r] W + b` for every row of `x` (`[rows][k]`, rows a multiple of
/// [`MM_ROWS`]); `out` is `[rows][n_pad]`.
#[inline(always)]
fn matmul<const FMA: bool>(x: &[f32], w: &PackedMat, out: &mut [f32]) {
    let (k, np) = (w.k, w.n_pad());
    let rows = x.len() / k;
    for r0 in (0..rows).step_by(MM_BLOCK) {
        let r1 = (r0 + MM_BLOCK).min(rows);
        for (tile, wt) in w.tiles.chunks_exact(k * MM_TILE).enumerate() {
            let mut bias = [0.0f32; MM_TILE];
            bias.copy_from_slice(&w.bias[tile * MM_TILE..][..MM_TILE]);
            for r in (r0..r1).step_by(MM_ROWS) {
                let xs: [&[f32]; MM_ROWS] = std::array::from_fn(|i| &x[(r + i) * k..][..k]);
                let mut acc = [bias; MM_ROWS];
                for (kk, wr) in wt.chunks_exact(MM_TILE).enumerate() {
                    for (a, xr) in acc.iter_mut().zip(&xs) {
                        let xv = xr[kk];
                        for (av, &wv) in a.iter_mut().zip(wr) {
                            *av = madd::<FMA>(xv, wv, *av);
                        }
                    }
                }
                for (i, a) in acc.iter().enumerate() {
                    out[(r + i) * np + tile * MM_TILE..][..MM_TILE].copy_from_slice(a);
                }
            }
        }
    }
}

/// `e^x`, branch-free and vectorisable: Cephes' `expf` range reduction and polynomial (about
/// 1 ulp), the input clamped to where the result is a normal float.
#[inline(always)]
fn exp(x: f32) -> f32 {
    const LOG2E: f32 = std::f32::consts::LOG2_E;
    const MAGIC: f32 = 12_582_912.0; // 1.5 * 2^23: adding it rounds to an integer
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    let x = x.clamp(-87.0, 88.0);
    let t = x * LOG2E + MAGIC;
    let n = t - MAGIC;
    let ni = t.to_bits() as i32 - MAGIC.to_bits() as i32;
    let r = x - n * LN2_HI - n * LN2_LO;
    let mut p = 1.987_569_1e-4f32;
    p = p * r + 1.398_199_9e-3;
    p = p * r + 8.333_452e-3;
    p = p * r + 4.166_579_6e-2;
    p = p * r + 1.666_666_5e-1;
    p = p * r + 5e-1;
    let y = p * r * r + r + 1.0;
    y * f32::from_bits(((ni + 127) as u32) << 23)
}

#[inline(always)]
fn sigmoid(x: f32) -> f32 {
    1.0 / (1.0 + exp(-x))
}

#[inline(always)]
fn tanh(x: f32) -> f32 {
    1.0 - 2.0 / (exp(2.0 * x) + 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fast_exp_sigmoid_tanh_match_std() {
        let mut worst = [0.0f32; 3];
        for i in -20_000..=20_000 {
            let x = i as f32 * 1e-3;
            worst[0] = worst[0].max(((exp(x) - x.exp()) / x.exp()).abs());
            worst[1] = worst[1].max((sigmoid(x) - 1.0 / (1.0 + (-x).exp())).abs());
            worst[2] = worst[2].max((tanh(x) - x.tanh()).abs());
        }
        assert!(worst[0] < 1e-6, "exp relative error {}", worst[0]);
        assert!(worst[1] < 1e-6 && worst[2] < 1e-6, "sigmoid/tanh abs error {worst:?}");
        assert!((0.0..1e-30).contains(&sigmoid(-1e4)) && sigmoid(1e4) == 1.0);
        assert!(tanh(1e4) == 1.0 && tanh(-1e4) == -1.0);
    }

    #[test]
    fn the_compiled_in_model_is_the_shipped_checkpoint() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let path = root.join("assets/hands/best.bpk");
        let from_file = HandWeights::load(&path).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(HandWeights::from_bytes(&bytes, &path).unwrap(), from_file);
        assert_eq!(HandModel::shipped().norm, HandModel::load(&path).unwrap().norm);
    }
}
