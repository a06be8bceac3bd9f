//! `SONG.glb`: binary glTF 2.0 with the rig as a skin and the motion as one animation.
//!
//! Layout: nodes 0..57 are the bones (node i = rig bone i, rest translation = the bone's
//! offset, the hips' lifted so that the rest pose stands on the floor, rest rotation
//! identity); node 57, "drummer", carries the skinned body, sticks and face (one primitive
//! per material, every vertex weighted 1 to its bone, the face's three blend shapes on every
//! primitive); skin 0 lists the 57 joints with their inverse bind matrices. With a kit,
//! node 58 "kit" holds a node per part ([`scene::kit`]). Animation 0 has 60 fps LINEAR
//! samplers: the translation of the root (hips), the rotation of every bone and the face's
//! blend shape weights, keyed on every frame, and the moving kit parts (the hi-hat's top
//! cymbal, the kick beater).
//! Axes are glTF's (Y-up, the drummer facing +Z), metres. Written by hand: a JSON chunk and
//! a BIN chunk, every buffer view 4-byte aligned.

use super::scene::{self, KitPart, Material, Moves};
use super::shapes::Shape;
use super::{write_file, write_one, y_up, y_up_rot, Baked, ExportError};
use crate::kit::Kit;
use crate::motion::rig::Rig;
use crate::motion::track::Motion;
use nalgebra::{UnitQuaternion, Vector3};
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;

pub(super) const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
const UNSIGNED_INT: u32 = 5125;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// Write the glTF binary of `motion` through `rig` to `path`.
pub fn write(motion: &Motion, rig: &Rig, path: &Path) -> Result<(), ExportError> {
    let baked = Baked::new(motion, rig)?;
    write_one(path, |partial| write_baked(&baked, partial))
}

/// Write already-solved motion to `path` as it is (a partial name of an output set).
pub fn write_baked(baked: &Baked, path: &Path) -> Result<(), ExportError> {
    let glb = build(baked);
    write_file(path, |w: &mut dyn Write| w.write_all(&glb))
}

/// The binary buffer and the views and accessors into it.
#[derive(Default)]
pub(super) struct Bin {
    pub(super) data: Vec<u8>,
    pub(super) views: Vec<Value>,
    pub(super) accessors: Vec<Value>,
}

impl Bin {
    /// Append a buffer view of little-endian f32 values.
    pub(super) fn floats(&mut self, values: &[f32], target: Option<u32>) -> usize {
        // Straight into the buffer (no copy of the bytes first: a long song's animation is
        // hundreds of megabytes).
        let offset = self.data.len();
        self.data.reserve(values.len() * 4);
        for v in values {
            self.data.extend_from_slice(&v.to_le_bytes());
        }
        self.finish_view(offset, values.len() * 4, target)
    }

    /// An accessor of `count` zero VEC3s in `view` (a view of at least that many zeros,
    /// shared by the primitives whose blend shapes do not move them).
    fn zeros(&mut self, view: usize, count: usize) -> usize {
        let zero = || json!([0.0, 0.0, 0.0]);
        self.accessor(view, FLOAT, count, "VEC3", Some((zero(), zero())))
    }

    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        let offset = self.data.len();
        self.data.extend_from_slice(bytes);
        self.finish_view(offset, bytes.len(), target)
    }

    /// Pad the buffer to 4 bytes and add the view of the `len` bytes at `offset`.
    fn finish_view(&mut self, offset: usize, len: usize, target: Option<u32>) -> usize {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": offset, "byteLength": len});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.views.push(v);
        self.views.len() - 1
    }

    pub(super) fn accessor(
        &mut self,
        view: usize,
        component: u32,
        count: usize,
        kind: &str,
        bounds: Option<(Value, Value)>,
    ) -> usize {
        let mut a = json!({"bufferView": view, "componentType": component, "count": count, "type": kind});
        if let Some((min, max)) = bounds {
            a["min"] = min;
            a["max"] = max;
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }
}

