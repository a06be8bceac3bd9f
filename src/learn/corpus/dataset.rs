//! The hand model's training pairs from the Groove MIDI Dataset: for each file of a split (as
//! listed in its info.csv), the teacher's piano roll and hand values, and a compact binary file
//! to keep them in.
//!
//! Each example runs to one second after the last note (GMD takes can carry minutes of hi-hat
//! pedal data after the playing ends). The teacher's seed is a hash of the example id, so an
//! example is the same whichever files are built with it.
//!
//! File format (all little-endian):
//! ```text
//! magic   8 bytes  "DRUMSIMC"
//! version u32      1
//! roll    u32      16 (roll columns)
//! values  u32      14 (hand values per frame)
//! count   u32      number of examples
//! per example:
//!   id_len u32, id (UTF-8, id_len bytes)
//!   frames u32
//!   roll   frames x u16   bit c set = onset in roll column c
//!   hands  frames x 14 f32
//! ```

use super::{teach, CorpusError};
use crate::kit::Kit;
use crate::midi::roll::frame_of;
use crate::midi::{read_file, NoteMap, ReadOptions};
use crate::motion::track::hands_to_values;
use crate::motion::HAND_VALUES;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};
use std::time::Instant;

pub const MAGIC: &[u8; 8] = b"DRUMSIMC";
pub const VERSION: u32 = 1;
/// Frames kept after the last note.
pub const TAIL_FRAMES: usize = 60;

pub use crate::learn::Example;

/// The examples of a split and the files that could not be read.
#[derive(Debug, Clone, Default)]
pub struct Dataset {
    pub examples: Vec<Example>,
    /// (file, why) for each file that failed to parse or teach.
    pub skipped: Vec<(PathBuf, String)>,
    /// Hand notes the teacher dropped (three or more at once), over all examples.
    pub dropped_notes: usize,
}

/// What [`run_corpus`] did.
#[derive(Debug, Clone)]
pub struct CorpusSummary {
    pub examples: usize,
    pub frames: usize,
    pub dropped_notes: usize,
    pub skipped: Vec<(PathBuf, String)>,
    pub seconds: f64,
    pub bytes: u64,
}

/// A row of info.csv.
#[derive(Debug, Clone, PartialEq)]
pub struct InfoRow {
    pub id: String,
    pub midi: PathBuf,
    pub split: String,
}

/// The rows of `gmd_dir/info.csv` (plain comma-separated, no quoting, a header line naming at
/// least `id`, `midi_filename` and `split`).
pub fn read_info(gmd_dir: &Path) -> Result<Vec<InfoRow>, CorpusError> {
    let path = gmd_dir.join("info.csv");
    let text = std::fs::read_to_string(&path).map_err(|source| CorpusError::Read { path: path.clone(), source })?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap_or("").split(',').map(str::trim).collect();
    let col = |name: &str| {
        header.iter().position(|h| *h == name).ok_or_else(|| CorpusError::Csv {
            path: path.clone(),
            line: 1,
            message: format!("no column {name:?} in the header"),
        })
    };
    let (ci, cm, cs) = (col("id")?, col("midi_filename")?, col("split")?);
    let mut rows = Vec::new();
    for (n, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').map(str::trim).collect();
        let get = |c: usize| {
            f.get(c).copied().ok_or_else(|| CorpusError::Csv {
                path: path.clone(),
                line: n + 2,
                message: format!("{} fields, expected at least {}", f.len(), c + 1),
            })
        };
        rows.push(InfoRow { id: get(ci)?.to_string(), midi: gmd_dir.join(get(cm)?), split: get(cs)?.to_string() });
    }
    Ok(rows)
}

/// FNV-1a of the id: the teacher's seed for an example.
pub fn seed_of(id: &str) -> u64 {
    id.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3))
}

/// Teach every file of `split` (e.g. "train", "validation") on the default kit with the
/// roland-td map. Files that fail are skipped and listed.
pub fn build_dataset(gmd_dir: &Path, split: &str) -> Result<Dataset, CorpusError> {
    let map = NoteMap::builtin("roland-td").expect("built-in map");
    let kit = Kit::builtin_default();
    let mut out = Dataset::default();
    for row in read_info(gmd_dir)?.into_iter().filter(|r| r.split == split) {
        match example(&row, &map, &kit) {
            Ok((ex, dropped)) => {
                out.examples.push(ex);
                out.dropped_notes += dropped;
            }
            Err(why) => out.skipped.push((row.midi, why)),
        }
    }
    Ok(out)
}

