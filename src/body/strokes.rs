//! The five stroke styles of the HIMC evaluation, as stick-tip trajectories.
//!
//! A stroke is a height profile over the struck surface: the tip waits at its preparatory
//! height, falls with constant acceleration so it meets the surface at the aimed time with
//! its full speed (aimed `depth` below the surface, which the drum stops), then rebounds
//! (decelerating) to the height the next stroke needs. Styles differ in height, depth of
//! travel, how much of the height the rebound regains, the fall time, a forward arc, and
//! the stiffness of the arm (a scale on the PD's natural frequency).
//!
//! The stick's direction follows the tip about a grip that rises half as much as the tip,
//! so strokes use wrist and arm together.

use super::ik::ArmTarget;
use super::model::Surface;
use super::sim::stick_dir;
use super::skeleton::STICK_RADIUS_M;
use rapier3d::math::Vector;

/// Task rate of Algorithm 2: targets arrive at 250 Hz.
pub const TASK_HZ: f64 = 250.0;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Style {
    Legato,
    Tenuto,
    Accent,
    VerticalAccent,
    Staccato,
}

/// Shape of one style.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StyleParams {
    /// Preparatory tip height above the surface, m.
    pub height_m: f32,
    /// How far below the surface the motion aims (the drum stops the tip), m.
    pub depth_m: f32,
    /// Fraction of the height regained by the rebound before the next preparation.
    pub rebound: f32,
    /// Fall time from the preparatory height to the surface, s.
    pub fall_s: f32,
    /// Rebound time, s.
    pub rise_s: f32,
    /// Backward travel of the tip at full height (an arc), m; 0 for a vertical stroke.
    pub arc_m: f32,
    /// Scale on the PD natural frequency (a stiffer arm).
    pub stiffness: f32,
    /// Time from one stroke to the next, s.
    pub period_s: f32,
}

impl Style {
    pub const ALL: [Style; 5] = [Style::Legato, Style::Tenuto, Style::Accent, Style::VerticalAccent, Style::Staccato];

    pub fn name(self) -> &'static str {
        match self {
            Style::Legato => "legato",
            Style::Tenuto => "tenuto",
            Style::Accent => "accent",
            Style::VerticalAccent => "vertical_accent",
            Style::Staccato => "staccato",
        }
    }

    pub fn params(self) -> StyleParams {
        match self {
            // Relaxed full strokes: the stick falls and comes back to where it started.
            Style::Legato => StyleParams {
                height_m: 0.15,
                depth_m: 0.005,
                rebound: 1.0,
                fall_s: 0.10,
                rise_s: 0.14,
                arc_m: 0.03,
                stiffness: 1.0,
                period_s: 0.5,
            },
            // Held, sustained: lower, presses a little longer into the head, half rebound.
            Style::Tenuto => StyleParams {
                height_m: 0.10,
                depth_m: 0.010,
                rebound: 0.5,
                fall_s: 0.10,
                rise_s: 0.20,
                arc_m: 0.02,
                stiffness: 1.2,
                period_s: 0.5,
            },
            // Loud: high preparation, fast fall, stopped low after the hit (a downstroke).
            Style::Accent => StyleParams {
                height_m: 0.28,
                depth_m: 0.010,
                rebound: 0.2,
                fall_s: 0.09,
                rise_s: 0.12,
                arc_m: 0.04,
                stiffness: 1.3,
                period_s: 0.6,
            },
            // As high and loud, but straight up and down, with a stiff arm.
            Style::VerticalAccent => StyleParams {
                height_m: 0.30,
                depth_m: 0.010,
                rebound: 0.2,
                fall_s: 0.09,
                rise_s: 0.12,
                arc_m: 0.0,
                stiffness: 1.5,
                period_s: 0.6,
            },
            // Short and detached: low, quick, stopped right after the hit.
            Style::Staccato => StyleParams {
                height_m: 0.06,
                depth_m: 0.004,
                rebound: 0.6,
                fall_s: 0.05,
                rise_s: 0.05,
                arc_m: 0.01,
                stiffness: 1.6,
                period_s: 0.25,
            },
        }
    }
}

/// Where and how one hand strikes: a surface, the aimed point on it, the stroke shape and
/// the times of the hits.
#[derive(Debug, Clone)]
pub struct StrokePlan {
    pub side: usize,
    pub point: Vector,
    pub normal: Vector,
    /// Unit direction of the stick at the hit, and the horizontal "back" of the arc.
    pub dir: Vector,
    pub back: Vector,
    pub params: StyleParams,
    /// Times at which the tip is aimed to reach the surface, seconds, ascending.
    pub hits: Vec<f64>,
}

impl StrokePlan {
    /// A plan striking `surface` at `(x, y)` (metres, surface coordinates) at `hits`.
    pub fn on(surface: &Surface, side: usize, x: f32, y: f32, params: StyleParams, hits: Vec<f64>) -> StrokePlan {
        let point = surface.center + surface.u * x + surface.v * y;
        let dir = stick_dir(side, surface.center, surface.normal);
        let flat = dir - surface.normal * dir.dot(surface.normal);
        StrokePlan { side, point, normal: surface.normal, dir, back: -flat.normalize_or_zero(), params, hits }
    }

