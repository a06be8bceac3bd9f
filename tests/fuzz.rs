//! Fuzzing on stable Rust: every reader of outside input (the MIDI reader, the OSC decoder,
//! the kit and map TOML readers, the motion and mocap JSON loaders, the hand model's weights
//! and sidecar, the retrieval library) is fed mutations of real files for a bounded time and
//! must return Ok or an error, never panic. Seeds: Groove MIDI takes (data/gmd), the demo,
//! the shipped configs and assets, and OSC messages from a direct-mode score.
//!
//! Each target runs `DRUMSIM_FUZZ_SECONDS` seconds (default 6; CI runs the default). Run it
//! longer, for example for an hour per target:
//!     DRUMSIM_FUZZ_SECONDS=3600 cargo test --release --test fuzz
//! `DRUMSIM_FUZZ_SEED` changes the mutation sequence (default 1). An input that panics is
//! written to target/fuzz-crashes/TARGET-HASH.bin and named in the failure; make it a named
//! regression test (tests/hostile_input.rs) with its fix.

use drumsim::kit::Kit;
use drumsim::midi::file::parse_bytes;
use drumsim::midi::{NoteMap, ReadOptions};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn read(rel: &str) -> Vec<u8> {
    std::fs::read(root().join(rel)).unwrap_or_else(|e| panic!("seed {rel}: {e}"))
}

/// xorshift64*: the mutation sequence is the same for the same seed.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Values that break readers: lengths and counts at their limits, MIDI status bytes, and in
/// text, numbers no config should hold.
const BYTES: [u8; 10] = [0x00, 0x01, 0x7F, 0x80, 0xFF, 0xF0, 0xF7, 0x2F, 0x90, 0xFE];
const NUMBERS: [&str; 14] = [
    "0",
    "-0",
    "-1",
    "1e30",
    "-1e30",
    "1e308",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "99999999999999999999",
    "0.0001",
    "127",
    "-128",
];

/// One to four random edits of `input`, some of them taken from `other` (a second seed).
fn mutate(rng: &mut Rng, input: &[u8], other: &[u8], text: bool) -> Vec<u8> {
    let mut v = input.to_vec();
    for _ in 0..1 + rng.below(4) {
        let at = rng.below(v.len() + 1);
        match rng.below(if text { 9 } else { 7 }) {
            0 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] ^= 1 << rng.below(8);
            }
            1 if !v.is_empty() => {
                let i = rng.below(v.len());
                v[i] = BYTES[rng.below(BYTES.len())];
            }
            2 => {
                let n = 1 + rng.below(8);
                let bytes: Vec<u8> = (0..n).map(|_| rng.next() as u8).collect();
                v.splice(at..at, bytes);
            }
            3 if !v.is_empty() => {
                let end = (at + 1 + rng.below(64)).min(v.len());
                v.drain(at.min(end)..end);
            }
            4 if !v.is_empty() => {
                // Repeat a stretch (events, notes, tensors) in place.
                let start = rng.below(v.len());
                let end = (start + 1 + rng.below(256)).min(v.len());
                let copy = v[start..end].to_vec();
                v.splice(at..at, copy);
            }
            5 if !other.is_empty() => {
                let start = rng.below(other.len());
                let end = (start + 1 + rng.below(512)).min(other.len());
                v.splice(at..at, other[start..end].iter().copied());
            }
            6 if v.len() >= 4 => {
                // A 16- or 32-bit length field set to a limit.
                let i = rng.below(v.len() - 3);
                let value: u32 = [0, 1, 0x7F, 0x80, 0xFFFF, 0x7FFF_FFFF, u32::MAX][rng.below(7)];
                let n = if rng.below(2) == 0 { 2 } else { 4 };
                v[i..i + n].copy_from_slice(&value.to_be_bytes()[4 - n..]);
            }
            7 => {
                // A number in the text replaced by one no config should hold.
                let digits: Vec<usize> = (0..v.len()).filter(|&i| v[i].is_ascii_digit()).collect();
                if let Some(&i) = digits.get(rng.below(digits.len())) {
                    let end = (i..v.len()).find(|&j| !(v[j].is_ascii_digit() || v[j] == b'.')).unwrap_or(v.len());
                    let start = (0..i).rev().find(|&j| !(v[j].is_ascii_digit() || v[j] == b'.' || v[j] == b'-'));
                    let start = start.map_or(0, |s| s + 1);
                    v.splice(start..end, NUMBERS[rng.below(NUMBERS.len())].bytes());
                }
            }
            8 => {
                // A line removed or doubled.
                let lines: Vec<usize> = (0..v.len()).filter(|&i| v[i] == b'\n').collect();
                if lines.len() >= 2 {
                    let k = rng.below(lines.len() - 1);
                    let (a, b) = (lines[k] + 1, lines[k + 1] + 1);
                    if rng.below(2) == 0 {
                        v.drain(a..b);
                    } else {
                        let line = v[a..b].to_vec();
                        v.splice(a..a, line);
                    }
                }
            }
            _ => {}
        }
    }
    v
}

