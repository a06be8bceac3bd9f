//! Motion out to files, through the rig and the whole-body IK: `SONG.motion.json` (the
//! project's own format, kit frame), `SONG.bvh` and `SONG.glb` (Y-up, for animation tools
//! and game engines) and `SONG.vrma` (a VRM Animation, for any VRM 1.0 model).
//!
//! Every file is written under a partial name in the same folder and moved into place with
//! the rest of its set ([`crate::outputs::OutputSet`]), so a failure never leaves a
//! half-written file, or a mix of new and old files, under the final names.
//!
//! BVH and glTF are Y-up: a kit point (x, y, z) becomes (-x, z, y), so +Y is up, the drummer
//! faces +Z and their left is +X (the CMU / glTF convention); a rotation keeps its w and
//! maps its vector part the same way.

pub mod bvh;
pub mod gltf;
pub mod json;
pub mod scene;
pub mod shapes;
pub mod vrma;

use super::body_ik;
use super::rig::{BodyPose, Rig, RigNames};
use super::track::Motion;
use crate::kit::Kit;
use crate::outputs::OutputSet;
use nalgebra::{UnitQuaternion, Vector3};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Why an export failed; the message names the file or the frame at fault.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExportError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("motion: {reason}")]
    BadMotion { reason: String },
}

/// The files [`write_all`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Paths {
    pub json: PathBuf,
    pub bvh: PathBuf,
    pub glb: PathBuf,
    pub vrma: PathBuf,
}

/// Write `DIR/SONG.motion.json`, `DIR/SONG.bvh`, `DIR/SONG.glb` (with `kit` in it, when
/// given) and `DIR/SONG.vrma`, solving the IK once, and publish the four together.
pub fn write_all(motion: &Motion, rig: &Rig, kit: Option<&Kit>, dir: &Path, song: &str) -> Result<Paths, ExportError> {
    let mut set = OutputSet::new();
    let paths = stage_all(motion, rig, kit, dir, song, &mut set)?;
    set.publish().map_err(|e| ExportError::Io { path: e.target, source: e.source })?;
    Ok(paths)
}

/// Write the four files of [`write_all`] under partial names of `set`, for the caller to
/// publish with the rest of its outputs.
pub fn stage_all(
    motion: &Motion,
    rig: &Rig,
    kit: Option<&Kit>,
    dir: &Path,
    song: &str,
    set: &mut OutputSet,
) -> Result<Paths, ExportError> {
    stage_all_named(motion, rig, kit, RigNames::Drumsim, dir, song, set)
}

/// [`stage_all`] with the BVH's and glTF's bones named the `names` way (SONG.motion.json
/// keeps drumsim's names; SONG.vrma has VRM's).
pub fn stage_all_named(
    motion: &Motion,
    rig: &Rig,
    kit: Option<&Kit>,
    names: RigNames,
    dir: &Path,
    song: &str,
    set: &mut OutputSet,
) -> Result<Paths, ExportError> {
    let mut baked = Baked::in_kit(motion, rig, kit)?;
    baked.names = rig.named(names).bones.into_iter().map(|b| b.name).collect();
    let paths = Paths {
        json: dir.join(format!("{song}.motion.json")),
        bvh: dir.join(format!("{song}.bvh")),
        glb: dir.join(format!("{song}.glb")),
        vrma: dir.join(format!("{song}.vrma")),
    };
    gltf::write_baked(&baked, &set.stage(&paths.glb)).map_err(|e| e.for_target(&paths.glb))?;
    bvh::write_baked(&baked, &set.stage(&paths.bvh)).map_err(|e| e.for_target(&paths.bvh))?;
    json::write_baked(&baked, &set.stage(&paths.json)).map_err(|e| e.for_target(&paths.json))?;
    vrma::write_baked(&baked, &set.stage(&paths.vrma)).map_err(|e| e.for_target(&paths.vrma))?;
    Ok(paths)
}

impl ExportError {
    /// An I/O error on a partial file, told under the name the user asked for.
    fn for_target(self, target: &Path) -> ExportError {
        match self {
            ExportError::Io { source, .. } => ExportError::Io { path: target.to_path_buf(), source },
            other => other,
        }
    }

    /// True for a failure of the disk or the folder (exit 1), false for bad motion (exit 2).
    pub fn is_io(&self) -> bool {
        matches!(self, ExportError::Io { .. })
    }
}