    /// Tip height above the surface (negative: aimed into it) at time `t`.
    ///
    /// Around each hit: the fall (from rest at the preparatory height, constant acceleration,
    /// height 0 at the hit), the press (down to `-depth` and back in a quarter of the rise
    /// time), the rebound (ease-out to `rebound * height`), then the preparation (a smooth
    /// lift back to full height before the next fall).
    pub fn height(&self, t: f64) -> f32 {
        let p = &self.params;
        let (top, low) = (p.height_m, p.height_m * p.rebound);
        let press = 0.25 * p.rise_s as f64;
        let rise = 0.75 * p.rise_s as f64;
        let next = self.hits.iter().position(|&h| h >= t);
        if let Some(i) = next {
            let n = self.hits[i];
            let fall_start = n - p.fall_s as f64;
            if t >= fall_start {
                let s = ((t - fall_start) / p.fall_s as f64) as f32;
                return top * (1.0 - s * s);
            }
        }
        let Some(h) = next.map_or(self.hits.last().copied(), |i| i.checked_sub(1).map(|k| self.hits[k])) else {
            return top;
        };
        let since = t - h;
        if since < press {
            let s = (since / press) as f32;
            return -p.depth_m * (std::f32::consts::PI * s).sin();
        }
        if since < press + rise {
            let u = ((since - press) / rise) as f32;
            return low * (1.0 - (1.0 - u) * (1.0 - u));
        }
        let Some(n) = next.map(|i| self.hits[i]) else { return low };
        // Preparation: smoothstep from the rebound height to full height before the fall.
        let start = h + press + rise;
        let end = n - p.fall_s as f64;
        let u = if end > start { ((t - start) / (end - start)).clamp(0.0, 1.0) as f32 } else { 1.0 };
        low + (top - low) * u * u * (3.0 - 2.0 * u)
    }

    /// The arm target at time `t`. Heights are of the tip bead's lowest point: its centre
    /// rides one stick radius higher, so the bead meets the surface exactly at a hit.
    pub fn target(&self, t: f64) -> ArmTarget {
        let h = self.height(t);
        let up = h.max(0.0);
        let frac = if self.params.height_m > 0.0 { up / self.params.height_m } else { 0.0 };
        let tip = self.point + self.normal * (h + STICK_RADIUS_M) + self.back * (self.params.arc_m * frac);
        let to_tip = 0.28;
        let grip = self.point - self.dir * to_tip + self.normal * (0.5 * up);
        ArmTarget { tip, dir: (tip - grip).normalize_or(self.dir) }
    }
}

/// Targets sampled at the task rate, from `t0` for `duration` seconds.
pub fn sample(plans: &[StrokePlan; 2], duration_s: f64) -> Vec<[ArmTarget; 2]> {
    let n = (duration_s * TASK_HZ).ceil() as usize + 1;
    (0..n)
        .map(|k| {
            let t = k as f64 / TASK_HZ;
            [plans[0].target(t), plans[1].target(t)]
        })
        .collect()
}

/// Linear interpolation of task-rate targets at time `t` (held after the last frame).
pub fn interpolate(frames: &[[ArmTarget; 2]], t: f64) -> [ArmTarget; 2] {
    let x = (t * TASK_HZ).max(0.0);
    let k = (x.floor() as usize).min(frames.len().saturating_sub(1));
    let k1 = (k + 1).min(frames.len() - 1);
    let a = (x - k as f64).clamp(0.0, 1.0) as f32;
    std::array::from_fn(|side| {
        let (p, q) = (frames[k][side], frames[k1][side]);
        ArmTarget { tip: p.tip.lerp(q.tip, a), dir: p.dir.lerp(q.dir, a).normalize_or(p.dir) }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::model::surface_basis;

    fn flat() -> Surface {
        let (u, v) = surface_basis(Vector::Z);
        Surface {
            id: "snare".into(),
            collider: rapier3d::prelude::ColliderHandle::invalid(),
            center: Vector::new(0.0, 0.4, 0.6),
            normal: Vector::Z,
            u,
            v,
            radius_m: 0.18,
            depth_m: 0.3,
        }
    }

    #[test]
    fn the_tip_reaches_the_surface_exactly_at_each_hit_and_falls_fast() {
        for style in Style::ALL {
            let p = style.params();
            let plan = StrokePlan::on(&flat(), 0, 0.0, -0.05, p, vec![0.5, 0.5 + p.period_s as f64]);
            for &hit in &plan.hits {
                assert!(plan.height(hit).abs() < 1e-6, "{}: {}", style.name(), plan.height(hit));
                // Speed just before the hit: 2 h / fall_s for a fall from rest.
                let dt = 1e-4;
                let v = (plan.height(hit - dt) - plan.height(hit)) / dt as f32;
                assert!(v > 0.5 && v < 12.0, "{}: {v} m/s", style.name());
                assert!(plan.height(hit + 0.01) < 0.0, "aimed into the head after the hit");
            }
            assert!((plan.height(0.0) - p.height_m).abs() < 1e-6);
        }
        // Accents fall faster than legato strokes, staccato strokes are the lowest.
        let speed = |s: Style| 2.0 * s.params().height_m / s.params().fall_s;
        assert!(speed(Style::Accent) > 1.5 * speed(Style::Legato));
        assert!(Style::ALL.iter().all(|s| s.params().height_m >= Style::Staccato.params().height_m));
    }

    #[test]
    fn interpolation_passes_through_the_frames() {
        let p = Style::Legato.params();
        let plan = StrokePlan::on(&flat(), 0, 0.0, 0.0, p, vec![0.3]);
        let plans = [plan.clone(), plan];
        let frames = sample(&plans, 1.0);
        let at = interpolate(&frames, 0.3);
        assert!((at[0].tip - plans[0].target(0.3).tip).length() < 1e-5);
        assert!(
            ((at[0].tip - plans[0].point).dot(Vector::Z) - STICK_RADIUS_M).abs() < 1e-5,
            "the bead touches at the hit"
        );
        let mid = interpolate(&frames, 0.302);
        let expect = (frames[75][0].tip + frames[76][0].tip) * 0.5;
        assert!((mid[0].tip - expect).length() < 1e-5);
    }
}
