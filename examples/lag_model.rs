//! Learns the live physical drummer's lag model (`assets/lag-model.json`): how late the body's
//! stick contacts land against their notes when a song is played straight through (the
//! offline physical render without its rehearsal, as live play must), by piece, velocity and
//! the time since the same hand's previous note. Live play then aims each stroke that much
//! earlier (`perform::lag`).
//!
//! `cargo run --release --example lag_model -- [--seconds S] [--out FILE] [--live] TAKE.mid ...`
//! (`--live`: learn from live play on the sliding window, `perform::replay`, instead).
//! The shipped model: the 17 Groove MIDI training takes listed in the README ("The live
//! physical drummer"), 45 s of each, played straight through with live play's targets.

use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library};
use drumsim::perform::lag::{LagModel, LagSample};
use drumsim::perform::matching::{match_contacts, onsets, Onset};
use drumsim::perform::replay::{replay, ReplaySettings};
use drumsim::perform::targets::TargetSettings;
use drumsim::perform::{play_with, RehearsalSettings};
use std::path::{Path, PathBuf};

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut seconds, mut out, mut live) = (45.0, None::<PathBuf>, false);
    let mut takes = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--seconds" => seconds = it.next().unwrap().parse()?,
            "--out" => out = Some(it.next().unwrap().into()),
            "--live" => live = true,
            t => takes.push(t.to_string()),
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd");
    let (kit, map) = (Kit::builtin_default(), NoteMap::builtin("roland-td").expect("a built-in map"));
    let mut samples = Vec::new();
    for take in &takes {
        let path = if Path::new(take).is_file() { PathBuf::from(take) } else { root.join(take) };
        let perf = read_file(&path, &ReadOptions { channel: 10 })?;
        let end = (perf.notes_end_s + 0.5).min(seconds);
        let notes: Vec<Onset> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < end - 0.1).collect();
        let msgs = if live {
            let r =
                replay(&kit, &map, HandModel::shipped(), shipped_library()?, &perf, end, &ReplaySettings::default())?;
            r.strikes.iter().filter(|s| s.time_s >= -0.01).map(|s| s.message_named(&r.surfaces[s.surface])).collect()
        } else {
            let predicted = model_hands(&HandModel::shipped(), &perf, &map);
            let planned = perform_planned(&perf, &map, &kit, &predicted, &shipped_library()?)?;
            // Straight through, with live play's targets (the stick's angle held at each hit).
            let straight = RehearsalSettings { attempts: 0, targets: TargetSettings::live(), ..Default::default() };
            play_with(&kit, &perf, &map, &planned, end, &straight)?.messages
        };
        let (of, _) = match_contacts(&notes, &msgs);
        // The time since the same hand's previous contact that played a note.
        let mut last = [f64::NEG_INFINITY; 2];
        let before = samples.len();
        for (m, o) in msgs.iter().zip(&of) {
            let (Some(i), hand @ 0..=1) = (*o, m.limb as usize) else { continue };
            let t = notes[i].time_s;
            samples.push(LagSample {
                piece: notes[i].piece.clone(),
                velocity: notes[i].velocity,
                since_s: t - last[hand],
                late_s: m.time_s as f64 - t,
            });
            last[hand] = t;
        }
        println!("{take}: {} hand contacts on notes", samples.len() - before);
    }
    let model = LagModel::fit(&samples);
    let (sd_before, sd_after) = model.residual_sd(&samples);
    println!(
        "{} samples; timing sd {:.2} ms, {:.2} ms with the model (in sample)",
        samples.len(),
        sd_before * 1e3,
        sd_after * 1e3
    );
    println!("{}", model.table());
    if let Some(out) = out {
        std::fs::write(&out, model.to_json())?;
        println!("wrote {}", out.display());
    }
    Ok(())
}
