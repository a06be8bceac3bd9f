//! The live physical drummer's physics: the conductor's task periods on the wall clock.
//!
//! The session clock is the live MIDI epoch (an `Instant`), the clock the audio callback
//! places every event by. The body plays a note at the note's own session time `t`; its
//! contacts sound at `t + lookahead`. So the body's period ending at `t` is due on the wall
//! clock at `epoch + t + lookahead - lead`: `lead` ahead of its sound, room for the message to
//! reach the audio callback (or a sound server) before it is to sound. The plans come from
//! the motion stage on a sliding window (`motion::window`) made on another thread, as tip
//! and pedal targets ([`BodyPlanner`]); the physics thread swaps each newer plan in between
//! two periods and hands the one it gave up back, to be dropped there.
//!
//! In steady state the physics thread takes no lock, never waits on another thread and never
//! calls the system allocator: plans and plans given up travel through bounded lock-free
//! channels (`try_recv`, `try_send`), what the body did leaves as plain [`BodyOut`] values,
//! and the allocations rapier makes on every step come from the thread's own free lists
//! (`rt_alloc`, the binary's allocator; counted, and reported if any reach the system). It
//! counts (never logs) every period that started late and the worst lateness; when it falls
//! more than [`CATCH_UP_S`] behind (the machine cannot keep up), it drops the periods it
//! missed (the body's clock jumps, its state stays), so that it never drifts behind the
//! sound; the periods dropped are counted.

use super::conductor::{Conductor, TargetShape};
use super::feet::PedalTargets;
use super::lag::LagModel;
use super::targets::{TargetSettings, TipTargets};
use crate::body::contacts::Strike;
use crate::body::pedals::PedalBodies;
use crate::body::strokes::TASK_HZ;
use crate::kit::Kit;
use crate::midi::NoteMap;
use crate::motion::track::Pose;
use crate::motion::window::WindowPlan;
use crossbeam_channel::{Receiver, Sender};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::time::{Duration, Instant};

/// Behind by more than this, the body drops the periods it missed, s.
pub const CATCH_UP_S: f64 = 0.030;

/// A period this late is counted as late, s (the sleep's own jitter is not lateness).
pub const LATE_S: f64 = 0.002;

/// A period this late is behind: its contacts may reach the sound after they are due (the
/// live body runs `LEAD_MS` = 25 ms ahead of its sound; 5 ms are kept for the way there), s.
pub const BEHIND_S: f64 = 0.020;

/// The hi-hat's openness is sent when it moved this much (as the offline render does).
const HIHAT_STEP: f32 = 0.005;

/// One window's plan as the body follows it.
pub struct BodyPlan {
    pub targets: TipTargets,
    pub pedals: Option<PedalTargets>,
}

/// The plans the body gave up at one replan, dropped off the physics thread.
pub type Spent = ([Option<TipTargets>; super::conductor::FADING], Option<PedalTargets>);

/// Makes body plans from window plans (on the planning thread).
pub struct BodyPlanner {
    shape: TargetShape,
    kit: Kit,
    map: NoteMap,
    bodies: Option<PedalBodies>,
    lag: Option<LagModel>,
}

impl BodyPlanner {
    /// A planner whose strokes are aimed against the shipped lag model ([`super::lag`]);
    /// for measurements, `DRUMSIM_LAG=off` aims them at the notes and `DRUMSIM_LAG=FILE`
    /// against another model (one that cannot be read is said and the shipped one used).
    pub fn new(shape: TargetShape, kit: &Kit, map: &NoteMap) -> BodyPlanner {
        let lag = match std::env::var("DRUMSIM_LAG").as_deref() {
            Ok("off") => None,
            Ok(path) => match crate::files::read_to_string_bounded(std::path::Path::new(path), 4 << 20)
                .map_err(|e| e.to_string())
                .and_then(|text| serde_json::from_str(&text).map_err(|e| e.to_string()))
            {
                Ok(model) => Some(model),
                Err(e) => {
                    eprintln!("drumsim: DRUMSIM_LAG={path}: {e}; using the shipped lag model");
                    Some(LagModel::shipped())
                }
            },
            Err(_) => Some(LagModel::shipped()),
        };
        BodyPlanner { shape, kit: kit.clone(), map: map.clone(), bodies: PedalBodies::new(kit), lag }
    }

    /// The same planner with strokes aimed against `lag`, or not at all.
    pub fn with_lag(self, lag: Option<LagModel>) -> BodyPlanner {
        BodyPlanner { lag, ..self }
    }

