//! The kit's drums as solids the body keeps out of: each a cylinder from its head down to
//! the shell depth the exports draw ([`drum_depth`]).

use super::export::scene::drum_depth;
use crate::kit::{Kit, PieceKind};
use nalgebra::Vector3;

/// The knee (a ball at the joint) and shin (a capsule from knee to ankle) radii the legs
/// keep out of the drums with, m; `eval::motion_quality` measures with the same.
pub const KNEE_R: f32 = 0.06;
pub const SHIN_R: f32 = 0.05;

/// One drum's solid.
#[derive(Debug, Clone, PartialEq)]
pub struct Shell {
    pub id: String,
    /// Head centre and outward normal (unit).
    pub center: Vector3<f32>,
    pub normal: Vector3<f32>,
    pub radius_m: f32,
    pub depth_m: f32,
}

/// The solids of `kit`'s drums (hoops and cymbals are not solids here).
pub fn shells(kit: &Kit) -> Vec<Shell> {
    kit.pieces
        .iter()
        .filter(|p| p.kind == PieceKind::Membrane && !p.id.ends_with("_rim"))
        .map(|p| Shell {
            id: p.id.clone(),
            center: Vector3::from(p.position_m),
            normal: Vector3::from(p.normal).normalize(),
            radius_m: p.radius_m,
            depth_m: drum_depth(p),
        })
        .collect()
}

impl Shell {
    /// How deep a capsule (segment `a`-`b`, radius `r`) reaches inside (negative: how far
    /// outside), from nine points along it.
    pub fn depth_of(&self, a: Vector3<f32>, b: Vector3<f32>, r: f32) -> f32 {
        (0..=8)
            .map(|i| {
                let p = a + (b - a) * (i as f32 / 8.0);
                let h = (p - self.center).dot(&self.normal);
                let radial = ((p - self.center) - self.normal * h).norm();
                (self.radius_m + r - radial).min(r - h).min(h + self.depth_m + r)
            })
            .fold(f32::NEG_INFINITY, f32::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ball_is_inside_a_drum_by_how_far_it_would_have_to_move_out() {
        let s = Shell { id: "tom".into(), center: Vector3::zeros(), normal: Vector3::z(), radius_m: 0.2, depth_m: 0.3 };
        let ball = |p: Vector3<f32>| s.depth_of(p, p, 0.05);
        // 10 cm under the head's centre: 15 cm to come up out of it.
        assert!((ball(Vector3::new(0.0, 0.0, -0.10)) - 0.15).abs() < 1e-6);
        // Beside the shell, 10 cm from its side: outside by 5 cm.
        assert!((ball(Vector3::new(0.30, 0.0, -0.10)) + 0.05).abs() < 1e-6);
        // Just under the bottom: inside by what the radius overlaps.
        assert!((ball(Vector3::new(0.0, 0.0, -0.33)) - 0.02).abs() < 1e-6);
    }
}
