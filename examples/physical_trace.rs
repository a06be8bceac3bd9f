//! Trace one hand of the physical performance around a moment: the target's and the
//! simulated tip's height over a piece, per task period, and the contacts.
//! `cargo run --release --example physical_trace TAKE.mid TIME_S HAND PIECE [KIT]`.
//! `STEPS=1`: every millisecond within 12 ms of TIME_S (`WIDE=S`: every 4 ms within S
//! seconds) the target's, the kinematic and the simulated tip's heights; `JOINTS=1` adds
//! each joint's error between the kinematic and the simulated layer and how fast each
//! turns it (trunk, neck, head, left clavicle, shoulder, elbow, wrist, then the right arm's).
//! Each period's line starts with how far the target's stick direction turned since the
//! period before (degrees; in brackets the same before the keep-out swings it round a
//! cymbal) and its share along the piece's normal (+: the stick points up from the piece).
//! `FEEDBACK`, `ITERS`, `HZ`, `ZETA` override the drummer's HIMC feedback gain, solver
//! iterations, PD natural frequency and damping ratio.

use drumsim::body::sim::{DrummerSettings, Mode};
use drumsim::body::skeleton::JOINTS;
use drumsim::kit::Kit;
use drumsim::midi::{read_file, NoteMap, ReadOptions};
use drumsim::motion::hands::HandModel;
use drumsim::motion::pipeline::{model_hands, perform_planned, shipped_library};
use drumsim::perform::Conductor;
use rapier3d::math::Rotation;
use std::path::Path;

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let take = &a[1];
    let at: f64 = a[2].parse().unwrap();
    let hand: usize = a[3].parse().unwrap();
    let piece = &a[4];
    let kit = Kit::load(Path::new(a.get(5).map(String::as_str).unwrap_or("default"))).unwrap();
    let map = NoteMap::builtin("roland-td").unwrap();
    let perf = read_file(Path::new(take), &ReadOptions { channel: 10 }).unwrap();
    let predicted = model_hands(&HandModel::shipped(), &perf, &map);
    let planned = perform_planned(&perf, &map, &kit, &predicted, &shipped_library().unwrap()).unwrap();
    for n in planned.hands.notes(hand).filter(|n| (n.time_s - at).abs() < 0.3) {
        println!("note {:.3} s {} v{} speed {:.2} m/s", n.time_s, kit.pieces[n.piece].id, n.velocity, n.speed_mps);
    }
    let mut ds = DrummerSettings::default();
    if let Some(f) = std::env::var("FEEDBACK").ok().and_then(|v| v.parse().ok()) {
        ds.feedback = f;
    }
    if let Some(f) = std::env::var("ITERS").ok().and_then(|v| v.parse().ok()) {
        ds.solver_iterations = f;
    }
    if let Some(f) = std::env::var("HZ").ok().and_then(|v| v.parse().ok()) {
        ds.natural_hz = f;
    }
    if let Some(f) = std::env::var("ZETA").ok().and_then(|v| v.parse().ok()) {
        ds.damping_ratio = f;
    }
    let mut c = Conductor::new(&kit, &perf, &map, &planned, ds).unwrap();
    let k = c.drummer().surfaces().iter().position(|s| &s.id == piece).expect("piece");
    let mut deepest = 0.0f32;
    let mut last: Option<([Rotation; JOINTS], [Rotation; JOINTS])> = None;
    let mut last_dir = rapier3d::math::Vector::Y;
    let mut last_plan = rapier3d::math::Vector::Y;
    while c.time_s() < at + 0.15 {
        if std::env::var_os("SANK").is_some() && c.drummer().max_penetration_m() > deepest + 0.001 {
            // Each new deepest penetration of a stick, as it happens (the whole take up to T).
            deepest = c.drummer().max_penetration_m();
            let (t, k, side) = c.drummer().deepest_penetration_at();
            println!(
                "sank {:.1} mm at {:.3} s into {} by stick {side}",
                deepest * 1e3,
                t - drumsim::perform::PREROLL_S,
                c.drummer().surfaces()[k].id
            );
        }
        let mut hits = Vec::new();
        let fine = std::env::var_os("STEPS").is_some();
        // WIDE=S: the steps S either side of TIME_S, every 4 ms (default 12 ms, every 1 ms).
        let wide: f64 = std::env::var("WIDE").ok().and_then(|v| v.parse().ok()).unwrap_or(0.012);
        let every = if wide > 0.012 { 40 } else { 10 };
        let joints = std::env::var_os("JOINTS").is_some();
        c.period_observed(&mut |s| hits.push(s), &mut |d, t, tg| {
            if fine && (t - at).abs() < wide && ((t * 1e4).round() as i64) % every == 0 {
                let s = &d.surfaces()[k];
                let tip = d.tips(Mode::Himc)[hand];
                let kin = d.tips(Mode::Ik)[hand];
                println!(
                    "    step {t:.4} target h {:+6.2} mm kinematic h {:+6.2} mm sim h {:+6.2} mm limit excess {:.3} at {}",
                    s.height(tg[hand].tip) * 1e3,
                    s.height(kin) * 1e3,
                    s.height(tip) * 1e3,
                    d.max_limit_excess,
                    d.worst_limit_joint
                );
                if joints {
                    // Each joint's error (kinematic against simulated, degrees) and how fast
                    // each layer turns it (degrees per ms, since the last line).
                    let (kj, sj) = (*d.kinematic_joints(), d.sim_joints());
                    let deg = |a: Rotation, b: Rotation| (a * b.inverse()).to_scaled_axis().length().to_degrees();
                    let per_ms = 1e-3 / (every as f64 * 1e-4);
                    let line = |f: &dyn Fn(usize) -> f64| (0..kj.len()).map(|j| format!("{:5.1}", f(j))).collect::<String>();
                    println!("      error       {}", line(&|j| deg(kj[j], sj[j]) as f64));
                    if let Some((pk, ps)) = last.as_ref() {
                        let (pk, ps): (&[Rotation; JOINTS], &[Rotation; JOINTS]) = (pk, ps);
                        println!("      kinematic   {}", line(&|j| deg(kj[j], pk[j]) as f64 * per_ms));
                        println!("      simulated   {}", line(&|j| deg(sj[j], ps[j]) as f64 * per_ms));
                    }
                    last = Some((kj, sj));
                }
            }
        });
        let t = c.time_s();
        if t > at - 0.15 {
            let s = &c.drummer().surfaces()[k];
            let tip = c.drummer().tips(Mode::Himc)[hand];
            let target = c.last_targets()[hand].tip;
            // How far the target's stick direction turned since the last period, degrees, and
            // how far it points along the piece's normal (up from it: +).
            let degrees =
                |a: rapier3d::math::Vector, b: rapier3d::math::Vector| a.dot(b).clamp(-1.0, 1.0).acos().to_degrees();
            let (dir, plan) = (c.last_targets()[hand].dir, c.targets().at(hand, t, None).dir);
            let (turn, plan_turn) = (degrees(dir, last_dir), degrees(plan, last_plan));
            (last_dir, last_plan) = (dir, plan);
            let n = s.normal;
            print!(
                "dir turn {turn:5.1} deg (before the keep-out {plan_turn:5.1}) dir.n {:+.2} ({:+.2}) ",
                dir.dot(n),
                plan.dot(n)
            );
            let on: Vec<&str> = c.drummer().touching(hand).map(|k| c.drummer().surfaces()[k].id.as_str()).collect();
            print!("{on:?} ");
            println!(
                "t {t:.3} target h {:+6.1} mm sim h {:+6.1} mm  planar {:5.1} mm (target {:5.1}) {}",
                s.height(target) * 1e3,
                s.height(tip) * 1e3,
                ((tip - s.center) - s.normal * s.height(tip)).length() * 1e3,
                ((target - s.center) - s.normal * s.height(target)).length() * 1e3,
                hits.iter()
                    .map(|h| format!(
                        "[{} {} {:.3} s {:.2} m/s]",
                        h.side,
                        c.drummer().surfaces()[h.surface].id,
                        h.time_s,
                        h.speed_mps
                    ))
                    .collect::<String>()
            );
        }
    }
}
