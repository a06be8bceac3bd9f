//! Offline pipeline: MIDI file -> contact messages (direct mode) -> OSC bytes over an
//! in-process channel -> sound engine -> DIR/SONG.wav and DIR/SONG.contacts.json.
//! Outputs are written to `.partial` files and renamed only when complete.

use crate::interaction::direct::{DirectError, Director};
use crate::interaction::transport::{self, PacketReceiver, PacketSender};
use crate::interaction::{decode, encode, Message};
use crate::kit::Kit;
use crate::midi::{read_file, DrumEventKind, NoteMap, Performance, ReadOptions};
use crate::outputs::{write_synced, OutputSet};
use crate::sound::wav::WavSink;
use crate::sound::{Engine, EngineSettings, SoundEvent};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub const SAMPLE_RATE_HZ: u32 = 48_000;
/// Longest ring-out rendered after the last event, seconds.
pub const MAX_TAIL_S: f64 = 8.0;
const BLOCK: usize = 512;
/// Blocks an offline render gives its voices at a time (0.34 s).
const WINDOW_BLOCKS: usize = 32;

/// Where the strikes that sound come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SoundMode {
    /// Straight from the MIDI notes (the fast mode).
    #[default]
    Direct,
    /// From the simulated body's contacts.
    Physical,
}

/// Options of `drumsim render`.
#[derive(Debug, Clone)]
pub struct RenderOptions {
    pub out_dir: PathBuf,
    pub kit: Option<PathBuf>,
    pub map: String,
    pub channel: Option<u8>,
    pub skip_unknown: bool,
    pub progress: bool,
    /// Write the motion too (SONG.motion.json, SONG.bvh, SONG.glb).
    pub motion: bool,
    /// Hand model weights (default: `$DRUMSIM_ASSETS/hands/best.bpk` if it exists, else the
    /// compiled-in model).
    pub weights: Option<PathBuf>,
    /// Hands from the corpus teacher instead of the hand model (`--teacher`): the teacher is
    /// training-only code (`crate::learn`), handed in by the command line.
    pub teacher: Option<TeacherHands>,
    pub sound: SoundMode,
    /// The bone names of SONG.bvh and SONG.glb.
    pub rig_names: crate::motion::rig::RigNames,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            out_dir: PathBuf::from("out"),
            kit: None,
            map: crate::midi::map::AUTO_MAP.into(),
            channel: None,
            skip_unknown: false,
            progress: false,
            motion: true,
            weights: None,
            teacher: None,
            sound: SoundMode::Direct,
            rig_names: crate::motion::rig::RigNames::Drumsim,
        }
    }
}

/// Bad input found while rendering (exit code 2).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderInputError {
    #[error("{0}")]
    Unsupported(String),
    #[error("--channel {0} is not a MIDI channel (1..=16)")]
    Channel(u8),
    #[error("{path}: the file name has no stem to name the outputs after")]
    NoStem { path: PathBuf },
    #[error(
        "{path}: its last note ends at {}, past the {} a render holds (a 24-bit stereo WAV stops at 4 GiB)",
        hms(*last_note_s),
        hms(MAX_SONG_S)
    )]
    TooLong { path: PathBuf, last_note_s: f64 },
    #[error(
        "{}: no note on channel {channel} is one the kit plays{}; nothing to render (a map for the file's kit, --map NAME|FILE, or --channel N for another drum channel)",
        .path.display(),
        if skipped.is_empty() { String::new() } else { format!(" (left out: {})", skipped_list(skipped)) }
    )]
    NothingToPlay { path: PathBuf, channel: u8, skipped: Vec<SkippedNote> },
    #[error(transparent)]
    Direct(#[from] DirectError),
}

/// A render's output could not be written (exit code 1: a full disk, a read-only folder).
#[derive(Debug, thiserror::Error)]
#[error("cannot write {}: {source}; nothing was published", .path.display())]
pub struct WriteError {
    pub path: PathBuf,
    pub source: std::io::Error,
}

