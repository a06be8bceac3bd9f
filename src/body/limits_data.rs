//! The joint limits drumsim ships, and the motion they are fitted from.
//!
//! Until captured drumming motion is loaded (issue 4's corpus), the motion the project has
//! is its own kinematic drumming: every stroke style played by each hand on every piece of
//! the default kit it can strike (hoops and the kick excluded), through the kinematic IK
//! from the ready pose. `drumsim limits` refits them (Algorithm 1) from that motion, or
//! from any joint trajectories given as JSON; config/limits.json is the shipped result.

use super::limits::{fit_all, JointLimit, LimitError};
use super::sim::{nalgebra_quat, Drummer, DrummerError, DrummerSettings, Mode};
use super::skeleton::JOINTS;
use super::strokes::{interpolate, sample, StrokePlan, Style};
use super::trials::STEPS_PER_FRAME;
use crate::kit::Kit;
use nalgebra::UnitQuaternion;

/// The shipped limits (config/limits.json, compiled in).
pub const LIMITS_JSON: &str = include_str!("../../config/limits.json");

/// Margin added around the motion's bounding ellipsoid, and the smallest radius, radians.
pub const MARGIN: f32 = 0.15;
pub const MIN_RADIUS_RAD: f32 = 0.12;

/// The shipped limits.
pub fn shipped() -> Vec<JointLimit> {
    serde_json::from_str(LIMITS_JSON).expect("config/limits.json is valid (tested)")
}

/// Joint trajectories (per joint, 250 Hz samples) of kinematic drumming on `kit`.
pub fn kinematic_drumming(kit: &Kit) -> Result<Vec<Vec<UnitQuaternion<f32>>>, DrummerError> {
    let settings = DrummerSettings { limits: None, ..DrummerSettings::default() };
    let probe = Drummer::new(kit, settings.clone())?;
    let mut traj: Vec<Vec<UnitQuaternion<f32>>> = vec![Vec::new(); JOINTS];
    let playable: Vec<usize> = (0..probe.surfaces().len())
        .filter(|&k| {
            let id = &probe.surfaces()[k].id;
            !id.ends_with("_rim") && id != "kick"
        })
        .collect();
    let ready = ["snare", "hihat"].map(|id| probe.surfaces().iter().position(|s| s.id == id).unwrap_or(0));
    for side in 0..2 {
        for &k in &playable {
            for style in [Style::Legato, Style::Accent, Style::Staccato] {
                let mut d = Drummer::new(kit, settings.clone())?;
                let s = d.surfaces();
                let p = style.params();
                let hits = vec![0.4, 0.4 + p.period_s as f64];
                let active = StrokePlan::on(&s[k], side, 0.0, -0.3 * s[k].radius_m, p, hits);
                let idle = StrokePlan::on(&s[ready[1 - side]], 1 - side, 0.0, 0.0, p, Vec::new());
                let plans = if side == 0 { [active, idle] } else { [idle, active] };
                let frames = sample(&plans, 0.6 + 2.0 * p.period_s as f64);
                for step in 0..(frames.len() - 1) * STEPS_PER_FRAME {
                    d.step_tips(Mode::Ik, &interpolate(&frames, (step + 1) as f64 * 1e-4), &mut |_| {});
                    if (step + 1) % STEPS_PER_FRAME == 0 {
                        for (j, q) in d.kinematic_joints().iter().enumerate() {
                            traj[j].push(nalgebra_quat(*q));
                        }
                    }
                }
            }
        }
    }
    Ok(traj)
}

/// Fit the limits from joint trajectories (Algorithm 1).
pub fn fit(trajectories: &[Vec<UnitQuaternion<f32>>]) -> Result<Vec<JointLimit>, LimitError> {
    fit_all(trajectories, MARGIN, MIN_RADIUS_RAD)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shipped_limits_cover_every_joint_and_compile() {
        let l = shipped();
        assert_eq!(l.len(), JOINTS);
        for (j, limit) in l.iter().enumerate() {
            limit.compile().unwrap_or_else(|e| panic!("joint {j}: {e}"));
            assert!(limit.radii.iter().all(|r| *r >= MIN_RADIUS_RAD * 0.999), "joint {j}: {:?}", limit.radii);
        }
    }
}
