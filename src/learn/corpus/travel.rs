//! The curves strokes are made of: minimum-jerk (quintic) travel between pieces, and cubic
//! Hermite segments for the stick height (lift, downstroke, rebound), whose end slopes are the
//! strike and rebound speeds.

/// Minimum-jerk progress (Flash and Hogan 1985) at normalised time `s`: 0 at 0, 1 at 1, with
/// zero velocity and acceleration at both ends: 10 s^3 - 15 s^4 + 6 s^5. Clamped outside [0, 1].
pub fn min_jerk(s: f32) -> f32 {
    let s = s.clamp(0.0, 1.0);
    s * s * s * (10.0 + s * (-15.0 + 6.0 * s))
}

/// `a + (b - a) * s`, per coordinate.
pub fn lerp3(a: [f32; 3], b: [f32; 3], s: f32) -> [f32; 3] {
    std::array::from_fn(|i| a[i] + (b[i] - a[i]) * s)
}

/// A cubic Hermite segment from (`t0`, `h0`, slope `m0`) to (`t1`, `h1`, slope `m1`), slopes
/// in units per second; evaluated at `t` (clamped to the segment).
pub fn hermite(t0: f64, h0: f32, m0: f32, t1: f64, h1: f32, m1: f32, t: f64) -> f32 {
    let d = (t1 - t0) as f32;
    if d <= 0.0 {
        return h1;
    }
    let s = (((t - t0) as f32) / d).clamp(0.0, 1.0);
    let s2 = s * s;
    let s3 = s2 * s;
    (2.0 * s3 - 3.0 * s2 + 1.0) * h0 + (s3 - 2.0 * s2 + s) * d * m0 + (-2.0 * s3 + 3.0 * s2) * h1 + (s3 - s2) * d * m1
}

/// The largest end slope (units per second) a Hermite segment of duration `d` between height 0
/// and height `h` may have without overshooting `h` or dipping below 0: 3 h / d. A downstroke
/// or rebound faster than this would need a higher lift, so the speed is capped instead.
pub fn max_slope(h: f32, d: f64) -> f32 {
    if d <= 0.0 {
        0.0
    } else {
        3.0 * h / d as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn min_jerk_starts_and_ends_at_rest() {
        assert_eq!(min_jerk(0.0), 0.0);
        assert!((min_jerk(1.0) - 1.0).abs() < 1e-6);
        assert!((min_jerk(0.5) - 0.5).abs() < 1e-6);
        let eps = 1e-2;
        assert!(min_jerk(eps) / eps < 2e-3, "velocity at the start");
        assert!((1.0 - min_jerk(1.0 - eps)) / eps < 2e-3, "velocity at the end");
        // Monotone.
        let v: Vec<f32> = (0..=100).map(|i| min_jerk(i as f32 / 100.0)).collect();
        assert!(v.windows(2).all(|w| w[1] >= w[0]));
    }

    #[test]
    fn hermite_meets_its_ends_and_slopes() {
        let f = |t| hermite(1.0, 0.0, 2.0, 1.5, 0.3, -4.0, t);
        assert!(f(1.0).abs() < 1e-6);
        assert!((f(1.5) - 0.3).abs() < 1e-6);
        let e = 1e-4;
        assert!(((f(1.0 + e) - f(1.0)) / e as f32 - 2.0).abs() < 0.01);
        assert!(((f(1.5) - f(1.5 - e)) / e as f32 + 4.0).abs() < 0.01);
    }

    #[test]
    fn a_downstroke_within_the_slope_limit_stays_between_ground_and_apex() {
        let (h, d) = (0.1f32, 0.08f64);
        let m = max_slope(h, d);
        for i in 0..=200 {
            let t = d * i as f64 / 200.0;
            let down = hermite(0.0, h, 0.0, d, 0.0, -m, t);
            let up = hermite(0.0, 0.0, m, d, h, 0.0, t);
            assert!((-1e-6..=h + 1e-6).contains(&down), "downstroke {down} at {t}");
            assert!((-1e-6..=h + 1e-6).contains(&up), "rebound {up} at {t}");
        }
        // Twice the limit overshoots: the cap is needed.
        let over = (0..=200).map(|i| hermite(0.0, h, 0.0, d, 0.0, -2.0 * m, d * i as f64 / 200.0));
        assert!(over.fold(0.0f32, f32::max) > h * 1.01);
    }
}