/// Per-component minimum and maximum of `n`-vectors.
pub(super) fn bounds(values: &[f32], n: usize) -> (Value, Value) {
    let mut lo = vec![f32::INFINITY; n];
    let mut hi = vec![f32::NEG_INFINITY; n];
    for chunk in values.chunks(n) {
        for (k, &v) in chunk.iter().enumerate() {
            lo[k] = lo[k].min(v);
            hi[k] = hi[k].max(v);
        }
    }
    (json!(lo), json!(hi))
}

/// Replace non-finite values by 0 (glTF forbids them).
pub(super) fn clean(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
}

/// The binary glTF of `baked`, in memory (the live viewer serves one).
pub fn bytes(baked: &Baked) -> Vec<u8> {
    build(baked)
}

fn build(baked: &Baked) -> Vec<u8> {
    let rig = baked.rig;
    let n = rig.bones.len();
    // The rig's rest pose has the hips at their seated height and the legs straight down,
    // so its feet would sink 35 cm through the floor: the bind pose stands, lifted until
    // its lowest joint touches the floor. (The animation sets the hips' place every frame.)
    let mut rest = rig.rest_positions();
    let lift = (-rest.iter().map(|p| p.z).fold(f32::INFINITY, f32::min)).max(0.0);
    for p in &mut rest {
        p.z += lift;
    }
    let mut bin = Bin::default();

    // Inverse bind matrices: every rest rotation is identity, so each is a translation.
    let ibm: Vec<f32> = rest
        .iter()
        .flat_map(|p| {
            let [x, y, z] = y_up(-p);
            [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, x, y, z, 1.0]
        })
        .collect();
    let v = bin.floats(&ibm, None);
    let ibm_acc = bin.accessor(v, FLOAT, n, "MAT4", None);

    // The drummer's body and sticks, one primitive per material, skinned to the bones.
    let materials: Vec<Value> = Material::ALL
        .iter()
        .map(|m| {
            let (colour, metallic, roughness) = m.pbr();
            json!({"name": m.name(), "doubleSided": true, "pbrMetallicRoughness": {
                "baseColorFactor": colour, "metallicFactor": metallic, "roughnessFactor": roughness}})
        })
        .collect();
    // Every primitive of the body carries the face's blend shapes (glTF asks the same
    // targets of all primitives of a mesh): zeros except on the face's.
    let body = scene::body(rig, &rest);
    let most = body.iter().map(|(_, s)| s.positions.len()).max().unwrap_or(0);
    let zero_view = bin.floats(&vec![0.0; 3 * most], Some(ARRAY_BUFFER));
    bin.views[zero_view]["byteStride"] = json!(12);
    let mut body_primitives: Vec<Value> = body
        .into_iter()
        .map(|(m, shape)| {
            let mut p = primitive(&mut bin, &shape, m, true);
            let zeros = bin.zeros(zero_view, shape.positions.len());
            p["targets"] = json!(vec![json!({"POSITION": zeros}); scene::FACE_TARGETS.len()]);
            p
        })
        .collect();
    let (face, deltas) = scene::face(rig, &rest);
    let mut p = primitive(&mut bin, &face, Material::Eyes, true);
    p["targets"] = json!(deltas
        .iter()
        .map(|d| {
            let values: Vec<f32> = d.iter().flat_map(|v| y_up(*v)).collect();
            let view = bin.floats(&values, Some(ARRAY_BUFFER));
            json!({"POSITION": bin.accessor(view, FLOAT, d.len(), "VEC3", Some(bounds(&values, 3)))})
        })
        .collect::<Vec<_>>());
    body_primitives.push(p);
    let kit_parts = baked.kit.map(|kit| scene::kit(kit, rig.bones[0].offset.z - 0.07)).unwrap_or_default();
    let kit_meshes: Vec<Value> = kit_parts
        .iter()
        .map(|part| json!({"name": part.name, "primitives": [primitive(&mut bin, &part.shape, part.material, false)]}))
        .collect();

    // The animation.
    let frames = baked.poses.len();
    let times: Vec<f32> = (0..frames).map(|i| baked.time_s(i) as f32).collect();
    let v = bin.floats(&times, None);
    let time_acc = bin.accessor(v, FLOAT, frames, "SCALAR", Some(bounds(&times, 1)));
    let root: Vec<f32> = baked.poses.iter().flat_map(|p| y_up(p.root).map(clean)).collect();
    let v = bin.floats(&root, None);
    let root_acc = bin.accessor(v, FLOAT, frames, "VEC3", None);
    let mut samplers = vec![json!({"input": time_acc, "output": root_acc, "interpolation": "LINEAR"})];
    let mut channels = vec![json!({"sampler": 0, "target": {"node": 0, "path": "translation"}})];
    for bone in 0..n {
        let mut rot = Vec::with_capacity(frames * 4);
        let mut prev = [0.0, 0.0, 0.0, 1.0];
        for pose in &baked.poses {
            let [w, x, y, z] = y_up_rot(&pose.local[bone]);
            let mut q = [x, y, z, w];
            if !q.iter().all(|v| v.is_finite()) {
                q = [0.0, 0.0, 0.0, 1.0];
            }
            // Stay in the previous key's hemisphere so that interpolation takes the short way.
            if q.iter().zip(&prev).map(|(a, b)| a * b).sum::<f32>() < 0.0 {
                q = q.map(|v| -v);
            }
            prev = q;
            rot.extend_from_slice(&q);
        }
        let v = bin.floats(&rot, None);
        let acc = bin.accessor(v, FLOAT, frames, "VEC4", None);
        samplers.push(json!({"input": time_acc, "output": acc, "interpolation": "LINEAR"}));
        channels.push(json!({"sampler": samplers.len() - 1, "target": {"node": bone, "path": "rotation"}}));
    }

    // The face: its blend shapes' weights from the motion's ARKit weights.
    let face_index: Vec<usize> = scene::FACE_TARGETS
        .iter()
        .map(|name| crate::motion::ARKIT_NAMES.iter().position(|a| a == name).expect("an ARKit name"))
        .collect();
    let weights: Vec<f32> =
        baked.motion.frames.iter().flat_map(|f| face_index.iter().map(|&k| clean(f.face[k]).clamp(0.0, 1.0))).collect();
    let v = bin.floats(&weights, None);
    let acc = bin.accessor(v, FLOAT, weights.len(), "SCALAR", None);
    samplers.push(json!({"input": time_acc, "output": acc, "interpolation": "LINEAR"}));
    channels.push(json!({"sampler": samplers.len() - 1, "target": {"node": n, "path": "weights"}}));

    // The hi-hat's top cymbal rides on the pedal: its node's translation follows the
    // motion's openness.
    // (`kit_parts` is empty without a kit.)
    if let Some(kit) = baked.kit {
        let rest = kit.pedals.map_or(0.0, |p| p.beater_rest_deg).to_radians();
        let angles = beater_angles(baked.motion, rest);
        for (k, part) in kit_parts.iter().enumerate() {
            if part.moves == Moves::Still {
                continue;
            }
            let moved: Vec<PartMotion> = baked
                .motion
                .frames
                .iter()
                .zip(&angles)
                .filter_map(|(f, &a)| part_motion(part, kit, f.hihat_openness, a))
                .collect();
            let (path, width) = match moved.first() {
                Some(PartMotion::Translation(_)) => ("translation", "VEC3"),
                _ => ("rotation", "VEC4"),
            };
            let values: Vec<f32> = moved
                .iter()
                .flat_map(|m| match m {
                    PartMotion::Translation(t) => t.to_vec(),
                    PartMotion::Rotation(q) => q.to_vec(),
                })
                .collect();
            let v = bin.floats(&values, None);
            let acc = bin.accessor(v, FLOAT, frames, width, None);
            samplers.push(json!({"input": time_acc, "output": acc, "interpolation": "LINEAR"}));
            channels.push(json!({"sampler": samplers.len() - 1, "target": {"node": n + 2 + k, "path": path}}));
        }
    }

    let mut nodes: Vec<Value> = rig
        .bones
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let offset = if b.parent.is_none() { b.offset + Vector3::z() * lift } else { b.offset };
            let mut node = json!({"name": baked.names[i], "translation": y_up(offset)});
            let children: Vec<usize> = (0..n).filter(|&c| rig.bones[c].parent == Some(i)).collect();
            if !children.is_empty() {
                node["children"] = json!(children);
            }
            node
        })
        .collect();
    nodes.push(json!({"name": "drummer", "mesh": 0, "skin": 0}));
    let mut roots = vec![0, n];
    let mut meshes = vec![json!({"name": "drummer", "primitives": body_primitives,
        "weights": vec![0.0; scene::FACE_TARGETS.len()], "extras": {"targetNames": scene::FACE_TARGETS}})];
    if !kit_parts.is_empty() {
        roots.push(n + 1);
        nodes.push(json!({"name": "kit", "children": (n + 2..n + 2 + kit_parts.len()).collect::<Vec<_>>()}));
        for (part, mesh) in kit_parts.iter().zip(kit_meshes) {
            let mut node = json!({"name": part.name, "mesh": meshes.len()});
            if part.origin != Vector3::zeros() {
                node["translation"] = json!(y_up(part.origin));
            }
            nodes.push(node);
            meshes.push(mesh);
        }
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "drumsim"},
        "scene": 0,
        "scenes": [{"name": "drummer", "nodes": roots}],
        "nodes": nodes,
        "skins": [{"name": "rig", "joints": (0..n).collect::<Vec<_>>(), "inverseBindMatrices": ibm_acc, "skeleton": 0}],
        "materials": materials,
        "meshes": meshes,
        "animations": [{"name": "drumming", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": bin.data.len()}],
        "bufferViews": bin.views,
        "accessors": bin.accessors,
    });
    glb(&doc.to_string(), bin.data)
}

