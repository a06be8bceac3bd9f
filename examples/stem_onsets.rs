//! How well `eval::onsets` finds strikes in the audio: a render's SONG.contacts.json (and
//! its hi-hat openness) sounded through the engine with stems, the onsets found in each
//! stem matched to the contacts (those within 5 ms on one piece are one sound) within 3 ms.
//!
//! `cargo run --release --example stem_onsets -- out/SONG.contacts.json` (default kit)
use drumsim::eval::onsets::stem_onsets;
use drumsim::interaction::{ContactMessage, Message};
use drumsim::kit::Kit;
use drumsim::sound::{Engine, EngineSettings, SoundEvent};

fn main() -> anyhow::Result<()> {
    let path = std::env::args().nth(1).expect("SONG.contacts.json");
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path)?)?;
    let kit = Kit::builtin_default();
    let fs = 48_000.0f32;
    let mut events = Vec::new();
    for h in v["hihat"].as_array().unwrap() {
        let m = Message::HiHat {
            time_s: h["time_s"].as_f64().unwrap() as f32,
            openness: h["openness"].as_f64().unwrap() as f32,
        };
        events.push(SoundEvent::from_message(&m, &kit, fs)?);
    }
    let mut truth: Vec<Vec<f64>> = vec![Vec::new(); kit.pieces.len()];
    for c in v["contacts"].as_array().unwrap() {
        let c: ContactMessage = serde_json::from_value(c.clone())?;
        let ev = SoundEvent::from_message(&Message::Contact(c.clone()), &kit, fs)?;
        if let drumsim::sound::SoundEventKind::Strike(s) = ev.kind {
            truth[s.piece].push(ev.at_sample as f64 / fs as f64);
        }
        events.push(ev);
    }
    events.sort_by_key(|e| e.at_sample);
    let block = 256;
    let mut engine =
        Engine::new(&kit, EngineSettings { sample_rate_hz: fs, max_block: block, event_capacity: 4096 }).with_stems();
    let lat = engine.latency_samples();
    let end = events.last().unwrap().at_sample as usize + 48_000 * 2;
    let mut stems: Vec<Vec<f32>> = vec![Vec::with_capacity(end); kit.pieces.len()];
    let (mut l, mut r) = (vec![0.0; block], vec![0.0; block]);
    let mut next = 0;
    drumsim::sound::denormals::with_flush_to_zero(|| {
        while (engine.sample_time() as usize) < end {
            let be = engine.sample_time() + block as u64;
            while next < events.len() && events[next].at_sample < be {
                engine.push(events[next]);
                next += 1;
            }
            engine.process(&mut l, &mut r);
            for (k, s) in stems.iter_mut().enumerate() {
                s.extend_from_slice(engine.stem(k));
            }
        }
    });
    let tol = 0.003;
    let (mut all_t, mut all_hit, mut all_d, mut all_fp) = (0, 0, 0, 0);
    let mut errs = Vec::new();
    for (k, piece) in kit.pieces.iter().enumerate() {
        let found: Vec<f64> = stem_onsets(&stems[k][lat..], fs as f64);
        // Contacts within 5 ms on one piece are one sound.
        let mut groups: Vec<f64> = Vec::new();
        for &t in &truth[k] {
            if groups.last().is_none_or(|g| t - g > 0.005) {
                groups.push(t);
            }
        }
        let mut used = vec![false; found.len()];
        let mut hit = 0;
        let mut missed = Vec::new();
        for &g in &groups {
            let best = (0..found.len())
                .filter(|&i| !used[i] && (found[i] - g).abs() <= tol)
                .min_by(|&a, &b| (found[a] - g).abs().total_cmp(&(found[b] - g).abs()));
            match best {
                Some(i) => {
                    used[i] = true;
                    hit += 1;
                    errs.push((found[i] - g) * 1e3);
                }
                None => missed.push(g),
            }
        }
        let fp: Vec<f64> = found.iter().zip(&used).filter(|(_, u)| !**u).map(|(t, _)| *t).collect();
        println!(
            "{:10} {} groups, {} found, {} hit, missed {:.3?} extra {:.3?}",
            piece.id,
            groups.len(),
            found.len(),
            hit,
            &missed[..missed.len().min(8)],
            &fp[..fp.len().min(8)]
        );
        all_t += groups.len();
        all_hit += hit;
        all_d += found.len();
        all_fp += fp.len();
    }
    errs.sort_by(f64::total_cmp);
    let n = errs.len();
    println!(
        "recall {:.2} % precision {:.2} %; onset - contact ms: p5 {:.2} median {:.2} p95 {:.2}",
        100.0 * all_hit as f64 / all_t as f64,
        100.0 * (1.0 - all_fp as f64 / all_d as f64),
        errs[n / 20],
        errs[n / 2],
        errs[n * 19 / 20]
    );
    Ok(())
}
