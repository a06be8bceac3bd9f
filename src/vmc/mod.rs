//! The drummer as a VMC protocol performer: OSC over UDP at a fixed 60 Hz to VSeeFace,
//! Warudo, VNyan, Unity (EVMC4U), Unreal (VRM4U) or Blender (VMC4B), which show it on their
//! own avatar. `render --vmc HOST:PORT` plays a render back in real time; `drumsim vmc
//! OUT/SONG` plays one already rendered.
//!
//! `motion::humanoid` maps the rig to Unity's humanoid bones and T-pose, `packets.rs` encodes
//! a frame, `sender.rs` paces the frames to the wall clock and sends them.

pub mod packets;
pub mod sender;

use crate::motion::humanoid::{Group, Humanoid};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use packets::{Content, Encoder, Packing};
use sender::{Pacer, Sender};
use serde::Deserialize;
use std::net::{SocketAddr, ToSocketAddrs};
use std::path::{Path, PathBuf};

/// The port VMC receivers (marionettes) listen on by default.
pub const DEFAULT_PORT: u16 = 39539;
/// Frames per second sent.
pub const RATE_HZ: f64 = 60.0;

/// Why VMC output cannot start; the message names the target, option or file.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VmcError {
    #[error("--vmc {target}: {reason}")]
    Target { target: String, reason: String },
    #[error("--vmc-parts {0:?}: not a part (torso, head, arms, fingers, legs, face, all)")]
    Part(String),
    #[error("{path}: {reason}")]
    Motion { path: PathBuf, reason: String },
    #[error("VMC socket: {0}")]
    Socket(std::io::Error),
}

impl VmcError {
    /// True for a failure of the machine (exit 1), false for bad input (exit 2).
    pub fn is_io(&self) -> bool {
        matches!(self, VmcError::Socket(_))
    }
}

/// Where and how to send.
#[derive(Debug, Clone, PartialEq)]
pub struct VmcOptions {
    pub target: SocketAddr,
    pub packing: Packing,
    pub content: Content,
}

/// Resolve `HOST[:PORT]` (the port defaults to 39539; `[::1]:39539` for IPv6).
pub fn parse_target(text: &str) -> Result<SocketAddr, VmcError> {
    let bad = |reason: String| VmcError::Target { target: text.to_string(), reason };
    let (host, port) = match text.rsplit_once(':') {
        // "[::1]" alone: the colon is the address's.
        _ if text.starts_with('[') && text.ends_with(']') => (&text[1..text.len() - 1], DEFAULT_PORT),
        Some((h, p)) if !h.is_empty() && (!h.contains(':') || h.starts_with('[')) => {
            let port: u16 = p.parse().map_err(|_| bad(format!("{p:?} is not a port (1-65535)")))?;
            (h.trim_start_matches('[').trim_end_matches(']'), port)
        }
        _ => (text.trim_start_matches('[').trim_end_matches(']'), DEFAULT_PORT),
    };
    if host.is_empty() || port == 0 {
        return Err(bad("give HOST or HOST:PORT (port 1-65535), e.g. 127.0.0.1:39539".into()));
    }
    let mut addrs = (host, port).to_socket_addrs().map_err(|e| bad(format!("host {host:?} does not resolve ({e})")))?;
    addrs.next().ok_or_else(|| bad(format!("host {host:?} has no address")))
}

/// Parse `--vmc-parts`: a comma-separated list of torso, head, arms, fingers, legs, face, or
/// all.
pub fn parse_parts(text: &str) -> Result<(Vec<Group>, bool), VmcError> {
    let mut groups = Vec::new();
    let mut face = false;
    for part in text.split(',').map(str::trim) {
        match part {
            "all" => {
                groups.extend([Group::Torso, Group::Head, Group::Arms, Group::Fingers, Group::Legs]);
                face = true;
            }
            "torso" => groups.push(Group::Torso),
            "head" => groups.push(Group::Head),
            "arms" => groups.push(Group::Arms),
            "fingers" => groups.push(Group::Fingers),
            "legs" => groups.push(Group::Legs),
            "face" => face = true,
            other => return Err(VmcError::Part(other.to_string())),
        }
    }
    groups.dedup();
    Ok((groups, face))
}

