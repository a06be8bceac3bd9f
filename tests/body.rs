//! The simulated drummer against physics and against its aims: energy and stability over
//! ten minutes of strokes, joint limits, contacts (one per stroke, on time, on the point,
//! none past the rim, no sinking), HIMC against ID, and bad input.

use drumsim::body::anthropometry::BodySettings;
use drumsim::body::contacts::Strike;
use drumsim::body::ik::ArmTarget;
use drumsim::body::sim::{Drummer, DrummerError, DrummerSettings, Mode};
use drumsim::body::strokes::{StrokePlan, Style};
use drumsim::body::trials::{plans_for, run_all, run_trial, ErrorStats};
use drumsim::kit::Kit;
use rapier3d::math::Vector;

fn drummer() -> Drummer {
    Drummer::new(&Kit::builtin_default(), DrummerSettings::default()).expect("default drummer")
}

#[test]
fn ten_minutes_of_strokes_stay_finite_bounded_inside_the_limits_and_out_of_the_drums() {
    let mut d = drummer();
    let styles = Style::ALL;
    let mut strikes = 0usize;
    let (mut e_min, mut e_max) = (f32::INFINITY, f32::NEG_INFINITY);
    let block_s = 10.0;
    for block in 0..60 {
        // Ten seconds of one style, strokes every period on both hands.
        let style = styles[block % styles.len()];
        let p = style.params();
        let t0 = block as f64 * block_s;
        let base = plans_for(&d, style, None);
        let plans: [StrokePlan; 2] = std::array::from_fn(|side| {
            let mut plan = base[side].clone();
            let first = t0 + 0.3 + side as f64 * 0.5 * p.period_s as f64;
            plan.hits =
                (0..).map(|k| first + k as f64 * p.period_s as f64).take_while(|&h| h < t0 + block_s - 0.3).collect();
            plan
        });
        for k in 0..(block_s * 1e4) as u64 {
            let t = d.time_s() + 1e-4;
            let targets = [plans[0].target(t), plans[1].target(t)];
            d.step_tips(Mode::Himc, &targets, &mut |_| strikes += 1);
            if k % 1000 == 0 {
                let e = d.energy_j();
                assert!(e.is_finite(), "energy not finite at {t} s");
                e_min = e_min.min(e);
                e_max = e_max.max(e);
                let tips = d.tips(Mode::Himc);
                assert!(tips.iter().all(|p| p.is_finite()));
            }
        }
    }
    assert!(d.time_s() >= 599.99);
    // Potential energy moves with the arms (tens of joules); kinetic energy peaks when a new
    // style's first target jumps by up to 30 cm. An unstable body would gain kilojoules.
    assert!(e_max - e_min < 150.0, "energy range {e_min}..{e_max} J");
    assert!(d.joint_gap_m() < 1e-3, "joints pulled apart by {} m", d.joint_gap_m());
    assert!(d.max_limit_excess < 0.05, "a joint left its limit by {} of the ellipsoid", d.max_limit_excess);
    assert!(d.max_penetration_m() < 0.002, "a stick sank {} m into a drum", d.max_penetration_m());
    // Two hands, a stroke every 0.25-0.6 s for ten minutes.
    assert!(strikes > 2000, "{strikes} strikes");
}

/// An arm pressing its stick into the snare head (its target 3 cm under the head for most of
/// a second) does not sink it: the kit is rigid to the body (`KIT_CONTACT_HZ`). With rapier's
/// soft default for a fixed body (60 Hz) the same press sank the stick 11.0 mm.
#[test]
fn a_stick_pressed_into_the_snare_head_does_not_sink_into_it() {
    let mut d = drummer();
    let plans = plans_for(&d, Style::Legato, None);
    let hold = [plans[0].target(0.0), plans[1].target(0.0)];
    let (point, normal) = (plans[0].point, plans[0].normal);
    let mut touched = false;
    for k in 0..10_000u32 {
        // Down to the head over 0.2 s, then 3 cm under it.
        let depth = (f64::from(k) / 2000.0).min(1.0) as f32;
        let mut left = hold[0];
        left.tip += (point - normal * 0.03 - left.tip) * depth;
        d.step_tips(Mode::Himc, &[left, hold[1]], &mut |s: Strike| touched |= s.side == 0);
    }
    eprintln!("pressed into the snare: sank {:.2} mm", d.max_penetration_m() * 1e3);
    assert!(touched, "the stick never reached the head");
    assert!(d.max_penetration_m() < 0.001, "sank {:.2} mm", d.max_penetration_m() * 1e3);
}

