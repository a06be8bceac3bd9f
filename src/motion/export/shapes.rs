//! Solid shapes for the glTF scene: surfaces of revolution (drum shells and heads, hoops,
//! cymbals, stands, the body's limbs) and boxes (pedal boards), as triangle meshes with
//! per-vertex normals, each vertex bound to one joint of the skin (or none, for the kit).
//! Points are in the kit frame (Z-up, metres); the writer turns them Y-up.

use nalgebra::Vector3;
use std::f32::consts::TAU;

type V3 = Vector3<f32>;

/// Triangles with normals and, for skinned parts, the joint each vertex follows.
#[derive(Debug, Clone, Default)]
pub struct Shape {
    pub positions: Vec<V3>,
    pub normals: Vec<V3>,
    pub joints: Vec<u16>,
    pub indices: Vec<u32>,
}

/// Where a surface of revolution stands: its axis through `origin` along the unit `axis`;
/// `across` (perpendicular to the axis) is the direction of the first radius, and radii are
/// scaled by `scale.0` along it and `scale.1` along `axis x across` (1, 1 for a round
/// shape).
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    pub origin: V3,
    pub axis: V3,
    pub across: V3,
    pub scale: (f32, f32),
}

impl Frame {
    /// A round frame along `axis`, its first radius along world x (or y when the axis is
    /// close to x).
    pub fn along(origin: V3, axis: V3) -> Frame {
        let axis = axis.try_normalize(1e-9).unwrap_or_else(V3::z);
        let pick = if axis.x.abs() > 0.9 { V3::y() } else { V3::x() };
        let across = (pick - axis * pick.dot(&axis)).normalize();
        Frame { origin, axis, across, scale: (1.0, 1.0) }
    }

    pub fn scaled(mut self, s0: f32, s1: f32) -> Frame {
        self.scale = (s0, s1);
        self
    }
}

impl Shape {
    /// Append `other`, its indices shifted.
    pub fn add(&mut self, other: Shape) {
        let base = self.positions.len() as u32;
        self.positions.extend(other.positions);
        self.normals.extend(other.normals);
        self.joints.extend(other.joints);
        self.indices.extend(other.indices.into_iter().map(|i| i + base));
    }

    /// Revolve `profile` ((radius, height along the axis) pairs) about the frame's axis in
    /// `segments` steps. A corner in the profile is given by repeating the point; normals
    /// point away from the axis's side the profile turns to (outward for a profile that runs
    /// from the top down, as a drum's head then its shell).
    pub fn lathe(frame: Frame, profile: &[(f32, f32)], segments: usize, joint: u16) -> Shape {
        let mut s = Shape::default();
        let e1 = frame.across;
        let e2 = frame.axis.cross(&e1);
        let n = profile.len();
        // Each profile point's normal in the (radius, height) plane, from its neighbours;
        // a repeated point (a corner) takes its normal from one side only.
        let normal2 = |k: usize| -> (f32, f32) {
            let seg = |a: usize, b: usize| {
                let (dr, dh) = (profile[b].0 - profile[a].0, profile[b].1 - profile[a].1);
                let l = (dr * dr + dh * dh).sqrt();
                if l < 1e-9 {
                    None
                } else {
                    Some((-dh / l, dr / l))
                }
            };
            let before = if k > 0 { seg(k - 1, k) } else { None };
            let after = if k + 1 < n { seg(k, k + 1) } else { None };
            match (before, after) {
                (Some(a), Some(b)) => {
                    let (x, y) = (a.0 + b.0, a.1 + b.1);
                    let l = (x * x + y * y).sqrt().max(1e-9);
                    (x / l, y / l)
                }
                (Some(a), None) | (None, Some(a)) => a,
                (None, None) => (0.0, 1.0),
            }
        };
        let (s0, s1) = frame.scale;
        for (k, &(r, h)) in profile.iter().enumerate() {
            let (nr, nh) = normal2(k);
            for j in 0..=segments {
                let a = j as f32 / segments as f32 * TAU;
                let (c, si) = (a.cos(), a.sin());
                s.positions.push(frame.origin + frame.axis * h + (e1 * (c * s0) + e2 * (si * s1)) * r);
                // The normal of a surface scaled along e1, e2 is scaled by the inverse.
                let normal = frame.axis * nh + (e1 * (c / s0) + e2 * (si / s1)) * nr;
                s.normals.push(normal.try_normalize(1e-9).unwrap_or(frame.axis));
                s.joints.push(joint);
            }
        }
        let ring = segments as u32 + 1;
        for k in 0..n.saturating_sub(1) as u32 {
            for j in 0..segments as u32 {
                let (a, b) = (k * ring + j, k * ring + j + 1);
                let (c, d) = (a + ring, b + ring);
                s.triangle(a, c, b);
                s.triangle(b, c, d);
            }
        }
        s
    }