/// The MIDI note a contact came from.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct NoteRef {
    pub note: u8,
    pub velocity: u8,
    pub time_s: f64,
}

/// A contact message with the note that made it.
#[derive(Debug, Clone, Serialize)]
pub struct ContactRecord {
    #[serde(flatten)]
    pub contact: crate::interaction::ContactMessage,
    pub note: Option<NoteRef>,
    /// Physical mode: where that note's stroke aimed, in the piece's coordinates (metres
    /// from its centre, like `x_m`, `y_m`), for the impact point deviation.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub aim_m: Option<[f32; 2]>,
}

#[derive(Debug, Clone, Copy, Serialize)]
pub struct HiHatRecord {
    pub time_s: f32,
    pub openness: f32,
}

#[derive(Debug, Clone, Serialize)]
pub struct ChokeRecord {
    pub piece: String,
    pub time_s: f32,
}

/// DIR/SONG.contacts.json.
#[derive(Debug, Clone, Serialize)]
pub struct ContactsFile {
    pub song: String,
    /// The drum channel read and [`Performance::notes_fingerprint`] of its notes.
    pub channel: u8,
    pub notes_fingerprint: String,
    pub sound: &'static str,
    pub kit: String,
    pub map: String,
    pub sample_rate_hz: u32,
    pub contacts: Vec<ContactRecord>,
    pub hihat: Vec<HiHatRecord>,
    pub chokes: Vec<ChokeRecord>,
    /// Notes left out: those the map skips (percussion no kit piece plays) and, with
    /// `--skip-unknown`, those it does not know.
    pub skipped_notes: Vec<SkippedNote>,
}

/// A note number a render left out, how often and why.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SkippedNote {
    pub note: u8,
    pub count: usize,
    pub first_time_s: f64,
    /// What the map calls it ("hand clap"), or "not in the map".
    pub what: String,
}

/// The notes of `perf` that `map` skips or does not know, ascending by note.
pub fn skipped_notes(perf: &Performance, map: &NoteMap) -> Vec<SkippedNote> {
    let mut all: Vec<SkippedNote> = map
        .skipped_notes(perf)
        .into_iter()
        .chain(map.unknown_notes(perf))
        .map(|u| SkippedNote {
            note: u.note,
            count: u.count,
            first_time_s: u.first_time_s,
            what: map.skip_reason(u.note).unwrap_or("not in the map").to_string(),
        })
        .collect();
    all.sort_by_key(|s| s.note);
    all
}

/// "12 x note 39 (hand clap), 2 x note 99 (not in the map)".
fn skipped_list(skipped: &[SkippedNote]) -> String {
    let list: Vec<String> = skipped.iter().map(|s| format!("{} x note {} ({})", s.count, s.note, s.what)).collect();
    list.join(", ")
}

/// What a render did.
#[derive(Debug, Clone)]
pub struct RenderReport {
    pub wav: PathBuf,
    pub contacts_json: PathBuf,
    pub audio_s: f64,
    pub wall_s: f64,
    pub contacts: usize,
    pub non_finite_samples: u64,
    /// Notes left out (see [`ContactsFile::skipped_notes`]).
    pub skipped: Vec<SkippedNote>,
    /// The note map's name and source ("Roland TD (auto: built-in roland-td)").
    pub map: String,
    /// The motion files, when written, and what the motion stage did.
    pub motion: Option<MotionOutput>,
    /// What the body did, in physical mode.
    pub physical: Option<PhysicalSummary>,
}

/// The motion a render wrote.
#[derive(Debug, Clone)]
pub struct MotionOutput {
    pub paths: crate::motion::export::Paths,
    /// "model WEIGHTS" or "the corpus teacher (--teacher)".
    pub hands_from: String,
    pub frames: usize,
    pub dropped_notes: usize,
    pub seconds: f64,
}

