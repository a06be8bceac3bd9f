//! VMC protocol output received by a real VMC receiver: `scripts/vmc-receive.py` on
//! python-osc, over UDP on 127.0.0.1. A Groove MIDI take rendered with `--vmc` is played back
//! in real time; the receiver must get 60 frames a second of the 55 Unity humanoid bones, the
//! 52 perfect-sync blendshapes, OK and T, and a Unity humanoid rig built from what it received
//! (T-pose offsets, local rotations, parents by Unity's own hierarchy) must put every joint
//! where drumsim's motion file has it, and turn every bone as drumsim's within 1 degree.
//!
//! python-osc is needed: `scripts/setup-debian.sh` installs it into /opt/drumsim-python.
//! Without it the receiving test says so and passes, unless DRUMSIM_REQUIRE_PYTHON_OSC=1
//! (CI sets it).

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde_json::Value;
use std::path::PathBuf;
use std::process::Command;
use vmc_receiver::{finish_receiver, python_osc, start_receiver};

mod vmc_receiver;

const TAKE: &str = "data/gmd/drummer3/session1/39_jazz_120_beat_4-4.mid";

fn drumsim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_drumsim"))
}

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("vmc-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Unity's humanoid hierarchy (HumanBodyBones), as a receiver knows it, and the drumsim bone
/// whose joint each one's joint is.
fn unity_bones() -> Vec<(String, Option<String>, String)> {
    let mut v: Vec<(String, Option<String>, String)> = Vec::new();
    let mut add = |u: &str, parent: Option<&str>, d: &str| v.push((u.into(), parent.map(Into::into), d.into()));
    add("Hips", None, "hips");
    add("Spine", Some("Hips"), "spine");
    add("Chest", Some("Spine"), "spine1");
    add("UpperChest", Some("Chest"), "spine2");
    add("Neck", Some("UpperChest"), "neck");
    add("Head", Some("Neck"), "head");
    add("Jaw", Some("Head"), "jaw");
    add("LeftEye", Some("Head"), "left_eye");
    add("RightEye", Some("Head"), "right_eye");
    for (side, s) in [("Left", "left"), ("Right", "right")] {
        add(&format!("{side}Shoulder"), Some("UpperChest"), &format!("{s}_shoulder"));
        add(&format!("{side}UpperArm"), Some(&format!("{side}Shoulder")), &format!("{s}_arm"));
        add(&format!("{side}LowerArm"), Some(&format!("{side}UpperArm")), &format!("{s}_forearm"));
        add(&format!("{side}Hand"), Some(&format!("{side}LowerArm")), &format!("{s}_hand"));
        for (u, d) in
            [("Thumb", "thumb"), ("Index", "index"), ("Middle", "middle"), ("Ring", "ring"), ("Little", "pinky")]
        {
            let mut parent = format!("{side}Hand");
            for (k, p) in ["Proximal", "Intermediate", "Distal"].iter().enumerate() {
                let name = format!("{side}{u}{p}");
                add(&name, Some(&parent), &format!("{s}_{d}{}", k + 1));
                parent = name;
            }
        }
        add(&format!("{side}UpperLeg"), Some("Hips"), &format!("{s}_upper_leg"));
        add(&format!("{side}LowerLeg"), Some(&format!("{side}UpperLeg")), &format!("{s}_leg"));
        add(&format!("{side}Foot"), Some(&format!("{side}LowerLeg")), &format!("{s}_foot"));
        add(&format!("{side}Toes"), Some(&format!("{side}Foot")), &format!("{s}_toe"));
    }
    v
}

fn quat(v: &[f64]) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(v[3], v[0], v[1], v[2]))
}

fn vec3(v: &[f64]) -> Vector3<f64> {
    Vector3::new(v[0], v[1], v[2])
}

/// A kit-frame point in Unity's frame (x right, y up, z forward).
fn unity(v: Vector3<f64>) -> Vector3<f64> {
    Vector3::new(v.x, v.z, v.y)
}

/// A kit-frame rotation in Unity's (a reflection: w kept, vector part (-x, -z, -y)).
fn unity_rot(q: &UnitQuaternion<f64>) -> UnitQuaternion<f64> {
    UnitQuaternion::from_quaternion(Quaternion::new(q.w, -q.i, -q.k, -q.j))
}

