//! Trace live play around a moment of a Groove MIDI take: each hand's planned tip every
//! 10 ms from 160 ms before TIME_S, in the whole-song plan and in each live window plan made
//! from 350 ms before it (a window's plan knows the notes played by its moment).
//! `cargo run --release --example live_plans TAKE.mid TIME_S`; with `BODY=HAND` (0 left,
//! 1 right) instead: live play on the simulated clock (`perform::replay_observed`), that
//! hand's target and simulated tip every 4 ms within 200 ms of TIME_S, and the strikes.
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library};
use drumsim::motion::window::WindowMotion;
use std::path::Path;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let at: f64 = a[2].parse().unwrap();
    let kit = Kit::builtin_default();
    let map = NoteMap::builtin("roland-td").unwrap();
    let perf = read_file(Path::new(&a[1]), &ReadOptions { channel: 10 }).unwrap();
    let predicted = model_hands(&HandModel::shipped(), &perf, &map);
    let planned = perform_planned(&perf, &map, &kit, &predicted, &shipped_library().unwrap()).unwrap();
    let show = |name: &str, h: &drumsim::motion::plan::PlannedHands| {
        for hand in 0..2 {
            let notes: Vec<String> = h
                .notes(hand)
                .filter(|n| (n.time_s - at).abs() < 1.3)
                .map(|n| format!("{:.3} {} v{} {:.2}m/s", n.time_s, kit.pieces[n.piece].id, n.velocity, n.speed_mps))
                .collect();
            println!("{name} hand {hand}: {}", notes.join(", "));
            let mut line = String::new();
            for k in -16..=3 {
                let t = at + k as f64 * 0.01;
                let p = h.tip(hand, t);
                line += &format!(" {:+.0}:({:.2},{:.2},{:.2})", k * 10, p[0], p[1], p[2]);
            }
            println!("   {line}");
        }
    };
    show("offline", &planned.hands);
    if std::env::var_os("BODY").is_some() {
        let hand: usize = std::env::var("BODY").unwrap().parse().unwrap();
        let lib = shipped_library().unwrap();
        let settings = drumsim::perform::replay::ReplaySettings::default();
        let mut n = 0u64;
        let r = drumsim::perform::replay::replay_observed(
            &kit,
            &map,
            HandModel::shipped(),
            lib,
            &perf,
            at + 0.1,
            &settings,
            &mut |d, t, tg| {
                n += 1;
                if (t - at).abs() < 0.2 && n.is_multiple_of(40) {
                    let tip = d.tips(drumsim::body::sim::Mode::Himc)[hand];
                    let g = tg[hand].tip;
                    println!(
                        "{:+5.0} ms target ({:.3},{:.3},{:.3}) sim ({:.3},{:.3},{:.3})",
                        (t - at) * 1e3,
                        g.x,
                        g.y,
                        g.z,
                        tip.x,
                        tip.y,
                        tip.z
                    );
                }
            },
        )
        .unwrap();
        for s in r.strikes.iter().filter(|s| (s.time_s - at).abs() < 0.2) {
            println!("strike {:.4} {} side {} {:.2} m/s", s.time_s, r.surfaces[s.surface], s.side, s.speed_mps);
        }
        return;
    }
    let mut w = WindowMotion::new(kit.clone(), map.clone(), HandModel::shipped(), shipped_library().unwrap(), 0.25);
    w.plan_upper_body(false);
    let mut events = perf.events.iter().peekable();
    let mut now = 0.0;
    while now < at + 0.05 {
        now += 0.05;
        while let Some(e) = events.next_if(|e| e.time_s <= now) {
            w.push(*e);
        }
        let p = w.plan(now).unwrap();
        if now > at - 0.35 {
            show(&format!("plan@{now:.2}"), &p.hands);
        }
    }
}
