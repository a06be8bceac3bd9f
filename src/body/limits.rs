//! Joint limits after "Algorithm 1" of the Hybrid Inverse Motion Control method (DESIGN.md 1b).
//!
//! A joint's rotations from motion data are summarised by an ellipsoid in the tangent space at
//! their mean. Each sample q maps to the rotation vector t = log(mean⁻¹ q) (angle × axis,
//! shortest arc, |t| ≤ π). The eigenvectors of the second moment of those vectors (taken about
//! t = 0, the mean rotation, which is the ellipsoid's centre) are the ellipsoid's axes; the
//! radii are the standard deviations along them, scaled just enough to hold every sample. In
//! simulation a joint whose tangent vector leaves the ellipsoid is pushed toward the nearest
//! point of the ellipsoid surface ([`CompiledLimit::restoring`]).
//!
//! Convention: q is the child's rotation relative to its parent, R_child = R_parent q. The
//! tangent vector lives in the mean's (child-side) frame; the restoring vector is in the parent
//! frame.
//!
//! [`JointLimit`] is the stored form (f32, serde). [`CompiledLimit`] is the hot-path form (f64,
//! `Copy`, built once by [`JointLimit::compile`]): inverse mean, orthonormalised axes and inverse
//! radii precomputed; none of its methods allocate. The query methods on `JointLimit` compile on
//! every call (about 60 flops more); they are for tools and tests.

use nalgebra::{Matrix3, Matrix4, Quaternion, SymmetricEigen, UnitQuaternion, Vector3};

/// Fewest samples [`JointLimit::fit`] accepts.
pub const MIN_SAMPLES: usize = 4;

/// Why a limit could not be fitted or compiled.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LimitError {
    #[error("need at least {MIN_SAMPLES} samples to fit a joint limit, got {count}")]
    TooFewSamples { count: usize },
    #[error("sample {index} is not a finite, non-zero quaternion")]
    BadSample { index: usize },
    #[error("{name} = {value} must be finite and {rule}")]
    BadParameter { name: &'static str, value: f32, rule: &'static str },
    #[error("the eigen decomposition for the {what} did not converge")]
    NoConvergence { what: &'static str },
    #[error("invalid joint limit: {what}")]
    InvalidLimit { what: &'static str },
    #[error("joint {joint}: {error}")]
    Joint { joint: usize, error: Box<LimitError> },
}

/// One joint's limit: an ellipsoid in the tangent space (rotation vectors) at the mean rotation.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointLimit {
    /// Unit quaternion (w, x, y, z) of the mean rotation.
    pub mean: [f32; 4],
    /// The principal axes (unit, orthonormal up to f32 rounding) in the tangent space, largest first.
    pub axes: [[f32; 3]; 3],
    /// Ellipsoid semi-axes along `axes`, radians.
    pub radii: [f32; 3],
}

