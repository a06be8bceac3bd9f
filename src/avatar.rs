//! The live avatar (`drumsim live --view`, `--vmc`): the player's notes drive a drummer
//! shown `lookahead` after they were played, at 60 frames a second, on the live page and to
//! a VMC receiver. Two threads:
//!
//! ```text
//! interaction thread --LiveEvent (bounded, try_send)--> planner
//! planner   every 50 ms: the motion stage on the last seconds (motion::window)
//!   --WindowPlan (bounded)--> poser
//! poser     60 Hz on deadlines: the frame at now - lookahead, faded between plans, whole-body
//!           IK, then JSON to the page's WebSocket hub and OSC bundles to the VMC receiver
//! ```
//! Neither is a real-time thread of the sound: the sound stays immediate and never waits on
//! them. A plan that fails is counted and the last good one stays on screen.
//!
//! With the live physical drummer (`--sound physical`) the avatar shows the body as it
//! plays: there is no planner here, the poser takes the body planner's window plans (the
//! same plans the body follows) and the body's own output (`BodyFeed`: the simulated hands
//! at 60 fps, the hi-hat's openness, every contact), and it lights the pieces the sticks
//! and beater really struck, at their contact times.

use crate::kit::Kit;
use crate::midi::live::LiveEvent;
use crate::midi::NoteMap;
use crate::motion::export::gltf::{self, PartMotion};
use crate::motion::export::scene::{self, KitPart, Moves};
use crate::motion::export::{y_up, y_up_rot, Baked};
use crate::motion::hands::HandModel;
use crate::motion::humanoid::Humanoid;
use crate::motion::rig::Rig;
use crate::motion::track::Pose;
use crate::motion::window::{blend_pose, shown_frame, WindowMotion, WindowPlan};
use crate::motion::{body_ik, pipeline, ARKIT_NAMES};
use crate::view::live::LiveHub;
use crate::vmc::packets::Encoder;
use crate::vmc::sender::{Pacer, Sender};
use crate::vmc::VmcOptions;
use crossbeam_channel::{Receiver, RecvTimeoutError};
use std::collections::VecDeque;
use std::fmt::Write as _;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering::Relaxed};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

/// How often the planner makes a new plan.
pub const PLAN_EVERY: Duration = Duration::from_millis(50);
/// The avatar's default lookahead, ms: long enough that every stroke is prepared (see the
/// README's measurements), short enough to follow a player.
pub const DEFAULT_LOOKAHEAD_MS: f32 = 250.0;
/// Frames a second to the page and to VMC.
pub const RATE_HZ: f64 = 60.0;

/// What the avatar shows and where.
#[derive(Debug, Clone)]
pub struct AvatarOptions {
    /// How long after a note is played the avatar strikes it, s.
    pub lookahead_s: f64,
    /// Serve the live page on this port of 127.0.0.1 (0: a free one).
    pub view_port: Option<u16>,
    /// Launch the desktop's browser on the page.
    pub open: bool,
    pub vmc: Option<VmcOptions>,
    /// The live physical drummer plays (the page says so; the motion comes from the body).
    pub physical: bool,
}

/// What the avatar threads count.
#[derive(Debug, Default)]
pub struct AvatarStats {
    pub plans: AtomicU64,
    pub plan_us_total: AtomicU64,
    pub plan_us_max: AtomicU64,
    pub plan_errors: AtomicU64,
    pub frames: AtomicU64,
    /// Frames skipped because the poser fell more than a frame behind.
    pub late_frames: AtomicU64,
    pub vmc_datagrams: AtomicU64,
    pub vmc_failed: AtomicU64,
    /// What the live physical body sent that the avatar's queue had no room for.
    pub body_dropped: AtomicU64,
}

/// What the live physical body tells the avatar, session seconds.
#[derive(Debug, Clone)]
pub enum BodyFeed {
    /// The simulated hands as grip poses (left, right), 60 a second.
    Hands {
        time_s: f64,
        grips: [Pose; 2],
    },
    HiHat {
        time_s: f64,
        openness: f32,
    },
    /// A contact: the piece struck (its id) and the contact's speed.
    Strike {
        time_s: f64,
        piece: String,
        speed_mps: f32,
    },
}

/// Where the avatar's motion comes from.
pub enum Source {
    /// The player's events, planned here on a sliding window (`--sound direct`).
    Events(Receiver<LiveEvent>),
    /// The live physical body: its planner's window plans and what it did.
    Body { plans: Receiver<Arc<WindowPlan>>, feed: Receiver<BodyFeed> },
}

