//! 16-bit fixed-point kernels for the hand model's three big products (the two recurrences
//! and layer 2's input projection), on AVX2's `vpmaddwd`: sixteen 16-bit products summed in
//! pairs into eight 32-bit lanes per instruction, twice the multiply-adds of an `f32` FMA.
//!
//! - Activations (hidden states, `|x| < 1`) are rounded to multiples of `1 / QX`.
//! - Each weight column `c` gets its own scale `s_c`, the largest for which the column's
//!   rounded weights fit 16 bits and `QX * sum_k |q_kc|` fits 31 bits, so no sum can
//!   overflow whatever the activations. With the shipped weights a column's largest weight
//!   keeps 13.3 to 14.8 bits in the recurrences, 12.5 to 13.7 in layer 2's projection.
//! - A product comes back as `init + acc * (1 / (QX s_c))` in `f32`; the gates, cell and
//!   output layer stay `f32`.
//!
//! The whole network then differs from its `f32` pass by a few thousandths of a standard
//! deviation of the targets (measured in `tests/hands.rs`), far below the model's own error.

use std::arch::x86_64::__m256i;

use pulp::x86::V3;
use pulp::{cast, f32x8, i16x16, i32x8};

use super::kernels::interleave;

/// Fixed-point scale of the activations.
pub const QX: f32 = 8192.0;
/// Columns per tile (two vectors of eight 32-bit sums).
const TILE: usize = 16;
/// `vpackssdw` interleaves its halves, so slot `j` of each block of eight pairs holds the
/// pair `8 b + PAIR_ORDER[j]`; the weights are packed in the same order.
const PAIR_ORDER: [usize; 8] = [0, 1, 4, 5, 2, 3, 6, 7];

/// A `[k][n]` row-major matrix as 16-bit column tiles: `[n_pad / 16][k / 2][2]` vectors,
/// vector `v` holding columns `8 v..8 v + 8` of the tile, each as its two rows of the pair.
#[derive(Debug, Clone)]
pub struct QTiles {
    pub k: usize,
    pub n_pad: usize,
    data: Vec<i16x16>,
    /// Per column, `1 / (QX s_c)`: a 32-bit sum times this is the `f32` product.
    scale: Vec<f32>,
}

impl QTiles {
    /// `k` must be a multiple of 16.
    pub fn new(w: &[f32], k: usize, n: usize) -> Self {
        assert!(k.is_multiple_of(16), "QTiles: k = {k} is not a multiple of 16");
        let n_pad = n.div_ceil(TILE) * TILE;
        let mut q = vec![0i16; k * n_pad];
        let mut scale = vec![0.0f32; n_pad];
        for c in 0..n {
            let col = (0..k).map(|r| w[r * n + c]);
            let max = col.clone().fold(0.0f32, |m, v| m.max(v.abs()));
            if max == 0.0 {
                continue;
            }
            let l1: f32 = col.clone().map(f32::abs).sum();
            let mut s = (32_767.0 / max).min(i32::MAX as f32 / (QX * (l1 + 0.5 * k as f32 / 32_767.0 * max)));
            // Rounding can push the sum of |q| up by k / 2; shrink until it provably fits.
            loop {
                let sum: i64 = col.clone().map(|v| ((v * s).round() as i64).abs()).sum();
                if (sum as f64) * (QX as f64) <= i32::MAX as f64 {
                    break;
                }
                s *= 0.999;
            }
            for r in 0..k {
                q[r * n_pad + c] = (w[r * n + c] * s).round() as i16;
            }
            scale[c] = 1.0 / (QX * s);
        }
        let pairs = k / 2;
        let mut data = Vec::with_capacity(n_pad / TILE * pairs * 2);
        for t in 0..n_pad / TILE {
            for slot in 0..pairs {
                let pair = slot / 8 * 8 + PAIR_ORDER[slot % 8];
                for v in 0..2 {
                    let lanes: [i16; 16] = std::array::from_fn(|l| {
                        let c = t * TILE + v * 8 + l / 2;
                        q[(2 * pair + l % 2) * n_pad + c]
                    });
                    data.push(cast(lanes));
                }
            }
        }
        Self { k, n_pad, data, scale }
    }

    fn tile(&self, t: usize) -> &[i16x16] {
        &self.data[t * self.k..][..self.k]
    }
}