    /// A box centred on `centre` with half extents `half` along the unit axes `axes`.
    pub fn cuboid(centre: V3, axes: [V3; 3], half: [f32; 3], joint: u16) -> Shape {
        let mut s = Shape::default();
        for (i, &axis) in axes.iter().enumerate() {
            for sign in [-1.0f32, 1.0] {
                let n = axis * sign;
                let (u, v) = (axes[(i + 1) % 3] * half[(i + 1) % 3], axes[(i + 2) % 3] * half[(i + 2) % 3]);
                let c = centre + n * half[i];
                let base = s.positions.len() as u32;
                for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                    s.positions.push(c + u * a + v * b);
                    s.normals.push(n);
                    s.joints.push(joint);
                }
                s.triangle(base, base + 1, base + 2);
                s.triangle(base, base + 2, base + 3);
            }
        }
        s
    }

    /// A rod of radius `r` from `a` to `b`, with flat ends.
    pub fn rod(a: V3, b: V3, r: f32, joint: u16) -> Shape {
        let len = (b - a).norm();
        Shape::lathe(
            Frame::along(a, b - a),
            &[(0.0, len), (r, len), (r, len), (r, 0.0), (r, 0.0), (0.0, 0.0)],
            8,
            joint,
        )
    }

    /// A capsule (a cylinder between two hemispheres), tapering from radius `r0` at `a` to
    /// `r1` at `b`, its cross-section scaled by `scale` (for flattened limbs and the torso).
    pub fn capsule(a: V3, b: V3, r0: f32, r1: f32, scale: (f32, f32), joint: u16) -> Shape {
        let len = (b - a).norm().max(1e-4);
        let frame = Frame::along(a, b - a).scaled(scale.0, scale.1);
        // Fewer facets on thin parts (fingers): the scene stays light for software renderers.
        let r = r0.max(r1) * scale.0.max(scale.1);
        let (segments, rings) = if r < 0.015 {
            (6, 2)
        } else if r < 0.045 {
            (10, 3)
        } else {
            (16, 5)
        };
        let mut profile = Vec::with_capacity(2 * rings + 2);
        for k in 0..=rings {
            let phi = k as f32 / rings as f32 * std::f32::consts::FRAC_PI_2;
            profile.push((r1 * phi.sin(), len + r1 * phi.cos()));
        }
        for k in 0..=rings {
            let phi = k as f32 / rings as f32 * std::f32::consts::FRAC_PI_2;
            profile.push((r0 * phi.cos(), -r0 * phi.sin()));
        }
        Shape::lathe(frame, &profile, segments, joint)
    }

    /// An ellipsoid centred on `centre` with semi-axes `radii` along x, y and z of the kit
    /// frame.
    pub fn ellipsoid(centre: V3, radii: [f32; 3], joint: u16) -> Shape {
        let frame = Frame { origin: centre, axis: V3::z(), across: V3::x(), scale: (radii[0], radii[1]) };
        let rings = if radii.iter().any(|&r| r > 0.03) { 10 } else { 4 };
        let profile: Vec<(f32, f32)> = (0..=rings)
            .map(|k| {
                let phi = k as f32 / rings as f32 * std::f32::consts::PI;
                (phi.sin(), radii[2] * phi.cos())
            })
            .collect();
        Shape::lathe(frame, &profile, 2 * rings.max(6), joint)
    }

    /// A torus: a tube of radius `tube` around the circle of radius `ring` about the frame.
    pub fn torus(frame: Frame, ring: f32, tube: f32, joint: u16) -> Shape {
        let profile: Vec<(f32, f32)> = (0..=6)
            .map(|k| {
                let a = -(k as f32) / 6.0 * TAU;
                (ring + tube * a.cos(), tube * a.sin())
            })
            .collect();
        // Clockwise in (radius, height), so that the profile's normals face out of the tube.
        Shape::lathe(frame, &profile, 32, joint)
    }

    /// Add the triangle (a, b, c), wound so that its face normal agrees with its vertices'
    /// normals (front faces outward).
    fn triangle(&mut self, a: u32, b: u32, c: u32) {
        let p = |i: u32| self.positions[i as usize];
        let face = (p(b) - p(a)).cross(&(p(c) - p(a)));
        let normal = self.normals[a as usize] + self.normals[b as usize] + self.normals[c as usize];
        if face.norm_squared() < 1e-20 {
            return;
        }
        if face.dot(&normal) >= 0.0 {
            self.indices.extend([a, b, c]);
        } else {
            self.indices.extend([a, c, b]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_capsule_is_closed_and_faces_outward() {
        let s = Shape::capsule(V3::zeros(), V3::new(0.0, 0.0, 0.3), 0.05, 0.04, (1.0, 1.0), 3);
        let centre = V3::new(0.0, 0.0, 0.15);
        assert!(s.joints.iter().all(|&j| j == 3));
        for tri in s.indices.chunks(3) {
            let p = |i: u32| s.positions[i as usize];
            let face = (p(tri[1]) - p(tri[0])).cross(&(p(tri[2]) - p(tri[0])));
            let mid = (p(tri[0]) + p(tri[1]) + p(tri[2])) / 3.0;
            assert!(face.dot(&(mid - centre)) > 0.0, "a triangle faces inward at {mid}");
        }
        let top = s.positions.iter().map(|p| p.z).fold(f32::MIN, f32::max);
        let bottom = s.positions.iter().map(|p| p.z).fold(f32::MAX, f32::min);
        assert!((top - 0.34).abs() < 1e-5 && (bottom + 0.05).abs() < 1e-5, "{bottom} {top}");
    }

    #[test]
    fn a_disc_faces_along_its_axis_and_a_shell_away_from_it() {
        let frame = Frame::along(V3::new(1.0, 0.0, 0.5), V3::new(0.0, -1.0, 0.0));
        let s = Shape::lathe(frame, &[(0.0, 0.0), (0.2, 0.0), (0.2, 0.0), (0.2, -0.3)], 12, 0);
        for (p, n) in s.positions.iter().zip(&s.normals) {
            let h = (p - frame.origin).dot(&frame.axis);
            if h.abs() < 1e-6 && n.dot(&frame.axis) > 0.5 {
                continue; // the head
            }
            let radial = (p - frame.origin) - frame.axis * h;
            assert!(n.dot(&radial) > 0.0 || radial.norm() < 1e-6, "{p} {n}");
        }
    }
}
