//! drumsim command line. Parses arguments and maps errors to exit codes; nothing else.

use clap::{Parser, Subcommand, ValueEnum};
use std::path::PathBuf;
use std::process::ExitCode;

/// Real-time threads (the live body's physics) allocate from their own pools; everything else
/// from the system (see `rt_alloc`).
#[global_allocator]
static ALLOCATOR: drumsim::rt_alloc::RtPool = drumsim::rt_alloc::RtPool;

/// `drumsim --version`: the version and the optional features this binary was built with.
#[cfg(feature = "jack")]
const VERSION: &str =
    concat!(env!("CARGO_PKG_VERSION"), " (features: jack; hand model, kits, maps and retrieval library compiled in)");
#[cfg(not(feature = "jack"))]
const VERSION: &str = concat!(
    env!("CARGO_PKG_VERSION"),
    " (features: none, ALSA only; hand model, kits, maps and retrieval library compiled in)"
);

#[derive(Parser)]
#[command(name = "drumsim", version = VERSION, about = "A physically simulated drummer: drum MIDI in, sound and motion out")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, ValueEnum)]
enum SoundMode {
    /// Strikes made by the simulated body's sticks, kick beater and hi-hat pedal (render; live,
    /// where the body plays each note --lookahead-ms after it).
    Physical,
    /// Strikes made straight from MIDI notes.
    Direct,
}

/// VMC protocol output (VSeeFace, Warudo, VNyan, EVMC4U, VRM4U, VMC4B).
#[derive(clap::Args)]
struct VmcArgs {
    /// Send the drummer to a VMC protocol receiver at HOST[:PORT] (port 39539 when left
    /// out): every bone under Unity's humanoid names, the 52 ARKit blendshapes, 60 frames a
    /// second, OSC over UDP.
    #[arg(long, value_name = "HOST[:PORT]")]
    vmc: Option<String>,
    /// How VMC frames go into datagrams: mtu (bundles of at most 1,472 bytes), frame (one
    /// bundle per frame, about 8 KB), messages (no bundles).
    #[arg(long, value_enum, default_value_t = VmcPacking::Mtu)]
    vmc_packing: VmcPacking,
    /// Send only rotations: no root, every bone position zero (for receivers that reset the
    /// pose when bone positions arrive; in EVMC4U untick Bone Position Synchronize).
    #[arg(long)]
    vmc_rotations_only: bool,
    /// What to send, comma-separated: torso, head, arms, fingers, legs, face, or all (leave
    /// out head,face to keep your own face tracking).
    #[arg(long, default_value = "all")]
    vmc_parts: String,
}

#[derive(Clone, Copy, ValueEnum)]
enum RigNamesArg {
    Drumsim,
    Mixamo,
}

#[derive(Clone, Copy, ValueEnum)]
enum VmcPacking {
    Mtu,
    Frame,
    Messages,
}

impl VmcArgs {
    /// The options, when --vmc (or `default`) names a receiver; checked before any work.
    fn options(&self, default: Option<&str>) -> Result<Option<drumsim::vmc::VmcOptions>, drumsim::vmc::VmcError> {
        // The parts are checked even without a receiver, so a mistake is never silent.
        let (groups, face) = drumsim::vmc::parse_parts(&self.vmc_parts)?;
        let Some(target) = self.vmc.as_deref().or(default) else {
            return Ok(None);
        };
        let target = drumsim::vmc::parse_target(target)?;
        use drumsim::vmc::packets::{Content, Packing};
        Ok(Some(drumsim::vmc::VmcOptions {
            target,
            packing: match self.vmc_packing {
                VmcPacking::Mtu => Packing::Mtu,
                VmcPacking::Frame => Packing::Frame,
                VmcPacking::Messages => Packing::Messages,
            },
            content: Content { groups, face, rotations_only: self.vmc_rotations_only },
        }))
    }
}

