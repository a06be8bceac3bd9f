use super::*;
use crate::midi::DrumEvent;
use crate::motion::{MotionFrame, Pose};

fn line(n: usize) -> Vec<[f32; 3]> {
    (0..n).map(|t| [0.01 * t as f32, 0.3, 0.8]).collect()
}

#[test]
fn l1_is_the_mean_absolute_error_per_coordinate() {
    let a = line(20);
    let b: Vec<[f32; 3]> = a.iter().map(|p| [p[0] + 0.01, p[1] - 0.02, p[2] + 0.03]).collect();
    // (0.01 + 0.02 + 0.03) / 3 per frame; the Euclidean reading would give 0.0374.
    assert!((l1_m(&a, &b).unwrap() - 0.02).abs() < 1e-7);
    assert!(l1_m(&a, &a).unwrap() == 0.0);
}

#[test]
fn l1_compares_the_common_frames_of_unequal_lengths() {
    let a = line(10);
    let mut b = line(30);
    for p in &mut b[10..] {
        p[2] += 5.0; // beyond a's end: must not count
    }
    assert!(l1_m(&a, &b).unwrap() < 1e-9);
}

#[test]
fn empty_or_nan_trajectories_are_errors() {
    let a = line(10);
    assert!(matches!(l1_m(&[], &a), Err(MotionMetricError::Empty { what: "l1 prediction" })));
    let mut b = a.clone();
    b[4][0] = f32::NAN;
    let e = l1_m(&a, &b).unwrap_err();
    assert_eq!(e, MotionMetricError::NotFinite { what: "l1 reference", frame: 4 });
    assert!(e.to_string().contains("frame 4"));
    assert!(matches!(jerk_rms(&a[..3], 60.0), Err(MotionMetricError::TooShort { needed: 4, .. })));
    assert!(jerk_rms(&a, f64::NAN).is_err());
    assert!(jerk_rms_per_frame(&b).is_err());
}

#[test]
fn jerk_of_a_sine_matches_the_difference_and_the_derivative() {
    // x = A sin(theta t): the third difference is -8 A sin^3(theta/2) cos(theta (t + 1.5)),
    // whose RMS over whole periods is 8 A sin^3(theta/2) / sqrt 2 per frame^3. The continuous
    // jerk is A w^3 / sqrt 2 with w = theta fps: 2 Hz at 60 fps here.
    let (a, theta, fps) = (0.1f64, 2.0 * std::f64::consts::PI / 30.0, 60.0);
    let traj: Vec<[f32; 3]> = (0..123).map(|t| [(a * (theta * t as f64).sin()) as f32, 0.2, 0.9]).collect();
    let per_frame = jerk_rms_per_frame(&traj).unwrap();
    let exact = 8.0 * a * (theta / 2.0).sin().powi(3) / 2f64.sqrt();
    assert!((per_frame / exact - 1.0).abs() < 1e-3, "{per_frame} vs {exact}");
    let mps3 = jerk_rms(&traj, fps).unwrap();
    let continuous = a * (theta * fps).powi(3) / 2f64.sqrt();
    assert!((mps3 / continuous - 1.0).abs() < 0.01, "{mps3} vs {continuous}");
}

#[test]
fn jerk_of_a_cubic_is_constant_and_of_a_parabola_zero() {
    // x = c t^3 (t in frames) has third difference 6c: 6 c fps^3 in m/s^3.
    let c = 1e-4;
    let cubic: Vec<[f32; 3]> = (0..12).map(|t| [0.0, 0.0, (c * (t * t * t) as f64) as f32]).collect();
    assert!((jerk_rms_per_frame(&cubic).unwrap() - 6.0 * c).abs() < 1e-6);
    assert!((jerk_rms(&cubic, 60.0).unwrap() / (6.0 * c * 216_000.0) - 1.0).abs() < 1e-3);
    let parabola: Vec<[f32; 3]> = (0..12).map(|t| [0.001 * (t * t) as f32, 0.0, 0.0]).collect();
    assert!(jerk_rms_per_frame(&parabola).unwrap() < 1e-6);
}

#[test]
fn mean_sd_median_of_known_samples() {
    let (m, s, d) = mean_sd_median(&[1.0, 2.0, 3.0, 4.0, 10.0]).unwrap();
    assert_eq!((m, d), (4.0, 3.0));
    assert!((s - 10.0f64.sqrt()).abs() < 1e-12); // population: (9+4+1+0+36)/5 = 10
    assert_eq!(mean_sd_median(&[3.0, 1.0]).unwrap().2, 2.0);
    assert!(mean_sd_median(&[]).is_none());
}

fn frame(left: [f32; 3], right: [f32; 3]) -> MotionFrame {
    MotionFrame {
        hands: [Pose { pos: left, rot: Pose::IDENTITY.rot }, Pose { pos: right, rot: Pose::IDENTITY.rot }],
        chest: Pose::IDENTITY,
        head: Pose::IDENTITY,
        feet: [Pose::IDENTITY; 2],
        face: vec![0.0; 52],
        hihat_openness: 0.0,
    }
}

/// Both hands swing sinusoidally along z with period 12 frames: speed peaks every 6 frames,
/// at t = 6k (where the sine crosses zero). `offset` moves them along x.
fn swinging(n: usize, offset: f32) -> Motion {
    let frames = (0..n)
        .map(|t| {
            let z = 0.05 * (2.0 * std::f32::consts::PI * t as f32 / 12.0).sin() + 0.8;
            frame([-0.2 + offset, 0.4, z], [0.2 + offset, 0.4, z])
        })
        .collect();
    Motion { fps: 60.0, frames }
}

