//! `SONG.motion.json`: the whole-body motion at 60 fps in the kit frame (DESIGN.md 7).
//!
//! Schema (all lengths in metres, kit frame: +x the drummer's right, +y forward, +z up,
//! origin on the floor under the stool; quaternions (w, x, y, z)):
//! ```text
//! {
//!   "format": "drumsim-motion", "version": 1,
//!   "fps": 60.0,
//!   "bones": [{"name": "hips", "parent": null, "offset": [x, y, z]},    57 bones; parent is
//!             {"name": "spine", "parent": 0, "offset": [...]}, ...],    an index into this list,
//!                                                                       always smaller than the
//!                                                                       bone's own; offset is the
//!                                                                       rest-pose joint in the
//!                                                                       parent's frame
//!   "face_names": ["eyeBlinkLeft", ...],                                 the 52 ARKit names
//!   "frames": [{
//!     "t": 0.0,                                                          seconds
//!     "bones": [[px, py, pz, qw, qx, qy, qz], ...],                     world position of each
//!                                                                       bone's joint and its world
//!                                                                       rotation, in "bones" order
//!     "tips": [[x, y, z], [x, y, z]],                                   left, right stick tip
//!     "face": [...],                                                     52 weights 0..1, in
//!                                                                       "face_names" order
//!     "hihat_openness": 0.0                                              0 closed .. 1 open
//!   }, ...]
//! }
//! ```
//! A bone's world rotation is relative to the rest pose, in which every bone frame is
//! aligned with the kit (see `motion::rig`). The stick tips are the motion's own (hand target
//! plus the rotated stick), which the rig's hands meet wherever the arms reach. Numbers are
//! rounded to 10 micrometres, 1e-6 for rotations and 1e-4 for weights.

use super::{write_file, write_one, Baked, ExportError};
use crate::motion::rig::Rig;
use crate::motion::track::{Motion, ARKIT_NAMES};
use serde::Serialize;
use std::io::Write;
use std::path::Path;

/// Write the motion JSON of `motion` through `rig` to `path`.
pub fn write(motion: &Motion, rig: &Rig, path: &Path) -> Result<(), ExportError> {
    let baked = Baked::new(motion, rig)?;
    write_one(path, |partial| write_baked(&baked, partial))
}

#[derive(Serialize)]
struct BoneEntry<'a> {
    name: &'a str,
    parent: Option<usize>,
    offset: [f64; 3],
}

#[derive(Serialize)]
struct Frame {
    t: f64,
    bones: Vec<[f64; 7]>,
    tips: [[f64; 3]; 2],
    face: Vec<f64>,
    hihat_openness: f64,
}

/// `x` rounded to `1 / per_unit` (a power of ten): dividing the integer count by it gives
/// the double nearest the decimal, which prints short (0.12345, not 0.12345000000000001).
fn round(x: impl Into<f64>, per_unit: f64) -> f64 {
    let r = (x.into() * per_unit).round() / per_unit;
    if r.is_finite() {
        r
    } else {
        0.0
    }
}

/// Write already-solved motion to `path` as it is (a partial name of an output set).
pub fn write_baked(baked: &Baked, path: &Path) -> Result<(), ExportError> {
    let rig = baked.rig;
    let bones: Vec<BoneEntry> = rig
        .bones
        .iter()
        .map(|b| BoneEntry { name: &b.name, parent: b.parent, offset: b.offset.map(|x| round(x, 1e5)).into() })
        .collect();
    write_file(path, |w: &mut dyn Write| {
        write!(w, "{{\"format\":\"drumsim-motion\",\"version\":1,\"fps\":{},\"bones\":", baked.motion.fps)?;
        serde_json::to_writer(&mut *w, &bones)?;
        write!(w, ",\"face_names\":")?;
        serde_json::to_writer(&mut *w, &ARKIT_NAMES[..])?;
        write!(w, ",\"frames\":[")?;
        for (i, (frame, pose)) in baked.motion.frames.iter().zip(&baked.poses).enumerate() {
            if i > 0 {
                writeln!(w, ",")?;
            } else {
                writeln!(w)?;
            }
            let world = rig.world(pose);
            let f = Frame {
                t: round(baked.time_s(i), 1e5),
                bones: world
                    .iter()
                    .map(|(p, q)| {
                        let (p, q) = (p.map(|x| round(x, 1e5)), q.coords.map(|x| round(x, 1e6)));
                        [p.x, p.y, p.z, q.w, q.x, q.y, q.z]
                    })
                    .collect(),
                tips: frame.hands.map(|h| h.stick_tip().map(|x| round(x, 1e5))),
                face: frame.face.iter().map(|&x| round(x, 1e4)).collect(),
                hihat_openness: round(frame.hihat_openness, 1e4),
            };
            serde_json::to_writer(&mut *w, &f)?;
        }
        writeln!(w, "\n]}}")
    })
}
