//! The motion exports (JSON, BVH, binary glTF) on a synthetic performance: hands circling over
//! the default kit's snare, a swaying chest, feet on the pedals. Each file is read back and
//! checked against the rig; the glTF goes through the Khronos validator when
//! DRUMSIM_GLTF_VALIDATOR names its script (scripts/gltf-validate.js), the BVH through
//! `assimp info` when assimp is installed.

use drumsim::kit::Kit;
use drumsim::motion::export::{self, ExportError};
use drumsim::motion::rig::{Rig, HAND};
use drumsim::motion::{Motion, MotionFrame, Pose, ARKIT_NAMES, FPS, STICK_TIP_LOCAL};
use nalgebra::{UnitQuaternion, Vector3};
use std::path::{Path, PathBuf};

/// `seconds` of hands circling 12 cm above the snare (2 turns a second, opposite phases),
/// a chest and head swaying at 0.5 Hz, feet on the hi-hat and kick pedals.
fn synthetic_motion(rig: &Rig, seconds: f64) -> Motion {
    let kit = Kit::builtin_default();
    let snare = Vector3::from(kit.piece("snare").expect("default kit has a snare").position_m);
    let rest = rig.rest_positions();
    let q = |r: UnitQuaternion<f32>| [r.w, r.i, r.j, r.k];
    let frames = (0..(seconds * FPS) as usize)
        .map(|i| {
            let t = (i as f64 / FPS) as f32;
            let hands = std::array::from_fn(|side| {
                let out = if side == 0 { -1.0 } else { 1.0 };
                let phase = std::f32::consts::TAU * 2.0 * t + side as f32 * std::f32::consts::PI;
                let tip = snare + Vector3::new(0.06 * out + 0.05 * phase.cos(), 0.05 * phase.sin(), 0.12);
                // Stick forward, tip down 20 degrees, turned 15 degrees towards the middle.
                let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), out * 0.26)
                    * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), -0.35);
                let grip = tip - rot * Vector3::from(STICK_TIP_LOCAL);
                Pose { pos: grip.into(), rot: q(rot) }
            });
            let sway = (std::f32::consts::TAU * 0.5 * t).sin();
            let lean = UnitQuaternion::from_euler_angles(0.02 * sway, 0.0, 0.05 * sway)
                * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), 0.12);
            let neck = rest[drumsim::motion::rig::NECK[0]];
            MotionFrame {
                hands,
                chest: Pose { pos: (neck + Vector3::new(0.0, 0.03, -0.005)).into(), rot: q(lean) },
                head: Pose { pos: rest[drumsim::motion::rig::HEAD].into(), rot: q(lean) },
                feet: [
                    Pose { pos: [-0.28, 0.38, 0.1], rot: [1.0, 0.0, 0.0, 0.0] },
                    Pose { pos: [0.1, 0.55, 0.1 + 0.03 * sway.max(0.0)], rot: [1.0, 0.0, 0.0, 0.0] },
                ],
                face: (0..ARKIT_NAMES.len()).map(|k| (0.5 + 0.5 * (t + k as f32).sin()) * 0.3).collect(),
                hihat_openness: 0.5 + 0.5 * sway,
            }
        })
        .collect();
    Motion { fps: FPS, frames }
}

fn out_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("drumsim-exports-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn v3(v: &serde_json::Value) -> Vector3<f32> {
    Vector3::new(v[0].as_f64().unwrap() as f32, v[1].as_f64().unwrap() as f32, v[2].as_f64().unwrap() as f32)
}