    pub fn plan(&self, w: &WindowPlan) -> BodyPlan {
        let targets = match &self.lag {
            Some(lag) => self.shape.targets_with(
                &w.hands.aimed(|n, since| lag.lag_s(&self.kit.pieces[n.piece].id, n.velocity, since)),
                TargetSettings::live(),
            ),
            None => self.shape.targets_with(&w.hands, TargetSettings::live()),
        };
        let pedals = self
            .bodies
            .as_ref()
            .map(|b| PedalTargets::new(&w.perf, &self.map, &self.kit, b, &w.motion).shifted(w.start_s));
        BodyPlan { targets, pedals }
    }
}

/// What the body did, as plain values (session seconds).
#[derive(Debug, Clone, Copy)]
pub enum BodyOut {
    Strike(Strike),
    HiHat {
        time_s: f64,
        openness: f32,
    },
    /// The simulated hands as the motion's grip poses (left, right), at 60 fps, for the
    /// avatar.
    Hands {
        time_s: f64,
        grips: [Pose; 2],
    },
}

/// What the physics thread counts.
#[derive(Debug, Default)]
pub struct PacedStats {
    pub periods: AtomicU64,
    /// Periods that started more than [`LATE_S`] after they were due.
    pub late_periods: AtomicU64,
    /// The latest a period started, microseconds.
    pub worst_late_us: AtomicU64,
    /// Periods that started more than [`BEHIND_S`] late.
    pub behind_periods: AtomicU64,
    /// Periods dropped to catch up.
    pub dropped_periods: AtomicU64,
    pub replans: AtomicU64,
    pub strikes: AtomicU64,
    /// Contacts and hi-hat messages the outgoing queue had no room for.
    pub out_full: AtomicU64,
    /// Plans given up that the planner had no room to take back (dropped here).
    pub spent_here: AtomicU64,
    /// Time spent stepping, microseconds (for the share of a core the body takes).
    pub busy_us: AtomicU64,
    /// Calls of the physics thread that reached the system allocator after its first
    /// second (`rt_alloc`; only counted where the binary's allocator is `RtPool`).
    pub system_allocs: AtomicU64,
    /// How the physics thread is scheduled (`rt_priority`), set once as it starts.
    pub scheduling: std::sync::OnceLock<crate::rt_priority::Scheduling>,
}

impl PacedStats {
    pub fn report(&self) -> String {
        let periods = self.periods.load(Relaxed);
        let busy = self.busy_us.load(Relaxed) as f64 * 1e-6;
        let wall = periods as f64 / TASK_HZ;
        let scheduling = self.scheduling.get().map_or(String::new(), |s| format!(", at {s}"));
        format!(
            "body: {periods} periods at 250 Hz ({:.0} % of a core), {} started over 2 ms late (worst {:.1} ms), {} \
             behind (contacts at risk of sounding late), {} dropped to catch up, {} plans, {} contacts, {} system \
             allocator calls in steady state{scheduling}",
            if wall > 0.0 { 100.0 * busy / wall } else { 0.0 },
            self.late_periods.load(Relaxed),
            self.worst_late_us.load(Relaxed) as f64 / 1e3,
            self.behind_periods.load(Relaxed),
            self.dropped_periods.load(Relaxed),
            self.replans.load(Relaxed),
            self.strikes.load(Relaxed),
            self.system_allocs.load(Relaxed),
        )
    }
}

/// When each period is due on the wall clock.
#[derive(Debug, Clone, Copy)]
pub struct PacedClock {
    /// Session time 0.
    pub epoch: Instant,
    /// The sound's lookahead minus how far ahead of its sound the body runs, s.
    pub delay_s: f64,
}

impl PacedClock {
    /// The wall-clock instant at which the body may play session time `t`.
    pub fn due(&self, t: f64) -> Instant {
        let s = t + self.delay_s;
        if s >= 0.0 {
            self.epoch + Duration::from_secs_f64(s)
        } else {
            self.epoch.checked_sub(Duration::from_secs_f64(-s)).unwrap_or(self.epoch)
        }
    }

    /// The session time the body may have reached at `now`.
    pub fn body_time(&self, now: Instant) -> f64 {
        now.saturating_duration_since(self.epoch).as_secs_f64() - self.delay_s
    }
}

