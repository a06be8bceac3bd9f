//! The forward pass on AVX2 + FMA ([`super::kernels`]), the recurrence run as parallel
//! *streams* so that each recurrent weight tile, read from L2 once per step, serves several
//! hidden states at once.
//!
//! A recurrence is sequential, so one stream would read all `4H x H` recurrent weights
//! (256 KiB at H = 128) from L2 for every frame, and that read, not arithmetic, would bound it
//! (about 2.7 us a step here). Instead a long sequence is cut into up to [`MAX_STREAMS`]
//! consecutive chunks run side by side: the first chunk of the forward direction (and the
//! last of the reverse one) starts from the zero state exactly as the network does; every
//! other chunk starts early from the zero state and discards those frames. Driven by notes,
//! an LSTM forgets its initial state, but through silence it holds it (measured: a chunk
//! starting after a long pause with 320 frames of warm-up was off by 1.9, with 640 by 1e-6),
//! so the warm-up reaches back until it holds [`WARMUP`] frames of playing (frames within
//! half a second of a note), past any pause. Then the chunks agree with the sequential pass
//! to well within the model's precision (measured in `tests/hands.rs`:
//! `chunked_inference_matches_the_sequential_pass`, on three minutes of Groove MIDI takes).
//! Sequences shorter than two chunks run as one stream, exactly.
//!
//! The two recurrences and layer 2's input projection run either in `f32` ([`Kernels::F32`],
//! [`super::kernels`]) or in 16-bit fixed point ([`Kernels::Fixed`], [`super::quant`]); the
//! gates, the cell update, layer 1's input and the output layer are `f32` in both.

use pulp::x86::V3;
use pulp::{Simd, WithSimd};

use super::kernels::{gemm, lstm_update, recurrent, Tiles, GEMM_ROWS, REC_ROWS, TILE};
use super::quant::{self, QTiles};
use super::weights::HandWeights;
use super::ROLL_COLUMNS;
use crate::motion::HAND_VALUES;

/// Most streams a direction runs side by side.
pub const MAX_STREAMS: usize = 6;
/// Frames of playing a chunk that does not start at the sequence's end warms up over.
pub const WARMUP: usize = 240;
/// A frame counts as playing within this many frames of a note (half a second).
pub const PLAYING_FRAMES: usize = 30;
/// The shortest chunk worth a stream of its own.
pub const MIN_CHUNK: usize = 1024;

/// The network laid out for the SIMD kernels, per direction.
#[derive(Debug, Clone)]
pub struct SimdNet {
    hidden: usize,
    /// Layer 1 input weights `[16][4H]` and biases `[4H]`, per direction.
    l1_w: [Vec<f32>; 2],
    l1_b: [Vec<f32>; 2],
    /// Recurrent weights `[layer][direction]`, `[H][4H]` packed.
    rec: [[Tiles; 2]; 2],
    /// Layer-2 input projection `[2H][4H]` packed, and bias, per direction.
    l2: [Tiles; 2],
    l2_b: [Vec<f32>; 2],
    /// Output layer `[2H][14]` (padded to 16), and the bias.
    head: Tiles,
    head_b: Vec<f32>,
    /// The recurrent weights and layer 2's input projection in fixed point (hidden a
    /// multiple of 16), for [`Kernels::Fixed`].
    fixed: Option<FixedNet>,
}

/// The 16-bit copies of the big matrices ([`super::quant`]).
#[derive(Debug, Clone)]
struct FixedNet {
    rec: [[QTiles; 2]; 2],
    l2: [QTiles; 2],
}

/// Which kernels do the three big products.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernels {
    /// `f32` FMA: one stream is the exact sequential pass.
    F32,
    /// 16-bit fixed point ([`super::quant`]), twice the multiply-adds an instruction.
    Fixed,
}