/// Hands for every roll frame of a performance on a kit, from something other than the hand
/// model (the corpus teacher).
pub type TeacherHands = fn(&Performance, &NoteMap, &Kit) -> anyhow::Result<Vec<[crate::motion::track::Pose; 2]>>;

/// Where a render's hands come from.
pub enum Hands {
    /// The hand model, with the name the summary gives it (a path, or the compiled-in one).
    Model(Box<crate::motion::hands::HandModel>, String),
    /// The corpus teacher, only when asked for (`--teacher`).
    Teacher(TeacherHands),
}

/// The hand model of a render: `--teacher`, else `--weights`, else
/// `$DRUMSIM_ASSETS/hands/best.bpk` when it exists, else the compiled-in model. Given weights
/// that cannot be read are an error; nothing falls back to the teacher silently.
pub fn load_hands(opts: &RenderOptions) -> anyhow::Result<Hands> {
    use crate::motion::hands::{HandModel, SHIPPED_WEIGHTS_NAME};
    if let Some(teacher) = opts.teacher {
        return Ok(Hands::Teacher(teacher));
    }
    Ok(match opts.weights.clone().or_else(crate::motion::pipeline::override_weights) {
        Some(path) => Hands::Model(Box::new(HandModel::load(&path)?), path.display().to_string()),
        None => Hands::Model(Box::new(HandModel::shipped()), SHIPPED_WEIGHTS_NAME.to_string()),
    })
}

/// The motion stage's result in a render, before anything is written.
pub struct Staged {
    pub planned: crate::motion::pipeline::Planned,
    /// "model NAME" or "the corpus teacher (--teacher)".
    pub hands_from: String,
    pub seconds: f64,
}

/// The motion stage of a render: hands from the model (or the teacher when asked for),
/// strike planning on `kit`, retrieval, feet.
pub fn stage_motion(perf: &Performance, kit: &Kit, map: &NoteMap, hands: &Hands) -> anyhow::Result<Staged> {
    use crate::motion::pipeline;
    let started = Instant::now();
    // The piano roll is made once: the hand model reads it, and the motion stage.
    let roll = crate::midi::roll::piano_roll(perf, map);
    let (predicted, hands_from) = match hands {
        Hands::Model(model, name) => (pipeline::roll_hands(model, &roll), format!("model {name}")),
        Hands::Teacher(teacher) => (teacher(perf, map, kit)?, "the corpus teacher (--teacher)".to_string()),
    };
    let library = pipeline::shipped_library()?;
    let planned = pipeline::perform_planned_roll(perf, map, &roll, kit, &predicted, &library)?;
    Ok(Staged { planned, hands_from, seconds: started.elapsed().as_secs_f64() })
}

/// Write a staged motion's exports (SONG.motion.json, .bvh, .glb, .vrma) under partial names
/// of `set`, to be published with the rest of the render.
pub fn stage_motion_files(
    staged: &Staged,
    kit: &Kit,
    names: crate::motion::rig::RigNames,
    out_dir: &Path,
    stem: &str,
    set: &mut OutputSet,
) -> anyhow::Result<MotionOutput> {
    use crate::motion::{export, rig::Rig};
    let started = Instant::now();
    let paths = export::stage_all_named(&staged.planned.motion, &Rig::default(), Some(kit), names, out_dir, stem, set)?;
    Ok(MotionOutput {
        paths,
        hands_from: staged.hands_from.clone(),
        frames: staged.planned.report.frames,
        dropped_notes: staged.planned.report.dropped,
        seconds: staged.seconds + started.elapsed().as_secs_f64(),
    })
}

