//! One VMC frame as OSC packets (rosc): `/VMC/Ext/Root/Pos`, a `/VMC/Ext/Bone/Pos` per bone,
//! a `/VMC/Ext/Blend/Val` per ARKit weight then `/VMC/Ext/Blend/Apply`, `/VMC/Ext/OK` and
//! `/VMC/Ext/T` last.
//!
//! Every number is an OSC float; positions in metres and rotations as (x, y, z, w), in Unity's
//! frame (see `motion::humanoid`). The 52 blendshapes go by their ARKit names with the first letter
//! capitalized, as VRM "perfect sync" models name their clips (`EyeBlinkLeft`, `JawOpen`).

use crate::motion::humanoid::{Group, Humanoid, UnityPose};
use rosc::{OscBundle, OscMessage, OscPacket, OscTime, OscType};

pub const ROOT: &str = "/VMC/Ext/Root/Pos";
pub const BONE: &str = "/VMC/Ext/Bone/Pos";
pub const BLEND: &str = "/VMC/Ext/Blend/Val";
pub const APPLY: &str = "/VMC/Ext/Blend/Apply";
pub const OK: &str = "/VMC/Ext/OK";
pub const TIME: &str = "/VMC/Ext/T";

/// The largest datagram of [`Packing::Mtu`]: an Ethernet frame less the IP and UDP headers.
pub const MTU_PAYLOAD: usize = 1472;

/// How a frame's messages are put into datagrams.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Packing {
    /// Bundles that each fit one Ethernet frame (1,472 bytes), `/VMC/Ext/T` in the last: no IP
    /// fragments, and receivers with small buffers read every one.
    Mtu,
    /// The whole frame as one bundle (about 8 KB; for receivers on the same machine).
    Frame,
    /// Every message its own datagram, no bundles (for receivers that do not read bundles).
    Messages,
}

/// What a frame carries.
#[derive(Debug, Clone, PartialEq)]
pub struct Content {
    /// Bone groups sent; the rest are left to the receiver (its own face tracking, say).
    pub groups: Vec<Group>,
    /// Send the 52 ARKit blendshapes.
    pub face: bool,
    /// Rotations only: no root message, and every bone's position sent as zero, for
    /// receivers that apply only rotations (EVMC4U with Bone Position Synchronize off).
    pub rotations_only: bool,
}

impl Default for Content {
    fn default() -> Self {
        Content {
            groups: vec![Group::Torso, Group::Head, Group::Arms, Group::Fingers, Group::Legs],
            face: true,
            rotations_only: false,
        }
    }
}

/// Encodes frames for one humanoid.
pub struct Encoder {
    content: Content,
    packing: Packing,
    /// Indices of the bones sent.
    bones: Vec<usize>,
    names: Vec<String>,
    blend_names: Vec<String>,
    positions: Vec<[f32; 3]>,
}

/// The ARKit name as a perfect-sync clip name: the first letter capitalized.
pub fn perfect_sync_name(arkit: &str) -> String {
    let mut c = arkit.chars();
    c.next().map(|f| f.to_uppercase().chain(c).collect()).unwrap_or_default()
}

fn floats(values: &[f32]) -> impl Iterator<Item = OscType> + '_ {
    values.iter().map(|&v| OscType::Float(if v.is_finite() { v } else { 0.0 }))
}

impl Encoder {
    pub fn new(humanoid: &Humanoid, content: Content, packing: Packing) -> Encoder {
        let bones: Vec<usize> =
            (0..humanoid.bones.len()).filter(|&k| content.groups.contains(&humanoid.bones[k].group)).collect();
        Encoder {
            names: humanoid.bones.iter().map(|b| b.name.clone()).collect(),
            positions: humanoid.bones.iter().map(|b| b.t_pose_local).collect(),
            blend_names: crate::motion::ARKIT_NAMES.iter().map(|n| perfect_sync_name(n)).collect(),
            bones,
            content,
            packing,
        }
    }

