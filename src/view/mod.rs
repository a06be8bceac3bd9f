//! `drumsim view OUT/SONG`: serves a page on 127.0.0.1 that shows a render: the drummer,
//! sticks and kit of SONG.glb, played in step with SONG.wav, each contact of
//! SONG.contacts.json lighting the piece it struck. The page (`assets/viewer/`) and
//! three.js (vendored, MIT) are compiled into the binary, so it works with no network.

pub mod chromium;
pub mod http;
pub mod live;
pub mod video;

use http::{Body, Route};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Why a render cannot be shown; the message names the file or the port.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ViewError {
    #[error("{path}: missing ({what}); render it with `drumsim render SONG.mid --out DIR` (without --no-motion)")]
    Missing { path: PathBuf, what: &'static str },
    #[error("{path}: {reason}")]
    Corrupt { path: PathBuf, reason: String },
    #[error("port {port} on 127.0.0.1: {source} (choose another with --port, or 0 for a free one)")]
    Port { port: u16, source: std::io::Error },
}

/// The files of one render.
#[derive(Debug, Clone)]
pub struct RenderFiles {
    pub song: String,
    pub glb: PathBuf,
    pub wav: PathBuf,
    pub contacts: PathBuf,
    /// Length of the WAV, s.
    pub duration_s: f64,
    /// `sound`, `kit` and the number of contacts, from SONG.contacts.json.
    pub sound: String,
    pub kit: String,
    pub contact_count: usize,
}

/// The extensions of a render's files: `OUT/SONG`, `OUT/SONG.wav`, `OUT/SONG.glb` and the
/// rest all name the same render.
const EXTENSIONS: [&str; 8] = [".contacts.json", ".motion.json", ".wav", ".glb", ".bvh", ".vrma", ".mp4", ".mid"];

/// Find and check the render named by `path` (`OUT/SONG` or one of its files).
pub fn find_render(path: &Path) -> Result<RenderFiles, ViewError> {
    let text = path.to_string_lossy();
    let stem = EXTENSIONS.iter().find_map(|e| text.strip_suffix(e)).unwrap_or(&text).to_string();
    let file = |ext: &str| PathBuf::from(format!("{stem}{ext}"));
    let (glb, wav, contacts) = (file(".glb"), file(".wav"), file(".contacts.json"));
    for (p, what) in [(&contacts, "the render's contacts"), (&wav, "the render's sound"), (&glb, "the drummer and kit")]
    {
        if !p.is_file() {
            return Err(ViewError::Missing { path: p.clone(), what });
        }
    }
    let corrupt = |p: &Path, reason: String| ViewError::Corrupt { path: p.to_path_buf(), reason };
    check_glb(&glb).map_err(|r| corrupt(&glb, r))?;
    let reader = hound::WavReader::open(&wav).map_err(|e| corrupt(&wav, format!("not a readable WAV file: {e}")))?;
    let spec = reader.spec();
    let duration_s = reader.duration() as f64 / spec.sample_rate.max(1) as f64;
    let text =
        crate::files::read_to_string_bounded(&contacts, 1 << 30).map_err(|e| corrupt(&contacts, e.to_string()))?;
    let doc: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| corrupt(&contacts, format!("not JSON: {e}")))?;
    let list = doc["contacts"].as_array().ok_or_else(|| corrupt(&contacts, "no \"contacts\" list".into()))?;
    for (i, c) in list.iter().enumerate() {
        if !(c["piece"].is_string() && c["time_s"].is_number() && c["speed_mps"].is_number()) {
            return Err(corrupt(&contacts, format!("contact {i} lacks piece, time_s or speed_mps")));
        }
    }
    let song = Path::new(&stem).file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    Ok(RenderFiles {
        song,
        glb,
        wav,
        contacts,
        duration_s,
        sound: doc["sound"].as_str().unwrap_or("?").to_string(),
        kit: doc["kit"].as_str().unwrap_or("?").to_string(),
        contact_count: list.len(),
    })
}