#[derive(Subcommand)]
enum Command {
    /// Render a MIDI file to DIR/SONG.wav and DIR/SONG.contacts.json.
    Render {
        song: PathBuf,
        #[arg(long, default_value = "out")]
        out: PathBuf,
        #[arg(long, value_enum, default_value_t = SoundMode::Direct)]
        sound: SoundMode,
        /// Kit: a built-in kit (default, rearranged, jazz, rock) or a kit file (default: default).
        #[arg(long)]
        kit: Option<PathBuf>,
        /// Note map: auto (the built-in map that knows the most of the song's notes), gm, gs,
        /// xg, roland-td, alesis, yamaha-dtx, or a file.
        #[arg(long, default_value = "auto")]
        map: String,
        /// Drum channel 1..=16 (default: the map's, 10 for General MIDI).
        #[arg(long)]
        channel: Option<u8>,
        /// Skip notes the map does not know instead of failing.
        #[arg(long)]
        skip_unknown: bool,
        /// Sound only: do not write SONG.motion.json, SONG.bvh and SONG.glb.
        #[arg(long)]
        no_motion: bool,
        /// Hand model weights (default: $DRUMSIM_ASSETS/hands/best.bpk if it exists, else the
        /// model compiled into this binary).
        #[arg(long, conflicts_with = "teacher")]
        weights: Option<PathBuf>,
        /// Hands from the corpus teacher (the hand model's training target) instead of the
        /// hand model.
        #[arg(long)]
        teacher: bool,
        /// The bone names of SONG.bvh and SONG.glb: drumsim's own, or Mixamo's
        /// (`mixamorig:LeftForeArm`) for retargeting tools.
        #[arg(long, value_enum, default_value_t = RigNamesArg::Drumsim)]
        rig_names: RigNamesArg,
        /// Then show the render in the viewer (as `drumsim view`), on --port.
        #[arg(long, conflicts_with = "no_motion")]
        view: bool,
        /// The viewer's port on 127.0.0.1 with --view (default: a free one).
        #[arg(long, default_value_t = 0, requires = "view")]
        port: u16,
        /// Then play the motion to a VMC receiver in real time (see `drumsim vmc`).
        #[command(flatten)]
        vmc: VmcArgs,
        /// Then play the render's contact messages to a sound server (`drumsim sound`, or any
        /// OSC synth) in real time, each in a bundle tagged 100 ms ahead (with --vmc, together
        /// with the motion). SONG.wav is written as always.
        #[arg(long, value_name = "udp://HOST:PORT", conflicts_with = "view")]
        sound_to: Option<String>,
    },
    /// Write OUT/SONG.mp4: the viewer's scene drawn frame by frame in headless Chromium, with
    /// the song's audio, encoded by ffmpeg (H.264 and AAC).
    Video {
        /// The render: OUT/SONG, or any of its files.
        render: PathBuf,
        /// WIDTHxHEIGHT in pixels (even numbers).
        #[arg(long, default_value = "1280x720")]
        size: String,
        #[arg(long, default_value_t = 30)]
        fps: u32,
        /// The camera: audience, seat, top, or follow (the page's follow camera).
        #[arg(long, default_value = "audience")]
        view: String,
    },
    /// Play a render's drummer to a VMC protocol receiver (VSeeFace, Warudo, VNyan, Unity
    /// with EVMC4U, Unreal with VRM4U, Blender with VMC4B) in real time, 60 frames a second.
    Vmc {
        /// The render: OUT/SONG, or any of its files.
        render: PathBuf,
        /// The receiver is --vmc HOST[:PORT] (default 127.0.0.1:39539).
        #[command(flatten)]
        vmc: VmcArgs,
    },
    /// Watch a render: serves a page on 127.0.0.1 (its address printed) that plays
    /// OUT/SONG.wav with the drummer and kit of OUT/SONG.glb, lighting each struck piece.
    View {
        /// The render: OUT/SONG, or any of its files (OUT/SONG.wav, OUT/SONG.glb, ...).
        render: PathBuf,
        /// Port on 127.0.0.1 (default: a free one).
        #[arg(long, default_value_t = 0)]
        port: u16,
        /// Launch the desktop's default browser on the page.
        #[arg(long)]
        open: bool,
    },
    /// Play a live MIDI input (e-kit, keyboard) through the speakers; with --view or --vmc,
    /// a drummer plays it too, --lookahead-ms after each note.
    Live {
        #[arg(long)]
        midi: Option<String>,
        #[arg(long)]
        audio: Option<String>,
        /// Without --view or --vmc: delay the sound by this much so that audio-block timing is
        /// jitter-free (default 0). With them: how long after a note the drummer strikes it,
        /// so that each stroke is prepared before it lands (default 250, 0-1000); the sound
        /// stays immediate.
        #[arg(long)]
        lookahead_ms: Option<f32>,
        #[arg(long, value_enum, default_value_t = SoundMode::Direct)]
        sound: SoundMode,
        /// Send the contact messages to a sound server (`drumsim sound --listen ...`, or any
        /// OSC synth) instead of playing them here: each in an OSC bundle tagged with when it
        /// is to sound, --lookahead-ms after its note (default 20 ms here).
        #[arg(long, value_name = "udp://HOST:PORT")]
        sound_to: Option<String>,
        /// Each kit piece on its own output channel after the stereo mix (channel 3: the
        /// kit's first piece; the names are printed): dry, unpanned, in time with the mix, for
        /// recording each drum on its own track. The device must offer that many channels
        /// (JACK does: up to 64).
        #[arg(long, conflicts_with = "sound_to")]
        stems: bool,
        #[arg(long)]
        kit: Option<PathBuf>,
        #[arg(long, default_value = "gm")]
        map: String,
        #[arg(long)]
        channel: Option<u8>,
        /// Stop after this many seconds.
        #[arg(long)]
        duration_s: Option<f64>,
        /// Show the drummer on a page served on 127.0.0.1 (its address printed), fed over a
        /// WebSocket at 60 frames a second.
        #[arg(long)]
        view: bool,
        /// The page's port with --view (default: a free one).
        #[arg(long, default_value_t = 0, requires = "view")]
        port: u16,
        /// Launch the desktop's browser on the page (with --view).
        #[arg(long, requires = "view")]
        open: bool,
        #[command(flatten)]
        vmc: VmcArgs,
    },
    /// Every piece of a kit struck alone at several velocities and zones: DIR/PIECE.wav and
    /// DIR/audition.json with each hit's measures (level, centroid, decay, tail, pitch, contact).
    Audition {
        /// Kit: a built-in kit (default, rearranged, jazz, rock) or a kit file (default: default).
        #[arg(long)]
        kit: Option<PathBuf>,
        #[arg(long, default_value = "audition")]
        out: PathBuf,
    },
    /// A sound server: plays the contact, hi-hat and choke messages that arrive over UDP
    /// (from `live --sound-to`, `render --sound-to` or any OSC sender) through the speakers,
    /// each time-tagged bundle at its tag.
    Sound {
        /// Where to listen: udp://HOST:PORT (udp://127.0.0.1:0 picks a free port, printed).
        #[arg(long, value_name = "udp://HOST:PORT")]
        listen: String,
        #[arg(long)]
        audio: Option<String>,
        /// The kit whose pieces the messages name (the sender's).
        #[arg(long)]
        kit: Option<PathBuf>,
        /// Messages without a time tag sound this long after they arrive (0-1000 ms).
        #[arg(long, default_value_t = 0.0)]
        latency_ms: f32,
        /// Each kit piece on its own output channel after the stereo mix, as `live --stems`.
        #[arg(long)]
        stems: bool,
        /// Stop after this many seconds.
        #[arg(long)]
        duration_s: Option<f64>,
    },
    /// List MIDI inputs and audio outputs.
    Devices,
    /// The HIMC stroke evaluation: five stroke styles, many perturbed trials, tip-tracking
    /// error of the simulated body per control mode.
    Strokes {
        #[arg(long, value_enum, default_value_t = ModeArg::All)]
        mode: ModeArg,
        /// Trials per style and mode.
        #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u32).range(1..=100_000))]
        trials: u32,
        /// Print the JSON object of DESIGN.md section 7 instead of a table.
        #[arg(long)]
        json: bool,
        /// Write joint-angle traces (one trial per style and mode, 250 Hz) to this JSON file.
        #[arg(long)]
        traces: Option<PathBuf>,
        /// Worker threads, 1 to 1024 (default: all cores; never more than there are trials).
        #[arg(long, value_parser = clap::value_parser!(u16).range(1..=1024))]
        threads: Option<u16>,
        #[arg(long)]
        kit: Option<PathBuf>,
    },
    /// Fit joint limits (Algorithm 1) from motion: joint trajectories as JSON, or the
    /// body's kinematic drumming on the kit.
    Limits {
        /// JSON file {"joints": [[[w, x, y, z], ...] x 11]}; default: kinematic drumming.
        #[arg(long)]
        from: Option<PathBuf>,
        #[arg(long)]
        kit: Option<PathBuf>,
        #[arg(long, default_value = "config/limits.json")]
        out: PathBuf,
    },
    /// Build the hand model's training material: the corpus teacher's motion for every
    /// performance of a Groove MIDI split, saved as one dataset file.
    Corpus {
        /// The Groove MIDI Dataset folder (with info.csv).
        #[arg(long, default_value = "data/gmd")]
        gmd: PathBuf,
        #[arg(long, value_parser = ["train", "validation", "test"], default_value = "train")]
        split: String,
        /// Dataset file to write (default: data/corpus-SPLIT.bin).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Instead of the dataset, build the upper-body retrieval library from the split
        /// and write it here (the shipped one: assets/upper-library.bin, from train).
        #[arg(long)]
        library: Option<PathBuf>,
    },
    /// The stability suite on your kit, map and body settings: every stroke style at 40-300
    /// bpm, the extremes of the allowed body sizes and gains, long continuous play, rolls,
    /// flams, a fast groove, a fill and SONGS played physically, and the sound engine under
    /// a barrage. A table (or --json) of every check's measures; exit 0 only if all hold.
    Check {
        /// Your songs, played physically too.
        songs: Vec<PathBuf>,
        #[arg(long)]
        kit: Option<PathBuf>,
        /// Note map of SONGS (as for render; default auto).
        #[arg(long, default_value = "auto")]
        map: String,
        /// A body or controller setting, KEY=VALUE (repeat): mass_kg, height_m,
        /// stick_length_m, natural_hz, damping_ratio, limit_hz, feedback, solver_iterations,
        /// ik.damping_m, ik.posture_gain, ik.max_step_m.
        #[arg(long = "body", value_name = "KEY=VALUE")]
        body: Vec<String>,
        /// Let gains and counts past their stable range through (--body), to see what the
        /// checks find there. Body sizes are still checked.
        #[arg(long)]
        force: bool,
        /// Simulated minutes of continuous play.
        #[arg(long, default_value_t = 10.0)]
        minutes: f64,
        /// Run only the checks whose name contains this text (strokes/accent, song/, ...).
        #[arg(long)]
        only: Option<String>,
        /// Print the report as one JSON object.
        #[arg(long)]
        json: bool,
    },
    /// Measure a render: hits and timing of its contacts against the MIDI, the DRUMS beat
    /// alignment of its hands, and (with --reference) L1, DTW and jerk against a reference
    /// motion. Prints one JSON object (DESIGN.md section 7).
    Eval {
        song: PathBuf,
        /// The folder `drumsim render` wrote SONG.contacts.json and SONG.motion.json to.
        #[arg(long, default_value = "out")]
        out: PathBuf,
        /// A reference SONG.motion.json (e.g. mocap exported through the same rig).
        #[arg(long)]
        reference: Option<PathBuf>,
        /// Note map (as for render; default auto, the map render chose).
        #[arg(long, default_value = "auto")]
        map: String,
    },
    /// Train the hand model (the DRUMS BiLSTM) on the corpus, resuming from the checkpoint
    /// in --out when there is one; the best-validation weights are OUT/best.bpk.
    Train {
        /// Training and validation dataset files (`drumsim corpus`); built from the Groove
        /// MIDI folder when missing.
        #[arg(long, default_value = "data/corpus-train.bin")]
        train: PathBuf,
        #[arg(long, default_value = "data/corpus-validation.bin")]
        val: PathBuf,
        #[arg(long, default_value = "data/gmd")]
        gmd: PathBuf,
        /// Mocap files of the MMIP shape (see the README) to train on as well.
        #[arg(long)]
        mocap: Vec<PathBuf>,
        #[arg(long, default_value = "assets/hands")]
        out: PathBuf,
        /// Epochs to reach (a resumed run continues up to this count).
        #[arg(long, default_value_t = 500, value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
        epochs: u32,
        /// Stop cleanly (resumable) after this many minutes.
        #[arg(long)]
        max_minutes: Option<f64>,
        /// Weight of the velocity term added to the masked MSE (grip positions' frame
        /// differences; 0 is the paper's loss alone). Default: the shipped model's.
        #[arg(long)]
        velocity_weight: Option<f32>,
        /// AdamW learning rate (default the paper's 1e-3; a lower one for a final phase).
        #[arg(long)]
        lr: Option<f64>,
        /// Do not train: measure OUT/best.bpk against the teacher on the validation set
        /// (L1 per hand, beat alignment) and print it as JSON.
        #[arg(long)]
        report: bool,
    },
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum ModeArg {
    Himc,
    Id,
    Ik,
    All,
}

/// `render --teacher`'s hands: the corpus teacher's (training-only code, reached from here
/// so that the render path does not depend on it).
fn teacher_hands(
    perf: &drumsim::midi::Performance,
    map: &drumsim::midi::NoteMap,
    kit: &drumsim::kit::Kit,
) -> anyhow::Result<Vec<[drumsim::motion::Pose; 2]>> {
    Ok(drumsim::learn::corpus::teacher_hands(perf, map, kit)?)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    if let Err(e) = drumsim::outputs::remove_partials_on_interrupt() {
        eprintln!("drumsim: warning: cannot catch Ctrl-C ({e}); an interrupted render may leave .partial files");
    }
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("drumsim: {}", describe(&err));
            ExitCode::from(exit_code(&err))
        }
    }
}