#[test]
fn motion_json_holds_bones_tips_face_and_hihat_per_frame() {
    let rig = Rig::default();
    let motion = synthetic_motion(&rig, 3.0);
    let dir = out_dir("json");
    let paths = export::write_all(&motion, &rig, None, &dir, "groove").unwrap();
    assert_eq!(paths.json, dir.join("groove.motion.json"));
    let doc: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&paths.json).unwrap()).unwrap();
    assert_eq!(doc["fps"].as_f64(), Some(60.0));
    let bones = doc["bones"].as_array().unwrap();
    assert_eq!(bones.len(), 57);
    for (i, b) in bones.iter().enumerate() {
        assert!(b["parent"].as_u64().is_none_or(|p| (p as usize) < i));
    }
    assert_eq!(doc["face_names"].as_array().unwrap().len(), 52);
    let frames = doc["frames"].as_array().unwrap();
    assert_eq!(frames.len(), motion.frames.len());
    let mut worst_grip = 0.0f32;
    let mut worst_link = 0.0f32;
    for (f, src) in frames.iter().zip(&motion.frames) {
        let b = f["bones"].as_array().unwrap();
        assert_eq!(b.len(), 57);
        assert_eq!(f["face"].as_array().unwrap().len(), 52);
        assert!((f["hihat_openness"].as_f64().unwrap() as f32 - src.hihat_openness).abs() < 1e-3);
        // The hand bone carries the stick's tip to the target's, within a millimetre (the
        // grip itself may turn about the tip, out of the body).
        for side in 0..2 {
            let h = &b[HAND[side]];
            let r = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(
                h[3].as_f64().unwrap() as f32,
                h[4].as_f64().unwrap() as f32,
                h[5].as_f64().unwrap() as f32,
                h[6].as_f64().unwrap() as f32,
            ));
            let grip = v3(h) + r * rig.grip_local;
            let bone_tip = grip + r * Vector3::from(drumsim::motion::track::STICK_TIP_LOCAL);
            worst_grip = worst_grip.max((bone_tip - Vector3::from(src.hands[side].stick_tip())).norm());
            let tip = v3(&f["tips"][side]);
            assert!((tip - Vector3::from(src.hands[side].stick_tip())).norm() < 1e-4);
        }
        // Joint positions keep the rig's link lengths.
        for (i, bone) in rig.bones.iter().enumerate() {
            if let Some(p) = bone.parent {
                let len = (v3(&b[i]) - v3(&b[p])).norm();
                worst_link = worst_link.max((len - rig.link_length(i)).abs());
            }
        }
    }
    println!(
        "motion json: worst stick tip error {:.3} mm, worst link error {:.3} mm",
        worst_grip * 1e3,
        worst_link * 1e3
    );
    assert!(worst_grip < 1e-3, "the stick tip misses by {worst_grip} m");
    assert!(worst_link < 1e-4, "link length off by {worst_link} m");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A joint of a parsed BVH.
struct BvhJoint {
    parent: Option<usize>,
    offset: Vector3<f32>,
    channels: Vec<String>,
}

/// A minimal BVH reader: the joints (ROOT and JOINT, not End Site) and the frames' values.
fn read_bvh(text: &str) -> (Vec<BvhJoint>, Vec<Vec<f32>>, f32) {
    let mut joints: Vec<BvhJoint> = vec![];
    let mut stack: Vec<Option<usize>> = vec![];
    let mut lines = text.lines().map(str::trim);
    assert_eq!(lines.next(), Some("HIERARCHY"));
    let mut pending: Option<Option<usize>> = None; // the parent of a joint just opened
    for line in lines.by_ref() {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.first().copied() {
            Some("ROOT") | Some("JOINT") => {
                let parent = stack.iter().rev().flatten().next().copied();
                joints.push(BvhJoint { parent, offset: Vector3::zeros(), channels: vec![] });
                pending = Some(Some(joints.len() - 1));
            }
            Some("End") => pending = Some(None),
            Some("{") => stack.push(pending.take().expect("{ without a joint")),
            Some("}") => {
                stack.pop().expect("unbalanced }");
            }
            Some("OFFSET") => {
                if let Some(Some(j)) = stack.last() {
                    let v: Vec<f32> = words[1..].iter().map(|w| w.parse().unwrap()).collect();
                    joints[*j].offset = Vector3::new(v[0], v[1], v[2]);
                }
            }
            Some("CHANNELS") => {
                let j = stack.last().unwrap().unwrap();
                let n: usize = words[1].parse().unwrap();
                joints[j].channels = words[2..].iter().map(|w| w.to_string()).collect();
                assert_eq!(joints[j].channels.len(), n);
            }
            Some("MOTION") => break,
            other => panic!("unexpected BVH line {other:?}"),
        }
    }
    assert!(stack.is_empty(), "unbalanced braces");
    let frames_line = lines.next().unwrap();
    let count: usize = frames_line.strip_prefix("Frames:").unwrap().trim().parse().unwrap();
    let dt: f32 = lines.next().unwrap().strip_prefix("Frame Time:").unwrap().trim().parse().unwrap();
    let values: Vec<Vec<f32>> =
        lines.filter(|l| !l.is_empty()).map(|l| l.split_whitespace().map(|w| w.parse().unwrap()).collect()).collect();
    assert_eq!(values.len(), count, "Frames: says {count}");
    (joints, values, dt)
}

