//! The grip's path and its timing between a hand's contacts.
//!
//! A drummer's hand is fastest when the stick strikes: the wrist keeps moving through the
//! impact while the stick rebounds in the fingers. The teacher builds the grip (the hand
//! pose's position) so that its speed, sampled at 60 fps, peaks at every note of that hand and
//! nowhere a listener would not expect: the hand-speed peaks that DRUMS' beat alignment
//! measures. At each contact the grip is exactly at the *impact grip*, where the tip is on the
//! strike point with the stick pitched [`PITCH_IMPACT_DEG`] (plus a run's drift, below).
//!
//! - **Strokes** (gaps of at least [`GLIDE_BELOW_S`]): the grip runs straight down through
//!   the contact, its speed `V cos(pi/2 x)` over a window of half-width `w` either side
//!   (`V` a fraction of the note's tip speed, [`GRIP_SPEED_FRACTION`]; `w` at most [`HALF_S`]
//!   and a quarter of the gap), so it comes to rest `2 V w / pi` below the contact. Between
//!   two windows one straight upstroke (which also carries any travel to the next piece)
//!   takes it from there to as far above the next contact, from rest to rest, fastest once:
//!   on another hand's note inside it if there is one (so the extra speed peak an upstroke
//!   must have lands on a beat), else in its middle. That moment is nudged (by up to a fifth
//!   of the upstroke) until the 60 fps speed, smoothed as DRUMS smooths it, peaks on the
//!   note's frame.
//! - **Glides** (shorter gaps, fast runs): the grip does not turn back. Between two contacts
//!   it follows a cubic curve that leaves and arrives moving straight down, timed so that its
//!   speed falls from one contact's speed to a single minimum and rises to the next's
//!   (`V_a f(u) + V_b f(1 - u)`, `f(u) = (1 - u)^k (1 + k u)`, `k` fitted to the curve's
//!   length). On one drum the stick's impact pitch drifts along the run so that the impact
//!   grips step down (at most [`RUN_DRIFT_MAX_RAD`] over a run, the run's speeds scaled to
//!   fit); where a glide's travel is longer than its speeds cover, both are raised.
//!
//! Before a hand's first note it waits above it; after its last it stays where the stroke
//! left it; a hand that never plays waits over its rest place. Known limit: a hand turning
//! back between two drums faster than about 150 ms can show its sampled speed peak a frame
//! off the note.

use super::normalize;
use super::travel::{lerp3, min_jerk};
use crate::motion::STICK_TIP_LOCAL;
use std::f32::consts::PI;

/// Grip speed at a contact as a fraction of the stick tip's strike speed.
pub const GRIP_SPEED_FRACTION: f32 = 0.15;
/// Longest half-width of the stroke window around a contact, seconds.
pub const HALF_S: f64 = 0.06;
/// The half-width is at most this fraction of the gap to either neighbouring contact.
pub const HALF_FRACTION: f64 = 0.25;
/// The upstroke between two contacts is fastest at another hand's note near the middle of
/// it, at least this fraction of it from either end (else at the middle).
pub const PEAK_MARGIN: f64 = 0.1;
/// Gaps shorter than this are glides: the grip does not turn back between the contacts but
/// moves on, fastest at each, while the stick's impact pitch drifts along the run.
pub const GLIDE_BELOW_S: f64 = 10.0 / 60.0;
/// Largest pitch drift over a run of glides, radians (its speeds are scaled down to fit).
pub const RUN_DRIFT_MAX_RAD: f32 = 0.28;
/// A glide's length is its gap times the sum of its two contact speeds over this (the
/// share of the ramps at their natural exponent 4).
const GLIDE_RAMP_SHARE: f64 = 3.0;
/// How far above its impact grip a hand that never plays waits.
pub const REST_ABOVE_M: f32 = 0.03;
/// Stick pitch below the horizontal at impact.
pub const PITCH_IMPACT_DEG: f32 = -20.0;
/// Shoulder pivots (x, y) the sticks are yawed from: left, right.
pub const PIVOTS: [[f32; 2]; 2] = [[-0.30, -0.15], [0.30, -0.15]];