#[test]
fn a_stroke_aimed_at_the_snare_makes_one_contact_on_time_on_the_point() {
    let kit = Kit::builtin_default();
    let r = run_trial(&kit, &DrummerSettings::default(), Style::Legato, Mode::Himc, None, false).unwrap();
    let snare = r.surface_names.iter().position(|s| s == "snare").unwrap();
    let plan = &r.plans[0];
    let on_snare: Vec<&Strike> = r.strikes.iter().filter(|s| s.surface == snare).collect();
    assert_eq!(on_snare.len(), plan.hits.len(), "one contact per stroke: {on_snare:?}");
    for (s, &hit) in on_snare.iter().zip(&plan.hits) {
        assert_eq!(s.side, 0);
        let dt_ms = (s.time_s - hit) * 1e3;
        let planar = s.point - plan.point;
        let off_mm = (planar - plan.normal * planar.dot(plan.normal)).length() * 1e3;
        eprintln!("snare contact {dt_ms:+.2} ms from the aim, {off_mm:.1} mm off the point, {:.2} m/s", s.speed_mps);
        assert!(dt_ms.abs() <= 2.0, "contact {dt_ms:+.2} ms from the aimed time");
        let miss = s.point - plan.point;
        let miss = (miss - plan.normal * miss.dot(plan.normal)).length();
        assert!(miss <= 0.01, "contact {:.1} mm from the aimed point", miss * 1e3);
        // A legato stroke falls from 15 cm in 0.1 s: about 3 m/s.
        assert!(s.speed_mps > 2.0 && s.speed_mps < 4.0, "{} m/s", s.speed_mps);
        // The stick strikes with at least its tip's mass (the kit's 12 g), more nearer its middle.
        let tip = drumsim::kit::Kit::builtin_default().strike.stick_mass_kg;
        assert!(s.impulse_ns > 0.0 && s.mass_kg >= tip * 0.999 && s.mass_kg < 0.5, "{} kg", s.mass_kg);
        let msg = s.message(drummer().surfaces());
        assert_eq!(msg.piece, "snare");
    }
    assert!(r.max_penetration_m < 0.002, "sank {} m", r.max_penetration_m);
    // The hi-hat hand's strokes land on the hi-hat only.
    let hihat = r.surface_names.iter().position(|s| s == "hihat").unwrap();
    assert!(r.strikes.iter().all(|s| s.surface == if s.side == 0 { snare } else { hihat }), "{:?}", r.strikes);
}

#[test]
fn a_stroke_aimed_past_the_rim_touches_nothing_on_the_snare() {
    let mut d = drummer();
    let snare = d.surfaces().iter().position(|s| s.id == "snare").unwrap();
    let hihat = d.surfaces().iter().position(|s| s.id == "hihat").unwrap();
    let s = d.surfaces()[snare].clone();
    // 6 cm beyond the snare's left edge, in its plane.
    let past = StrokePlan::on(&s, 0, -(s.radius_m + 0.06), 0.0, Style::Legato.params(), vec![0.5, 1.0]);
    let idle = StrokePlan::on(&d.surfaces()[hihat].clone(), 1, 0.0, 0.0, Style::Legato.params(), Vec::new());
    let mut strikes = Vec::new();
    let mut lowest = f32::INFINITY;
    for _ in 0..14000 {
        let t = d.time_s() + 1e-4;
        d.step_tips(Mode::Himc, &[past.target(t), idle.target(t)], &mut |st| strikes.push(st));
        lowest = lowest.min(s.height(d.tips(Mode::Himc)[0]));
    }
    assert!(
        strikes.iter().all(|st| st.surface != snare && !d.surfaces()[st.surface].id.starts_with("snare")),
        "{strikes:?}"
    );
    // The tip really went down past the head's plane beside the drum.
    assert!(lowest < 0.0, "lowest tip height {lowest}");
}