/// The running avatar.
pub struct Avatar {
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
    pub stats: Arc<AvatarStats>,
    pub hub: Option<Arc<LiveHub>>,
    /// The live page's address, when it is served.
    pub url: Option<String>,
    first_error: Arc<Mutex<Option<String>>>,
}

/// An avatar ready to start: the models loaded, the page serving, the socket open. Made
/// before the sound starts, so that its loading never holds up the audio.
pub struct Prepared {
    window: WindowMotion,
    waiting: WindowPlan,
    rig: Rig,
    kit: Kit,
    lookahead_s: f64,
    hub: Option<Arc<LiveHub>>,
    url: Option<String>,
    vmc: Option<(Humanoid, Encoder, Sender)>,
}

/// Load what the avatar needs and serve its page.
pub fn prepare(kit: &Kit, map: &NoteMap, opts: &AvatarOptions) -> anyhow::Result<Prepared> {
    let library = pipeline::shipped_library()?;
    let model = match pipeline::override_weights() {
        Some(path) => HandModel::load(&path)?,
        None => HandModel::shipped(),
    };
    let mut window = WindowMotion::new(kit.clone(), map.clone(), model, library, opts.lookahead_s);
    let rig = Rig::default();
    // The drummer waiting, for the page's glb and the first frames.
    let waiting = window.plan(0.0)?;
    let hub = opts.view_port.map(|_| Arc::new(LiveHub::default()));
    let url = match (opts.view_port, &hub) {
        (Some(port), Some(hub)) => {
            let baked = Baked::in_kit(&waiting.motion, &rig, Some(kit))?;
            let info = serde_json::json!({
                "live": true,
                "song": "live",
                "sound": if opts.physical { "physical" } else { "direct" },
                "kit": kit.name,
                "lookahead_ms": opts.lookahead_s * 1e3,
                "bones": rig.bones.iter().map(|b| b.name.as_str()).collect::<Vec<_>>(),
                "face_targets": scene::FACE_TARGETS,
                "pieces": kit.pieces.iter().map(|p| p.id.as_str()).collect::<Vec<_>>(),
                "duration_s": 0.0,
            });
            let routes = crate::view::live_routes(&info, gltf::bytes(&baked), Arc::clone(hub));
            Some(crate::view::start_live(routes, port)?)
        }
        _ => None,
    };
    let vmc = match &opts.vmc {
        Some(v) => {
            let humanoid = Humanoid::of_rig(&rig);
            let encoder = Encoder::new(&humanoid, v.content.clone(), v.packing);
            Some((humanoid, encoder, Sender::new(v.target)?))
        }
        None => None,
    };
    Ok(Prepared { window, waiting, rig, kit: kit.clone(), lookahead_s: opts.lookahead_s, hub, url, vmc })
}

/// Start the avatar's threads on `source` (session clock from `epoch`).
pub fn start(prepared: Prepared, source: Source, epoch: Instant) -> anyhow::Result<Avatar> {
    let Prepared { mut window, waiting, rig, kit, lookahead_s, hub, url, vmc } = prepared;
    let stats = Arc::new(AvatarStats::default());
    let stop = Arc::new(AtomicBool::new(false));
    let first_error = Arc::new(Mutex::new(None));
    // The feet stay on their pedals, so the knees' turns for the drummer waiting hold.
    let knees = body_ik::knee_angles(&rig, &waiting.motion, &crate::motion::shells::shells(&kit));
    let waiting = Arc::new(waiting);
    let mut threads = Vec::new();
    let (plan_rx, body) = match source {
        Source::Events(events) => {
            let (plan_tx, plan_rx) = crossbeam_channel::bounded::<Arc<WindowPlan>>(4);
            let (stop, stats, first_error) = (stop.clone(), stats.clone(), first_error.clone());
            threads.push(thread::Builder::new().name("drumsim-avatar-plan".into()).spawn(move || {
                let mut last = Instant::now();
                while !stop.load(Relaxed) {
                    match events.recv_timeout(PLAN_EVERY) {
                        Ok(e) => window.push(e.event),
                        Err(RecvTimeoutError::Timeout) => {}
                        Err(RecvTimeoutError::Disconnected) => thread::sleep(PLAN_EVERY),
                    }
                    while let Ok(e) = events.try_recv() {
                        window.push(e.event);
                    }
                    if last.elapsed() < PLAN_EVERY {
                        continue;
                    }
                    last = Instant::now();
                    match window.plan(epoch.elapsed().as_secs_f64()) {
                        Ok(p) => {
                            let us = last.elapsed().as_micros() as u64;
                            stats.plans.fetch_add(1, Relaxed);
                            stats.plan_us_total.fetch_add(us, Relaxed);
                            stats.plan_us_max.fetch_max(us, Relaxed);
                            if plan_tx.send(Arc::new(p)).is_err() {
                                return;
                            }
                        }
                        Err(e) => {
                            stats.plan_errors.fetch_add(1, Relaxed);
                            first_error.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(e.to_string());
                        }
                    }
                }
            })?);
            (plan_rx, None)
        }
        Source::Body { plans, feed } => (plans, Some(feed)),
    };
    let poser = {
        let (stop, stats, hub) = (stop.clone(), stats.clone(), hub.clone());
        let poser = Poser::new(&kit, rig, lookahead_s, knees);
        thread::Builder::new()
            .name("drumsim-avatar-pose".into())
            .spawn(move || poser.run(waiting, &plan_rx, body.as_ref(), epoch, &stop, &stats, hub.as_deref(), vmc))?
    };
    threads.push(poser);
    Ok(Avatar { stop, threads, stats, hub, url, first_error })
}

