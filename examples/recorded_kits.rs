//! Recorded acoustic drum kits measured with drumsim's own hit measures
//! (`drumsim::eval::timbre`), as a reference to hold `drumsim audition` against row by row:
//! the same stroke names and velocities (`drumsim::audition::VELOCITIES`).
//!
//! `cargo run --release --example recorded_kits [-- OUT.json]` writes
//! assets/reference/recorded-kits.json (or OUT.json) and prints a table. With
//! `DRUMSIM_RECORDED_WAVS=DIR` it also writes each measured hit as DIR/KIT/NAME-VELOCITY.wav
//! (for `examples/spectrograms.rs`). Two kits, both from
//! Debian packages: FluidR3 GM (fluid-soundfont-gm, rendered by fluidsynth with reverb and
//! chorus off) and Hydrogen's "The Black Pearl 1.0" (hydrogen-drumkits, its WAV layers read
//! directly and scaled the way Hydrogen scales them).

use anyhow::{anyhow, bail, Context, Result};
use drumsim::audition::VELOCITIES;
use drumsim::eval::timbre::{measure_hit, HitMeasures};
use midly::{Format, Header, MetaMessage, MidiMessage, Smf, Timing, TrackEvent, TrackEventKind};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::process::Command;

const DEFAULT_OUT: &str = "assets/reference/recorded-kits.json";
const SF2: &str = "/usr/share/sounds/sf2/FluidR3_GM.sf2";
const PEARL: &str = "/usr/share/hydrogen/data/drumkits/The Black Pearl 1.0";
/// Each measured signal: from 10 ms before the hit, 2 s long.
const PRE_S: f64 = 0.010;
const LEN_S: f64 = 2.0;
/// MIDI render: hits 2.5 s apart from 0.5 s, note-off 0.5 s after each, all sound off
/// 0.3 s before each (so a cymbal's tail does not run into the next, quieter hit).
const FIRST_S: f64 = 0.5;
const SPACING_S: f64 = 2.5;
const RATE_HZ: u32 = 48_000;

/// GM drum notes (channel 10) for drumsim's stroke names; GM has no rim shot.
const GM: [(&str, u8); 14] = [
    ("kick", 36),
    ("snare", 38),
    ("snare cross-stick", 37),
    ("tom1", 48),
    ("tom2", 45),
    ("floor_tom", 43),
    ("hihat closed", 42),
    ("hihat open", 46),
    ("hihat pedal", 44),
    ("crash bow", 49),
    ("ride bow", 51),
    ("ride bell", 53),
    ("splash bow", 55),
    ("china bow", 52),
];

/// The Black Pearl's instruments for drumsim's stroke names; it has no china.
const PEARL_MAP: [(&str, &str); 14] = [
    ("kick", "Pearl Kick"),
    ("snare", "Pearl Snare"),
    ("snare rim shot", "Pearl Snare Rimshot"),
    ("snare cross-stick", "Pearl Side Stick"),
    ("tom1", "Pearl Tom 1"),
    ("tom2", "Pearl Tom 2"),
    ("floor_tom", "Pearl Tom Floor"),
    ("hihat closed", "Sabian Hat Closed"),
    ("hihat open", "Sabian Hat Open"),
    ("hihat pedal", "Sabian Hat Pedal"),
    ("crash bow", "Sabian Crash"),
    ("ride bow", "Paiste Ride"),
    ("ride bell", "Paiste Bell"),
    ("splash bow", "Zildjian Splash"),
];

#[derive(Serialize)]
struct Reference {
    command: &'static str,
    kits: Vec<KitHits>,
}

#[derive(Serialize)]
struct KitHits {
    name: &'static str,
    source: &'static str,
    hits: Vec<Hit>,
}

#[derive(Serialize)]
struct Hit {
    name: String,
    velocity: u8,
    measures: HitMeasures,
}