/// Check a binary glTF's container and that its JSON has a scene and an animation.
fn check_glb(path: &Path) -> Result<(), String> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(|e| e.to_string())?;
    let mut head = [0u8; 20];
    f.read_exact(&mut head).map_err(|_| "shorter than a glTF header".to_string())?;
    let word = |o: usize| u32::from_le_bytes(head[o..o + 4].try_into().expect("4 bytes"));
    if &head[0..4] != b"glTF" || word(4) != 2 || &head[16..20] != b"JSON" {
        return Err("not a binary glTF 2.0 file".into());
    }
    let len = std::fs::metadata(path).map_err(|e| e.to_string())?.len();
    if word(8) as u64 != len {
        return Err(format!("truncated: the header says {} bytes, the file has {len}", word(8)));
    }
    let mut json = vec![0u8; word(12) as usize];
    f.read_exact(&mut json).map_err(|_| "its JSON chunk is cut short".to_string())?;
    let doc: serde_json::Value = serde_json::from_slice(&json).map_err(|e| format!("its JSON chunk: {e}"))?;
    if doc["animations"].as_array().is_none_or(|a| a.is_empty()) {
        return Err("no animation in it".into());
    }
    Ok(())
}

/// The page and three.js, compiled in.
fn page_routes() -> Vec<Route> {
    macro_rules! asset {
        ($route:expr, $file:expr) => {
            Route {
                path: $route.into(),
                content_type: http::content_type($file),
                body: Body::Bytes(Arc::from(&include_bytes!(concat!("../../assets/viewer/", $file))[..])),
            }
        };
    }
    vec![
        asset!("/", "index.html"),
        asset!("/index.html", "index.html"),
        asset!("/viewer.js", "viewer.js"),
        asset!("/viewer.css", "viewer.css"),
        asset!("/vendor/three/three.module.js", "vendor/three/three.module.js"),
        asset!("/vendor/three/three.core.js", "vendor/three/three.core.js"),
        asset!("/vendor/three/addons/loaders/GLTFLoader.js", "vendor/three/addons/loaders/GLTFLoader.js"),
        asset!("/vendor/three/addons/controls/OrbitControls.js", "vendor/three/addons/controls/OrbitControls.js"),
        asset!("/vendor/three/addons/utils/BufferGeometryUtils.js", "vendor/three/addons/utils/BufferGeometryUtils.js"),
        asset!("/vendor/three/addons/utils/SkeletonUtils.js", "vendor/three/addons/utils/SkeletonUtils.js"),
        asset!(
            "/vendor/three/addons/environments/RoomEnvironment.js",
            "vendor/three/addons/environments/RoomEnvironment.js"
        ),
        asset!("/vendor/three/LICENSE", "vendor/three/LICENSE"),
    ]
}

/// Every route of the viewer for one render.
pub fn routes(render: &RenderFiles) -> Vec<Route> {
    let info = serde_json::json!({
        "song": render.song,
        "duration_s": render.duration_s,
        "sound": render.sound,
        "kit": render.kit,
        "contacts": render.contact_count,
    });
    let mut routes = page_routes();
    routes.push(info_route(&info));
    routes.push(Route {
        path: "/song.glb".into(),
        content_type: "model/gltf-binary",
        body: Body::File(render.glb.clone()),
    });
    routes.push(Route { path: "/song.wav".into(), content_type: "audio/wav", body: Body::File(render.wav.clone()) });
    routes.push(Route {
        path: "/contacts.json".into(),
        content_type: "application/json",
        body: Body::File(render.contacts.clone()),
    });
    routes
}

/// `/info.json`: what the page shows (song, sound, kit; `live` for the live page).
fn info_route(info: &serde_json::Value) -> Route {
    Route {
        path: "/info.json".into(),
        content_type: "application/json",
        body: Body::Bytes(Arc::from(info.to_string().into_bytes())),
    }
}

