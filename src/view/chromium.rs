//! Headless Chromium for `drumsim video` (and the viewer's tests): where the binary is and
//! how it draws WebGL.
//!
//! Without a GPU Chromium has two software renderers. SwiftShader (its own, always there) is
//! single-minded and slow; the system's OpenGL through ANGLE's EGL backend is Mesa's
//! llvmpipe on such a machine (it JIT-compiles the shaders with LLVM and draws on every
//! core), or the GPU where Mesa drives one. On this 2-core machine a 1280x720 video frame
//! took 57-60 ms to draw and read back with SwiftShader and about 29 ms with llvmpipe. The
//! system's OpenGL is used when a probe page gets a WebGL 2 context from it; otherwise
//! SwiftShader. `DRUMSIM_GL=swiftshader` or `DRUMSIM_GL=system` forces the choice.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// How Chromium draws WebGL.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Gl {
    /// The system's OpenGL (Mesa: llvmpipe, or a GPU) through ANGLE's EGL backend.
    System,
    /// Chromium's own SwiftShader.
    SwiftShader,
}

impl Gl {
    /// Chromium's command-line flags for this renderer.
    pub fn flags(self) -> &'static [&'static str] {
        match self {
            Gl::System => &["--use-angle=gl-egl", "--ignore-gpu-blocklist"],
            Gl::SwiftShader => &["--use-angle=swiftshader", "--enable-unsafe-swiftshader"],
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Gl::System => "system OpenGL",
            Gl::SwiftShader => "SwiftShader",
        }
    }
}

/// A program on the PATH.
pub(crate) fn on_path(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH")?.to_str()?.split(':').map(|d| PathBuf::from(d).join(name)).find(|p| p.is_file())
}

/// Chromium: $CHROMIUM, else `chromium`, `chromium-browser` or `google-chrome` on the PATH.
pub fn chromium() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("CHROMIUM") {
        return Some(PathBuf::from(p));
    }
    ["chromium", "chromium-browser", "google-chrome"].iter().find_map(|n| on_path(n))
}

/// The renderer to start `browser` with: `DRUMSIM_GL` when set, else the system's OpenGL
/// when it gives the probe page a WebGL 2 context, else SwiftShader. Probed once a process.
pub fn gl(browser: &Path) -> Gl {
    static CHOICE: OnceLock<Gl> = OnceLock::new();
    *CHOICE.get_or_init(|| match std::env::var("DRUMSIM_GL").as_deref() {
        Ok("swiftshader") => Gl::SwiftShader,
        Ok("system") => Gl::System,
        _ if system_gl_works(browser) => Gl::System,
        _ => Gl::SwiftShader,
    })
}

/// Whether Chromium started with the system's OpenGL gets a WebGL 2 context: a page that
/// writes the renderer's name into its body, read back with `--dump-dom` (about a second).
fn system_gl_works(browser: &Path) -> bool {
    const PAGE: &str = "data:text/html,<body><script>const g=document.createElement('canvas').getContext('webgl2');\
        document.body.textContent='GL='+(g?g.getParameter(g.RENDERER):'none');</script></body>";
    let profile = std::env::temp_dir().join(format!("drumsim-gl-probe-{}", std::process::id()));
    let child = Command::new(browser)
        .args(["--headless", "--no-sandbox", "--no-first-run", "--disable-background-networking"])
        .args(Gl::System.flags())
        .arg(format!("--user-data-dir={}", profile.display()))
        .args(["--dump-dom", PAGE])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn();
    let Ok(mut child) = child else { return false };
    // A browser that hangs is given 20 s, then taken for one without the system's OpenGL.
    let started = Instant::now();
    let finished = loop {
        match child.try_wait() {
            Ok(Some(_)) => break true,
            Ok(None) if started.elapsed() < Duration::from_secs(20) => std::thread::sleep(Duration::from_millis(20)),
            _ => break false,
        }
    };
    if !finished {
        let _ = child.kill();
        let _ = child.wait();
    }
    let mut out = String::new();
    if finished {
        if let Some(mut stdout) = child.stdout.take() {
            let _ = std::io::Read::read_to_string(&mut stdout, &mut out);
        }
    }
    let _ = std::fs::remove_dir_all(&profile);
    out.split("GL=").nth(1).is_some_and(|rest| !rest.starts_with("none") && !rest.starts_with('<'))
}