impl JointLimit {
    /// Fit from samples. The mean is Markley's (eigenvector of Σ q qᵀ with the largest
    /// eigenvalue), so q and -q count as the same rotation. The axes are the eigenvectors of the
    /// second moment of the tangent vectors; the radii are the standard deviations times the
    /// largest Mahalanobis distance of any sample, times (1 + margin), each at least
    /// `min_radius_rad`. Every sample is then inside (checked in f64 against the stored f32 form).
    /// A standard deviation below 1e-6 of the largest is raised to that, so planar data works.
    pub fn fit(samples: &[UnitQuaternion<f32>], margin: f32, min_radius_rad: f32) -> Result<JointLimit, LimitError> {
        if !(margin.is_finite() && margin >= 0.0) {
            return Err(LimitError::BadParameter { name: "margin", value: margin, rule: ">= 0" });
        }
        if !(min_radius_rad.is_finite() && min_radius_rad > 0.0) {
            return Err(LimitError::BadParameter { name: "min_radius_rad", value: min_radius_rad, rule: "> 0" });
        }
        if samples.len() < MIN_SAMPLES {
            return Err(LimitError::TooFewSamples { count: samples.len() });
        }
        let mut moment = Matrix4::<f64>::zeros();
        for (index, q) in samples.iter().enumerate() {
            let c = to_f64(q).coords;
            let norm = c.norm();
            if !(norm.is_finite() && norm > 0.0) {
                return Err(LimitError::BadSample { index });
            }
            moment += c * c.transpose() / (norm * norm);
        }
        let eig = SymmetricEigen::try_new(moment, f64::EPSILON, 1000)
            .ok_or(LimitError::NoConvergence { what: "mean rotation" })?;
        let c = eig.eigenvectors.column(eig.eigenvalues.imax()).into_owned();
        let c = if c[3] < 0.0 { -c } else { c }; // coords are (x, y, z, w); keep w >= 0
        let mean = [c[3] as f32, c[0] as f32, c[1] as f32, c[2] as f32];

        let inv_mean = unit(mean).conjugate();
        let tangents: Vec<Vector3<f64>> = samples.iter().map(|q| log(inv_mean * to_f64(q))).collect();
        let second = tangents.iter().map(|t| t * t.transpose()).sum::<Matrix3<f64>>() / tangents.len() as f64;
        let eig = SymmetricEigen::try_new(second, f64::EPSILON, 1000)
            .ok_or(LimitError::NoConvergence { what: "tangent spread" })?;
        let mut order = [0, 1, 2];
        order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
        let a0 = canonical_sign(eig.eigenvectors.column(order[0]).into_owned());
        let a1 = canonical_sign(eig.eigenvectors.column(order[1]).into_owned());
        let axes = [a0, a1, a0.cross(&a1)].map(|a| [a.x as f32, a.y as f32, a.z as f32]);

        // Mahalanobis distances in the frame exactly as `CompiledLimit` rebuilds it from f32.
        let frame = axes_matrix(&axes);
        let floor = (eig.eigenvalues[order[0]] * 1e-12).max(1e-30);
        let sd = Vector3::from_fn(|i, _| eig.eigenvalues[order[i]].max(floor).sqrt());
        let scale = tangents.iter().map(|t| (frame * t).component_div(&sd).norm()).fold(0.0, f64::max);
        // The 1e-9 slack and upward rounding keep the extreme sample inside despite rounding.
        let radii =
            [0, 1, 2].map(|i| round_up(scale * sd[i] * (1.0 + margin as f64) * (1.0 + 1e-9)).max(min_radius_rad));
        Ok(JointLimit { mean, axes, radii })
    }

    /// A limit that never binds (radii = π, the largest tangent length) around identity.
    pub fn free() -> JointLimit {
        let pi = std::f32::consts::PI; // rounds above f64's π, so even |t| = π is inside
        JointLimit {
            mean: [1.0, 0.0, 0.0, 0.0],
            axes: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            radii: [pi; 3],
        }
    }

    /// Check the limit (finite, unit mean and orthonormal axes within 1e-3, positive radii) and
    /// build the hot-path form.
    pub fn compile(&self) -> Result<CompiledLimit, LimitError> {
        let bad = |what| Err(LimitError::InvalidLimit { what });
        if !self.mean.iter().chain(self.axes.iter().flatten()).chain(&self.radii).all(|v| v.is_finite()) {
            return bad("a value is NaN or infinite");
        }
        if (Quaternion::from(self.mean.map(f64::from)).norm() - 1.0).abs() > 1e-3 {
            return bad("mean is not a unit quaternion");
        }
        if self.radii.iter().any(|&r| r <= 0.0) {
            return bad("a radius is not positive");
        }
        let a = Matrix3::from_fn(|i, j| f64::from(self.axes[i][j]));
        if (a * a.transpose() - Matrix3::identity()).amax() > 1e-3 {
            return bad("axes are not orthonormal");
        }
        Ok(CompiledLimit::unchecked(self))
    }