/// Stick length from grip to tip.
fn stick_len() -> f32 {
    STICK_TIP_LOCAL[1]
}

/// Yaw of `hand`'s stick toward `point`, from its shoulder pivot.
pub fn yaw_toward(hand: usize, point: [f32; 3]) -> f32 {
    let pivot = PIVOTS[hand];
    (-(point[0] - pivot[0])).atan2(point[1] - pivot[1])
}

/// The stick's direction (grip to tip) for a yaw and a pitch: `Rz(yaw) Rx(pitch)` of +y.
pub fn stick_dir(yaw: f32, pitch: f32) -> [f32; 3] {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    [-sy * cp, cy * cp, sp]
}

/// The rotation (w, x, y, z) `Rz(yaw) Rx(pitch)`.
pub fn rotation(yaw: f32, pitch: f32) -> [f32; 4] {
    let (sy, cy) = (yaw / 2.0).sin_cos();
    let (sp, cp) = (pitch / 2.0).sin_cos();
    [cy * cp, cy * sp, sy * sp, sy * cp]
}

/// Where `hand`'s grip is when its tip strikes `point`.
pub fn impact_grip(hand: usize, point: [f32; 3]) -> [f32; 3] {
    grip_for_pitch(hand, point, PITCH_IMPACT_DEG.to_radians())
}

/// Where `hand`'s grip is when its tip is on `point` with the stick pitched `pitch`.
fn grip_for_pitch(hand: usize, point: [f32; 3], pitch: f32) -> [f32; 3] {
    let d = stick_dir(yaw_toward(hand, point), pitch);
    let l = stick_len();
    [point[0] - l * d[0], point[1] - l * d[1], point[2] - l * d[2]]
}

/// The pitch that puts the tip of a stick held at `grip` (yawed `yaw`) `h` metres above the
/// plane through `base` with normal `n`: Newton's method from the impact pitch, kept within
/// +-80 degrees (where no pitch reaches, the nearest one).
pub fn solve_pitch(grip: [f32; 3], base: [f32; 3], n: [f32; 3], yaw: f32, h: f32) -> f32 {
    let l = stick_len();
    let (sy, cy) = yaw.sin_cos();
    let off = (0..3).map(|k| (grip[k] - base[k]) * n[k]).sum::<f32>();
    let limit = 80f32.to_radians();
    let mut p = PITCH_IMPACT_DEG.to_radians();
    for _ in 0..8 {
        let (sp, cp) = p.sin_cos();
        let f = off + l * (-sy * cp * n[0] + cy * cp * n[1] + sp * n[2]) - h;
        let df = l * (sy * sp * n[0] - cy * sp * n[1] + cp * n[2]);
        if f.abs() < 1e-7 || df.abs() < 1e-6 {
            break;
        }
        p = (p - f / df).clamp(-limit, limit);
    }
    p
}

/// One contact as the grip sees it.
#[derive(Debug, Clone, Copy)]
pub struct GripHit {
    pub t: f64,
    pub point: [f32; 3],
    pub normal: [f32; 3],
    /// Grip speed at the contact, m/s.
    pub speed: f32,
}

/// A hand's grip over a whole performance (see the module doc).
#[derive(Debug, Clone)]
pub struct GripTrack {
    hand: usize,
    hits: Vec<GripHit>,
    /// Each contact's impact grip (with its run's pitch drift).
    impact: Vec<[f32; 3]>,
    /// Half-width of each contact's stroke window, seconds.
    half: Vec<f64>,
    /// How far the grip runs straight through each contact on either side, metres.
    reach: Vec<f32>,
    /// Per gap (after contact i): a glide for a short gap, `None` for a stroke (window,
    /// upstroke, window).
    glide: Vec<Option<Glide>>,
    /// Per gap: where its upstroke is fastest, as a fraction of the upstroke.
    peak: Vec<f64>,
    rest: ([f32; 3], [f32; 3]),
}

