//! The live avatar's sliding-window motion stage against the whole-song motion of a render,
//! on Groove MIDI validation takes played as if live: notes arrive at their times, a plan is
//! made every 50 ms, the avatar shows `now - lookahead` at 60 fps with the fade between plans.
//! For each lookahead: where the shown stick tip is at each hand note's time against the
//! render's (a stroke not prepared in time lands away from its strike point), the tip's
//! distance over all shown frames, and the time one plan takes.
//! Run: `cargo run --release --example live_window [STEP]` (every STEP-th validation take,
//! default 12).

use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library};
use drumsim::motion::window::{shown_frame, WindowMotion, WindowPlan};
use std::path::Path;
use std::time::Instant;

const GMD: &str = "data/gmd";

fn pct(v: &mut [f64], p: f64) -> f64 {
    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
    v[((v.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let step: usize = std::env::args().nth(1).map(|s| s.parse().unwrap()).unwrap_or(12);
    let info = std::fs::read_to_string(Path::new(GMD).join("info.csv")).unwrap();
    let files: Vec<_> = info
        .lines()
        .skip(1)
        .filter(|l| l.ends_with(",validation"))
        .step_by(step)
        .map(|l| Path::new(GMD).join(l.split(',').nth(7).unwrap()))
        .collect();
    let map = NoteMap::builtin("roland-td").unwrap();
    let kit = Kit::builtin_default();
    let model = HandModel::shipped();
    let lib = shipped_library().unwrap();
    println!("{} takes, 60 s at most of each", files.len());
    println!("lookahead_ms | nearer tip to the strike point at each note: median / p95 / >2 cm | all frames median / p95 | plan ms mean / max");
    for lookahead_ms in [100.0, 150.0, 200.0, 250.0, 300.0, 400.0] {
        let lookahead = lookahead_ms / 1000.0;
        let (mut at_notes, mut all, mut plan_ms) = (Vec::new(), Vec::new(), Vec::new());
        let mut render_at_notes = Vec::new();
        for path in &files {
            let mut perf = read_file(path, &ReadOptions { channel: 10 }).unwrap();
            perf.events.retain(|e| e.time_s < 60.0);
            perf.notes_end_s = perf.notes_end_s.min(60.0);
            let hands = model_hands(&model, &perf, &map);
            let whole = perform_planned(&perf, &map, &kit, &hands, &lib).unwrap();
            let tip = |f: &drumsim::motion::MotionFrame, s: usize| f.hands[s].stick_tip();
            let mut live = WindowMotion::new(kit.clone(), map.clone(), HandModel::shipped(), lib.clone(), lookahead);
            let mut next_event = 0;
            let (mut newest, mut before): (Option<WindowPlan>, Option<WindowPlan>) = (None, None);
            let mut since = 0.0;
            let end = perf.notes_end_s;
            let frames = (end * 60.0) as usize;
            let mut shown: Vec<Option<[[f32; 3]; 2]>> = vec![None; frames + 1];
            for i in 0..frames {
                let now = i as f64 / 60.0;
                while next_event < perf.events.len() && perf.events[next_event].time_s <= now {
                    live.push(perf.events[next_event]);
                    next_event += 1;
                }
                if i % 3 == 0 {
                    let t0 = Instant::now();
                    let p = live.plan(now).unwrap();
                    plan_ms.push(t0.elapsed().as_secs_f64() * 1e3);
                    before = newest.replace(p);
                    since = now;
                }
                let Some(plan) = &newest else { continue };
                let shown_t = now - lookahead;
                if shown_t < 0.5 {
                    continue;
                }
                let f = shown_frame(plan, before.as_ref(), since, now, shown_t);
                let k = (shown_t * 60.0).round() as usize;
                if k >= whole.motion.frames.len() {
                    continue;
                }
                shown[k] = Some([tip(&f, 0), tip(&f, 1)]);
                for s in 0..2 {
                    all.push(dist(tip(&f, s), tip(&whole.motion.frames[k], s)));
                }
            }
            // At each played hand note's time: the nearer shown tip to its strike point, and
            // the render's.
            for (n, hand) in whole.notes.iter().zip(&whole.report.hands) {
                if hand.is_none() {
                    continue;
                }
                let k = (n.time_s * 60.0).round() as usize;
                if let Some(Some(tips)) = shown.get(k) {
                    at_notes.push(dist(tips[0], n.point).min(dist(tips[1], n.point)));
                    let f = &whole.motion.frames[k];
                    render_at_notes.push(dist(tip(f, 0), n.point).min(dist(tip(f, 1), n.point)));
                }
            }
        }
        let over = at_notes.iter().filter(|d| **d > 0.02).count() as f64 / at_notes.len().max(1) as f64;
        let render_over =
            render_at_notes.iter().filter(|d| **d > 0.02).count() as f64 / render_at_notes.len().max(1) as f64;
        let mean_plan = plan_ms.iter().sum::<f64>() / plan_ms.len().max(1) as f64;
        let max_plan = plan_ms.iter().cloned().fold(0.0, f64::max);
        println!(
            "{lookahead_ms:>5} | {:.1} / {:.1} mm / {:.1} % of {} (render {:.1} mm / {:.1} %) | {:.1} / {:.1} mm | {mean_plan:.1} / {max_plan:.1}",
            pct(&mut at_notes, 0.5) * 1e3,
            pct(&mut at_notes, 0.95) * 1e3,
            over * 100.0,
            at_notes.len(),
            pct(&mut render_at_notes, 0.95) * 1e3,
            render_over * 100.0,
            pct(&mut all, 0.5) * 1e3,
            pct(&mut all, 0.95) * 1e3,
        );
    }
}

fn dist(a: [f32; 3], b: [f32; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt() as f64
}