impl Avatar {
    /// Stop both threads and say what they did.
    pub fn stop(self) -> String {
        self.stop.store(true, Relaxed);
        for t in self.threads {
            let _ = t.join();
        }
        let s = &self.stats;
        let plans = s.plans.load(Relaxed).max(1);
        let mut text = format!(
            "avatar: {} frames ({} skipped as late), {} plans ({:.1} ms mean, {:.1} ms max), {} failed",
            s.frames.load(Relaxed),
            s.late_frames.load(Relaxed),
            s.plans.load(Relaxed),
            s.plan_us_total.load(Relaxed) as f64 / plans as f64 / 1e3,
            s.plan_us_max.load(Relaxed) as f64 / 1e3,
            s.plan_errors.load(Relaxed),
        );
        if let Some(e) = self.first_error.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
            let _ = write!(text, " (first: {e})");
        }
        if let Some(hub) = &self.hub {
            let _ = write!(
                text,
                "; page: {} connections, {} frames a slow page missed",
                hub.connections.load(Relaxed),
                hub.dropped.load(Relaxed)
            );
        }
        if s.body_dropped.load(Relaxed) > 0 {
            let _ = write!(text, "; {} of the body's messages dropped", s.body_dropped.load(Relaxed));
        }
        if s.vmc_datagrams.load(Relaxed) + s.vmc_failed.load(Relaxed) > 0 {
            let _ = write!(
                text,
                "; vmc: {} datagrams, {} failed",
                s.vmc_datagrams.load(Relaxed),
                s.vmc_failed.load(Relaxed)
            );
        }
        text
    }
}

/// The poser's fixed state: the rig, the kit's moving parts, the lookahead, the knees'
/// turns clear of the kit's drums.
struct Poser {
    rig: Rig,
    knees: [Option<f32>; 2],
    kit: Kit,
    moving: Vec<KitPart>,
    lookahead_s: f64,
    beater_rest: f32,
    face_index: Vec<usize>,
}

impl Poser {
    fn new(kit: &Kit, rig: Rig, lookahead_s: f64, knees: [Option<f32>; 2]) -> Poser {
        let moving =
            scene::kit(kit, rig.bones[0].offset.z - 0.07).into_iter().filter(|p| p.moves != Moves::Still).collect();
        let face_index = scene::FACE_TARGETS
            .iter()
            .map(|n| ARKIT_NAMES.iter().position(|a| a == n).expect("an ARKit name"))
            .collect();
        let beater_rest = kit.pedals.map_or(0.0, |p| p.beater_rest_deg).to_radians();
        Poser { rig, knees, kit: kit.clone(), moving, lookahead_s, beater_rest, face_index }
    }