/// Where the aim of a stick is: the surface point below it, the normal, the yaw.
pub type Aim = ([f32; 3], [f32; 3], f32);

/// `integral_0^x (1 - u)^k (1 + k u) du`; the ramp is 1 with zero slope at 0, 0 at 1.
fn ramp_integral(k: f64, x: f64) -> f64 {
    let x = x.clamp(0.0, 1.0);
    let a = 1.0 - (1.0 - x).powf(k + 1.0);
    let b = 1.0 - (1.0 - x).powf(k + 2.0);
    a / (k + 1.0) + k * (a / (k + 1.0) - b / (k + 2.0))
}

fn dist(a: [f32; 3], b: [f32; 3]) -> f64 {
    (0..3).map(|i| ((a[i] - b[i]) as f64).powi(2)).sum::<f64>().sqrt()
}

impl GripTrack {
    /// The grip for `hits` (time order, distinct times). `onsets` are the times of every
    /// hand-played note (both hands, sorted); `rest` is where a hand with no notes waits.
    pub fn new(hand: usize, mut hits: Vec<GripHit>, onsets: &[f64], rest: ([f32; 3], [f32; 3])) -> GripTrack {
        let n = hits.len();
        let gaps: Vec<f64> = hits.windows(2).map(|w| w[1].t - w[0].t).collect();
        let short = |g: usize| gaps[g] < GLIDE_BELOW_S;
        // Runs of contacts joined by short gaps: slower grips, and the pitch drifts along.
        let mut drift = vec![0.0f32; n];
        let mut start = 0;
        while start < n {
            let mut end = start;
            while end + 1 < n && short(end) {
                end += 1;
            }
            if end > start {
                let lengths: Vec<f64> = (start..end)
                    .map(|g| gaps[g] * (hits[g].speed + hits[g + 1].speed) as f64 / GLIDE_RAMP_SHARE)
                    .collect();
                let total = lengths.iter().sum::<f64>();
                let scale = (RUN_DRIFT_MAX_RAD as f64 * stick_len() as f64 / total.max(1e-9)).min(1.0);
                for h in &mut hits[start..=end] {
                    h.speed *= scale as f32;
                }
                let mut acc = 0.0;
                for (g, want) in (start..end).zip(&lengths) {
                    let travel = dist(impact_grip(hand, hits[g].point), impact_grip(hand, hits[g + 1].point));
                    let want = want * scale;
                    drift[g] = acc as f32;
                    acc += (want * want - travel * travel).max(0.0).sqrt() / stick_len() as f64;
                }
                drift[end] = acc as f32;
                for d in &mut drift[start..=end] {
                    *d -= 0.5 * acc as f32;
                }
            }
            start = end + 1;
        }
        let impact: Vec<[f32; 3]> = hits
            .iter()
            .zip(&drift)
            .map(|(h, &dp)| grip_for_pitch(hand, h.point, PITCH_IMPACT_DEG.to_radians() + dp))
            .collect();
        // A glide whose path its contact speeds could not cover at ramp exponent 4 raises
        // both (one forward pass: raising only lengthens the other gap a speed borders).
        let paths: Vec<Option<Vec<f64>>> =
            (0..gaps.len()).map(|g| short(g).then(|| glide_lengths(impact[g], impact[g + 1]))).collect();
        for (g, path) in paths.iter().enumerate() {
            let Some(path) = path else { continue };
            let need = 6.0 * path[GLIDE_SAMPLES] / (2.0 * gaps[g]);
            let have = (hits[g].speed + hits[g + 1].speed) as f64;
            if have < need {
                let f = (need / have.max(1e-9)) as f32;
                hits[g].speed *= f;
                hits[g + 1].speed *= f;
            }
        }
        let glide: Vec<Option<Glide>> = paths
            .into_iter()
            .enumerate()
            .map(|(g, path)| {
                path.map(|lengths| {
                    let len = lengths[GLIDE_SAMPLES].max(1e-6);
                    let k = (2.0 * gaps[g] * (hits[g].speed + hits[g + 1].speed) as f64 / len - 2.0).clamp(2.5, 40.0);
                    Glide { k, lengths }
                })
            })
            .collect();
        // A stroke window beside a glide matches the glide's ramp at the contact (the same
        // curvature of speed), so the speed peak is symmetric about it.
        let matched = |g: usize| {
            glide[g].as_ref().map_or(f64::INFINITY, |gl| PI as f64 * gaps[g] / (2.0 * (gl.k * (gl.k + 1.0)).sqrt()))
        };
        let half: Vec<f64> = (0..n)
            .map(|i| {
                let before = i.checked_sub(1).filter(|&g| !short(g)).map_or(f64::INFINITY, |g| gaps[g]);
                let after = if i + 1 < n && !short(i) { gaps[i] } else { f64::INFINITY };
                let beside = i.checked_sub(1).map_or(f64::INFINITY, matched).min(if i + 1 < n {
                    matched(i)
                } else {
                    f64::INFINITY
                });
                HALF_S.min(HALF_FRACTION * before).min(HALF_FRACTION * after).min(beside)
            })
            .collect();
        let reach = hits.iter().zip(&half).map(|(h, &w)| 2.0 * h.speed * w as f32 / PI).collect();
        let mut targets = vec![None; gaps.len()];
        let peak = (0..gaps.len())
            .map(|i| {
                let (t0, t1) = (hits[i].t + half[i], hits[i + 1].t - half[i + 1]);
                let mid = 0.5 * (t0 + t1);
                let lo = onsets.partition_point(|&o| o < t0 + PEAK_MARGIN * (t1 - t0));
                let hi = onsets.partition_point(|&o| o <= t1 - PEAK_MARGIN * (t1 - t0));
                let at =
                    onsets[lo..hi.max(lo)].iter().copied().min_by(|a, b| (a - mid).abs().total_cmp(&(b - mid).abs()));
                targets[i] = at;
                (at.unwrap_or(mid) - t0) / (t1 - t0).max(1e-9)
            })
            .collect();
        let mut track = GripTrack { hand, hits, impact, half, reach, glide, peak, rest };
        for (g, target) in targets.into_iter().enumerate() {
            if let (Some(t), None) = (target, &track.glide[g]) {
                track.tune_peak(g, t);
            }
        }
        track
    }

