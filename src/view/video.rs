//! `drumsim video OUT/SONG`: OUT/SONG.mp4, the viewer's scene rendered frame by frame with
//! the song's audio. drumsim serves the viewer and starts headless Chromium on it in video
//! mode (`?video=1`): the page sets each frame's time, draws it, reads its pixels back and
//! sends them over a WebSocket (`/frames`); drumsim pipes them to ffmpeg, which encodes
//! H.264 and muxes SONG.wav as AAC. The page sends at most two frames ahead of the ones
//! drumsim has taken, so memory stays bounded whatever the song's length.

use super::http::{Body, Route, SocketHandler};
use super::{find_render, routes};
use crate::outputs::OutputSet;
use crossbeam_channel::{Receiver, Sender};
use std::io::Write;
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tungstenite::protocol::Role;
use tungstenite::{Message, WebSocket};

/// How the video is made.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoOptions {
    pub width: u32,
    pub height: u32,
    pub fps: u32,
    /// audience, seat, top or follow.
    pub view: String,
    pub progress: bool,
}

/// Why a video could not be made. A missing program or a failed encoder is exit 1; a bad
/// render or option is a [`super::ViewError`] or [`VideoInputError`] (exit 2).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum VideoError {
    #[error(
        "{program} is not installed; it {why} (Debian: apt-get install {package}, or run scripts/setup-debian.sh)"
    )]
    Missing { program: &'static str, package: &'static str, why: &'static str },
    #[error("{0}")]
    Failed(String),
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
}

/// A bad `video` option (exit 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct VideoInputError(pub String);

/// Parse `--size WxH`: even sides of 16 to 3840 pixels (H.264's 4:2:0 needs even sides).
pub fn parse_size(text: &str) -> Result<(u32, u32), VideoInputError> {
    let bad = || VideoInputError(format!("--size {text:?}: give WIDTHxHEIGHT, even numbers 16..=3840, e.g. 1280x720"));
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h): (u32, u32) = (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    if !(16..=3840).contains(&w) || !(16..=3840).contains(&h) || w % 2 == 1 || h % 2 == 1 {
        return Err(bad());
    }
    Ok((w, h))
}

/// What the page's frames came to: how many drumsim took, or what went wrong.
type PageOutcome = Result<u64, String>;

/// Frames from the page into ffmpeg.
#[derive(Debug)]
struct FrameSink {
    frame_bytes: usize,
    encoder: Mutex<Option<ChildStdin>>,
    progress: indicatif::ProgressBar,
    /// The page's outcome: frames taken, or what went wrong.
    done: Sender<PageOutcome>,
    /// The page's milliseconds a frame (JSON: draw, read back, send, wait).
    page_times: Mutex<String>,
}

impl SocketHandler for FrameSink {
    fn serve(&self, stream: TcpStream) {
        let mut ws = WebSocket::from_raw_socket(stream, Role::Server, None);
        let mut frames = 0u64;
        let outcome = loop {
            match ws.read() {
                Ok(Message::Binary(data)) => {
                    if data.len() != self.frame_bytes {
                        break Err(format!("the page sent a frame of {} bytes, not {}", data.len(), self.frame_bytes));
                    }
                    let mut encoder = self.encoder.lock().unwrap_or_else(|e| e.into_inner());
                    let Some(stdin) = encoder.as_mut() else { break Err("the encoder is closed".into()) };
                    if let Err(e) = stdin.write_all(&data) {
                        break Err(format!("ffmpeg stopped taking frames: {e}"));
                    }
                    frames += 1;
                    self.progress.inc(1);
                    if ws.send(Message::text("ok")).is_err() {
                        break Err("the page went away".into());
                    }
                }
                Ok(Message::Text(t)) if t.as_str().starts_with("done") => {
                    *self.page_times.lock().unwrap_or_else(|e| e.into_inner()) = t.as_str()[4..].trim().to_string();
                    break Ok(frames);
                }
                Ok(Message::Text(t)) => break Err(format!("the page: {}", t.as_str())),
                Ok(_) => {}
                Err(e) => break Err(format!("the page's connection: {e}")),
            }
        };
        let _ = self.done.send(outcome);
    }
}

/// Kills a child process when dropped.
struct Guard(Child);

impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Make OUT/SONG.mp4 for the render named by `path`.
pub fn make_video(path: &Path, opts: &VideoOptions) -> anyhow::Result<VideoReport> {
    if !["audience", "seat", "top", "follow"].contains(&opts.view.as_str()) {
        return Err(VideoInputError(format!("--view {:?}: audience, seat, top or follow", opts.view)).into());
    }
    if !(1..=120).contains(&opts.fps) {
        return Err(VideoInputError(format!("--fps {}: 1..=120", opts.fps)).into());
    }
    let render = find_render(path)?;
    let browser = super::chromium::chromium().ok_or(VideoError::Missing {
        program: "Chromium",
        package: "chromium",
        why: "draws the video's frames",
    })?;
    // The whole making of the video is timed, the choice of renderer (a probe, about 1 s) too.
    let started = std::time::Instant::now();
    let gl = super::chromium::gl(&browser);
    let ffmpeg = super::chromium::on_path("ffmpeg").ok_or(VideoError::Missing {
        program: "ffmpeg",
        package: "ffmpeg",
        why: "encodes the video",
    })?;
    let out = render.wav.with_extension("mp4");
    let frames = ((render.duration_s * f64::from(opts.fps)).round() as u64).max(1);

    let mut set = OutputSet::new();
    let partial = set.stage(&out);
    let mut encoder = Command::new(&ffmpeg)
        .args(["-hide_banner", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgba", "-s"])
        .arg(format!("{}x{}", opts.width, opts.height))
        .args(["-r", &opts.fps.to_string(), "-i", "-", "-i"])
        .arg(&render.wav)
        .args(["-map", "0:v", "-map", "1:a", "-vf", "vflip", "-c:v", "libx264", "-preset", "ultrafast", "-crf", "20"])
        .args(["-pix_fmt", "yuv420p", "-c:a", "aac", "-b:a", "192k", "-movflags", "+faststart", "-f", "mp4"])
        .arg(&partial)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| VideoError::Failed(format!("cannot start {}: {e}", ffmpeg.display())))?;
    let stdin = encoder.stdin.take();
    let stderr = encoder.stderr.take();
    let mut encoder = Guard(encoder);
    let errors = std::thread::spawn(move || {
        let mut text = String::new();
        if let Some(mut e) = stderr {
            let _ = std::io::Read::read_to_string(&mut e, &mut text);
        }
        text
    });

    let progress = if opts.progress {
        let bar = indicatif::ProgressBar::new(frames);
        bar.set_style(
            indicatif::ProgressStyle::with_template("video {bar:40} {pos}/{len} frames, {per_sec}, eta {eta}")
                .expect("a valid template"),
        );
        bar
    } else {
        indicatif::ProgressBar::hidden()
    };
    let (done_tx, done_rx): (Sender<PageOutcome>, Receiver<PageOutcome>) = crossbeam_channel::bounded(1);
    let sink = Arc::new(FrameSink {
        frame_bytes: (opts.width * opts.height * 4) as usize,
        encoder: Mutex::new(stdin),
        progress: progress.clone(),
        done: done_tx,
        page_times: Mutex::new(String::new()),
    });
    let mut all = routes(&render);
    all.push(Route { path: "/frames".into(), content_type: "text/plain", body: Body::Socket(sink.clone()) });
    let url = super::start_live(all, 0).map_err(|e| VideoError::Failed(format!("cannot serve the page: {e}")))?;
    let page = format!(
        "{url}?video=1&ui=0&w={}&h={}&fps={}&frames={frames}&view={}",
        opts.width, opts.height, opts.fps, opts.view
    );
    let profile = std::env::temp_dir().join(format!("drumsim-video-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&profile);
    let chrome = Command::new(&browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--mute-audio",
            "--hide-scrollbars",
        ])
        .args(gl.flags())
        .arg(format!("--window-size={},{}", opts.width, opts.height))
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(&page)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| VideoError::Failed(format!("cannot start {}: {e}", browser.display())))?;
    let mut chrome = Guard(chrome);

    // The page's outcome; Chromium that exits first, never connects or stops drawing is an
    // error.
    let mut last = (0, std::time::Instant::now());
    let outcome = loop {
        match done_rx.recv_timeout(Duration::from_millis(200)) {
            Ok(r) => break r,
            Err(_) => {
                if let Ok(Some(status)) = chrome.0.try_wait() {
                    break Err(format!("Chromium exited ({status}) before the video was drawn"));
                }
                if progress.position() != last.0 {
                    last = (progress.position(), std::time::Instant::now());
                }
                let (limit, what) = if last.0 == 0 { (120, "no frame") } else { (60, "no new frame") };
                if last.1.elapsed() > Duration::from_secs(limit) {
                    break Err(format!("Chromium drew {what} in {limit} s"));
                }
            }
        }
    };
    drop(chrome);
    // Chromium's helper processes may still be closing their files: try a few times.
    for _ in 0..20 {
        if std::fs::remove_dir_all(&profile).is_ok() || !profile.exists() {
            break;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    progress.finish_and_clear();
    // Closing ffmpeg's input ends the video; then it writes the file.
    drop(sink.encoder.lock().unwrap_or_else(|e| e.into_inner()).take());
    let status = encoder.0.wait().map_err(|e| VideoError::Failed(format!("ffmpeg: {e}")))?;
    let log = errors.join().unwrap_or_default();
    // ffmpeg's own failure first: it is why the page's frames stopped going in.
    if !status.success() {
        return Err(VideoError::Failed(format!("ffmpeg failed ({status}): {}", log.trim())).into());
    }
    let taken = outcome.map_err(VideoError::Failed)?;
    if taken != frames {
        return Err(VideoError::Failed(format!("the page drew {taken} frames of {frames}")).into());
    }
    set.publish().map_err(|e| VideoError::Io { path: e.target, source: e.source })?;
    let seconds = started.elapsed().as_secs_f64();
    let times = sink.page_times.lock().unwrap_or_else(|e| e.into_inner()).clone();
    Ok(VideoReport {
        path: out,
        frames,
        seconds,
        real_time: frames as f64 / f64::from(opts.fps) / seconds,
        page_ms: times,
        gl: gl.name(),
    })
}

/// What [`make_video`] made.
#[derive(Debug, Clone)]
pub struct VideoReport {
    pub path: PathBuf,
    pub frames: u64,
    pub seconds: f64,
    /// Seconds of video made per second.
    pub real_time: f64,
    /// The page's milliseconds a frame, as JSON (draw_ms, read_ms, send_ms, wait_ms).
    pub page_ms: String,
    /// How Chromium drew WebGL (system OpenGL or SwiftShader).
    pub gl: &'static str,
}

impl std::fmt::Display for VideoReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "video: {} frames in {:.1} s ({:.2}x real time, WebGL by {}): {}; the page's ms a frame: {}",
            self.frames,
            self.seconds,
            self.real_time,
            self.gl,
            self.path.display(),
            self.page_ms
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes() {
        assert_eq!(parse_size("1280x720").unwrap(), (1280, 720));
        for bad in ["1280", "1281x720", "0x0", "99999x720", "axb"] {
            assert!(parse_size(bad).unwrap_err().to_string().contains(&format!("{bad:?}")), "{bad}");
        }
    }
}
