//! The forward pass on AVX2 + FMA ([`super::kernels`]), the recurrence run as parallel
//! *streams* so that each recurrent weight tile, read from L2 once per step, serves several
//! hidden states at once.
//!
//! A recurrence is sequential, so one stream would read all `4H x H` recurrent weights
//! (256 KiB at H = 128) from L2 for every frame, and that read, not arithmetic, would bound it
//! (about 2.7 us a step here). Instead a long sequence is cut into up to [`MAX_STREAMS`]
//! consecutive chunks run side by side: the first chunk of the forward direction (and the
//! last of the reverse one) starts from the zero state exactly as the network does; every
//! other chunk starts [`WARMUP`] frames early from the zero state and discards those frames.
//! An LSTM forgets its initial state, so after the warm-up the chunk's states agree with the
//! sequential ones to well within the model's precision (measured in `tests/hands.rs`:
//! `chunked_inference_matches_the_sequential_pass`). Sequences shorter than two chunks run as
//! one stream, exactly. The network was trained on 200-frame crops from the zero state, so
//! 2 s of warm-up is more context than it ever learned from.

use pulp::{Simd, WithSimd};

use super::kernels::{gemm, lstm_update, recurrent, Tiles, TILE};
use super::weights::HandWeights;
use super::ROLL_COLUMNS;
use crate::motion::HAND_VALUES;

/// Most streams a direction runs side by side.
pub const MAX_STREAMS: usize = 8;
/// Frames of warm-up before a chunk that does not start at the sequence's end.
pub const WARMUP: usize = 120;
/// The shortest chunk worth a stream of its own.
pub const MIN_CHUNK: usize = 1024;

/// The network laid out for the SIMD kernels.
#[derive(Debug, Clone)]
pub struct SimdNet {
    hidden: usize,
    /// Layer 1, both directions: `[16][8H]` and `[8H]` (forward gates, then reverse).
    l1_w: Vec<f32>,
    l1_b: Vec<f32>,
    /// Recurrent weights `[layer][direction]`, `[H][4H]` packed.
    rec: [[Tiles; 2]; 2],
    /// Layer-2 input projection `[2H][8H]` and its bias.
    l2: Tiles,
    l2_b: Vec<f32>,
    /// Output layer `[2H][14]` (padded to 16) and its bias.
    head: Tiles,
    head_b: Vec<f32>,
}

impl SimdNet {
    /// The layout, where the kernels can take the network (hidden a multiple of 8).
    pub fn new(w: &HandWeights) -> Option<Self> {
        let h = w.hidden;
        if h == 0 || h % 8 != 0 {
            return None;
        }
        let g4 = 4 * h;
        let cat = |a: &[f32], b: &[f32], rows: usize| -> Vec<f32> {
            (0..rows).flat_map(|r| a[r * g4..][..g4].iter().chain(&b[r * g4..][..g4]).copied()).collect()
        };
        let [l1f, l1r] = &w.layers[0];
        let [l2f, l2r] = &w.layers[1];
        let rec = |l: &super::weights::DirWeights| Tiles::new(&l.w_hh, h, g4);
        let mut head_b = w.head_b.to_vec();
        head_b.resize(HAND_VALUES.div_ceil(TILE) * TILE, 0.0);
        Some(Self {
            hidden: h,
            l1_w: cat(&l1f.w_ih, &l1r.w_ih, ROLL_COLUMNS),
            l1_b: cat(&l1f.bias, &l1r.bias, 1),
            rec: [[rec(l1f), rec(l1r)], [rec(l2f), rec(l2r)]],
            l2: Tiles::new(&cat(&l2f.w_ih, &l2r.w_ih, 2 * h), 2 * h, 8 * h),
            l2_b: cat(&l2f.bias, &l2r.bias, 1),
            head: Tiles::new(&w.head_w, 2 * h, HAND_VALUES),
            head_b,
        })
    }
}

/// Streams and warm-up for a sequence of `t` frames.
pub fn plan(t: usize) -> (usize, usize) {
    let streams = (t / MIN_CHUNK).clamp(1, MAX_STREAMS);
    (streams, if streams > 1 { WARMUP } else { 0 })
}

