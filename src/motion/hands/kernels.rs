//! The SIMD kernels of the hand model's forward pass, written against pulp's `Simd` trait so
//! that they compile to AVX2 + FMA inside `pulp::x86::V3::vectorize` (8 lanes of `f32`).
//!
//! - [`Tiles`]: a `[k][n]` matrix packed as column tiles of 16 (`[n / 16][k][16]`), so a
//!   register tile of `R` rows x 16 columns streams its weights contiguously.
//! - [`micro`]: `R` rows x 16 columns of `init + x W`, the accumulators in `2 R` registers.
//! - [`gemm`]: every row of a matrix through [`micro`], 6 rows at a time, in row blocks
//!   that stay in L2.
//! - [`lstm_update`]: an LSTM cell update over whole gate vectors, with a vectorised `exp`
//!   (the same Cephes polynomial as the scalar path, about 1 ulp).

use pulp::Simd;

/// Output columns per register tile (two AVX registers).
pub const TILE: usize = 16;
/// Rows per register tile of [`gemm`].
const GEMM_ROWS: usize = 6;
/// Rows per cache block of [`gemm`].
const GEMM_BLOCK: usize = 96;

/// A `[k][n]` row-major matrix packed as `[n_pad / TILE][k][TILE]` (zero-padded columns).
#[derive(Debug, Clone)]
pub struct Tiles {
    pub k: usize,
    pub n_pad: usize,
    pub data: Vec<f32>,
}

impl Tiles {
    pub fn new(w: &[f32], k: usize, n: usize) -> Self {
        let n_pad = n.div_ceil(TILE) * TILE;
        let mut data = vec![0.0; n_pad * k];
        for r in 0..k {
            for c in 0..n {
                data[((c / TILE) * k + r) * TILE + c % TILE] = w[r * n + c];
            }
        }
        Self { k, n_pad, data }
    }

    fn tile(&self, t: usize) -> &[f32] {
        &self.data[t * self.k * TILE..][..self.k * TILE]
    }
}

/// `out[at[i]..][..16] = init[i] + xs[i] . W_tile` for `R` rows; `w` is one packed tile
/// (`[k][16]`), `xs[i]` has `k` values, `init[i]` 16.
#[inline(always)]
pub fn micro<S: Simd, const R: usize>(
    simd: S,
    xs: [&[f32]; R],
    w: &[f32],
    init: [&[f32]; R],
    out: &mut [f32],
    at: [usize; R],
) {
    debug_assert_eq!(S::F32_LANES, 8);
    let k = w.len() / TILE;
    let xs = xs.map(|x| &x[..k]);
    let (wv, _) = S::as_simd_f32s(w);
    let wv = &wv[..2 * k];
    let mut acc: [[S::f32s; 2]; R] = std::array::from_fn(|i| {
        let (v, _) = S::as_simd_f32s(&init[i][..TILE]);
        [v[0], v[1]]
    });
    for kk in 0..k {
        let (w0, w1) = (wv[2 * kk], wv[2 * kk + 1]);
        for i in 0..R {
            let xb = simd.splat_f32s(xs[i][kk]);
            acc[i][0] = simd.mul_add_e_f32s(xb, w0, acc[i][0]);
            acc[i][1] = simd.mul_add_e_f32s(xb, w1, acc[i][1]);
        }
    }
    for i in 0..R {
        let (o, _) = S::as_mut_simd_f32s(&mut out[at[i]..][..TILE]);
        o[0] = acc[i][0];
        o[1] = acc[i][1];
    }
}

/// `out[r] = bias + x[r] W` for every row of `x` (`[rows][k]`); `out` is `[rows][n_pad]`.
#[inline(always)]
pub fn gemm<S: Simd>(simd: S, x: &[f32], w: &Tiles, bias: &[f32], out: &mut [f32]) {
    let (k, np) = (w.k, w.n_pad);
    let rows = x.len() / k;
    let row = |r: usize| &x[r * k..][..k];
    for r0 in (0..rows).step_by(GEMM_BLOCK) {
        let r1 = (r0 + GEMM_BLOCK).min(rows);
        for t in 0..np / TILE {
            let (wt, b) = (w.tile(t), &bias[t * TILE..][..TILE]);
            let mut r = r0;
            while r + GEMM_ROWS <= r1 {
                let xs: [&[f32]; GEMM_ROWS] = std::array::from_fn(|i| row(r + i));
                let at: [usize; GEMM_ROWS] = std::array::from_fn(|i| (r + i) * np + t * TILE);
                micro::<S, GEMM_ROWS>(simd, xs, wt, [b; GEMM_ROWS], out, at);
                r += GEMM_ROWS;
            }
            for r in r..r1 {
                micro::<S, 1>(simd, [row(r)], wt, [b], out, [r * np + t * TILE]);
            }
        }
    }
}