impl SimdNet {
    /// The layout, where the kernels can take the network (hidden a multiple of 8).
    pub fn new(w: &HandWeights) -> Option<Self> {
        let h = w.hidden;
        if h == 0 || !h.is_multiple_of(8) {
            return None;
        }
        let g4 = 4 * h;
        let [l1, l2] = &w.layers;
        let mut head_b = w.head_b.to_vec();
        head_b.resize(HAND_VALUES.div_ceil(TILE) * TILE, 0.0);
        Some(Self {
            hidden: h,
            l1_w: [l1[0].w_ih.clone(), l1[1].w_ih.clone()],
            l1_b: [l1[0].bias.clone(), l1[1].bias.clone()],
            rec: [
                [Tiles::new(&l1[0].w_hh, h, g4), Tiles::new(&l1[1].w_hh, h, g4)],
                [Tiles::new(&l2[0].w_hh, h, g4), Tiles::new(&l2[1].w_hh, h, g4)],
            ],
            l2: [Tiles::new(&l2[0].w_ih, 2 * h, g4), Tiles::new(&l2[1].w_ih, 2 * h, g4)],
            l2_b: [l2[0].bias.clone(), l2[1].bias.clone()],
            head: Tiles::new(&w.head_w[..2 * h * HAND_VALUES], 2 * h, HAND_VALUES),
            head_b,
            fixed: h.is_multiple_of(16).then(|| FixedNet {
                rec: [
                    [QTiles::new(&l1[0].w_hh, h, g4), QTiles::new(&l1[1].w_hh, h, g4)],
                    [QTiles::new(&l2[0].w_hh, h, g4), QTiles::new(&l2[1].w_hh, h, g4)],
                ],
                l2: [QTiles::new(&l2[0].w_ih, 2 * h, g4), QTiles::new(&l2[1].w_ih, 2 * h, g4)],
            }),
        })
    }
}

/// Frames within [`PLAYING_FRAMES`] of a note: where the input drives the state.
fn playing(roll: &[[f32; ROLL_COLUMNS]]) -> Vec<bool> {
    let onset: Vec<bool> = roll.iter().map(|f| f.iter().any(|&v| v != 0.0)).collect();
    let mut near = vec![false; roll.len()];
    let mut last: Option<usize> = None;
    for f in 0..roll.len() {
        if onset[f] {
            last = Some(f);
        }
        near[f] = last.is_some_and(|l| f - l <= PLAYING_FRAMES);
    }
    let mut next: Option<usize> = None;
    for f in (0..roll.len()).rev() {
        if onset[f] {
            next = Some(f);
        }
        near[f] |= next.is_some_and(|n| n - f <= PLAYING_FRAMES);
    }
    near
}

/// How many frames of `frames` (walking away from a chunk's edge) a warm-up needs to hold
/// `want` playing frames; all of them if it never does.
fn lead_over(frames: impl ExactSizeIterator<Item = bool>, want: usize) -> usize {
    let len = frames.len();
    let mut seen = 0;
    for (i, playing) in frames.enumerate() {
        seen += usize::from(playing);
        if seen >= want {
            return i + 1;
        }
    }
    len
}

/// Per stream: the first frame it owns, one past its last, and its warm-up lead (reaching
/// back in the forward direction, ahead in the reverse one, until the warm-up holds
/// `warmup` frames of playing, or to the end of the sequence). The streams run in
/// lockstep, so the chunks are sized for equal work, warm-up included: a chunk with no
/// warm-up (the first forward, the last reverse) is the longer.
fn balanced_spans(active: &[bool], d: usize, streams: usize, warmup: usize) -> Vec<(usize, usize, usize)> {
    let t = active.len();
    let lead = |a: usize, b: usize| {
        if d == 0 {
            lead_over((0..a).rev().map(|f| active[f]), warmup)
        } else {
            lead_over((b..t).map(|f| active[f]), warmup)
        }
    };
    let mut bounds: Vec<usize> = (0..=streams).map(|s| (s * t).div_ceil(streams)).collect();
    for _ in 0..3 {
        let leads: Vec<usize> = (0..streams).map(|s| lead(bounds[s], bounds[s + 1])).collect();
        let steps = (t + leads.iter().sum::<usize>()).div_ceil(streams);
        let mut next = vec![0; streams + 1];
        for s in 0..streams {
            next[s + 1] = (next[s] + steps.saturating_sub(leads[s])).min(t);
        }
        next[streams] = t;
        bounds = next;
    }
    (0..streams).map(|s| (bounds[s], bounds[s + 1], lead(bounds[s], bounds[s + 1]))).collect()
}

/// Streams and warm-up for a sequence of `t` frames.
pub fn plan(t: usize) -> (usize, usize) {
    let streams = (t / MIN_CHUNK).clamp(1, MAX_STREAMS);
    (streams, if streams > 1 { WARMUP } else { 0 })
}

/// The forward pass over a roll: raw (normalised) outputs.
pub struct Forward<'a> {
    pub v3: V3,
    pub net: &'a SimdNet,
    pub roll: &'a [[f32; ROLL_COLUMNS]],
    pub streams: usize,
    pub warmup: usize,
    /// [`Kernels::Fixed`] falls back to `f32` where the network has no fixed-point copy.
    pub kernels: Kernels,
}

