//! A real headless Chromium, driven over the Chrome DevTools Protocol (a WebSocket), for the
//! viewer's tests: navigate, evaluate JavaScript (awaiting promises), take screenshots, and
//! collect every error the page logs.

use base64::Engine as _;
use serde_json::{json, Value};
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};
use tungstenite::{Message, WebSocket};

pub struct Browser {
    child: Child,
    ws: WebSocket<TcpStream>,
    next_id: u64,
    profile: PathBuf,
    /// Errors the page logged: exceptions, console.error, failed loads.
    pub errors: Vec<String>,
}

/// An RGBA screenshot.
pub struct Image {
    pub width: usize,
    pub height: usize,
    pub rgba: Vec<u8>,
}

impl Image {
    pub fn at(&self, x: usize, y: usize) -> [u8; 4] {
        let i = 4 * (y.min(self.height - 1) * self.width + x.min(self.width - 1));
        [self.rgba[i], self.rgba[i + 1], self.rgba[i + 2], self.rgba[i + 3]]
    }

    /// Pixels in the box [x0, x1) x [y0, y1) whose colours differ by more than `by` (sum
    /// of the three channels' differences) between `self` and `other`.
    pub fn differing(&self, other: &Image, (x0, y0, x1, y1): (usize, usize, usize, usize), by: u32) -> usize {
        let mut n = 0;
        for y in y0..y1.min(self.height) {
            for x in x0..x1.min(self.width) {
                let (a, b) = (self.at(x, y), other.at(x, y));
                let d: u32 = (0..3).map(|c| (a[c] as i32 - b[c] as i32).unsigned_abs()).sum();
                if d > by {
                    n += 1;
                }
            }
        }
        n
    }
}

/// The Chromium binary: $CHROMIUM, else `chromium`, `chromium-browser` or `google-chrome` on
/// the PATH (the lookup `drumsim video` uses).
pub fn chromium() -> Option<PathBuf> {
    drumsim::view::chromium::chromium()
}