/// A render's motion as VMC needs it: the rig and every frame's bones and face.
pub struct MotionFile {
    pub fps: f64,
    pub humanoid: Humanoid,
    /// Per frame: the hips joint (kit frame) and each drumsim bone's world rotation.
    pub frames: Vec<(Vector3<f32>, Vec<UnitQuaternion<f32>>)>,
    /// Per frame: the 52 ARKit weights.
    pub face: Vec<Vec<f32>>,
}

#[derive(Deserialize)]
struct RawMotion {
    fps: f64,
    bones: Vec<RawBone>,
    face_names: Vec<String>,
    frames: Vec<RawFrame>,
}

#[derive(Deserialize)]
struct RawBone {
    name: String,
    parent: Option<usize>,
    offset: [f32; 3],
}

#[derive(Deserialize)]
struct RawFrame {
    bones: Vec<[f32; 7]>,
    face: Vec<f32>,
}

impl MotionFile {
    /// Read `SONG.motion.json` (the schema of `motion::export::json`).
    pub fn read(path: &Path) -> Result<MotionFile, VmcError> {
        let bad = |reason: String| VmcError::Motion { path: path.to_path_buf(), reason };
        let text = crate::files::read_to_string_bounded(path, 1 << 30).map_err(|e| bad(e.to_string()))?;
        let raw: RawMotion = serde_json::from_str(&text).map_err(|e| bad(format!("not a drumsim motion file: {e}")))?;
        if !(raw.fps.is_finite() && raw.fps > 0.0) || raw.frames.is_empty() {
            return Err(bad(format!("fps {} and {} frames: nothing to play", raw.fps, raw.frames.len())));
        }
        if raw.face_names.as_slice() != crate::motion::ARKIT_NAMES {
            return Err(bad("face_names are not the 52 ARKit names in drumsim's order".into()));
        }
        let names: Vec<String> = raw.bones.iter().map(|b| b.name.clone()).collect();
        let parents: Vec<Option<usize>> = raw.bones.iter().map(|b| b.parent).collect();
        let offsets: Vec<Vector3<f32>> = raw.bones.iter().map(|b| Vector3::from(b.offset)).collect();
        let humanoid = Humanoid::new(&names, &parents, &offsets).map_err(|e| bad(e.to_string()))?;
        let hips = names.iter().position(|n| n == "hips").unwrap_or(0);
        let mut frames = Vec::with_capacity(raw.frames.len());
        let mut face = Vec::with_capacity(raw.frames.len());
        for (i, f) in raw.frames.into_iter().enumerate() {
            if f.bones.len() != names.len() || f.face.len() != 52 {
                return Err(bad(format!(
                    "frame {i}: {} bones and {} face weights, expected {} and 52",
                    f.bones.len(),
                    f.face.len(),
                    names.len()
                )));
            }
            if f.bones.iter().flatten().chain(&f.face).any(|v| !v.is_finite()) {
                return Err(bad(format!("frame {i}: a number that is not finite")));
            }
            if let Some(b) = f.bones.iter().position(|b| (b[3] * b[3] + b[4] * b[4] + b[5] * b[5] + b[6] * b[6]) < 0.25)
            {
                return Err(bad(format!("frame {i}: bone {b}'s rotation is not a unit quaternion")));
            }
            let rot = f
                .bones
                .iter()
                .map(|b| UnitQuaternion::from_quaternion(Quaternion::new(b[3], b[4], b[5], b[6])))
                .collect();
            let h = f.bones[hips];
            frames.push((Vector3::new(h[0], h[1], h[2]), rot));
            face.push(f.face);
        }
        Ok(MotionFile { fps: raw.fps, humanoid, frames, face })
    }

    /// Length, s.
    pub fn duration_s(&self) -> f64 {
        self.frames.len() as f64 / self.fps
    }
}