    /// Move upstroke `g`'s fastest moment (by up to 0.2 of it) until the grip's speed at 60
    /// frames a second, smoothed as DRUMS smooths it (central differences, Savitzky-Golay 7
    /// and 2), peaks on the frame of the note at `t`: an asymmetric upstroke's sampled peak
    /// can sit a frame off its continuous one.
    fn tune_peak(&mut self, g: usize, t: f64) {
        const SG7: [f64; 7] = [-2.0, 3.0, 6.0, 7.0, 6.0, 3.0, -2.0];
        let fps = crate::motion::FPS;
        let f = (t * fps).round() as i64;
        if f < 5 {
            return;
        }
        let original = self.peak[g];
        let smoothed_at = |track: &GripTrack| -> [f64; 3] {
            let pos: Vec<[f32; 3]> = (f - 5..=f + 5).map(|k| track.at(k as f64 / fps).0).collect();
            let speed: Vec<f64> = (1..pos.len() - 1).map(|k| dist(pos[k + 1], pos[k - 1])).collect();
            std::array::from_fn(|j| (0..7).map(|w| SG7[w] * speed[j + w]).sum::<f64>())
        };
        for step in 0..=20 {
            let delta = if step % 2 == 1 { (step / 2 + 1) as f64 } else { -((step / 2) as f64) } * 0.02;
            self.peak[g] = (original + delta).clamp(0.1, 0.9);
            let s = smoothed_at(self);
            if s[1] > s[0] && s[1] > s[2] {
                return;
            }
        }
        self.peak[g] = original;
    }

    fn aim(&self, base: [f32; 3], n: [f32; 3]) -> Aim {
        (base, n, yaw_toward(self.hand, base))
    }

