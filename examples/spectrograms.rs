//! Spectrograms of drumsim's kit beside recorded kits, one PNG per stroke: three panels
//! left to right, drumsim (default kit, or `KIT=NAME|FILE`), FluidR3 GM, The Black Pearl (a black panel where a
//! kit lacks the stroke). Each panel is 1.5 s from 10 ms before the hit (x) by 50 Hz to
//! 20 kHz on a log scale (y, high at the top), 80 dB of level from black through red and
//! yellow to white, velocity 110.
//!
//! ```sh
//! DRUMSIM_RECORDED_WAVS=/tmp/recorded cargo run --release --example recorded_kits -- /tmp/rk.json
//! cargo run --release --example spectrograms -- /tmp/recorded docs/spectrograms
//! ```

use anyhow::{Context, Result};
use drumsim::audition;
use drumsim::eval::audio::fft;
use drumsim::kit::Kit;
use std::path::{Path, PathBuf};

const STROKES: [&str; 7] = ["snare", "kick", "tom1", "hihat closed", "hihat open", "crash bow", "ride bow"];
const VELOCITY: u8 = 110;
const SECONDS: f64 = 1.5;
const WIDTH: usize = 300;
const HEIGHT: usize = 240;
const GAP: usize = 6;
const FFT: usize = 2048;
const RANGE_DB: f64 = 80.0;

fn main() -> Result<()> {
    let mut args = std::env::args().skip(1);
    let recorded = PathBuf::from(args.next().context("usage: spectrograms RECORDED_WAVS_DIR OUT_DIR")?);
    let out = PathBuf::from(args.next().unwrap_or_else(|| "docs/spectrograms".into()));
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    // KIT=NAME|FILE draws another kit beside the recorded ones.
    let kit = Kit::load(std::path::Path::new(&std::env::var("KIT").unwrap_or("default".into())))?;
    let strokes = audition::strokes(&kit);
    for name in STROKES {
        let stroke = strokes
            .iter()
            .find(|s| s.name == name)
            .with_context(|| format!("kit {} has no stroke {name}", kit.name))?;
        let (l, r, _) = audition::hit(&kit, stroke, VELOCITY, SECONDS, 0)?;
        let ours = mono(&l, &r);
        let mut panels = vec![spectrogram(&ours, audition::SAMPLE_RATE_HZ as f64)];
        for kit_dir in ["fluidr3", "black-pearl"] {
            let path = recorded.join(kit_dir).join(format!("{name}-{VELOCITY}.wav"));
            panels.push(match read(&path)? {
                Some((x, rate)) => spectrogram(&x, rate),
                None => vec![0.0; WIDTH * HEIGHT],
            });
        }
        let file = out.join(format!("{}.png", name.replace(' ', "-")));
        write_png(&file, &panels)?;
        println!("wrote {}", file.display());
    }
    Ok(())
}

fn mono(l: &[f32], r: &[f32]) -> Vec<f32> {
    l.iter().zip(r).map(|(a, b)| 0.5 * (a + b)).collect()
}

/// A recorded hit's WAV as mono, or `None` when the kit has no such stroke.
fn read(path: &Path) -> Result<Option<(Vec<f32>, f64)>> {
    if !path.exists() {
        return Ok(None);
    }
    let mut reader = hound::WavReader::open(path).with_context(|| format!("reading {}", path.display()))?;
    let spec = reader.spec();
    let x: Vec<f32> = reader.samples::<f32>().collect::<Result<_, _>>()?;
    let ch = spec.channels as usize;
    let m = x.chunks(ch).map(|c| c.iter().sum::<f32>() / ch as f32).collect();
    Ok(Some((m, spec.sample_rate as f64)))
}

/// Level in dB re the loudest cell, WIDTH x HEIGHT, row 0 at 20 kHz.
fn spectrogram(x: &[f32], rate: f64) -> Vec<f64> {
    let mut cells = vec![f64::MIN; WIDTH * HEIGHT];
    let hop = SECONDS * rate / WIDTH as f64;
    for col in 0..WIDTH {
        let start = (col as f64 * hop) as usize;
        let (mut re, mut im) = (vec![0.0; FFT], vec![0.0; FFT]);
        for (i, r) in re.iter_mut().enumerate() {
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / FFT as f64).cos();
            *r = x.get(start + i).copied().unwrap_or(0.0) as f64 * w;
        }
        fft(&mut re, &mut im);
        for row in 0..HEIGHT {
            // Log frequency: row 0 is 20 kHz, the last row 50 Hz; each cell the strongest bin
            // it covers.
            let f_at = |r: f64| 50.0 * (20_000.0f64 / 50.0).powf(1.0 - r / HEIGHT as f64);
            let (hi, lo) = (f_at(row as f64), f_at(row as f64 + 1.0));
            let (a, b) = (
                (lo * FFT as f64 / rate) as usize,
                ((hi * FFT as f64 / rate) as usize).max((lo * FFT as f64 / rate) as usize + 1),
            );
            let p = (a..b.min(FFT / 2)).map(|k| re[k] * re[k] + im[k] * im[k]).fold(1e-30, f64::max);
            cells[row * WIDTH + col] = 10.0 * p.log10();
        }
    }
    let top = cells.iter().cloned().fold(f64::MIN, f64::max);
    cells.iter().map(|c| ((c - top + RANGE_DB) / RANGE_DB).clamp(0.0, 1.0)).collect()
}

/// Black -> red -> yellow -> white.
fn colour(v: f64) -> [u8; 3] {
    let r = (v * 3.0).min(1.0);
    let g = (v * 3.0 - 1.0).clamp(0.0, 1.0);
    let b = (v * 3.0 - 2.0).clamp(0.0, 1.0);
    [(r * 255.0) as u8, (g * 255.0) as u8, (b * 255.0) as u8]
}

fn write_png(path: &Path, panels: &[Vec<f64>]) -> Result<()> {
    let width = panels.len() * WIDTH + (panels.len() - 1) * GAP;
    let mut rgb = vec![96u8; width * HEIGHT * 3];
    for (p, panel) in panels.iter().enumerate() {
        for row in 0..HEIGHT {
            for col in 0..WIDTH {
                let x = p * (WIDTH + GAP) + col;
                let i = (row * width + x) * 3;
                rgb[i..i + 3].copy_from_slice(&colour(panel[row * WIDTH + col]));
            }
        }
    }
    let file = std::fs::File::create(path).with_context(|| format!("writing {}", path.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), width as u32, HEIGHT as u32);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()?.write_image_data(&rgb)?;
    Ok(())
}