fn main() -> Result<()> {
    let out = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| DEFAULT_OUT.into()));
    let fluid = KitHits {
        name: "FluidR3 GM",
        source: "fluid-soundfont-gm: /usr/share/sounds/sf2/FluidR3_GM.sf2 via fluidsynth, reverb and chorus off",
        hits: fluid_hits().context("FluidR3 GM")?,
    };
    let pearl = KitHits {
        name: "The Black Pearl",
        source: "hydrogen-drumkits: /usr/share/hydrogen/data/drumkits/The Black Pearl 1.0, WAV layers \
                 scaled by velocity, layer gain and instrument volume and gain (pan ignored)",
        hits: pearl_hits().context("The Black Pearl")?,
    };
    let reference = Reference { command: "cargo run --release --example recorded_kits", kits: vec![fluid, pearl] };

    println!(
        "{:16} {:18} {:>4} {:>9} {:>9} {:>9} {:>8} {:>8}",
        "kit", "name", "vel", "level_dB", "cent50Hz", "dec20_ms", "tail4kdB", "tailflat"
    );
    let opt = |v: Option<f64>, p: usize| v.map_or("-".to_string(), |v| format!("{v:.p$}"));
    for kit in &reference.kits {
        for h in &kit.hits {
            let m = &h.measures;
            println!(
                "{:16} {:18} {:>4} {:>9.1} {:>9.0} {:>9} {:>8} {:>8}",
                kit.name,
                h.name,
                h.velocity,
                m.level_db,
                m.centroid_50ms_hz,
                opt(m.decay_20db_ms, 0),
                opt(m.tail_above_4k_db, 1),
                opt(m.tail_flatness, 3)
            );
        }
    }

    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let partial = out.with_extension("json.partial");
    std::fs::write(&partial, serde_json::to_string_pretty(&reference)? + "\n")
        .with_context(|| format!("writing {}", partial.display()))?;
    std::fs::rename(&partial, &out).with_context(|| format!("renaming to {}", out.display()))?;
    println!("wrote {}", out.display());
    Ok(())
}