/// The physics thread: periods as they fall due, until `stop`; `hands`: send the simulated
/// hands at 60 fps too.
#[allow(clippy::too_many_arguments)]
pub fn run(
    mut c: Conductor,
    clock: PacedClock,
    hands: bool,
    plans: &Receiver<BodyPlan>,
    spent: &Sender<Spent>,
    out: &Sender<BodyOut>,
    stats: &PacedStats,
    stop: &AtomicBool,
) {
    let period = 1.0 / TASK_HZ;
    let mut hihat = FrameOut::new(c.time_s(), hands);
    crate::rt_alloc::RtPool::enter(POOL_BYTES);
    let mut baseline: Option<u64> = None;
    while !stop.load(Relaxed) {
        if baseline.is_none() && stats.periods.load(Relaxed) >= TASK_HZ as u64 {
            baseline = Some(crate::rt_alloc::RtPool::system_calls());
        }
        take_plans(&mut c, plans, spent, stats);
        let next = c.time_s() + period;
        let due = clock.due(next);
        let now = Instant::now();
        if now < due {
            std::thread::sleep((due - now).min(Duration::from_millis(2)));
            continue;
        }
        let late = (now - due).as_secs_f64();
        if late > LATE_S {
            stats.late_periods.fetch_add(1, Relaxed);
            stats.worst_late_us.fetch_max((late * 1e6) as u64, Relaxed);
        }
        if late > BEHIND_S {
            stats.behind_periods.fetch_add(1, Relaxed);
        }
        if late > CATCH_UP_S {
            let behind = ((clock.body_time(now) - c.time_s()) / period).floor().max(0.0);
            c.skip_periods(behind as usize);
            stats.dropped_periods.fetch_add(behind as u64, Relaxed);
            hihat = FrameOut::new(c.time_s(), hands);
            continue;
        }
        let started = Instant::now();
        play_period(&mut c, &mut hihat, out, stats);
        stats.busy_us.fetch_add(started.elapsed().as_micros() as u64, Relaxed);
    }
    if let Some(b) = baseline {
        stats.system_allocs.store(crate::rt_alloc::RtPool::system_calls() - b, Relaxed);
    }
}

/// The physics thread's own memory (`rt_alloc`): rapier's per-step buffers need well under 1 MiB.
pub const POOL_BYTES: usize = 16 << 20;

/// Swap in the newest plan waiting, handing the ones given up back.
pub fn take_plans(c: &mut Conductor, plans: &Receiver<BodyPlan>, spent: &Sender<Spent>, stats: &PacedStats) {
    while let Ok(plan) = plans.try_recv() {
        let old = c.replan(plan.targets, plan.pedals);
        stats.replans.fetch_add(1, Relaxed);
        if let Err(e) = spent.try_send(old) {
            stats.spent_here.fetch_add(1, Relaxed);
            drop(e);
        }
    }
}

/// What goes out at 60 fps: where the hi-hat's openness stands in what was sent, and
/// whether the hands go out too (for an avatar).
pub struct FrameOut {
    last: f32,
    /// The next 60 fps frame to look at.
    frame: f64,
    hands: bool,
}

impl FrameOut {
    pub fn new(t: f64, hands: bool) -> FrameOut {
        FrameOut { last: f32::NAN, frame: (t * 60.0).ceil(), hands }
    }
}

/// One task period: the body's contacts, and at 60 fps the hi-hat's openness where it moved
/// (and the hands, when an avatar shows them), to `out`.
pub fn play_period(c: &mut Conductor, hihat: &mut FrameOut, out: &Sender<BodyOut>, stats: &PacedStats) {
    c.period(&mut |s| {
        stats.strikes.fetch_add(1, Relaxed);
        if out.try_send(BodyOut::Strike(s)).is_err() {
            stats.out_full.fetch_add(1, Relaxed);
        }
    });
    while hihat.frame / 60.0 <= c.time_s() {
        if hihat.hands {
            let grips = super::offline::grip_poses(c.drummer());
            if out.try_send(BodyOut::Hands { time_s: hihat.frame / 60.0, grips }).is_err() {
                stats.out_full.fetch_add(1, Relaxed);
            }
        }
        if let Some(o) = c.pedals().map(|p| p.hihat_openness()) {
            if hihat.last.is_nan() || (o - hihat.last).abs() >= HIHAT_STEP {
                hihat.last = o;
                if out.try_send(BodyOut::HiHat { time_s: hihat.frame / 60.0, openness: o }).is_err() {
                    stats.out_full.fetch_add(1, Relaxed);
                }
            }
        }
        hihat.frame += 1.0;
    }
    stats.periods.fetch_add(1, Relaxed);
}
