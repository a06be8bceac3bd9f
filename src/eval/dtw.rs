//! Dynamic time warping between two 3-D trajectories (DRUMS' "DTW" hand metric).
//!
//! Local cost: the mean absolute difference per coordinate of the two frames,
//! `(|dx| + |dy| + |dz|) / 3`, the same per-frame term as [`super::motion::l1_m`].
//! Steps: (i-1, j-1), (i-1, j), (i, j-1), each weight 1; the path runs from the first
//! frames to the last ones. Normalisation: the minimal cumulative cost divided by
//! `max(n, m)`, a per-frame average in metres. DRUMS does not state its normalisation;
//! its table (DTW 0.0479 just under L1 0.0524) fits a per-frame average, and this one
//! keeps DTW <= L1 for equal lengths because the diagonal path is one of the paths.
//!
//! Memory is two rolling rows of `m + 1` cells. An optional Sakoe-Chiba band keeps
//! only cells within `band` frames of the (length-scaled) diagonal: the result is then
//! an upper bound of the full DTW, equal to it whenever the optimal path stays inside
//! the band. The band is widened to at least `ceil(m / n)` so that a path always exists.

use super::motion::{check_trajectory, MotionMetricError};

/// Full DTW (every cell, O(n m) time), normalised by `max(n, m)`. See the module doc.
pub fn dtw(pred: &[[f32; 3]], reference: &[[f32; 3]]) -> Result<f64, MotionMetricError> {
    dtw_banded(pred, reference, None)
}

/// DTW restricted to a Sakoe-Chiba band of `band` frames around the diagonal (None:
/// full). O(n * band) time, O(m) memory.
pub fn dtw_banded(pred: &[[f32; 3]], reference: &[[f32; 3]], band: Option<usize>) -> Result<f64, MotionMetricError> {
    check_trajectory(pred, "dtw prediction")?;
    check_trajectory(reference, "dtw reference")?;
    let (n, m) = (pred.len(), reference.len());
    let w = band.map(|b| b.max(m.div_ceil(n)));
    // Column range (1-based, inclusive) of row i (1-based).
    let range = |i: usize| -> (usize, usize) {
        match w {
            None => (1, m),
            Some(w) => {
                let c = i as f64 * m as f64 / n as f64;
                let lo = (c - w as f64).floor().max(1.0) as usize;
                let hi = ((c + w as f64).ceil() as usize).min(m);
                (lo, hi)
            }
        }
    };
    let inf = f64::INFINITY;
    let mut prev = vec![inf; m + 1];
    let mut cur = vec![inf; m + 1];
    prev[0] = 0.0;
    // The cells `cur` holds from two rows ago, cleared before reuse.
    let mut stale = (0usize, 0usize);
    let mut prev_range = (0usize, 0usize);
    for i in 1..=n {
        cur[stale.0..=stale.1].fill(inf);
        let (lo, hi) = range(i);
        let p = pred[i - 1];
        let mut left = cur[lo - 1];
        for j in lo..=hi {
            let r = reference[j - 1];
            let cost = ((p[0] - r[0]).abs() + (p[1] - r[1]).abs() + (p[2] - r[2]).abs()) as f64 / 3.0;
            let best = prev[j - 1].min(prev[j]).min(left);
            left = cost + best;
            cur[j] = left;
        }
        stale = prev_range;
        prev_range = (lo, hi);
        std::mem::swap(&mut prev, &mut cur);
    }
    let total = prev[m];
    if !total.is_finite() {
        return Err(MotionMetricError::Invalid {
            what: "dtw",
            message: format!("no warping path inside the band ({n} x {m} frames)"),
        });
    }
    Ok(total / n.max(m) as f64)
}

#[cfg(test)]
mod tests {
    use super::super::motion::l1_m;
    use super::*;

    /// Flat, then a smooth rise and fall, then flat: shifting it by up to the flat
    /// margins moves nothing out of the sequence.
    fn bump(n: usize, start: usize) -> Vec<[f32; 3]> {
        (0..n)
            .map(|t| {
                let u = t as f32 - start as f32;
                let v = if (0.0..20.0).contains(&u) { (u / 20.0 * std::f32::consts::PI).sin() * 0.1 } else { 0.0 };
                [v, 0.5 * v, 1.0]
            })
            .collect()
    }