    /// The grip `s` metres above (`s > 0`) or below contact `i`'s impact grip.
    fn on_line(&self, i: usize, s: f32) -> [f32; 3] {
        let g = self.impact[i];
        [g[0], g[1], g[2] + s]
    }

    /// The grip at `t`, and where the stick is aimed.
    pub fn at(&self, t: f64) -> ([f32; 3], Aim) {
        let here = |i: usize| self.aim(self.hits[i].point, self.hits[i].normal);
        let between = |a: usize, b: usize, p: f32| {
            let (ha, hb) = (self.hits[a], self.hits[b]);
            self.aim(lerp3(ha.point, hb.point, p), normalize(lerp3(ha.normal, hb.normal, p)))
        };
        if self.hits.is_empty() {
            let g = impact_grip(self.hand, self.rest.0);
            return ([g[0], g[1], g[2] + REST_ABOVE_M], self.aim(self.rest.0, self.rest.1));
        }
        let next = self.hits.partition_point(|h| h.t <= t);
        let prev = next.checked_sub(1);
        let next = (next < self.hits.len()).then_some(next);
        if let (Some(a), Some(b)) = (prev, next) {
            if let Some(gl) = &self.glide[a] {
                let (va, vb, k) = (self.hits[a].speed as f64, self.hits[b].speed as f64, gl.k);
                let u = (t - self.hits[a].t) / (self.hits[b].t - self.hits[a].t);
                let covered = va * ramp_integral(k, u) + vb * (ramp_integral(k, 1.0) - ramp_integral(k, 1.0 - u));
                let q = covered / ((va + vb) * ramp_integral(k, 1.0)).max(1e-12);
                let sp = gl.param_at(q);
                let p = min_jerk(sp as f32);
                return (glide_point(self.impact[a], self.impact[b], sp), between(a, b, p));
            }
        }
        if let Some(a) = prev {
            let x = (t - self.hits[a].t) / self.half[a];
            if x <= 1.0 {
                let s = self.reach[a] * (0.5 * PI * x as f32).sin();
                return (self.on_line(a, -s), here(a));
            }
        }
        if let Some(b) = next {
            let y = (self.hits[b].t - t) / self.half[b];
            if y <= 1.0 {
                let s = self.reach[b] * (0.5 * PI * y as f32).sin();
                return (self.on_line(b, s), here(b));
            }
        }
        match (prev, next) {
            (Some(a), Some(b)) => {
                let t0 = self.hits[a].t + self.half[a];
                let t1 = self.hits[b].t - self.half[b];
                let z = ((t - t0) / (t1 - t0).max(1e-9)).clamp(0.0, 1.0);
                let p = upstroke_progress(z, self.peak[a]) as f32;
                let from = self.on_line(a, -self.reach[a]);
                let to = self.on_line(b, self.reach[b]);
                (lerp3(from, to, p), between(a, b, p))
            }
            (None, Some(b)) => (self.on_line(b, self.reach[b]), here(b)),
            (Some(a), None) => (self.on_line(a, -self.reach[a]), here(a)),
            (None, None) => unreachable!("hits is not empty"),
        }
    }
}

/// A glide's end tangents are straight down, this many times the distance it spans.
const GLIDE_TANGENT: f64 = 3.0;
/// Samples of a glide's path for its arc length.
const GLIDE_SAMPLES: usize = 64;

/// A glide's path: the cubic Hermite curve from one impact grip to the next that leaves and
/// arrives moving straight down (tangents `-z` times [`GLIDE_TANGENT`] times their distance), so the grip goes on
/// down through every contact of a fast run, even one that turns back to another drum; it
/// turns between them, where it is slowest.
#[derive(Debug, Clone)]
struct Glide {
    /// Ramp exponent of its timing.
    k: f64,
    /// Cumulative arc length at `GLIDE_SAMPLES + 1` even steps of the curve parameter.
    lengths: Vec<f64>,
}