fn budget() -> Duration {
    let s = std::env::var("DRUMSIM_FUZZ_SECONDS").ok().and_then(|s| s.parse::<f64>().ok()).unwrap_or(6.0);
    Duration::from_secs_f64(s.max(0.1))
}

/// Feed mutations of `seeds` to `target` for the time budget; fail naming every input that
/// panicked (saved under target/fuzz-crashes). Returns how many inputs ran.
fn fuzz(name: &str, seeds: &[Vec<u8>], text: bool, target: impl Fn(&[u8])) -> u64 {
    let seed = std::env::var("DRUMSIM_FUZZ_SEED").ok().and_then(|s| s.parse::<u64>().ok()).unwrap_or(1);
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15 ^ seed.wrapping_mul(0xD1B5_4A32_D192_ED03) ^ name.len() as u64);
    let crashes_dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("../fuzz-crashes");
    let mut crashes: Vec<PathBuf> = Vec::new();
    let (started, budget) = (Instant::now(), budget());
    let mut runs = 0u64;
    // The seeds themselves first, then mutations (of mutations, a quarter of the time).
    let mut last: Vec<u8> = Vec::new();
    while runs < seeds.len() as u64 || started.elapsed() < budget {
        let input = if (runs as usize) < seeds.len() {
            seeds[runs as usize].clone()
        } else {
            let base = if !last.is_empty() && rng.below(4) == 0 {
                last.clone()
            } else {
                seeds[rng.below(seeds.len())].clone()
            };
            let other = rng.below(seeds.len());
            mutate(&mut rng, &base, &seeds[other], text)
        };
        runs += 1;
        if catch_unwind(AssertUnwindSafe(|| target(&input))).is_err() {
            std::fs::create_dir_all(&crashes_dir).unwrap();
            let hash =
                input.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ b as u64).wrapping_mul(0x100_0000_01b3));
            let path = crashes_dir.join(format!("{name}-{hash:016x}.bin"));
            std::fs::write(&path, &input).unwrap();
            crashes.push(path);
            if crashes.len() >= 5 {
                break;
            }
        }
        last = input;
    }
    assert!(crashes.is_empty(), "{name}: {} of {runs} inputs panicked: {crashes:?}", crashes.len());
    eprintln!("fuzz {name}: {runs} inputs in {:.1} s, no panic", started.elapsed().as_secs_f64());
    runs
}

fn text(bytes: &[u8]) -> &str {
    std::str::from_utf8(bytes).unwrap_or("")
}

#[test]
fn fuzz_the_midi_reader() {
    let seeds: Vec<Vec<u8>> = [
        "assets/demo/demo.mid",
        "data/gmd/drummer1/session1/251_funk-purdieshuffle_130_fill_4-4.mid",
        "data/gmd/drummer3/session1/21_jazz_120_beat_4-4.mid",
        "data/gmd/drummer1/session1/37_latin-samba_116_fill_4-4.mid",
        "data/gmd/drummer1/session2/4_jazz_120_beat_3-4.mid",
    ]
    .iter()
    .map(|p| read(p))
    .collect();
    let gm = NoteMap::builtin("gm").unwrap();
    let kit = Kit::builtin_default();
    let runs = fuzz("midi", &seeds, false, |bytes| {
        if let Ok(perf) = parse_bytes(bytes, Path::new("fuzz.mid"), &ReadOptions { channel: 10 }) {
            // What a render does next with a song that reads: choose a map, make the score.
            let _ = NoteMap::auto_for(&perf);
            if perf.notes_end_s < 120.0 {
                let _ = drumsim::render::score_performance(&perf, &kit, &gm);
            }
        }
    });
    assert!(runs > 100, "{runs}");
}

