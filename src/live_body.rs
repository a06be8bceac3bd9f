//! The live physical drummer (`drumsim live --sound physical`): the player's notes become
//! stick-tip and pedal targets, the body plays them at 10 kHz on its own thread, and its
//! contacts are the sound. Three threads besides live's own:
//!
//! ```text
//! interaction --LiveEvent (bounded, try_send)--> planner
//! planner   every 50 ms: the motion stage on the last seconds (motion::window), made into
//!           tip and pedal targets (perform::paced::BodyPlanner)
//!   --BodyPlan (bounded, try_send)--> body; plans given up come back to be dropped here
//! body      the conductor's 250 Hz periods on the wall clock (perform::paced::run), each
//!           `lookahead - LEAD_MS` after its session time; no allocation, lock or wait
//!   --BodyOut (bounded, try_send)--> out
//! out       (polled every ms) contacts and the hi-hat's openness as contact messages, to live's sound
//!           (the feed of this process, or a sound server); chokes from the interaction thread
//! ```
//! The body plays each note at the note's session time, and its sound is placed
//! `lookahead` later: the drummer plays `--lookahead-ms` behind the player, sample-accurately.
//!
//! With an avatar (`--view`, `--vmc`), the planner also hands each window plan to the
//! avatar's poser, the body sends its hands at 60 fps, and the out thread passes the hands,
//! the hi-hat and every contact on to the poser (`avatar::BodyFeed`, bounded, try_send).

use crate::body::sim::{Drummer, DrummerSettings};
use crate::interaction::Message;
use crate::kit::Kit;
use crate::midi::live::LiveEvent;
use crate::midi::NoteMap;
use crate::motion::hands::HandModel;
use crate::motion::pipeline;
use crate::motion::window::{WindowMotion, WindowPlan};
use crate::perform::conductor::{Conductor, TargetShape};
use crate::perform::paced::{self, BodyOut, BodyPlanner, PacedClock, PacedStats, Spent};
use crossbeam_channel::{Receiver, RecvTimeoutError};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

/// The live physical drummer's default lookahead, ms: a stroke is prepared before it lands
/// (the stick lifts about 100-200 ms ahead of a note), so the body plays the notes this long
/// after they were played.
pub const DEFAULT_LOOKAHEAD_MS: f32 = 250.0;
/// How far ahead of its sound the body runs, ms: room for a contact to reach the audio
/// callback (or a sound server) before it is to sound.
pub const LEAD_MS: f64 = 25.0;
/// How often the planner makes a new plan.
pub const PLAN_EVERY: Duration = Duration::from_millis(50);
/// A note the body learns of less than this before it is to strike it gets a shorter
/// stroke than the plan would give it (counted), s.
pub const FULL_STROKE_S: f64 = 0.120;

/// How often the out thread looks for the body's contacts (well inside [`LEAD_MS`]).
const OUT_POLL: Duration = Duration::from_millis(1);

/// What the planner counts.
#[derive(Debug, Default)]
pub struct PlanStats {
    pub plans: AtomicU64,
    pub plan_us_max: AtomicU64,
    pub plan_us_total: AtomicU64,
    pub failed: AtomicU64,
    /// Plans the body had not taken yet when a newer one came (the newer replaces it).
    pub superseded: AtomicU64,
    /// Notes the body learned of later than [`FULL_STROKE_S`] before their strike.
    pub short_strokes: AtomicU64,
    /// Notes planned (the kit plays them).
    pub notes: AtomicU64,
    /// Messages the sound had no room for.
    pub unsent: AtomicU64,
    /// Events a full window dropped (a note flood, `motion::window::MAX_EVENTS`).
    pub flooded: AtomicU64,
    pub messages: AtomicU64,
}

/// What the drummer needs, loaded before the sound starts.
pub struct Prepared {
    window: WindowMotion,
    planner: BodyPlanner,
    surfaces: Vec<String>,
    /// What the body is built from, on its own thread (so that its memory is that thread's
    /// pool's, `rt_alloc`).
    kit: Kit,
    settings: DrummerSettings,
    first: paced::BodyPlan,
    t0: f64,
}