impl WithSimd for Forward<'_> {
    type Output = Vec<[f32; HAND_VALUES]>;

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) -> Self::Output {
        let (p, roll) = (self.net, self.roll);
        let (h, t) = (p.hidden, roll.len());
        let (streams, warmup) = (self.streams.clamp(1, MAX_STREAMS), self.warmup);
        // Layer 1's pre-activations come straight from the sparse roll; its states go to z1.
        let active = playing(roll);
        let fixed = p.fixed.as_ref().filter(|_| self.kernels == Kernels::Fixed);
        let v3 = self.v3;
        let mut z1 = vec![0.0f32; t * 2 * h];
        for d in 0..2 {
            let mut src = RollSource::new(roll, &p.l1_w[d], &p.l1_b[d], streams);
            let mut sink = StateSink { z: &mut z1, offset: d * h, stride: 2 * h };
            let spec = Spec { d, active: &active, streams, warmup, hidden: h };
            match fixed {
                Some(f) => direction(simd, &mut FixedRecurrence::new(v3, &f.rec[0][d]), &mut src, &mut sink, spec),
                None => direction(simd, &mut F32Recurrence::new(&p.rec[0][d]), &mut src, &mut sink, spec),
            }
        }
        // Layer 2's pre-activations are made block by block from z1 as each stream reaches
        // them; its states go to z2, and then through the output layer all at once.
        let mut z2 = vec![0.0f32; t * 2 * h];
        let mut z1q = Vec::new();
        if fixed.is_some() {
            z1q.resize(t * h, 0);
            quant::quantize(v3, &z1, &mut z1q);
        }
        for d in 0..2 {
            let mut sink = StateSink { z: &mut z2, offset: d * h, stride: 2 * h };
            let spec = Spec { d, active: &active, streams, warmup, hidden: h };
            let (b, g4) = (&p.l2_b[d], p.l2[d].n_pad);
            match fixed {
                Some(f) => {
                    let proj = FixedProjection { v3, z: &z1q, w: &f.l2[d], b, xt: Vec::new() };
                    let mut src = BlockSource::new(proj, t, g4, streams, d == 1);
                    direction(simd, &mut FixedRecurrence::new(v3, &f.rec[1][d]), &mut src, &mut sink, spec);
                }
                None => {
                    let proj = F32Projection { z: &z1, w: &p.l2[d], b, xt: Vec::new() };
                    let mut src = BlockSource::new(proj, t, g4, streams, d == 1);
                    direction(simd, &mut F32Recurrence::new(&p.rec[1][d]), &mut src, &mut sink, spec);
                }
            }
        }
        let np = p.head.n_pad;
        let mut out = vec![0.0f32; BLOCK * np];
        let mut xt = Vec::new();
        let mut values = Vec::with_capacity(t);
        for z in z2.chunks(BLOCK * 2 * h) {
            let rows = z.len() / (2 * h);
            gemm(simd, z, &p.head, &p.head_b, &mut out[..rows * np], &mut xt);
            values.extend(
                out[..rows * np].chunks_exact(np).map(|r| -> [f32; HAND_VALUES] { std::array::from_fn(|c| r[c]) }),
            );
        }
        values
    }
}

/// Where a direction's gate pre-activations come from.
trait Source {
    /// Make frame `f`'s pre-activations (`4H`) ready for stream `s`.
    fn prepare<S: Simd>(&mut self, simd: S, s: usize, f: usize);
    /// Stream `s`'s pre-activations of frame `f`, after [`Source::prepare`].
    fn row(&self, s: usize, f: usize) -> &[f32];
}

/// Layer 1: bias plus the input weight rows of the notes on in the frame.
struct RollSource<'a> {
    roll: &'a [[f32; ROLL_COLUMNS]],
    w: &'a [f32],
    b: &'a [f32],
    /// Per stream, `[4H]`.
    rows: Vec<f32>,
}

impl<'a> RollSource<'a> {
    fn new(roll: &'a [[f32; ROLL_COLUMNS]], w: &'a [f32], b: &'a [f32], streams: usize) -> Self {
        Self { roll, w, b, rows: vec![0.0; streams * b.len()] }
    }
}

