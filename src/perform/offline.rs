//! A whole song played by the body, offline: the conductor's periods from the preroll to the
//! end, every new contact kept with its performance time, the simulated tips at 60 fps, and
//! what the stability checks need (penetration, energy, finiteness).

use super::conductor::{Conductor, PREROLL_S};
use crate::body::contacts::Strike;
use crate::body::sim::{DrummerError, DrummerSettings, Mode};
use crate::body::skeleton::HAND;
use crate::body::strokes::TASK_HZ;
use crate::interaction::ContactMessage;
use crate::kit::Kit;
use crate::midi::{NoteMap, Performance};
use crate::motion::pipeline::Planned;
use crate::motion::Pose;
use rapier3d::math::{Rotation, Vector};

/// Contacts this early before time 0 still belong to the song (at time 0), seconds.
const EARLY_S: f64 = 0.010;

/// What the body did over a song.
#[derive(Debug, Clone)]
pub struct PhysicalTake {
    /// Contacts from time 0 on (the preroll's are left out), in time order.
    pub strikes: Vec<Strike>,
    /// The contact messages of `strikes`, in the same order.
    pub messages: Vec<ContactMessage>,
    /// The simulated stick tips (left, right) at 60 fps from time 0.
    pub tips: Vec<[[f32; 3]; 2]>,
    /// The simulated hands as the motion's grip poses (stick along local +y, its tip
    /// [`crate::motion::track::STICK_TIP_LOCAL`] away when the sticks are the same length)
    /// at 60 fps from time 0.
    pub hands: Vec<[Pose; 2]>,
    /// The simulated hi-hat's openness at 60 fps from time 0 (empty without pedals).
    pub hihat_openness: Vec<f32>,
    /// Deepest a stick sank into a piece, metres, and where: performance time, piece id,
    /// stick.
    pub max_penetration_m: f32,
    pub deepest_at: (f64, String, usize),
    /// Largest mechanical energy of the moving links, J.
    pub max_energy_j: f32,
    /// False if any tip left the finite numbers.
    pub finite: bool,
    /// Physics steps taken (preroll included).
    pub steps: u64,
}

/// Play `perf` as the motion stage `planned` it on `kit`, from the preroll until `end_s`
/// (performance seconds).
pub fn play(
    kit: &Kit,
    perf: &Performance,
    map: &NoteMap,
    planned: &Planned,
    end_s: f64,
) -> Result<PhysicalTake, DrummerError> {
    let mut c = Conductor::new(kit, perf, map, planned, DrummerSettings::default())?;
    let mut hihat_openness = Vec::new();
    let mut hands = Vec::with_capacity((end_s.max(0.0) * 60.0) as usize + 2);
    let periods = ((end_s + PREROLL_S) * TASK_HZ).ceil().max(0.0) as usize;
    let mut strikes = Vec::new();
    let mut tips = Vec::with_capacity((end_s.max(0.0) * 60.0) as usize + 2);
    let (mut max_energy_j, mut finite) = (0.0f32, true);
    for _ in 0..periods {
        c.period(&mut |mut s| {
            // A first note at time 0 may be struck a hair early: it is still the song's.
            if s.time_s >= -EARLY_S {
                s.time_s = s.time_s.max(0.0);
                strikes.push(s)
            }
        });
        let t = c.time_s();
        // The 60 fps frames that fall in this period.
        while t >= 0.0 && (tips.len() as f64) / 60.0 <= t {
            let tip = c.drummer().tips(Mode::Himc);
            finite &= tip.iter().all(|v| v.is_finite());
            tips.push(tip.map(|v| [v.x, v.y, v.z]));
            let d = c.drummer();
            let pose = d.sim_pose();
            let along = Rotation::from_rotation_arc(Vector::Y, d.skel.stick.dir);
            hands.push([0, 1].map(|side| {
                let (p, q) = (pose.pos[HAND[side]], pose.rot[HAND[side]]);
                let grip = p + q * d.skel.stick.grip;
                let r = (q * along).normalize();
                Pose { pos: [grip.x, grip.y, grip.z], rot: [r.w, r.x, r.y, r.z] }
            }));
            if let Some(p) = c.pedals() {
                hihat_openness.push(p.hihat_openness());
            }
        }
        max_energy_j = max_energy_j.max(c.drummer().energy_j());
    }
    let surfaces = c.drummer().surfaces();
    let messages = strikes.iter().map(|s| s.message(surfaces)).collect();
    Ok(PhysicalTake {
        strikes,
        messages,
        tips,
        hands,
        hihat_openness,
        max_penetration_m: c.drummer().max_penetration_m(),
        deepest_at: {
            let (t, k, side) = c.drummer().deepest_penetration_at();
            (t - PREROLL_S, c.drummer().surfaces()[k].id.clone(), side)
        },
        max_energy_j,
        finite,
        steps: c.drummer().steps(),
    })
}