/// Load the hand model and retrieval library and build the body, waiting.
pub fn prepare(kit: &Kit, map: &NoteMap, lookahead_s: f64) -> anyhow::Result<Prepared> {
    let library = pipeline::shipped_library()?;
    let model = match pipeline::override_weights() {
        Some(path) => HandModel::load(&path)?,
        None => HandModel::shipped(),
    };
    let settings = DrummerSettings::default();
    // Built here once to fail early and to learn its stick and surfaces; the body itself is
    // built again on its own thread (its memory that thread's pool's).
    let drummer = Drummer::new(kit, settings.clone())?;
    let surfaces = drummer.surfaces().iter().map(|s| s.id.clone()).collect();
    let planner = BodyPlanner::new(TargetShape::of(&drummer), kit, map);
    let mut window = WindowMotion::new(kit.clone(), map.clone(), model, library, lookahead_s);
    let first = planner.plan(&window.plan(0.0)?);
    let t0 = -lookahead_s + LEAD_MS / 1e3;
    Ok(Prepared { window, planner, surfaces, kit: kit.clone(), settings, first, t0 })
}

/// Where an avatar takes the body's plans and what it did.
pub struct ShowTo {
    pub plans: crossbeam_channel::Sender<Arc<WindowPlan>>,
    pub feed: crossbeam_channel::Sender<crate::avatar::BodyFeed>,
    pub stats: Arc<crate::avatar::AvatarStats>,
}

/// The running drummer.
pub struct LiveBody {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    pub body: Arc<PacedStats>,
    pub plans: Arc<PlanStats>,
    first_error: Arc<Mutex<Option<String>>>,
}

