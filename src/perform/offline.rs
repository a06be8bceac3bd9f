//! A whole song played by the body, offline: the conductor's periods from the preroll to the
//! end, every new contact kept with its performance time, the simulated tips at 60 fps, and
//! what the stability checks need (penetration, energy, finiteness).

use super::conductor::{period_index, BodyState, Conductor, PREROLL_S};
use super::rehearsal::{Rehearsal, RehearsalSettings};
use crate::body::contacts::Strike;
use crate::body::sim::{Drummer, DrummerError, DrummerSettings, Mode};
use crate::body::skeleton::HAND;
use crate::interaction::ContactMessage;
use crate::kit::Kit;
use crate::midi::{NoteMap, Performance};
use crate::motion::pipeline::Planned;
use crate::motion::Pose;
use rapier3d::math::{Rotation, Vector};
use std::collections::VecDeque;

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
    /// Largest and smallest mechanical energy of the moving links, J.
    pub max_energy_j: f32,
    pub min_energy_j: f32,
    /// False if any tip left the finite numbers.
    pub finite: bool,
    /// Physics steps taken (preroll included, strokes played again included).
    pub steps: u64,
    /// Strokes the rehearsal played again, and the notes that needed it.
    pub replays: usize,
    pub rehearsed: usize,
    /// Why strokes were played again ([`super::rehearsal::Rehearsal::reasons`]).
    pub reasons: [usize; 7],
}

/// Play `perf` as the motion stage `planned` it on `kit`, from the preroll until `end_s`
/// (performance seconds), rehearsing strokes that fell off their notes
/// ([`RehearsalSettings::default`]).
pub fn play(
    kit: &Kit,
    perf: &Performance,
    map: &NoteMap,
    planned: &Planned,
    end_s: f64,
) -> Result<PhysicalTake, DrummerError> {
    play_with(kit, perf, map, planned, end_s, &RehearsalSettings::default())
}

/// What a snapshot must bring back besides the body: how much had been written.
struct Mark {
    state: BodyState,
    strikes: usize,
    frames: usize,
    hihat: usize,
    max_energy_j: f32,
    min_energy_j: f32,
    finite: bool,
}

/// [`play`] with the rehearsal's settings.
pub fn play_with(
    kit: &Kit,
    perf: &Performance,
    map: &NoteMap,
    planned: &Planned,
    end_s: f64,
    settings: &RehearsalSettings,
) -> Result<PhysicalTake, DrummerError> {
    play_as(kit, perf, map, planned, end_s, settings, DrummerSettings::default())
}

/// [`play_with`] by a drummer of the given settings (`drumsim check --body`).
pub fn play_as(
    kit: &Kit,
    perf: &Performance,
    map: &NoteMap,
    planned: &Planned,
    end_s: f64,
    settings: &RehearsalSettings,
    drummer: DrummerSettings,
) -> Result<PhysicalTake, DrummerError> {
    let mut c = Conductor::new_with(kit, perf, map, planned, drummer, settings.targets)?;
    let frames = (end_s.max(0.0) * 60.0) as usize + 2;
    let (mut tips, mut hands, mut hihat_openness) =
        (Vec::with_capacity(frames), Vec::with_capacity(frames), Vec::new());
    let mut strikes: Vec<Strike> = Vec::new();
    let (mut max_energy_j, mut min_energy_j, mut finite) = (0.0f32, f32::INFINITY, true);
    let mut rehearsal = Rehearsal::new(&c, period_index(end_s) + 2, *settings);
    let mut marks: VecDeque<Mark> = VecDeque::new();
    let mut period = 0usize;
    while c.time_s() < end_s {
        if period.is_multiple_of(settings.snapshot_every.max(1)) {
            // Keep the snapshots a stroke's preparation may need to go back to.
            while marks.len() > 1 && marks[1].state.time_s() <= c.time_s() - HISTORY_S {
                marks.pop_front();
            }
            let (strikes, frames, hihat) = (strikes.len(), tips.len(), hihat_openness.len());
            marks.push_back(Mark { state: c.snapshot(), strikes, frames, hihat, max_energy_j, min_energy_j, finite });
        }
        period += 1;
        c.period(&mut |s| strikes.push(s));
        let t = c.time_s();
        // The 60 fps frames that fall in this period.
        while t >= 0.0 && (tips.len() as f64) / 60.0 <= t {
            let tip = c.drummer().tips(Mode::Himc);
            finite &= tip.iter().all(|v| v.is_finite());
            tips.push(tip.map(|v| [v.x, v.y, v.z]));
            hands.push(grip_poses(c.drummer()));
            if let Some(p) = c.pedals() {
                hihat_openness.push(p.hihat_openness());
            }
        }
        let e = c.drummer().energy_j();
        (max_energy_j, min_energy_j) = (max_energy_j.max(e), min_energy_j.min(e));
        if let Some(from) = rehearsal.after_period(&mut c, &strikes) {
            // The latest snapshot before the stroke's preparation (the first one if none).
            let i = marks.iter().rposition(|m| m.state.time_s() <= from).unwrap_or(0);
            marks.truncate(i + 1);
            let m = &marks[i];
            c.restore(&m.state);
            strikes.truncate(m.strikes);
            tips.truncate(m.frames);
            hands.truncate(m.frames);
            hihat_openness.truncate(m.hihat);
            (max_energy_j, min_energy_j, finite) = (m.max_energy_j, m.min_energy_j, m.finite);
            rehearsal.restart(c.time_s(), strikes.len());
            // The snapshot just restored is still kept: the next is due a cadence later.
            period = 1;
        }
    }
    // A first note at time 0 may be struck a hair early: it is still the song's.
    let strikes: Vec<Strike> = strikes
        .into_iter()
        .filter(|s| s.time_s >= -EARLY_S)
        .map(|mut s| {
            s.time_s = s.time_s.max(0.0);
            s
        })
        .collect();
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
        min_energy_j,
        finite,
        steps: c.drummer().steps(),
        replays: rehearsal.replays,
        reasons: rehearsal.reasons,
        rehearsed: rehearsal.rehearsed(),
    })
}

/// Snapshots reach this far back: a stroke's longest preparation and the time to judge it.
const HISTORY_S: f64 = 0.35;

/// The simulated hands as the motion's grip poses (no allocation).
pub(crate) fn grip_poses(d: &Drummer) -> [Pose; 2] {
    let pose = d.sim_pose();
    let along = Rotation::from_rotation_arc(Vector::Y, d.skel.stick.dir);
    [0, 1].map(|side| {
        let (p, q) = (pose.pos[HAND[side]], pose.rot[HAND[side]]);
        let grip = p + q * d.skel.stick.grip;
        let r = (q * along).normalize();
        Pose { pos: [grip.x, grip.y, grip.z], rot: [r.w, r.x, r.y, r.z] }
    })
}
