//! The retrieval library: clips of roll + chest, head and face, and its compact file.
//!
//! File layout (little-endian): magic `DRUMSIM-UPPER`, version u32 = 1, clip count u32;
//! per clip: id length u32 and UTF-8 bytes, frame count u32, then per frame the roll as a
//! u16 bit mask (bit c = column c of `midi::roll::NOTE_NUMS`), chest and head as 3
//! positions in i16 tenths of a millimetre and 4 quaternion components in i16 /32767, and
//! the 52 face weights in u8 /255. 82 bytes a frame.

use crate::motion::track::{Pose, ARKIT_NAMES};
use std::path::{Path, PathBuf};

const MAGIC: &[u8] = b"DRUMSIM-UPPER";
const VERSION: u32 = 1;
const FACE: usize = ARKIT_NAMES.len();
/// Positions are stored in these units (0.1 mm): +-3.2 m.
const POS_SCALE: f32 = 1e4;

/// The upper body and face of one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpperFrame {
    pub chest: Pose,
    pub head: Pose,
    pub face: [f32; FACE],
}

/// A stretch of training motion with its roll.
#[derive(Debug, Clone, PartialEq)]
pub struct Clip {
    pub id: String,
    /// Per frame, bit c set when roll column c has an onset.
    pub roll: Vec<u16>,
    pub frames: Vec<UpperFrame>,
}

/// The clips retrieval may copy from.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Library {
    pub clips: Vec<Clip>,
}

#[derive(Debug, thiserror::Error)]
pub enum LibraryError {
    #[error("{path}: cannot read the upper-body library: {source}")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{path}: cannot write the upper-body library: {source}")]
    Write { path: PathBuf, source: std::io::Error },
    #[error("{path}: not an upper-body library, or corrupt: {why} (at byte {at})")]
    Corrupt { path: PathBuf, why: &'static str, at: usize },
    #[error("upper-body library clip {clip}: {why}")]
    Clip { clip: String, why: String },
    #[error("the upper-body library is empty")]
    Empty,
}

/// The bit mask of a frame of a boolean roll.
pub fn mask(frame: &[bool; 16]) -> u16 {
    frame.iter().enumerate().fold(0u16, |m, (c, &on)| if on { m | (1 << c) } else { m })
}

impl Library {
    /// Check every clip: as many roll frames as poses, finite values.
    pub fn validate(&self) -> Result<(), LibraryError> {
        if self.clips.iter().all(|c| c.frames.is_empty()) {
            return Err(LibraryError::Empty);
        }
        for c in &self.clips {
            let bad = |why: String| LibraryError::Clip { clip: c.id.clone(), why };
            if c.roll.len() != c.frames.len() {
                return Err(bad(format!("{} roll frames but {} poses", c.roll.len(), c.frames.len())));
            }
            for (i, f) in c.frames.iter().enumerate() {
                let finite = [f.chest, f.head].iter().all(|p| p.pos.iter().chain(&p.rot).all(|x| x.is_finite()))
                    && f.face.iter().all(|x| x.is_finite());
                if !finite {
                    return Err(bad(format!("frame {i} is not finite")));
                }
            }
        }
        Ok(())
    }

    /// Frames in all clips.
    pub fn frames(&self) -> usize {
        self.clips.iter().map(|c| c.frames.len()).sum()
    }

    /// The library as bytes (the layout in the module doc).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(64 + self.frames() * 82);
        b.extend_from_slice(MAGIC);
        b.extend_from_slice(&VERSION.to_le_bytes());
        b.extend_from_slice(&(self.clips.len() as u32).to_le_bytes());
        for c in &self.clips {
            b.extend_from_slice(&(c.id.len() as u32).to_le_bytes());
            b.extend_from_slice(c.id.as_bytes());
            b.extend_from_slice(&(c.frames.len() as u32).to_le_bytes());
            for (m, f) in c.roll.iter().zip(&c.frames) {
                b.extend_from_slice(&m.to_le_bytes());
                for p in [f.chest, f.head] {
                    for x in p.pos {
                        b.extend_from_slice(&((x * POS_SCALE).round().clamp(-32767.0, 32767.0) as i16).to_le_bytes());
                    }
                    for x in p.rot {
                        b.extend_from_slice(&((x * 32767.0).round().clamp(-32767.0, 32767.0) as i16).to_le_bytes());
                    }
                }
                b.extend(f.face.iter().map(|w| (w.clamp(0.0, 1.0) * 255.0).round() as u8));
            }
        }
        b
    }