/// `gates[s] = init[s] + h[s] W_hh` for each stream `s` (`h` is `[streams][H]`, `gates`
/// `[streams][n_pad]`), four streams at a time so each weight tile is reused from L1.
#[inline(always)]
pub fn recurrent<S: Simd>(simd: S, h: &[f32], w: &Tiles, init: &[&[f32]], gates: &mut [f32]) {
    let (k, np) = (w.k, w.n_pad);
    let streams = init.len();
    let hrow = |s: usize| &h[s * k..][..k];
    for t in 0..np / TILE {
        let wt = w.tile(t);
        let mut s = 0;
        while s + 4 <= streams {
            let xs: [&[f32]; 4] = std::array::from_fn(|i| hrow(s + i));
            let ini: [&[f32]; 4] = std::array::from_fn(|i| &init[s + i][t * TILE..]);
            let at: [usize; 4] = std::array::from_fn(|i| (s + i) * np + t * TILE);
            micro::<S, 4>(simd, xs, wt, ini, gates, at);
            s += 4;
        }
        for s in s..streams {
            micro::<S, 1>(simd, [hrow(s)], wt, [&init[s][t * TILE..]], gates, [s * np + t * TILE]);
        }
    }
}

/// `e^x` on a vector: the scalar path's Cephes range reduction and polynomial, `2^n` built
/// in the exponent bits.
#[inline(always)]
fn exp<S: Simd>(simd: S, x: S::f32s) -> S::f32s {
    const MAGIC: f32 = 12_582_912.0; // 1.5 * 2^23
    let c = |v: f32| simd.splat_f32s(v);
    let x = simd.min_f32s(simd.max_f32s(x, c(-87.0)), c(88.0));
    let t = simd.mul_add_e_f32s(x, c(std::f32::consts::LOG2_E), c(MAGIC));
    let n = simd.sub_f32s(t, c(MAGIC));
    let r = simd.mul_add_e_f32s(n, c(-0.693_359_4), x);
    let r = simd.mul_add_e_f32s(n, c(2.121_944_4e-4), r);
    let mut p = c(1.987_569_1e-4);
    for k in [1.398_199_9e-3, 8.333_452e-3, 4.166_579_6e-2, 1.666_666_5e-1, 5e-1] {
        p = simd.mul_add_e_f32s(p, r, c(k));
    }
    let y = simd.add_f32s(simd.mul_add_e_f32s(simd.mul_f32s(p, r), r, r), c(1.0));
    let bits = simd.transmute_u32s_f32s(t);
    let e = simd.sub_u32s(bits, simd.splat_u32s(MAGIC.to_bits() - 127));
    let scale = simd.transmute_f32s_u32s(simd.mul_u32s(e, simd.splat_u32s(1 << 23)));
    simd.mul_f32s(y, scale)
}

#[inline(always)]
fn sigmoid<S: Simd>(simd: S, x: S::f32s) -> S::f32s {
    let one = simd.splat_f32s(1.0);
    simd.div_f32s(one, simd.add_f32s(one, exp(simd, simd.neg_f32s(x))))
}

#[inline(always)]
fn tanh<S: Simd>(simd: S, x: S::f32s) -> S::f32s {
    let one = simd.splat_f32s(1.0);
    let e = exp(simd, simd.add_f32s(x, x));
    simd.sub_f32s(one, simd.div_f32s(simd.splat_f32s(2.0), simd.add_f32s(e, one)))
}

/// One LSTM cell update: `gates` is `[i | f | g | o]` (`H` each, `H` a multiple of 8),
/// `c = sigmoid(f) c + sigmoid(i) tanh(g)`, `h = sigmoid(o) tanh(c)`.
#[inline(always)]
pub fn lstm_update<S: Simd>(simd: S, gates: &[f32], h: &mut [f32], c: &mut [f32]) {
    let n = h.len();
    let (gv, _) = S::as_simd_f32s(&gates[..4 * n]);
    let (hv, _) = S::as_mut_simd_f32s(h);
    let (cv, _) = S::as_mut_simd_f32s(c);
    let m = hv.len();
    for j in 0..m {
        let i = sigmoid(simd, gv[j]);
        let f = sigmoid(simd, gv[m + j]);
        let g = tanh(simd, gv[2 * m + j]);
        let o = sigmoid(simd, gv[3 * m + j]);
        let cn = simd.mul_add_e_f32s(f, cv[j], simd.mul_f32s(i, g));
        cv[j] = cn;
        hv[j] = simd.mul_f32s(o, tanh(simd, cn));
    }
}