    /// The mean rotation.
    pub fn mean(&self) -> UnitQuaternion<f32> {
        let [w, x, y, z] = self.mean;
        UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z))
    }

    /// log(mean⁻¹ q) as a rotation vector. On a limit that fails [`JointLimit::compile`] this and
    /// the other queries below return unspecified (possibly NaN) values, but never panic.
    pub fn tangent(&self, q: &UnitQuaternion<f32>) -> Vector3<f32> {
        CompiledLimit::unchecked(self).tangent(q)
    }
    /// Inside or on the ellipsoid (tolerance 0).
    pub fn contains(&self, q: &UnitQuaternion<f32>) -> bool {
        CompiledLimit::unchecked(self).contains(q)
    }
    /// sqrt(Σ (tᵢ / rᵢ)²) of q's tangent components tᵢ along the axes: 1 on the surface.
    pub fn normalized_radius(&self, q: &UnitQuaternion<f32>) -> f32 {
        CompiledLimit::unchecked(self).normalized_radius(q)
    }
    /// See [`CompiledLimit::nearest_allowed`].
    pub fn nearest_allowed(&self, q: &UnitQuaternion<f32>) -> UnitQuaternion<f32> {
        CompiledLimit::unchecked(self).nearest_allowed(q)
    }
    /// See [`CompiledLimit::restoring`].
    pub fn restoring(&self, q: &UnitQuaternion<f32>) -> Option<Vector3<f32>> {
        CompiledLimit::unchecked(self).restoring(q)
    }
}

/// Fit every joint at once: `trajectories[j]` is joint j's samples. Errors name the joint.
pub fn fit_all(
    trajectories: &[Vec<UnitQuaternion<f32>>],
    margin: f32,
    min_radius_rad: f32,
) -> Result<Vec<JointLimit>, LimitError> {
    let fit = |(joint, samples): (usize, &Vec<_>)| {
        JointLimit::fit(samples, margin, min_radius_rad).map_err(|e| LimitError::Joint { joint, error: Box::new(e) })
    };
    trajectories.iter().enumerate().map(fit).collect()
}

/// A [`JointLimit`] ready for the physics step (10 kHz): f64, precomputed, allocation-free.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompiledLimit {
    mean: Quaternion<f64>,
    inv_mean: Quaternion<f64>,
    /// Rows: the orthonormalised principal axes.
    axes: Matrix3<f64>,
    radii: Vector3<f64>,
    inv_radii: Vector3<f64>,
}

impl CompiledLimit {
    fn unchecked(limit: &JointLimit) -> CompiledLimit {
        let mean = unit(limit.mean);
        let radii = Vector3::from(limit.radii.map(f64::from));
        let inv_radii = radii.map(|r| 1.0 / r);
        CompiledLimit { mean, inv_mean: mean.conjugate(), axes: axes_matrix(&limit.axes), radii, inv_radii }
    }

    /// q's tangent vector in axis coordinates.
    fn local(&self, q: &UnitQuaternion<f32>) -> Vector3<f64> {
        self.axes * log(self.inv_mean * to_f64(q))
    }

    fn radius_sq(&self, y: &Vector3<f64>) -> f64 {
        y.component_mul(&self.inv_radii).norm_squared()
    }

    /// log(mean⁻¹ q) as a rotation vector.
    pub fn tangent(&self, q: &UnitQuaternion<f32>) -> Vector3<f32> {
        log(self.inv_mean * to_f64(q)).cast()
    }
    /// Inside or on the ellipsoid (tolerance 0).
    pub fn contains(&self, q: &UnitQuaternion<f32>) -> bool {
        self.radius_sq(&self.local(q)) <= 1.0
    }
    /// sqrt(Σ (tᵢ / rᵢ)²): 1 on the surface.
    pub fn normalized_radius(&self, q: &UnitQuaternion<f32>) -> f32 {
        self.radius_sq(&self.local(q)).sqrt() as f32
    }

    /// The point of the ellipsoid nearest (Euclidean, in the tangent space) to q's tangent
    /// vector, as a rotation; q itself if inside.
    pub fn nearest_allowed(&self, q: &UnitQuaternion<f32>) -> UnitQuaternion<f32> {
        self.nearest(q).map_or(*q, |n| UnitQuaternion::from_quaternion(n.cast()))
    }

    /// None inside; otherwise the rotation vector r in the joint's parent frame with
    /// exp(r) q = nearest_allowed(q), i.e. log(nearest q⁻¹). Apply torque k r to the child and
    /// -k r to the parent.
    pub fn restoring(&self, q: &UnitQuaternion<f32>) -> Option<Vector3<f32>> {
        self.nearest(q).map(|n| log(n * to_f64(q).conjugate()).cast())
    }

