//! What `SONG.glb` shows besides the bones: the drummer's body (rounded limbs, torso, head
//! and eyes, each part bound to its bone, so the skin follows the rig), the two sticks in
//! the hands, and the kit the render played, built from the kit file: drums (head, shell,
//! hoops), cymbals, the hi-hat (its top cymbal a node of its own that the animation opens),
//! stands, the pedals and the stool. Kit frame (Z-up, metres); the glTF writer turns it Y-up.
//!
//! Node names are what the viewer lights at a contact: a piece's struck surface is named by
//! the piece's id (`snare`, `snare_rim`, `ride`, `hihat`); other parts carry a suffix
//! (`snare shell`, `ride stand`).

use super::shapes::{Frame, Shape};
use crate::kit::{Kit, Piece, PieceKind};
use crate::motion::rig::{Rig, HAND};
use crate::motion::STICK_TIP_LOCAL;
use nalgebra::Vector3;

type V3 = Vector3<f32>;

/// The scene's materials: base colour (linear RGB), metallic, roughness.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Material {
    Skin,
    Shirt,
    Trousers,
    Shoes,
    Eyes,
    Stick,
    DrumHead,
    Shell,
    Chrome,
    Bronze,
    Felt,
}

impl Material {
    pub const ALL: [Material; 11] = [
        Material::Skin,
        Material::Shirt,
        Material::Trousers,
        Material::Shoes,
        Material::Eyes,
        Material::Stick,
        Material::DrumHead,
        Material::Shell,
        Material::Chrome,
        Material::Bronze,
        Material::Felt,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Material::Skin => "skin",
            Material::Shirt => "shirt",
            Material::Trousers => "trousers",
            Material::Shoes => "shoes",
            Material::Eyes => "eyes",
            Material::Stick => "stick",
            Material::DrumHead => "drum head",
            Material::Shell => "shell",
            Material::Chrome => "chrome",
            Material::Bronze => "bronze",
            Material::Felt => "felt",
        }
    }

    /// Base colour (linear RGBA), metallic and roughness.
    pub fn pbr(self) -> ([f32; 4], f32, f32) {
        match self {
            Material::Skin => ([0.62, 0.40, 0.29, 1.0], 0.0, 0.7),
            Material::Shirt => ([0.08, 0.16, 0.34, 1.0], 0.0, 0.9),
            Material::Trousers => ([0.05, 0.05, 0.06, 1.0], 0.0, 0.9),
            Material::Shoes => ([0.02, 0.02, 0.02, 1.0], 0.0, 0.6),
            Material::Eyes => ([0.01, 0.01, 0.01, 1.0], 0.0, 0.2),
            Material::Stick => ([0.72, 0.52, 0.28, 1.0], 0.0, 0.6),
            Material::DrumHead => ([0.62, 0.62, 0.6, 1.0], 0.0, 0.8),
            Material::Shell => ([0.35, 0.02, 0.03, 1.0], 0.2, 0.35),
            Material::Chrome => ([0.75, 0.75, 0.78, 1.0], 1.0, 0.25),
            Material::Bronze => ([0.78, 0.52, 0.18, 1.0], 1.0, 0.35),
            Material::Felt => ([0.8, 0.8, 0.78, 1.0], 0.0, 1.0),
        }
    }
}

/// One part of the kit: a node of the glTF scene with one mesh.
#[derive(Debug, Clone)]
pub struct KitPart {
    pub name: String,
    pub material: Material,
    /// The node's place (kit frame); the shape is relative to it.
    pub origin: V3,
    pub shape: Shape,
    pub moves: Moves,
}

/// How a part moves in the animation.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Moves {
    Still,
    /// The hi-hat's top cymbal: lifted along the piece's normal by the openness.
    HihatTop,
    /// The kick beater: swung about its axle (the node's origin, the kit's x axis) by the
    /// right foot, striking the head on each kick.
    KickBeater,
}