/// The error and its causes, leaving out a cause whose text the message already holds.
fn describe(err: &anyhow::Error) -> String {
    let mut message = err.to_string();
    for cause in err.chain().skip(1) {
        let text = cause.to_string();
        if !message.contains(&text) {
            message.push_str(": ");
            message.push_str(&text);
        }
    }
    message
}

/// 2 for bad input (a file, a config, a value the user can fix), 1 for anything else.
fn exit_code(err: &anyhow::Error) -> u8 {
    let bad_input = err.chain().any(|e| {
        e.is::<drumsim::midi::MidiError>()
            || e.is::<drumsim::midi::MapError>()
            || e.is::<drumsim::kit::KitError>()
            || e.is::<drumsim::render::RenderInputError>()
            || e.is::<drumsim::sound::event::UnknownPiece>()
            || e.is::<drumsim::live::LiveInputError>()
            || e.is::<drumsim::interaction::remote::AddressError>()
            || e.downcast_ref::<drumsim::interaction::play_to::PlayError>().is_some_and(|e| !e.is_io())
            || e.is::<drumsim::body::sim::DrummerError>()
            || e.is::<drumsim::body::report::TrajectoryError>()
            || e.is::<drumsim::learn::corpus::CorpusError>()
            || e.is::<drumsim::motion::notes::NotesError>()
            || e.is::<drumsim::motion::upper::LibraryError>()
            || e.is::<drumsim::motion::hands::HandsError>()
            || e.is::<drumsim::learn::mocap::MocapError>()
            || e.is::<drumsim::motion::pipeline::MotionError>()
            || e.downcast_ref::<drumsim::motion::export::ExportError>().is_some_and(|e| !e.is_io())
            || e.is::<drumsim::eval::report::EvalError>()
            || e.is::<drumsim::eval::motion::MotionMetricError>()
            || e.is::<drumsim::check::BodyKeyError>()
            || e.is::<drumsim::check::RunNothing>()
            || e.is::<drumsim::body::anthropometry::BodyError>()
            || e.is::<drumsim::view::ViewError>()
            || e.is::<drumsim::view::video::VideoInputError>()
            || e.downcast_ref::<drumsim::vmc::VmcError>().is_some_and(|e| !e.is_io())
            || e.downcast_ref::<drumsim::sound::device::OutputError>()
                .is_some_and(|e| matches!(e, drumsim::sound::device::OutputError::NoStemChannels { .. }))
    });
    if bad_input {
        2
    } else {
        1
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::View { render, port, open } => Ok(drumsim::view::run(&render, port, open)?),
        Command::Video { render, size, fps, view } => {
            let (width, height) = drumsim::view::video::parse_size(&size)?;
            let opts = drumsim::view::video::VideoOptions { width, height, fps, view, progress: true };
            let report = drumsim::view::video::make_video(&render, &opts)?;
            eprintln!("{report}");
            Ok(())
        }
        Command::Vmc { render, vmc } => {
            let opts = vmc.options(Some("127.0.0.1"))?.expect("a default target");
            let report = drumsim::vmc::play_render(&render, &opts, true)?;
            eprintln!("{report}");
            Ok(())
        }
        Command::Render {
            song,
            out,
            sound,
            kit,
            map,
            channel,
            skip_unknown,
            no_motion,
            weights,
            teacher,
            rig_names,
            view,
            port,
            vmc,
            sound_to,
        } => {
            let sound_to = sound_to.map(|s| drumsim::interaction::remote::udp_address("--sound-to", &s)).transpose()?;
            if vmc.vmc.is_some() && (view || no_motion) {
                return Err(drumsim::render::RenderInputError::Unsupported(
                    "--vmc plays the render's motion: it goes with neither --view nor --no-motion".into(),
                )
                .into());
            }
            let vmc = vmc.options(None)?;
            let shown = song.file_stem().map(|stem| out.join(stem));
            let opts = drumsim::render::RenderOptions {
                out_dir: out,
                kit,
                map,
                channel,
                skip_unknown,
                progress: true,
                motion: !no_motion,
                weights,
                teacher: teacher.then_some(teacher_hands as drumsim::render::TeacherHands),
                sound: match sound {
                    SoundMode::Direct => drumsim::render::SoundMode::Direct,
                    SoundMode::Physical => drumsim::render::SoundMode::Physical,
                },
                rig_names: match rig_names {
                    RigNamesArg::Drumsim => drumsim::motion::rig::RigNames::Drumsim,
                    RigNamesArg::Mixamo => drumsim::motion::rig::RigNames::Mixamo,
                },
            };
            let report = drumsim::render::render_file(&song, &opts)?;
            eprintln!("{report}");
            let played = match sound_to {
                Some(to) => {
                    let msgs = drumsim::interaction::play_to::read_messages(&report.contacts_json)?;
                    eprintln!("sound: playing {} messages to udp://{to} in real time; Ctrl-C stops", msgs.len());
                    let ahead = std::time::Duration::from_millis(100);
                    Some(std::thread::spawn(move || drumsim::interaction::play_to::play(&msgs, to, ahead)))
                }
                None => None,
            };
            let result = match shown {
                Some(path) if vmc.is_some() => {
                    let report = drumsim::vmc::play_render(&path, vmc.as_ref().expect("checked"), true)?;
                    eprintln!("{report}");
                    Ok(())
                }
                Some(path) if view => Ok(drumsim::view::run(&path, port, false)?),
                Some(path) if !no_motion => {
                    eprintln!("watch the drummer: drumsim view {}", path.display());
                    Ok(())
                }
                _ => Ok(()),
            };
            if let Some(played) = played {
                let report = played.join().map_err(|_| anyhow::anyhow!("the sound sender panicked"))??;
                eprintln!("{report}");
            }
            result
        }
        Command::Sound { listen, audio, kit, latency_ms, stems, duration_s } => {
            let listen = drumsim::interaction::remote::udp_address("--listen", &listen)?;
            let opts = drumsim::sound_server::ServerOptions {
                listen,
                audio_device: audio,
                kit,
                latency_ms,
                stems,
                duration_s,
            };
            drumsim::sound_server::run(&opts)
        }
        Command::Live {
            midi,
            audio,
            lookahead_ms,
            sound,
            sound_to,
            stems,
            kit,
            map,
            channel,
            duration_s,
            view,
            port,
            open,
            vmc,
        } => {
            let physical = matches!(sound, SoundMode::Physical);
            let vmc = vmc.options(None)?;
            let shown = view || vmc.is_some();
            // The physical drummer's avatar shows the body, which plays `lookahead` behind.
            let avatar_ms = match physical {
                true => lookahead_ms.unwrap_or(drumsim::live_body::DEFAULT_LOOKAHEAD_MS),
                false => lookahead_ms.unwrap_or(drumsim::avatar::DEFAULT_LOOKAHEAD_MS),
            };
            if shown && !(0.0..=1000.0).contains(&avatar_ms) {
                return Err(drumsim::live::LiveInputError::Lookahead(avatar_ms).into());
            }
            let avatar = shown.then(|| drumsim::avatar::AvatarOptions {
                lookahead_s: f64::from(avatar_ms) / 1000.0,
                view_port: view.then_some(port),
                open,
                vmc,
                physical,
            });
            let sound_to = sound_to.map(|s| drumsim::interaction::remote::udp_address("--sound-to", &s)).transpose()?;
            let sound_ms = match (sound_to, shown) {
                _ if physical => lookahead_ms.unwrap_or(drumsim::live_body::DEFAULT_LOOKAHEAD_MS),
                (Some(_), true) => drumsim::live::REMOTE_LOOKAHEAD_MS,
                (Some(_), false) => lookahead_ms.unwrap_or(drumsim::live::REMOTE_LOOKAHEAD_MS),
                (None, true) => 0.0,
                (None, false) => lookahead_ms.unwrap_or(0.0),
            };
            let opts = drumsim::live::LiveOptions {
                midi_port: midi,
                audio_device: audio,
                sound_to,
                stems,
                lookahead_ms: sound_ms,
                kit,
                map,
                channel,
                duration_s,
                avatar,
                physical,
            };
            drumsim::live::run(&opts)
        }
        Command::Devices => drumsim::live::list_devices(),
        Command::Check { songs, kit, map, body, force, minutes, only, json } => {
            use drumsim::check;
            if !(minutes.is_finite() && (0.0..=600.0).contains(&minutes)) {
                return Err(drumsim::render::RenderInputError::Unsupported(format!(
                    "--minutes {minutes}: allowed 0 ..= 600"
                ))
                .into());
            }
            let kit = match &kit {
                Some(path) => drumsim::kit::Kit::load(path)?,
                None => drumsim::kit::Kit::builtin_default(),
            };
            let map = if map == drumsim::midi::map::AUTO_MAP {
                drumsim::midi::NoteMap::builtin("gm").expect("built-in map")
            } else {
                drumsim::midi::NoteMap::load(&map)?
            };
            let mut drummer = drumsim::body::sim::DrummerSettings { unchecked_gains: force, ..Default::default() };
            for b in &body {
                check::set_body(&mut drummer, b)?;
            }
            drummer.validate()?;
            drumsim::body::anthropometry::BodySettings::validate(drummer.body)?;
            let opts = check::CheckOptions { kit, map, drummer, songs, minutes, progress: !json, only };
            let report = check::run(&opts)?;
            if json {
                println!("{}", serde_json::to_string(&report)?);
            } else {
                print!("{}", report.table());
            }
            if report.ok {
                Ok(())
            } else {
                let names: Vec<&str> = report.failures().map(|c| c.name.as_str()).collect();
                Err(check::ChecksFailed { names: names.join(", "), failed: names.len(), total: report.checks.len() }
                    .into())
            }
        }
        Command::Audition { kit, out } => {
            let kit = match &kit {
                Some(path) => drumsim::kit::Kit::load(path)?,
                None => drumsim::kit::Kit::builtin_default(),
            };
            let audition = drumsim::audition::audition(&kit, Some(&out))?;
            print!("{}", drumsim::audition::table(&audition));
            println!("wrote {} WAVs and audition.json to {}", audition.wavs(), out.display());
            Ok(())
        }
        Command::Strokes { mode, trials, json, traces, threads, kit } => {
            use drumsim::body::sim::Mode;
            let modes = match mode {
                ModeArg::Himc => vec![Mode::Himc],
                ModeArg::Id => vec![Mode::Id],
                ModeArg::Ik => vec![Mode::Ik],
                ModeArg::All => Mode::ALL.to_vec(),
            };
            let threads = threads
                .map(usize::from)
                .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
                .max(1);
            let opts = drumsim::body::report::StrokesOptions {
                modes,
                trials: trials as usize,
                threads,
                kit,
                traces,
                progress: !json,
            };
            let report = drumsim::body::report::run_strokes(&opts)?;
            if json {
                println!("{}", serde_json::to_string(&report)?);
            } else {
                print!("{}", report.table());
            }
            Ok(())
        }
        Command::Limits { from, kit, out } => {
            drumsim::body::report::run_limits(from.as_deref(), &kit, &out)?;
            eprintln!("wrote {}", out.display());
            Ok(())
        }
        Command::Eval { song, out, reference, map } => {
            let map =
                if map == drumsim::midi::map::AUTO_MAP { None } else { Some(drumsim::midi::NoteMap::load(&map)?) };
            let m = drumsim::eval::report::run_eval(&song, &out, reference.as_deref(), map.as_ref())?;
            println!("{}", serde_json::to_string(&m)?);
            Ok(())
        }
        Command::Train { train, val, gmd, mocap, out, epochs, max_minutes, velocity_weight, lr, report } => {
            // Checked before any corpus is built: training to NaN or to nothing helps no one.
            if let Some(lr) = lr.filter(|lr| !(lr.is_finite() && *lr > 0.0 && *lr <= 1.0)) {
                return Err(drumsim::motion::hands::HandsError::Config(format!(
                    "--lr {lr:e}: allowed 0 < lr <= 1 (the paper's is 1e-3)"
                ))
                .into());
            }
            use drumsim::learn::{corpus, mocap as mc, Example};
            use drumsim::motion::hands;
            let load = |path: &PathBuf, split: &str| -> anyhow::Result<Vec<Example>> {
                if !path.exists() {
                    eprintln!("{} is missing: building it from {} ({split})", path.display(), gmd.display());
                    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
                        std::fs::create_dir_all(dir)?;
                    }
                    corpus::run_corpus(&gmd, path, split)?;
                }
                Ok(corpus::dataset::load_examples(path)?)
            };
            let val_set = load(&val, "validation")?;
            if report {
                let model = hands::HandModel::load(&out.join("best.bpk"))?;
                let v = drumsim::learn::validate::validate(&model, &val_set)?;
                println!("{}", serde_json::to_string(&v)?);
                return Ok(());
            }
            let mut train_set = load(&train, "train")?;
            let map = drumsim::midi::NoteMap::builtin("gm").expect("built-in map");
            for path in &mocap {
                let take = mc::load_mocap(path, &mc::JointNames::default(), Some(&map))?;
                train_set.push(take.example(&path.display().to_string()));
            }
            std::fs::create_dir_all(&out)?;
            let r = drumsim::learn::run_train(
                &train_set,
                &val_set,
                &out,
                epochs as usize,
                max_minutes,
                velocity_weight,
                lr,
            )?;
            println!(
                "epoch {}: best validation loss {:.5} at epoch {} -> {}",
                r.epoch,
                r.best_val_loss,
                r.best_epoch,
                out.join("best.bpk").display()
            );
            Ok(())
        }
        Command::Corpus { gmd, split, out: _, library: Some(path) } => {
            let (lib, s) = drumsim::learn::upper_library::build_library(&gmd, &split, 15, 600)?;
            lib.save(&path)?;
            for (id, why) in &s.skipped {
                eprintln!("skipped {id}: {why}");
            }
            println!("{}: {} clips, {} frames from the {split} split", path.display(), s.clips, s.frames);
            Ok(())
        }
        Command::Corpus { gmd, split, out, library: None } => {
            let out = out.unwrap_or_else(|| PathBuf::from(format!("data/corpus-{split}.bin")));
            if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(dir)?;
            }
            let s = drumsim::learn::corpus::run_corpus(&gmd, &out, &split)?;
            for (path, why) in &s.skipped {
                eprintln!("skipped {}: {why}", path.display());
            }
            println!(
                "{}: {} performances, {} frames ({:.2} h at 60 fps), {} notes dropped, {} skipped, {:.1} s, {:.1} MB",
                out.display(),
                s.examples,
                s.frames,
                s.frames as f64 / 60.0 / 3600.0,
                s.dropped_notes,
                s.skipped.len(),
                s.seconds,
                s.bytes as f64 / 1e6
            );
            Ok(())
        }
    }
}
