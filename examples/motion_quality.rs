//! What an animator checks, over Groove MIDI takes (issue 16; `src/eval/motion_quality.rs`):
//! `cargo run --release --example motion_quality [TAKE.mid ...]` (default: every sixth
//! validation take). `KIT=rearranged` plays another kit; `JSON=1` prints each take's figures, `KNEES=1` each knee's turn clear of the drums.

use drumsim::eval::motion_quality::{measure_take, MotionQuality};
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library};
use drumsim::motion::rig::Rig;
use drumsim::motion::shells::shells;
use std::path::Path;

fn main() {
    let mut takes: Vec<String> = std::env::args().skip(1).collect();
    if takes.is_empty() {
        let info = std::fs::read_to_string("data/gmd/info.csv").expect("data/gmd/info.csv");
        takes = info
            .lines()
            .skip(1)
            .filter(|l| l.ends_with(",validation"))
            .step_by(6)
            .map(|l| format!("data/gmd/{}", l.split(',').nth(7).unwrap()))
            .collect();
    }
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::load(Path::new(&std::env::var("KIT").unwrap_or("default".into()))).unwrap();
    let (model, library, rig) = (HandModel::shipped(), shipped_library().unwrap(), Rig::default());
    let mut all = MotionQuality::default();
    let mut chest = Vec::new();
    for take in &takes {
        let perf = read_file(Path::new(take), &ReadOptions { channel: 10 }).unwrap();
        let (q, toms) = measure_take(&perf, &map, &kit, &model, &library, &rig).unwrap();
        if std::env::var_os("KNEES").is_some() {
            let planned = perform_planned(&perf, &map, &kit, &model_hands(&model, &perf, &map), &library).unwrap();
            let a = drumsim::motion::body_ik::knee_angles(&rig, &planned.motion, &shells(&kit));
            println!("  knee turns {:?} degrees", a.map(|x| x.map(f32::to_degrees)));
        }
        if toms {
            chest.extend(q.chest_follows_hands);
        }
        if std::env::var_os("JSON").is_some() {
            println!("{}", serde_json::json!({"take": take, "toms": toms, "quality": q}));
        } else {
            println!(
                "{take}: turn {:.0} deg ({} over 45), wrist {:.1} cm ({} over 6), body {:.1} cm ({} frames), kit {:.1} cm ({} frames), through cymbals {}, legs {:.1} cm ({} frames), chest {:?}, ghost/accent {:?}, blinks {:.1}/min",
                q.max_turn_deg, q.turns_over_45, q.max_wrist_step_m * 100.0, q.wrist_steps_over_6cm,
                q.deepest_in_body_m * 100.0, q.frames_in_body, q.deepest_arm_in_kit_m * 100.0, q.frames_arm_in_kit,
                q.frames_stick_through_cymbal, q.deepest_leg_in_kit_m * 100.0, q.frames_leg_in_kit,
                q.chest_follows_hands, q.ghost_over_accent, q.blinks_per_min
            );
        }
        all.merge(&q);
    }
    chest.sort_by(f32::total_cmp);
    println!("{} takes, {} frames:\n{}", takes.len(), all.frames, serde_json::to_string_pretty(&all).unwrap());
    println!("chest-hands correlation over takes with toms: {chest:?}");
}