    fn nearest(&self, q: &UnitQuaternion<f32>) -> Option<Quaternion<f64>> {
        let y = self.local(q);
        if self.radius_sq(&y) <= 1.0 {
            return None;
        }
        let x = closest_on_ellipsoid(&y, &self.radii);
        Some(self.mean * exp(self.axes.transpose() * x))
    }
}

/// The closest point to y (outside) on the ellipsoid Σ (xᵢ/rᵢ)² = 1. It is xᵢ = rᵢ² yᵢ / (rᵢ² + s)
/// where s > 0 is the root of F(s) = Σ (rᵢ yᵢ / (rᵢ² + s))² - 1 (Lagrange multiplier, as in
/// Eberly's "Distance from a point to an ellipse, an ellipsoid, or a hyperellipsoid"). For an
/// outside point F is convex and decreasing on s ≥ 0, so Newton from a lower bound climbs
/// monotonically to the root; points on the axes need no special case and the radii need no order.
fn closest_on_ellipsoid(y: &Vector3<f64>, r: &Vector3<f64>) -> Vector3<f64> {
    let r2 = r.component_mul(r);
    let ry = r.component_mul(y).abs();
    // Each term alone is at most 1 at the root: s ≥ rᵢ|yᵢ| - rᵢ², so F ≥ 0 here.
    let mut s = (ry - r2).max().max(0.0);
    for _ in 0..100 {
        let u = ry.component_div(&r2.add_scalar(s));
        let f = u.norm_squared() - 1.0;
        let df = -2.0 * u.component_mul(&u).component_div(&r2.add_scalar(s)).sum();
        let next = s - f / df;
        if f <= 0.0 || next.is_nan() || next <= s {
            break;
        }
        s = next;
    }
    Vector3::from_fn(|i, _| r2[i] * y[i] / (r2[i] + s))
}

/// Rotation vector (angle × axis) of q, shortest arc; q's scale does not matter.
fn log(q: Quaternion<f64>) -> Vector3<f64> {
    let (w, v) = if q.w < 0.0 { (-q.w, -q.imag()) } else { (q.w, q.imag()) };
    let s = v.norm();
    if s == 0.0 {
        return Vector3::zeros();
    }
    v * (2.0 * s.atan2(w) / s)
}

/// Unit quaternion of a rotation vector.
fn exp(r: Vector3<f64>) -> Quaternion<f64> {
    let angle = r.norm();
    let k = if angle < 1e-8 { 0.5 } else { (0.5 * angle).sin() / angle };
    Quaternion::from_parts((0.5 * angle).cos(), r * k)
}

fn to_f64(q: &UnitQuaternion<f32>) -> Quaternion<f64> {
    q.quaternion().cast()
}

/// (w, x, y, z) normalised in f64.
fn unit([w, x, y, z]: [f32; 4]) -> Quaternion<f64> {
    Quaternion::new(w, x, y, z).cast::<f64>().normalize()
}

/// Rows: the axes, orthonormalised (Gram-Schmidt; the third is the cross product: an axis's sign
/// does not change an ellipsoid).
fn axes_matrix(axes: &[[f32; 3]; 3]) -> Matrix3<f64> {
    let v = |i: usize| Vector3::from(axes[i].map(f64::from));
    let a0 = v(0).normalize();
    let a1 = (v(1) - a0 * a0.dot(&v(1))).normalize();
    Matrix3::from_rows(&[a0.transpose(), a1.transpose(), a0.cross(&a1).transpose()])
}

/// The largest component positive, so that fits are reproducible.
fn canonical_sign(v: Vector3<f64>) -> Vector3<f64> {
    if v[v.iamax()] < 0.0 {
        -v
    } else {
        v
    }
}

