//! Where a piece is struck: its surface's in-plane axes and each zone's strike point, shared
//! by the motion stage (where a stick aims), the body (contact points in the piece's
//! coordinates) and direct mode (the strike point its messages carry), so that all three
//! strike a piece at the same place.

use super::{Kit, Piece};
use crate::midi::Zone;

/// The in-plane axes (u, v) of a surface with unit normal `n`: strike points are given as
/// `x` along `u` and `y` along `v`, metres from the piece's centre. `u` is the world x axis
/// (y for a surface facing along x) with its normal part removed.
pub fn surface_basis(n: [f32; 3]) -> ([f32; 3], [f32; 3]) {
    let pick = if n[0].abs() > 0.9 { [0.0, 1.0, 0.0] } else { [1.0, 0.0, 0.0] };
    let d = dot(pick, n);
    let u = normalize([pick[0] - d * n[0], pick[1] - d * n[1], pick[2] - d * n[2]]);
    (u, cross(n, u))
}

impl super::Zones {
    /// The zone's radius as a fraction of the piece's.
    pub fn fraction(&self, zone: Zone) -> f32 {
        match zone {
            Zone::Center => self.center,
            Zone::Head => self.head,
            Zone::Rim => self.rim,
            Zone::CrossStick => self.cross_stick,
            Zone::Bow => self.bow,
            Zone::Edge => self.edge,
            Zone::Bell => self.bell,
            Zone::Pedal => self.pedal,
        }
    }
}

/// Unit direction in the piece's plane from its centre toward the drummer's seat (the
/// origin); toward -y, else up, when the seat is along the normal.
pub fn toward_drummer(piece: &Piece) -> [f32; 3] {
    let n = piece.normal;
    let c = piece.position_m;
    let inplane = |v: [f32; 3]| {
        let d = dot(v, n);
        [v[0] - d * n[0], v[1] - d * n[1], v[2] - d * n[2]]
    };
    let mut dir = inplane([-c[0], -c[1], 0.0]);
    // A piece facing the seat (the kick): up its face instead.
    for fallback in [[0.0, -1.0, 0.0], [0.0, 0.0, 1.0]] {
        if norm(dir) < 1e-4 {
            dir = inplane(fallback);
        }
    }
    normalize(dir)
}

/// Where a zone of a piece is struck, and the surface normal there: on the side toward the
/// drummer, at the zone's radius.
pub fn strike_point(kit: &Kit, piece: &Piece, zone: Zone) -> ([f32; 3], [f32; 3]) {
    let dir = toward_drummer(piece);
    let c = piece.position_m;
    let r = piece.radius_m * kit.zones.fraction(zone);
    ([c[0] + dir[0] * r, c[1] + dir[1] * r, c[2] + dir[2] * r], piece.normal)
}

/// The angle of [`toward_drummer`] in the piece's (u, v) axes, radians: direct mode strikes
/// along it.
pub fn toward_drummer_angle(piece: &Piece) -> f32 {
    let dir = toward_drummer(piece);
    let (u, v) = surface_basis(piece.normal);
    dot(dir, v).atan2(dot(dir, u))
}

/// A zone's strike point in the piece's own surface coordinates (`x` along `u`, `y` along
/// `v` of [`surface_basis`], metres from its centre), as contact messages carry their points.
pub fn strike_point_uv(kit: &Kit, piece: &Piece, zone: Zone) -> [f32; 2] {
    let (u, v) = surface_basis(normalize(piece.normal));
    let (p, _) = strike_point(kit, piece, zone);
    let d = [p[0] - piece.position_m[0], p[1] - piece.position_m[1], p[2] - piece.position_m[2]];
    [dot(d, u), dot(d, v)]
}

/// How far a contact fell from the strike point it was aimed at, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrikeMiss {
    /// The distance in the surface's plane: the physical render's IPD (DESIGN.md section 5).
    pub distance_m: f32,
    /// Its part along [`toward_drummer`], + toward the seat.
    pub radial_m: f32,
    /// Its part across that way: along the radial direction turned a quarter turn about the
    /// surface's normal (counter-clockwise seen from above the surface).
    pub across_m: f32,
}

/// Where a contact at `at` (the piece's surface coordinates, as in its contact message) fell
/// from `zone`'s strike point on `piece`.
pub fn strike_miss(kit: &Kit, piece: &Piece, zone: Zone, at: [f32; 2]) -> StrikeMiss {
    let aim = strike_point_uv(kit, piece, zone);
    let (mx, my) = (at[0] - aim[0], at[1] - aim[1]);
    let (u, v) = surface_basis(normalize(piece.normal));
    let w = toward_drummer(piece);
    let (wu, wv) = (dot(w, u), dot(w, v));
    StrikeMiss { distance_m: mx.hypot(my), radial_m: mx * wu + my * wv, across_m: my * wu - mx * wv }
}

pub(crate) fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(crate) fn norm(a: [f32; 3]) -> f32 {
    dot(a, a).sqrt()
}

/// `a` scaled to unit length; straight up for a zero vector.
pub(crate) fn normalize(a: [f32; 3]) -> [f32; 3] {
    let n = norm(a);
    if n > 1e-9 {
        a.map(|x| x / n)
    } else {
        [0.0, 0.0, 1.0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn direct_mode_s_angle_points_at_the_strike_point() {
        let kit = Kit::builtin_default();
        for piece in &kit.pieces {
            let (p, _) = strike_point(&kit, piece, Zone::Bow);
            let a = toward_drummer_angle(piece);
            let (u, v) = surface_basis(piece.normal);
            let d = [p[0] - piece.position_m[0], p[1] - piece.position_m[1], p[2] - piece.position_m[2]];
            let r = piece.radius_m * kit.zones.bow;
            assert!((dot(d, u) - r * a.cos()).abs() < 1e-5, "{}", piece.id);
            assert!((dot(d, v) - r * a.sin()).abs() < 1e-5, "{}", piece.id);
        }
    }

    #[test]
    fn a_contact_at_the_centre_misses_its_strike_point_away_from_the_seat() {
        let kit = Kit::builtin_default();
        for piece in &kit.pieces {
            let on = strike_miss(&kit, piece, Zone::Head, strike_point_uv(&kit, piece, Zone::Head));
            assert!(on.distance_m < 1e-6 && on.radial_m.abs() < 1e-6 && on.across_m.abs() < 1e-6, "{}", piece.id);
            // The head's strike point lies toward the seat: the centre is that far beyond it.
            let r = piece.radius_m * kit.zones.head;
            let centre = strike_miss(&kit, piece, Zone::Head, [0.0, 0.0]);
            assert!((centre.distance_m - r).abs() < 1e-5, "{}: {centre:?}", piece.id);
            assert!((centre.radial_m + r).abs() < 1e-5 && centre.across_m.abs() < 1e-5, "{}: {centre:?}", piece.id);
        }
    }
}