impl Source for RollSource<'_> {
    #[inline(always)]
    fn prepare<S: Simd>(&mut self, simd: S, s: usize, f: usize) {
        let g4 = self.b.len();
        let row = &mut self.rows[s * g4..][..g4];
        row.copy_from_slice(self.b);
        for (n, &v) in self.roll[f].iter().enumerate() {
            if v != 0.0 {
                let (rv, _) = S::as_mut_simd_f32s(row);
                let (wv, _) = S::as_simd_f32s(&self.w[n * g4..][..g4]);
                let vv = simd.splat_f32s(v);
                for (r, &w) in rv.iter_mut().zip(wv) {
                    *r = simd.mul_add_e_f32s(vv, w, *r);
                }
            }
        }
    }

    #[inline(always)]
    fn row(&self, s: usize, _f: usize) -> &[f32] {
        let g4 = self.b.len();
        &self.rows[s * g4..][..g4]
    }
}

/// Frames per block of layer-2 pre-activations a stream computes at once.
const BLOCK: usize = 48;

/// Layer 2's input projection of a run of frames: `out[r] = bias + z1[a + r] W_ih`.
trait Projection {
    fn rows<S: Simd>(&mut self, simd: S, a: usize, b: usize, out: &mut [f32]);
}

struct F32Projection<'a> {
    z: &'a [f32],
    w: &'a Tiles,
    b: &'a [f32],
    xt: Vec<[f32; GEMM_ROWS]>,
}

impl Projection for F32Projection<'_> {
    #[inline(always)]
    fn rows<S: Simd>(&mut self, simd: S, a: usize, b: usize, out: &mut [f32]) {
        let k = self.w.k;
        gemm(simd, &self.z[a * k..b * k], self.w, self.b, out, &mut self.xt);
    }
}

/// The same from the fixed-point layer-1 states.
struct FixedProjection<'a> {
    v3: V3,
    z: &'a [i32],
    w: &'a QTiles,
    b: &'a [f32],
    xt: Vec<[i32; quant::ROWS]>,
}

impl Projection for FixedProjection<'_> {
    #[inline(always)]
    fn rows<S: Simd>(&mut self, _simd: S, a: usize, b: usize, out: &mut [f32]) {
        let p = self.w.k / 2;
        quant::gemm(self.v3, &self.z[a * p..b * p], self.w, self.b, out, &mut self.xt);
    }
}

/// Layer 2: its projection computed for [`BLOCK`] frames of a stream at a time (ahead of
/// it in its direction), so no `[t][4H]` array is ever made.
struct BlockSource<P> {
    proj: P,
    frames: usize,
    g4: usize,
    reverse: bool,
    /// Per stream: `[BLOCK][4H]` and the first frame the block holds.
    blocks: Vec<f32>,
    first: Vec<Option<usize>>,
}

impl<P: Projection> BlockSource<P> {
    fn new(proj: P, frames: usize, g4: usize, streams: usize, reverse: bool) -> Self {
        Self { proj, frames, g4, reverse, blocks: vec![0.0; streams * BLOCK * g4], first: vec![None; streams] }
    }
}

impl<P: Projection> Source for BlockSource<P> {
    #[inline(always)]
    fn prepare<S: Simd>(&mut self, simd: S, s: usize, f: usize) {
        let g4 = self.g4;
        let held = self.first[s].is_some_and(|a| (a..a + BLOCK).contains(&f));
        if !held {
            let a = if self.reverse { (f + 1).saturating_sub(BLOCK) } else { f };
            let b = (a + BLOCK).min(self.frames);
            self.proj.rows(simd, a, b, &mut self.blocks[s * BLOCK * g4..][..(b - a) * g4]);
            self.first[s] = Some(a);
        }
    }

    #[inline(always)]
    fn row(&self, s: usize, f: usize) -> &[f32] {
        let g4 = self.g4;
        let a = self.first[s].unwrap_or(f);
        &self.blocks[(s * BLOCK + f - a) * g4..][..g4]
    }
}

/// A direction's recurrent product, `gates[s] = init[s] + h[s] W_hh` for every stream.
trait Recurrence {
    fn gates<S: Simd>(&mut self, simd: S, hs: &[f32], init: &[&[f32]], gates: &mut [f32]);
}

struct F32Recurrence<'a> {
    w: &'a Tiles,
    xt: Vec<[f32; REC_ROWS]>,
}

impl<'a> F32Recurrence<'a> {
    fn new(w: &'a Tiles) -> Self {
        Self { w, xt: Vec::with_capacity(w.k) }
    }
}

impl Recurrence for F32Recurrence<'_> {
    #[inline(always)]
    fn gates<S: Simd>(&mut self, simd: S, hs: &[f32], init: &[&[f32]], gates: &mut [f32]) {
        recurrent(simd, hs, self.w, init, gates, &mut self.xt);
    }
}