impl std::fmt::Display for RenderReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(m) = &self.motion {
            writeln!(
                f,
                "motion: {} frames (hands from {}; {} notes no hand could play) in {:.2} s: {}, {}, {}, {}",
                m.frames,
                m.hands_from,
                m.dropped_notes,
                m.seconds,
                m.paths.json.display(),
                m.paths.bvh.display(),
                m.paths.glb.display(),
                m.paths.vrma.display()
            )?;
        }
        if let Some(p) = &self.physical {
            writeln!(
                f,
                "physical: {} of {} notes hit within 10 ms ({:.2} %), {} contacts that played no note, deepest stick {:.1} mm, body in {:.2} s ({} strokes rehearsed again){}",
                p.hit,
                p.notes,
                100.0 * p.hit as f64 / p.notes.max(1) as f64,
                p.spurious,
                p.max_penetration_mm,
                p.seconds,
                p.replays,
                if p.pedals { "" } else { "; the kit has no [pedals]: kick and hi-hat pedal notes are not played" }
            )?;
        }
        write!(
            f,
            "rendered {:.1} s of audio in {:.2} s ({:.0}x real time), {} contacts: {} and {}",
            self.audio_s,
            self.wall_s,
            self.audio_s / self.wall_s.max(1e-9),
            self.contacts,
            self.wav.display(),
            self.contacts_json.display()
        )?;
        write!(f, "; note map {}", self.map)?;
        if !self.skipped.is_empty() {
            let n: usize = self.skipped.iter().map(|s| s.count).sum();
            write!(f, "; {n} notes left out: {}", skipped_list(&self.skipped))?;
        }
        if self.non_finite_samples > 0 {
            write!(f, "; {} non-finite samples were silenced", self.non_finite_samples)?;
        }
        Ok(())
    }
}

/// Everything the sound side needs for one song, in direct mode.
pub struct Score {
    pub contacts: ContactsFile,
    /// Sound events in time order, decoded from the OSC packets that carried them.
    pub events: Vec<SoundEvent>,
    /// Time of the last note, seconds (files may run on long after it with pedal data only).
    pub duration_s: f64,
}

/// The note map a render uses and its song read with it: `opts.map` names a built-in map or
/// a file, or is `auto` ([`NoteMap::auto_for`] on the song read on its drum channel).
pub fn load_song(song: &Path, opts: &RenderOptions) -> anyhow::Result<(Performance, NoteMap)> {
    let map = if opts.map == crate::midi::map::AUTO_MAP {
        let channel = opts.channel.unwrap_or(10);
        if !(1..=16).contains(&channel) {
            return Err(RenderInputError::Channel(channel).into());
        }
        NoteMap::auto_for(&read_file(song, &ReadOptions { channel })?)
    } else {
        NoteMap::load(&opts.map)?
    };
    Ok((read_song(song, &map, opts)?, map))
}

/// Read a song for a render: the drum channel checked, unknown notes refused unless skipped.
pub fn read_song(song: &Path, map: &NoteMap, opts: &RenderOptions) -> anyhow::Result<Performance> {
    let channel = opts.channel.unwrap_or(map.channel);
    if !(1..=16).contains(&channel) {
        return Err(RenderInputError::Channel(channel).into());
    }
    let mut perf = read_file(song, &ReadOptions { channel })?;
    map.normalize_pedal(&mut perf);
    if !opts.skip_unknown {
        map.check_known(&perf)?;
    }
    let played =
        perf.events.iter().any(|e| matches!(e.kind, DrumEventKind::NoteOn { note, .. } if map.entry(note).is_some()));
    if !played {
        let skipped = skipped_notes(&perf, map);
        return Err(RenderInputError::NothingToPlay { path: song.to_path_buf(), channel, skipped }.into());
    }
    if perf.notes_end_s > MAX_SONG_S {
        return Err(RenderInputError::TooLong { path: song.to_path_buf(), last_note_s: perf.notes_end_s }.into());
    }
    Ok(perf)
}

/// The longest song a render takes, seconds: its WAV (24-bit stereo at 48 kHz) must stay
/// under the format's 4 GiB, which holds 4.14 hours.
pub const MAX_SONG_S: f64 = 4.0 * 3600.0;

