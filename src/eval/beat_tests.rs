use super::*;
use crate::eval::motion::mean_sd_median;

const FPS: f64 = 60.0;
/// Half-length of a stroke in frames: strokes back to back every 12 frames.
const W: f64 = 6.0;

/// A hand swinging back and forth along x, one stroke per centre (frames, 2W apart):
/// its velocity is a raised-cosine bump `amp * (1 + cos(pi (t - c) / W)) / 2` per stroke,
/// alternating in sign, so the speed is symmetric about every centre and peaks exactly
/// there (and about every stroke boundary, where it is zero).
fn strokes(n: usize, centres: &[f64], amp: f64) -> Vec<[f32; 3]> {
    let integral = |u: f64| {
        if u <= -W {
            0.0
        } else if u >= W {
            W
        } else {
            (u + W) / 2.0 + W / (2.0 * std::f64::consts::PI) * (std::f64::consts::PI * u / W).sin()
        }
    };
    (0..n)
        .map(|t| {
            let x: f64 = centres
                .iter()
                .enumerate()
                .map(|(k, c)| if k % 2 == 0 { 1.0 } else { -1.0 } * amp * integral(t as f64 - c))
                .sum();
            [x as f32 + 0.1, 0.4, 0.8]
        })
        .collect()
}

/// Stroke centres 6, 18, ..., covering frames 0..120 (and one before, one after).
fn centres() -> Vec<f64> {
    (-1..=10).map(|k| 12.0 * k as f64 + 6.0).collect()
}

#[test]
fn speed_peaks_sit_on_the_stroke_centres() {
    let traj = strokes(120, &centres(), 0.01);
    let speed = savgol_filter(&hand_speed(&traj, FPS).unwrap(), 7, 2).unwrap();
    let peaks = local_maxima(&speed);
    let want: Vec<usize> = (0..10).map(|k| 12 * k + 6).collect();
    assert_eq!(peaks, want);
}

#[test]
fn peaks_two_frames_late_give_plus_33_ms() {
    let traj = strokes(120, &centres(), 0.01);
    let onsets: Vec<f64> = (0..10).map(|k| (12.0 * k as f64 + 6.0 - 2.0) / FPS).collect();
    let b = beat_alignment(&[&traj], &onsets, FPS, &BeatParams::default()).unwrap();
    let (mean, sd, median) = mean_sd_median(&b.delays_ms).unwrap();
    assert!((mean - 2000.0 / 60.0).abs() < 1e-9, "{mean}");
    assert!(sd.abs() < 1e-9 && (median - 2000.0 / 60.0).abs() < 1e-9);
    assert_eq!((b.peaks, b.delays_ms.len(), b.unmatched_peaks, b.unmatched_onsets), (10, 10, 0, 0));
}

#[test]
fn mixed_offsets_misses_and_strays_are_counted() {
    let traj = strokes(120, &centres(), 0.01);
    // Peaks at 6 + 12k. Onsets: peak - d for d = -1, 0, 2, 3, 1 on strokes 1..=5; stroke 6
    // 4 frames early (out of the window); no onset for the others; one stray onset at
    // frame 96, 6 frames from the nearest peaks.
    let mut frames: Vec<f64> = [(1, -1.0), (2, 0.0), (3, 2.0), (4, 3.0), (5, 1.0), (6, 4.0)]
        .iter()
        .map(|&(k, d)| 12.0 * k as f64 + 6.0 - d)
        .collect();
    frames.push(96.0);
    let onsets: Vec<f64> = frames.iter().map(|f| f / FPS).collect();
    let b = beat_alignment(&[&traj], &onsets, FPS, &BeatParams::default()).unwrap();
    let (mean, sd, median) = mean_sd_median(&b.delays_ms).unwrap();
    let frame_ms = 1000.0 / FPS;
    // Delays (frames) -1, 0, 2, 3, 1: mean 1, median 1, population sd sqrt(10 / 5).
    assert!((mean - frame_ms).abs() < 1e-9 && (median - frame_ms).abs() < 1e-9, "{:?}", b.delays_ms);
    assert!((sd - 2f64.sqrt() * frame_ms).abs() < 1e-9);
    assert_eq!((b.peaks, b.delays_ms.len(), b.unmatched_peaks), (10, 5, 5));
    // Onsets 7: the 4-frames-early one and the stray are left.
    assert_eq!((b.onsets, b.unmatched_onsets), (7, 2));
}

