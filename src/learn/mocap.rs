//! Loader for drum motion capture of the MMIP shape (60 fps frames of named joint positions and
//! quaternions, with the MIDI as a 60 fps note list), so that a user with real mocap can train
//! the hand model on it instead of (or beside) the corpus teacher.
//!
//! The schema (JSON; `assets/mocap-example.json` is a tiny example):
//! ```text
//! {
//!   "fps": 60,                                   frames per second; must be 60
//!   "joints": ["Hips", "Spine2", "Head", ...],   joint names, in the order of each frame's lists
//!   "frames": [                                  one object per frame
//!     {"positions": [[x, y, z], ...],            metres, kit frame (+x right, +y forward, +z up)
//!      "rotations": [[w, x, y, z], ...],         unit quaternions (normalised on load)
//!      "blendshapes": [52 numbers]}              optional: ARKit weights (ARKIT_NAMES order)
//!   ],
//!   "midi": {"fps": 60, "notes": [[frame, note, velocity], ...]}
//! }
//! ```
//! Joints are picked by name ([`JointNames`]; the defaults are Mixamo-style). When the stick
//! tips are present, each hand's rotation is turned (by the smallest rotation) so that its +y
//! points from the grip at the tip, and the grip is placed [`STICK_TIP_LOCAL`] behind the tip
//! along that line: the tip, which is what strikes, is kept exactly. MIDI notes must be DRUMS
//! roll notes ([`NOTE_NUMS`]) or notes the given map knows.

