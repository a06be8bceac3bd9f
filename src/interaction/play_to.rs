//! A render's messages played to a sound server in real time (`render --sound-to`): every
//! contact, hi-hat and choke of SONG.contacts.json, in time order, each sent `ahead` before
//! it is to sound, tagged with that moment.

use super::remote::{SendCounts, TimedSender};
use super::{ContactMessage, Message};
use serde::Deserialize;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A render's messages could not be read (exit code 2), or sent (exit code 1).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlayError {
    #[error("{path}: {reason}")]
    Contacts { path: PathBuf, reason: String },
    #[error("sending to the sound server at udp://{to}: {source}")]
    Send { to: SocketAddr, source: super::transport::TransportError },
}

impl PlayError {
    pub fn is_io(&self) -> bool {
        matches!(self, PlayError::Send { .. })
    }
}

#[derive(Deserialize)]
struct ContactsFile {
    contacts: Vec<ContactMessage>,
    #[serde(default)]
    hihat: Vec<HiHat>,
    #[serde(default)]
    chokes: Vec<Choke>,
}

#[derive(Deserialize)]
struct HiHat {
    time_s: f32,
    openness: f32,
}

#[derive(Deserialize)]
struct Choke {
    piece: String,
    time_s: f32,
}

/// Every message of a render's SONG.contacts.json, in time order.
pub fn read_messages(path: &Path) -> Result<Vec<Message>, PlayError> {
    let err = |reason: String| PlayError::Contacts { path: path.to_path_buf(), reason };
    let text = std::fs::read_to_string(path).map_err(|e| err(e.to_string()))?;
    let file: ContactsFile = serde_json::from_str(&text).map_err(|e| err(format!("not a contacts file: {e}")))?;
    let mut msgs: Vec<Message> = file.contacts.into_iter().map(Message::Contact).collect();
    msgs.extend(file.hihat.into_iter().map(|h| Message::HiHat { time_s: h.time_s, openness: h.openness }));
    msgs.extend(file.chokes.into_iter().map(|c| Message::Choke { piece: c.piece, time_s: c.time_s }));
    if let Some(m) = msgs.iter().find(|m| !m.time_s().is_finite()) {
        return Err(err(format!("a message at time {}", m.time_s())));
    }
    msgs.sort_by(|a, b| a.time_s().total_cmp(&b.time_s()));
    Ok(msgs)
}

/// What [`play`] did.
#[derive(Debug, Clone, Copy)]
pub struct PlayReport {
    pub to: SocketAddr,
    pub seconds: f64,
    pub counts: SendCounts,
}

impl std::fmt::Display for PlayReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "sound: played {:.1} s to udp://{}: {} messages sent", self.seconds, self.to, self.counts.sent)?;
        if self.counts.refused > 0 {
            write!(f, ", {} refused (is `drumsim sound --listen udp://{}` running?)", self.counts.refused, self.to)?;
        }
        Ok(())
    }
}

/// Play `msgs` (in time order) to `to` in real time: time 0 is now, each message is sent
/// `ahead` before it is to sound.
pub fn play(msgs: &[Message], to: SocketAddr, ahead: Duration) -> Result<PlayReport, PlayError> {
    let epoch = Instant::now();
    let mut sender = TimedSender::connect(to, epoch, ahead).map_err(|e| PlayError::Send { to, source: e.into() })?;
    for msg in msgs {
        let send_at = sender.due(msg.time_s()) - ahead;
        let now = Instant::now();
        if send_at > now {
            std::thread::sleep(send_at - now);
        }
        sender.send(msg).map_err(|source| PlayError::Send { to, source })?;
    }
    Ok(PlayReport { to, seconds: epoch.elapsed().as_secs_f64(), counts: sender.counts })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::interaction::decode;
    use crate::interaction::transport::{PacketReceiver, UdpReceiver};

    #[test]
    fn a_contacts_file_plays_every_message_in_time_order() {
        let dir = std::env::temp_dir().join(format!("drumsim-play-to-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("song.contacts.json");
        std::fs::write(
            &path,
            r#"{"contacts": [
                {"piece": "snare", "time_s": 0.05, "speed_mps": 3.0, "mass_kg": 0.012, "x_m": 0.03, "y_m": 0.0,
                 "impulse_ns": 0.0, "hardness": 1.0, "limb": 0, "note": null},
                {"piece": "kick", "time_s": 0.0, "speed_mps": 2.0, "mass_kg": 0.1, "x_m": 0.0, "y_m": 0.0,
                 "impulse_ns": 0.0, "hardness": 0.5, "limb": 2, "note": {"time_s": 0.0}}],
              "hihat": [{"time_s": 0.02, "openness": 0.3}], "chokes": [{"piece": "crash", "time_s": 0.04}]}"#,
        )
        .unwrap();
        let msgs = read_messages(&path).unwrap();
        let times: Vec<f32> = msgs.iter().map(Message::time_s).collect();
        assert_eq!(times, [0.0, 0.02, 0.04, 0.05]);
        let mut rx = UdpReceiver::bind("127.0.0.1:0").unwrap();
        let report = play(&msgs, rx.local_addr().unwrap(), Duration::from_millis(10)).unwrap();
        assert_eq!(report.counts.sent, 4);
        let mut got = Vec::new();
        while let Some(p) = rx.recv_timeout(Duration::from_millis(200)).unwrap() {
            got.extend(decode(p).unwrap());
        }
        assert_eq!(got, msgs);
        std::fs::write(&path, r#"{"contacts": [{"piece": "snare"}]}"#).unwrap();
        let err = read_messages(&path).unwrap_err().to_string();
        assert!(err.contains("song.contacts.json") && err.contains("missing field"), "{err}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
