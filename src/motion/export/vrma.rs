//! `SONG.vrma`: the motion as a VRM Animation (glTF with the `VRMC_vrm_animation` 1.0
//! extension), which VRM tools (UniVRM, three-vrm, the VRM add-on for Blender, VTuber apps)
//! play on any VRM 1.0 model.
//!
//! The file holds the 53 humanoid bones drumsim drives (the 55 of `motion::humanoid` less the
//! eyes, which VRM Animation leaves to its look-at) as nodes in the VRM T-pose: every rest
//! rotation the identity, the joints at drumsim's proportions, glTF's Y-up frame with the
//! drummer facing +Z (as a VRM 1.0 model faces). One animation at 60 frames a second: each
//! bone's rotation from the T-pose, and the hips' translation (the only one VRM Animation
//! allows). The face: blink, blinkLeft, blinkRight and aa (jaw open) as presets (VRM adds
//! expressions up, so `blink` is both eyes' shared closing and each eye's preset the rest),
//! the other ARKit weights the motion moves as custom expressions under their ARKit names
//! (for "perfect sync" models), each an expression node whose translation's x is the weight.

use super::gltf::{bounds, clean, glb, Bin, FLOAT};
use super::{write_file, y_up, y_up_rot, Baked, ExportError};
use crate::motion::humanoid::Humanoid;
use crate::motion::ARKIT_NAMES;
use serde_json::{json, Value};
use std::io::Write;
use std::path::Path;

/// The VRM 1.0 humanoid bone name of a Unity `HumanBodyBones` name: lower camel case, and
/// the thumb's three bones are metacarpal, proximal and distal (Unity: proximal,
/// intermediate, distal).
pub fn vrm_bone_name(unity: &str) -> String {
    let thumb = unity.replace("ThumbProximal", "ThumbMetacarpal").replace("ThumbIntermediate", "ThumbProximal");
    let mut c = thumb.chars();
    c.next().map(|f| f.to_lowercase().chain(c).collect()).unwrap_or_default()
}

/// VRM preset expressions and the ARKit weight each follows.
const PRESETS: [(&str, &str); 3] = [("blinkLeft", "eyeBlinkLeft"), ("blinkRight", "eyeBlinkRight"), ("aa", "jawOpen")];

/// Write `baked`'s motion as a VRM Animation to `path` (a partial name of an output set).
pub fn write_baked(baked: &Baked, path: &Path) -> Result<(), ExportError> {
    let bytes = build(baked);
    write_file(path, |w: &mut dyn Write| w.write_all(&bytes))
}