/// The body's parts in the rig's bind pose (`rest`: every bone's joint, bind-pose
/// rotations all identity), one shape per material, every vertex bound to one bone.
pub fn body(rig: &Rig, rest: &[V3]) -> Vec<(Material, Shape)> {
    let mut parts: Vec<(Material, Shape)> = Vec::new();
    let mut put = |m: Material, s: Shape| match parts.iter_mut().find(|(pm, _)| *pm == m) {
        Some((_, shape)) => shape.add(s),
        None => parts.push((m, s)),
    };
    for (i, bone) in rig.bones.iter().enumerate() {
        let j = i as u16;
        let a = rest[i];
        let b = a + bone.tail;
        let name = bone.name.as_str();
        let side_free = name.trim_start_matches("left_").trim_start_matches("right_");
        match side_free {
            "hips" => put(Material::Trousers, Shape::ellipsoid(a + V3::new(0.0, -0.01, 0.07), [0.165, 0.12, 0.11], j)),
            "spine" => put(Material::Shirt, Shape::capsule(a, b, 0.125, 0.125, (1.15, 0.8), j)),
            "spine1" => put(Material::Shirt, Shape::capsule(a, b, 0.125, 0.13, (1.2, 0.8), j)),
            "spine2" => put(Material::Shirt, Shape::capsule(a, b - V3::z() * 0.04, 0.13, 0.12, (1.3, 0.8), j)),
            "neck" | "neck1" => put(Material::Skin, Shape::capsule(a, b, 0.05, 0.048, (1.0, 1.0), j)),
            "head" => {
                let centre = a + bone.tail * 0.48 + V3::y() * 0.005;
                put(Material::Skin, Shape::ellipsoid(centre, [0.075, 0.095, 0.118], j));
            }
            "eye" => {} // the face's
            "shoulder" => put(Material::Shirt, Shape::capsule(a, b, 0.055, 0.055, (1.0, 1.0), j)),
            "arm" => put(Material::Shirt, Shape::capsule(a, b, 0.05, 0.042, (1.0, 1.0), j)),
            "forearm" => put(Material::Skin, Shape::capsule(a, b, 0.04, 0.03, (1.0, 1.0), j)),
            "hand" => put(Material::Skin, Shape::capsule(a, b, 0.028, 0.03, (1.0, 0.75), j)),
            "upper_leg" => put(Material::Trousers, Shape::capsule(a, b, 0.08, 0.055, (1.0, 1.0), j)),
            "leg" => put(Material::Trousers, Shape::capsule(a, b, 0.052, 0.04, (1.0, 1.0), j)),
            "foot" => put(Material::Shoes, Shape::capsule(a, b, 0.04, 0.037, (1.0, 0.8), j)),
            "toe" => put(Material::Shoes, Shape::capsule(a, b, 0.036, 0.03, (1.0, 0.75), j)),
            f if f.starts_with("thumb") => put(Material::Skin, Shape::capsule(a, b, 0.011, 0.01, (1.0, 1.0), j)),
            f if ["index", "middle", "ring", "pinky"].iter().any(|p| f.starts_with(p)) => {
                put(Material::Skin, Shape::capsule(a, b, 0.0095, 0.0085, (1.0, 1.0), j))
            }
            _ => {} // head_end, jaw: no shape of their own
        }
    }
    // The sticks: the hand bone's frame is the grip's (the stick along its +y), the grip
    // point `grip_local` from the wrist. A 16" stick: tip 0.28 m ahead of the grip.
    for &h in &HAND {
        let grip = rest[h] + rig.grip_local;
        let along = V3::from(STICK_TIP_LOCAL);
        let tip = grip + along;
        let butt = grip - along.normalize() * (STICK_LENGTH_M - along.norm());
        put(
            Material::Stick,
            Shape::capsule(butt, tip - along.normalize() * 0.012, 0.0075, 0.0055, (1.0, 1.0), h as u16),
        );
        put(Material::Stick, Shape::ellipsoid(tip - along.normalize() * 0.006, [0.0065, 0.009, 0.0065], h as u16));
    }
    parts
}

/// The face's blend shapes in the glTF, a subset of the motion's 52 ARKit weights.
pub const FACE_TARGETS: [&str; 3] = ["eyeBlinkLeft", "eyeBlinkRight", "jawOpen"];

/// The face: the eyes (bound to the eye bones) and the mouth (bound to the head), with one
/// displacement per vertex for each of [`FACE_TARGETS`]: a blink closes an eye to a line,
/// `jawOpen` opens the mouth.
pub fn face(rig: &Rig, rest: &[V3]) -> (Shape, [Vec<V3>; 3]) {
    let mut shape = Shape::default();
    let mut targets: [Vec<V3>; 3] = Default::default();
    let mut add = |s: Shape, centre: V3, target: usize, squash: f32| {
        for p in &s.positions {
            for (k, t) in targets.iter_mut().enumerate() {
                t.push(if k == target { V3::new(0.0, 0.0, (p.z - centre.z) * squash) } else { V3::zeros() });
            }
        }
        shape.add(s);
    };
    for (name, target) in [("left_eye", 0), ("right_eye", 1)] {
        if let Some(i) = rig.index_of(name) {
            add(Shape::ellipsoid(rest[i], [0.012, 0.012, 0.012], i as u16), rest[i], target, -0.85);
        }
    }
    if let Some(head) = rig.index_of("head") {
        let mouth = rest[head] + V3::new(0.0, 0.074, 0.045);
        add(Shape::ellipsoid(mouth, [0.022, 0.012, 0.004], head as u16), mouth, 2, 3.0);
    }
    (shape, targets)
}