/// Round `src` (`k` values, `|x| < 1`, `k` a multiple of 16) to fixed point, two to a
/// 32-bit slot in [`PAIR_ORDER`]: `dst` gets `k / 2` slots.
#[inline(always)]
pub fn quantize(v3: V3, src: &[f32], dst: &mut [i32]) {
    let qx = v3.splat_f32x8(QX);
    for (block, out) in src.chunks_exact(16).zip(dst.chunks_exact_mut(8)) {
        let (lo, hi) = block.split_at(8);
        let a: f32x8 = cast(<[f32; 8]>::try_from(lo).unwrap_or_default());
        let b: f32x8 = cast(<[f32; 8]>::try_from(hi).unwrap_or_default());
        let a: __m256i = v3.avx._mm256_cvtps_epi32(cast(v3.mul_f32x8(a, qx)));
        let b: __m256i = v3.avx._mm256_cvtps_epi32(cast(v3.mul_f32x8(b, qx)));
        let packed: [i32; 8] = cast(v3.avx2._mm256_packs_epi32(a, b));
        out.copy_from_slice(&packed);
    }
}

/// `out[at[i]..][..16] = init[i] + x_i . W_tile` for `R` rows, in fixed point: `xt[p][i]` is
/// row `i`'s slot `p` (see [`quantize`]), `w` one tile of a [`QTiles`], `scale` its 16
/// columns' scales.
#[inline(always)]
fn micro<const R: usize>(
    v3: V3,
    xt: &[[i32; R]],
    w: &[i16x16],
    scale: &[f32],
    init: [&[f32]; R],
    out: &mut [f32],
    at: [usize; R],
) {
    let zero = v3.splat_i32x8(0);
    let mut acc: [[i32x8; 2]; R] = [[zero; 2]; R];
    for (w2, x) in w.chunks_exact(2).zip(xt) {
        let (w0, w1): (__m256i, __m256i) = (cast(w2[0]), cast(w2[1]));
        for i in 0..R {
            let xb: __m256i = cast(v3.splat_i32x8(x[i]));
            acc[i][0] = v3.wrapping_add_i32x8(acc[i][0], cast(v3.avx2._mm256_madd_epi16(xb, w0)));
            acc[i][1] = v3.wrapping_add_i32x8(acc[i][1], cast(v3.avx2._mm256_madd_epi16(xb, w1)));
        }
    }
    let load = |s: &[f32]| -> f32x8 { cast(<[f32; 8]>::try_from(&s[..8]).unwrap_or_default()) };
    let s = [load(&scale[..8]), load(&scale[8..16])];
    for i in 0..R {
        for v in 0..2 {
            let sum = v3.mul_add_f32x8(v3.convert_i32x8_to_f32x8(acc[i][v]), s[v], load(&init[i][8 * v..]));
            out[at[i] + 8 * v..][..8].copy_from_slice(&cast::<f32x8, [f32; 8]>(sum));
        }
    }
}

/// Rows per register tile (twelve accumulators, as the `f32` kernels).
pub const ROWS: usize = 6;

/// `out[r] = bias + x[r] W` for every row of `x` (quantized, `[rows][k / 2]` slots); `out` is
/// `[rows][n_pad]`. Six rows at a time, every row group per weight tile.
#[inline(always)]
pub fn gemm(v3: V3, x: &[i32], w: &QTiles, bias: &[f32], out: &mut [f32], xt: &mut Vec<[i32; ROWS]>) {
    let (p, np) = (w.k / 2, w.n_pad);
    let rows = x.len() / p;
    let row = |r: usize| &x[r * p..][..p];
    let groups = rows / ROWS;
    for g in 0..groups {
        interleave::<i32, ROWS>(std::array::from_fn(|i| row(g * ROWS + i)), xt);
        for t in 0..np / TILE {
            let at: [usize; ROWS] = std::array::from_fn(|i| (g * ROWS + i) * np + t * TILE);
            let sc = &w.scale[t * TILE..][..TILE];
            micro::<ROWS>(v3, xt, w.tile(t), sc, [&bias[t * TILE..]; ROWS], out, at);
        }
    }
    for r in groups * ROWS..rows {
        let x1: Vec<[i32; 1]> = row(r).iter().map(|&v| [v]).collect();
        for t in 0..np / TILE {
            let sc = &w.scale[t * TILE..][..TILE];
            micro::<1>(v3, &x1, w.tile(t), sc, [&bias[t * TILE..]], out, [r * np + t * TILE]);
        }
    }
}