/// How a moving kit part is placed in one frame (Y-up, relative to its parent, the kit).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PartMotion {
    Translation([f32; 3]),
    /// (x, y, z, w).
    Rotation([f32; 4]),
}

/// Where a moving part is in a frame with this hi-hat openness (0..1) and kick beater angle
/// (radians back from the head); none for a part that does not move.
pub fn part_motion(part: &KitPart, kit: &Kit, openness: f32, beater_angle: f32) -> Option<PartMotion> {
    match part.moves {
        Moves::Still => None,
        // The hi-hat's top cymbal rides on the pedal: lifted along the piece's normal.
        Moves::HihatTop => {
            let normal = kit.piece(&part.name).map_or(Vector3::z(), |p| Vector3::from(p.normal));
            let travel = kit.pedals.map_or(0.0, |p| p.hihat_travel_m);
            Some(PartMotion::Translation(y_up(part.origin + normal * (travel * clean(openness).clamp(0.0, 1.0)))))
        }
        Moves::KickBeater => {
            let rest = kit.pedals.map_or(0.0, |p| p.beater_rest_deg).to_radians();
            let [w, x, y, z] = y_up_rot(&UnitQuaternion::from_axis_angle(&Vector3::x_axis(), beater_angle - rest));
            Some(PartMotion::Rotation([x, y, z, w]))
        }
    }
}