    #[allow(clippy::too_many_arguments)]
    fn run(
        &self,
        waiting: Arc<WindowPlan>,
        plans: &Receiver<Arc<WindowPlan>>,
        body: Option<&Receiver<BodyFeed>>,
        epoch: Instant,
        stop: &AtomicBool,
        stats: &AvatarStats,
        hub: Option<&LiveHub>,
        mut vmc: Option<(Humanoid, Encoder, Sender)>,
    ) {
        let mut pacer = Pacer::new(RATE_HZ);
        // The drummer waiting until the first plan comes.
        let (mut newest, mut before): (Option<Arc<WindowPlan>>, Option<Arc<WindowPlan>>) = (Some(waiting), None);
        let mut since = 0.0;
        let mut struck_until = f64::NEG_INFINITY;
        let mut lift_before = 0.0;
        let mut scratch = Vec::new();
        let mut unity = vmc.as_ref().map(|(h, _, _)| h.empty_pose());
        let mut text = String::with_capacity(4096);
        let mut carry = body_ik::Carry { knee: self.knees, ..Default::default() };
        // The pose shown before, for `limit_turns` (no bone turning over 45 degrees a frame).
        let mut shown_before: Option<crate::motion::rig::BodyPose> = None;
        let mut played = Played::default();
        while !stop.load(Relaxed) {
            let Some((i, skipped)) = pacer.next_frame(u64::MAX) else { return };
            stats.late_frames.fetch_add(skipped, Relaxed);
            // The frame shows the moment it was due (a thread woken a few ms late on a busy
            // machine still poses its frame's moment: frames stay 1/60 s apart).
            let now = pacer.due(i).saturating_duration_since(epoch).as_secs_f64();
            while let Ok(p) = plans.try_recv() {
                before = newest.replace(p);
                since = now;
            }
            let Some(plan) = newest.as_deref() else { continue };
            let shown = now - self.lookahead_s;
            let mut frame = shown_frame(plan, before.as_deref(), since, now, shown);
            if let Some(feed) = body {
                played.take(feed, shown);
                played.show(shown, &mut frame);
            }
            let mut pose = body_ik::solve_after(&self.rig, &frame, &mut carry);
            match shown_before.as_mut() {
                Some(before) => {
                    body_ik::limit_turns(&self.rig, &mut pose, before);
                    before.clone_from(&pose);
                }
                None => shown_before = Some(pose.clone()),
            }
            if let (Some((humanoid, encoder, sender)), Some(unity)) = (vmc.as_mut(), unity.as_mut()) {
                let world = self.rig.world(&pose);
                humanoid.pose_into(&world[0].0, |i| world[i].1, &mut scratch, unity);
                let (sent, failed) = (sender.datagrams, sender.failed);
                sender.send_all(&encoder.datagrams(unity, &frame.face, now as f32));
                stats.vmc_datagrams.fetch_add(sender.datagrams - sent, Relaxed);
                stats.vmc_failed.fetch_add(sender.failed - failed, Relaxed);
            }
            if let Some(hub) = hub {
                let lift = gltf::kick_foot_lift(&frame);
                let beater = gltf::beater_angle(lift, lift_before, self.beater_rest);
                lift_before = lift;
                text.clear();
                let _ = write!(text, "{{\"t\":{now:.4},\"s\":{shown:.4},\"root\":");
                push_floats(&mut text, &y_up(pose.root));
                text.push_str(",\"bones\":[");
                for (i, q) in pose.local.iter().enumerate() {
                    let [w, x, y, z] = y_up_rot(q);
                    if i > 0 {
                        text.push(',');
                    }
                    push_floats(&mut text, &[x, y, z, w]);
                }
                text.push_str("],\"face\":");
                let face: Vec<f32> = self.face_index.iter().map(|&k| frame.face[k].clamp(0.0, 1.0)).collect();
                push_floats(&mut text, &face);
                text.push_str(",\"nodes\":[");
                for (k, part) in self.moving.iter().enumerate() {
                    if k > 0 {
                        text.push(',');
                    }
                    let _ = write!(text, "{{\"name\":{:?},", part.name);
                    match gltf::part_motion(part, &self.kit, frame.hihat_openness, beater) {
                        Some(PartMotion::Translation(t)) => {
                            text.push_str("\"t\":");
                            push_floats(&mut text, &t);
                        }
                        Some(PartMotion::Rotation(r)) => {
                            text.push_str("\"r\":");
                            push_floats(&mut text, &r);
                        }
                        None => text.push_str("\"still\":true"),
                    }
                    text.push('}');
                }
                text.push_str("],\"tips\":[");
                push_floats(&mut text, &frame.hands[0].stick_tip());
                text.push(',');
                push_floats(&mut text, &frame.hands[1].stick_tip());
                text.push_str("],\"strikes\":[");
                let mut first = true;
                if body.is_some() {
                    // Each contact of the body once, when the shown moment reaches it.
                    while let Some((at, piece, speed)) = played.strikes.front().filter(|c| c.0 <= shown) {
                        if !first {
                            text.push(',');
                        }
                        first = false;
                        let velocity = self.kit.strike.velocity_for_speed(*speed).round();
                        let _ = write!(text, "{{\"piece\":{piece:?},\"at\":{at:.4},\"velocity\":{velocity}}}");
                        played.strikes.pop_front();
                    }
                } else {
                    // Each note once, when the shown moment reaches it (or at once when its
                    // plan came later than that, with a lookahead shorter than a plan takes).
                    for (at, piece, velocity) in plan.notes.iter().filter(|n| n.0 > struck_until && n.0 <= shown) {
                        if !first {
                            text.push(',');
                        }
                        first = false;
                        let _ = write!(text, "{{\"piece\":{piece:?},\"at\":{at:.4},\"velocity\":{velocity}}}");
                    }
                    struck_until = plan.notes.iter().map(|n| n.0).filter(|&t| t <= shown).fold(struck_until, f64::max);
                }
                text.push_str("]}");
                hub.broadcast(Arc::from(text.as_str()));
            }
            stats.frames.fetch_add(1, Relaxed);
        }
    }
}