/// World positions of the joints of one BVH frame (channels applied in their listed order).
fn bvh_world(joints: &[BvhJoint], values: &[f32]) -> Vec<Vector3<f32>> {
    let mut world: Vec<(Vector3<f32>, UnitQuaternion<f32>)> = vec![];
    let mut k = 0;
    for j in joints {
        let mut pos = j.offset;
        let mut rot = UnitQuaternion::identity();
        for c in &j.channels {
            let v = values[k];
            k += 1;
            let axis = |a| UnitQuaternion::from_axis_angle(&a, v.to_radians());
            match c.as_str() {
                "Xposition" => pos.x = v,
                "Yposition" => pos.y = v,
                "Zposition" => pos.z = v,
                "Xrotation" => rot *= axis(Vector3::x_axis()),
                "Yrotation" => rot *= axis(Vector3::y_axis()),
                "Zrotation" => rot *= axis(Vector3::z_axis()),
                other => panic!("channel {other}"),
            }
        }
        world.push(match j.parent {
            None => (pos, rot),
            Some(p) => (world[p].0 + world[p].1 * j.offset, world[p].1 * rot),
        });
    }
    assert_eq!(k, values.len(), "values per frame");
    world.into_iter().map(|w| w.0).collect()
}

#[test]
fn bvh_parses_back_to_57_joints_that_match_the_rig() {
    let rig = Rig::default();
    let motion = synthetic_motion(&rig, 2.0);
    let dir = out_dir("bvh");
    let path = dir.join("groove.bvh");
    export::bvh::write(&motion, &rig, &path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    let (joints, values, dt) = read_bvh(&text);
    assert_eq!(joints.len(), 57);
    assert_eq!(values.len(), motion.frames.len());
    assert!((dt - 1.0 / 60.0).abs() < 1e-6);
    assert!(values.iter().all(|v| v.len() == 6 + 56 * 3));
    // Forward kinematics of the BVH equals the rig's, in centimetres and Y-up.
    let poses = drumsim::motion::body_ik::solve_motion(&rig, &motion);
    let mut worst = 0.0f32;
    for (pose, v) in poses.iter().zip(&values).step_by(7) {
        let bvh = bvh_world(&joints, v);
        for ((p, _), b) in rig.world(pose).iter().zip(&bvh) {
            let expect = Vector3::from(export::y_up(*p)) * 100.0;
            worst = worst.max((expect - b).norm());
        }
    }
    println!("bvh: worst joint position difference to the rig {worst:.4} cm");
    assert!(worst < 0.05, "BVH joints off the rig by {worst} cm");

    if let Some(report) = assimp_info(&path) {
        // assimp makes a node of every joint and of every End Site, and animates the joints.
        let leaves = (0..57).filter(|&i| !rig.bones.iter().any(|b| b.parent == Some(i))).count();
        let nodes = assimp_count(&report, "Nodes:");
        let channels = assimp_count(&report, "Animation Channels:");
        println!("assimp info: {nodes:?} nodes, {channels:?} animation channels");
        assert_eq!(channels, Some(57), "assimp report:\n{report}");
        assert_eq!(nodes, Some(57 + leaves), "assimp report:\n{report}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `assimp info FILE`'s report, or None (with a note) when assimp is not installed.
fn assimp_info(path: &Path) -> Option<String> {
    match std::process::Command::new("assimp").arg("info").arg(path).output() {
        Ok(out) if out.status.success() => Some(String::from_utf8_lossy(&out.stdout).into_owned()),
        Ok(out) => panic!("assimp info {} failed: {}", path.display(), String::from_utf8_lossy(&out.stderr)),
        Err(_) => {
            println!("assimp not installed: skipping the assimp check (apt-get install assimp-utils)");
            None
        }
    }
}

/// The number after `key` in an `assimp info` report.
fn assimp_count(report: &str, key: &str) -> Option<usize> {
    report.lines().find_map(|l| l.trim().strip_prefix(key).and_then(|r| r.trim().parse().ok()))
}

/// World joint positions of frame `k` of a GLB's animation 0: node translations, the
/// animated root translation and rotations, composed down the node tree.
fn glb_world(doc: &serde_json::Value, bin: &[u8], k: usize, joints: usize) -> Vec<Vector3<f32>> {
    let floats = |acc: usize, width: usize| -> Vec<f32> {
        let a = &doc["accessors"][acc];
        let view = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let at = view["byteOffset"].as_u64().unwrap() as usize + k * width * 4;
        (0..width).map(|c| f32::from_le_bytes(bin[at + 4 * c..at + 4 * c + 4].try_into().unwrap())).collect()
    };
    let nodes = doc["nodes"].as_array().unwrap();
    let mut parent = vec![None; joints];
    for (i, n) in nodes.iter().enumerate().take(joints) {
        for c in n["children"].as_array().into_iter().flatten() {
            parent[c.as_u64().unwrap() as usize] = Some(i);
        }
    }
    let mut translation: Vec<Vector3<f32>> = nodes.iter().take(joints).map(|n| v3(&n["translation"])).collect();
    let mut rotation = vec![UnitQuaternion::identity(); joints];
    let anim = &doc["animations"][0];
    for ch in anim["channels"].as_array().unwrap() {
        let node = ch["target"]["node"].as_u64().unwrap() as usize;
        let sampler = &anim["samplers"][ch["sampler"].as_u64().unwrap() as usize];
        let out = sampler["output"].as_u64().unwrap() as usize;
        match ch["target"]["path"].as_str().unwrap() {
            "translation" => translation[node] = Vector3::from_vec(floats(out, 3)),
            "rotation" => {
                let q = floats(out, 4); // x, y, z, w
                rotation[node] = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[3], q[0], q[1], q[2]));
            }
            "weights" => {} // the face's blend shapes
            other => panic!("animated {other}"),
        }
    }
    let mut world: Vec<(Vector3<f32>, UnitQuaternion<f32>)> = vec![];
    for i in 0..joints {
        world.push(match parent[i] {
            None => (translation[i], rotation[i]),
            Some(p) => (world[p].0 + world[p].1 * translation[i], world[p].1 * rotation[i]),
        });
    }
    world.into_iter().map(|w| w.0).collect()
}

/// The JSON chunk of a GLB file, after checking the container.
fn glb_json(bytes: &[u8]) -> serde_json::Value {
    let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap()) as usize;
    assert_eq!(&bytes[0..4], b"glTF");
    assert_eq!(u32_at(4), 2);
    assert_eq!(u32_at(8), bytes.len());
    let json_len = u32_at(12);
    assert_eq!(&bytes[16..20], b"JSON");
    assert_eq!(json_len % 4, 0);
    let bin_at = 20 + json_len;
    assert_eq!(&bytes[bin_at + 4..bin_at + 8], b"BIN\0");
    assert_eq!(bin_at + 8 + u32_at(bin_at), bytes.len());
    serde_json::from_slice(&bytes[20..20 + json_len]).unwrap()
}

/// Run the Khronos glTF validator on `path` when DRUMSIM_GLTF_VALIDATOR names its script
/// (as `.ci/run` does) and assert 0 errors.
fn khronos_validate(path: &Path) {
    match std::env::var_os("DRUMSIM_GLTF_VALIDATOR") {
        Some(script) => {
            let out = std::process::Command::new("node").arg(&script).arg(path).output().expect("run node");
            let report = String::from_utf8_lossy(&out.stdout);
            println!("gltf-validator: {report}");
            let errors = report
                .lines()
                .next()
                .and_then(|l| l.strip_prefix("errors="))
                .and_then(|r| r.split_whitespace().next())
                .and_then(|n| n.parse::<usize>().ok())
                .unwrap_or_else(|| panic!("no report from {script:?}: {}", String::from_utf8_lossy(&out.stderr)));
            assert_eq!(errors, 0, "{report}");
        }
        None => println!("DRUMSIM_GLTF_VALIDATOR not set: skipping the Khronos glTF validator"),
    }
}

#[test]
fn glb_carries_the_kit_and_the_sticks_and_validates() {
    let rig = Rig::default();
    let kit = Kit::builtin_default();
    let mut motion = synthetic_motion(&rig, 1.0);
    for (i, f) in motion.frames.iter_mut().enumerate() {
        f.hihat_openness = if i < 30 { 0.0 } else { 1.0 };
    }
    let dir = out_dir("glb-kit");
    let paths = export::write_all(&motion, &rig, Some(&kit), &dir, "kit").unwrap();
    let bytes = std::fs::read(&paths.glb).unwrap();
    let doc = glb_json(&bytes);
    let names: Vec<&str> = doc["nodes"].as_array().unwrap().iter().filter_map(|n| n["name"].as_str()).collect();
    for piece in &kit.pieces {
        assert!(names.contains(&piece.id.as_str()), "no node for {}", piece.id);
    }
    for part in ["kit", "drummer", "kick beater", "hihat pedal", "stool"] {
        assert!(names.contains(&part), "no {part} node");
    }
    let materials: Vec<&str> = doc["materials"].as_array().unwrap().iter().filter_map(|m| m["name"].as_str()).collect();
    assert!(materials.contains(&"stick") && materials.contains(&"skin") && materials.contains(&"bronze"));
    // The hi-hat's top cymbal is animated: closed, then open by the pedal's travel.
    let anim = &doc["animations"][0];
    let hihat = names.iter().position(|n| *n == "hihat").unwrap();
    let channel =
        anim["channels"].as_array().unwrap().iter().find(|c| c["target"]["node"] == hihat).expect("a hi-hat channel");
    assert_eq!(channel["target"]["path"], "translation");
    let out = anim["samplers"][channel["sampler"].as_u64().unwrap() as usize]["output"].as_u64().unwrap() as usize;
    let bin = &bytes[20 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize + 8..];
    let y_at = |frame: usize| {
        let view = &doc["bufferViews"][doc["accessors"][out]["bufferView"].as_u64().unwrap() as usize];
        let at = view["byteOffset"].as_u64().unwrap() as usize + frame * 12 + 4;
        f32::from_le_bytes(bin[at..at + 4].try_into().unwrap())
    };
    let beater = names.iter().position(|n| *n == "kick beater").unwrap();
    assert!(anim["channels"]
        .as_array()
        .unwrap()
        .iter()
        .any(|c| c["target"]["node"] == beater && c["target"]["path"] == "rotation"));
    let travel = kit.pedals.unwrap().hihat_travel_m;
    assert!((y_at(45) - y_at(0) - travel).abs() < 1e-4, "open {} closed {}", y_at(45), y_at(0));
    khronos_validate(&paths.glb);
    // The VRM Animation beside it: a valid glTF with the humanoid's 53 bones and the face.
    let vrma = glb_json(&std::fs::read(&paths.vrma).unwrap());
    let ext = &vrma["extensions"]["VRMC_vrm_animation"];
    assert_eq!(ext["humanoid"]["humanBones"].as_object().unwrap().len(), 53);
    assert!(ext["expressions"]["preset"]["blinkLeft"].is_object() && ext["expressions"]["preset"]["aa"].is_object());
    khronos_validate(&paths.vrma);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn glb_has_the_skin_and_one_animation_and_validates() {
    let rig = Rig::default();
    let motion = synthetic_motion(&rig, 3.0);
    let dir = out_dir("glb");
    let path = dir.join("groove.glb");
    export::gltf::write(&motion, &rig, &path).unwrap();
    let bytes = std::fs::read(&path).unwrap();
    let doc = glb_json(&bytes);
    assert_eq!(doc["skins"][0]["joints"].as_array().unwrap().len(), 57);
    // The rest (bind) pose stands on the floor: its lowest joint at y = 0, none below.
    let nodes = doc["nodes"].as_array().unwrap();
    let mut rest: Vec<Vector3<f32>> = Vec::new();
    for i in 0..57 {
        let parent = (0..i).find(|&p| nodes[p]["children"].as_array().is_some_and(|c| c.iter().any(|c| c == i)));
        rest.push(parent.map_or(Vector3::zeros(), |p| rest[p]) + v3(&nodes[i]["translation"]));
    }
    let lowest = rest.iter().map(|p| p.y).fold(f32::INFINITY, f32::min);
    assert!(lowest.abs() < 1e-4, "the rest pose's lowest joint is at y = {lowest} m");
    // The animated skeleton is the rig's, in metres and Y-up.
    let bin = &bytes[20 + u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize + 8..];
    let poses = drumsim::motion::body_ik::solve_motion(&rig, &motion);
    let mut worst = 0.0f32;
    for k in (0..poses.len()).step_by(11) {
        for ((p, _), g) in rig.world(&poses[k]).iter().zip(glb_world(&doc, bin, k, 57)) {
            worst = worst.max((Vector3::from(export::y_up(*p)) - g).norm());
        }
    }
    println!("glb: worst joint position difference to the rig {:.4} mm", worst * 1e3);
    assert!(worst < 1e-4, "GLB joints off the rig by {worst} m");
    let anim = &doc["animations"][0];
    // The root's translation, every bone's rotation, the face's blend shape weights.
    assert_eq!(anim["channels"].as_array().unwrap().len(), 1 + 57 + 1);
    let targets = doc["meshes"][0]["extras"]["targetNames"].as_array().unwrap();
    assert_eq!(targets.len(), 3);
    assert!(doc["meshes"][0]["primitives"]
        .as_array()
        .unwrap()
        .iter()
        .all(|p| p["targets"].as_array().unwrap().len() == 3));
    let input = anim["samplers"][0]["input"].as_u64().unwrap() as usize;
    let times = &doc["accessors"][input];
    assert_eq!(times["count"].as_u64().unwrap() as usize, motion.frames.len());
    let last = (motion.frames.len() - 1) as f64 / 60.0;
    assert!((times["max"][0].as_f64().unwrap() - last).abs() < 1e-5);

    khronos_validate(&path);
    if let Some(report) = assimp_info(&path) {
        // assimp splits the body into one mesh per material and counts each mesh's bones:
        // every bone but head_end and jaw (which carry no shape) is used by some mesh.
        let bones = assimp_count(&report, "Bones:").unwrap_or(0);
        assert!(bones >= 55, "assimp reads {bones} bones:\n{report}");
        assert_eq!(assimp_count(&report, "Animations:"), Some(1), "assimp report:\n{report}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn bad_motion_and_bad_folders_are_errors_that_write_nothing() {
    let rig = Rig::default();
    let dir = out_dir("bad");
    let empty = Motion { fps: FPS, frames: vec![] };
    let err = export::write_all(&empty, &rig, None, &dir, "empty").unwrap_err();
    assert!(matches!(err, ExportError::BadMotion { .. }), "{err}");
    let mut short_face = synthetic_motion(&rig, 0.1);
    short_face.frames[3].face.pop();
    let err = export::write_all(&short_face, &rig, None, &dir, "face").unwrap_err();
    assert!(err.to_string().contains("frame 3"), "{err}");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    let missing: &Path = &dir.join("no/such/folder");
    let err = export::write_all(&synthetic_motion(&rig, 0.1), &rig, None, missing, "song").unwrap_err();
    assert!(err.to_string().contains("no/such/folder"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// pixiv's VRM Animation loader (three-vrm, `scripts/vrma-read.mjs`) reads SONG.vrma of a
/// rendered take: every humanoid bone drumsim drives, the hips' translation, the expressions,
/// the length of the motion. Runs when DRUMSIM_VRMA_READER names the script (as `.ci/run`
/// does).
#[test]
fn three_vrm_reads_the_vrm_animation() {
    let Some(script) = std::env::var_os("DRUMSIM_VRMA_READER") else {
        println!("DRUMSIM_VRMA_READER not set: skipping the three-vrm reader");
        return;
    };
    let rig = Rig::default();
    let motion = synthetic_motion(&rig, 2.0);
    let dir = out_dir("vrma");
    let paths = export::write_all(&motion, &rig, None, &dir, "take").unwrap();
    let out = std::process::Command::new("node").arg(&script).arg(&paths.vrma).output().expect("run node");
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let read: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    println!("three-vrm read: {read}");
    let rotation: Vec<&str> = read["rotation"].as_array().unwrap().iter().map(|v| v.as_str().unwrap()).collect();
    assert_eq!(rotation.len(), 53, "{rotation:?}");
    for bone in ["hips", "upperChest", "jaw", "leftThumbMetacarpal", "rightLittleDistal", "leftToes"] {
        assert!(rotation.contains(&bone), "no {bone} track");
    }
    assert_eq!(read["translation"], serde_json::json!(["hips"]));
    assert_eq!(read["preset"], serde_json::json!(["blinkLeft", "blinkRight", "aa", "blink"]));
    let frames = motion.frames.len() as f64;
    assert!((read["duration"].as_f64().unwrap() - (frames - 1.0) / motion.fps).abs() < 1e-3, "{read}");
    let hips_y = read["rest_hips"][1].as_f64().unwrap();
    assert!((hips_y - rig.bones[0].offset.z as f64).abs() < 1e-4, "{read}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `render --rig-names mixamo`: the BVH's and glb's bones go by Mixamo's names, for
/// retargeting tools; the motion JSON keeps drumsim's, and the viewer and VMC still read it.
#[test]
fn mixamo_names_in_the_bvh_and_glb() {
    let dir = out_dir("mixamo");
    let demo = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/demo/demo.mid");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .args(["render", demo, "--rig-names", "mixamo", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let glb = dir.join("demo.glb");
    let doc = glb_json(&std::fs::read(&glb).unwrap());
    let names: Vec<&str> = doc["nodes"].as_array().unwrap().iter().filter_map(|n| n["name"].as_str()).collect();
    for bone in [
        "mixamorig:Hips",
        "mixamorig:Spine2",
        "mixamorig:LeftForeArm",
        "mixamorig:RightHandIndex3",
        "mixamorig:LeftToeBase",
    ] {
        assert!(names.contains(&bone), "no {bone} in the glb");
    }
    assert!(!names.contains(&"hips"));
    let bvh = std::fs::read_to_string(dir.join("demo.bvh")).unwrap();
    assert!(bvh.contains("ROOT mixamorig:Hips") && bvh.contains("JOINT mixamorig:RightUpLeg"));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("demo.motion.json")).unwrap()).unwrap();
    assert_eq!(json["bones"][0]["name"], "hips");
    khronos_validate(&glb);
    std::fs::remove_dir_all(&dir).unwrap();
}
