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
use drumsim::perform::targets::TargetSettings;
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

/// Of the hand contacts matched to notes: the share struck at under half the speed their
/// note's velocity asks (the kit's speed map), and the median of speed / asked.
fn speeds(kit: &Kit, notes: &[Onset], msgs: &[ContactMessage]) -> (f64, f64, f64) {
    let (of, _) = match_contacts(notes, msgs);
    let pairs: Vec<(f64, f64)> = of
        .iter()
        .zip(msgs)
        .filter(|(_, m)| {
            !matches!(m.limb, drumsim::interaction::Limb::RightFoot | drumsim::interaction::Limb::LeftFoot)
        })
        .filter_map(|(o, m)| o.map(|i| (f64::from(notes[i].velocity), f64::from(m.speed_mps))))
        .collect();
    let mut ratios: Vec<f64> = of
        .iter()
        .zip(msgs)
        .filter(|(_, m)| {
            !matches!(m.limb, drumsim::interaction::Limb::RightFoot | drumsim::interaction::Limb::LeftFoot)
        })
        .filter_map(|(o, m)| o.map(|i| f64::from(m.speed_mps / kit.strike.speed_for_velocity(notes[i].velocity))))
        .collect();
    ratios.sort_by(f64::total_cmp);
    let soft = ratios.iter().filter(|r| **r < 0.5).count() as f64 / ratios.len().max(1) as f64;
    (soft, ratios.get(ratios.len() / 2).copied().unwrap_or(0.0), spearman(&pairs))
}

/// Spearman's rank correlation of the pairs (ties ranked by their mean rank).
fn spearman(pairs: &[(f64, f64)]) -> f64 {
    let rank = |v: Vec<f64>| {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|&a, &b| v[a].total_cmp(&v[b]));
        let mut r = vec![0.0; v.len()];
        let mut i = 0;
        while i < idx.len() {
            let mut j = i;
            while j + 1 < idx.len() && v[idx[j + 1]] == v[idx[i]] {
                j += 1;
            }
            for k in i..=j {
                r[idx[k]] = 0.5 * (i + j) as f64;
            }
            i = j + 1;
        }
        r
    };
    let (a, b) = (rank(pairs.iter().map(|p| p.0).collect()), rank(pairs.iter().map(|p| p.1).collect()));
    let n = a.len().max(1) as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let cov: f64 = a.iter().zip(&b).map(|(x, y)| (x - ma) * (y - mb)).sum();
    let (va, vb): (f64, f64) = (a.iter().map(|x| (x - ma).powi(2)).sum(), b.iter().map(|y| (y - mb).powi(2)).sum());
    cov / (va * vb).sqrt().max(1e-12)
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
                play_with(
                    &kit,
                    &perf,
                    &map,
                    &planned,
                    end,
                    &RehearsalSettings { attempts: 0, targets: TargetSettings::live(), ..Default::default() },
                )?
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
            let (soft, ratio, rho) = speeds(&kit, &notes, msgs);
            println!(
                "  {name:20} recall {:6.2} %  precision {:6.2} %  timing {m:+5.2} / {sd:4.2} ms  hand strokes \
                 under half the asked speed {:5.2} %, median speed / asked {ratio:.2}, velocity-speed Spearman {rho:.3}",
                100.0 * r,
                100.0 * p,
                100.0 * soft
            );
            for (j, v) in [r, p, m, sd].into_iter().enumerate() {
                totals[k][j] += v / takes.len() as f64;
            }
            if verbose && name != "offline, rehearsed" {
                println!("   {name}:");
                let (of, _) = match_contacts(&notes, msgs);
                for (o, m) in of.iter().zip(msgs.iter()) {
                    if let Some(i) = o {
                        let asked = kit.strike.speed_for_velocity(notes[*i].velocity);
                        if m.speed_mps < 0.5 * asked && (m.limb as u8) < 2 {
                            println!(
                                "    soft {:7.3} s {} vel {} speed {:.2} of {:.2} limb {:?}",
                                notes[*i].time_s, notes[*i].piece, notes[*i].velocity, m.speed_mps, asked, m.limb
                            );
                        }
                    }
                }
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