/// The right foot's lift off the kick pedal, 0 (down) .. 1 (a full press's lift).
pub fn kick_foot_lift(frame: &crate::motion::MotionFrame) -> f32 {
    use crate::motion::feet::{FEET_HOME, PRESS_LIFT_M};
    ((frame.feet[1].pos[2] - FEET_HOME[1][2]) / PRESS_LIFT_M).clamp(0.0, 1.0)
}

/// The kick beater's angle back from the head (radians) in every frame, from the right
/// foot of the motion: at the head on a kick's frame (the foot back down after a press),
/// drawn further back as the foot lifts before it, else at `rest`.
fn beater_angles(motion: &Motion, rest: f32) -> Vec<f32> {
    let lift: Vec<f32> = motion.frames.iter().map(kick_foot_lift).collect();
    swing(&lift, rest)
}

/// The beater's angle in a frame from the foot's lift in it and in the frame before.
pub fn beater_angle(lift: f32, lift_before: f32, rest: f32) -> f32 {
    if lift < 1e-3 && lift_before > 1e-3 {
        0.0
    } else {
        rest * (1.0 + 0.6 * lift)
    }
}

/// The beater's angle for each frame's foot lift (0..1).
fn swing(lift: &[f32], rest: f32) -> Vec<f32> {
    (0..lift.len()).map(|i| beater_angle(lift[i], if i > 0 { lift[i - 1] } else { 0.0 }, rest)).collect()
}