/// Write one file alone, atomically: a partial name, then moved into place.
fn write_one(path: &Path, write: impl FnOnce(&Path) -> Result<(), ExportError>) -> Result<(), ExportError> {
    let mut set = OutputSet::new();
    write(&set.stage(path)).map_err(|e| e.for_target(path))?;
    set.publish().map_err(|e| ExportError::Io { path: path.to_path_buf(), source: e.source })
}

/// A checked motion with its body poses solved.
pub struct Baked<'a> {
    pub motion: &'a Motion,
    pub rig: &'a Rig,
    pub poses: Vec<BodyPose>,
    /// The kit to put in the glTF scene beside the drummer (none: the drummer alone).
    pub kit: Option<&'a Kit>,
    /// The names of the bones in the BVH and glTF (the rig's own unless renamed; the motion
    /// JSON and the VRM Animation always use the rig's).
    pub names: Vec<String>,
}

impl<'a> Baked<'a> {
    /// Check the motion (a positive finite frame rate, at least one frame, 52 face weights
    /// per frame) and solve every frame's pose.
    pub fn new(motion: &'a Motion, rig: &'a Rig) -> Result<Baked<'a>, ExportError> {
        Baked::in_kit(motion, rig, None)
    }

    /// [`Self::new`] beside `kit`: the knees are kept out of its drums, and the glTF scene
    /// shows it.
    pub fn in_kit(motion: &'a Motion, rig: &'a Rig, kit: Option<&'a Kit>) -> Result<Baked<'a>, ExportError> {
        let bad = |reason: String| Err(ExportError::BadMotion { reason });
        if !(motion.fps.is_finite() && motion.fps > 0.0) {
            return bad(format!("fps = {} is not a positive number", motion.fps));
        }
        if motion.frames.is_empty() {
            return bad("no frames to export".into());
        }
        for (i, f) in motion.frames.iter().enumerate() {
            if f.face.len() != super::ARKIT_NAMES.len() {
                return bad(format!("frame {i}: {} face weights, expected {}", f.face.len(), super::ARKIT_NAMES.len()));
            }
        }
        let names = rig.bones.iter().map(|b| b.name.clone()).collect();
        let shells = kit.map(super::shells::shells).unwrap_or_default();
        Ok(Baked { motion, rig, poses: body_ik::solve_motion_in(rig, motion, &shells), kit, names })
    }

    /// Time of frame `i`, s.
    pub fn time_s(&self, i: usize) -> f64 {
        i as f64 / self.motion.fps
    }
}

/// A kit-frame point in the Y-up frame of BVH and glTF.
pub fn y_up(v: Vector3<f32>) -> [f32; 3] {
    [-v.x, v.z, v.y]
}

/// A kit-frame rotation in the Y-up frame, as (w, x, y, z).
pub fn y_up_rot(q: &UnitQuaternion<f32>) -> [f32; 4] {
    [q.w, -q.i, q.k, q.j]
}

/// Create `path`, fill it with `fill`, flush and sync it; on any error the file is removed.
/// `path` is a partial name of an output set.
pub fn write_file(path: &Path, fill: impl FnOnce(&mut dyn Write) -> std::io::Result<()>) -> Result<(), ExportError> {
    let result = (|| {
        let file = std::fs::File::create(path)?;
        let mut w = std::io::BufWriter::new(file);
        fill(&mut w)?;
        let file = w.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(path);
    }
    result.map_err(|source| ExportError::Io { path: path.to_path_buf(), source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn y_up_maps_rotations_like_points() {
        let q = UnitQuaternion::from_euler_angles(0.3, -0.7, 1.1);
        let v = Vector3::new(0.2, -0.5, 0.9);
        let [w, x, y, z] = y_up_rot(&q);
        let q2 = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        let a = Vector3::from(y_up(q * v));
        let b = q2 * Vector3::from(y_up(v));
        assert!((a - b).norm() < 1e-6, "{a} {b}");
    }

    #[test]
    fn a_failed_write_leaves_no_file() {
        let dir = std::env::temp_dir().join(format!("drumsim-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("x.json");
        let err = write_one(&path, |partial| {
            write_file(partial, |w: &mut dyn Write| {
                w.write_all(b"{\"half\":")?;
                Err(std::io::Error::other("disk full"))
            })
        });
        assert!(err.as_ref().unwrap_err().to_string().starts_with(&path.display().to_string()), "{err:?}");
        assert!(matches!(err, Err(ExportError::Io { .. })));
        assert!(!path.exists());
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "temporary file left behind");
        write_one(&path, |partial| write_file(partial, |w: &mut dyn Write| w.write_all(b"{}"))).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "{}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
