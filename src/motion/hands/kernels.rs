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

    pub fn tile(&self, t: usize) -> &[f32] {
        &self.data[t * self.k * TILE..][..self.k * TILE]
    }
}

/// `out[at[i]..][..16] = init[i] + x_i . W_tile` for `R` rows, where `xt[kk][i]` is row
/// `i`'s `kk`-th value (the rows interleaved, so the loop has no bounds checks); `w` is one
/// packed tile (`[k][16]`), `init[i]` has 16 values.
#[inline(always)]
pub fn micro<S: Simd, const R: usize>(
    simd: S,
    xt: &[[f32; R]],
    w: &[f32],
    init: [&[f32]; R],
    out: &mut [f32],
    at: [usize; R],
) {
    debug_assert_eq!(S::F32_LANES, 8);
    let (wv, _) = S::as_simd_f32s(w);
    let mut acc: [[S::f32s; 2]; R] = std::array::from_fn(|i| {
        let (v, _) = S::as_simd_f32s(&init[i][..TILE]);
        [v[0], v[1]]
    });
    for (w2, x) in wv.chunks_exact(2).zip(xt) {
        let (w0, w1) = (w2[0], w2[1]);
        for i in 0..R {
            let xb = simd.splat_f32s(x[i]);
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

/// Interleave `R` rows of equal length into `xt` (`[len][R]`).
#[inline(always)]
pub fn interleave<T: Copy + Default, const R: usize>(rows: [&[T]; R], xt: &mut Vec<[T; R]>) {
    xt.clear();
    xt.resize(rows[0].len(), [T::default(); R]);
    for (i, row) in rows.iter().enumerate() {
        for (x, &v) in xt.iter_mut().zip(*row) {
            x[i] = v;
        }
    }
}

/// `out[r] = bias + x[r] W` for every row of `x` (`[rows][k]`, at most a cache block's
/// worth); `out` is `[rows][n_pad]`. Six rows at a time (twelve accumulators hide the FMA
/// latency), every row group per weight tile so each tile is read once.
#[inline(always)]
pub fn gemm<S: Simd>(simd: S, x: &[f32], w: &Tiles, bias: &[f32], out: &mut [f32], xt: &mut Vec<[f32; GEMM_ROWS]>) {
    let (k, np) = (w.k, w.n_pad);
    let rows = x.len() / k;
    let groups = rows / GEMM_ROWS;
    let row = |r: usize| &x[r * k..][..k];
    xt.clear();
    xt.resize(groups * k, [0.0; GEMM_ROWS]);
    for (g, chunk) in xt.chunks_exact_mut(k).enumerate() {
        for i in 0..GEMM_ROWS {
            for (c, &v) in chunk.iter_mut().zip(row(g * GEMM_ROWS + i)) {
                c[i] = v;
            }
        }
    }
    for t in 0..np / TILE {
        let wt = w.tile(t);
        for (g, chunk) in xt.chunks_exact(k).enumerate() {
            let at: [usize; GEMM_ROWS] = std::array::from_fn(|i| (g * GEMM_ROWS + i) * np + t * TILE);
            micro::<S, GEMM_ROWS>(simd, chunk, wt, [&bias[t * TILE..]; GEMM_ROWS], out, at);
        }
        for r in groups * GEMM_ROWS..rows {
            let (x1, _) = row(r).as_chunks::<1>();
            micro::<S, 1>(simd, x1, wt, [&bias[t * TILE..]], out, [r * np + t * TILE]);
        }
    }
}

/// `gates[s] = init[s] + h[s] W_hh` for each stream `s` (`h` is `[streams][H]`, `gates`
/// `[streams][n_pad]`), [`REC_ROWS`] streams at a time so each weight tile, read from L2,
/// serves them all from L1 (and twelve accumulators hide the FMA latency).
#[inline(always)]
pub fn recurrent<S: Simd>(
    simd: S,
    h: &[f32],
    w: &Tiles,
    init: &[&[f32]],
    gates: &mut [f32],
    xt: &mut Vec<[f32; REC_ROWS]>,
) {
    let (k, np) = (w.k, w.n_pad);
    let streams = init.len();
    let hrow = |s: usize| &h[s * k..][..k];
    let mut s = 0;
    while s + REC_ROWS <= streams {
        interleave::<f32, REC_ROWS>(std::array::from_fn(|i| hrow(s + i)), xt);
        for t in 0..np / TILE {
            let ini: [&[f32]; REC_ROWS] = std::array::from_fn(|i| &init[s + i][t * TILE..]);
            let at: [usize; REC_ROWS] = std::array::from_fn(|i| (s + i) * np + t * TILE);
            micro::<S, REC_ROWS>(simd, xt, w.tile(t), ini, gates, at);
        }
        s += REC_ROWS;
    }
    for (s, ini) in init.iter().enumerate().skip(s) {
        let (x1, _) = hrow(s).as_chunks::<1>();
        for t in 0..np / TILE {
            micro::<S, 1>(simd, x1, w.tile(t), [&ini[t * TILE..]], gates, [s * np + t * TILE]);
        }
    }
}

/// Streams per register tile of [`recurrent`].
pub const REC_ROWS: usize = 6;
/// Rows per register tile of [`gemm`].
pub const GEMM_ROWS: usize = 6;

/// `e^x` on a vector: the scalar path's Cephes range reduction, a degree-5 polynomial (about
/// 3e-6 relative error), `2^n` built in the exponent bits.
#[inline(always)]
fn exp<S: Simd>(simd: S, x: S::f32s) -> S::f32s {
    exp_in_range(simd, simd.min_f32s(simd.max_f32s(x, simd.splat_f32s(-87.0)), simd.splat_f32s(88.0)))
}

/// [`exp`] for `x` already within [-87, 88].
#[inline(always)]
fn exp_in_range<S: Simd>(simd: S, x: S::f32s) -> S::f32s {
    const MAGIC: f32 = 12_582_912.0; // 1.5 * 2^23
    let c = |v: f32| simd.splat_f32s(v);
    let t = simd.mul_add_e_f32s(x, c(std::f32::consts::LOG2_E), c(MAGIC));
    let n = simd.sub_f32s(t, c(MAGIC));
    let r = simd.mul_add_e_f32s(n, c(-0.693_359_4), x);
    let r = simd.mul_add_e_f32s(n, c(2.121_944_4e-4), r);
    let mut p = c(8.333_452e-3);
    for k in [4.166_579_6e-2, 1.666_666_5e-1, 5e-1] {
        p = simd.mul_add_e_f32s(p, r, c(k));
    }
    let y = simd.add_f32s(simd.mul_add_e_f32s(simd.mul_f32s(p, r), r, r), c(1.0));
    let bits = simd.transmute_u32s_f32s(t);
    let e = simd.sub_u32s(bits, simd.splat_u32s(MAGIC.to_bits() - 127));
    let scale = simd.transmute_f32s_u32s(simd.wrapping_dyn_shl_u32s(e, simd.splat_u32s(23)));
    simd.mul_f32s(y, scale)
}

#[inline(always)]
fn tanh<S: Simd>(simd: S, x: S::f32s) -> S::f32s {
    let one = simd.splat_f32s(1.0);
    let e = exp(simd, simd.add_f32s(x, x));
    simd.sub_f32s(one, simd.div_f32s(simd.splat_f32s(2.0), simd.add_f32s(e, one)))
}

/// One LSTM cell update: `gates` is `[i | f | g | o]` (`H` each, `H` a multiple of 8),
/// `c = sigmoid(f) c + sigmoid(i) tanh(g)`, `h = sigmoid(o) tanh(c)`.
///
/// Divisions are the slow part, so the three sigmoids and `tanh(g)` share one: with
/// `a = 1 + e^-i`, `b = 1 + e^-f`, `d = 1 + e^-o`, `q = e^2g + 1` and `r = 1 / (a b d q)`,
/// `sigmoid(i) = b d q r` and so on, `tanh(g) = (e^2g - 1) a b d r`. The arguments are
/// clamped to +-20 (+-10 for `tanh`), where the functions are within 2e-9 of their limits,
/// so the product stays below 1e35. Eight vectors go through each stage together: each
/// one's chain of dependent operations is long, and interleaved they keep the FMA units busy
/// (87 -> 49 cycles a vector, measured).
#[inline(always)]
pub fn lstm_update<S: Simd>(simd: S, gates: &[f32], h: &mut [f32], c: &mut [f32]) {
    let n = h.len();
    let (gv, _) = S::as_simd_f32s(&gates[..4 * n]);
    let (hv, _) = S::as_mut_simd_f32s(h);
    let (cv, _) = S::as_mut_simd_f32s(c);
    let m = hv.len();
    let mut j = 0;
    while j + UPDATE_BLOCK <= m {
        cell_block::<S, UPDATE_BLOCK>(simd, gv, m, j, hv, cv);
        j += UPDATE_BLOCK;
    }
    while j < m {
        cell_block::<S, 1>(simd, gv, m, j, hv, cv);
        j += 1;
    }
}

/// Vectors per block of [`lstm_update`].
const UPDATE_BLOCK: usize = 8;

/// [`lstm_update`] for vectors `j..j + U` of each gate.
#[inline(always)]
fn cell_block<S: Simd, const U: usize>(
    simd: S,
    gv: &[S::f32s],
    m: usize,
    j: usize,
    hv: &mut [S::f32s],
    cv: &mut [S::f32s],
) {
    let one = simd.splat_f32s(1.0);
    let mut a = [one; U];
    let mut b = [one; U];
    let mut e2g = [one; U];
    let mut d = [one; U];
    for u in 0..U {
        a[u] = sig_den(simd, gv[j + u]);
        b[u] = sig_den(simd, gv[m + j + u]);
        let g = clamp(simd, gv[2 * m + j + u], 10.0);
        e2g[u] = exp_in_range(simd, simd.add_f32s(g, g));
        d[u] = sig_den(simd, gv[3 * m + j + u]);
    }
    let mut cn = [one; U];
    let mut so = [one; U];
    for u in 0..U {
        let q = simd.add_f32s(e2g[u], one);
        let (ab, dq) = (simd.mul_f32s(a[u], b[u]), simd.mul_f32s(d[u], q));
        let r = simd.div_f32s(one, simd.mul_f32s(ab, dq));
        let si = simd.mul_f32s(simd.mul_f32s(b[u], dq), r);
        let sf = simd.mul_f32s(simd.mul_f32s(a[u], dq), r);
        so[u] = simd.mul_f32s(simd.mul_f32s(ab, q), r);
        let tg = simd.mul_f32s(simd.mul_f32s(simd.sub_f32s(e2g[u], one), simd.mul_f32s(ab, d[u])), r);
        cn[u] = simd.mul_add_e_f32s(sf, cv[j + u], simd.mul_f32s(si, tg));
    }
    for u in 0..U {
        cv[j + u] = cn[u];
        hv[j + u] = simd.mul_f32s(so[u], tanh(simd, cn[u]));
    }
}

#[inline(always)]
fn clamp<S: Simd>(simd: S, x: S::f32s, l: f32) -> S::f32s {
    simd.min_f32s(simd.max_f32s(x, simd.splat_f32s(-l)), simd.splat_f32s(l))
}

/// `1 + e^-x`, `x` clamped to +-20.
#[inline(always)]
fn sig_den<S: Simd>(simd: S, x: S::f32s) -> S::f32s {
    simd.add_f32s(simd.splat_f32s(1.0), exp_in_range(simd, simd.neg_f32s(clamp(simd, x, 20.0))))
}