/// A mesh primitive of `shape` (Y-up) with `material`; `skinned` adds its joints, each
/// vertex weighted 1 to its bone.
fn primitive(bin: &mut Bin, shape: &Shape, material: Material, skinned: bool) -> Value {
    let positions: Vec<f32> = shape.positions.iter().flat_map(|p| y_up(*p)).collect();
    let normals: Vec<f32> = shape.normals.iter().flat_map(|p| y_up(*p)).collect();
    let v = bin.floats(&positions, Some(ARRAY_BUFFER));
    let pos_acc = bin.accessor(v, FLOAT, positions.len() / 3, "VEC3", Some(bounds(&positions, 3)));
    let v = bin.floats(&normals, Some(ARRAY_BUFFER));
    let normal_acc = bin.accessor(v, FLOAT, normals.len() / 3, "VEC3", None);
    let index_bytes: Vec<u8> = shape.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let v = bin.view(&index_bytes, Some(ELEMENT_ARRAY_BUFFER));
    let index_acc = bin.accessor(v, UNSIGNED_INT, shape.indices.len(), "SCALAR", None);
    let mut attributes = json!({"POSITION": pos_acc, "NORMAL": normal_acc});
    if skinned {
        let joint_bytes: Vec<u8> =
            shape.joints.iter().flat_map(|&j| [j, 0, 0, 0]).flat_map(|j| j.to_le_bytes()).collect();
        let v = bin.view(&joint_bytes, Some(ARRAY_BUFFER));
        attributes["JOINTS_0"] = json!(bin.accessor(v, UNSIGNED_SHORT, shape.joints.len(), "VEC4", None));
        let weights: Vec<f32> = shape.joints.iter().flat_map(|_| [1.0, 0.0, 0.0, 0.0]).collect();
        let v = bin.floats(&weights, Some(ARRAY_BUFFER));
        attributes["WEIGHTS_0"] = json!(bin.accessor(v, FLOAT, shape.joints.len(), "VEC4", None));
    }
    json!({"attributes": attributes, "indices": index_acc, "material": Material::ALL.iter().position(|m| *m == material)})
}

/// The GLB container: 12-byte header, JSON chunk padded with spaces, BIN chunk padded with
/// zeros, both to 4 bytes.
pub(super) fn glb(json_text: &str, mut bin: Vec<u8>) -> Vec<u8> {
    let mut json_bytes = json_text.as_bytes().to_vec();
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json_bytes.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json_bytes);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_beater_meets_the_head_on_the_frame_the_foot_comes_down() {
        let lift = [0.0, 0.0, 0.5, 1.0, 0.5, 0.0, 0.0];
        let a = super::swing(&lift, 0.7);
        assert_eq!(a[5], 0.0, "{a:?}");
        assert!(a[3] > a[2] && a[2] > a[0] && (a[0] - 0.7).abs() < 1e-6 && (a[6] - 0.7).abs() < 1e-6, "{a:?}");
    }
}