#[test]
fn himc_tracks_stick_tips_better_than_id_in_every_style_with_less_spread() {
    let kit = Kit::builtin_default();
    let (results, steps, _) =
        run_all(&kit, &DrummerSettings::default(), &[Mode::Himc, Mode::Id], 6, 2, &|| {}).unwrap();
    assert!(steps > 0);
    for style in Style::ALL {
        let stats = |mode| {
            let (_, _, v) = results.iter().find(|(s, m, _)| *s == style && *m == mode).unwrap();
            ErrorStats::of(v)
        };
        let (himc, id) = (stats(Mode::Himc), stats(Mode::Id));
        eprintln!(
            "{:16} himc {:.2} mm rms, {:.2} mm spread ({:.2} between trials); id {:.2}, {:.2} ({:.2})",
            style.name(),
            himc.rms_m * 1e3,
            himc.sd_m * 1e3,
            himc.trial_sd_m * 1e3,
            id.rms_m * 1e3,
            id.sd_m * 1e3,
            id.trial_sd_m * 1e3
        );
        assert!(himc.rms_m < id.rms_m, "{}: himc {} vs id {}", style.name(), himc.rms_m, id.rms_m);
        assert!(himc.sd_m < id.sd_m, "{}: spread himc {} vs id {}", style.name(), himc.sd_m, id.sd_m);
    }
}

#[test]
fn unreachable_nan_and_buried_targets_leave_a_finite_body() {
    let mut d = drummer();
    let ready = [0, 1].map(|i| ArmTarget { tip: d.tips(Mode::Ik)[i], dir: d.stick_dirs()[i] });
    let snare = d.surfaces().iter().find(|s| s.id == "snare").unwrap().clone();
    let cases = [
        // Far outside the arm's reach, behind the drummer.
        [
            ArmTarget { tip: Vector::new(0.0, -3.0, 3.0), dir: Vector::Y },
            ArmTarget { tip: Vector::new(5.0, 5.0, -2.0), dir: -Vector::Y },
        ],
        // Not a number.
        [
            ArmTarget { tip: Vector::splat(f32::NAN), dir: Vector::Y },
            ArmTarget { tip: ready[1].tip, dir: Vector::splat(f32::NAN) },
        ],
        // Deep inside the snare.
        [ArmTarget { tip: snare.center - snare.normal * 0.15, dir: ready[0].dir }, ready[1]],
    ];
    for targets in cases {
        for _ in 0..5000 {
            d.step_tips(Mode::Himc, &targets, &mut |_| {});
        }
        let tips = d.tips(Mode::Himc);
        assert!(tips.iter().all(|p| p.is_finite()) && d.energy_j().is_finite());
        assert!(d.joint_gap_m() < 0.01, "joints pulled apart by {} m", d.joint_gap_m());
        for _ in 0..5000 {
            d.step_tips(Mode::Himc, &ready, &mut |_| {});
        }
    }
    // Joint limits and the 2 mm bound on sinking are asserted in play (above); an arm flung
    // after impossible targets may strain both, but the body stays whole and finite.
    eprintln!(
        "after abuse: limit excess {} at joint {}, sank {} m",
        d.max_limit_excess,
        d.worst_limit_joint,
        d.max_penetration_m()
    );
    assert!(d.max_penetration_m() < 0.05, "a stick went {} m into the kit", d.max_penetration_m());
    // Back at the ready targets, the body tracks them again.
    for _ in 0..10000 {
        d.step_tips(Mode::Himc, &ready, &mut |_| {});
    }
    let tips = d.tips(Mode::Himc);
    eprintln!("recovered to {} m, {} m", (tips[0] - ready[0].tip).length(), (tips[1] - ready[1].tip).length());
    // The right arm, which was only stretched, tracks its ready target again. (The left
    // stick, driven under the snare by the buried target, can stay caught beneath it: the IK
    // does not plan around the kit.)
    assert!((tips[1] - ready[1].tip).length() < 0.01);
    assert!(tips[0].is_finite());
}

