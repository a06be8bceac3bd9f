//! The physical performance of Groove MIDI takes, measured as `drumsim eval` would: hand
//! notes hit by a contact within 10 ms, spurious contacts, timing, speed against velocity.
//! `cargo run --release --example physical_probe [TAKE.mid ...]` (default: a funk groove).

use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions, Zone};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library};
use drumsim::perform::matching::{match_contacts, onsets};
use drumsim::perform::play_with;
use std::path::Path;

/// Pedal notes on `piece`: hit (`hit` true) or all.
fn count(notes: &[drumsim::perform::matching::Onset], played: &[bool], piece: &str, hit: bool) -> usize {
    notes.iter().zip(played).filter(|(o, p)| o.zone == Zone::Pedal && o.piece == piece && (**p || !hit)).count()
}

fn main() {
    let mut takes: Vec<String> = std::env::args().skip(1).collect();
    if takes.is_empty() {
        takes.push("data/gmd/drummer1/session1/1_funk_80_beat_4-4.mid".into());
    }
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::load(Path::new(&std::env::var("KIT").unwrap_or("default".into()))).unwrap();
    let model = HandModel::shipped();
    let library = shipped_library().unwrap();
    for take in takes {
        let perf = read_file(Path::new(&take), &ReadOptions { channel: 10 }).unwrap();
        let predicted = model_hands(&model, &perf, &map);
        let planned = perform_planned(&perf, &map, &kit, &predicted, &library).unwrap();
        let started = std::time::Instant::now();
        let mut settings = drumsim::perform::RehearsalSettings::default();
        if let Some(a) = std::env::var("ATTEMPTS").ok().and_then(|v| v.parse().ok()) {
            settings.attempts = a;
        }
        if let Some(a) = std::env::var("AIM_MM").ok().and_then(|v| v.parse::<f32>().ok()) {
            settings.aim_tolerance_m = a / 1e3;
        }
        if let Some(a) = std::env::var("SNAP").ok().and_then(|v| v.parse().ok()) {
            settings.snapshot_every = a;
        }
        // UNTIL=S plays the first S seconds only (the notes after them are not counted).
        let until = std::env::var("UNTIL").ok().and_then(|v| v.parse::<f64>().ok()).unwrap_or(f64::INFINITY);
        let mut take_ = play_with(&kit, &perf, &map, &planned, perf.notes_end_s.min(until) + 0.5, &settings).unwrap();
        // Contacts after the cut-off belong to notes that are not counted.
        let keep: Vec<bool> = take_.messages.iter().map(|m| (m.time_s as f64) < until).collect();
        let mut it = keep.iter();
        take_.messages.retain(|_| *it.next().unwrap());
        let mut it = keep.iter();
        take_.strikes.retain(|_| *it.next().unwrap());
        let wall = started.elapsed().as_secs_f64();
        let all: Vec<_> = onsets(&perf, &map).into_iter().filter(|o| o.time_s < until).collect();
        let hand = all.clone();
        let (of, played) = match_contacts(&hand, &take_.messages);
        let hit = played.iter().filter(|p| **p).count();
        let spurious: Vec<_> = of.iter().enumerate().filter(|(_, o)| o.is_none()).map(|(i, _)| i).collect();
        let mut errs = Vec::new();
        let mut first = vec![None; hand.len()];
        for (k, o) in of.iter().enumerate() {
            if let Some(i) = *o {
                if first[i].is_none() {
                    first[i] = Some(k);
                    errs.push((take_.messages[k].time_s as f64 - hand[i].time_s) * 1e3);
                }
            }
        }
        let mean = errs.iter().sum::<f64>() / errs.len().max(1) as f64;
        let sd = (errs.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / errs.len().max(1) as f64).sqrt();
        if std::env::var_os("JSON").is_none() {
            println!(
            "{take}: {:.1} s in {wall:.1} s ({:.1}x real time); notes {} hit {:.2} % (kick {}/{}, hi-hat pedal {}/{}), contacts {} spurious {} ({:.2} %); timing {mean:+.2} / sd {sd:.2} ms; {} notes rehearsed, {} replays {:?}; sank {:.1} mm, energy {:.0} J, finite {}",
            perf.notes_end_s,
            perf.notes_end_s / wall,
            hand.len(),
            100.0 * hit as f64 / hand.len().max(1) as f64,
            count(&hand, &played, "kick", true),
            count(&hand, &played, "kick", false),
            count(&hand, &played, "hihat", true),
            count(&hand, &played, "hihat", false),
            of.len(),
            spurious.len(),
            100.0 * spurious.len() as f64 / of.len().max(1) as f64,
            take_.rehearsed,
            take_.replays,
            take_.reasons,
            take_.max_penetration_m * 1e3,
            take_.max_energy_j,
            take_.finite
        );
        }
        if std::env::var_os("SPUR").is_some() {
            // One JSON line per spurious contact and per missed note, for a split-wide tally.
            let hand_notes = |h: usize| {
                planned
                    .hands
                    .notes(h)
                    .map(|n| (n.time_s, kit.pieces[n.piece].id.clone(), n.velocity))
                    .collect::<Vec<_>>()
            };
            let hn = [hand_notes(0), hand_notes(1)];
            let around = |h: usize, t: f64| {
                let v = &hn[h];
                let k = v.partition_point(|n| n.0 <= t);
                let prev = k.checked_sub(1).map(|i| (1e3 * (v[i].0 - t), v[i].1.clone(), v[i].2));
                let next = v.get(k).map(|n| (1e3 * (n.0 - t), n.1.clone(), n.2));
                (prev, next)
            };
            for &k in &spurious {
                let (s, m) = (&take_.strikes[k], &take_.messages[k]);
                let base = m.piece.strip_suffix("_rim").unwrap_or(&m.piece);
                let near = hand
                    .iter()
                    .filter(|o| o.piece == base)
                    .map(|o| 1e3 * (m.time_s as f64 - o.time_s))
                    .min_by(|a, b| a.abs().total_cmp(&b.abs()));
                let (prev, next) = if s.side < 2 { around(s.side, m.time_s as f64) } else { (None, None) };
                println!(
                    "{}",
                    serde_json::json!({"kind": "spur", "take": take, "t": m.time_s, "piece": m.piece, "side": s.side, "speed": m.speed_mps, "from_tip": s.from_tip_m, "near_ms": near, "prev": prev, "next": next})
                );
            }
            for (o, _) in hand.iter().zip(&played).filter(|(_, p)| !**p) {
                let near = take_
                    .messages
                    .iter()
                    .filter(|m| m.piece == o.piece || m.piece.strip_suffix("_rim") == Some(o.piece.as_str()))
                    .map(|m| 1e3 * (m.time_s as f64 - o.time_s))
                    .min_by(|a, b| a.abs().total_cmp(&b.abs()));
                let h = (0..2).find(|&h| hn[h].iter().any(|n| (n.0 - o.time_s).abs() < 1e-6 && n.1 == o.piece));
                let (prev, _) = h.map_or((None, None), |h| around(h, o.time_s - 1e-6));
                println!(
                    "{}",
                    serde_json::json!({"kind": "miss", "take": take, "t": o.time_s, "piece": o.piece, "zone": format!("{:?}", o.zone), "vel": o.velocity, "hand": h, "near_ms": near, "prev": prev})
                );
            }
        }
        if std::env::var_os("JSON").is_some() {
            // One line per take with everything a split-wide figure needs.
            let mut vel_speed = Vec::new();
            let mut ipd_mm = Vec::new();
            // Each IPD's piece, zone, how far from the tip its contact was (m), limb, and the miss
            // toward the drummer (radial, mm) and across that way (mm).
            let mut ipd_of = Vec::new();
            for (i, k) in first.iter().enumerate() {
                let Some(k) = *k else { continue };
                let m = &take_.messages[k];
                let part = take_.strikes[k].from_tip_m;
                vel_speed.push((
                    hand[i].velocity,
                    m.speed_mps,
                    format!("{:?}", m.limb),
                    m.piece.ends_with("_rim"),
                    format!("{:?}", hand[i].zone),
                    part,
                ));
                let stick =
                    matches!(m.limb, drumsim::interaction::Limb::LeftHand | drumsim::interaction::Limb::RightHand);
                if let (true, Some(piece)) = (stick, kit.piece(&hand[i].piece).filter(|p| p.id == m.piece)) {
                    let miss = drumsim::kit::strike_miss(&kit, piece, hand[i].zone, [m.x_m, m.y_m]);
                    ipd_mm.push(1e3 * miss.distance_m);
                    ipd_of.push((
                        m.piece.clone(),
                        format!("{:?}", hand[i].zone),
                        part,
                        format!("{:?}", m.limb),
                        1e3 * miss.radial_m,
                        1e3 * miss.across_m,
                    ));
                }
            }
            let line = serde_json::json!({
                "take": take, "seconds": perf.notes_end_s, "wall_s": wall, "notes": hand.len(), "hit": hit,
                "contacts": of.len(), "spurious": spurious.len(), "timing_ms": errs,
                "vel_speed": vel_speed, "ipd_mm": ipd_mm, "ipd_of": ipd_of, "sank_mm": take_.max_penetration_m * 1e3,
                "energy_j": take_.max_energy_j, "replays": take_.replays, "reasons": take_.reasons, "rehearsed": take_.rehearsed, "finite": take_.finite, "deepest_at": take_.deepest_at,
            });
            println!("{line}");
            continue;
        }
        if std::env::var_os("DIAG").is_some() {
            // Why notes were missed and where spurious contacts came from.
            let near_piece = |t: f64, piece: &str, w: f64| {
                take_
                    .messages
                    .iter()
                    .filter(|m| {
                        (m.time_s as f64 - t).abs() <= w
                            && (m.piece == piece || m.piece.strip_suffix("_rim") == Some(piece))
                    })
                    .count()
            };
            let (mut timing, mut other, mut none) = (0, 0, 0);
            for (o, _) in hand.iter().zip(&played).filter(|(_, p)| !**p) {
                if near_piece(o.time_s, &o.piece, 0.04) > 0 {
                    timing += 1;
                } else if take_.messages.iter().any(|m| (m.time_s as f64 - o.time_s).abs() <= 0.01) {
                    other += 1;
                } else {
                    none += 1;
                }
            }
            let (mut bounce, mut graze) = (0, 0);
            let mut by_piece = std::collections::BTreeMap::<String, usize>::new();
            for &k in &spurious {
                let m = &take_.messages[k];
                let base = m.piece.strip_suffix("_rim").unwrap_or(&m.piece);
                if hand.iter().any(|o| o.piece == base && (o.time_s - m.time_s as f64).abs() <= 0.06) {
                    bounce += 1;
                } else {
                    graze += 1;
                    *by_piece.entry(m.piece.clone()).or_default() += 1;
                }
            }
            // Spurious contacts by what touched: the bead (tip) or the shaft, and by speed.
            let mut kinds = std::collections::BTreeMap::<String, usize>::new();
            for &k in &spurious {
                let (s, m) = (&take_.strikes[k], &take_.messages[k]);
                let part = if s.side >= 2 {
                    "foot"
                } else if s.from_tip_m < 0.012 {
                    "bead"
                } else {
                    "shaft"
                };
                let base = m.piece.strip_suffix("_rim").unwrap_or(&m.piece);
                let near = hand.iter().any(|o| o.piece == base && (o.time_s - m.time_s as f64).abs() <= 0.06);
                let speed = if m.speed_mps < 0.5 {
                    "slow"
                } else if m.speed_mps < 2.0 {
                    "mid"
                } else {
                    "fast"
                };
                *kinds.entry(format!("{part}/{}/{speed}", if near { "near" } else { "far" })).or_default() += 1;
            }
            println!("  spurious kinds {kinds:?}");
            println!("  missed: off-time(<=40ms on piece) {timing}, other piece only {other}, nothing {none}; spurious: near a note on its piece {bounce}, no note near {graze} {by_piece:?}");
        }
        if std::env::var_os("VERBOSE").is_some() {
            println!("  deepest: {:?}", take_.deepest_at);
            for &k in spurious.iter().take(15) {
                let m = &take_.messages[k];
                let near = hand
                    .iter()
                    .filter(|o| o.piece == m.piece)
                    .min_by(|a, b| (a.time_s - m.time_s as f64).abs().total_cmp(&(b.time_s - m.time_s as f64).abs()));
                let dt = near.map_or(f64::NAN, |o| (m.time_s as f64 - o.time_s) * 1e3);
                println!(
                    "  spurious {:.3} s {} {:.2} m/s limb {:?}; nearest note on it {dt:+.1} ms",
                    m.time_s, m.piece, m.speed_mps, m.limb
                );
            }
            for (o, _) in hand.iter().zip(&played).filter(|(_, p)| !**p).take(25) {
                let near: Vec<String> = take_
                    .messages
                    .iter()
                    .filter(|m| (m.time_s as f64 - o.time_s).abs() < 0.05)
                    .map(|m| {
                        format!(
                            "{}{:+.1}ms/{:?}/{:.2}",
                            m.piece,
                            (m.time_s as f64 - o.time_s) * 1e3,
                            m.limb,
                            m.speed_mps
                        )
                    })
                    .collect();
                println!("  missed {:.3} s {} {:?} v{}: {near:?}", o.time_s, o.piece, o.zone, o.velocity);
            }
        }
    }
}