/// The routes of the live page: the page, `info` (with `"live": true`), the drummer and kit
/// as a glb, and the pose stream at `/live`.
pub fn live_routes(info: &serde_json::Value, glb: Vec<u8>, hub: Arc<live::LiveHub>) -> Vec<Route> {
    let mut routes = page_routes();
    routes.push(info_route(info));
    routes.push(Route {
        path: "/song.glb".into(),
        content_type: "model/gltf-binary",
        body: Body::Bytes(Arc::from(glb)),
    });
    routes.push(Route { path: "/live".into(), content_type: "text/plain", body: Body::Socket(hub) });
    routes
}

/// Serve the live page on 127.0.0.1:`port` (0: a free one) from a thread of its own; returns
/// its address.
pub fn start_live(routes: Vec<Route>, port: u16) -> Result<String, ViewError> {
    let listener = bind(port)?;
    let addr = listener.local_addr().map_err(|source| ViewError::Port { port, source })?;
    std::thread::Builder::new()
        .name("drumsim-view".into())
        .spawn(move || http::serve(listener, routes))
        .map_err(|source| ViewError::Port { port, source })?;
    Ok(format!("http://{addr}/"))
}

/// Bind 127.0.0.1:`port` (0: a free port).
pub fn bind(port: u16) -> Result<TcpListener, ViewError> {
    TcpListener::bind(("127.0.0.1", port)).map_err(|source| ViewError::Port { port, source })
}

/// Launch the desktop's default browser on `url`; false when there is none to launch.
pub fn open_browser(url: &str) -> bool {
    let opener = if cfg!(target_os = "macos") { "open" } else { "xdg-open" };
    std::process::Command::new(opener)
        .arg(url)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .is_ok()
}

/// Show `path`'s render on `port` until the process is stopped.
pub fn run(path: &Path, port: u16, open: bool) -> Result<(), ViewError> {
    let render = find_render(path)?;
    let listener = bind(port)?;
    let addr = listener.local_addr().map_err(|source| ViewError::Port { port, source })?;
    let url = format!("http://{addr}/");
    println!(
        "drumsim view: {url}  ({}: {:.1} s, {} contacts, {} sound; Ctrl-C to stop)",
        render.song, render.duration_s, render.contact_count, render.sound
    );
    use std::io::Write;
    let _ = std::io::stdout().flush();
    if open && !open_browser(&url) {
        eprintln!("drumsim view: no browser could be launched; open {url} yourself");
    }
    http::serve(listener, routes(&render));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_page_asset_is_compiled_in() {
        let routes = page_routes();
        let js = routes.iter().find(|r| r.path == "/viewer.js").unwrap();
        let Body::Bytes(b) = &js.body else { panic!() };
        let text = std::str::from_utf8(b).unwrap();
        // Every module the page imports is served.
        for import in ["three/addons/loaders/GLTFLoader.js", "three/addons/controls/OrbitControls.js"] {
            assert!(text.contains(import));
            let path = format!("/vendor/{import}");
            assert!(routes.iter().any(|r| r.path == path), "{path} not served");
        }
    }

    #[test]
    fn missing_and_corrupt_files_are_named() {
        let dir = std::env::temp_dir().join(format!("drumsim-view-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let err = find_render(&dir.join("song")).unwrap_err();
        assert!(err.to_string().contains("song.contacts.json: missing"), "{err}");
        std::fs::write(dir.join("song.contacts.json"), "{\"contacts\": []}").unwrap();
        std::fs::write(dir.join("song.wav"), b"RIFF").unwrap();
        std::fs::write(dir.join("song.glb"), b"glTF\x02\0\0\0").unwrap();
        let err = find_render(&dir.join("song.wav")).unwrap_err();
        assert!(err.to_string().contains("song.glb: shorter than a glTF header"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