/// Hours:minutes:seconds of `s`.
fn hms(s: f64) -> String {
    let s = s.max(0.0).round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

/// Read a song and turn it into contact messages and sound events (direct mode).
pub fn score_file(song: &Path, kit: &Kit, map: &NoteMap, opts: &RenderOptions) -> anyhow::Result<Score> {
    score_performance(&read_song(song, map, opts)?, kit, map)
}

/// Carries messages as OSC bytes through the in-process channel the live mode uses, decodes
/// them into sound events, and records them for SONG.contacts.json.
struct Carrier<'a> {
    kit: &'a Kit,
    tx: transport::ChannelSender,
    rx: transport::ChannelReceiver,
    buf: Vec<u8>,
    events: Vec<SoundEvent>,
    contacts: ContactsFile,
}

impl<'a> Carrier<'a> {
    fn new(perf: &Performance, kit: &'a Kit, map: &NoteMap, sound: &'static str) -> Self {
        let (tx, rx) = transport::channel(64);
        let contacts = ContactsFile {
            song: perf.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
            channel: perf.channel,
            notes_fingerprint: perf.notes_fingerprint(),
            sound,
            kit: kit.name.clone(),
            map: map.name.clone(),
            sample_rate_hz: SAMPLE_RATE_HZ,
            contacts: Vec::new(),
            hihat: Vec::new(),
            chokes: Vec::new(),
            skipped_notes: skipped_notes(perf, map),
        };
        Carrier { kit, tx, rx, buf: Vec::with_capacity(128), events: Vec::new(), contacts }
    }

    fn carry(&mut self, m: &Message, note: Option<NoteRef>) -> anyhow::Result<()> {
        encode(m, &mut self.buf)?;
        self.tx.send(&self.buf)?;
        let packet = self.rx.recv_timeout(Duration::ZERO)?.expect("a packet just sent is there");
        for msg in decode(packet)? {
            self.events.push(SoundEvent::from_message(&msg, self.kit, SAMPLE_RATE_HZ as f32)?);
            match msg {
                Message::Contact(contact) => self.contacts.contacts.push(ContactRecord { contact, note, aim_m: None }),
                Message::HiHat { time_s, openness } => self.contacts.hihat.push(HiHatRecord { time_s, openness }),
                Message::Choke { piece, time_s } => self.contacts.chokes.push(ChokeRecord { piece, time_s }),
            }
        }
        Ok(())
    }

    fn finish(mut self, duration_s: f64) -> Score {
        self.events.sort_by_key(|e| e.at_sample);
        Score { contacts: self.contacts, events: self.events, duration_s }
    }
}

/// Turn a performance into messages, carry them as OSC bytes through an in-process channel
/// exactly as the physics sends them, and decode them into sound events.
pub fn score_performance(perf: &Performance, kit: &Kit, map: &NoteMap) -> anyhow::Result<Score> {
    score_direct(perf, kit, map, None)
}

/// Direct mode with the motion stage's hands, when there is a motion: each hand note's
/// contact names the hand that strikes it in the motion files.
pub fn score_direct(
    perf: &Performance,
    kit: &Kit,
    map: &NoteMap,
    planned: Option<&crate::motion::pipeline::Planned>,
) -> anyhow::Result<Score> {
    let mut director = Director::new(kit, map).map_err(RenderInputError::from)?;
    if let Some(p) = planned {
        let hands = p.notes.iter().zip(&p.report.hands);
        director.set_sticking(hands.filter_map(|(n, h)| Some((n.time_s, kit.pieces.get(n.piece)?.id.clone(), (*h)?))));
    }
    director.note_openness = !perf.events.iter().any(|e| matches!(e.kind, DrumEventKind::HiHatPedal { .. }));
    let mut carrier = Carrier::new(perf, kit, map, "direct");
    let mut msgs = Vec::new();
    for ev in &perf.events {
        msgs.clear();
        director.on_event(ev, &mut msgs);
        let note = match ev.kind {
            DrumEventKind::NoteOn { note, velocity } => Some(NoteRef { note, velocity, time_s: ev.time_s }),
            _ => None,
        };
        for m in &msgs {
            carrier.carry(m, note)?;
        }
    }
    Ok(carrier.finish(perf.notes_end_s))
}