/// The smallest f32 not below a positive finite x.
fn round_up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x {
        f32::from_bits(y.to_bits() + 1)
    } else {
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// splitmix64 with Box-Muller: deterministic, no rand crate.
    struct Rng(u64);
    impl Rng {
        fn uniform(&mut self) -> f64 {
            self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
            let mut z = self.0;
            z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 + 0.5 / (1u64 << 53) as f64
        }
        fn gauss(&mut self) -> f64 {
            (-2.0 * self.uniform().ln()).sqrt() * (std::f64::consts::TAU * self.uniform()).cos()
        }
    }

    fn true_mean() -> UnitQuaternion<f64> {
        UnitQuaternion::from_axis_angle(
            &nalgebra::Unit::new_normalize(Vector3::new(1.0, 2.0, -1.0)),
            40f64.to_radians(),
        )
    }
    /// Columns: the true principal axes, largest spread first.
    fn true_axes() -> Rotation3<f64> {
        Rotation3::from_euler_angles(0.3, -0.7, 1.1)
    }
    const SD: [f64; 3] = [0.3, 0.1, 0.03];

    /// Samples mean * exp(t), t Gaussian with standard deviations SD along the true axes.
    fn samples(n: usize, seed: u64) -> Vec<UnitQuaternion<f32>> {
        let mut rng = Rng(seed);
        let (mean, axes) = (true_mean(), true_axes());
        (0..n)
            .map(|_| {
                let t = axes * Vector3::from_fn(|i, _| SD[i] * rng.gauss());
                UnitQuaternion::from_quaternion((mean.into_inner() * exp(t)).cast())
            })
            .collect()
    }

    /// mean * exp(Aᵀ y): the rotation whose tangent has axis coordinates y.
    fn at(limit: &JointLimit, y: Vector3<f64>) -> UnitQuaternion<f32> {
        let c = CompiledLimit::unchecked(limit);
        UnitQuaternion::from_quaternion((c.mean * exp(c.axes.transpose() * y)).cast())
    }

    fn angle_between(a: &UnitQuaternion<f32>, b: &UnitQuaternion<f32>) -> f64 {
        log(to_f64(a).conjugate() * to_f64(b)).norm()
    }

    #[test]
    fn fit_recovers_known_mean_axes_and_spread() {
        let limit = JointLimit::fit(&samples(20_000, 1), 0.1, 1e-3).unwrap();
        let mean_err = angle_between(&limit.mean(), &true_mean().cast());
        assert!(mean_err < 0.01, "mean is {mean_err} rad off");
        let dots = [0, 1, 2].map(|i| {
            let dot = Vector3::from(limit.axes[i].map(f64::from)).dot(&true_axes().matrix().column(i)).abs();
            assert!(dot > 0.99, "axis {i}: |dot| = {dot}");
            dot
        });
        // Gaussian data: radii = scale * sd * 1.1, so their ratios are the sd ratios (1/3, 1/10).
        let r = limit.radii.map(f64::from);
        let (r1, r2) = (r[1] / r[0] / (SD[1] / SD[0]), r[2] / r[0] / (SD[2] / SD[0]));
        assert!((r1 - 1.0).abs() < 0.03 && (r2 - 1.0).abs() < 0.03, "ratio errors {r1} {r2}");
        // The scale is the largest Mahalanobis distance of 20000 3-D Gaussian draws: about 4.9.
        let scale = r[0] / (SD[0] * 1.1);
        assert!((4.0..6.0).contains(&scale), "scale {scale}");
        let d = dots.map(|d| 1.0 - d);
        println!("mean err {mean_err:.2e} rad, 1 - |dot| {:.1e} {:.1e} {:.1e}, ratios/true {r1:.4} {r2:.4}, scale {scale:.3}", d[0], d[1], d[2]);
    }

    #[test]
    fn flipping_quaternion_signs_gives_the_same_fit() {
        let plain = samples(500, 2);
        let flipped: Vec<_> = plain
            .iter()
            .enumerate()
            .map(|(i, q)| if i % 2 == 0 { UnitQuaternion::new_unchecked(-q.into_inner()) } else { *q })
            .collect();
        assert!(flipped.iter().filter(|q| q.w < 0.0).count() >= 250);
        // Negation is exact in floating point and every step is sign-blind, so the fits are equal.
        assert_eq!(JointLimit::fit(&plain, 0.1, 1e-3).unwrap(), JointLimit::fit(&flipped, 0.1, 1e-3).unwrap());
    }

    #[test]
    fn every_training_sample_is_inside_and_far_points_are_not() {
        let data = samples(2000, 3);
        let tight = JointLimit::fit(&data, 0.0, 1e-3).unwrap();
        let worst = data.iter().map(|q| tight.normalized_radius(q)).fold(0.0, f32::max);
        assert!(data.iter().all(|q| tight.contains(q)));
        assert!(worst > 1.0 - 1e-6, "the tight fit is loose: extreme sample at {worst}");

        let limit = JointLimit::fit(&data, 0.05, 1e-3).unwrap();
        assert!(data.iter().all(|q| limit.contains(q)));
        let along = at(&limit, Vector3::new(1.5 * f64::from(limit.radii[0]), 0.0, 0.0));
        assert!(!limit.contains(&along) && (limit.normalized_radius(&along) - 1.5).abs() < 1e-5);
        let extreme = data.iter().max_by(|a, b| limit.normalized_radius(a).total_cmp(&limit.normalized_radius(b)));
        let t = log(unit(limit.mean).conjugate() * to_f64(extreme.unwrap()));
        let beyond = UnitQuaternion::from_quaternion((unit(limit.mean) * exp(1.5 * t)).cast());
        let nr = limit.normalized_radius(&beyond);
        assert!(!limit.contains(&beyond) && (nr - 1.5 / 1.05).abs() < 1e-4, "scaled extreme at {nr}");
    }

    fn hand_limit() -> JointLimit {
        let axes = true_axes();
        let axes = [0, 1, 2].map(|i| [0, 1, 2].map(|j| axes[(j, i)] as f32));
        let m = true_mean();
        JointLimit { mean: [m.w, m.i, m.j, m.k].map(|v| v as f32), axes, radii: [0.8, 0.4, 0.1] }
    }

    #[test]
    fn nearest_allowed_is_on_the_surface_and_closest() {
        let limit = hand_limit();
        let r = Vector3::from(limit.radii.map(f64::from));
        let mut rng = Rng(4);
        let mut points = vec![
            Vector3::new(1.0, 0.0, 0.0),
            Vector3::new(0.0, -0.7, 0.0),
            Vector3::new(0.0, 0.0, 0.3),
            Vector3::new(0.0, 0.0, -2.0), // far out on the shortest axis: the nearest point is the pole
        ];
        for _ in 0..12 {
            let u = Vector3::from_fn(|_, _| rng.gauss());
            points.push(u / u.component_div(&r).norm() * (1.05 + 1.5 * rng.uniform()));
        }
        let surface: Vec<Vector3<f32>> = (0..45 * 45)
            .map(|k| {
                let (theta, phi) = (std::f64::consts::PI * ((k / 45) as f64 + 0.5) / 45.0, 0.14 * (k % 45) as f64);
                let y = Vector3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()).component_mul(&r);
                limit.tangent(&at(&limit, y))
            })
            .collect();
        let mut worst_gap: f32 = 0.0;
        for y in points {
            let q = at(&limit, y);
            let near = limit.nearest_allowed(&q);
            let nr = limit.normalized_radius(&near);
            assert!((nr - 1.0).abs() < 1e-4, "nearest point of {y:?} at normalized radius {nr}");
            let t = limit.tangent(&q);
            let exact = (limit.tangent(&near) - t).norm();
            let brute = surface.iter().map(|s| (s - t).norm()).fold(f32::INFINITY, f32::min);
            assert!(exact <= brute + 1e-5, "{y:?}: exact {exact} farther than sampled {brute}");
            worst_gap = worst_gap.max(brute - exact);
        }
        assert!(worst_gap < 0.05, "the surface sampling is too coarse to test: gap {worst_gap}");
        let inside = at(&limit, Vector3::new(0.3, 0.1, 0.02));
        assert_eq!(limit.nearest_allowed(&inside), inside);
        println!("largest (sampled - exact) distance {worst_gap:.2e} rad");
    }

    #[test]
    fn restoring_rotation_is_in_the_parent_frame() {
        let limit = hand_limit();
        assert_eq!(limit.restoring(&limit.mean()), None);
        assert_eq!(limit.restoring(&at(&limit, Vector3::new(0.0, 0.0, 0.099))), None);
        let mut rng = Rng(5);
        for _ in 0..20 {
            let y = Vector3::from_fn(|_, _| rng.gauss()).normalize() * 1.2;
            let q = at(&limit, y);
            let r = limit.restoring(&q).expect("outside");
            let near = limit.nearest_allowed(&q);
            let err = angle_between(&(UnitQuaternion::from_scaled_axis(r) * q), &near);
            assert!(err < 1e-5, "exp(r) q misses nearest_allowed(q) by {err} rad");
            // The child-frame reading q exp(r) would miss: the frame is really tested.
            assert!(angle_between(&(q * UnitQuaternion::from_scaled_axis(r)), &near) > 1e-3);
        }
    }

    #[test]
    fn restoring_torque_brings_a_free_body_back() {
        // One rigid body (isotropic inertia 0.01 kg m², fixed parent = world), torque k r - d ω,
        // world-frame angular velocity ω, q ← exp(ω dt) q; k = 10 N m/rad, d near critical.
        let limit = hand_limit().compile().unwrap();
        let (inertia, dt, k, d) = (0.01f32, 1e-4f32, 10.0f32, 0.6f32);
        let mut q = at(&hand_limit(), Vector3::new(0.5, 0.3, 0.12));
        let start = limit.normalized_radius(&q);
        // Outward: along the ellipsoid normal at q, mapped from the mean's frame to the world.
        let normal = CompiledLimit::unchecked(&hand_limit()).axes.transpose()
            * limit.local(&q).component_div(&limit.radii.component_mul(&limit.radii));
        let mut omega = q * (2.0 * normal.normalize()).cast::<f32>();
        let mut peak = start;
        for _ in 0..20_000 {
            let torque = limit.restoring(&q).map_or(Vector3::zeros(), |r| k * r) - d * omega;
            omega += torque / inertia * dt;
            q = UnitQuaternion::from_scaled_axis(omega * dt) * q;
            peak = peak.max(limit.normalized_radius(&q));
        }
        assert!(start > 1.0 && peak > start, "the body did not start outside moving out ({start}, {peak})");
        let miss = (limit.tangent(&limit.nearest_allowed(&q)) - limit.tangent(&q)).norm();
        assert!(miss < 0.01, "ended {miss} rad outside (normalized radius {})", limit.normalized_radius(&q));
        println!("start {start:.3}, peak {peak:.3}, end {:.5}, miss {miss:.2e} rad", limit.normalized_radius(&q));
    }

    #[test]
    fn free_limit_never_binds_and_round_trips_through_json() {
        let free = JointLimit::free();
        let mut rng = Rng(6);
        for _ in 0..1000 {
            let v = Vector3::from_fn(|_, _| rng.gauss()).normalize() * std::f64::consts::PI * rng.uniform().sqrt();
            assert_eq!(free.restoring(&UnitQuaternion::from_scaled_axis(v.cast())), None);
        }
        assert!(free.contains(&UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f32::consts::PI)));
        let json = serde_json::to_string(&hand_limit()).unwrap();
        assert_eq!(serde_json::from_str::<JointLimit>(&json).unwrap(), hand_limit());
    }

    #[test]
    fn bad_input_is_an_error_naming_the_index() {
        let data = samples(10, 7);
        let e = JointLimit::fit(&data[..3], 0.1, 1e-3).unwrap_err();
        assert_eq!(e, LimitError::TooFewSamples { count: 3 });
        assert!(e.to_string().contains("got 3"), "{e}");
        let mut bad = data.clone();
        bad[5] = UnitQuaternion::new_unchecked(Quaternion::new(f32::NAN, 0.0, 0.0, 0.0));
        let e = JointLimit::fit(&bad, 0.1, 1e-3).unwrap_err();
        assert!(e.to_string().contains("sample 5"), "{e}");
        let e = fit_all(&[data.clone(), data.clone(), bad], 0.1, 1e-3).unwrap_err();
        assert!(e.to_string().starts_with("joint 2: sample 5"), "{e}");
        assert!(matches!(JointLimit::fit(&data, f32::NAN, 1e-3), Err(LimitError::BadParameter { .. })));
        assert!(matches!(JointLimit::fit(&data, 0.1, 0.0), Err(LimitError::BadParameter { .. })));
        let flat = JointLimit { radii: [0.5, 0.0, 0.1], ..hand_limit() };
        assert!(flat.compile().is_err() && !flat.contains(&at(&hand_limit(), Vector3::new(0.0, 0.1, 0.0))));
    }
}