/// What a playback sent.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayReport {
    pub frames: u64,
    pub datagrams: u64,
    /// Frames skipped because the sender fell more than a frame behind the clock.
    pub late: u64,
    pub failed_sends: u64,
    pub first_error: Option<String>,
    pub seconds: f64,
}

impl std::fmt::Display for PlayReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "vmc: sent {} frames ({} datagrams) in {:.1} s, {} skipped as late, {} sends failed",
            self.frames, self.datagrams, self.seconds, self.late, self.failed_sends
        )?;
        if let Some(e) = &self.first_error {
            write!(f, " (first: {e})")?;
        }
        Ok(())
    }
}

/// The motion file of a render named by `path` (`OUT/SONG` or one of its files).
pub fn motion_path(path: &Path) -> PathBuf {
    let text = path.to_string_lossy();
    let stem = [".contacts.json", ".motion.json", ".wav", ".glb", ".bvh", ".vrma", ".mp4", ".mid"]
        .iter()
        .find_map(|e| text.strip_suffix(e))
        .unwrap_or(&text)
        .to_string();
    PathBuf::from(format!("{stem}.motion.json"))
}

/// Play a render's motion to a VMC receiver in real time, 60 frames a second.
pub fn play_render(path: &Path, opts: &VmcOptions, progress: bool) -> Result<PlayReport, VmcError> {
    let file = motion_path(path);
    if !file.is_file() {
        return Err(VmcError::Motion {
            path: file,
            reason: "missing; render it with `drumsim render SONG.mid --out DIR` (without --no-motion)".into(),
        });
    }
    let motion = MotionFile::read(&file)?;
    let encoder = Encoder::new(&motion.humanoid, opts.content.clone(), opts.packing);
    let mut sender = Sender::new(opts.target)?;
    let total = (motion.duration_s() * RATE_HZ).round().max(1.0) as u64;
    if progress {
        eprintln!(
            "vmc: playing {} ({:.1} s) to {} at 60 frames a second; Ctrl-C stops",
            file.display(),
            motion.duration_s(),
            opts.target
        );
    }
    let mut pose = motion.humanoid.empty_pose();
    let mut scratch = Vec::new();
    let mut pacer = Pacer::new(RATE_HZ);
    let mut late = 0;
    while let Some((i, skipped)) = pacer.next_frame(total) {
        late += skipped;
        let t = i as f64 / RATE_HZ;
        let k = ((t * motion.fps).round() as usize).min(motion.frames.len() - 1);
        let (hips, rot) = &motion.frames[k];
        motion.humanoid.pose_into(hips, |b| rot[b], &mut scratch, &mut pose);
        // T is the song's time of the frame, so a receiver can line frames up with the sound.
        sender.send_all(&encoder.datagrams(&pose, &motion.face[k], t as f32));
    }
    Ok(PlayReport {
        frames: sender.frames,
        datagrams: sender.datagrams,
        late,
        failed_sends: sender.failed,
        first_error: sender.first_error.clone(),
        seconds: pacer.elapsed_s(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn targets_and_parts() {
        assert_eq!(parse_target("127.0.0.1").unwrap(), "127.0.0.1:39539".parse().unwrap());
        assert_eq!(parse_target("127.0.0.1:40000").unwrap(), "127.0.0.1:40000".parse().unwrap());
        assert_eq!(parse_target("[::1]:40000").unwrap(), "[::1]:40000".parse().unwrap());
        assert_eq!(parse_target("::1").unwrap(), "[::1]:39539".parse().unwrap());
        assert_eq!(parse_target("[::1]").unwrap(), "[::1]:39539".parse().unwrap());
        for bad in ["127.0.0.1:x", "127.0.0.1:0", ":39539", "no-such-host.invalid:39539"] {
            let e = parse_target(bad).unwrap_err();
            assert!(e.to_string().starts_with(&format!("--vmc {bad}:")), "{e}");
        }
        assert_eq!(parse_parts("torso,arms,face").unwrap(), (vec![Group::Torso, Group::Arms], true));
        assert_eq!(parse_parts("all").unwrap().0.len(), 5);
        assert!(parse_parts("torso,tail").unwrap_err().to_string().contains("\"tail\""));
    }
}
