//! Savitzky-Golay smoothing: a least-squares polynomial fitted over a sliding window and
//! evaluated at the window's centre (DRUMS smooths hand speed this way before finding its
//! peaks, DESIGN.md 5).
//!
//! Coefficients come from the normal equations of the local fit, solved here (no tables),
//! so any odd window and order below it work. The ends use scipy's default `mode="interp"`:
//! the first and last `window / 2` samples take the polynomial fitted to the first (last)
//! full window, evaluated at their own position, so the output has the input's length
//! and no padding invents data.

use super::motion::MotionMetricError;

/// Weights `c` of a Savitzky-Golay fit over `window` samples at offsets `-h..=h`
/// (`h = window / 2`), polynomial `order`, evaluated at offset `at` from the centre:
/// the smoothed value is `sum_k c[k] * x[k]`. With `at = 0` these are the classic tables,
/// for example window 5, order 2: `[-3, 12, 17, 12, -3] / 35`.
pub fn savgol_coefficients(window: usize, order: usize, at: f64) -> Result<Vec<f64>, MotionMetricError> {
    check_window(window, order)?;
    let h = (window / 2) as f64;
    let p = order + 1;
    // Normal matrix (A^T A)[q][r] = sum_k x_k^(q+r), with x_k = k - h.
    let xs: Vec<f64> = (0..window).map(|k| k as f64 - h).collect();
    let mut ata = vec![vec![0.0; p]; p];
    for (q, row) in ata.iter_mut().enumerate() {
        for (r, cell) in row.iter_mut().enumerate() {
            *cell = xs.iter().map(|x| x.powi((q + r) as i32)).sum();
        }
    }
    // Solve (A^T A) z = e(at), e = [1, at, at^2, ...]; then c_k = sum_r x_k^r z_r.
    let e: Vec<f64> = (0..p).map(|q| at.powi(q as i32)).collect();
    let z = solve(ata, e).ok_or_else(|| MotionMetricError::Invalid {
        what: "savitzky-golay",
        message: format!("window {window}, order {order}: singular normal equations"),
    })?;
    Ok(xs.iter().map(|x| z.iter().enumerate().map(|(r, zr)| zr * x.powi(r as i32)).sum()).collect())
}

/// `x` smoothed by a Savitzky-Golay filter (odd `window`, `order < window`), ends by
/// `mode="interp"` (see the module doc). Needs at least `window` samples.
pub fn savgol_filter(x: &[f64], window: usize, order: usize) -> Result<Vec<f64>, MotionMetricError> {
    check_window(window, order)?;
    if x.len() < window {
        return Err(MotionMetricError::TooShort { what: "savitzky-golay input", needed: window, got: x.len() });
    }
    let h = window / 2;
    let n = x.len();
    let centre = savgol_coefficients(window, order, 0.0)?;
    let dot = |c: &[f64], start: usize| c.iter().zip(&x[start..start + window]).map(|(a, b)| a * b).sum::<f64>();
    let mut out = vec![0.0; n];
    for (i, o) in out.iter_mut().enumerate().take(n - h).skip(h) {
        *o = dot(&centre, i - h);
    }
    for i in 0..h {
        // Head: the first window's fit at offset i - h; tail mirrored on the last window.
        let head = savgol_coefficients(window, order, i as f64 - h as f64)?;
        out[i] = dot(&head, 0);
        let tail = savgol_coefficients(window, order, h as f64 - i as f64)?;
        out[n - 1 - i] = dot(&tail, n - window);
    }
    Ok(out)
}

fn check_window(window: usize, order: usize) -> Result<(), MotionMetricError> {
    if window.is_multiple_of(2) || window <= order {
        return Err(MotionMetricError::Invalid {
            what: "savitzky-golay",
            message: format!("window {window} must be odd and above the order {order}"),
        });
    }
    Ok(())
}

/// Gaussian elimination with partial pivoting; None when singular.
fn solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Option<Vec<f64>> {
    let n = b.len();
    for col in 0..n {
        let pivot = (col..n).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let (top, rest) = a.split_at_mut(col + 1);
        let pivot_row = &top[col];
        for (offset, row) in rest.iter_mut().enumerate() {
            let f = row[col] / pivot_row[col];
            for (x, p) in row[col..].iter_mut().zip(&pivot_row[col..]) {
                *x -= f * p;
            }
            b[col + 1 + offset] -= f * b[col];
        }
    }
    let mut z = vec![0.0; n];
    for row in (0..n).rev() {
        let s: f64 = (row + 1..n).map(|k| a[row][k] * z[k]).sum();
        z[row] = (b[row] - s) / a[row][row];
    }
    Some(z)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: &[f64], b: &[f64], tol: f64) -> bool {
        a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < tol)
    }

    #[test]
    fn centre_coefficients_match_the_published_tables() {
        // Savitzky & Golay (1964), quadratic/cubic smoothing tables.
        let c5 = savgol_coefficients(5, 2, 0.0).unwrap();
        assert!(close(&c5, &[-3.0, 12.0, 17.0, 12.0, -3.0].map(|v| v / 35.0), 1e-12), "{c5:?}");
        let c7 = savgol_coefficients(7, 2, 0.0).unwrap();
        assert!(close(&c7, &[-2.0, 3.0, 6.0, 7.0, 6.0, 3.0, -2.0].map(|v| v / 21.0), 1e-12), "{c7:?}");
        // Order 3 has the same centre weights as order 2 (odd terms vanish at the centre).
        assert!(close(&savgol_coefficients(7, 3, 0.0).unwrap(), &c7, 1e-12));
        let c9 = savgol_coefficients(9, 4, 0.0).unwrap();
        let t9 = [15.0, -55.0, 30.0, 135.0, 179.0, 135.0, 30.0, -55.0, 15.0].map(|v| v / 429.0);
        assert!(close(&c9, &t9, 1e-12), "{c9:?}");
    }

    #[test]
    fn reproduces_polynomials_of_its_order_everywhere_including_the_ends() {
        let x: Vec<f64> = (0..20).map(|i| 0.3 - 0.2 * i as f64 + 0.05 * (i * i) as f64).collect();
        let y = savgol_filter(&x, 7, 2).unwrap();
        assert!(close(&x, &y, 1e-9), "{y:?}");
    }

    #[test]
    fn smooths_an_alternating_spike_train() {
        // +-1 alternation is the highest frequency; window 5 order 2 leaves (-3-12... )/35 of it.
        let x: Vec<f64> = (0..30).map(|i| if i % 2 == 0 { 1.0 } else { -1.0 }).collect();
        let y = savgol_filter(&x, 5, 2).unwrap();
        let gain = (-3.0 - 12.0 + 17.0 - 12.0 - 3.0) / 35.0;
        for (i, v) in y.iter().enumerate().take(28).skip(2) {
            assert!((v - x[i] * gain).abs() < 1e-12);
        }
        assert!(gain.abs() < 0.4);
    }

    #[test]
    fn bad_windows_and_short_input_are_errors() {
        assert!(savgol_coefficients(6, 2, 0.0).is_err());
        assert!(savgol_coefficients(3, 3, 0.0).is_err());
        assert!(matches!(savgol_filter(&[1.0; 4], 7, 2), Err(MotionMetricError::TooShort { .. })));
    }
}