impl Glide {
    /// The curve parameter where fraction `q` of the arc length is covered.
    fn param_at(&self, q: f64) -> f64 {
        let total = self.lengths[GLIDE_SAMPLES];
        if total <= 0.0 {
            return q.clamp(0.0, 1.0);
        }
        let want = q.clamp(0.0, 1.0) * total;
        let j = self.lengths.partition_point(|&l| l < want).clamp(1, GLIDE_SAMPLES);
        let (l0, l1) = (self.lengths[j - 1], self.lengths[j]);
        let frac = if l1 > l0 { ((want - l0) / (l1 - l0)).clamp(0.0, 1.0) } else { 0.0 };
        (j as f64 - 1.0 + frac) / GLIDE_SAMPLES as f64
    }
}

/// The glide curve between impact grips `a` and `b` at parameter `s`.
fn glide_point(a: [f32; 3], b: [f32; 3], s: f64) -> [f32; 3] {
    let d = dist(a, b);
    let (s2, s3) = (s * s, s * s * s);
    let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2);
    std::array::from_fn(|k| {
        let m = if k == 2 { -GLIDE_TANGENT * d } else { 0.0 };
        (h00 * a[k] as f64 + h01 * b[k] as f64 + (h10 + h11) * m) as f32
    })
}

/// Cumulative arc length of the glide from `a` to `b`.
fn glide_lengths(a: [f32; 3], b: [f32; 3]) -> Vec<f64> {
    let pts: Vec<[f32; 3]> = (0..=GLIDE_SAMPLES).map(|j| glide_point(a, b, j as f64 / GLIDE_SAMPLES as f64)).collect();
    let mut out = vec![0.0];
    for w in pts.windows(2) {
        out.push(out[out.len() - 1] + dist(w[0], w[1]));
    }
    out
}

/// Progress (0 to 1) of an upstroke at fraction `z` of its time whose speed is
/// `sin^2(pi/2 z/zp)` up to `zp` and `sin^2(pi/2 (1-z)/(1-zp))` after: zero with zero slope at
/// both ends, one smooth maximum at `zp`.
fn upstroke_progress(z: f64, zp: f64) -> f64 {
    use std::f64::consts::PI;
    let zp = zp.clamp(0.05, 0.95);
    // integral_0^x sin^2(pi x / (2 w)) = x/2 - w/(2 pi) sin(pi x / w).
    let part = |x: f64, w: f64| x / 2.0 - w / (2.0 * PI) * (PI * x / w).sin();
    let covered = if z <= zp { part(z, zp) } else { zp / 2.0 + (1.0 - zp) / 2.0 - part(1.0 - z, 1.0 - zp) };
    2.0 * covered
}

#[cfg(test)]
mod tests {
    use super::*;

    const RIGHT_HAND: usize = 1;

    fn hit(t: f64, point: [f32; 3], speed: f32) -> GripHit {
        GripHit { t, point, normal: [0.0, 0.0, 1.0], speed }
    }

    /// Central-difference speed at 60 fps of the grip over `frames`.
    fn speeds(track: &GripTrack, frames: usize) -> Vec<f64> {
        let pos: Vec<[f32; 3]> = (0..frames).map(|f| track.at(f as f64 / 60.0).0).collect();
        (0..frames).map(|f| if f == 0 || f + 1 == frames { 0.0 } else { dist(pos[f + 1], pos[f - 1]) * 30.0 }).collect()
    }

