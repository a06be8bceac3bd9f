//! Does a planned stick tip meet the struck surface, on the right piece, on time?
//! (DRUMS cannot check this, its stated limit; drumsim's strike planning must.)
//!
//! A note's surface is a plane (a point at the piece's centre, its outward normal) cut to
//! a disc of the piece's radius. The tip's signed distance is `(tip - centre) . n`,
//! positive above the surface. Frames are `round(time_s * fps)`.
//! - [`strike_crossings`]: per note, the frame where the tip of the note's hand *arrives*
//!   at the plane (signed distance <= tolerance after a frame above it, or already at
//!   frame 0) within `search_frames` of the note's frame, the arrival nearest the note
//!   frame (the earlier on a tie, so a neighbouring stroke of a fast roll is not taken
//!   when this one's arrival is closer), its offset (arrival - note frame) and whether the
//!   tip was within the disc there.
//! - [`fraction_on_surface_within`]: the share of notes whose tip is *on* the surface
//!   (within [`SURFACE_TOL_M`] of the plane, either side, and within the radius of the
//!   centre measured in the plane) at some frame within +-`frames_tol` of the note frame.

use super::motion::MotionMetricError;

/// How close to the plane counts as touching it, metres (5 mm).
pub const SURFACE_TOL_M: f32 = 0.005;
/// How far from a note's frame [`strike_crossings`] looks for the arrival (100 ms at 60 fps).
pub const SEARCH_FRAMES: usize = 6;

/// A note to be struck: when, by which hand (0 left, 1 right), and the struck surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrikeNote {
    pub time_s: f64,
    pub hand: usize,
    /// Centre of the playing surface, kit frame, metres.
    pub center: [f32; 3],
    /// Outward normal of the surface (normalised here).
    pub normal: [f32; 3],
    pub radius_m: f32,
}

/// Where a note's tip arrived at its surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrikeCrossing {
    pub note_frame: i64,
    /// The arrival frame, None when the tip did not reach the plane within the search.
    pub frame: Option<usize>,
    /// `frame - note_frame`.
    pub offset_frames: Option<i64>,
    /// The tip was within the piece's radius of its centre at the arrival.
    pub on_piece: bool,
}

/// A note checked and its normal made unit: (note frame, hand, unit normal).
fn checked(note: &StrikeNote, index: usize, fps: f64) -> Result<(i64, usize, [f32; 3]), MotionMetricError> {
    let bad = |message: String| MotionMetricError::Invalid { what: "strike note", message };
    if note.hand > 1 {
        return Err(bad(format!("note {index}: hand {} is not 0 (left) or 1 (right)", note.hand)));
    }
    let n = note.normal;
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    if !(len.is_finite() && len > 1e-6) {
        return Err(bad(format!("note {index}: normal {n:?} is not a direction")));
    }
    if !(note.time_s.is_finite() && note.radius_m.is_finite() && note.radius_m > 0.0) {
        return Err(bad(format!("note {index}: time {} s, radius {} m", note.time_s, note.radius_m)));
    }
    if !note.center.iter().all(|v| v.is_finite()) {
        return Err(bad(format!("note {index}: centre {:?} is not finite", note.center)));
    }
    Ok(((note.time_s * fps).round() as i64, note.hand, n.map(|v| v / len)))
}

fn check_inputs(notes: &[StrikeNote], tips: &[[[f32; 3]; 2]], fps: f64) -> Result<(), MotionMetricError> {
    if !(fps.is_finite() && fps > 0.0) {
        return Err(MotionMetricError::Invalid { what: "strike", message: format!("fps {fps} must be positive") });
    }
    if notes.is_empty() {
        return Err(MotionMetricError::Empty { what: "strike notes" });
    }
    if tips.is_empty() {
        return Err(MotionMetricError::Empty { what: "strike tips" });
    }
    match tips.iter().position(|f| !f.iter().flatten().all(|v| v.is_finite())) {
        Some(frame) => Err(MotionMetricError::NotFinite { what: "strike tips", frame }),
        None => Ok(()),
    }
}

/// Signed distance above the plane and distance from the centre within the plane.
fn place(tip: [f32; 3], center: [f32; 3], normal: [f32; 3]) -> (f32, f32) {
    let v = [tip[0] - center[0], tip[1] - center[1], tip[2] - center[2]];
    let d = v[0] * normal[0] + v[1] * normal[1] + v[2] * normal[2];
    let lateral = (0..3).map(|k| (v[k] - d * normal[k]).powi(2)).sum::<f32>().sqrt();
    (d, lateral)
}

/// Frames `[centre - reach, centre + reach]` that exist in a trajectory of `len` frames.
fn window(centre: i64, reach: usize, len: usize) -> std::ops::Range<usize> {
    let lo = (centre - reach as i64).max(0);
    let hi = (centre + reach as i64 + 1).min(len as i64);
    if lo >= hi {
        0..0
    } else {
        lo as usize..hi as usize
    }
}

/// Per note, the tip's arrival at the struck plane near the note (module doc).
/// `tips[frame][hand]`; `tolerance_m` is how far above the plane still counts as arrived.
pub fn strike_crossings(
    notes: &[StrikeNote],
    tips: &[[[f32; 3]; 2]],
    fps: f64,
    tolerance_m: f32,
    search_frames: usize,
) -> Result<Vec<StrikeCrossing>, MotionMetricError> {
    check_inputs(notes, tips, fps)?;
    let mut out = Vec::with_capacity(notes.len());
    for (i, note) in notes.iter().enumerate() {
        let (nf, hand, normal) = checked(note, i, fps)?;
        let dist = |f: usize| place(tips[f][hand], note.center, normal);
        let arrival = window(nf, search_frames, tips.len())
            .filter(|&f| dist(f).0 <= tolerance_m && (f == 0 || dist(f - 1).0 > tolerance_m))
            .min_by_key(|&f| ((f as i64 - nf).abs(), f));
        out.push(StrikeCrossing {
            note_frame: nf,
            frame: arrival,
            offset_frames: arrival.map(|f| f as i64 - nf),
            on_piece: arrival.is_some_and(|f| dist(f).1 <= note.radius_m),
        });
    }
    Ok(out)
}

/// Share of notes whose hand's tip is on the right piece's surface (within
/// [`SURFACE_TOL_M`] of the plane and the radius of the centre) at a frame within
/// +-`frames_tol` of the note's frame.
pub fn fraction_on_surface_within(
    notes: &[StrikeNote],
    tips: &[[[f32; 3]; 2]],
    fps: f64,
    frames_tol: usize,
) -> Result<f64, MotionMetricError> {
    check_inputs(notes, tips, fps)?;
    let mut on = 0usize;
    for (i, note) in notes.iter().enumerate() {
        let (nf, hand, normal) = checked(note, i, fps)?;
        let hit = window(nf, frames_tol, tips.len()).any(|f| {
            let (d, lateral) = place(tips[f][hand], note.center, normal);
            d.abs() <= SURFACE_TOL_M && lateral <= note.radius_m
        });
        on += usize::from(hit);
    }
    Ok(on as f64 / notes.len() as f64)
}

#[cfg(test)]
#[path = "strike_tests.rs"]
mod tests;