    #[test]
    fn a_time_shifted_sequence_warps_to_zero_while_l1_does_not() {
        let a = bump(60, 10);
        let b = bump(60, 14);
        assert!(dtw(&a, &b).unwrap() < 1e-9);
        assert!(dtw_banded(&a, &b, Some(5)).unwrap() < 1e-9);
        assert!(l1_m(&a, &b).unwrap() > 0.005);
    }

    #[test]
    fn a_band_narrower_than_the_shift_costs_more() {
        let a = bump(60, 10);
        let b = bump(60, 16);
        assert!(dtw_banded(&a, &b, Some(2)).unwrap() > 1e-4);
        assert!(dtw_banded(&a, &b, Some(6)).unwrap() < 1e-9);
    }

    #[test]
    fn an_offset_in_a_constant_coordinate_costs_a_third_of_it_under_any_warping() {
        // z is 1.0 throughout, so |dz| = 0.03 on every cell; x and y align exactly.
        let a = bump(40, 5);
        let b: Vec<[f32; 3]> = a.iter().map(|p| [p[0], p[1], p[2] + 0.03]).collect();
        let d = dtw(&a, &b).unwrap();
        assert!((d - 0.01).abs() < 1e-6, "{d}");
        assert!((d - l1_m(&a, &b).unwrap()).abs() < 1e-6);
    }

    #[test]
    fn dtw_never_exceeds_l1_for_equal_lengths_and_is_symmetric() {
        let a: Vec<[f32; 3]> = (0..50).map(|t| [(t as f32 * 0.3).sin() * 0.1, 0.0, (t as f32 * 0.1).cos()]).collect();
        let b: Vec<[f32; 3]> =
            (0..50).map(|t| [(t as f32 * 0.31 + 0.2).sin() * 0.1, 0.01, (t as f32 * 0.1).cos()]).collect();
        let d = dtw(&a, &b).unwrap();
        assert!(d <= l1_m(&a, &b).unwrap() + 1e-9);
        assert!((d - dtw(&b, &a).unwrap()).abs() < 1e-9);
        // A band as wide as the sequence is the full DTW.
        assert!((d - dtw_banded(&a, &b, Some(50)).unwrap()).abs() < 1e-12);
    }

    #[test]
    fn unequal_lengths_align_a_resampled_copy() {
        // b repeats every frame of a twice: warping absorbs it, cost 0.
        let a = bump(30, 5);
        let b: Vec<[f32; 3]> = a.iter().flat_map(|p| [*p, *p]).collect();
        assert!(dtw(&a, &b).unwrap() < 1e-9);
        assert!(dtw_banded(&a, &b, Some(1)).unwrap() < 1e-9);
        assert!(dtw_banded(&b, &a, Some(1)).unwrap() < 1e-9);
    }

    #[test]
    fn hand_computed_small_case() {
        // 1-D along x: a = [0, 1, 2], b = [0, 2]; best path (0,0) (1,0|1) (2,1): costs 0 + 1/3 + 0.
        let a = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        let b = [[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]];
        assert!((dtw(&a, &b).unwrap() - (1.0 / 3.0) / 3.0).abs() < 1e-12);
    }

    #[test]
    fn empty_and_nan_are_errors() {
        let a = bump(10, 0);
        assert!(matches!(dtw(&[], &a), Err(MotionMetricError::Empty { .. })));
        let mut b = a.clone();
        b[3][1] = f32::NAN;
        assert!(matches!(dtw(&a, &b), Err(MotionMetricError::NotFinite { frame: 3, .. })));
    }

    /// Not a timing assertion: prints how long 3 minutes at 60 fps takes, full and banded.
    /// Run: cargo test --release --lib eval::dtw::tests::timing_of_three_minutes -- --ignored --nocapture
    #[test]
    #[ignore]
    fn timing_of_three_minutes() {
        let n = 10_800;
        let a: Vec<[f32; 3]> = (0..n).map(|t| [(t as f32 * 0.2).sin() * 0.1, 0.3, 0.9]).collect();
        let b: Vec<[f32; 3]> = (0..n).map(|t| [(t as f32 * 0.2 + 0.3).sin() * 0.1, 0.31, 0.9]).collect();
        for band in [None, Some(120)] {
            let t0 = std::time::Instant::now();
            let d = dtw_banded(&a, &b, band).unwrap();
            println!("dtw {n} x {n}, band {band:?}: {d:.6} in {:.3} s", t0.elapsed().as_secs_f64());
        }
    }
}