/// What the body did in a physical render.
#[derive(Debug, Clone)]
pub struct PhysicalSummary {
    /// Notes (hand and foot) and how many a contact played within 10 ms.
    pub notes: usize,
    pub hit: usize,
    /// Contacts that played no note.
    pub spurious: usize,
    /// Whether the kit has pedals (without, kick and hi-hat pedal notes are not played).
    pub pedals: bool,
    pub max_penetration_mm: f32,
    /// Strokes the rehearsal played again.
    pub replays: usize,
    pub seconds: f64,
}

/// Physical mode: the staged motion played by the body; its contacts, and the hi-hat
/// openness of the left foot, are the only messages besides cymbal chokes (a grab the body
/// does not make yet, sent at the aftertouch's time). Notes are matched to contacts only
/// for SONG.contacts.json and the summary.
pub fn score_physical(
    perf: &Performance,
    kit: &Kit,
    map: &NoteMap,
    staged: &mut Staged,
) -> anyhow::Result<(Score, PhysicalSummary)> {
    use crate::perform::matching::{match_contacts, onsets};
    let started = Instant::now();
    let take = crate::perform::play(kit, perf, map, &staged.planned, perf.notes_end_s + 0.5)?;
    if !take.finite {
        anyhow::bail!("{}: the simulated body left the finite numbers", perf.path.display());
    }
    // The motion files show the simulated hands and sticks (and the simulated hi-hat).
    for (f, frame) in staged.planned.motion.frames.iter_mut().enumerate() {
        if let (Some(h), o) = (take.hands.get(f), take.hihat_openness.get(f)) {
            frame.hands = *h;
            frame.hihat_openness = o.copied().unwrap_or(frame.hihat_openness);
        }
    }
    let all = onsets(perf, map);
    let (of_contact, played) = match_contacts(&all, &take.messages);
    let mut carrier = Carrier::new(perf, kit, map, "physical");
    // The simulated hi-hat's openness, wherever it changes (60 fps).
    let mut last = f32::NAN;
    for (f, &o) in take.hihat_openness.iter().enumerate() {
        if last.is_nan() || (o - last).abs() >= 0.005 {
            let time_s = (f as f64 / 60.0) as f32;
            carrier.carry(&Message::HiHat { time_s, openness: o }, None)?;
            last = o;
        }
    }
    // A hand grabbing a cymbal (poly aftertouch) chokes it. The body does not reach for the
    // cymbal yet: the grab is taken from the performance at its time, as direct mode does.
    for ev in &perf.events {
        if let crate::midi::DrumEventKind::Aftertouch { note, pressure } = ev.kind {
            if let (true, Some(entry)) = (pressure > 0, map.entry(note)) {
                carrier.carry(&Message::Choke { piece: entry.piece.clone(), time_s: ev.time_s as f32 }, None)?;
            }
        }
    }
    for (m, of) in take.messages.iter().zip(&of_contact) {
        let note = of.map(|i| NoteRef { note: all[i].note, velocity: all[i].velocity, time_s: all[i].time_s });
        carrier.carry(&Message::Contact(m.clone()), note)?;
        // The aim: the note's strike point on its piece, in that surface's coordinates; only
        // for sticks on the note's own piece (a pedal's point is its geometry, not a plan).
        let stick = matches!(m.limb, crate::interaction::Limb::LeftHand | crate::interaction::Limb::RightHand);
        let aim = of.filter(|_| stick).and_then(|i| {
            let piece = kit.piece(&all[i].piece).filter(|p| p.id == m.piece)?;
            Some(crate::kit::strike_point_uv(kit, piece, all[i].zone))
        });
        if let Some(last) = carrier.contacts.contacts.last_mut() {
            last.aim_m = aim;
        }
    }
    let summary = PhysicalSummary {
        notes: all.len(),
        hit: played.iter().filter(|p| **p).count(),
        spurious: of_contact.iter().filter(|o| o.is_none()).count(),
        pedals: kit.pedals.is_some(),
        max_penetration_mm: take.max_penetration_m * 1e3,
        replays: take.replays,
        seconds: started.elapsed().as_secs_f64(),
    };
    Ok((carrier.finish(perf.notes_end_s), summary))
}