fn example(row: &InfoRow, map: &NoteMap, kit: &Kit) -> Result<(Example, usize), String> {
    let perf = read_file(&row.midi, &ReadOptions { channel: map.channel }).map_err(|e| e.to_string())?;
    let t = teach(&perf, map, kit, seed_of(&row.id)).map_err(|e| e.to_string())?;
    let frames = (frame_of(perf.notes_end_s) + TAIL_FRAMES + 1).min(t.roll.len());
    let ex = Example {
        id: row.id.clone(),
        roll: t.roll.frames[..frames].iter().map(|f| f.map(|b| if b { 1.0 } else { 0.0 })).collect(),
        hands: t.motion.frames[..frames].iter().map(|f| hands_to_values(&f.hands)).collect(),
    };
    Ok((ex, t.dropped))
}

/// Write examples in the format above.
pub fn save_examples(path: &Path, examples: &[Example]) -> Result<u64, CorpusError> {
    let werr = |source| CorpusError::Write { path: path.to_path_buf(), source };
    let file = std::fs::File::create(path).map_err(werr)?;
    let mut w = BufWriter::new(file);
    let mut bytes = 0u64;
    let mut put = |w: &mut BufWriter<std::fs::File>, b: &[u8]| {
        bytes += b.len() as u64;
        w.write_all(b)
    };
    let u32le = |x: usize| (x as u32).to_le_bytes();
    put(&mut w, MAGIC).map_err(werr)?;
    for x in [VERSION as usize, 16, HAND_VALUES, examples.len()] {
        put(&mut w, &u32le(x)).map_err(werr)?;
    }
    for ex in examples {
        put(&mut w, &u32le(ex.id.len())).map_err(werr)?;
        put(&mut w, ex.id.as_bytes()).map_err(werr)?;
        let frames = ex.roll.len().min(ex.hands.len());
        put(&mut w, &u32le(frames)).map_err(werr)?;
        let mut buf = Vec::with_capacity(frames * (2 + 4 * HAND_VALUES));
        for r in &ex.roll[..frames] {
            let bits = r.iter().enumerate().filter(|(_, v)| **v > 0.5).fold(0u16, |b, (c, _)| b | (1 << c));
            buf.extend_from_slice(&bits.to_le_bytes());
        }
        for h in &ex.hands[..frames] {
            for v in h {
                buf.extend_from_slice(&v.to_le_bytes());
            }
        }
        put(&mut w, &buf).map_err(werr)?;
    }
    w.flush().map_err(werr)?;
    Ok(bytes)
}

/// A reader over the file's bytes that names the offset of what is missing.
struct Reader<'a> {
    path: &'a Path,
    bytes: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize, what: &str) -> Result<&[u8], CorpusError> {
        let end = self.at.checked_add(n).filter(|&e| e <= self.bytes.len()).ok_or_else(|| CorpusError::Format {
            path: self.path.to_path_buf(),
            message: format!("cut short at byte {} reading {what} ({n} bytes)", self.at),
        })?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    fn u32(&mut self, what: &str) -> Result<usize, CorpusError> {
        let b = self.take(4, what)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    }
}