/// `gates[s] = init[s] + h[s] W` for each stream `s` (`h` quantized, `[streams][k / 2]`),
/// [`ROWS`] streams at a time, then the rest (up to four) together.
#[inline(always)]
pub fn recurrent(v3: V3, h: &[i32], w: &QTiles, init: &[&[f32]], gates: &mut [f32], xt: &mut Vec<[i32; ROWS]>) {
    let streams = init.len();
    let mut s = 0;
    while s + ROWS <= streams {
        recurrent_group::<ROWS>(v3, h, w, init, gates, s, xt);
        s += ROWS;
    }
    while s < streams {
        let rows = (streams - s).min(4);
        match rows {
            4 => recurrent_group::<4>(v3, h, w, init, gates, s, &mut Vec::new()),
            3 => recurrent_group::<3>(v3, h, w, init, gates, s, &mut Vec::new()),
            2 => recurrent_group::<2>(v3, h, w, init, gates, s, &mut Vec::new()),
            _ => recurrent_group::<1>(v3, h, w, init, gates, s, &mut Vec::new()),
        }
        s += rows;
    }
}

/// [`recurrent`] for streams `first..first + R`.
#[inline(always)]
fn recurrent_group<const R: usize>(
    v3: V3,
    h: &[i32],
    w: &QTiles,
    init: &[&[f32]],
    gates: &mut [f32],
    first: usize,
    xt: &mut Vec<[i32; R]>,
) {
    let (p, np) = (w.k / 2, w.n_pad);
    interleave::<i32, R>(std::array::from_fn(|i| &h[(first + i) * p..][..p]), xt);
    for t in 0..np / TILE {
        let ini: [&[f32]; R] = std::array::from_fn(|i| &init[first + i][t * TILE..]);
        let at: [usize; R] = std::array::from_fn(|i| (first + i) * np + t * TILE);
        micro::<R>(v3, xt, w.tile(t), &w.scale[t * TILE..][..TILE], ini, gates, at);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The fixed-point product against the `f32` one, on a matrix with one column of large
    /// weights (the overflow bound) and one of zeros.
    #[test]
    fn fixed_point_products_match_f32_within_their_rounding() {
        let Some(v3) = V3::try_new() else { return };
        let (k, n, rows) = (32, 20, 7);
        let mut s = 3u64;
        let mut rnd = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            ((s >> 40) as f32 / (1u64 << 24) as f32) * 2.0 - 1.0
        };
        let mut w: Vec<f32> = (0..k * n).map(|_| 0.3 * rnd()).collect();
        for r in 0..k {
            w[r * n + 3] = 4.0 * if r % 2 == 0 { 1.0 } else { -1.0 };
            w[r * n + 5] = 0.0;
        }
        let x: Vec<f32> = (0..rows * k).map(|_| 0.999 * rnd()).collect();
        // Activations at the extremes, aligned with column 3's signs: its largest sum.
        let x: Vec<f32> = x
            .chunks(k)
            .enumerate()
            .flat_map(|(i, r)| {
                r.iter().enumerate().map(move |(j, &v)| {
                    if i == 0 {
                        if j % 2 == 0 {
                            0.9999
                        } else {
                            -0.9999
                        }
                    } else {
                        v
                    }
                })
            })
            .collect();
        let bias: Vec<f32> = (0..32).map(|c| c as f32 * 0.01).collect();
        let qt = QTiles::new(&w, k, n);
        let mut xq = vec![0i32; rows * k / 2];
        for (src, dst) in x.chunks(k).zip(xq.chunks_mut(k / 2)) {
            v3.vectorize(|| quantize(v3, src, dst));
        }
        let mut out = vec![0.0f32; rows * qt.n_pad];
        let mut xt = Vec::new();
        v3.vectorize(|| gemm(v3, &xq, &qt, &bias, &mut out, &mut xt));
        for r in 0..rows {
            for c in 0..n {
                let exact: f32 = bias[c] + (0..k).map(|j| x[r * k + j] * w[j * n + c]).sum::<f32>();
                let l1: f32 = (0..k).map(|j| w[j * n + c].abs()).sum();
                let got = out[r * qt.n_pad + c];
                assert!((got - exact).abs() <= 1e-3 * l1 + 1e-6, "row {r} col {c}: {got} vs {exact}");
            }
        }
        assert_eq!(out[5], bias[5]);
        assert!((out[3] - (bias[3] + 0.9999 * 4.0 * k as f32)).abs() < 0.05, "{}", out[3]);
    }
}
