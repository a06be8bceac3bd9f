//! The VMC test receiver (`scripts/vmc-receive.py`, python-osc) as the tests start it.

use serde_json::Value;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Command, Stdio};

/// A Python with python-osc, or none (and the reason).
pub fn python_osc() -> Option<String> {
    let candidates = [
        std::env::var("DRUMSIM_VMC_PYTHON").ok(),
        Some("/opt/drumsim-python/bin/python3".to_string()),
        Some("python3".to_string()),
    ];
    for p in candidates.into_iter().flatten() {
        let ok = Command::new(&p).args(["-c", "import pythonosc"]).output().is_ok_and(|o| o.status.success());
        if ok {
            return Some(p);
        }
    }
    if std::env::var("DRUMSIM_REQUIRE_PYTHON_OSC").as_deref() == Ok("1") {
        panic!("no Python with python-osc (run scripts/setup-debian.sh), and DRUMSIM_REQUIRE_PYTHON_OSC=1");
    }
    eprintln!("skipped: no Python with python-osc; scripts/setup-debian.sh installs it");
    None
}

pub struct Received {
    pub frames: Vec<Value>,
    pub messages: u64,
    pub unknown: Vec<Value>,
}

/// Start the receiver on a free port; returns it and the port.
pub fn start_receiver(python: &str, out: &Path) -> (std::process::Child, u16) {
    let mut child = Command::new(python)
        .arg(concat!(env!("CARGO_MANIFEST_DIR"), "/scripts/vmc-receive.py"))
        .args(["--port", "0", "--quiet-s", "1.5", "--max-s", "90", "--out"])
        .arg(out)
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .expect("start the VMC receiver");
    let mut line = String::new();
    BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).unwrap();
    let port = line.trim().parse().unwrap_or_else(|_| panic!("the receiver printed {line:?}, not its port"));
    (child, port)
}

pub fn finish_receiver(mut child: std::process::Child, out: &Path) -> Received {
    let status = child.wait().unwrap();
    assert!(status.success(), "the receiver failed");
    let mut text = String::new();
    std::fs::File::open(out).unwrap().read_to_string(&mut text).unwrap();
    let v: Value = serde_json::from_str(&text).unwrap();
    Received {
        frames: v["frames"].as_array().unwrap().clone(),
        messages: v["messages"].as_u64().unwrap(),
        unknown: v["unknown"].as_array().unwrap().clone(),
    }
}
