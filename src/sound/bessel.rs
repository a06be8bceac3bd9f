//! Bessel functions of the first kind of integer order, and the zeros of J_m and J_m'.
//! J_0..J_M at one x by Miller's backward recurrence, normalised by J_0 + 2 sum J_2k = 1.

/// Fill `out[m]` with J_m(x) for m in 0..out.len(). Accurate to ~1e-13 for x in 0..=500.
pub fn bessel_j_all(x: f64, out: &mut [f64]) {
    let m_max = out.len().saturating_sub(1);
    out.fill(0.0);
    if out.is_empty() {
        return;
    }
    let ax = x.abs();
    if ax < 1e-12 {
        out[0] = 1.0;
        return;
    }
    let start = miller_start(m_max, ax);
    let two_over_x = 2.0 / ax;
    let (mut j_next, mut j_cur) = (0.0f64, 1e-300f64);
    let mut norm = 0.0f64;
    for k in (1..=start).rev() {
        // j_cur = J_k (unnormalised); compute J_{k-1}.
        let j_prev = (k as f64 * two_over_x) * j_cur - j_next;
        j_next = j_cur;
        j_cur = j_prev;
        let order = k - 1;
        if order <= m_max {
            out[order] = j_cur;
        }
        if order % 2 == 0 && order > 0 {
            norm += 2.0 * j_cur;
        }
        if j_cur.abs() > 1e250 {
            // Rescale everything computed so far.
            j_cur *= 1e-250;
            j_next *= 1e-250;
            norm *= 1e-250;
            for v in out.iter_mut() {
                *v *= 1e-250;
            }
        }
    }
    norm += j_cur; // J_0
    let inv_norm = 1.0 / norm;
    for v in out.iter_mut() {
        *v *= inv_norm;
    }
    if x < 0.0 {
        for (m, v) in out.iter_mut().enumerate() {
            if m % 2 == 1 {
                *v = -*v;
            }
        }
    }
}

/// Where Miller's backward recurrence starts for orders up to `m_max` at |x| = `ax`: well
/// above both, at an even index.
fn miller_start(m_max: usize, ax: f64) -> usize {
    let top = m_max.max(ax as usize);
    ((top + 20 + (40.0 * (top as f64 + 1.0)).sqrt() as usize) | 1) + 1
}

/// J_m(x) for one order: the same recurrence as [`bessel_j_all`], two orders per turn (an odd
/// and an even one, so the normalising sum needs no test), keeping only the order asked for.
pub fn bessel_j(m: usize, x: f64) -> f64 {
    let ax = x.abs();
    if ax < 1e-12 {
        return if m == 0 { 1.0 } else { 0.0 };
    }
    let two_over_x = 2.0 / ax;
    // j_hi = J_k, j_top = J_(k+1) (unnormalised), k even.
    let (mut j_top, mut j_hi) = (0.0f64, 1e-300f64);
    let (mut norm, mut value) = (0.0f64, 0.0f64);
    let mut k = miller_start(m, ax);
    while k >= 2 {
        let j_odd = (k as f64 * two_over_x) * j_hi - j_top; // J_(k-1)
        let j_even = ((k - 1) as f64 * two_over_x) * j_odd - j_hi; // J_(k-2)
        if k - 1 == m {
            value = j_odd;
        } else if k - 2 == m {
            value = j_even;
        }
        norm += if k > 2 { 2.0 * j_even } else { j_even };
        (j_top, j_hi) = (j_odd, j_even);
        if j_hi.abs() > 1e250 {
            j_top *= 1e-250;
            j_hi *= 1e-250;
            norm *= 1e-250;
            value *= 1e-250;
        }
        k -= 2;
    }
    let v = value / norm;
    if x < 0.0 && m % 2 == 1 {
        -v
    } else {
        v
    }
}

/// d/dx J_m(x).
pub fn bessel_j_prime(m: usize, x: f64) -> f64 {
    if m == 0 {
        -bessel_j(1, x)
    } else {
        0.5 * (bessel_j(m - 1, x) - bessel_j(m + 1, x))
    }
}

/// Which zeros to find.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ZeroKind {
    /// Zeros of J_m (fixed edge: membranes).
    Value,
    /// Positive zeros of J_m' (free edge: plates).
    Slope,
}

/// All positive zeros below `x_max` of J_m (or J_m') for m in 0..=m_max, as (m, zero), in order
/// of m then zero.
pub fn zeros(kind: ZeroKind, m_max: usize, x_max: f64) -> Vec<(usize, f64)> {
    zeros_where(kind, m_max, x_max, |_, _| true).into_iter().map(|(m, _, z)| (m, z)).collect()
}