/// A 16-inch stick, m.
const STICK_LENGTH_M: f32 = 0.406;

/// Shell depth as drawn: a kick lies on its side (about 40 cm deep), a snare (a drum with
/// wires) is shallow, toms deepen with their size.
pub fn drum_depth(p: &Piece) -> f32 {
    if p.normal[2].abs() < 0.5 {
        0.40
    } else if p.wires.is_some() {
        0.14
    } else {
        (1.6 * p.radius_m).clamp(0.18, 0.42)
    }
}

/// A cymbal's profile (radius, height) from the top of its bell out to its edge and back
/// under it, for radius `r`; `flip` turns it bell-down (the hi-hat's bottom cymbal).
fn cymbal_profile(r: f32, flip: bool) -> Vec<(f32, f32)> {
    let top = [(0.0, 0.026), (0.1 * r, 0.025), (0.17 * r, 0.016), (0.24 * r, 0.006), (0.6 * r, -0.002), (r, -0.012)];
    let mut p: Vec<(f32, f32)> = top.to_vec();
    p.push((r, -0.012));
    p.push((r, -0.0135));
    p.push((r, -0.0135));
    p.extend(top.iter().rev().map(|&(x, h)| (x, h - 0.0015)));
    if flip {
        p.iter_mut().for_each(|q| q.1 = -q.1);
    }
    p
}

fn v(a: [f32; 3]) -> V3 {
    V3::from(a)
}

/// The kit's parts: struck surfaces named by their piece's id, the rest by suffix.
pub fn kit(kit: &Kit, seat_height_m: f32) -> Vec<KitPart> {
    let mut parts = Vec::new();
    let mut moving = Vec::new();
    let mut part = |name: String, material: Material, shape: Shape| {
        parts.push(KitPart { name, material, origin: V3::zeros(), shape, moves: Moves::Still });
    };
    let hoop_of = |drum: &str| kit.piece(&format!("{drum}_rim")).map(|p| p.id.clone());
    for p in &kit.pieces {
        let (c, n, r) = (v(p.position_m), v(p.normal), p.radius_m);
        let is_hoop =
            p.id.strip_suffix("_rim").and_then(|d| kit.piece(d)).is_some_and(|d| d.kind == PieceKind::Membrane);
        if is_hoop {
            continue; // drawn with its drum
        }
        let frame = Frame::along(c, n);
        match p.kind {
            PieceKind::Membrane => {
                let depth = drum_depth(p);
                part(p.id.clone(), Material::DrumHead, Shape::lathe(frame, &[(0.0, 0.0), (r, 0.0)], 32, 0));
                let mut shell = Shape::lathe(frame, &[(r + 0.003, -0.004), (r + 0.003, -depth)], 32, 0);
                shell.add(Shape::lathe(frame, &[(r, -depth + 0.002), (0.0, -depth + 0.002)], 32, 0));
                part(format!("{} shell", p.id), Material::Shell, shell);
                let top_hoop = Shape::torus(Frame::along(c + n * 0.004, n), r + 0.004, 0.0065, 0);
                let mut hoops = Shape::torus(Frame::along(c - n * depth, n), r + 0.004, 0.0065, 0);
                match hoop_of(&p.id) {
                    Some(hoop) => part(hoop, Material::Chrome, top_hoop),
                    None => hoops.add(top_hoop),
                }
                part(format!("{} hoops", p.id), Material::Chrome, hoops);
                if n.z.abs() >= 0.5 {
                    // A stand or legs from the floor to the shell's bottom.
                    let bottom = c - n * depth;
                    let mut stand = Shape::default();
                    if p.wires.is_none() && r > 0.18 {
                        for k in 0..3 {
                            let a = k as f32 * std::f32::consts::TAU / 3.0 + 0.5;
                            let side = V3::new(a.cos(), a.sin(), 0.0);
                            let top = c - n * (0.5 * depth) + side * (r + 0.012);
                            let foot = V3::new(top.x + side.x * 0.06, top.y + side.y * 0.06, 0.0);
                            stand.add(Shape::rod(foot, top, 0.0065, 0));
                        }
                    } else {
                        stand.add(tripod(V3::new(bottom.x, bottom.y, 0.0), bottom.z - 0.02));
                        stand.add(Shape::rod(V3::new(bottom.x, bottom.y, 0.0), bottom - n * 0.01, 0.0095, 0));
                    }
                    part(format!("{} stand", p.id), Material::Chrome, stand);
                }
            }
            PieceKind::Plate => {
                let is_hihat = p.closed_damping_factor.is_some();
                let profile = cymbal_profile(r, false);
                if is_hihat {
                    // The top cymbal is a node at the piece's place, opened by the animation.
                    moving.push(KitPart {
                        name: p.id.clone(),
                        material: Material::Bronze,
                        origin: c,
                        shape: Shape::lathe(Frame::along(V3::zeros(), n), &profile, 32, 0),
                        moves: Moves::HihatTop,
                    });
                    let bottom = Shape::lathe(Frame::along(c - n * 0.006, n), &cymbal_profile(r, true), 32, 0);
                    part(format!("{} bottom", p.id), Material::Bronze, bottom);
                } else {
                    part(p.id.clone(), Material::Bronze, Shape::lathe(frame, &profile, 32, 0));
                }
                let under = c - n * 0.03;
                let foot = V3::new(c.x, c.y, 0.0);
                let mut stand = tripod(foot, 0.32);
                stand.add(Shape::rod(foot, under, 0.0095, 0));
                part(format!("{} stand", p.id), Material::Chrome, stand);
            }
        }
    }
    if let Some(pedals) = &kit.pedals {
        let axle = v(pedals.kick_axle_m);
        let heel = V3::new(axle.x, axle.y - 0.27, 0.03);
        part("kick pedal".into(), Material::Chrome, board(heel, axle - V3::z() * 0.03, 0.05));
        let rest = pedals.beater_rest_deg.to_radians();
        let dir = V3::new(0.0, -rest.sin(), rest.cos());
        // The beater at its rest angle, about the axle (its node's origin).
        let ball = dir * pedals.beater_length_m;
        let mut beater = Shape::rod(V3::zeros(), ball, 0.004, 0);
        beater.add(Shape::ellipsoid(ball, [0.035, 0.025, 0.035], 0));
        moving.push(KitPart {
            name: "kick beater".into(),
            material: Material::Felt,
            origin: axle,
            shape: beater,
            moves: Moves::KickBeater,
        });
        let hh = v(pedals.hihat_pedal_m);
        let toe = V3::new(hh.x, hh.y + 0.27, 0.08);
        part("hihat pedal".into(), Material::Chrome, board(V3::new(hh.x, hh.y, 0.03), toe, 0.045));
    }
    // The stool under the hips.
    let mut stool = Shape::lathe(
        Frame::along(V3::new(0.0, 0.0, seat_height_m), V3::z()),
        &[(0.0, 0.0), (0.17, 0.0), (0.17, 0.0), (0.17, -0.08), (0.17, -0.08), (0.0, -0.08)],
        32,
        0,
    );
    stool.add(Shape::rod(V3::zeros(), V3::new(0.0, 0.0, seat_height_m - 0.08), 0.02, 0));
    stool.add(tripod(V3::zeros(), 0.25));
    part("stool".into(), Material::Trousers, stool);
    parts.extend(moving);
    parts
}