/// Render sound events to stereo blocks handed to `sink`, starting at the events' time zero
/// (the limiter's delay is removed). Stops after the last event once all is silent, or after
/// [`MAX_TAIL_S`]. Returns the number of samples rendered and the engine's NaN count.
pub fn render_events(
    kit: &Kit,
    events: &[SoundEvent],
    duration_s: f64,
    mut sink: impl FnMut(&[f32], &[f32]) -> anyhow::Result<()>,
    mut progress: impl FnMut(u64),
) -> anyhow::Result<(u64, u64)> {
    // Every event of a window waits in the queue until the window is processed: room for the
    // busiest window of the song (4,097 notes at one instant are one window's).
    let window = (WINDOW_BLOCKS * BLOCK) as u64;
    let mut busiest = 0usize;
    for in_window in events.chunk_by(|a, b| a.at_sample / window == b.at_sample / window) {
        busiest = busiest.max(in_window.len());
    }
    let event_capacity = busiest.max(4096);
    let settings = EngineSettings { sample_rate_hz: SAMPLE_RATE_HZ as f32, max_block: BLOCK, event_capacity };
    let mut engine = Engine::new(kit, settings);
    let latency = engine.latency_samples() as u64;
    let last_event = events.last().map_or(0, |e| e.at_sample);
    let end_min = last_event.max((duration_s * SAMPLE_RATE_HZ as f64) as u64);
    let end_max = end_min + (MAX_TAIL_S * SAMPLE_RATE_HZ as f64) as u64;
    // Windows of blocks, the voices of each on every core (`Engine::process_parallel`: the
    // same samples as one block at a time on one).
    let threads = crate::sound::offline::threads();
    let frames = WINDOW_BLOCKS * BLOCK;
    let (mut left, mut right) = (vec![0.0f32; frames], vec![0.0f32; frames]);
    let mut silent = vec![false; WINDOW_BLOCKS];
    let mut next = 0;
    let mut written = 0u64;
    crate::sound::denormals::with_flush_to_zero(|| -> anyhow::Result<()> {
        loop {
            let t = engine.sample_time();
            let window_end = t + frames as u64;
            while next < events.len() && events[next].at_sample < window_end {
                if !engine.push(events[next]) {
                    anyhow::bail!("sound engine queue overflowed at sample {}", events[next].at_sample);
                }
                next += 1;
            }
            engine.process_parallel(&mut left, &mut right, &mut silent, threads);
            for (b, &silent_after) in silent.iter().enumerate() {
                let block_t = t + (b * BLOCK) as u64;
                // Drop the limiter's look-ahead so the output lines up with the events.
                let skip = latency.saturating_sub(block_t).min(BLOCK as u64) as usize;
                let range = b * BLOCK + skip..(b + 1) * BLOCK;
                sink(&left[range.clone()], &right[range])?;
                written += (BLOCK - skip) as u64;
                progress(written);
                let done = written >= end_min && next == events.len() && silent_after;
                if done || written >= end_max {
                    return Ok(());
                }
            }
        }
    })?;
    Ok((written, engine.non_finite_samples()))
}