    /// Parse bytes written by [`Library::to_bytes`]; `path` names them in errors.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Library, LibraryError> {
        let mut r = Reader { b: bytes, at: 0, path };
        if r.take(MAGIC.len())? != MAGIC {
            return Err(r.corrupt("bad magic"));
        }
        if r.u32()? != VERSION {
            return Err(r.corrupt("unknown version"));
        }
        let n = r.u32()? as usize;
        let mut clips = Vec::with_capacity(n.min(1 << 16));
        for _ in 0..n {
            let len = r.u32()? as usize;
            let id = String::from_utf8(r.take(len)?.to_vec()).map_err(|_| r.corrupt("clip id is not UTF-8"))?;
            let frames = r.u32()? as usize;
            if frames.saturating_mul(82) > bytes.len() {
                return Err(r.corrupt("clip longer than the file"));
            }
            let mut clip = Clip { id, roll: Vec::with_capacity(frames), frames: Vec::with_capacity(frames) };
            for _ in 0..frames {
                clip.roll.push(u16::from_le_bytes([r.byte()?, r.byte()?]));
                let mut poses = [Pose::IDENTITY; 2];
                for p in &mut poses {
                    for x in &mut p.pos {
                        *x = r.i16()? as f32 / POS_SCALE;
                    }
                    for x in &mut p.rot {
                        *x = r.i16()? as f32 / 32767.0;
                    }
                }
                let mut face = [0.0; FACE];
                for w in &mut face {
                    *w = r.byte()? as f32 / 255.0;
                }
                clip.frames.push(UpperFrame { chest: poses[0], head: poses[1], face });
            }
            clips.push(clip);
        }
        if r.at != bytes.len() {
            return Err(r.corrupt("bytes after the last clip"));
        }
        let lib = Library { clips };
        lib.validate()?;
        Ok(lib)
    }

    pub fn load(path: &Path) -> Result<Library, LibraryError> {
        let bytes = std::fs::read(path).map_err(|source| LibraryError::Read { path: path.into(), source })?;
        Library::from_bytes(&bytes, path)
    }

    /// Write atomically: a temporary file beside `path`, then a rename.
    pub fn save(&self, path: &Path) -> Result<(), LibraryError> {
        let tmp = path.with_extension("tmp");
        let write = |source| LibraryError::Write { path: path.into(), source };
        std::fs::write(&tmp, self.to_bytes()).map_err(write)?;
        std::fs::rename(&tmp, path).map_err(write)
    }
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
    path: &'a Path,
}

impl Reader<'_> {
    fn corrupt(&self, why: &'static str) -> LibraryError {
        LibraryError::Corrupt { path: self.path.into(), why, at: self.at }
    }
    fn take(&mut self, n: usize) -> Result<&[u8], LibraryError> {
        if self.b.len() - self.at < n {
            return Err(self.corrupt("ends early"));
        }
        self.at += n;
        Ok(&self.b[self.at - n..self.at])
    }
    fn byte(&mut self) -> Result<u8, LibraryError> {
        Ok(self.take(1)?[0])
    }
    fn i16(&mut self) -> Result<i16, LibraryError> {
        let s = self.take(2)?;
        Ok(i16::from_le_bytes([s[0], s[1]]))
    }
    fn u32(&mut self) -> Result<u32, LibraryError> {
        let s = self.take(4)?;
        Ok(u32::from_le_bytes([s[0], s[1], s[2], s[3]]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clip(n: usize) -> Clip {
        let frames = (0..n)
            .map(|i| {
                let t = i as f32 * 0.01;
                let s = (0.5 * t).sin();
                let chest = Pose { pos: [0.0, 0.05 * t.sin(), 1.1], rot: [(0.5 * t).cos(), 0.0, 0.0, s] };
                let head = Pose { pos: [0.01, 0.0, 1.5], rot: [1.0, 0.0, 0.0, 0.0] };
                let mut face = [0.0; FACE];
                face[i % FACE] = 0.5;
                UpperFrame { chest, head, face }
            })
            .collect();
        Clip { id: format!("clip{n}"), roll: (0..n).map(|i| i as u16 * 37).collect(), frames }
    }

    #[test]
    fn round_trips_within_its_quantisation() {
        let lib = Library { clips: vec![clip(50), clip(7)] };
        let back = Library::from_bytes(&lib.to_bytes(), Path::new("t.bin")).unwrap();
        assert_eq!(back.clips.len(), 2);
        assert_eq!(lib.to_bytes().len(), MAGIC.len() + 8 + 2 * 8 + "clip50clip7".len() + 57 * 82);
        for (a, b) in lib.clips.iter().zip(&back.clips) {
            assert_eq!(a.roll, b.roll);
            for (x, y) in a.frames.iter().zip(&b.frames) {
                for k in 0..3 {
                    assert!((x.chest.pos[k] - y.chest.pos[k]).abs() <= 0.5 / POS_SCALE);
                }
                for k in 0..4 {
                    assert!((x.chest.rot[k] - y.chest.rot[k]).abs() <= 1.0 / 32767.0);
                }
                assert!(x.face.iter().zip(&y.face).all(|(p, q)| (p - q).abs() <= 0.5 / 255.0 + 1e-6));
            }
        }
    }

    #[test]
    fn truncated_or_foreign_files_are_refused_with_the_path() {
        let bytes = Library { clips: vec![clip(10)] }.to_bytes();
        let e = Library::from_bytes(&bytes[..bytes.len() - 3], Path::new("lib.bin")).unwrap_err();
        assert!(e.to_string().contains("lib.bin") && e.to_string().contains("ends early"), "{e}");
        let e = Library::from_bytes(b"PK\x03\x04 not a library", Path::new("x.zip")).unwrap_err();
        assert!(e.to_string().contains("bad magic"), "{e}");
        let empty = Library::default();
        assert!(matches!(Library::from_bytes(&empty.to_bytes(), Path::new("e")), Err(LibraryError::Empty)));
    }
}