#[test]
fn absurd_settings_are_rejected_with_the_key() {
    let kit = Kit::builtin_default();
    let bad = |s: DrummerSettings| match Drummer::new(&kit, s) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("accepted"),
    };
    let msg = bad(DrummerSettings { natural_hz: 1e6, ..DrummerSettings::default() });
    assert!(msg.contains("natural_hz"), "{msg}");
    let msg = bad(DrummerSettings { damping_ratio: f32::NAN, ..DrummerSettings::default() });
    assert!(msg.contains("damping_ratio"), "{msg}");
    let body = BodySettings { mass_kg: 5000.0, ..BodySettings::default() };
    let msg = bad(DrummerSettings { body, ..DrummerSettings::default() });
    assert!(msg.contains("mass_kg"), "{msg}");
    let err =
        Drummer::new(&kit, DrummerSettings { limits: Some(Vec::new()), ..DrummerSettings::default() }).err().unwrap();
    assert!(matches!(err, DrummerError::Setting { key: "limits", .. }), "{err}");
}

#[test]
fn the_feet_follow_their_pedal_targets_and_the_whole_figure_exists() {
    use drumsim::body::legs::{FootTarget, FEET_HOME};
    let kit = Kit::builtin_default();
    let mut d = Drummer::new(&kit, DrummerSettings::default()).unwrap();
    let legs = d.leg_poses();
    for side in 0..2 {
        let ankle = legs[side][2];
        let home = FEET_HOME[side];
        assert!((0..3).all(|k| (ankle[k] - home[k]).abs() < 1e-3), "{ankle:?}");
        // The knee is forward of the hip and above the pedal.
        assert!(legs[side][1].y > legs[side][0].y && legs[side][1].z > ankle.z);
    }
    // A kick press: the right foot lifts 4 cm with the toe up, then comes down at the hit.
    let lifted = FootTarget { ankle: Vector::new(0.10, 0.40, 0.14), toe_up_rad: 0.3 };
    // The arms hold still where they are.
    let hold = |d: &Drummer| {
        let (t, s) = (d.tips(Mode::Ik), d.stick_dirs());
        [ArmTarget { tip: t[0], dir: s[0] }, ArmTarget { tip: t[1], dir: s[1] }]
    };
    d.set_feet([FootTarget::home(0), lifted]);
    for _ in 0..10 {
        let targets = hold(&d);
        d.step_tips(Mode::Himc, &targets, &mut |_| {});
    }
    let up = d.leg_poses()[1];
    assert!((up[2] - lifted.ankle).length() < 1e-3, "{:?}", up[2]);
    assert!(up[3].z > up[2].z + 0.05, "toe raised: {:?} over {:?}", up[3], up[2]);
    d.set_feet([FootTarget::home(0), FootTarget::home(1)]);
    let targets = hold(&d);
    d.step_tips(Mode::Himc, &targets, &mut |_| {});
    assert!((d.leg_poses()[1][2].z - FEET_HOME[1][2]).abs() < 1e-3);
}

#[test]
fn a_stroke_on_a_tilted_cymbal_is_reported_in_the_step_its_bead_touches() {
    // The ride is a plate tilted toward the drummer: slow and fast strokes on its bow each
    // make one contact, reported within 0.3 ms of the bead reaching it, and press in under
    // 2 mm.
    for style in [Style::Legato, Style::Accent, Style::VerticalAccent, Style::Staccato] {
        strike_ride(style);
    }
}