/// `drumsim render`: DIR/SONG.wav and DIR/SONG.contacts.json.
pub fn render_file(song: &Path, opts: &RenderOptions) -> anyhow::Result<RenderReport> {
    let started = Instant::now();
    let kit = match &opts.kit {
        Some(path) => Kit::load(path)?,
        None => Kit::builtin_default(),
    };
    let (perf, map) = load_song(song, opts)?;
    let stem = song
        .file_stem()
        .ok_or_else(|| RenderInputError::NoStem { path: song.to_path_buf() })?
        .to_string_lossy()
        .into_owned();
    // The hand model is read before anything is written: bad weights stop the render early.
    let (score, staged, physical) = match opts.sound {
        SoundMode::Direct => {
            let staged = if opts.motion { Some(stage_motion(&perf, &kit, &map, &load_hands(opts)?)?) } else { None };
            let score = score_direct(&perf, &kit, &map, staged.as_ref().map(|s| &s.planned))?;
            (score, staged, None)
        }
        SoundMode::Physical => {
            let hands = load_hands(opts)?;
            let mut staged = stage_motion(&perf, &kit, &map, &hands)?;
            let (score, summary) = score_physical(&perf, &kit, &map, &mut staged)?;
            (score, Some(staged).filter(|_| opts.motion), Some(summary))
        }
    };
    std::fs::create_dir_all(&opts.out_dir)
        .map_err(|e| anyhow::anyhow!("cannot create output directory {}: {e}", opts.out_dir.display()))?;
    // Every file goes under a partial name first; the set is published whole at the end, so
    // a failure anywhere leaves the folder as it was.
    let mut set = OutputSet::new();
    let wav_path = opts.out_dir.join(format!("{stem}.wav"));
    let json_path = opts.out_dir.join(format!("{stem}.contacts.json"));
    let json = serde_json::to_vec_pretty(&score.contacts)?;
    write_synced(&set.stage(&json_path), &json).map_err(|e| WriteError { path: json_path.clone(), source: e })?;
    let motion =
        staged.map(|s| stage_motion_files(&s, &kit, opts.rig_names, &opts.out_dir, &stem, &mut set)).transpose()?;
    let total = ((score.duration_s + 2.0) * SAMPLE_RATE_HZ as f64) as u64;
    let bar = if opts.progress { indicatif::ProgressBar::new(total) } else { indicatif::ProgressBar::hidden() };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} rendering [{bar:40}] {percent}% ({eta} left)")
            .expect("valid progress template")
            .progress_chars("=> "),
    );
    let wav_error = |e: hound::Error| match e {
        hound::Error::IoError(source) => WriteError { path: wav_path.clone(), source },
        other => WriteError { path: wav_path.clone(), source: std::io::Error::other(other.to_string()) },
    };
    let mut wav = WavSink::create(&set.stage(&wav_path), SAMPLE_RATE_HZ).map_err(wav_error)?;
    let result = render_events(
        &kit,
        &score.events,
        score.duration_s,
        |l, r| Ok(wav.write(l, r).map_err(wav_error)?),
        |n| bar.set_position(n.min(total)),
    );
    bar.finish_and_clear();
    let (samples, non_finite) = result?;
    wav.finish().map_err(wav_error)?;
    set.publish()?;
    Ok(RenderReport {
        motion,
        physical,
        wav: wav_path,
        contacts_json: json_path,
        audio_s: samples as f64 / SAMPLE_RATE_HZ as f64,
        wall_s: started.elapsed().as_secs_f64(),
        contacts: score.contacts.contacts.len(),
        non_finite_samples: non_finite,
        skipped: score.contacts.skipped_notes.clone(),
        map: format!("{} ({})", map.name, map.source),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_summary_counts_non_finite_samples_only_when_there_are_some() {
        let report = |n| RenderReport {
            wav: "out/a.wav".into(),
            contacts_json: "out/a.contacts.json".into(),
            audio_s: 1.0,
            wall_s: 0.1,
            contacts: 2,
            non_finite_samples: n,
            skipped: Vec::new(),
            map: "General MIDI (built-in gm)".into(),
            motion: None,
            physical: None,
        };
        assert!(!report(0).to_string().contains("non-finite"));
        assert!(report(3).to_string().ends_with("; 3 non-finite samples were silenced"), "{}", report(3));
    }
}