#[test]
fn two_hands_pool_their_matches() {
    let c = centres();
    let left = strokes(120, &c, 0.01);
    // The right hand strokes 6 frames later, halfway between the left hand's.
    let shifted: Vec<f64> = c.iter().map(|x| x + 6.0).collect();
    let right = strokes(120, &shifted, 0.02);
    // Onsets 1 frame after each left peak and 1 frame before each right peak.
    let onsets: Vec<f64> =
        (0..9).flat_map(|k| [12.0 * k as f64 + 7.0, 12.0 * k as f64 + 11.0]).map(|f| f / FPS).collect();
    let b = beat_alignment(&[&left, &right], &onsets, FPS, &BeatParams::default()).unwrap();
    let late = b.delays_ms.iter().filter(|d| (**d - 1000.0 / FPS).abs() < 1e-9).count();
    let early = b.delays_ms.iter().filter(|d| (**d + 1000.0 / FPS).abs() < 1e-9).count();
    // Left peaks 6..=102 each match the onset 1 later (-1 frame); right peaks 12..=108 the
    // onset 1 earlier (+1 frame); the left peak at 114 has none within 3 frames.
    assert_eq!(late, 9, "{:?}", b.delays_ms);
    assert_eq!(early, 9, "{:?}", b.delays_ms);
    assert_eq!(b.unmatched_onsets, 0);
}

#[test]
fn a_resting_hand_has_no_peaks_and_a_threshold_drops_slow_ones() {
    let still = vec![[0.1, 0.2, 0.9]; 30];
    let b = beat_alignment(&[&still], &[0.1, 0.2], FPS, &BeatParams::default()).unwrap();
    assert_eq!((b.peaks, b.unmatched_onsets), (0, 2));
    let slow = strokes(120, &centres(), 0.001); // 0.06 m/s peaks
    let p = BeatParams { min_peak_speed_mps: 0.1, ..BeatParams::default() };
    assert_eq!(beat_alignment(&[&slow], &[], FPS, &p).unwrap().peaks, 0);
    assert_eq!(beat_alignment(&[&slow], &[], FPS, &BeatParams::default()).unwrap().peaks, 10);
}

#[test]
fn speed_of_uniform_motion_is_its_velocity() {
    let traj: Vec<[f32; 3]> = (0..10).map(|t| [0.0, 0.01 * t as f32, 0.0]).collect();
    for s in hand_speed(&traj, FPS).unwrap() {
        assert!((s - 0.6).abs() < 1e-5, "{s}");
    }
}

#[test]
fn local_maxima_of_plateaus_and_edges() {
    assert_eq!(local_maxima(&[0.0, 1.0, 1.0, 1.0, 0.0]), vec![2]);
    assert_eq!(local_maxima(&[0.0, 1.0, 1.0, 2.0, 0.0]), vec![3]);
    assert_eq!(local_maxima(&[0.0, 1.0, 1.0]), Vec::<usize>::new());
    assert_eq!(local_maxima(&[1.0, 0.0, 1.0]), Vec::<usize>::new());
    assert_eq!(local_maxima(&[0.0, 2.0, 0.0, 3.0, 1.0]), vec![1, 3]);
}

#[test]
fn nearest_onset_prefers_the_closer_then_the_earlier() {
    let onsets = [10, 16, 30];
    assert_eq!(nearest(&onsets, 13, 3), Some(0)); // tie 10 / 16: the earlier
    assert_eq!(nearest(&onsets, 14, 3), Some(1));
    assert_eq!(nearest(&onsets, 23, 3), None);
    assert_eq!(nearest(&onsets, 33, 3), Some(2));
    assert_eq!(nearest(&[], 3, 3), None);
}

#[test]
fn bad_input_is_an_error_not_a_panic() {
    let mut traj = strokes(40, &centres(), 0.01);
    let p = BeatParams::default();
    assert!(matches!(beat_alignment(&[&[]], &[], FPS, &p), Err(MotionMetricError::Empty { .. })));
    assert!(matches!(beat_alignment(&[&traj[..5]], &[], FPS, &p), Err(MotionMetricError::TooShort { .. })));
    assert!(beat_alignment(&[&traj], &[f64::NAN], FPS, &p).is_err());
    assert!(beat_alignment(&[&traj], &[], 0.0, &p).is_err());
    traj[7][2] = f32::INFINITY;
    assert!(matches!(beat_alignment(&[&traj], &[], FPS, &p), Err(MotionMetricError::NotFinite { frame: 7, .. })));
}
