//! Every Groove MIDI file (train and validation, 1,021 takes, about 12 hours) renders in
//! direct mode with the default map (auto), which plays all its notes: finite, within full
//! scale, as long as the song. Two worker threads.

use drumsim::kit::Kit;
use drumsim::render::{load_song, render_events, score_performance, RenderOptions, SAMPLE_RATE_HZ};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

fn midi_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            midi_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "mid") {
            out.push(path);
        }
    }
}

#[test]
fn every_groove_midi_file_renders() {
    let mut files = Vec::new();
    midi_files(&Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd"), &mut files);
    files.sort();
    assert_eq!(files.len(), 1021);
    let kit = Kit::builtin_default();
    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::new());
    let audio_s = Mutex::new(0.0f64);
    std::thread::scope(|s| {
        for _ in 0..2 {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(song) = files.get(i) else { break };
                // The default map (auto) plays every note of every take.
                let score = match load_song(song, &RenderOptions::default()).and_then(|(perf, map)| {
                    anyhow::ensure!(map.plays_all(&perf), "auto chose {}, which leaves notes out", map.source);
                    score_performance(&perf, &kit, &map)
                }) {
                    Ok(score) => score,
                    Err(e) => {
                        failures.lock().unwrap().push(format!("{}: {e:#}", song.display()));
                        continue;
                    }
                };
                let (mut samples, mut bad) = (0u64, 0u64);
                let rendered = render_events(
                    &kit,
                    &score.events,
                    score.duration_s,
                    |l, r| {
                        samples += l.len() as u64;
                        bad += l.iter().chain(r.iter()).filter(|v| !(v.is_finite() && v.abs() <= 1.0)).count() as u64;
                        Ok(())
                    },
                    |_| {},
                );
                let seconds = samples as f64 / SAMPLE_RATE_HZ as f64;
                if let Err(e) = rendered {
                    failures.lock().unwrap().push(format!("{}: {e:#}", song.display()));
                } else if bad > 0 || seconds < score.duration_s {
                    failures.lock().unwrap().push(format!(
                        "{}: {bad} bad samples, {seconds:.1} s of {:.1} s",
                        song.display(),
                        score.duration_s
                    ));
                }
                *audio_s.lock().unwrap() += seconds;
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    println!("rendered {:.2} hours of audio", audio_s.into_inner().unwrap() / 3600.0);
    assert!(failures.is_empty(), "{} of 1021 files failed:\n{}", failures.len(), failures.join("\n"));
}