#[test]
fn motion_metrics_assemble_the_eval_object() {
    // 123 frames: the jerk's 120 third differences cover 10 whole periods.
    let pred = swinging(123, 0.0);
    let reference = swinging(123, 0.01);
    // Onsets on the speed peaks 6k, k = 1..=19, as seconds.
    let onsets: Vec<f64> = (1..=19).map(|k| (6 * k) as f64 / 60.0).collect();
    let m = motion_metrics(&pred, Some(&reference), &onsets).unwrap();
    let beat = m.beat_alignment_ms.unwrap();
    assert_eq!(beat.mean, Some(0.0));
    assert_eq!(beat.median, Some(0.0));
    assert_eq!(beat.unmatched_onsets, 0);
    let hands = m.hands.unwrap();
    // Offset 1 cm along x only: 1 cm / 3 per coordinate, and no warping can undo it.
    assert!((hands.l1_m - 0.01 / 3.0).abs() < 1e-6 && (hands.dtw - 0.01 / 3.0).abs() < 1e-6, "{hands:?}");
    // Jerk of the z sine: 8 A sin^3(pi / 12) / sqrt 2 per frame^3 (both hands alike).
    let exact = 8.0 * 0.05 * (std::f64::consts::PI / 12.0).sin().powi(3) / 2f64.sqrt();
    assert!((hands.jerk_rms / exact - 1.0).abs() < 1e-3, "{} vs {exact}", hands.jerk_rms);
    // The contact parts are null, the object has exactly the keys of DESIGN.md 7.
    let v = serde_json::to_value(&m).unwrap();
    for key in ["notes", "contacts", "hits", "timing_ms", "ipd_mm"] {
        assert!(v[key].is_null(), "{key}");
    }
    for key in ["l1_m", "dtw", "jerk_rms"] {
        assert!(v["hands"][key].is_number(), "{key}");
    }
    for key in ["mean", "sd", "median"] {
        assert!(v["beat_alignment_ms"][key].is_number(), "{key}");
    }
    let back: MotionMetrics = serde_json::from_value(v).unwrap();
    assert_eq!(back, m);
}

#[test]
fn motion_metrics_without_a_reference_or_onsets() {
    let m = motion_metrics(&swinging(60, 0.0), None, &[]).unwrap();
    assert!(m.hands.is_none());
    let beat = m.beat_alignment_ms.unwrap();
    assert_eq!((beat.mean, beat.matched), (None, 0));
    assert!(beat.unmatched_peaks > 0);
    let v = serde_json::to_value(&m).unwrap();
    assert!(v["hands"].is_null() && v["beat_alignment_ms"]["mean"].is_null());
}

#[test]
fn motion_metrics_reject_bad_motions() {
    let mut bad = swinging(60, 0.0);
    bad.fps = 0.0;
    assert!(motion_metrics(&bad, None, &[]).is_err());
    let mut other = swinging(60, 0.0);
    other.fps = 30.0;
    assert!(motion_metrics(&swinging(60, 0.0), Some(&other), &[]).is_err());
    let mut nan = swinging(60, 0.0);
    nan.frames[10].hands[1].pos[0] = f32::NAN;
    assert!(matches!(motion_metrics(&nan, None, &[]), Err(MotionMetricError::NotFinite { frame: 10, .. })));
    assert!(motion_metrics(&Motion { fps: 60.0, frames: vec![] }, None, &[]).is_err());
}

#[test]
fn hand_onsets_leave_out_the_feet() {
    let map = NoteMap::builtin("gm").unwrap();
    let on = |time_s, note| DrumEvent { time_s, tick: 0, kind: DrumEventKind::NoteOn { note, velocity: 100 } };
    let perf = Performance {
        path: "t.mid".into(),
        events: vec![
            on(0.0, 36),
            on(0.0, 42),
            on(0.5, 38),
            on(0.6, 44),
            DrumEvent { time_s: 0.7, tick: 0, kind: DrumEventKind::NoteOff { note: 38 } },
        ],
        duration_s: 1.0,
        notes_end_s: 1.0,
        channel: 10,
    };
    assert_eq!(hand_onsets_s(&perf, &map), vec![0.0, 0.5]);
}

#[test]
fn spearman_ranks_ties_and_refuses_what_it_cannot_rank() {
    // Monotone but not linear: 1. Reversed: -1. Ties take their mean rank.
    assert!((spearman(&[1.0, 2.0, 3.0, 4.0], &[1.0, 8.0, 27.0, 64.0]).unwrap() - 1.0).abs() < 1e-12);
    assert!((spearman(&[1.0, 2.0, 3.0], &[3.0, 2.0, 1.0]).unwrap() + 1.0).abs() < 1e-12);
    assert_eq!(ranks(&[5.0, 1.0, 5.0, 3.0]), vec![3.5, 1.0, 3.5, 2.0]);
    assert!((spearman(&[1.0, 2.0, 2.0, 3.0], &[1.0, 2.0, 3.0, 4.0]).unwrap() - 0.9486832980505138).abs() < 1e-9);
    assert_eq!(spearman(&[1.0, 2.0], &[1.0, 2.0]), None);
    assert_eq!(spearman(&[1.0, 1.0, 1.0], &[1.0, 2.0, 3.0]), None);
}
