//! `drumsim view` in a real browser: a Groove MIDI take rendered, the viewer started on it,
//! headless Chromium (software WebGL, no network) driven over the DevTools protocol.
//! Screenshots are asserted on pixels: the drummer and the kit are there, the sticks move,
//! the struck piece lights up at a contact; the picture's time follows the audio's after a
//! seek and after 10 s of play; the page logs no error.
//!
//! Chromium is needed: `scripts/setup-debian.sh` installs it. Without it the test says so
//! and passes, unless DRUMSIM_REQUIRE_BROWSER=1 (CI sets it).

mod browser;

use browser::{chromium, Browser, Image};
use serde_json::Value;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::Duration;

const TAKE: &str = "data/gmd/drummer3/session1/7_rock_105_beat_4-4.mid";
const W: u32 = 1280;
const H: u32 = 720;

fn drumsim() -> Command {
    Command::new(env!("CARGO_BIN_EXE_drumsim"))
}

/// A running `drumsim view`, stopped when dropped.
struct Viewer {
    child: Child,
    url: String,
}

impl Drop for Viewer {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start_viewer(render: &Path) -> Viewer {
    let mut child = drumsim()
        .arg("view")
        .arg(render)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start drumsim view");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let url =
        line.split_whitespace().find(|w| w.starts_with("http://")).expect("the viewer prints its address").to_string();
    Viewer { child, url }
}

fn render_take(dir: &Path) -> PathBuf {
    let out = drumsim().args(["render", TAKE, "--sound", "direct", "--out"]).arg(dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    dir.join("7_rock_105_beat_4-4")
}

fn out_dir(name: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("viewer-{name}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn xy(v: &Value) -> (f64, f64) {
    (v["x"].as_f64().unwrap(), v["y"].as_f64().unwrap())
}

/// A box of half-size `r` CSS pixels around `p`, clipped to the image.
fn around((x, y): (f64, f64), r: f64) -> (usize, usize, usize, usize) {
    let clip = |v: f64, max: u32| v.clamp(0.0, max as f64) as usize;
    (clip(x - r, W), clip(y - r, H), clip(x + r, W), clip(y + r, H))
}

/// Median over a box of red minus blue: how orange (lit) a drum head looks.
fn warmth(img: &Image, b: (usize, usize, usize, usize)) -> f64 {
    let mut v: Vec<i32> = Vec::new();
    for y in b.1..b.3 {
        for x in b.0..b.2 {
            let p = img.at(x, y);
            v.push(p[0] as i32 - p[2] as i32);
        }
    }
    v.sort_unstable();
    v[v.len() / 2] as f64
}

fn browser_or_skip() -> Option<PathBuf> {
    let found = chromium();
    if found.is_none() {
        assert!(
            std::env::var_os("DRUMSIM_REQUIRE_BROWSER").is_none(),
            "DRUMSIM_REQUIRE_BROWSER is set but no chromium"
        );
        println!("no chromium on this machine (scripts/setup-debian.sh installs it): skipping the browser test");
    }
    found
}

#[test]
fn the_viewer_shows_the_drummer_playing_in_step_with_the_sound() {
    let Some(chrome) = browser_or_skip() else { return };
    let dir = out_dir("take");
    let render = render_take(&dir);
    let viewer = start_viewer(&render);
    let mut b = Browser::launch(&chrome, W, H);
    eprintln!("viewer at {}", viewer.url);
    // A fixed drawing scale, so that screenshots compare pixel for pixel.
    b.navigate(&format!("{}?scale=1", viewer.url));
    assert!(b.wait_for("!!(window.drumsim && (drumsim.ready || drumsim.errors.length))", Duration::from_secs(90)));
    assert_eq!(b.eval("drumsim.errors"), serde_json::json!([]), "the page failed to load");
    // The dynamic drawing scale (off here: ?scale=1), fed frame intervals: frames at the
    // display's 60 Hz keep it; a second of missed frames lowers it a step; 5 s at 60 Hz
    // raise it back; a step up that fails at once waits twice as long before the next try.
    let feed = |b: &mut Browser, ms: f64, n: usize| {
        b.eval(&format!("drumsim.feedFrameIntervals(Array({n}).fill({ms}))")).as_f64().unwrap()
    };
    assert_eq!(feed(&mut b, 16.7, 60), 1.0);
    let lowered = feed(&mut b, 33.4, 30);
    assert!((lowered - 0.85).abs() < 1e-9, "a second of 30 fps left the scale at {lowered}");
    assert!((feed(&mut b, 16.7, 270) - 0.85).abs() < 1e-9, "raised before 5 s at 60 fps");
    assert_eq!(feed(&mut b, 16.7, 30), 1.0, "not raised after 5 s at 60 fps");
    assert!((feed(&mut b, 33.4, 30) - 0.85).abs() < 1e-9);
    assert!((feed(&mut b, 16.7, 300) - 0.85).abs() < 1e-9, "a failed step up was retried after 5 s");
    assert_eq!(feed(&mut b, 16.7, 300), 1.0, "a failed step up was not retried after 10 s");
    assert_eq!(b.eval("drumsim.scaling.auto"), serde_json::json!(false));
    let shots = dir.join("shots");
    std::fs::create_dir_all(&shots).unwrap();

    // The drummer and the kit: the picture changes where each is hidden.
    b.eval("drumsim.seek(4.0)");
    let full = b.screenshot(Some(&shots.join("audience.png")));
    b.eval("drumsim.setVisible('drummer', false)");
    let no_drummer = b.screenshot(None);
    b.eval("drumsim.setVisible('drummer', true); drumsim.setVisible('kit', false)");
    let no_kit = b.screenshot(None);
    b.eval("drumsim.setVisible('kit', true)");
    let whole = (0, 0, W as usize, H as usize);
    let (drummer_px, kit_px) = (full.differing(&no_drummer, whole, 40), full.differing(&no_kit, whole, 40));
    println!("pixels of the drummer {drummer_px}, of the kit {kit_px} (of {})", W * H);
    assert!(drummer_px > 20_000, "the drummer's silhouette covers only {drummer_px} pixels");
    assert!(kit_px > 30_000, "the kit covers only {kit_px} pixels");

    // The sticks move: around both hands, the picture at two moments a quarter second apart
    // differs.
    let hands_at =
        |b: &mut Browser| [xy(&b.eval("drumsim.project('left_hand')")), xy(&b.eval("drumsim.project('right_hand')"))];
    b.eval("drumsim.seek(6.0)");
    let (h1, s1) = (hands_at(&mut b), b.screenshot(None));
    b.eval("drumsim.seek(6.25)");
    let (h2, s2) = (hands_at(&mut b), b.screenshot(None));
    let moved: usize = h1.iter().chain(&h2).map(|&p| s1.differing(&s2, around(p, 90.0), 40)).sum();
    println!("pixels changed around the hands between 6.0 and 6.25 s: {moved}");
    assert!(moved > 1_500, "the sticks and hands did not move: {moved} pixels changed");

    // The struck piece lights up: from above, a drum head at a contact of its own (none on it
    // in the 0.6 s before) against the same head 0.3 s earlier.
    b.eval("drumsim.setView('top')");
    let pick = b.eval(
        "(() => { const heads = ['snare', 'tom1', 'tom2', 'floor_tom'];
          const cs = drumsim.contacts.filter(c => heads.includes(c.piece) && c.time_s > 1);
          for (const c of cs) {
            if (!cs.some(o => o.piece === c.piece && o.time_s < c.time_s && o.time_s > c.time_s - 0.6)) return c;
          }
          return null; })()",
    );
    let (piece, t) = (pick["piece"].as_str().expect("a drum contact").to_string(), pick["time_s"].as_f64().unwrap());
    b.eval(&format!("drumsim.seek({})", t + 0.01));
    let lit_level = b.eval(&format!("drumsim.litLevel('{piece}')")).as_f64().unwrap();
    let centre = xy(&b.eval(&format!("drumsim.project('{piece}')")));
    let lit = b.screenshot(Some(&shots.join("lit.png")));
    b.eval(&format!("drumsim.seek({})", t - 0.3));
    let unlit = b.screenshot(Some(&shots.join("unlit.png")));
    let (w_lit, w_unlit) = (warmth(&lit, around(centre, 14.0)), warmth(&unlit, around(centre, 14.0)));
    println!("{piece} at {t:.3} s: light level {lit_level:.2}, red - blue {w_unlit} -> {w_lit}");
    assert!(lit_level > 0.3, "{piece} is not lit at its contact");
    assert!(w_lit > w_unlit + 40.0, "{piece} does not look lit: red - blue {w_unlit} -> {w_lit}");

    // Picture and sound keep time: after a seek, and after 10 s of play.
    b.eval("drumsim.setView('audience')");
    let gap = |b: &mut Browser| b.eval("Math.abs(drumsim.animTime - drumsim.audioTime())").as_f64().unwrap();
    b.eval("drumsim.seek(8.5)");
    let after_seek = gap(&mut b);
    b.eval("drumsim.resetFrameStats(); drumsim.play()");
    std::thread::sleep(Duration::from_secs(10));
    let playing = b.eval("({t: drumsim.audioTime(), gap: Math.abs(drumsim.animTime - drumsim.audioTime()), stats: drumsim.frameStats()})");
    b.eval("drumsim.pause()");
    let played = playing["t"].as_f64().unwrap() - 8.5;
    // "Within one frame": of 1/60 s, or of the page's own frame time where software
    // rendering draws slower than that.
    let frame_s = (playing["stats"]["p95_ms"].as_f64().unwrap() / 1e3).max(1.0 / 60.0) + 0.002;
    let gap_playing = playing["gap"].as_f64().unwrap();
    println!(
        "after a seek the picture is {:.1} ms from the sound; after {played:.2} s of play {:.1} ms (a frame: {:.1} ms); frame times {}",
        after_seek * 1e3,
        gap_playing * 1e3,
        frame_s * 1e3,
        playing["stats"]
    );
    assert!(after_seek <= 1.0 / 60.0, "after a seek the picture is {after_seek} s off the sound");
    assert!(played > 9.0, "the audio played only {played} s in 10 s");
    assert!(gap_playing <= frame_s, "after 10 s of play the picture is {gap_playing} s off the sound");

    b.drain_events();
    assert_eq!(b.eval("drumsim.errors"), serde_json::json!([]));

    // As an OBS browser source: no background, floor or controls; the drummer and kit drawn
    // over whatever lies behind.
    b.navigate(&format!("{}?transparent=1&t=4", viewer.url));
    assert!(b.wait_for("!!(window.drumsim && (drumsim.ready || drumsim.errors.length))", Duration::from_secs(90)));
    b.call(
        "Emulation.setDefaultBackgroundColorOverride",
        serde_json::json!({"color": {"r": 0, "g": 0, "b": 0, "a": 0}}),
    );
    let clear = b.screenshot(Some(&shots.join("transparent.png")));
    let opaque = clear.rgba.chunks(4).filter(|p| p[3] == 255).count();
    let see_through = clear.rgba.chunks(4).filter(|p| p[3] == 0).count();
    println!("transparent mode: {opaque} opaque pixels, {see_through} clear");
    assert_eq!(clear.at(5, 5)[3], 0, "the corner is not transparent");
    assert!(opaque > 50_000 && see_through > (W * H) as usize / 2, "{opaque} opaque, {see_through} clear");
    assert_eq!(b.eval("getComputedStyle(document.getElementById('ui')).display"), "none");
    b.drain_events();
    assert!(b.errors.is_empty(), "the page logged errors: {:#?}", b.errors);
    drop(b);
    drop(viewer);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_missing_or_damaged_render_and_a_port_in_use_are_named_with_exit_2() {
    let dir = out_dir("bad");
    // Nothing rendered there.
    let out = drumsim().arg("view").arg(dir.join("song")).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("song.contacts.json: missing"), "{err}");
    // A render whose glb was cut short.
    let render = render_take(&dir);
    let glb = render.with_extension("glb");
    let bytes = std::fs::read(&glb).unwrap();
    std::fs::write(&glb, &bytes[..bytes.len() / 2]).unwrap();
    let out = drumsim().arg("view").arg(&glb).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("7_rock_105_beat_4-4.glb: truncated"), "{err}");
    std::fs::write(&glb, &bytes).unwrap();
    // A port another program holds.
    let held = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = held.local_addr().unwrap().port();
    let out = drumsim().arg("view").arg(&render).args(["--port", &port.to_string()]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains(&format!("port {port} on 127.0.0.1")) && err.contains("--port"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn the_server_answers_ranges_of_the_wav_for_seeking() {
    let dir = out_dir("ranges");
    let render = render_take(&dir);
    let viewer = start_viewer(&render);
    let port: u16 = viewer.url.trim_end_matches('/').rsplit(':').next().unwrap().parse().unwrap();
    let wav = std::fs::read(render.with_extension("wav")).unwrap();
    let mut s = std::net::TcpStream::connect(("127.0.0.1", port)).unwrap();
    use std::io::{Read, Write};
    write!(s, "GET /song.wav HTTP/1.1\r\nRange: bytes=1000-1099\r\nConnection: close\r\n\r\n").unwrap();
    let mut answer = Vec::new();
    s.read_to_end(&mut answer).unwrap();
    let text = String::from_utf8_lossy(&answer);
    assert!(text.starts_with("HTTP/1.1 206"), "{text}");
    assert_eq!(&answer[answer.len() - 100..], &wav[1000..1100]);
    let page = browser::http_get(port, "/");
    assert!(page.contains("importmap") && page.contains("/viewer.js"));
    let three = browser::http_get(port, "/vendor/three/LICENSE");
    assert!(three.contains("MIT"), "three.js is served with its licence");
    drop(viewer);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn render_with_view_renders_then_serves_the_render() {
    let dir = out_dir("render-view");
    let mut child = drumsim()
        .args(["render", TAKE, "--sound", "direct", "--view", "--out"])
        .arg(&dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let viewer =
        Viewer { url: line.split_whitespace().find(|w| w.starts_with("http://")).expect(&line).to_string(), child };
    let port: u16 = viewer.url.trim_end_matches('/').rsplit(':').next().unwrap().parse().unwrap();
    let info: Value = serde_json::from_str(&browser::http_get(port, "/info.json")).unwrap();
    assert_eq!(info["song"], "7_rock_105_beat_4-4");
    assert!(info["duration_s"].as_f64().unwrap() > 30.0 && info["contacts"].as_u64().unwrap() > 100, "{info}");
    assert!(dir.join("7_rock_105_beat_4-4.glb").is_file());
    drop(viewer);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// One frame of a video, by index, as RGB.
fn video_frame(video: &Path, index: usize, w: usize, h: usize) -> Image {
    let out = Command::new("ffmpeg")
        .args(["-v", "error", "-i"])
        .arg(video)
        .args(["-vf", &format!("select=eq(n\\,{index})"), "-frames:v", "1", "-f", "rawvideo", "-pix_fmt", "rgba", "-"])
        .output()
        .expect("ffmpeg");
    assert!(
        out.status.success() && out.stdout.len() == w * h * 4,
        "frame {index}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Image { width: w, height: h, rgba: out.stdout }
}

/// Pixels that are warmer (red minus blue up by more than 40) in `lit` than in `unlit`: a
/// lit piece takes the flash's orange.
fn warmer_pixels(lit: &Image, unlit: &Image) -> usize {
    let warmth = |p: &[u8]| p[0] as i32 - p[2] as i32;
    lit.rgba.chunks(4).zip(unlit.rgba.chunks(4)).filter(|(a, b)| warmth(a) - warmth(b) > 40).count()
}

#[test]
fn drumsim_video_writes_the_song_as_h264_with_its_audio() {
    let Some(_) = browser_or_skip() else { return };
    let dir = out_dir("video");
    let take = "data/gmd/drummer7/session1/2_rock_86_fill_4-4.mid";
    let out = drumsim().args(["render", take, "--sound", "direct", "--out"]).arg(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let render = dir.join("2_rock_86_fill_4-4");
    let (w, h, fps) = (640usize, 360usize, 30.0);
    let out = drumsim().arg("video").arg(&render).args(["--size", "640x360", "--view", "top"]).output().unwrap();
    let said = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{said}");
    println!("{}", said.trim());
    let video = render.with_extension("mp4");
    assert!(video.is_file());

    // ffprobe: an H.264 video of the song's length within one frame, and an audio stream.
    let probe = Command::new("ffprobe")
        .args([
            "-v",
            "error",
            "-show_entries",
            "stream=codec_type,codec_name,width,height,nb_frames,duration",
            "-of",
            "json",
        ])
        .arg(&video)
        .output()
        .expect("ffprobe");
    let streams: Value = serde_json::from_slice(&probe.stdout).unwrap();
    let streams = streams["streams"].as_array().unwrap();
    let v = streams.iter().find(|s| s["codec_type"] == "video").expect("a video stream");
    let a = streams.iter().find(|s| s["codec_type"] == "audio").expect("an audio stream");
    assert_eq!(
        (v["codec_name"].as_str(), v["width"].as_u64(), v["height"].as_u64()),
        (Some("h264"), Some(640), Some(360))
    );
    assert_eq!(a["codec_name"].as_str(), Some("aac"));
    let wav = hound::WavReader::open(render.with_extension("wav")).unwrap();
    let song_s = wav.duration() as f64 / wav.spec().sample_rate as f64;
    let video_s: f64 = v["duration"].as_str().unwrap().parse().unwrap();
    let frames: usize = v["nb_frames"].as_str().unwrap().parse().unwrap();
    println!("video {video_s:.3} s ({frames} frames), song {song_s:.3} s");
    assert!((video_s - song_s).abs() <= 1.0 / fps + 1e-3, "video {video_s} s, song {song_s} s");

    // A frame at a note's time shows the struck piece lit: a drum with no contact in the
    // 0.6 s before, against the frame 0.3 s earlier.
    let contacts: Value =
        serde_json::from_str(&std::fs::read_to_string(render.with_extension("contacts.json")).unwrap()).unwrap();
    let heads = ["snare", "tom1", "tom2", "floor_tom"];
    let list = contacts["contacts"].as_array().unwrap();
    let t = list
        .iter()
        .filter(|c| heads.contains(&c["piece"].as_str().unwrap()) && c["time_s"].as_f64().unwrap() > 1.0)
        .map(|c| (c["piece"].as_str().unwrap(), c["time_s"].as_f64().unwrap()))
        .find(|(p, t)| {
            !list.iter().any(|o| {
                let ot = o["time_s"].as_f64().unwrap();
                o["piece"].as_str() == Some(p) && ot < *t && ot > t - 0.6
            })
        })
        .expect("a drum contact")
        .1;
    let lit_index = (t * fps).ceil() as usize;
    let lit = video_frame(&video, lit_index, w, h);
    let unlit = video_frame(&video, lit_index - 9, w, h);
    let warmer = warmer_pixels(&lit, &unlit);
    println!("at {t:.3} s (frame {lit_index}) {warmer} pixels warmer than 0.3 s before");
    let shots = dir.join("shots");
    std::fs::create_dir_all(&shots).unwrap();
    save_png(&shots.join("video-lit.png"), &lit);
    save_png(&shots.join("video-unlit.png"), &unlit);
    assert!(warmer > 1_000, "the struck drum is not lit in the video: {warmer} pixels warmer");

    // --view picks the camera: the follow camera's picture is not the audience's.
    let mut small = Vec::new();
    for view in ["audience", "follow"] {
        let out = drumsim().arg("video").arg(&render).args(["--size", "320x180", "--view", view]).output().unwrap();
        assert!(out.status.success(), "{view}: {}", String::from_utf8_lossy(&out.stderr));
        small.push(video_frame(&video, 120, 320, 180));
    }
    let moved = small[0].differing(&small[1], (0, 0, 320, 180), 40);
    println!("follow against audience at frame 120: {moved} pixels differ");
    assert!(moved > 5_000, "--view follow drew the audience's picture ({moved} pixels differ)");
}

fn save_png(path: &Path, img: &Image) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut enc = png::Encoder::new(file, img.width as u32, img.height as u32);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header().unwrap().write_image_data(&img.rgba).unwrap();
}

#[test]
fn video_without_chromium_or_ffmpeg_says_what_to_install() {
    let dir = out_dir("video-missing");
    let render = render_take(&dir);
    let empty = dir.join("empty-path");
    std::fs::create_dir_all(&empty).unwrap();
    let out = drumsim().arg("video").arg(&render).env("PATH", &empty).env_remove("CHROMIUM").output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("Chromium is not installed") && err.contains("apt-get install chromium"), "{err}");
    let out = drumsim().arg("video").arg(&render).args(["--size", "641x360"]).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("--size \"641x360\""), "{err}");
    assert!(!render.with_extension("mp4").exists());
}

/// The page's frame times while it plays a long take, as a user watching it would get them
/// (a measurement, not an assert): `DRUMSIM_VIEWER_TAKE` (default the 181 s
/// `drummer8/session2/37_rock_112_beat_4-4`), `DRUMSIM_VIEWER_SIZE` (default 1280x720),
/// 20 s from the take's middle.
/// `cargo test --release --test viewer frame_times -- --ignored --nocapture`
#[test]
#[ignore]
fn frame_times() {
    let Some(chrome) = browser_or_skip() else { return };
    let take =
        std::env::var("DRUMSIM_VIEWER_TAKE").unwrap_or("data/gmd/drummer8/session2/37_rock_112_beat_4-4.mid".into());
    let (w, h) = drumsim::view::video::parse_size(&std::env::var("DRUMSIM_VIEWER_SIZE").unwrap_or("1280x720".into()))
        .expect("DRUMSIM_VIEWER_SIZE as WxH");
    let dir = out_dir("frame-times");
    let out = drumsim().args(["render", &take, "--sound", "direct", "--out"]).arg(&dir).output().unwrap();
    assert!(out.status.success(), "{}", String::from_utf8_lossy(&out.stderr));
    let stem = Path::new(&take).file_stem().unwrap().to_str().unwrap().to_string();
    let viewer = start_viewer(&dir.join(stem));
    let mut b = Browser::launch(&chrome, w, h);
    b.navigate(&format!("{}{}", viewer.url, std::env::var("DRUMSIM_VIEWER_QUERY").unwrap_or_default()));
    assert!(b.wait_for("!!(window.drumsim && (drumsim.ready || drumsim.errors.length))", Duration::from_secs(90)));
    assert_eq!(b.eval("drumsim.errors"), serde_json::json!([]), "the page failed to load");
    let renderer = b.eval("drumsim.renderer");
    let middle = b.eval("drumsim.audioDuration()").as_f64().unwrap_or(20.0) / 2.0 - 10.0;
    if let Ok(js) = std::env::var("DRUMSIM_VIEWER_EVAL") {
        b.eval(&js);
    }
    b.eval(&format!("drumsim.seek({}); drumsim.play()", middle.max(0.0)));
    std::thread::sleep(Duration::from_secs(2));
    b.eval("drumsim.resetFrameStats()");
    std::thread::sleep(Duration::from_secs(20));
    let stats = b.eval("drumsim.frameStats()");
    b.screenshot(Some(&dir.join("playing.png")));
    println!("{w}x{h}, {renderer}: {stats}; a screenshot: {}", dir.join("playing.png").display());
}