fn build(baked: &Baked) -> Vec<u8> {
    let humanoid = Humanoid::of_rig(baked.rig);
    // The bones a VRM Animation may carry: all but the eyes.
    let keep: Vec<usize> = (0..humanoid.bones.len()).filter(|&k| !humanoid.bones[k].name.ends_with("Eye")).collect();
    let node_of = |k: usize| keep.iter().position(|&x| x == k);
    let mut nodes: Vec<Value> = keep
        .iter()
        .map(|&k| {
            let b = &humanoid.bones[k];
            let mut node = json!({"name": vrm_bone_name(&b.name), "translation": y_up(b.t_pose_kit)});
            let children: Vec<usize> =
                keep.iter().enumerate().filter(|(_, &c)| humanoid.bones[c].parent == Some(k)).map(|(i, _)| i).collect();
            if !children.is_empty() {
                node["children"] = json!(children);
            }
            node
        })
        .collect();
    let mut bin = Bin::default();
    let frames = baked.poses.len();
    let times: Vec<f32> = (0..frames).map(|i| baked.time_s(i) as f32).collect();
    let v = bin.floats(&times, None);
    let time_acc = bin.accessor(v, FLOAT, frames, "SCALAR", Some(bounds(&times, 1)));
    let mut samplers: Vec<Value> = Vec::new();
    let mut channels: Vec<Value> = Vec::new();
    let mut channel = |bin: &mut Bin, node: usize, path: &str, values: &[f32], kind: &str| {
        let v = bin.floats(values, None);
        let acc = bin.accessor(v, FLOAT, frames, kind, None);
        samplers.push(json!({"input": time_acc, "output": acc, "interpolation": "LINEAR"}));
        channels.push(json!({"sampler": samplers.len() - 1, "target": {"node": node, "path": path}}));
    };

    // Bone rotations from the T-pose, and the hips' place.
    let n = humanoid.bones.len();
    let mut rotations = vec![Vec::with_capacity(frames * 4); keep.len()];
    let mut hips = Vec::with_capacity(frames * 3);
    let mut scratch = Vec::new();
    for pose in &baked.poses {
        let world = baked.rig.world(pose);
        humanoid.local_into(|i| world[i].1, &mut scratch);
        for (slot, &k) in keep.iter().enumerate() {
            let [w, x, y, z] = y_up_rot(&scratch[n + k]);
            let mut q = [x, y, z, w].map(clean);
            // Stay in the previous key's hemisphere so that interpolation takes the short way.
            let r = &mut rotations[slot];
            if r.len() >= 4 && q.iter().zip(&r[r.len() - 4..]).map(|(a, b)| a * b).sum::<f32>() < 0.0 {
                q = q.map(|v| -v);
            }
            r.extend_from_slice(&q);
        }
        hips.extend(y_up(world[0].0).map(clean));
    }
    let hips_node = node_of(0).expect("hips");
    channel(&mut bin, hips_node, "translation", &hips, "VEC3");
    drop(hips);
    // Each bone's keys go into the buffer and are freed at once (a long song's are large).
    for (slot, r) in rotations.into_iter().enumerate() {
        channel(&mut bin, slot, "rotation", &r, "VEC4");
    }

    // Expressions: a node each, its translation's x the weight.
    let mut preset = serde_json::Map::new();
    let mut custom = serde_json::Map::new();
    let weight_of = |name: &str| ARKIT_NAMES.iter().position(|a| *a == name).expect("an ARKit name");
    let mut expression = |nodes: &mut Vec<Value>, bin: &mut Bin, name: &str, weight: &dyn Fn(usize) -> f32| {
        nodes.push(json!({"name": format!("expression {name}")}));
        let values: Vec<f32> = (0..frames).flat_map(|i| [clean(weight(i)).clamp(0.0, 1.0), 0.0, 0.0]).collect();
        channel(bin, nodes.len() - 1, "translation", &values, "VEC3");
        nodes.len() - 1
    };
    let face = |i: usize, k: usize| baked.motion.frames[i].face[k];
    // VRM adds expressions up: both eyes' shared closing is `blink`, each eye's own the rest.
    let (l, r) = (weight_of("eyeBlinkLeft"), weight_of("eyeBlinkRight"));
    let both = |i: usize| face(i, l).min(face(i, r));
    for (vrm, arkit) in PRESETS {
        let k = weight_of(arkit);
        let own = |i: usize| if k == l || k == r { face(i, k) - both(i) } else { face(i, k) };
        let node = expression(&mut nodes, &mut bin, vrm, &own);
        preset.insert(vrm.to_string(), json!({"node": node}));
    }
    let node = expression(&mut nodes, &mut bin, "blink", &both);
    preset.insert("blink".to_string(), json!({"node": node}));
    // The other ARKit weights the motion moves (one that stays 0 needs no key: unanimated is
    // 0); the blinks and the jaw are the presets' already, and would add up with them.
    for (k, name) in ARKIT_NAMES.iter().enumerate() {
        if PRESETS.iter().any(|(_, a)| a == name) || (0..frames).all(|i| face(i, k) == 0.0) {
            continue;
        }
        let node = expression(&mut nodes, &mut bin, name, &|i| face(i, k));
        custom.insert(name.to_string(), json!({"node": node}));
    }

    let human_bones: serde_json::Map<String, Value> = keep
        .iter()
        .enumerate()
        .map(|(slot, &k)| (vrm_bone_name(&humanoid.bones[k].name), json!({"node": slot})))
        .collect();
    let roots: Vec<usize> = std::iter::once(hips_node).chain(keep.len()..nodes.len()).collect();
    let doc = json!({
        "asset": {"version": "2.0", "generator": "drumsim"},
        "extensionsUsed": ["VRMC_vrm_animation"],
        "extensions": {"VRMC_vrm_animation": {
            "specVersion": "1.0",
            "humanoid": {"humanBones": human_bones},
            "expressions": {"preset": preset, "custom": custom},
        }},
        "scene": 0,
        "scenes": [{"name": "drummer", "nodes": roots}],
        "nodes": nodes,
        "animations": [{"name": "drumming", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": bin.data.len()}],
        "bufferViews": bin.views,
        "accessors": bin.accessors,
    });
    glb(&doc.to_string(), bin.data)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::rig::Rig;
    use crate::motion::track::{Motion, MotionFrame, Pose};
    use nalgebra::{Quaternion, UnitQuaternion, Vector3};

    #[test]
    fn vrm_names() {
        assert_eq!(vrm_bone_name("Hips"), "hips");
        assert_eq!(vrm_bone_name("UpperChest"), "upperChest");
        assert_eq!(vrm_bone_name("LeftThumbProximal"), "leftThumbMetacarpal");
        assert_eq!(vrm_bone_name("LeftThumbIntermediate"), "leftThumbProximal");
        assert_eq!(vrm_bone_name("RightLittleDistal"), "rightLittleDistal");
        assert_eq!(vrm_bone_name("LeftToes"), "leftToes");
    }

    /// A few frames of arms raised to either side.
    fn motion(rig: &Rig) -> Motion {
        let rest = rig.rest_positions();
        let frames = (0..4)
            .map(|i| {
                let lift = 0.1 * i as f32;
                let hand = |side: usize| {
                    let p = rest[crate::motion::rig::HAND[side]] + Vector3::new(0.0, 0.25, 0.2 + lift);
                    Pose { pos: p.into(), rot: [1.0, 0.0, 0.0, 0.0] }
                };
                let at = |b: usize| Pose { pos: rest[b].into(), rot: [1.0, 0.0, 0.0, 0.0] };
                let mut face = vec![0.0; 52];
                face[0] = 0.25 * i as f32;
                MotionFrame {
                    hands: [hand(0), hand(1)],
                    chest: at(crate::motion::rig::SPINE[2]),
                    head: at(crate::motion::rig::HEAD),
                    feet: [at(crate::motion::rig::FOOT[0]), at(crate::motion::rig::FOOT[1])],
                    face,
                    hihat_openness: 0.0,
                }
            })
            .collect();
        Motion { fps: 60.0, frames }
    }

    #[test]
    fn the_file_puts_every_joint_where_drumsim_has_it() {
        // Read the file back: forward kinematics of its T-pose nodes with each frame's
        // rotations and hips translation meets drumsim's joints (glTF frame).
        let rig = Rig::default();
        let m = motion(&rig);
        let baked = Baked::new(&m, &rig).unwrap();
        let bytes = build(&baked);
        let json_len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        let doc: Value = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
        let bin = &bytes[20 + json_len + 8..];
        let ext = &doc["extensions"]["VRMC_vrm_animation"];
        assert_eq!(ext["specVersion"], "1.0");
        let bones = ext["humanoid"]["humanBones"].as_object().unwrap();
        assert_eq!(bones.len(), 53);
        assert!(
            !bones.contains_key("leftEye") && bones.contains_key("leftThumbMetacarpal") && bones.contains_key("jaw")
        );
        // Only the weights that move and no preset has (the test motion moves eyeBlinkLeft, a
        // preset's).
        assert_eq!(ext["expressions"]["custom"].as_object().unwrap().len(), 0);
        let floats = |acc: usize| -> Vec<f32> {
            let a = &doc["accessors"][acc];
            let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
            let off = view["byteOffset"].as_u64().unwrap() as usize;
            let len = view["byteLength"].as_u64().unwrap() as usize;
            bin[off..off + len].chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect()
        };
        let nodes = doc["nodes"].as_array().unwrap();
        let anim = &doc["animations"][0];
        let channel = |node: usize, path: &str| -> Vec<f32> {
            let ch = anim["channels"]
                .as_array()
                .unwrap()
                .iter()
                .find(|c| c["target"]["node"] == node && c["target"]["path"] == path);
            let sampler = &anim["samplers"][ch.unwrap()["sampler"].as_u64().unwrap() as usize];
            floats(sampler["output"].as_u64().unwrap() as usize)
        };
        let mut parent = vec![None; nodes.len()];
        for (i, n) in nodes.iter().enumerate() {
            for c in n["children"].as_array().into_iter().flatten() {
                parent[c.as_u64().unwrap() as usize] = Some(i);
            }
        }
        let humanoid = Humanoid::of_rig(&rig);
        for (f, pose) in baked.poses.iter().enumerate() {
            let world = rig.world(pose);
            let mut placed: Vec<(Vector3<f32>, UnitQuaternion<f32>)> = Vec::new();
            for i in 0..nodes.len() {
                if nodes[i]["name"].as_str().unwrap().starts_with("expression") {
                    break;
                }
                let r = channel(i, "rotation");
                let q = UnitQuaternion::from_quaternion(Quaternion::new(
                    r[4 * f + 3],
                    r[4 * f],
                    r[4 * f + 1],
                    r[4 * f + 2],
                ));
                let t: Vec<f32> =
                    nodes[i]["translation"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap() as f32).collect();
                let entry = match parent[i] {
                    None => {
                        let h = channel(i, "translation");
                        (Vector3::new(h[3 * f], h[3 * f + 1], h[3 * f + 2]), q)
                    }
                    Some(p) => (placed[p].0 + placed[p].1 * Vector3::new(t[0], t[1], t[2]), placed[p].1 * q),
                };
                placed.push(entry);
                let unity = nodes[i]["name"].as_str().unwrap();
                let b = humanoid.bones.iter().find(|b| vrm_bone_name(&b.name) == unity).unwrap();
                let expected = Vector3::from(y_up(world[b.source].0));
                let tolerance =
                    if unity == "head" || parent[i].is_some_and(|p| nodes[p]["name"] == "head") { 3e-3 } else { 1e-4 };
                assert!((entry.0 - expected).norm() < tolerance, "frame {f} {unity}: {} vs {expected}", entry.0);
            }
        }
        // The blink of the left eye follows the ARKit weight (the right eye stays open).
        let node = ext["expressions"]["preset"]["blinkLeft"]["node"].as_u64().unwrap() as usize;
        let w = channel(node, "translation");
        assert_eq!([w[0], w[3], w[6], w[9]], [0.0, 0.25, 0.5, 0.75]);
    }
}
