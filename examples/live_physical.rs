//! The live physical drummer against the offline physical render, on Groove MIDI validation
//! takes: recall, precision and timing of the body's contacts (a) offline with the whole song
//! planned at once and rehearsed, (b) offline planned at once but played straight through
//! (no rehearsal, as live must), (c) live: planned on the sliding window every 50 ms and
//! played as `drumsim live --sound physical` would (`perform::replay`).
//!
//! `cargo run --release --example live_physical [TAKE.mid ...] [--seconds S] [--lookahead-ms N]
//! [--live-only] [--verbose]` (`DRUMSIM_LAG=off` or `=FILE`: live play without the lag model, or with
//! another; with `--verbose`, `NEARBY=1` lists the contacts within 30 ms of each stray one)
//! (default: six validation takes, the first 30 s of each).

use drumsim::interaction::ContactMessage;
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library};
use drumsim::perform::matching::{match_contacts, onsets, Onset};
use drumsim::perform::replay::{replay, ReplaySettings};
use drumsim::perform::{play_with, RehearsalSettings};
use std::path::Path;

const TAKES: [&str; 6] = [
    "drummer1/session2/1_latin-chacarera_157_beat_3-4.mid",
    "drummer3/session1/39_jazz_120_beat_4-4.mid",
    "drummer1/session1/145_latin-brazilian-baiao_95_beat_4-4.mid",
    "drummer6/session3/1_rock_90_beat_4-4.mid",
    "drummer1/session1/17_jazz-funk_116_fill_4-4.mid",
    "drummer1/session1/126_funk-fast_125_beat_4-4.mid",
];

fn score(notes: &[Onset], msgs: &[ContactMessage]) -> (f64, f64, f64, f64, Vec<usize>, Vec<usize>) {
    let (of, played) = match_contacts(notes, msgs);
    let recall = played.iter().filter(|p| **p).count() as f64 / notes.len().max(1) as f64;
    let precision = of.iter().filter(|o| o.is_some()).count() as f64 / of.len().max(1) as f64;
    let errs: Vec<f64> =
        of.iter().zip(msgs).filter_map(|(o, m)| o.map(|i| 1e3 * (m.time_s as f64 - notes[i].time_s))).collect();
    let n = errs.len().max(1) as f64;
    let mean = errs.iter().sum::<f64>() / n;
    let sd = (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / n).sqrt();
    let missed = played.iter().enumerate().filter(|(_, p)| !**p).map(|(i, _)| i).collect();
    let spurious = of.iter().enumerate().filter(|(_, o)| o.is_none()).map(|(k, _)| k).collect();
    (recall, precision, mean, sd, missed, spurious)
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut seconds = 30.0;
    let mut lookahead_ms = f64::from(drumsim::live_body::DEFAULT_LOOKAHEAD_MS);
    let mut takes: Vec<String> = Vec::new();
    let mut verbose = false;
    let mut live_only = false;
    let mut plan_every_ms = 50.0;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--seconds" => seconds = it.next().unwrap().parse()?,
            "--lookahead-ms" => lookahead_ms = it.next().unwrap().parse()?,
            "--verbose" => verbose = true,
            "--live-only" => live_only = true,
            "--plan-every-ms" => plan_every_ms = it.next().unwrap().parse()?,
            t => takes.push(t.to_string()),
        }
    }
    if takes.is_empty() {
        takes = TAKES.iter().map(|s| s.to_string()).collect();
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd");
    let (kit, map) = (Kit::builtin_default(), NoteMap::builtin("roland-td").expect("a built-in map"));
    let settings = ReplaySettings {
        lookahead_s: lookahead_ms / 1e3,
        plan_every_s: plan_every_ms / 1e3,
        ..ReplaySettings::default()
    };
    let mut totals = [[0.0f64; 4]; 3];
    for take in &takes {
        let perf = read_file(&root.join(take), &ReadOptions { channel: 10 })?;
        let end = (perf.notes_end_s + 0.5).min(seconds);
        let notes: Vec<Onset> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < end - 0.1).collect();
        let predicted = model_hands(&HandModel::shipped(), &perf, &map);
        let planned = perform_planned(&perf, &map, &kit, &predicted, &shipped_library()?)?;
        let (rehearsed, straight) = match live_only {
            true => (vec![], vec![]),
            false => (
                play_with(&kit, &perf, &map, &planned, end, &RehearsalSettings::default())?.messages,
                play_with(&kit, &perf, &map, &planned, end, &RehearsalSettings { attempts: 0, ..Default::default() })?
                    .messages,
            ),
        };
        let live = replay(&kit, &map, HandModel::shipped(), shipped_library()?, &perf, end, &settings)?;
        let live_msgs: Vec<ContactMessage> = live
            .strikes
            .iter()
            .filter(|s| s.time_s >= -0.01)
            .map(|s| s.message_named(&live.surfaces[s.surface]))
            .collect();
        println!("{take} ({} notes, {end:.0} s):", notes.len());
        for (k, (name, msgs)) in
            [("offline, rehearsed", &rehearsed), ("offline, straight", &straight), ("live", &live_msgs)]
                .into_iter()
                .enumerate()
        {
            let (r, p, m, sd, missed, spurious) = score(&notes, msgs);
            println!(
                "  {name:20} recall {:6.2} %  precision {:6.2} %  timing {m:+5.2} / {sd:4.2} ms",
                100.0 * r,
                100.0 * p
            );
            for (j, v) in [r, p, m, sd].into_iter().enumerate() {
                totals[k][j] += v / takes.len() as f64;
            }
            if verbose && name != "offline, rehearsed" {
                println!("   {name}:");
                for i in missed {
                    println!("    missed {:7.3} s {}", notes[i].time_s, notes[i].piece);
                }
                for kk in spurious {
                    let c = &msgs[kk];
                    println!("    spurious {:7.3} s {} speed {:.2} limb {:?}", c.time_s, c.piece, c.speed_mps, c.limb);
                    if std::env::var_os("NEARBY").is_some() {
                        for o in msgs.iter().filter(|o| (o.time_s - c.time_s).abs() < 0.03) {
                            println!(
                                "      nearby {:7.4} s {} speed {:.2} limb {:?}",
                                o.time_s, o.piece, o.speed_mps, o.limb
                            );
                        }
                    }
                }
            }
        }
    }
    println!("mean over {} takes:", takes.len());
    for (k, name) in ["offline, rehearsed", "offline, straight", "live"].iter().enumerate() {
        let [r, p, m, sd] = totals[k];
        println!(
            "  {name:20} recall {:6.2} %  precision {:6.2} %  timing {m:+5.2} / {sd:4.2} ms",
            100.0 * r,
            100.0 * p
        );
    }
    Ok(())
}