/// Three legs from `height` on the axis above `foot` out to the floor.
fn tripod(foot: V3, height: f32) -> Shape {
    let mut s = Shape::default();
    let top = foot + V3::z() * height.max(0.05);
    for k in 0..3 {
        let a = k as f32 * std::f32::consts::TAU / 3.0 + 1.2;
        let out = V3::new(foot.x + 0.22 * a.cos(), foot.y + 0.22 * a.sin(), 0.01);
        s.add(Shape::rod(out, top, 0.007, 0));
    }
    s
}

/// A pedal's footboard from `heel` to `toe`, `half_width` wide on each side.
fn board(heel: V3, toe: V3, half_width: f32) -> Shape {
    let along = (toe - heel).normalize();
    let side = along.cross(&V3::z()).normalize();
    let up = side.cross(&along);
    Shape::cuboid((heel + toe) * 0.5, [along, side, up], [0.5 * (toe - heel).norm(), half_width, 0.008], 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_piece_has_a_node_named_for_it() {
        let kit = Kit::builtin_default();
        let parts = super::kit(&kit, 0.55);
        for p in &kit.pieces {
            assert!(parts.iter().any(|q| q.name == p.id), "no node for {}", p.id);
        }
        assert!(parts.iter().all(|p| !p.shape.indices.is_empty()));
    }

    #[test]
    fn the_sticks_follow_the_hands() {
        let rig = Rig::default();
        let rest = rig.rest_positions();
        let parts = body(&rig, &rest);
        let (_, sticks) = parts.iter().find(|(m, _)| *m == Material::Stick).unwrap();
        let hands: Vec<u16> = HAND.iter().map(|&h| h as u16).collect();
        assert!(sticks.joints.iter().all(|j| hands.contains(j)));
        // The tip lies where the motion puts it, 0.28 m along the grip frame's +y (the bead
        // reaching 3 mm past it).
        let far = sticks.positions.iter().map(|p| p.y).fold(f32::MIN, f32::max);
        let grip_y = rest[HAND[0]].y + rig.grip_local.y;
        let past = far - grip_y - STICK_TIP_LOCAL[1];
        assert!((0.0..0.005).contains(&past), "the stick ends {past} m past the tip");
    }
}