/// Like [`zeros`], but only refines the zeros for which `want(m, index)` is true (index 0 is
/// the first positive zero of that order), returned as (m, index, zero).
pub fn zeros_where(
    kind: ZeroKind,
    m_max: usize,
    x_max: f64,
    want: impl Fn(usize, usize) -> bool,
) -> Vec<(usize, usize, f64)> {
    let f = |m: usize, x: f64| match kind {
        ZeroKind::Value => bessel_j(m, x),
        ZeroKind::Slope => bessel_j_prime(m, x),
    };
    // Consecutive zeros of J_m and J_m' are more than 1.5 apart, so this step cannot skip one.
    let step = 0.25;
    let mut count = vec![0usize; m_max + 1];
    let mut buf = vec![0.0; m_max + 2];
    let eval_all = |x: f64, buf: &mut Vec<f64>, out: &mut Vec<f64>| {
        bessel_j_all(x, buf);
        out.clear();
        for m in 0..=m_max {
            out.push(match kind {
                ZeroKind::Value => buf[m],
                ZeroKind::Slope if m == 0 => -buf[1],
                ZeroKind::Slope => 0.5 * (buf[m - 1] - buf[m + 1]),
            });
        }
    };
    let (mut prev, mut cur) = (Vec::new(), Vec::new());
    let mut found = Vec::new();
    let mut x0 = 1e-3;
    eval_all(x0, &mut buf, &mut prev);
    while x0 < x_max {
        let x1 = (x0 + step).min(x_max);
        eval_all(x1, &mut buf, &mut cur);
        for m in 0..=m_max {
            if prev[m] != 0.0 && cur[m] != 0.0 && prev[m].signum() != cur[m].signum() {
                let index = count[m];
                count[m] += 1;
                if !want(m, index) {
                    continue;
                }
                // Illinois regula falsi: superlinear, and it keeps the bracket.
                let (mut lo, mut hi) = (x0, x1);
                let (mut flo, mut fhi) = (prev[m], cur[m]);
                let mut side = 0i8;
                for _ in 0..60 {
                    let mid = (lo * fhi - hi * flo) / (fhi - flo);
                    let fm = f(m, mid);
                    if fm == 0.0 || (hi - lo) < 1e-13 * hi {
                        (lo, hi) = (mid, mid);
                        break;
                    }
                    if fm.signum() == flo.signum() {
                        (lo, flo) = (mid, fm);
                        if side == -1 {
                            fhi *= 0.5;
                        }
                        side = -1;
                    } else {
                        (hi, fhi) = (mid, fm);
                        if side == 1 {
                            flo *= 0.5;
                        }
                        side = 1;
                    }
                }
                found.push((m, index, 0.5 * (lo + hi)));
            }
        }
        std::mem::swap(&mut prev, &mut cur);
        x0 = x1;
    }
    found.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)));
    found
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_match_tables() {
        // Abramowitz & Stegun table 9.1.
        assert!((bessel_j(0, 1.0) - 0.765_197_686_557_966_6).abs() < 1e-13);
        assert!((bessel_j(1, 1.0) - 0.440_050_585_744_933_5).abs() < 1e-13);
        assert!((bessel_j(2, 5.0) - 0.046_565_116_277_752_2).abs() < 1e-13);
        assert!((bessel_j(10, 10.0) - 0.207_486_106_633_358_9).abs() < 1e-12);
        assert!((bessel_j(0, 50.0) - 0.055_812_327_669_251_8).abs() < 1e-12);
        assert_eq!(bessel_j(3, 0.0), 0.0);
        assert_eq!(bessel_j(0, 0.0), 1.0);
    }

    #[test]
    fn one_order_agrees_with_all_orders() {
        let mut all = [0.0; 41];
        for x in [-7.3, 0.01, 0.5, 3.0, 17.25, 44.0, 120.0] {
            bessel_j_all(x, &mut all);
            for (m, want) in all.iter().enumerate() {
                let got = bessel_j(m, x);
                assert!((got - want).abs() <= 1e-15 + 1e-12 * want.abs(), "J_{m}({x}): {got} vs {want}");
            }
        }
    }

    #[test]
    fn membrane_zeros_match_tables() {
        let z = zeros(ZeroKind::Value, 3, 8.0);
        let get = |m: usize, n: usize| z.iter().filter(|(mm, _)| *mm == m).nth(n - 1).unwrap().1;
        assert!((get(0, 1) - 2.404_825_557_695_773).abs() < 1e-9);
        assert!((get(1, 1) - 3.831_705_970_207_512).abs() < 1e-9);
        assert!((get(2, 1) - 5.135_622_301_840_683).abs() < 1e-9);
        assert!((get(0, 2) - 5.520_078_110_286_311).abs() < 1e-9);
        assert!((get(3, 1) - 6.380_161_895_923_984).abs() < 1e-9);
        assert!((get(1, 2) - 7.015_586_669_815_619).abs() < 1e-9);
    }

    #[test]
    fn free_edge_zeros_match_tables() {
        let z = zeros(ZeroKind::Slope, 2, 6.0);
        let get = |m: usize, n: usize| z.iter().filter(|(mm, _)| *mm == m).nth(n - 1).unwrap().1;
        assert!((get(1, 1) - 1.841_183_781_340_659).abs() < 1e-9);
        assert!((get(2, 1) - 3.054_236_928_227_14).abs() < 1e-9);
        assert!((get(0, 1) - 3.831_705_970_207_512).abs() < 1e-9);
    }
}
