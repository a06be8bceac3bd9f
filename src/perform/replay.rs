//! The live body on a simulated clock: a performance played as `drumsim live --sound
//! physical` would play it, with the same window plans, body plans and conductor, but each
//! plan made at the simulated moment its notes had all arrived, and handed to the body when
//! live play would hand it over. Deterministic and faster than real time: for tests, and to
//! tune the live drummer on many takes.

use super::conductor::{Conductor, TargetShape};
use super::paced::BodyPlanner;
use crate::body::contacts::Strike;
use crate::body::sim::{Drummer, DrummerSettings};
use crate::body::strokes::TASK_HZ;
use crate::kit::Kit;
use crate::midi::{NoteMap, Performance};
use crate::motion::hands::HandModel;
use crate::motion::upper::Library;
use crate::motion::window::WindowMotion;

/// How a replay is played.
#[derive(Debug, Clone, Copy)]
pub struct ReplaySettings {
    /// The sound's lookahead (how long after its note a stroke lands), s.
    pub lookahead_s: f64,
    /// How far ahead of its sound the body runs, s.
    pub lead_s: f64,
    /// A new plan this often, s.
    pub plan_every_s: f64,
    /// A plan reaches the body this long after it was begun, s.
    pub plan_latency_s: f64,
}

impl Default for ReplaySettings {
    fn default() -> Self {
        ReplaySettings {
            lookahead_s: f64::from(crate::live_body::DEFAULT_LOOKAHEAD_MS) / 1e3,
            lead_s: crate::live_body::LEAD_MS / 1e3,
            plan_every_s: crate::live_body::PLAN_EVERY.as_secs_f64(),
            plan_latency_s: 0.008,
        }
    }
}

/// What the body struck, each strike at the session time it plays (its sound comes
/// `lookahead_s` later), and the surfaces' ids.
pub struct Replayed {
    pub strikes: Vec<Strike>,
    pub surfaces: Vec<String>,
    pub plans: usize,
}

/// The player starts this long after the session (as a player does): the first notes are
/// not the body's first moments, s.
const LEAD_IN_S: f64 = 1.0;

/// Play `perf` until `end_s` as live play would, the player starting [`LEAD_IN_S`] into the
/// session; the strikes' times are the performance's.
pub fn replay(
    kit: &Kit,
    map: &NoteMap,
    model: HandModel,
    library: Library,
    perf: &Performance,
    end_s: f64,
    s: &ReplaySettings,
) -> anyhow::Result<Replayed> {
    replay_observed(kit, map, model, library, perf, end_s, s, &mut |_, _, _| {})
}

/// [`replay`], showing `observe` the body after every physics step with the step's
/// performance time and its targets (for traces).
#[allow(clippy::too_many_arguments)]
pub fn replay_observed(
    kit: &Kit,
    map: &NoteMap,
    model: HandModel,
    library: Library,
    perf: &Performance,
    end_s: f64,
    s: &ReplaySettings,
    observe: &mut impl FnMut(&Drummer, f64, &[crate::body::ik::ArmTarget; 2]),
) -> anyhow::Result<Replayed> {
    let settings = DrummerSettings::default();
    let shape = TargetShape::of(&Drummer::new(kit, settings.clone())?);
    let planner = BodyPlanner::new(shape, kit, map);
    let mut window = WindowMotion::new(kit.clone(), map.clone(), model, library, s.lookahead_s);
    // As live play with no avatar showing.
    window.plan_upper_body(false);
    let first = planner.plan(&window.plan(0.0)?);
    // Body time tau is played at wall time tau + delay.
    let delay = s.lookahead_s - s.lead_s;
    let mut c = Conductor::live(kit, settings, first.targets, first.pedals, -delay)?;
    let surfaces = c.drummer().surfaces().iter().map(|x| x.id.clone()).collect();
    let shifted: Vec<_> =
        perf.events.iter().map(|e| crate::midi::DrumEvent { time_s: e.time_s + LEAD_IN_S, ..*e }).collect();
    let mut events = shifted.iter().peekable();
    let mut strikes = Vec::new();
    let mut next_plan = s.plan_every_s;
    let mut plans = 0;
    while c.time_s() < end_s + LEAD_IN_S {
        let wall = c.time_s() + 1.0 / TASK_HZ + delay;
        // Every plan whose moment came before this period is due, made from the events that had
        // arrived by then.
        while next_plan + s.plan_latency_s <= wall {
            while let Some(e) = events.next_if(|e| e.time_s <= next_plan) {
                window.push(*e);
            }
            let plan = planner.plan(&window.plan(next_plan)?);
            c.replan(plan.targets, plan.pedals);
            plans += 1;
            next_plan += s.plan_every_s;
        }
        c.period_observed(
            &mut |mut st| {
                st.time_s -= LEAD_IN_S;
                strikes.push(st)
            },
            &mut |d, t, tg| observe(d, t - LEAD_IN_S, tg),
        );
    }
    Ok(Replayed { strikes, surfaces, plans })
}