/// Start the drummer: `events` are the player's events as they arrive (session clock from
/// `epoch`), `messages` what the interaction thread sends besides (chokes); every message is
/// handed to `send` (false: the sound had no room for it); `show`: an avatar to show the body.
#[allow(clippy::too_many_arguments)]
pub fn start(
    prepared: Prepared,
    events: Receiver<LiveEvent>,
    messages: Receiver<Message>,
    epoch: Instant,
    lookahead_s: f64,
    show: Option<ShowTo>,
    mut send: impl FnMut(&Message) -> bool + Send + 'static,
) -> anyhow::Result<LiveBody> {
    let Prepared { mut window, planner, surfaces, kit, settings, first, t0 } = prepared;
    let stop = Arc::new(AtomicBool::new(false));
    let (body, plans) = (Arc::new(PacedStats::default()), Arc::new(PlanStats::default()));
    let first_error = Arc::new(Mutex::new(None));
    let clock = PacedClock { epoch, delay_s: lookahead_s - LEAD_MS / 1e3 };
    let (plan_tx, plan_rx) = crossbeam_channel::bounded(1);
    let (spent_tx, spent_rx) = crossbeam_channel::bounded::<Spent>(4);
    let (out_tx, out_rx) = crossbeam_channel::bounded::<BodyOut>(4096);
    let hands = show.is_some();
    // Only an avatar needs the upper body planned.
    window.plan_upper_body(hands);
    let (show_plans, show_feed) = match show {
        Some(s) => (Some(s.plans), Some((s.feed, s.stats))),
        None => (None, None),
    };
    let planning = {
        let (stop, stats, first_error) = (stop.clone(), plans.clone(), first_error.clone());
        let taken_back = plan_rx.clone();
        thread::Builder::new().name("drumsim-body-plan".into()).spawn(move || {
            let mut last = Instant::now();
            let mut newest_note = f64::NEG_INFINITY;
            while !stop.load(Relaxed) {
                match events.recv_timeout(PLAN_EVERY / 5) {
                    Ok(e) => window.push(e.event),
                    Err(RecvTimeoutError::Timeout) => {}
                    Err(RecvTimeoutError::Disconnected) => thread::sleep(PLAN_EVERY / 5),
                }
                while let Ok(e) = events.try_recv() {
                    window.push(e.event);
                }
                while spent_rx.try_recv().is_ok() {}
                if last.elapsed() < PLAN_EVERY {
                    continue;
                }
                last = Instant::now();
                let w = match window.plan(epoch.elapsed().as_secs_f64()) {
                    Ok(w) => w,
                    Err(e) => {
                        stats.failed.fetch_add(1, Relaxed);
                        first_error.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e.to_string());
                        continue;
                    }
                };
                stats.flooded.store(window.flooded(), Relaxed);
                let plan = planner.plan(&w);
                let us = last.elapsed().as_micros() as u64;
                stats.plans.fetch_add(1, Relaxed);
                stats.plan_us_total.fetch_add(us, Relaxed);
                stats.plan_us_max.fetch_max(us, Relaxed);
                // Notes new in this plan: how long before its strike the body learns of each.
                let body_now = clock.body_time(Instant::now());
                for &(t, _, _) in w.notes.iter().filter(|n| n.0 > newest_note) {
                    stats.notes.fetch_add(1, Relaxed);
                    if t - body_now < FULL_STROKE_S {
                        stats.short_strokes.fetch_add(1, Relaxed);
                    }
                }
                newest_note = w.notes.iter().map(|n| n.0).fold(newest_note, f64::max);
                if let Some(to) = &show_plans {
                    // The poser takes plans promptly; a full queue only loses a plan the
                    // next one replaces.
                    let _ = to.try_send(Arc::new(w));
                }
                // The body takes the newest plan: one it has not taken yet is replaced.
                if let Err(crossbeam_channel::TrySendError::Full(plan)) = plan_tx.try_send(plan) {
                    if taken_back.try_recv().is_ok() {
                        stats.superseded.fetch_add(1, Relaxed);
                    }
                    let _ = plan_tx.try_send(plan);
                }
            }
        })?
    };
    let stepping = {
        let (stop, stats) = (stop.clone(), body.clone());
        thread::Builder::new().name("drumsim-body".into()).spawn(move || {
            crate::rt_alloc::RtPool::enter(paced::POOL_BYTES);
            // Ahead of every ordinary thread (a browser drawing the avatar, the planner): a
            // body that falls behind drops periods and the strokes in them.
            let _ = stats.scheduling.set(crate::rt_priority::raise_current_thread());
            match Conductor::live(&kit, settings, first.targets, first.pedals, t0) {
                Ok(c) => paced::run(c, clock, hands, &plan_rx, &spent_tx, &out_tx, &stats, &stop),
                Err(e) => eprintln!("drumsim live: the body could not be built: {e}"),
            }
        })?
    };
    let out = {
        let (stop, stats) = (stop.clone(), plans.clone());
        thread::Builder::new().name("drumsim-body-out".into()).spawn(move || {
            use crate::avatar::BodyFeed;
            let to_avatar = |f: BodyFeed| {
                if let Some((feed, stats)) = &show_feed {
                    if feed.try_send(f).is_err() {
                        stats.body_dropped.fetch_add(1, Relaxed);
                    }
                }
            };
            let mut forward = |msg: &Message| {
                stats.messages.fetch_add(1, Relaxed);
                if !send(msg) {
                    stats.unsent.fetch_add(1, Relaxed);
                }
            };
            // Polled, never waited on: a receiver blocked on the body's channel would make
            // the body's `try_send` wake it (a lock and a system call on the physics thread).
            while !stop.load(Relaxed) {
                let mut idle = true;
                while let Ok(o) = out_rx.try_recv() {
                    idle = false;
                    match o {
                        BodyOut::Strike(s) => {
                            let piece = &surfaces[s.surface];
                            forward(&Message::Contact(s.message_named(piece)));
                            if show_feed.is_some() {
                                let (time_s, piece, speed_mps) = (s.time_s, piece.clone(), s.speed_mps);
                                to_avatar(BodyFeed::Strike { time_s, piece, speed_mps });
                            }
                        }
                        BodyOut::HiHat { time_s, openness } => {
                            forward(&Message::HiHat { time_s: time_s as f32, openness });
                            to_avatar(BodyFeed::HiHat { time_s, openness });
                        }
                        BodyOut::Hands { time_s, grips } => to_avatar(BodyFeed::Hands { time_s, grips }),
                    }
                }
                while let Ok(m) = messages.try_recv() {
                    idle = false;
                    forward(&m);
                }
                if idle {
                    thread::sleep(OUT_POLL);
                }
            }
        })?
    };
    Ok(LiveBody { stop, threads: vec![planning, stepping, out], body, plans, first_error })
}

impl LiveBody {
    /// Stop the threads and say what they did.
    pub fn stop(self) -> String {
        self.stop.store(true, Relaxed);
        for t in self.threads {
            let _ = t.join();
        }
        let p = &self.plans;
        let n = p.plans.load(Relaxed).max(1);
        let mut text = format!(
            "{}; {} plans ({:.1} ms mean, {:.1} ms max, {} not taken in time, {} failed), {} notes ({} learned of \
             too late for a full stroke, {} dropped in a note flood), {} messages ({} the sound had no room for)",
            self.body.report(),
            p.plans.load(Relaxed),
            p.plan_us_total.load(Relaxed) as f64 / n as f64 / 1e3,
            p.plan_us_max.load(Relaxed) as f64 / 1e3,
            p.superseded.load(Relaxed),
            p.failed.load(Relaxed),
            p.notes.load(Relaxed),
            p.short_strokes.load(Relaxed),
            p.flooded.load(Relaxed),
            p.messages.load(Relaxed),
            p.unsent.load(Relaxed),
        );
        if let Some(e) = self.first_error.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            text += &format!(" (first failure: {e})");
        }
        text
    }
}