/// The states rounded to fixed point each step, then [`quant::recurrent`].
struct FixedRecurrence<'a> {
    v3: V3,
    w: &'a QTiles,
    hq: Vec<i32>,
    xt: Vec<[i32; quant::ROWS]>,
}

impl<'a> FixedRecurrence<'a> {
    fn new(v3: V3, w: &'a QTiles) -> Self {
        Self { v3, w, hq: Vec::new(), xt: Vec::with_capacity(w.k / 2) }
    }
}

impl Recurrence for FixedRecurrence<'_> {
    #[inline(always)]
    fn gates<S: Simd>(&mut self, _simd: S, hs: &[f32], init: &[&[f32]], gates: &mut [f32]) {
        self.hq.resize(hs.len() / 2, 0);
        quant::quantize(self.v3, hs, &mut self.hq);
        quant::recurrent(self.v3, &self.hq, self.w, init, gates, &mut self.xt);
    }
}

/// Where a direction's hidden states go.
trait Sink {
    fn emit<S: Simd>(&mut self, simd: S, f: usize, h: &[f32]);
}

/// Into `z[f][offset..]`.
struct StateSink<'a> {
    z: &'a mut [f32],
    offset: usize,
    stride: usize,
}

impl Sink for StateSink<'_> {
    #[inline(always)]
    fn emit<S: Simd>(&mut self, _simd: S, f: usize, h: &[f32]) {
        self.z[f * self.stride + self.offset..][..h.len()].copy_from_slice(h);
    }
}

/// What a direction runs over: `d` 0 forward, 1 reverse; the frames that are playing; the
/// streams and warm-up; the hidden size.
#[derive(Clone, Copy)]
struct Spec<'a> {
    d: usize,
    active: &'a [bool],
    streams: usize,
    warmup: usize,
    hidden: usize,
}

/// One direction of an LSTM layer over `t` frames as `streams` chunks: gate pre-activations
/// from `src`, the recurrent product from `rec`, hidden states of owned frames to `sink`.
#[inline(always)]
fn direction<S: Simd, R: Recurrence, Src: Source, Snk: Sink>(
    simd: S,
    rec: &mut R,
    src: &mut Src,
    sink: &mut Snk,
    spec: Spec,
) {
    let Spec { d, active, streams, warmup, hidden: h } = spec;
    let g4 = 4 * h;
    let spans = balanced_spans(active, d, streams, warmup);
    let steps = spans.iter().map(|&(a, b, lead)| b - a + lead).max().unwrap_or(0);
    let (mut hs, mut cs) = (vec![0.0f32; streams * h], vec![0.0f32; streams * h]);
    let mut gates = vec![0.0f32; streams * g4];
    let zeros = vec![0.0f32; g4];
    let mut frames = vec![None; streams];
    for j in 0..steps {
        for (s, &(a, b, lead)) in spans.iter().enumerate() {
            frames[s] = (j < b - a + lead).then(|| if d == 0 { a - lead + j } else { b - 1 + lead - j });
            if let Some(f) = frames[s] {
                src.prepare(simd, s, f);
            }
        }
        let mut init: [&[f32]; MAX_STREAMS] = [&[]; MAX_STREAMS];
        for (s, slot) in init[..streams].iter_mut().enumerate() {
            *slot = frames[s].map_or(&zeros[..], |f| src.row(s, f));
        }
        rec.gates(simd, &hs, &init[..streams], &mut gates);
        for (s, &(a, b, _)) in spans.iter().enumerate() {
            let Some(f) = frames[s] else { continue };
            lstm_update(simd, &gates[s * g4..][..g4], &mut hs[s * h..][..h], &mut cs[s * h..][..h]);
            if (a..b).contains(&f) {
                sink.emit(simd, f, &hs[s * h..][..h]);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_warm_up_reaches_back_past_a_pause_to_the_playing() {
        // Notes every 10 frames, then 400 frames of silence, then the chunk's edge.
        let mut roll = vec![[0.0f32; ROLL_COLUMNS]; 1000];
        for f in (0..500).step_by(10) {
            roll[f][2] = 1.0;
        }
        let active = playing(&roll);
        assert!(active[495] && active[520] && !active[521] && !active[899]);
        let edge = 900;
        let lead = lead_over((0..edge).rev().map(|f| active[f]), 160);
        // Back over the 379 silent frames and then 160 playing ones.
        assert_eq!(lead, (edge - 521) + 160);
        // No playing at all: back to the start (the exact zero state).
        assert_eq!(lead_over((0..100).rev().map(|_| false), 160), 100);
    }
}
