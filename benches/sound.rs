//! Speed of the synthesizer, as ratios measured in one process (the machines are shared).
//!
//! - "modal bank": one [`Bank`] of N ringing modes processing 512-sample blocks, beside a naive
//!   scalar reference (one mode at a time, a two-pole recursion summed into the output per
//!   sample). Throughput is in mode-samples.
//! - "stressed plate": the same bank of 1,024 modes running coupled through a plate's in-plane
//!   stress ([`Stress`]), as a cymbal does after a hard hit.
//! - "render 60 s": a 60-second Groove MIDI beat scored and rendered in direct mode through the
//!   functions `drumsim render` uses, into a sink that only checks the samples: with the
//!   voices on every core (as `drumsim render` runs) and on one (`DRUMSIM_THREADS=1`).
//! - "one strike": the Hertz contact of one snare and one crash strike.
//!
//! `cargo bench --bench sound` ends with a summary: ns per mode-sample, the ratio to the naive
//! reference, and the render's real-time factor (audio seconds per wall second) on every core
//! and on one.

use criterion::measurement::WallTime;
use criterion::{BenchmarkId, Criterion, SamplingMode, Throughput};
use drumsim::kit::Kit;
use drumsim::midi::NoteMap;
use drumsim::render::{render_events, score_file, RenderOptions, SAMPLE_RATE_HZ};
use drumsim::sound::bank::{Bank, Lane, LANES};
use drumsim::sound::denormals::with_flush_to_zero;
use drumsim::sound::stress::Stress;
use drumsim::sound::voice::Voice;
use drumsim::sound::Strike;
use std::collections::BTreeMap;
use std::hint::black_box;
use std::path::PathBuf;
use std::sync::Mutex;
use std::time::{Duration, Instant};

const BLOCK: usize = 512;
const MODE_COUNTS: [usize; 3] = [64, 256, 1024];
/// 59.97 s of a hip-hop beat at 92 bpm (drummer 3, session 2, take 26).
const SONG: &str = "drummer3/session2/26_hiphop_92_beat_4-4.mid";

/// Samples criterion takes of each benchmark.
const SAMPLES: usize = 10;

/// Seconds per iteration of each call criterion made, by benchmark name.
static TIMES: Mutex<BTreeMap<String, Vec<f64>>> = Mutex::new(BTreeMap::new());

/// Keep the time per iteration of one call for the summary.
fn record(name: &str, iters: u64, elapsed: Duration) -> Duration {
    let mut times = TIMES.lock().expect("bench timing lock");
    times.entry(name.to_string()).or_default().push(elapsed.as_secs_f64() / iters as f64);
    elapsed
}

/// Time `iters` runs of `f`, and keep the time per run for the summary.
fn timed(name: &str, iters: u64, mut f: impl FnMut()) -> Duration {
    let start = Instant::now();
    for _ in 0..iters {
        f();
    }
    record(name, iters, start.elapsed())
}

/// Median seconds per iteration over the measured samples of a benchmark (the last
/// [`SAMPLES`] calls; the ones before were warm-up), if it ran.
fn median_s(name: &str) -> Option<f64> {
    let times = TIMES.lock().expect("bench timing lock");
    let all = times.get(name)?;
    let mut t = all[all.len().saturating_sub(SAMPLES)..].to_vec();
    t.sort_by(f64::total_cmp);
    Some(t[t.len() / 2])
}

/// Mode frequencies spread like a kit piece's (50 Hz .. 16 kHz), undamped so no chunk sleeps.
fn coefficients(modes: usize) -> Vec<(f32, f32, f32)> {
    (0..modes)
        .map(|k| {
            let f = 50.0 * (320.0f64).powf(k as f64 / modes as f64);
            let w = 2.0 * std::f64::consts::PI * f / SAMPLE_RATE_HZ as f64;
            ((2.0 * w.cos()) as f32, 1.0, 1.0 / (1.0 + k as f32))
        })
        .collect()
}

fn ringing_bank(modes: usize) -> Bank {
    let coef = coefficients(modes);
    let gains: Vec<f32> = coef.iter().map(|c| c.2).collect();
    let mut bank = Bank::new(&gains, &[]);
    for (k, &(a1, a2, _)) in coef.iter().enumerate() {
        bank.set_coefficients(k, a1, a2);
        bank.set_state(k, 1e-3, 0.0);
    }
    bank
}

