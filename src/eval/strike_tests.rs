use super::*;

const FPS: f64 = 60.0;
const SNARE: [f32; 3] = [0.1, 0.5, 0.6];

fn snare_note(frame: usize, hand: usize) -> StrikeNote {
    StrikeNote { time_s: frame as f64 / FPS, hand, center: SNARE, normal: [0.0, 0.0, 1.0], radius_m: 0.17 }
}

/// The right tip bounces off the snare plane (1 cm per frame) at the given frames, `dx`
/// from its centre; the left tip stays 40 cm above it.
fn bounces(n: usize, at: &[usize], dx: f32) -> Vec<[[f32; 3]; 2]> {
    (0..n)
        .map(|f| {
            let gap = at.iter().map(|&s| (f as f32 - s as f32).abs()).fold(f32::INFINITY, f32::min);
            [[-0.1, 0.5, 1.0], [SNARE[0] + dx, SNARE[1], SNARE[2] + 0.01 * gap]]
        })
        .collect()
}

#[test]
fn a_tip_on_time_crosses_at_the_note_frame() {
    let tips = bounces(40, &[20], 0.0);
    let c = strike_crossings(&[snare_note(20, 1)], &tips, FPS, SURFACE_TOL_M, SEARCH_FRAMES).unwrap();
    assert_eq!(c[0], StrikeCrossing { note_frame: 20, frame: Some(20), offset_frames: Some(0), on_piece: true });
    assert_eq!(fraction_on_surface_within(&[snare_note(20, 1)], &tips, FPS, 1).unwrap(), 1.0);
}

#[test]
fn offsets_are_counted_in_frames_and_only_within_tolerance() {
    let tips = bounces(40, &[20], 0.0);
    let notes = [snare_note(22, 1), snare_note(21, 1), snare_note(18, 1)];
    let c = strike_crossings(&notes, &tips, FPS, SURFACE_TOL_M, SEARCH_FRAMES).unwrap();
    let offsets: Vec<_> = c.iter().map(|x| x.offset_frames).collect();
    assert_eq!(offsets, vec![Some(-2), Some(-1), Some(2)]);
    // Within +-1 frame only the note at 21 sees the tip at the surface (frame 20).
    let f = fraction_on_surface_within(&notes, &tips, FPS, 1).unwrap();
    assert!((f - 1.0 / 3.0).abs() < 1e-12);
    assert!((fraction_on_surface_within(&notes, &tips, FPS, 2).unwrap() - 1.0).abs() < 1e-12);
}

#[test]
fn the_nearest_arrival_wins_in_a_fast_roll() {
    let tips = bounces(40, &[16, 21], 0.0);
    let c = strike_crossings(&[snare_note(20, 1), snare_note(17, 1)], &tips, FPS, SURFACE_TOL_M, 6).unwrap();
    assert_eq!((c[0].frame, c[1].frame), (Some(21), Some(16)));
}

#[test]
fn missing_the_disc_or_using_the_wrong_hand_does_not_count() {
    let off = bounces(40, &[20], 0.25); // 25 cm from the centre of a 17 cm snare
    let c = strike_crossings(&[snare_note(20, 1)], &off, FPS, SURFACE_TOL_M, SEARCH_FRAMES).unwrap();
    assert_eq!((c[0].frame, c[0].on_piece), (Some(20), false));
    assert_eq!(fraction_on_surface_within(&[snare_note(20, 1)], &off, FPS, 1).unwrap(), 0.0);
    let tips = bounces(40, &[20], 0.0);
    let c = strike_crossings(&[snare_note(20, 0)], &tips, FPS, SURFACE_TOL_M, SEARCH_FRAMES).unwrap();
    assert_eq!(c[0].frame, None);
    assert_eq!(fraction_on_surface_within(&[snare_note(20, 0)], &tips, FPS, 1).unwrap(), 0.0);
}

#[test]
fn tilted_surfaces_and_unnormalised_normals() {
    // A tom tilted 30 degrees toward the drummer: the tip comes down along its normal.
    let (s, c) = (0.5f32, 0.75f32.sqrt());
    let normal = [0.0, -s, c];
    let centre = [0.2, 0.6, 0.7];
    // The tip bounces along the normal, 2 cm from the centre along x (which lies in the plane).
    let tips: Vec<[[f32; 3]; 2]> = (0..30)
        .map(|f| {
            let h = 0.01 * (f as f32 - 10.0).abs();
            [[0.0, 0.0, 2.0], [centre[0] + 0.02, centre[1] + h * normal[1], centre[2] + h * normal[2]]]
        })
        .collect();
    let note =
        StrikeNote { time_s: 10.0 / FPS, hand: 1, center: centre, normal: normal.map(|v| 3.0 * v), radius_m: 0.1 };
    let x = strike_crossings(&[note], &tips, FPS, SURFACE_TOL_M, SEARCH_FRAMES).unwrap();
    assert_eq!((x[0].frame, x[0].on_piece), (Some(10), true));
    assert_eq!(fraction_on_surface_within(&[note], &tips, FPS, 0).unwrap(), 1.0);
}

#[test]
fn bad_notes_and_tips_are_errors() {
    let tips = bounces(10, &[5], 0.0);
    let ok = snare_note(5, 1);
    let f = |notes: &[StrikeNote], tips: &[[[f32; 3]; 2]]| fraction_on_surface_within(notes, tips, FPS, 1);
    assert!(matches!(f(&[], &tips), Err(MotionMetricError::Empty { .. })));
    assert!(matches!(f(&[ok], &[]), Err(MotionMetricError::Empty { .. })));
    assert!(f(&[StrikeNote { hand: 2, ..ok }], &tips).unwrap_err().to_string().contains("hand 2"));
    assert!(f(&[StrikeNote { normal: [0.0; 3], ..ok }], &tips).is_err());
    assert!(f(&[StrikeNote { time_s: f64::NAN, ..ok }], &tips).is_err());
    assert!(f(&[StrikeNote { radius_m: -1.0, ..ok }], &tips).is_err());
    let mut nan = tips.clone();
    nan[3][0][1] = f32::NAN;
    assert!(matches!(f(&[ok], &nan), Err(MotionMetricError::NotFinite { frame: 3, .. })));
    // A note past the end of the motion is simply not struck.
    assert_eq!(f(&[snare_note(50, 1)], &tips).unwrap(), 0.0);
}