/// What the live physical body did, kept for the frames still to be shown.
#[derive(Default)]
struct Played {
    /// The simulated grips, in time order.
    hands: VecDeque<(f64, [Pose; 2])>,
    /// The hi-hat's openness where it changed, in time order.
    hihat: VecDeque<(f64, f32)>,
    /// Contacts not shown yet: time, piece, speed.
    strikes: VecDeque<(f64, String, f32)>,
}

/// How far back the body's grips are kept, s.
const KEEP_S: f64 = 0.5;

impl Played {
    /// Take what the body sent since the last frame; forget what is older than needed.
    fn take(&mut self, feed: &Receiver<BodyFeed>, shown: f64) {
        while let Ok(f) = feed.try_recv() {
            match f {
                BodyFeed::Hands { time_s, grips } => self.hands.push_back((time_s, grips)),
                BodyFeed::HiHat { time_s, openness } => self.hihat.push_back((time_s, openness)),
                BodyFeed::Strike { time_s, piece, speed_mps } => self.strikes.push_back((time_s, piece, speed_mps)),
            }
        }
        while self.hands.len() > 2 && self.hands[1].0 < shown - KEEP_S {
            self.hands.pop_front();
        }
        while self.hihat.len() > 1 && self.hihat[1].0 <= shown {
            self.hihat.pop_front();
        }
        // A contact the page will never be shown (the body ran far ahead, or the clock
        // jumped) goes after a second.
        while self.strikes.front().is_some_and(|c| c.0 < shown - 1.0) {
            self.strikes.pop_front();
        }
    }

    /// The body's hands and hi-hat at session time `t` in `frame` (between the two grips
    /// around it; the plan's where the body has none within 50 ms).
    fn show(&self, t: f64, frame: &mut crate::motion::MotionFrame) {
        let after = self.hands.iter().position(|h| h.0 > t);
        let grips = match after {
            Some(0) => Some(self.hands[0]).filter(|h| h.0 - t < 0.05).map(|h| h.1),
            Some(j) => {
                let (a, b) = (&self.hands[j - 1], &self.hands[j]);
                let w = ((t - a.0) / (b.0 - a.0).max(1e-9)).clamp(0.0, 1.0) as f32;
                Some([0, 1].map(|s| blend_pose(&a.1[s], &b.1[s], w)))
            }
            None => self.hands.back().filter(|h| t - h.0 < 0.05).map(|h| h.1),
        };
        if let Some(g) = grips {
            frame.hands = g;
        }
        if let Some(&(_, o)) = self.hihat.front().filter(|h| h.0 <= t) {
            frame.hihat_openness = o;
        }
    }
}

fn push_floats(text: &mut String, values: &[f32]) {
    text.push('[');
    for (i, v) in values.iter().enumerate() {
        if i > 0 {
            text.push(',');
        }
        let v = if v.is_finite() { *v } else { 0.0 };
        let _ = write!(text, "{}", (v * 1e5).round() / 1e5);
    }
    text.push(']');
}