#[test]
fn a_render_played_to_a_vmc_receiver_reproduces_the_drummer() {
    let Some(python) = python_osc() else { return };
    let dir = out_dir("render");
    let received = dir.join("received.json");
    let (receiver, port) = start_receiver(&python, &received);
    let out = drumsim()
        .args(["render", TAKE, "--sound", "direct", "--out"])
        .arg(&dir)
        .args(["--vmc", &format!("127.0.0.1:{port}")])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(stderr.contains("0 sends failed"), "{stderr}");
    let got = finish_receiver(receiver, &received);
    assert!(got.unknown.is_empty(), "addresses outside VMC: {:?}", got.unknown);

    let motion: Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("39_jazz_120_beat_4-4.motion.json")).unwrap()).unwrap();
    let fps = motion["fps"].as_f64().unwrap();
    let frames = motion["frames"].as_array().unwrap();
    let names: Vec<&str> = motion["bones"].as_array().unwrap().iter().map(|b| b["name"].as_str().unwrap()).collect();
    let face_names: Vec<String> = motion["face_names"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| {
            let n = n.as_str().unwrap();
            n[..1].to_uppercase() + &n[1..]
        })
        .collect();

    // Every frame, at 60 a second, in order.
    let n = got.frames.len();
    let expected = (frames.len() as f64 / fps * 60.0).round() as usize;
    assert_eq!(n, expected, "frames received");
    let span = got.frames[n - 1]["arrival_s"].as_f64().unwrap() - got.frames[0]["arrival_s"].as_f64().unwrap();
    let rate = (n - 1) as f64 / span;
    assert!((59.0..=61.0).contains(&rate), "{rate:.2} frames per second over {span:.2} s");
    let mut last_t = -1.0;
    let bones = unity_bones();
    let index = |d: &str| names.iter().position(|n| *n == d).unwrap();
    let (mut worst_deg, mut worst_mm) = (0.0f64, 0.0f64);
    let mut worst_bone = String::new();
    for f in &got.frames {
        let t = f["t"].as_f64().unwrap();
        assert!(t > last_t, "T goes back: {t} after {last_t}");
        last_t = t;
        assert_eq!(f["ok"].as_i64(), Some(1));
        assert!(f["applied"].as_bool().unwrap(), "no Blend/Apply");
        assert_eq!(f["bones"].as_object().unwrap().len(), 55);
        let blend = f["blend"].as_object().unwrap();
        assert_eq!(blend.len(), 52);
        assert!(face_names.iter().all(|n| blend.contains_key(n)), "{:?}", blend.keys().collect::<Vec<_>>());
        let root = f["root"].as_array().unwrap().iter().map(|v| v.as_f64().unwrap()).collect::<Vec<_>>();
        assert_eq!(root, vec![0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0], "the root stays at the origin");

        // The drumsim frame this one shows: T is the song's time.
        let k = ((t * fps).round() as usize).min(frames.len() - 1);
        let drum = frames[k]["bones"].as_array().unwrap();
        let drum_bone = |d: &str| -> (Vector3<f64>, UnitQuaternion<f64>) {
            let v: Vec<f64> = drum[index(d)].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            (
                unity(vec3(&v[0..3])),
                unity_rot(&UnitQuaternion::from_quaternion(Quaternion::new(v[3], v[4], v[5], v[6]))),
            )
        };
        // The receiver's rig: forward kinematics from what arrived.
        let mut world: std::collections::HashMap<&str, (Vector3<f64>, UnitQuaternion<f64>)> = Default::default();
        for (name, parent, d) in &bones {
            let v: Vec<f64> = f["bones"][name].as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect();
            let (p, q) = (vec3(&v[0..3]), quat(&v[3..7]));
            let w = match parent {
                None => (p, q),
                Some(parent) => {
                    let (pp, pq) = world[parent.as_str()];
                    (pp + pq * p, pq * q)
                }
            };
            world.insert(name.as_str(), w);
            // The joint is where drumsim's is.
            let (dp, dq) = drum_bone(d);
            let mm = (w.0 - dp).norm() * 1e3;
            if mm > worst_mm {
                worst_mm = mm;
            }
            // The bone turned as drumsim's: drumsim's rest is the T-pose with the arms lowered
            // 90 degrees about the forward axis (Unity's +z; -90 degrees for the left arm).
            let arm = ["UpperArm", "LowerArm", "Hand", "Thumb", "Index", "Middle", "Ring", "Little"]
                .iter()
                .any(|a| name.contains(a));
            let lowered = match (arm, name.starts_with("Left")) {
                (false, _) => UnitQuaternion::identity(),
                (true, left) => UnitQuaternion::from_axis_angle(
                    &Vector3::z_axis(),
                    if left { 1.0 } else { -1.0 } * std::f64::consts::FRAC_PI_2,
                ),
            };
            let deg = (w.1).angle_to(&(dq * lowered)).to_degrees();
            // Neck turns half way to drumsim's neck1 (it has no Unity bone); Head is exact.
            if name != "Neck" && deg > worst_deg {
                worst_deg = deg;
                worst_bone = format!("{name} at t = {t:.3} s");
            }
        }
    }
    assert!(worst_deg <= 1.0, "{worst_bone} turned {worst_deg:.3} degrees off drumsim's");
    assert!(worst_mm <= 3.0, "a joint {worst_mm:.2} mm from drumsim's");
    eprintln!(
        "vmc: {n} frames at {rate:.2} per second, {} messages; worst bone {worst_deg:.4} degrees ({worst_bone}), worst joint {worst_mm:.2} mm",
        got.messages
    );
}

#[test]
fn bad_vmc_targets_and_renders_are_refused_before_any_work() {
    let dir = out_dir("bad");
    let out = drumsim()
        .args(["render", TAKE, "--out"])
        .arg(&dir)
        .args(["--vmc", "no-such-host.invalid:39539"])
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("--vmc no-such-host.invalid:39539") && stderr.contains("does not resolve"), "{stderr}");
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "a refused render wrote files");
    for (args, says) in [
        (vec!["--vmc", "127.0.0.1:99999"], "not a port"),
        (vec!["--vmc", "127.0.0.1", "--vmc-parts", "arms,tail"], "\"tail\""),
        (vec!["--vmc", "127.0.0.1", "--no-motion"], "--vmc plays the render's motion"),
    ] {
        let out = drumsim().args(["render", TAKE, "--out"]).arg(&dir).args(&args).output().unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
    // `drumsim vmc` on a render without motion, and on a corrupt motion file.
    let out = drumsim().arg("vmc").arg(dir.join("nothing")).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("nothing.motion.json: missing"), "{stderr}");
    std::fs::write(dir.join("cut.motion.json"), b"{\"format\":\"drumsim-motion\",\"fps\":60,\"bo").unwrap();
    let out = drumsim().arg("vmc").arg(dir.join("cut")).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("cut.motion.json: not a drumsim motion file"), "{stderr}");
}