impl Browser {
    /// Start headless Chromium (software WebGL, audio allowed to play without a gesture)
    /// with a window of `width` x `height` CSS pixels.
    pub fn launch(binary: &PathBuf, width: u32, height: u32) -> Browser {
        let profile = std::env::temp_dir().join(format!("drumsim-chromium-{}-{}", std::process::id(), width));
        let _ = std::fs::remove_dir_all(&profile);
        let mut child = Command::new(binary)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--disable-default-apps",
                "--no-first-run",
                "--mute-audio",
                "--autoplay-policy=no-user-gesture-required",
                "--remote-debugging-port=0",
                "--hide-scrollbars",
            ])
            .args(drumsim::view::chromium::gl(binary).flags())
            .args(std::env::var("DRUMSIM_TEST_CHROMIUM_FLAGS").unwrap_or_default().split_whitespace())
            .arg(format!("--user-data-dir={}", profile.display()))
            .arg(format!("--window-size={width},{height}"))
            .arg("about:blank")
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start chromium");
        // Chromium prints its DevTools address on stderr.
        let stderr = child.stderr.take().expect("stderr");
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stderr).lines().map_while(Result::ok) {
                if let Some(at) = line.find("ws://") {
                    let _ = tx.send(line[at..].trim().to_string());
                }
            }
        });
        let browser_ws = rx.recv_timeout(Duration::from_secs(60)).expect("chromium printed no DevTools address");
        let port: u16 = browser_ws["ws://127.0.0.1:".len()..].split('/').next().unwrap().parse().unwrap();
        let list = http_get(port, "/json/list");
        let pages: Value = serde_json::from_str(&list).expect("DevTools page list");
        let url = pages
            .as_array()
            .unwrap()
            .iter()
            .find(|p| p["type"] == "page")
            .and_then(|p| p["webSocketDebuggerUrl"].as_str())
            .expect("a page target")
            .to_string();
        let stream = TcpStream::connect(("127.0.0.1", port)).unwrap();
        let (ws, _) = tungstenite::client(url.as_str(), stream).expect("DevTools WebSocket");
        let mut b = Browser { child, ws, next_id: 1, profile, errors: vec![] };
        for domain in ["Runtime.enable", "Log.enable", "Page.enable"] {
            b.call(domain, json!({}));
        }
        // The page's viewport is exactly width x height (a headless window's is smaller).
        b.call(
            "Emulation.setDeviceMetricsOverride",
            json!({"width": width, "height": height, "deviceScaleFactor": 1, "mobile": false}),
        );
        b
    }

    /// Send a command and wait for its answer, noting the events that arrive meanwhile.
    pub fn call(&mut self, method: &str, params: Value) -> Value {
        let id = self.next_id;
        self.next_id += 1;
        self.ws.send(Message::text(json!({"id": id, "method": method, "params": params}).to_string())).unwrap();
        loop {
            let msg = self.ws.read().expect("DevTools connection");
            let Message::Text(text) = msg else { continue };
            let v: Value = serde_json::from_str(&text).unwrap();
            if v["id"].as_u64() == Some(id) {
                if let Some(err) = v.get("error") {
                    panic!("{method}: {err}");
                }
                return v["result"].clone();
            }
            self.note_event(&v);
        }
    }

    fn note_event(&mut self, v: &Value) {
        let p = &v["params"];
        match v["method"].as_str() {
            Some("Runtime.exceptionThrown") => self.errors.push(format!("exception: {}", p["exceptionDetails"])),
            Some("Runtime.consoleAPICalled") if p["type"] == "error" => {
                self.errors.push(format!("console.error: {}", p["args"]))
            }
            Some("Log.entryAdded") if p["entry"]["level"] == "error" => {
                self.errors.push(format!("log: {} {}", p["entry"]["text"], p["entry"]["url"]))
            }
            _ => {}
        }
    }

    /// Evaluate `expr` in the page, awaiting a promise, and return its value.
    pub fn eval(&mut self, expr: &str) -> Value {
        let r = self.call("Runtime.evaluate", json!({"expression": expr, "awaitPromise": true, "returnByValue": true}));
        if let Some(e) = r.get("exceptionDetails") {
            panic!("{expr}: {e}");
        }
        r["result"]["value"].clone()
    }

    /// Evaluate `expr` every 100 ms until it is true, for at most `limit`.
    pub fn wait_for(&mut self, expr: &str, limit: Duration) -> bool {
        let start = Instant::now();
        while start.elapsed() < limit {
            if self.eval(expr) == json!(true) {
                return true;
            }
            std::thread::sleep(Duration::from_millis(100));
        }
        false
    }

    pub fn navigate(&mut self, url: &str) {
        self.call("Page.navigate", json!({"url": url}));
    }

    /// A PNG screenshot of the page, decoded (and saved to `save` when given).
    pub fn screenshot(&mut self, save: Option<&std::path::Path>) -> Image {
        let r = self.call("Page.captureScreenshot", json!({"format": "png"}));
        let bytes = base64::engine::general_purpose::STANDARD.decode(r["data"].as_str().unwrap()).unwrap();
        if let Some(path) = save {
            std::fs::write(path, &bytes).unwrap();
        }
        let decoder = png::Decoder::new(std::io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        let (w, h) = (info.width as usize, info.height as usize);
        let rgba = match info.color_type {
            png::ColorType::Rgba => buf[..w * h * 4].to_vec(),
            png::ColorType::Rgb => buf[..w * h * 3].chunks(3).flat_map(|c| [c[0], c[1], c[2], 255]).collect(),
            other => panic!("screenshot colour type {other:?}"),
        };
        Image { width: w, height: h, rgba }
    }

    /// Take the events that arrived since the last command (errors among them).
    pub fn drain_events(&mut self) {
        self.eval("0");
    }
}

impl Drop for Browser {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        let _ = std::fs::remove_dir_all(&self.profile);
    }
}

/// A plain HTTP GET on 127.0.0.1, the body as text (read to its Content-Length: Chromium's
/// DevTools server keeps the connection open).
pub fn http_get(port: u16, path: &str) -> String {
    let start = Instant::now();
    loop {
        if let Ok(s) = TcpStream::connect(("127.0.0.1", port)) {
            let mut w = s.try_clone().unwrap();
            write!(w, "GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nConnection: close\r\n\r\n").unwrap();
            let mut r = BufReader::new(s);
            let mut length = None;
            loop {
                let mut line = String::new();
                if r.read_line(&mut line).unwrap() == 0 {
                    break;
                }
                let line = line.trim_end();
                if line.is_empty() {
                    break;
                }
                if let Some((k, v)) = line.split_once(':') {
                    if k.eq_ignore_ascii_case("content-length") {
                        length = v.trim().parse::<usize>().ok();
                    }
                }
            }
            let mut body = vec![0; length.expect("a Content-Length")];
            r.read_exact(&mut body).unwrap();
            return String::from_utf8(body).unwrap();
        }
        assert!(start.elapsed() < Duration::from_secs(20), "no answer on port {port}");
        std::thread::sleep(Duration::from_millis(100));
    }
}