/// Modes of the stressed plate.
const STRESSED_MODES: usize = 1024;

/// [`ringing_bank`] as a bronze plate struck hard: the stress runs (and, undamped, never
/// stops).
fn stressed_bank(modes: usize) -> Bank {
    let mut bank = ringing_bank(modes);
    let freq: Vec<f64> = (0..modes).map(|k| 50.0 * (320.0f64).powf(k as f64 / modes as f64)).collect();
    let slope2: Vec<f64> = freq.iter().map(|f| 0.06 * f).collect();
    bank.set_stress(Stress::new(&vec![0.2; modes], &freq, &slope2, 5e8, SAMPLE_RATE_HZ as f64, 1));
    for k in 0..modes {
        bank.set_state(k, 2e-5, 0.0);
    }
    bank.wake_stretch();
    bank
}

/// The naive reference: each mode's recursion run over the block, one mode at a time.
#[derive(Clone, Copy)]
struct NaiveMode {
    a1: f32,
    a2: f32,
    gain: f32,
    y1: f32,
    y2: f32,
}

fn naive_process(modes: &mut [NaiveMode], out: &mut [f32]) {
    out.fill(0.0);
    for m in modes.iter_mut() {
        for o in out.iter_mut() {
            let y = m.a1 * m.y1 - m.a2 * m.y2;
            m.y2 = m.y1;
            m.y1 = y;
            *o += m.gain * y;
        }
    }
}

fn modal_bank(c: &mut Criterion) {
    let mut group = c.benchmark_group("modal bank");
    group.sample_size(SAMPLES).warm_up_time(Duration::from_millis(300)).measurement_time(Duration::from_secs(1));
    for modes in MODE_COUNTS {
        group.throughput(Throughput::Elements((modes * BLOCK) as u64));
        bench_bank(&mut group, BenchmarkId::new("bank", modes), &format!("bank/{modes}"), ringing_bank(modes));
        let mut out = vec![0.0f32; BLOCK];
        let mut naive: Vec<NaiveMode> = coefficients(modes)
            .into_iter()
            .map(|(a1, a2, gain)| NaiveMode { a1, a2, gain, y1: 1e-3, y2: 0.0 })
            .collect();
        group.bench_function(BenchmarkId::new("naive scalar", modes), |b| {
            b.iter_custom(|iters| {
                timed(&format!("naive/{modes}"), iters, || {
                    naive_process(black_box(&mut naive), &mut out);
                    black_box(&mut out);
                })
            })
        });
    }
    group.throughput(Throughput::Elements((STRESSED_MODES * BLOCK) as u64));
    bench_bank(
        &mut group,
        BenchmarkId::new("stressed plate", STRESSED_MODES),
        "stressed",
        stressed_bank(STRESSED_MODES),
    );
    group.finish();
}

/// Time `bank` over blocks of [`BLOCK`] samples, kept for the summary as `name`.
fn bench_bank(group: &mut criterion::BenchmarkGroup<'_, WallTime>, id: BenchmarkId, name: &str, mut bank: Bank) {
    let mut acc: Vec<Lane> = vec![[0.0; LANES]; BLOCK];
    let mut out = vec![0.0f32; BLOCK];
    group.bench_function(id, |b| {
        b.iter_custom(|iters| {
            timed(name, iters, || {
                out.fill(0.0);
                bank.process(&mut out, None, &mut acc);
                black_box(&mut out);
            })
        })
    });
}

fn gmd_path() -> PathBuf {
    let root = std::env::var_os("DRUMSIM_GMD")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("data/gmd"));
    root.join(SONG)
}

/// Score and render the song; returns seconds of audio.
fn render_song(kit: &Kit, map: &NoteMap, song: &std::path::Path) -> f64 {
    let opts = RenderOptions { map: map.name.clone(), ..RenderOptions::default() };
    let score = score_file(song, kit, map, &opts).expect("the song scores");
    let mut peak = 0.0f32;
    let (samples, non_finite) = render_events(
        kit,
        &score.events,
        score.duration_s,
        |l, r| {
            peak = l.iter().chain(r).fold(peak, |m, v| m.max(v.abs()));
            Ok(())
        },
        |_| {},
    )
    .expect("the song renders");
    assert!(non_finite == 0 && peak > 0.01 && peak <= 1.0, "render went wrong: peak {peak}");
    samples as f64 / SAMPLE_RATE_HZ as f64
}

