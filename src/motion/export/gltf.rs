//! `SONG.glb`: binary glTF 2.0 with the rig as a skin and the motion as one animation.
//!
//! Layout: nodes 0..57 are the bones (node i = rig bone i, rest translation = the bone's
//! offset, the hips' lifted so that the rest pose stands on the floor, rest rotation
//! identity), node 57 carries a small skinned mesh (a tetrahedron
//! along each bone, weighted 1 to it) so that any viewer shows the figure; skin 0 lists the
//! 57 joints with their inverse bind matrices. Animation 0 has 60 fps LINEAR samplers: the
//! translation of the root (hips) and the rotation of every bone, keyed on every frame.
//! Axes are glTF's (Y-up, the drummer facing +Z), metres. Written by hand: a JSON chunk and
//! a BIN chunk, every buffer view 4-byte aligned.

use super::{write_file, write_one, y_up, y_up_rot, Baked, ExportError};
use crate::motion::rig::Rig;
use crate::motion::track::Motion;
use nalgebra::Vector3;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;

const FLOAT: u32 = 5126;
const UNSIGNED_SHORT: u32 = 5123;
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
struct Bin {
    data: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Bin {
    /// Append a buffer view of little-endian f32 values.
    fn floats(&mut self, values: &[f32], target: Option<u32>) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.view(&bytes, target)
    }

    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        let offset = self.data.len();
        self.data.extend_from_slice(bytes);
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        self.views.push(v);
        self.views.len() - 1
    }

    fn accessor(
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
fn bounds(values: &[f32], n: usize) -> (Value, Value) {
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
fn clean(v: f32) -> f32 {
    if v.is_finite() {
        v
    } else {
        0.0
    }
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

    // The bone shapes.
    let (positions, joints, weights, indices) = bone_shapes(rig, &rest);
    let v = bin.floats(&positions, Some(ARRAY_BUFFER));
    let pos_acc = bin.accessor(v, FLOAT, positions.len() / 3, "VEC3", Some(bounds(&positions, 3)));
    let joint_bytes: Vec<u8> = joints.iter().flat_map(|j| j.to_le_bytes()).collect();
    let v = bin.view(&joint_bytes, Some(ARRAY_BUFFER));
    let joint_acc = bin.accessor(v, UNSIGNED_SHORT, joints.len() / 4, "VEC4", None);
    let v = bin.floats(&weights, Some(ARRAY_BUFFER));
    let weight_acc = bin.accessor(v, FLOAT, weights.len() / 4, "VEC4", None);
    let index_bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let v = bin.view(&index_bytes, Some(ELEMENT_ARRAY_BUFFER));
    let index_acc = bin.accessor(v, UNSIGNED_SHORT, indices.len(), "SCALAR", None);

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

    let mut nodes: Vec<Value> = rig
        .bones
        .iter()
        .enumerate()
        .map(|(i, b)| {
            let offset = if b.parent.is_none() { b.offset + Vector3::z() * lift } else { b.offset };
            let mut node = json!({"name": b.name, "translation": y_up(offset)});
            let children: Vec<usize> = (0..n).filter(|&c| rig.bones[c].parent == Some(i)).collect();
            if !children.is_empty() {
                node["children"] = json!(children);
            }
            node
        })
        .collect();
    nodes.push(json!({"name": "drummer", "mesh": 0, "skin": 0}));
    let doc = json!({
        "asset": {"version": "2.0", "generator": "drumsim"},
        "scene": 0,
        "scenes": [{"name": "drummer", "nodes": [0, n]}],
        "nodes": nodes,
        "skins": [{"name": "rig", "joints": (0..n).collect::<Vec<_>>(), "inverseBindMatrices": ibm_acc, "skeleton": 0}],
        "meshes": [{"name": "bones", "primitives": [{
            "attributes": {"POSITION": pos_acc, "JOINTS_0": joint_acc, "WEIGHTS_0": weight_acc},
            "indices": index_acc,
        }]}],
        "animations": [{"name": "drumming", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": bin.data.len()}],
        "bufferViews": bin.views,
        "accessors": bin.accessors,
    });
    glb(&doc.to_string(), bin.data)
}

/// One tetrahedron per bone from its joint to its tail, in the rest pose, Y-up: positions,
/// joint indices and weights (4 per vertex), triangle indices.
fn bone_shapes(rig: &Rig, rest: &[Vector3<f32>]) -> (Vec<f32>, Vec<u16>, Vec<f32>, Vec<u16>) {
    let (mut pos, mut joints, mut weights, mut indices) = (vec![], vec![], vec![], vec![]);
    for (i, bone) in rig.bones.iter().enumerate() {
        let tail = if bone.tail.norm() > 1e-4 { bone.tail } else { Vector3::z() * 0.01 };
        let len = tail.norm();
        let axis = tail / len;
        let helper = if axis.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
        let e1 = axis.cross(&helper).normalize();
        let e2 = axis.cross(&e1);
        let r = (0.12 * len).clamp(0.003, 0.02);
        let first = (pos.len() / 3) as u16;
        let mut corners: Vec<Vector3<f32>> = (0..3)
            .map(|k| {
                let a = k as f32 * std::f32::consts::TAU / 3.0;
                rest[i] + (e1 * a.cos() + e2 * a.sin()) * r
            })
            .collect();
        corners.push(rest[i] + tail);
        for c in corners {
            pos.extend_from_slice(&y_up(c));
            joints.extend_from_slice(&[i as u16, 0, 0, 0]);
            weights.extend_from_slice(&[1.0, 0.0, 0.0, 0.0]);
        }
        for tri in [[0, 1, 3], [1, 2, 3], [2, 0, 3], [0, 2, 1]] {
            indices.extend(tri.iter().map(|&k| first + k));
        }
    }
    (pos, joints, weights, indices)
}

/// The GLB container: 12-byte header, JSON chunk padded with spaces, BIN chunk padded with
/// zeros, both to 4 bytes.
fn glb(json_text: &str, mut bin: Vec<u8>) -> Vec<u8> {
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