/// Read a file written by [`save_examples`].
pub fn load_examples(path: &Path) -> Result<Vec<Example>, CorpusError> {
    let bytes = std::fs::read(path).map_err(|source| CorpusError::Read { path: path.to_path_buf(), source })?;
    let bad = |message: String| CorpusError::Format { path: path.to_path_buf(), message };
    let mut r = Reader { path, bytes: &bytes, at: 0 };
    if r.take(8, "magic")? != MAGIC {
        return Err(bad("not a drumsim corpus file (bad magic)".into()));
    }
    let version = r.u32("version")?;
    if version != VERSION as usize {
        return Err(bad(format!("version {version}, this build reads version {VERSION}")));
    }
    let (cols, vals) = (r.u32("roll width")?, r.u32("hand values")?);
    if cols != 16 || vals != HAND_VALUES {
        return Err(bad(format!("{cols} roll columns and {vals} hand values, expected 16 and {HAND_VALUES}")));
    }
    let count = r.u32("example count")?;
    let mut out = Vec::with_capacity(count.min(1 << 16));
    for i in 0..count {
        let len = r.u32("id length")?;
        let id = std::str::from_utf8(r.take(len, "id")?).map_err(|_| bad(format!("example {i}: id is not UTF-8")))?;
        let id = id.to_string();
        let frames = r.u32("frame count")?;
        let roll_bytes = r.take(frames.saturating_mul(2), "roll")?;
        let roll = roll_bytes
            .chunks_exact(2)
            .map(|b| {
                let bits = u16::from_le_bytes([b[0], b[1]]);
                std::array::from_fn(|c| if bits & (1 << c) != 0 { 1.0 } else { 0.0 })
            })
            .collect();
        let hand_bytes = r.take(frames.saturating_mul(4 * HAND_VALUES), "hand values")?;
        let mut hands = Vec::with_capacity(frames);
        for (f, chunk) in hand_bytes.chunks_exact(4 * HAND_VALUES).enumerate() {
            let v: [f32; HAND_VALUES] = std::array::from_fn(|k| {
                f32::from_le_bytes([chunk[4 * k], chunk[4 * k + 1], chunk[4 * k + 2], chunk[4 * k + 3]])
            });
            if v.iter().any(|x| !x.is_finite()) {
                return Err(bad(format!("example {i} ({id}), frame {f}: a hand value is not finite")));
            }
            hands.push(v);
        }
        out.push(Example { id, roll, hands });
    }
    if r.at != bytes.len() {
        return Err(bad(format!("{} bytes after the last example", bytes.len() - r.at)));
    }
    Ok(out)
}

/// Build the examples of `split` and write them to `out_path`, timing it.
pub fn run_corpus(gmd_dir: &Path, out_path: &Path, split: &str) -> Result<CorpusSummary, CorpusError> {
    let start = Instant::now();
    let data = build_dataset(gmd_dir, split)?;
    if data.examples.is_empty() {
        return Err(CorpusError::Empty {
            path: gmd_dir.join("info.csv"),
            split: split.to_string(),
            skipped: data.skipped.len(),
        });
    }
    let bytes = save_examples(out_path, &data.examples)?;
    Ok(CorpusSummary {
        examples: data.examples.len(),
        frames: data.examples.iter().map(|e| e.roll.len()).sum(),
        dropped_notes: data.dropped_notes,
        skipped: data.skipped,
        seconds: start.elapsed().as_secs_f64(),
        bytes,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tmp(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("drumsim-corpus-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d.join(name)
    }

    fn examples() -> Vec<Example> {
        (0..3)
            .map(|i| Example {
                id: format!("drummer{i}/s/{i}"),
                roll: (0..5 + i).map(|f| std::array::from_fn(|c| ((f + c) % 3 == 0) as u8 as f32)).collect(),
                hands: (0..5 + i).map(|f| std::array::from_fn(|k| (f * 14 + k) as f32 * 0.01 - 0.3)).collect(),
            })
            .collect()
    }

    #[test]
    fn save_and_load_round_trip() {
        let p = tmp("rt.bin");
        let ex = examples();
        let bytes = save_examples(&p, &ex).unwrap();
        assert_eq!(bytes, std::fs::metadata(&p).unwrap().len());
        assert_eq!(load_examples(&p).unwrap(), ex);
    }

    #[test]
    fn a_truncated_or_foreign_file_is_an_error_naming_it() {
        let p = tmp("cut.bin");
        save_examples(&p, &examples()).unwrap();
        let bytes = std::fs::read(&p).unwrap();
        std::fs::write(&p, &bytes[..bytes.len() - 3]).unwrap();
        let e = load_examples(&p).unwrap_err().to_string();
        assert!(e.contains("cut.bin") && e.contains("cut short"), "{e}");
        std::fs::write(&p, b"hello world, not a corpus").unwrap();
        assert!(load_examples(&p).unwrap_err().to_string().contains("magic"));
    }

    #[test]
    fn info_rows_are_read_by_header_name() {
        let d = tmp("gmd");
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("info.csv"), "split,id,midi_filename\ntrain,a/1,a/1.mid\nvalidation,b/2,b/2.mid\n")
            .unwrap();
        let rows = read_info(&d).unwrap();
        assert_eq!(rows.len(), 2);
        assert_eq!(rows[1].id, "b/2");
        assert_eq!(rows[1].midi, d.join("b/2.mid"));
        // A split whose files are missing builds nothing and lists them.
        let data = build_dataset(&d, "train").unwrap();
        assert!(data.examples.is_empty() && data.skipped.len() == 1);
        std::fs::write(d.join("info.csv"), "id,split\n").unwrap();
        assert!(read_info(&d).unwrap_err().to_string().contains("midi_filename"));
    }
}