/// Measure one hit, or say which one was silent.
fn measure(kit: &str, name: &str, velocity: u8, left: &[f32], right: &[f32], rate_hz: f64) -> Result<Hit> {
    if let Some(dir) = std::env::var_os("DRUMSIM_RECORDED_WAVS") {
        let dir = Path::new(&dir).join(kit);
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let path = dir.join(format!("{name}-{velocity}.wav"));
        let spec = hound::WavSpec {
            channels: 2,
            sample_rate: rate_hz as u32,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let mut w = hound::WavWriter::create(&path, spec).with_context(|| format!("writing {}", path.display()))?;
        for (l, r) in left.iter().zip(right) {
            w.write_sample(*l)?;
            w.write_sample(*r)?;
        }
        w.finalize()?;
    }
    let measures = measure_hit(left, right, rate_hz).ok_or_else(|| anyhow!("{name} v{velocity}: silent"))?;
    // The onset should be at 10 ms; say so when the recording has leading silence or a
    // slow attack.
    let onset_ms = onset_s(left, right) * 1e3 / rate_hz;
    if !(5.0..=20.0).contains(&onset_ms) {
        eprintln!("note: {name} v{velocity}: onset at {onset_ms:.1} ms into the signal (expected 10 ms)");
    }
    Ok(Hit { name: name.into(), velocity, measures })
}

/// The first sample within 40 dB of the peak power (as `measure_hit` finds it).
fn onset_s(left: &[f32], right: &[f32]) -> f64 {
    let power: Vec<f32> = left.iter().zip(right).map(|(l, r)| l * l + r * r).collect();
    let peak = power.iter().cloned().fold(0.0, f32::max);
    power.iter().position(|p| *p >= peak * 1e-4).unwrap_or(0) as f64
}

/// `x[from..]`, `len` long, padded with zeros.
fn slice(x: &[f32], from: usize, len: usize) -> Vec<f32> {
    let mut v: Vec<f32> = x.iter().skip(from).take(len).copied().collect();
    v.resize(len, 0.0);
    v
}

/// Render every GM note at every velocity through fluidsynth and measure each hit.
fn fluid_hits() -> Result<Vec<Hit>> {
    if !Path::new(SF2).is_file() {
        bail!("{SF2} is missing (apt install fluid-soundfont-gm)");
    }
    let dir = std::env::temp_dir().join(format!("recorded_kits.{}", std::process::id()));
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let result = fluid_render(&dir);
    let _ = std::fs::remove_dir_all(&dir);
    let (left, right) = result?;
    let mut hits = Vec::new();
    let (pre, len) = ((PRE_S * RATE_HZ as f64) as usize, (LEN_S * RATE_HZ as f64) as usize);
    for (i, (name, _, velocity)) in gm_hits().enumerate() {
        let from = ((FIRST_S + i as f64 * SPACING_S) * RATE_HZ as f64) as usize - pre;
        hits.push(measure(
            "fluidr3",
            name,
            velocity,
            &slice(&left, from, len),
            &slice(&right, from, len),
            RATE_HZ as f64,
        )?);
    }
    Ok(hits)
}

/// (stroke name, GM note, velocity) in render order.
fn gm_hits() -> impl Iterator<Item = (&'static str, u8, u8)> {
    GM.iter().flat_map(|&(name, key)| VELOCITIES.iter().map(move |&v| (name, key, v)))
}

/// Write the MIDI file into `dir`, render it, and read it back as stereo f32.
fn fluid_render(dir: &Path) -> Result<(Vec<f32>, Vec<f32>)> {
    // 480 ticks a beat at 120 bpm: 960 ticks a second.
    let ticks = |s: f64| (s * 960.0).round() as u32;
    let event = |delta: u32, message: MidiMessage| TrackEvent {
        delta: delta.into(),
        kind: TrackEventKind::Midi { channel: 9.into(), message },
    };
    let note = |delta: u32, key: u8, vel: u8| match vel {
        0 => event(delta, MidiMessage::NoteOff { key: key.into(), vel: 0.into() }),
        _ => event(delta, MidiMessage::NoteOn { key: key.into(), vel: vel.into() }),
    };
    let mut track =
        vec![TrackEvent { delta: 0.into(), kind: TrackEventKind::Meta(MetaMessage::Tempo(500_000.into())) }];
    let mut now = 0;
    for (i, (_, key, velocity)) in gm_hits().enumerate() {
        let on = ticks(FIRST_S + i as f64 * SPACING_S);
        let silence = on - ticks(0.3);
        track.push(event(silence - now, MidiMessage::Controller { controller: 120.into(), value: 0.into() }));
        track.push(note(on - silence, key, velocity));
        track.push(note(ticks(0.5), key, 0));
        now = on + ticks(0.5);
    }
    track.push(TrackEvent { delta: ticks(SPACING_S).into(), kind: TrackEventKind::Meta(MetaMessage::EndOfTrack) });
    let mut smf = Smf::new(Header::new(Format::SingleTrack, Timing::Metrical(480.into())));
    smf.tracks.push(track);
    let mid = dir.join("gm-drums.mid");
    smf.save(&mid).with_context(|| format!("writing {}", mid.display()))?;

    let wav = dir.join("gm-drums.wav");
    // Float output: at gain 1.0 a loud hit would clip 16-bit samples.
    let status = Command::new("fluidsynth")
        .args(["-q", "-ni", "-g", "1.0", "-R", "0", "-C", "0", "-r", &RATE_HZ.to_string(), "-O", "float", "-F"])
        .arg(&wav)
        .arg(SF2)
        .arg(&mid)
        .stdout(std::process::Stdio::null())
        .status()
        .map_err(|e| anyhow!("running fluidsynth: {e} (apt install fluidsynth)"))?;
    if !status.success() {
        bail!("fluidsynth failed ({status})");
    }
    let (left, right, rate) = read_wav(&wav)?;
    if rate != RATE_HZ {
        bail!("fluidsynth rendered at {rate} Hz, asked for {RATE_HZ}");
    }
    Ok((left, right))
}

/// A WAV file as stereo f32 (mono on both channels), with its sample rate.
fn read_wav(path: &Path) -> Result<(Vec<f32>, Vec<f32>, u32)> {
    let mut reader = hound::WavReader::open(path).with_context(|| format!("reading {}", path.display()))?;
    let spec = reader.spec();
    let samples: Vec<f32> = match spec.sample_format {
        hound::SampleFormat::Float => reader.samples::<f32>().collect::<Result<_, _>>(),
        hound::SampleFormat::Int => {
            let scale = 1.0 / (1u64 << (spec.bits_per_sample - 1)) as f32;
            reader.samples::<i32>().map(|s| s.map(|s| s as f32 * scale)).collect()
        }
    }
    .with_context(|| format!("reading {}", path.display()))?;
    let channels = spec.channels as usize;
    let left = samples.iter().step_by(channels).copied().collect();
    let right = samples.iter().skip(channels.min(2) - 1).step_by(channels).copied().collect();
    Ok((left, right, spec.sample_rate))
}

/// One velocity layer of a Hydrogen instrument.
struct Layer {
    file: String,
    min: f64,
    max: f64,
    gain: f64,
}

/// Measure each mapped Black Pearl instrument at every velocity from its WAV layers.
fn pearl_hits() -> Result<Vec<Hit>> {
    let dir = Path::new(PEARL);
    let xml_path = dir.join("drumkit.xml");
    let xml = std::fs::read_to_string(&xml_path)
        .with_context(|| format!("reading {} (apt install hydrogen-drumkits)", xml_path.display()))?;
    let mut hits = Vec::new();
    for (name, instrument) in PEARL_MAP {
        let block = xml
            .split("<instrument>")
            .skip(1)
            .map(|b| b.split("</instrument>").next().unwrap_or(b))
            .find(|b| tag(b, "name").as_deref() == Some(instrument))
            .ok_or_else(|| anyhow!("{}: no instrument \"{instrument}\"", xml_path.display()))?;
        // The instrument's own fields come before its layers.
        let head = block.split("<layer>").next().unwrap_or(block);
        let number = |text: &str, t: &str| -> Result<f64> {
            let v = tag(text, t).ok_or_else(|| anyhow!("{instrument}: no <{t}>"))?;
            v.parse().with_context(|| format!("{instrument}: <{t}>{v}</{t}>"))
        };
        let volume = number(head, "volume")? * tag(head, "gain").map_or(Ok(1.0), |_| number(head, "gain"))?;
        let layers = block
            .split("<layer>")
            .skip(1)
            .map(|l| {
                let file = tag(l, "filename").ok_or_else(|| anyhow!("{instrument}: a layer without <filename>"))?;
                Ok(Layer { file, min: number(l, "min")?, max: number(l, "max")?, gain: number(l, "gain")? })
            })
            .collect::<Result<Vec<_>>>()?;
        if layers.is_empty() {
            bail!("{instrument}: no layers");
        }
        for velocity in VELOCITIES {
            let v = velocity as f64 / 127.0;
            // The first layer whose range holds v; between layers (a gap), the nearest.
            let distance = |l: &Layer| (l.min - v).max(v - l.max).max(0.0);
            let layer = layers.iter().min_by(|a, b| distance(a).total_cmp(&distance(b))).unwrap_or(&layers[0]);
            if distance(layer) > 0.0 {
                eprintln!("note: {instrument} v{velocity}: no layer holds {v:.3}; using {}", layer.file);
            }
            let (left, right, rate) = read_wav(&dir.join(&layer.file))?;
            let gain = (v * layer.gain * volume) as f32;
            let (pre, len) = ((PRE_S * rate as f64) as usize, (LEN_S * rate as f64) as usize);
            let padded = |x: &[f32]| -> Vec<f32> {
                let mut out = vec![0.0; pre];
                out.extend(x.iter().map(|s| s * gain));
                slice(&out, 0, len)
            };
            hits.push(measure("black-pearl", name, velocity, &padded(&left), &padded(&right), rate as f64)?);
        }
    }
    Ok(hits)
}

/// The text of the first `<t>...</t>` in `text`, XML entities decoded.
fn tag(text: &str, t: &str) -> Option<String> {
    let start = text.find(&format!("<{t}>"))? + t.len() + 2;
    let end = start + text[start..].find(&format!("</{t}>"))?;
    let decoded = text[start..end].trim().replace("&lt;", "<").replace("&gt;", ">").replace("&quot;", "\"");
    Some(decoded.replace("&apos;", "'").replace("&amp;", "&"))
}