use super::Example;
use crate::midi::roll::{column, PianoRoll, NOTE_NUMS};
use crate::midi::NoteMap;
use crate::motion::track::hands_to_values;
use crate::motion::{Motion, MotionFrame, Pose, FPS, STICK_TIP_LOCAL};
use nalgebra::{UnitQuaternion, Vector3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

/// Which joints of the file are the six targets (and the stick tips, when there are any).
#[derive(Debug, Clone, PartialEq)]
pub struct JointNames {
    pub left_hand: String,
    pub right_hand: String,
    pub chest: String,
    pub head: String,
    pub left_foot: String,
    pub right_foot: String,
    /// Stick tips; used when the file has joints of these names.
    pub left_tip: Option<String>,
    pub right_tip: Option<String>,
}

impl Default for JointNames {
    fn default() -> Self {
        JointNames {
            left_hand: "LeftHand".into(),
            right_hand: "RightHand".into(),
            chest: "Spine2".into(),
            head: "Head".into(),
            left_foot: "LeftFoot".into(),
            right_foot: "RightFoot".into(),
            left_tip: Some("LeftStickTip".into()),
            right_tip: Some("RightStickTip".into()),
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MocapError {
    #[error("{path}: cannot read: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}: not mocap JSON of the documented shape: {message}")]
    Json { path: PathBuf, message: String },
    #[error("{path}: {what} is {fps} fps; only 60 fps is supported (resample it first)")]
    Fps { path: PathBuf, what: &'static str, fps: f64 },
    #[error("{path}: no joint named {name:?} (the file has: {available})")]
    MissingJoint { path: PathBuf, name: String, available: String },
    #[error("{path}: frame {frame}: {message}")]
    Frame { path: PathBuf, frame: usize, message: String },
    #[error("{path}: midi note {index} ([{frame}, {note}, ...]): {message}")]
    Note { path: PathBuf, index: usize, frame: i64, note: i64, message: String },
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    fps: f64,
    joints: Vec<String>,
    frames: Vec<RawFrame>,
    midi: RawMidi,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFrame {
    positions: Vec<[f64; 3]>,
    rotations: Vec<[f64; 4]>,
    #[serde(default)]
    blendshapes: Option<Vec<f64>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMidi {
    fps: f64,
    notes: Vec<[i64; 3]>,
}

/// A loaded take: its motion and its piano roll, frame for frame.
#[derive(Debug, Clone)]
pub struct MocapTake {
    pub motion: Motion,
    pub roll: PianoRoll,
}

impl MocapTake {
    /// The take as a training example for the hand model.
    pub fn example(&self, id: &str) -> Example {
        Example {
            id: id.to_string(),
            roll: self.roll.frames.iter().map(|f| f.map(|b| if b { 1.0 } else { 0.0 })).collect(),
            hands: self.motion.frames.iter().map(|f| hands_to_values(&f.hands)).collect(),
        }
    }
}

/// Load a mocap file. `map` translates MIDI notes that are not DRUMS roll notes (None: they
/// are errors).
pub fn load_mocap(path: &Path, names: &JointNames, map: Option<&NoteMap>) -> Result<MocapTake, MocapError> {
    let text = crate::files::read_to_string_bounded(path, crate::files::MAX_DATA_BYTES)
        .map_err(|source| MocapError::Read { path: path.to_path_buf(), source })?;
    parse_mocap(&text, path, names, map)
}

/// Parse mocap JSON; `path` is only used in messages.
pub fn parse_mocap(
    text: &str,
    path: &Path,
    names: &JointNames,
    map: Option<&NoteMap>,
) -> Result<MocapTake, MocapError> {
    let raw: RawFile = serde_json::from_str(text)
        .map_err(|e| MocapError::Json { path: path.to_path_buf(), message: e.to_string() })?;
    for (what, fps) in [("the motion", raw.fps), ("the midi", raw.midi.fps)] {
        if (fps - FPS).abs() > 1e-6 {
            return Err(MocapError::Fps { path: path.to_path_buf(), what, fps });
        }
    }
    let find = |name: &str| {
        raw.joints.iter().position(|j| j == name).ok_or_else(|| MocapError::MissingJoint {
            path: path.to_path_buf(),
            name: name.to_string(),
            available: raw.joints.join(", "),
        })
    };
    let [lh, rh, chest, head, lf, rf] =
        [&names.left_hand, &names.right_hand, &names.chest, &names.head, &names.left_foot, &names.right_foot]
            .map(|n| find(n));
    let (lh, rh, chest, head, lf, rf) = (lh?, rh?, chest?, head?, lf?, rf?);
    let tip = |n: &Option<String>| n.as_ref().and_then(|n| raw.joints.iter().position(|j| j == n));
    let tips = [tip(&names.left_tip), tip(&names.right_tip)];
    let mut frames = Vec::with_capacity(raw.frames.len());
    for (f, fr) in raw.frames.iter().enumerate() {
        let err = |message: String| MocapError::Frame { path: path.to_path_buf(), frame: f, message };
        if fr.positions.len() != raw.joints.len() || fr.rotations.len() != raw.joints.len() {
            return Err(err(format!(
                "{} positions and {} rotations for {} joints",
                fr.positions.len(),
                fr.rotations.len(),
                raw.joints.len()
            )));
        }
        let pose = |j: usize| -> Result<Pose, MocapError> {
            let (p, q) = (fr.positions[j], fr.rotations[j]);
            if p.iter().chain(q.iter()).any(|x| !x.is_finite()) {
                return Err(err(format!("joint {:?} is not finite", raw.joints[j])));
            }
            let n = q.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n < 1e-6 {
                return Err(err(format!("joint {:?} has a zero quaternion", raw.joints[j])));
            }
            Ok(Pose { pos: p.map(|x| x as f32), rot: q.map(|x| (x / n) as f32) })
        };
        let mut hands = [pose(lh)?, pose(rh)?];
        for (side, t) in tips.iter().enumerate() {
            if let Some(t) = *t {
                hands[side] = aim_at_tip(hands[side], pose(t)?.pos);
            }
        }
        let face = match &fr.blendshapes {
            None => vec![0.0; 52],
            Some(b) if b.len() == 52 && b.iter().all(|x| x.is_finite()) => b.iter().map(|&x| x as f32).collect(),
            Some(b) => return Err(err(format!("{} blendshape weights (finite), expected 52", b.len()))),
        };
        frames.push(MotionFrame {
            hands,
            chest: pose(chest)?,
            head: pose(head)?,
            feet: [pose(lf)?, pose(rf)?],
            face,
            hihat_openness: 0.0,
        });
    }
    let mut roll = PianoRoll { frames: vec![[false; 16]; frames.len()] };
    for (index, &[frame, note, velocity]) in raw.midi.notes.iter().enumerate() {
        let err = |message: String| MocapError::Note { path: path.to_path_buf(), index, frame, note, message };
        if frame < 0 || frame as usize >= frames.len() {
            return Err(err(format!("frame outside the take's {} frames", frames.len())));
        }
        if !(0..=127).contains(&note) || !(0..=127).contains(&velocity) {
            return Err(err("note and velocity must be 0..=127".into()));
        }
        if velocity == 0 {
            continue;
        }
        let roll_note = if NOTE_NUMS.contains(&(note as u8)) {
            Some(note as u8)
        } else {
            map.and_then(|m| m.entry(note as u8)).map(|e| e.roll)
        };
        let col =
            roll_note.and_then(column).ok_or_else(|| err("neither a DRUMS roll note nor known to the map".into()))?;
        roll.frames[frame as usize][col] = true;
    }
    Ok(MocapTake { motion: Motion { fps: FPS, frames }, roll })
}

/// Turn a hand so that its +y (the stick) points at `tip`, by the smallest rotation, and put the
/// grip [`STICK_TIP_LOCAL`] behind the tip.
fn aim_at_tip(hand: Pose, tip: [f32; 3]) -> Pose {
    let q = hand.rotation();
    let current = q * Vector3::y();
    let want = Vector3::from(tip) - Vector3::from(hand.pos);
    if want.norm() < 1e-6 {
        return hand;
    }
    let turn = UnitQuaternion::rotation_between(&current, &want).unwrap_or_else(|| {
        // Opposite directions: half a turn about the hand's x.
        UnitQuaternion::from_axis_angle(&(q * Vector3::x_axis()), std::f32::consts::PI)
    });
    let r = turn * q;
    let stick = r * Vector3::from(STICK_TIP_LOCAL);
    Pose { pos: [tip[0] - stick.x, tip[1] - stick.y, tip[2] - stick.z], rot: [r.w, r.i, r.j, r.k] }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn doc(fps: f64, pos_x: &str, extra_joint: bool) -> String {
        let joints = r#"["LeftHand","RightHand","Spine2","Head","LeftFoot","RightFoot""#.to_string()
            + if extra_joint { r#","RightStickTip"]"# } else { "]" };
        let n = if extra_joint { 7 } else { 6 };
        let p = vec![format!("[{pos_x}, 0.1, 0.9]"); n].join(",");
        let q = vec!["[1, 0, 0, 0]"; n].join(",");
        format!(
            r#"{{"fps": {fps}, "joints": {joints}, "frames": [{{"positions": [{p}], "rotations": [{q}]}},
               {{"positions": [{p}], "rotations": [{q}]}}], "midi": {{"fps": 60, "notes": [[1, 38, 90], [0, 36, 0]]}}}}"#
        )
    }

    #[test]
    fn errors_name_the_file_and_the_fault() {
        let names = JointNames::default();
        let p = Path::new("take.json");
        let e = parse_mocap(&doc(30.0, "0.0", false), p, &names, None).unwrap_err().to_string();
        assert!(e.contains("take.json") && e.contains("30 fps"), "{e}");
        let mut other = names.clone();
        other.chest = "Chest".into();
        let e = parse_mocap(&doc(60.0, "0.0", false), p, &other, None).unwrap_err().to_string();
        assert!(e.contains("\"Chest\"") && e.contains("Spine2"), "{e}");
        let e = parse_mocap(&doc(60.0, "NaN", false), p, &names, None).unwrap_err().to_string();
        assert!(e.contains("take.json") && e.contains("not mocap JSON"), "{e}");
        let bad_note = doc(60.0, "0.0", false).replace("[1, 38, 90]", "[5, 38, 90]");
        let e = parse_mocap(&bad_note, p, &names, None).unwrap_err().to_string();
        assert!(e.contains("midi note 0") && e.contains("outside"), "{e}");
    }

    #[test]
    fn stick_tips_aim_the_hands_and_are_kept_exactly() {
        let text = doc(60.0, "0.0", true).replacen("[0.0, 0.1, 0.9]]", "[0.3, 0.1, 0.7]]", 2);
        let t = parse_mocap(&text, Path::new("t.json"), &JointNames::default(), None).unwrap();
        let tip = t.motion.frames[0].hands[1].stick_tip();
        assert!((tip[0] - 0.3).abs() < 1e-5 && (tip[1] - 0.1).abs() < 1e-5 && (tip[2] - 0.7).abs() < 1e-5, "{tip:?}");
        assert!(t.roll.frames[1][column(38).unwrap()]);
        assert_eq!(t.roll.onsets(column(36).unwrap()), 0, "velocity 0 is no onset");
    }
}