fn strike_ride(style: Style) {
    let mut d = drummer();
    let ride = d.surfaces().iter().position(|s| s.id == "ride").unwrap();
    let hihat = d.surfaces().iter().position(|s| s.id == "hihat").unwrap();
    let s = d.surfaces()[ride].clone();
    let hits: Vec<f64> = (0..6).map(|k| 0.6 + 0.4 * k as f64).collect();
    // Half way from its centre toward the drummer's seat, on the bow.
    let toward = Vector::new(-s.center.x, -s.center.y, 0.0);
    let toward = (toward - s.normal * toward.dot(s.normal)).normalize() * (0.5 * s.radius_m);
    let (x, y) = (toward.dot(s.u), toward.dot(s.v));
    let plan = StrokePlan::on(&s, 1, x, y, style.params(), hits.clone());
    let idle = StrokePlan::on(&d.surfaces()[hihat].clone(), 0, 0.0, 0.0, Style::Legato.params(), Vec::new());
    let bead = d.skel.stick.radius_m;
    let mut strikes = Vec::new();
    let mut touches = Vec::new();
    let mut was_touching = false;
    let mut lowest = f32::INFINITY;
    // First up from over the hi-hat and across above the ride, not under its edge.
    let start = d.tips(Mode::Himc)[1];
    let (up, over) = (start + Vector::Z * 0.35, plan.target(0.5).tip + s.normal * 0.1);
    let approach = |t: f64| {
        let x = (t / 0.25).min(1.0) as f32;
        let y = ((t - 0.25) / 0.2).clamp(0.0, 1.0) as f32;
        let z = ((t - 0.45) / 0.1).clamp(0.0, 1.0) as f32;
        let p = if t < 0.25 {
            start.lerp(up, x)
        } else if t < 0.45 {
            up.lerp(over, y)
        } else {
            over.lerp(plan.target(0.55).tip, z)
        };
        ArmTarget { tip: p, dir: plan.target(t).dir }
    };
    while d.time_s() < 3.0 {
        let t = d.time_s() + 1e-4;
        let right = if t < 0.55 { approach(t) } else { plan.target(t) };
        d.step_tips(Mode::Himc, &[idle.target(t), right], &mut |st| strikes.push(st));
        // The solver's contact stops the bead up to a step's travel short: 0.6 mm at the
        // accent's 6.4 m/s.
        let touching = s.height(d.tips(Mode::Himc)[1]) <= bead + 1e-3;
        if touching && !was_touching {
            touches.push(d.time_s());
        }
        was_touching = touching;
        if t > 0.55 {
            lowest = lowest.min(s.height(d.tips(Mode::Himc)[1]));
        }
    }
    let on_ride: Vec<&Strike> = strikes.iter().filter(|st| st.surface == ride && st.side == 1).collect();
    assert_eq!(
        on_ride.len(),
        hits.len(),
        "{style:?}: one contact per stroke: {on_ride:?}, bead touched at {touches:?}"
    );
    for st in &on_ride {
        let first = touches.iter().map(|&t| (t - st.time_s).abs()).fold(f64::INFINITY, f64::min);
        assert!(first <= 3e-4, "{style:?}: contact reported {:.2} ms from the bead's touch", first * 1e3);
    }
    assert!(lowest > bead - 0.002, "{style:?}: the bead sank {:.1} mm into the ride", (bead - lowest) * 1e3);
}

#[test]
fn an_arm_reaching_past_its_joint_limits_gets_to_its_target_without_running_away() {
    // The rearranged kit's floor tom played by the left hand, stick tilted up toward the
    // drummer's right: the target sits at the edge of what the left arm's limits allow. Once
    // a clamped step carried the tip off and the kinematic layer swung 0.9 m in 8 ms.
    let kit = Kit::builtin("rearranged").unwrap();
    let mut d = Drummer::new(&kit, DrummerSettings::default()).unwrap();
    let ready = [0, 1].map(|i| ArmTarget { tip: d.tips(Mode::Ik)[i], dir: d.stick_dirs()[i] });
    let reach = ArmTarget { tip: Vector::new(0.42, 0.30, 0.68), dir: Vector::new(0.71, 0.42, 0.57).normalize() };
    let (mut worst_step, mut reached) = (0.0f32, f32::INFINITY);
    let mut last = d.tips(Mode::Ik)[0];
    for k in 0..6000 {
        // 0.3 s there, a stick turning about its tip for 0.3 s.
        let a = (k as f32 / 3000.0).min(1.0);
        let turn = ((k as f32 - 3000.0) / 3000.0).clamp(0.0, 1.0);
        let mut left =
            ArmTarget { tip: ready[0].tip.lerp(reach.tip, a), dir: ready[0].dir.lerp(reach.dir, a).normalize() };
        left.dir = (left.dir + Vector::Z * turn).normalize();
        d.step_tips(Mode::Ik, &[left, ready[1]], &mut |_| {});
        let tip = d.tips(Mode::Ik)[0];
        worst_step = worst_step.max((tip - last).length());
        last = tip;
        if k == 2999 {
            reached = (tip - reach.tip).length();
        }
    }
    eprintln!("reached to {reached} m; turned, {} m off", (last - reach.tip).length());
    // The tip gets there (2.5 mm measured); the turned stick is an aim the arm cannot hold.
    assert!(reached < 0.01, "the left tip stopped {reached} m from its target");
    // One kinematic step moves the tip at most ik.max_step_m (1.5 mm) and a little more
    // where the posture pull adds to it.
    assert!(worst_step < 0.004, "the left tip jumped {worst_step} m in one step");
}