#[test]
fn fuzz_the_osc_decoder() {
    // The messages of the demo's direct-mode score, as the transport carries them.
    let song = root().join("assets/demo/demo.mid");
    let map = NoteMap::builtin("gm").unwrap();
    let opts = drumsim::render::RenderOptions::default();
    let score = drumsim::render::score_file(&song, &Kit::builtin_default(), &map, &opts).unwrap();
    let mut seeds: Vec<Vec<u8>> = Vec::new();
    for c in score.contacts.contacts.iter().take(40) {
        let mut buf = Vec::new();
        drumsim::interaction::encode(&drumsim::interaction::Message::Contact(c.contact.clone()), &mut buf).unwrap();
        seeds.push(buf);
    }
    for m in [
        drumsim::interaction::Message::HiHat { time_s: 1.5, openness: 0.4 },
        drumsim::interaction::Message::Choke { piece: "crash".into(), time_s: 2.0 },
    ] {
        let mut buf = Vec::new();
        drumsim::interaction::encode(&m, &mut buf).unwrap();
        seeds.push(buf);
    }
    fuzz("osc", &seeds, false, |bytes| {
        let _ = drumsim::interaction::decode(bytes);
    });
}

#[test]
fn fuzz_the_kit_reader() {
    let seeds = vec![read("config/kits/default.toml"), read("config/kits/rearranged.toml")];
    fuzz("kit", &seeds, true, |bytes| {
        let _ = Kit::from_toml_str(text(bytes), Path::new("fuzz.toml"));
    });
}

#[test]
fn fuzz_the_map_reader() {
    let seeds: Vec<Vec<u8>> = ["gm", "xg", "roland-td", "alesis", "yamaha-dtx"]
        .iter()
        .map(|m| read(&format!("config/maps/{m}.toml")))
        .collect();
    fuzz("map", &seeds, true, |bytes| {
        let _ = NoteMap::from_toml_str(text(bytes), Path::new("fuzz.toml"));
    });
}

#[test]
fn fuzz_the_mocap_loader() {
    use drumsim::learn::mocap::{parse_mocap, JointNames};
    let seeds = vec![read("assets/mocap-example.json")];
    let (names, gm) = (JointNames::default(), NoteMap::builtin("gm").unwrap());
    fuzz("mocap", &seeds, true, |bytes| {
        let _ = parse_mocap(text(bytes), Path::new("fuzz.json"), &names, Some(&gm));
    });
}

#[test]
fn fuzz_the_motion_loader() {
    // A short motion written by the exporter: the demo's first seconds.
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("fuzz-motion-{}", std::process::id()));
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .args(["render", "assets/demo/demo.mid", "--out", dir.to_str().unwrap()])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let full = std::fs::read(dir.join("demo.motion.json")).unwrap();
    // The header and ten frames, closed again, keep each input small.
    let text_full = String::from_utf8(full).unwrap();
    let cut = text_full.match_indices("},\n").nth(9).map_or(text_full.len(), |(i, _)| i + 1);
    let short = format!("{}\n]}}\n", &text_full[..cut]);
    assert!(drumsim::eval::report::parse_motion_hands(short.as_bytes(), Path::new("short.json")).is_ok());
    fuzz("motion", &[short.into_bytes()], true, |bytes| {
        let _ = drumsim::eval::report::parse_motion_hands(bytes, Path::new("fuzz.json"));
    });
}

#[test]
fn fuzz_the_hand_model_weights_and_sidecar() {
    use drumsim::motion::hands::weights::HandWeights;
    use drumsim::motion::hands::HandModel;
    let weights = read("assets/hands/best.bpk");
    fuzz("weights", std::slice::from_ref(&weights), false, |bytes| {
        let _ = HandWeights::from_bytes(bytes, Path::new("fuzz.bpk"));
    });
    let good = HandWeights::from_bytes(&weights, Path::new("best.bpk")).unwrap();
    fuzz("sidecar", &[read("assets/hands/best.json")], true, |bytes| {
        let _ = HandModel::with_sidecar(&good, text(bytes), Path::new("fuzz.json"));
    });
}

#[test]
fn fuzz_the_retrieval_library() {
    let seeds = vec![read("assets/upper-library.bin")];
    fuzz("library", &seeds, false, |bytes| {
        let _ = drumsim::motion::upper::Library::from_bytes(bytes, Path::new("fuzz.bin"));
    });
}
