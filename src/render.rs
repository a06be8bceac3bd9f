//! Offline pipeline: MIDI file -> contact messages (direct mode) -> OSC bytes over an
//! in-process channel -> sound engine -> DIR/SONG.wav and DIR/SONG.contacts.json.
//! Outputs are written to `.partial` files and renamed only when complete.

use crate::interaction::direct::{DirectError, Director};
use crate::interaction::transport::{self, PacketReceiver, PacketSender};
use crate::interaction::{decode, encode, Message};
use crate::kit::Kit;
use crate::midi::{read_file, DrumEventKind, NoteMap, Performance, ReadOptions};
use crate::sound::wav::{write_atomically, WavSink};
use crate::sound::{Engine, EngineSettings, SoundEvent};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

pub const SAMPLE_RATE_HZ: u32 = 48_000;
/// Longest ring-out rendered after the last event, seconds.
pub const MAX_TAIL_S: f64 = 8.0;
const BLOCK: usize = 512;

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
    /// Hands from the corpus teacher instead of the hand model.
    pub teacher: bool,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            out_dir: PathBuf::from("out"),
            kit: None,
            map: "gm".into(),
            channel: None,
            skip_unknown: false,
            progress: false,
            motion: true,
            weights: None,
            teacher: false,
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
    #[error(transparent)]
    Direct(#[from] DirectError),
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
    pub sound: &'static str,
    pub kit: String,
    pub map: String,
    pub sample_rate_hz: u32,
    pub contacts: Vec<ContactRecord>,
    pub hihat: Vec<HiHatRecord>,
    pub chokes: Vec<ChokeRecord>,
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
    /// The motion files, when written, and what the motion stage did.
    pub motion: Option<MotionOutput>,
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

/// Where a render's hands come from.
pub enum Hands {
    /// The hand model, with the name the summary gives it (a path, or the compiled-in one).
    Model(Box<crate::motion::hands::HandModel>, String),
    /// The corpus teacher, only when asked for (`--teacher`).
    Teacher,
}

/// The hand model of a render: `--teacher`, else `--weights`, else
/// `$DRUMSIM_ASSETS/hands/best.bpk` when it exists, else the compiled-in model. Given weights
/// that cannot be read are an error; nothing falls back to the teacher silently.
pub fn load_hands(opts: &RenderOptions) -> anyhow::Result<Hands> {
    use crate::motion::hands::{HandModel, SHIPPED_WEIGHTS_NAME};
    if opts.teacher {
        return Ok(Hands::Teacher);
    }
    Ok(match opts.weights.clone().or_else(crate::motion::pipeline::override_weights) {
        Some(path) => Hands::Model(Box::new(HandModel::load(&path)?), path.display().to_string()),
        None => Hands::Model(Box::new(HandModel::shipped()), SHIPPED_WEIGHTS_NAME.to_string()),
    })
}

/// The motion stage of a render: hands from the model (or the teacher when asked for),
/// strike planning on `kit`, retrieval, feet, then the exports.
pub fn render_motion(
    song: &Path,
    stem: &str,
    kit: &Kit,
    map: &NoteMap,
    opts: &RenderOptions,
    hands: Hands,
) -> anyhow::Result<MotionOutput> {
    use crate::motion::{export, pipeline, rig::Rig};
    let started = Instant::now();
    let channel = opts.channel.unwrap_or(map.channel);
    let perf = read_file(song, &ReadOptions { channel })?;
    let (predicted, hands_from) = match &hands {
        Hands::Model(model, name) => (pipeline::model_hands(model, &perf, map), format!("model {name}")),
        Hands::Teacher => (pipeline::teacher_hands(&perf, map, kit)?, "the corpus teacher (--teacher)".to_string()),
    };
    let library = pipeline::shipped_library()?;
    let (motion, report) = pipeline::perform(&perf, map, kit, &predicted, &library)?;
    let paths = export::write_all(&motion, &Rig::default(), &opts.out_dir, stem)?;
    Ok(MotionOutput {
        paths,
        hands_from,
        frames: report.frames,
        dropped_notes: report.dropped,
        seconds: started.elapsed().as_secs_f64(),
    })
}

impl std::fmt::Display for RenderReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(m) = &self.motion {
            writeln!(
                f,
                "motion: {} frames (hands from {}; {} notes no hand could play) in {:.2} s: {}, {}, {}",
                m.frames,
                m.hands_from,
                m.dropped_notes,
                m.seconds,
                m.paths.json.display(),
                m.paths.bvh.display(),
                m.paths.glb.display()
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
        )
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

/// Read a song and turn it into contact messages and sound events (direct mode).
pub fn score_file(song: &Path, kit: &Kit, map: &NoteMap, opts: &RenderOptions) -> anyhow::Result<Score> {
    let channel = opts.channel.unwrap_or(map.channel);
    if !(1..=16).contains(&channel) {
        return Err(RenderInputError::Channel(channel).into());
    }
    let perf = read_file(song, &ReadOptions { channel })?;
    if !opts.skip_unknown {
        map.check_known(&perf)?;
    }
    score_performance(&perf, kit, map)
}

/// Turn a performance into messages, carry them as OSC bytes through an in-process channel
/// exactly as the physics will send them, and decode them into sound events.
pub fn score_performance(perf: &Performance, kit: &Kit, map: &NoteMap) -> anyhow::Result<Score> {
    let mut director = Director::new(kit, map).map_err(RenderInputError::from)?;
    director.note_openness = !perf.events.iter().any(|e| matches!(e.kind, DrumEventKind::HiHatPedal { .. }));
    let mut contacts = ContactsFile {
        song: perf.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default(),
        sound: "direct",
        kit: kit.name.clone(),
        map: map.name.clone(),
        sample_rate_hz: SAMPLE_RATE_HZ,
        contacts: Vec::new(),
        hihat: Vec::new(),
        chokes: Vec::new(),
    };
    // The same in-process transport the live mode uses: OSC bytes in, decoded messages out.
    let (mut tx, mut rx) = transport::channel(64);
    let mut events = Vec::new();
    let (mut msgs, mut buf) = (Vec::new(), Vec::with_capacity(128));
    for ev in &perf.events {
        msgs.clear();
        director.on_event(ev, &mut msgs);
        let note = match ev.kind {
            DrumEventKind::NoteOn { note, velocity } => Some(NoteRef { note, velocity, time_s: ev.time_s }),
            _ => None,
        };
        for m in &msgs {
            encode(m, &mut buf)?;
            tx.send(&buf)?;
            let packet = rx.recv_timeout(Duration::ZERO)?.expect("a packet just sent is there");
            for msg in decode(packet)? {
                events.push(SoundEvent::from_message(&msg, kit, SAMPLE_RATE_HZ as f32)?);
                match msg {
                    Message::Contact(contact) => contacts.contacts.push(ContactRecord { contact, note }),
                    Message::HiHat { time_s, openness } => contacts.hihat.push(HiHatRecord { time_s, openness }),
                    Message::Choke { piece, time_s } => contacts.chokes.push(ChokeRecord { piece, time_s }),
                }
            }
        }
    }
    events.sort_by_key(|e| e.at_sample);
    Ok(Score { contacts, events, duration_s: perf.notes_end_s })
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
    let settings = EngineSettings { sample_rate_hz: SAMPLE_RATE_HZ as f32, max_block: BLOCK, event_capacity: 4096 };
    let mut engine = Engine::new(kit, settings);
    let latency = engine.latency_samples() as u64;
    let last_event = events.last().map_or(0, |e| e.at_sample);
    let end_min = last_event.max((duration_s * SAMPLE_RATE_HZ as f64) as u64);
    let end_max = end_min + (MAX_TAIL_S * SAMPLE_RATE_HZ as f64) as u64;
    let (mut left, mut right) = (vec![0.0f32; BLOCK], vec![0.0f32; BLOCK]);
    let mut next = 0;
    let mut written = 0u64;
    crate::sound::denormals::with_flush_to_zero(|| -> anyhow::Result<()> {
        loop {
            let t = engine.sample_time();
            let block_end = t + BLOCK as u64;
            while next < events.len() && events[next].at_sample < block_end {
                if !engine.push(events[next]) {
                    anyhow::bail!("sound engine queue overflowed at sample {t}");
                }
                next += 1;
            }
            engine.process(&mut left, &mut right);
            // Drop the limiter's look-ahead so the output lines up with the events.
            let skip = latency.saturating_sub(t).min(BLOCK as u64) as usize;
            sink(&left[skip..], &right[skip..])?;
            written += (BLOCK - skip) as u64;
            progress(written);
            let done = written >= end_min && next == events.len() && engine.is_silent();
            if done || written >= end_max {
                return Ok(());
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
    let map = NoteMap::load(&opts.map)?;
    let stem = song
        .file_stem()
        .ok_or_else(|| RenderInputError::NoStem { path: song.to_path_buf() })?
        .to_string_lossy()
        .into_owned();
    let score = score_file(song, &kit, &map, opts)?;
    // The hand model is read before anything is written: bad weights stop the render early.
    let hands = if opts.motion { Some(load_hands(opts)?) } else { None };
    std::fs::create_dir_all(&opts.out_dir)
        .map_err(|e| anyhow::anyhow!("cannot create output directory {}: {e}", opts.out_dir.display()))?;
    let wav_path = opts.out_dir.join(format!("{stem}.wav"));
    let json_path = opts.out_dir.join(format!("{stem}.contacts.json"));
    let total = ((score.duration_s + 2.0) * SAMPLE_RATE_HZ as f64) as u64;
    let bar = if opts.progress { indicatif::ProgressBar::new(total) } else { indicatif::ProgressBar::hidden() };
    bar.set_style(
        indicatif::ProgressStyle::with_template("{spinner} rendering [{bar:40}] {percent}% ({eta} left)")
            .expect("valid progress template")
            .progress_chars("=> "),
    );
    let mut wav = WavSink::create(&wav_path, SAMPLE_RATE_HZ)
        .map_err(|e| anyhow::anyhow!("cannot create {}: {e}", wav_path.display()))?;
    let result = render_events(
        &kit,
        &score.events,
        score.duration_s,
        |l, r| Ok(wav.write(l, r)?),
        |n| bar.set_position(n.min(total)),
    );
    bar.finish_and_clear();
    let (samples, non_finite) = match result {
        Ok(r) => r,
        Err(e) => {
            wav.abandon();
            return Err(e);
        }
    };
    let wav_path = wav.finish().map_err(|e| anyhow::anyhow!("cannot finish {}: {e}", wav_path.display()))?;
    let json = serde_json::to_vec_pretty(&score.contacts)?;
    write_atomically(&json_path, &json).map_err(|e| anyhow::anyhow!("cannot write {}: {e}", json_path.display()))?;
    let motion = match hands {
        Some(hands) => Some(render_motion(song, &stem, &kit, &map, opts, hands)?),
        None => None,
    };
    Ok(RenderReport {
        motion,
        wav: wav_path,
        contacts_json: json_path,
        audio_s: samples as f64 / SAMPLE_RATE_HZ as f64,
        wall_s: started.elapsed().as_secs_f64(),
        contacts: score.contacts.contacts.len(),
        non_finite_samples: non_finite,
    })
}
