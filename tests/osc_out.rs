//! `drumsim render --sound-to udp://...` plays the render's contact messages in real time as
//! standard OSC: python-osc (the library most OSC tools in Python use) receives them over real
//! UDP on 127.0.0.1 and reads each message's bundle time tag. Needs python-osc
//! (`scripts/setup-debian.sh` installs it); skipped without it unless
//! DRUMSIM_REQUIRE_PYTHON_OSC=1.

#[allow(dead_code)]
mod vmc_receiver;

use serde_json::Value;
use std::io::{BufRead, BufReader, Read};
use std::path::Path;
use std::process::{Command, Stdio};

/// Prints its port, then a JSON list of what arrived: address, arguments, the time tag as
/// system time (python-osc gives `now` for a tag already past) and the arrival time.
const RECEIVER: &str = r#"
import json, socket, sys, time
from pythonosc.osc_packet import OscPacket
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1], flush=True)
s.settimeout(float(sys.argv[1]))
got = []
try:
    while True:
        d = s.recv(65536)
        now = time.time()
        for m in OscPacket(d).messages:
            got.append({"address": m.message.address, "args": list(m.message.params), "tag": m.time, "arrived": now})
except socket.timeout:
    pass
print(json.dumps(got), flush=True)
"#;

#[test]
fn python_osc_reads_a_renders_contact_messages_each_tagged_ahead_at_its_time() {
    let Some(python) = vmc_receiver::python_osc() else { return };
    let song = Path::new(env!("CARGO_MANIFEST_DIR")).join("data/gmd/drummer7/session1/34_hiphop_100_fill_4-4.mid");
    let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("osc-out-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&out);
    let mut receiver = Command::new(&python)
        .args(["-c", RECEIVER, "3"])
        .stdout(Stdio::piped())
        .spawn()
        .expect("start the python-osc receiver");
    let mut stdout = BufReader::new(receiver.stdout.take().unwrap());
    let mut line = String::new();
    stdout.read_line(&mut line).unwrap();
    let port: u16 = line.trim().parse().unwrap_or_else(|_| panic!("the receiver printed {line:?}"));

    let to = format!("udp://127.0.0.1:{port}");
    let args = ["render", song.to_str().unwrap(), "--out", out.to_str().unwrap(), "--no-motion", "--sound-to", &to];
    let render = Command::new(env!("CARGO_BIN_EXE_drumsim")).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&render.stderr);
    assert!(render.status.success(), "render --sound-to failed:\n{stderr}");
    let mut text = String::new();
    stdout.read_to_string(&mut text).unwrap();
    assert!(receiver.wait().unwrap().success(), "the receiver failed");
    let got: Vec<Value> = serde_json::from_str(&text).unwrap();

    // What the render wrote: its contacts, in time order.
    let json = std::fs::read_to_string(out.join("34_hiphop_100_fill_4-4.contacts.json")).unwrap();
    let written: Value = serde_json::from_str(&json).unwrap();
    let mut times: Vec<f64> =
        written["contacts"].as_array().unwrap().iter().map(|c| c["time_s"].as_f64().unwrap()).collect();
    times.sort_by(f64::total_cmp);
    let contacts: Vec<&Value> = got.iter().filter(|m| m["address"] == "/drumsim/contact").collect();
    assert_eq!(contacts.len(), times.len(), "every contact of the render, once:\n{stderr}");
    assert!(got.iter().all(|m| m["address"].as_str().unwrap().starts_with("/drumsim/")), "{text}");

    let (tag0, t0) = (contacts[0]["tag"].as_f64().unwrap(), times[0]);
    let mut worst_spacing: f64 = 0.0;
    let mut ahead = Vec::new();
    for (m, &t) in contacts.iter().zip(&times) {
        let args = m["args"].as_array().unwrap();
        assert_eq!(args.len(), 9, "piece, time, speed, mass, x, y, impulse, hardness, limb: {m}");
        assert!((args[1].as_f64().unwrap() - t).abs() < 1e-4, "{m} is the contact at {t} s");
        let tag = m["tag"].as_f64().unwrap();
        worst_spacing = worst_spacing.max(((tag - tag0) - (t - t0)).abs());
        ahead.push(tag - m["arrived"].as_f64().unwrap());
    }
    let least = ahead.iter().copied().fold(f64::INFINITY, f64::min);
    println!(
        "{} contacts; tags keep the contacts' spacing within {:.3} ms; each arrived {:.1}-{:.1} ms before its tag",
        contacts.len(),
        worst_spacing * 1e3,
        least * 1e3,
        ahead.iter().copied().fold(0.0, f64::max) * 1e3
    );
    assert!(worst_spacing < 1e-3, "the tags keep the performance's timing");
    // Sent 100 ms ahead (python-osc reports a tag already past as its arrival time: ahead 0).
    assert!(least > 0.05, "every message arrived ahead of its tag");
    let _ = std::fs::remove_dir_all(&out);
}