fn render_60s(c: &mut Criterion) -> Option<f64> {
    let song = gmd_path();
    if !song.exists() {
        eprintln!("render 60 s: {} not found (set DRUMSIM_GMD); skipped", song.display());
        return None;
    }
    let kit = Kit::builtin_default();
    let map = NoteMap::load("roland-td").expect("built-in map");
    let audio_s = render_song(&kit, &map, &song);
    let mut group = c.benchmark_group("render 60 s");
    group.sample_size(SAMPLES).sampling_mode(SamplingMode::Flat).warm_up_time(Duration::from_millis(500));
    group.measurement_time(Duration::from_secs(4));
    group.bench_function("direct", |b| {
        b.iter_custom(|iters| timed("render", iters, || _ = black_box(render_song(&kit, &map, &song))))
    });
    // The same on one core. The bench sets the variable before its own render threads run.
    std::env::set_var("DRUMSIM_THREADS", "1");
    group.bench_function("direct, one core", |b| {
        b.iter_custom(|iters| timed("render1", iters, || _ = black_box(render_song(&kit, &map, &song))))
    });
    std::env::remove_var("DRUMSIM_THREADS");
    group.finish();
    Some(audio_s)
}

fn one_strike(c: &mut Criterion) {
    let kit = Kit::builtin_default();
    let mut group = c.benchmark_group("one strike");
    group.sample_size(SAMPLES).warm_up_time(Duration::from_millis(300)).measurement_time(Duration::from_secs(1));
    for (id, r_frac, mass_kg) in [("snare", 0.3, 0.045), ("crash", 0.9, 0.045), ("kick", 0.2, 0.12)] {
        let piece = kit.piece(id).expect("default kit piece");
        let voice = Voice::new(piece, SAMPLE_RATE_HZ as f32, BLOCK);
        let strike =
            Strike { piece: 0, speed_mps: 6.0, mass_kg, x_m: 0.0, y_m: -r_frac * piece.radius_m, hardness: 1.0 };
        group.bench_function(id, |b| {
            b.iter_custom(|iters| {
                let mut total = Duration::ZERO;
                for _ in 0..iters {
                    let mut v = voice.clone();
                    let start = Instant::now();
                    with_flush_to_zero(|| v.strike(black_box(&strike)));
                    total += start.elapsed();
                    black_box(&v);
                }
                record(&format!("strike/{id}"), iters, total)
            })
        });
    }
    group.finish();
}

fn summary(audio_s: Option<f64>) {
    println!("\nsummary (medians; ratios measured in this process):");
    for modes in MODE_COUNTS {
        if let (Some(bank), Some(naive)) = (median_s(&format!("bank/{modes}")), median_s(&format!("naive/{modes}"))) {
            let per = |s: f64| s * 1e9 / (modes * BLOCK) as f64;
            println!(
                "modal bank, {modes} modes: {:.3} ns per mode-sample; naive scalar {:.3} ns; {:.1}x faster",
                per(bank),
                per(naive),
                naive / bank
            );
        }
    }
    if let (Some(stressed), Some(free)) = (median_s("stressed"), median_s(&format!("bank/{STRESSED_MODES}"))) {
        println!(
            "stressed plate, {STRESSED_MODES} modes: {:.3} ns per mode-sample, {:.1}x the free bank",
            stressed * 1e9 / (STRESSED_MODES * BLOCK) as f64,
            stressed / free
        );
    }
    if let (Some(audio_s), Some(wall)) = (audio_s, median_s("render")) {
        let cores = drumsim::sound::offline::threads();
        println!(
            "render 60 s ({SONG}): {audio_s:.1} s of audio in {wall:.3} s, {:.0}x real time ({cores} cores)",
            audio_s / wall
        );
    }
    if let (Some(audio_s), Some(wall)) = (audio_s, median_s("render1")) {
        println!("render 60 s, one core: {audio_s:.1} s of audio in {wall:.3} s, {:.0}x real time", audio_s / wall);
    }
    for id in ["snare", "crash", "kick"] {
        if let Some(s) = median_s(&format!("strike/{id}")) {
            println!("one strike, {id}: {:.1} us", s * 1e6);
        }
    }
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    modal_bank(&mut c);
    let audio_s = render_60s(&mut c);
    one_strike(&mut c);
    c.final_summary();
    summary(audio_s);
}