    #[test]
    fn an_upstroke_runs_from_rest_to_rest_fastest_where_asked() {
        for zp in [0.2, 0.5, 0.8] {
            assert!(upstroke_progress(0.0, zp).abs() < 1e-12);
            assert!((upstroke_progress(1.0, zp) - 1.0).abs() < 1e-12);
            let v: Vec<f64> = (0..1000)
                .map(|i| upstroke_progress((i + 1) as f64 / 1000.0, zp) - upstroke_progress(i as f64 / 1000.0, zp))
                .collect();
            assert!(v.iter().all(|&d| d >= 0.0), "never turns back");
            let fastest = v.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).unwrap().0 as f64 / 1000.0;
            assert!((fastest - zp).abs() < 0.01, "fastest at {fastest}, asked {zp}");
        }
    }

    #[test]
    fn the_grip_is_on_its_impact_point_at_every_contact_and_fastest_there() {
        let snare = [0.0, 0.5, 0.6];
        let toms = [[0.1, 0.55, 0.65], [0.2, 0.6, 0.68], [0.32, 0.62, 0.7]];
        // Long gaps (strokes), a fast run on one drum (glides with pitch drift) and a fast run
        // round the toms.
        let mut hits = Vec::new();
        let mut t = 0.5;
        for (i, dt) in [0.5, 0.4, 0.3, 0.1, 0.1, 0.1, 0.1, 0.35, 0.15, 0.15, 0.4, 0.5].iter().enumerate() {
            let t_frame = (t * 60.0f64).round() / 60.0;
            hits.push(hit(t_frame, if (8..11).contains(&i) { toms[i - 8] } else { snare }, 0.6 + 0.05 * i as f32));
            t += dt;
        }
        let track = GripTrack::new(RIGHT_HAND, hits.clone(), &[], (snare, [0.0, 0.0, 1.0]));
        for (i, h) in hits.iter().enumerate() {
            let (g, (base, _, yaw)) = track.at(h.t);
            assert_eq!(base, h.point, "aimed at the struck point");
            // The tip, with the stick pitched to put it on the surface, is on the point.
            let p = solve_pitch(g, base, h.normal, yaw, 0.0);
            let d = stick_dir(yaw, p);
            let tip = [g[0] + stick_len() * d[0], g[1] + stick_len() * d[1], g[2] + stick_len() * d[2]];
            assert!(dist(tip, h.point) < 1e-5, "contact {i}: tip {tip:?}");
        }
        let v = speeds(&track, (t * 60.0) as usize + 30);
        for h in &hits {
            let f = (h.t * 60.0).round() as usize;
            assert!(
                v[f] > v[f - 1] && v[f] > v[f + 1],
                "speed peaks at the contact frame {f}: {:?}",
                &v[f - 3..=f + 3]
            );
        }
        // In the fast run the grip never turns back (its motion between frames keeps going
        // the same way): no upstroke, so no extra speed peak.
        let pos: Vec<[f32; 3]> = (0..v.len()).map(|f| track.at(f as f64 / 60.0).0).collect();
        let run = ((hits[3].t * 60.0).round() as usize, (hits[7].t * 60.0).round() as usize);
        for f in run.0 + 1..run.1 {
            let (a, b) = (pos[f], pos[f + 1]);
            let (c, d) = (pos[f - 1], pos[f]);
            let dot: f32 = (0..3).map(|k| (b[k] - a[k]) * (d[k] - c[k])).sum();
            assert!(dot > 0.0, "frame {f}: the grip turned back in a glide");
        }
    }

    #[test]
    fn an_upstroke_is_fastest_on_another_hands_note() {
        let snare = [0.0, 0.5, 0.6];
        let hits = vec![hit(0.5, snare, 1.0), hit(1.0, snare, 1.0)];
        // The other hand plays at frame 40 (not the middle, 45).
        let track = GripTrack::new(RIGHT_HAND, hits, &[40.0 / 60.0], (snare, [0.0, 0.0, 1.0]));
        let v = speeds(&track, 80);
        const SG7: [f64; 7] = [-2.0, 3.0, 6.0, 7.0, 6.0, 3.0, -2.0];
        let s: Vec<f64> = (3..v.len() - 3).map(|f| (0..7).map(|w| SG7[w] * v[f + w - 3]).sum()).collect();
        let peaks: Vec<usize> =
            (1..s.len() - 1).filter(|&i| s[i] > s[i - 1] && s[i] > s[i + 1]).map(|i| i + 3).collect();
        assert_eq!(peaks, vec![30, 40, 60], "speed peaks: the two contacts and the other hand's note");
    }
}