/// The forward pass over a roll: raw (normalised) outputs.
pub struct Forward<'a> {
    pub net: &'a SimdNet,
    pub roll: &'a [[f32; ROLL_COLUMNS]],
    pub streams: usize,
    pub warmup: usize,
}

impl WithSimd for Forward<'_> {
    type Output = Vec<[f32; HAND_VALUES]>;

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> Self::Output {
        let (p, roll) = (self.net, self.roll);
        let (h, t) = (p.hidden, roll.len());
        let g8 = 8 * h;
        let mut pre = vec![0.0f32; t * g8];
        for (x, row) in roll.iter().zip(pre.chunks_exact_mut(g8)) {
            row.copy_from_slice(&p.l1_b);
            for (n, &v) in x.iter().enumerate() {
                if v != 0.0 {
                    for (r, w) in row.iter_mut().zip(&p.l1_w[n * g8..][..g8]) {
                        *r += v * *w;
                    }
                }
            }
        }
        let mut z = vec![0.0f32; t * 2 * h];
        let (streams, warmup) = (self.streams.clamp(1, MAX_STREAMS), self.warmup);
        for layer in 0..2 {
            if layer == 1 {
                gemm(simd, &z, &p.l2, &p.l2_b, &mut pre);
            }
            for (d, rec) in p.rec[layer].iter().enumerate() {
                direction(simd, rec, &pre, d, t, streams, warmup, &mut z);
            }
        }
        let np = p.head.n_pad;
        let mut out = vec![0.0f32; t * np];
        gemm(simd, &z, &p.head, &p.head_b, &mut out);
        out.chunks_exact(np).map(|r| std::array::from_fn(|c| r[c])).collect()
    }
}

/// One direction (`d` 0 forward, 1 reverse) of an LSTM layer over `t` frames as `streams`
/// chunks: gate pre-activations from `pre` (`[t][8H]`, this direction's at `4H d`), hidden
/// states into `z` (`[t][2H]`, at `H d`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn direction<S: Simd>(
    simd: S,
    rec: &Tiles,
    pre: &[f32],
    d: usize,
    t: usize,
    streams: usize,
    warmup: usize,
    z: &mut [f32],
) {
    let h = rec.k;
    let (g4, g8) = (4 * h, 8 * h);
    let chunk = t.div_ceil(streams);
    // Per stream: first frame it owns, one past its last, and its warm-up lead.
    let spans: Vec<(usize, usize, usize)> = (0..streams)
        .map(|s| {
            let (a, b) = ((s * chunk).min(t), ((s + 1) * chunk).min(t));
            let lead = if d == 0 { warmup.min(a) } else { warmup.min(t - b) };
            (a, b, lead)
        })
        .collect();
    let steps = spans.iter().map(|&(a, b, lead)| b - a + lead).max().unwrap_or(0);
    let zero = vec![0.0f32; g4];
    let (mut hs, mut cs) = (vec![0.0f32; streams * h], vec![0.0f32; streams * h]);
    let mut gates = vec![0.0f32; streams * g4];
    let mut frames = vec![None; streams];
    let mut init: Vec<&[f32]> = vec![&zero; streams];
    for j in 0..steps {
        for (s, &(a, b, lead)) in spans.iter().enumerate() {
            frames[s] = (j < b - a + lead).then(|| if d == 0 { a - lead + j } else { b - 1 + lead - j });
            init[s] = frames[s].map_or(&zero[..], |f| &pre[f * g8 + d * g4..][..g4]);
        }
        recurrent(simd, &hs, rec, &init, &mut gates);
        for (s, &(a, b, _)) in spans.iter().enumerate() {
            let Some(f) = frames[s] else { continue };
            lstm_update(simd, &gates[s * g4..][..g4], &mut hs[s * h..][..h], &mut cs[s * h..][..h]);
            if (a..b).contains(&f) {
                z[f * 2 * h + d * h..][..h].copy_from_slice(&hs[s * h..][..h]);
            }
        }
    }
}