    /// The messages of one frame, in order; `face` holds the 52 ARKit weights.
    pub fn messages(&self, pose: &UnityPose, face: &[f32], time_s: f32) -> Vec<OscMessage> {
        let msg = |addr: &str, args: Vec<OscType>| OscMessage { addr: addr.to_string(), args };
        let mut out = Vec::with_capacity(self.bones.len() + self.blend_names.len() + 4);
        if !self.content.rotations_only {
            let args = std::iter::once(OscType::String("root".into()))
                .chain(floats(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]))
                .collect();
            out.push(msg(ROOT, args));
        }
        for &k in &self.bones {
            let p = match (self.content.rotations_only, k) {
                (true, _) => [0.0; 3],
                (false, 0) => pose.hips,
                (false, _) => self.positions[k],
            };
            let args = std::iter::once(OscType::String(self.names[k].clone()))
                .chain(floats(&p))
                .chain(floats(&pose.local[k]))
                .collect();
            out.push(msg(BONE, args));
        }
        if self.content.face {
            for (name, w) in self.blend_names.iter().zip(face) {
                out.push(msg(BLEND, vec![OscType::String(name.clone()), OscType::Float(w.clamp(0.0, 1.0))]));
            }
            out.push(msg(APPLY, vec![]));
        }
        out.push(msg(OK, vec![OscType::Int(1)]));
        out.push(msg(TIME, vec![OscType::Float(time_s)]));
        out
    }

    /// One frame as datagrams, by the encoder's packing.
    pub fn datagrams(&self, pose: &UnityPose, face: &[f32], time_s: f32) -> Vec<Vec<u8>> {
        let messages = self.messages(pose, face, time_s);
        let encode = |p: &OscPacket| rosc::encoder::encode(p).expect("OSC encoding into a Vec cannot fail");
        let bundle = |content: Vec<OscPacket>| {
            encode(&OscPacket::Bundle(OscBundle { timetag: OscTime { seconds: 0, fractional: 1 }, content }))
        };
        match self.packing {
            Packing::Messages => messages.into_iter().map(|m| encode(&OscPacket::Message(m))).collect(),
            Packing::Frame => vec![bundle(messages.into_iter().map(OscPacket::Message).collect())],
            Packing::Mtu => {
                // "#bundle\0" and the time tag, then each element's size and bytes.
                const HEADER: usize = 16;
                let mut out = Vec::new();
                let mut group: Vec<OscPacket> = Vec::new();
                let mut size = HEADER;
                for m in messages {
                    let packet = OscPacket::Message(m);
                    let len = 4 + encode(&packet).len();
                    if !group.is_empty() && size + len > MTU_PAYLOAD {
                        out.push(bundle(std::mem::take(&mut group)));
                        size = HEADER;
                    }
                    size += len;
                    group.push(packet);
                }
                if !group.is_empty() {
                    out.push(bundle(group));
                }
                out
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::rig::Rig;

    fn frame(packing: Packing, content: Content) -> (Vec<Vec<u8>>, Vec<OscMessage>) {
        let h = Humanoid::of_rig(&Rig::default());
        let e = Encoder::new(&h, content, packing);
        let pose = h.empty_pose();
        let face = vec![0.25; 52];
        let datagrams = e.datagrams(&pose, &face, 1.5);
        let mut messages = Vec::new();
        fn flatten(p: OscPacket, out: &mut Vec<OscMessage>) {
            match p {
                OscPacket::Message(m) => out.push(m),
                OscPacket::Bundle(b) => b.content.into_iter().for_each(|p| flatten(p, out)),
            }
        }
        for d in &datagrams {
            let (rest, p) = rosc::decoder::decode_udp(d).unwrap();
            assert!(rest.is_empty());
            flatten(p, &mut messages);
        }
        (datagrams, messages)
    }

    #[test]
    fn a_frame_has_every_bone_blendshape_ok_and_time_last() {
        let (datagrams, messages) = frame(Packing::Mtu, Content::default());
        assert!(datagrams.iter().all(|d| d.len() <= MTU_PAYLOAD && d.starts_with(b"#bundle\0")));
        assert!(datagrams.len() >= 5, "{} datagrams", datagrams.len());
        let count = |a: &str| messages.iter().filter(|m| m.addr == a).count();
        assert_eq!((count(ROOT), count(BONE), count(BLEND), count(APPLY), count(OK)), (1, 55, 52, 1, 1));
        assert_eq!(messages.last().unwrap().addr, TIME);
        assert_eq!(messages.last().unwrap().args, vec![OscType::Float(1.5)]);
        // Blend values come before Apply; names are the perfect-sync ones.
        let apply = messages.iter().position(|m| m.addr == APPLY).unwrap();
        assert!(messages.iter().rposition(|m| m.addr == BLEND).unwrap() < apply);
        assert!(messages.iter().any(|m| m.args.first() == Some(&OscType::String("EyeBlinkLeft".into()))));
        let bone = messages.iter().find(|m| m.addr == BONE).unwrap();
        assert_eq!(bone.args.len(), 8);
        assert!(bone.args[1..].iter().all(|a| matches!(a, OscType::Float(_))));
    }

    #[test]
    fn packings_and_groups() {
        let (one, all) = frame(Packing::Frame, Content::default());
        assert_eq!(one.len(), 1);
        let (each, same) = frame(Packing::Messages, Content::default());
        assert_eq!(each.len(), all.len());
        assert!(each.iter().all(|d| d.starts_with(b"/VMC/")));
        assert_eq!(all, same);
        // Head and face left to the streamer's face tracking; rotations only.
        let content = Content {
            groups: vec![Group::Torso, Group::Arms, Group::Fingers, Group::Legs],
            face: false,
            rotations_only: true,
        };
        let (_, some) = frame(Packing::Mtu, content);
        let names: Vec<&OscType> = some.iter().filter(|m| m.addr == BONE).map(|m| &m.args[0]).collect();
        assert_eq!(names.len(), 50);
        assert!(!names.contains(&&OscType::String("Head".into())));
        assert!(!some.iter().any(|m| m.addr == BLEND || m.addr == ROOT || m.addr == APPLY));
        let hips = some.iter().find(|m| m.args.first() == Some(&OscType::String("Hips".into()))).unwrap();
        assert_eq!(hips.args[1..4], [OscType::Float(0.0), OscType::Float(0.0), OscType::Float(0.0)]);
    }
}
