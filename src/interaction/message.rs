//! `/drumsim/contact`, `/drumsim/hihat` and `/drumsim/choke`, encoded and decoded with rosc.
//! Encoding reuses a caller's buffer; decoding allocates, so it stays off the audio thread.

use rosc::{OscBundle, OscMessage, OscPacket, OscTime, OscType};
use serde::{Deserialize, Serialize};

pub const CONTACT_ADDR: &str = "/drumsim/contact";
pub const HIHAT_ADDR: &str = "/drumsim/hihat";
pub const CHOKE_ADDR: &str = "/drumsim/choke";

/// Which limb made a contact (the `limb` argument of the contact message).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Limb {
    LeftHand = 0,
    RightHand = 1,
    RightFoot = 2,
    LeftFoot = 3,
}

impl Limb {
    pub fn from_index(i: i32) -> Option<Limb> {
        match i {
            0 => Some(Limb::LeftHand),
            1 => Some(Limb::RightHand),
            2 => Some(Limb::RightFoot),
            3 => Some(Limb::LeftFoot),
            _ => None,
        }
    }
}

/// A stick tip or beater meeting a surface.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ContactMessage {
    pub piece: String,
    pub time_s: f32,
    /// Normal speed of the striker into the surface, m/s (positive).
    pub speed_mps: f32,
    /// Effective striking mass, kg.
    pub mass_kg: f32,
    /// Strike point on the surface, metres from its centre.
    pub x_m: f32,
    pub y_m: f32,
    /// Normal impulse measured by the physics, N s (0 in direct mode).
    pub impulse_ns: f32,
    /// Tip stiffness scale: wood tip 1.0, softer below.
    pub hardness: f32,
    #[serde(serialize_with = "limb_index", deserialize_with = "limb_from_index")]
    pub limb: Limb,
}

fn limb_index<S: serde::Serializer>(limb: &Limb, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_i32(*limb as i32)
}

fn limb_from_index<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Limb, D::Error> {
    let i = i32::deserialize(d)?;
    Limb::from_index(i).ok_or_else(|| serde::de::Error::custom(format!("limb {i} is not 0..=3")))
}

#[derive(Debug, Clone, PartialEq)]
pub enum Message {
    Contact(ContactMessage),
    /// Hi-hat openness, 0 closed .. 1 open.
    HiHat {
        time_s: f32,
        openness: f32,
    },
    /// A hand grabs a cymbal.
    Choke {
        piece: String,
        time_s: f32,
    },
}

impl Message {
    pub fn time_s(&self) -> f32 {
        match self {
            Message::Contact(c) => c.time_s,
            Message::HiHat { time_s, .. } | Message::Choke { time_s, .. } => *time_s,
        }
    }
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum MessageError {
    #[error("OSC packet does not decode: {0}")]
    Decode(String),
    #[error("OSC message {addr} has arguments {found}, expected {expected}")]
    Arguments { addr: String, found: String, expected: &'static str },
    #[error("OSC address {0} is not a drumsim message")]
    UnknownAddress(String),
    #[error("OSC encoding failed: {0}")]
    Encode(String),
}

fn to_osc(msg: &Message) -> OscMessage {
    match msg {
        Message::Contact(c) => OscMessage {
            addr: CONTACT_ADDR.to_string(),
            args: vec![
                OscType::String(c.piece.clone()),
                OscType::Float(c.time_s),
                OscType::Float(c.speed_mps),
                OscType::Float(c.mass_kg),
                OscType::Float(c.x_m),
                OscType::Float(c.y_m),
                OscType::Float(c.impulse_ns),
                OscType::Float(c.hardness),
                OscType::Int(c.limb as i32),
            ],
        },
        Message::HiHat { time_s, openness } => {
            OscMessage { addr: HIHAT_ADDR.to_string(), args: vec![OscType::Float(*time_s), OscType::Float(*openness)] }
        }
        Message::Choke { piece, time_s } => OscMessage {
            addr: CHOKE_ADDR.to_string(),
            args: vec![OscType::String(piece.clone()), OscType::Float(*time_s)],
        },
    }
}

/// Encode one message into `buf` (cleared first), ready for a channel or a UDP socket.
pub fn encode(msg: &Message, buf: &mut Vec<u8>) -> Result<(), MessageError> {
    buf.clear();
    rosc::encoder::encode_into(&OscPacket::Message(to_osc(msg)), buf)
        .map(|_| ())
        .map_err(|e| MessageError::Encode(e.to_string()))
}

/// Encode several messages as one OSC bundle with a time tag (for a sender that runs ahead).
pub fn encode_bundle(msgs: &[Message], time: OscTime, buf: &mut Vec<u8>) -> Result<(), MessageError> {
    buf.clear();
    let bundle = OscBundle { timetag: time, content: msgs.iter().map(|m| OscPacket::Message(to_osc(m))).collect() };
    rosc::encoder::encode_into(&OscPacket::Bundle(bundle), buf)
        .map(|_| ())
        .map_err(|e| MessageError::Encode(e.to_string()))
}

/// Decode a packet (a message or a bundle, nested bundles flattened) into messages.
pub fn decode(bytes: &[u8]) -> Result<Vec<Message>, MessageError> {
    Ok(decode_timed(bytes)?.into_iter().map(|(_, m)| m).collect())
}

/// Bundles nest at most this deep (the OSC decoder recurses into each level; a datagram of
/// nothing but nested bundle headers would nest 3,000 deep).
pub const MAX_BUNDLE_DEPTH: usize = 8;

/// [`decode`], each message with the time tag of the bundle it came in (the innermost), or
/// None for a bare message or a bundle tagged "immediately".
pub fn decode_timed(bytes: &[u8]) -> Result<Vec<(Option<OscTime>, Message)>, MessageError> {
    if !nesting_within(bytes, MAX_BUNDLE_DEPTH) {
        return Err(MessageError::Decode(format!("bundles nested deeper than {MAX_BUNDLE_DEPTH}")));
    }
    let (rest, packet) = rosc::decoder::decode_udp(bytes).map_err(|e| MessageError::Decode(e.to_string()))?;
    if !rest.is_empty() {
        // A bundle's elements end at the first that does not decode: a truncated datagram.
        return Err(MessageError::Decode(format!("{} bytes after the packet do not decode (truncated?)", rest.len())));
    }
    let mut out = Vec::new();
    flatten(packet, None, &mut out)?;
    Ok(out)
}

const BUNDLE_TAG: &[u8] = b"#bundle\0";

/// True when the bundles in `bytes` nest no deeper than `depth` (a walk over the element
/// sizes, before the decoder recurses; malformed sizes are left for the decoder to refuse).
fn nesting_within(bytes: &[u8], depth: usize) -> bool {
    if !bytes.starts_with(BUNDLE_TAG) {
        return true;
    }
    if depth == 0 {
        return false;
    }
    let mut rest = bytes.get(16..).unwrap_or_default();
    while let Some(size) = rest.get(..4).map(|b| u32::from_be_bytes([b[0], b[1], b[2], b[3]]) as usize) {
        let Some(element) = rest.get(4..4 + size) else { return true };
        if !nesting_within(element, depth - 1) {
            return false;
        }
        rest = &rest[4 + size..];
    }
    true
}

fn flatten(
    packet: OscPacket,
    time: Option<OscTime>,
    out: &mut Vec<(Option<OscTime>, Message)>,
) -> Result<(), MessageError> {
    match packet {
        OscPacket::Message(m) => out.push((time, from_osc(m)?)),
        OscPacket::Bundle(b) => {
            let immediately = OscTime { seconds: 0, fractional: 1 };
            let time = if b.timetag == immediately { time } else { Some(b.timetag) };
            for p in b.content {
                flatten(p, time, out)?;
            }
        }
    }
    Ok(())
}

fn from_osc(m: OscMessage) -> Result<Message, MessageError> {
    use OscType::{Float as F, Int as I, String as S};
    let bad = |expected| MessageError::Arguments { addr: m.addr.clone(), found: format!("{:?}", m.args), expected };
    match m.addr.as_str() {
        CONTACT_ADDR => match m.args.as_slice() {
            [S(piece), F(t), F(v), F(mass), F(x), F(y), F(imp), F(h), I(limb)] => {
                let limb = Limb::from_index(*limb).ok_or_else(|| bad("limb 0..=3"))?;
                if ![t, v, mass, x, y, imp, h].iter().all(|f| f.is_finite()) {
                    return Err(bad("finite numbers"));
                }
                Ok(Message::Contact(ContactMessage {
                    piece: piece.clone(),
                    time_s: *t,
                    speed_mps: *v,
                    mass_kg: *mass,
                    x_m: *x,
                    y_m: *y,
                    impulse_ns: *imp,
                    hardness: *h,
                    limb,
                }))
            }
            _ => Err(bad(",sfffffffi")),
        },
        HIHAT_ADDR => match m.args.as_slice() {
            [F(t), F(o)] if t.is_finite() && o.is_finite() => Ok(Message::HiHat { time_s: *t, openness: *o }),
            [F(_), F(_)] => Err(bad("finite numbers")),
            _ => Err(bad(",ff")),
        },
        CHOKE_ADDR => match m.args.as_slice() {
            [S(piece), F(t)] if t.is_finite() => Ok(Message::Choke { piece: piece.clone(), time_s: *t }),
            [S(_), F(_)] => Err(bad("finite numbers")),
            _ => Err(bad(",sf")),
        },
        other => Err(MessageError::UnknownAddress(other.to_string())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn contact() -> Message {
        Message::Contact(ContactMessage {
            piece: "snare".into(),
            time_s: 1.25,
            speed_mps: 4.5,
            mass_kg: 0.03,
            x_m: 0.05,
            y_m: -0.02,
            impulse_ns: 0.0,
            hardness: 1.0,
            limb: Limb::LeftHand,
        })
    }

    #[test]
    fn contact_round_trips_through_osc_bytes() {
        let mut buf = Vec::new();
        encode(&contact(), &mut buf).unwrap();
        assert!(buf.starts_with(b"/drumsim/contact\0"));
        assert_eq!(decode(&buf).unwrap(), vec![contact()]);
    }

    #[test]
    fn bundle_flattens_in_order() {
        let msgs = vec![
            contact(),
            Message::HiHat { time_s: 1.0, openness: 0.25 },
            Message::Choke { piece: "crash".into(), time_s: 2.0 },
        ];
        let mut buf = Vec::new();
        encode_bundle(&msgs, OscTime { seconds: 0, fractional: 1 }, &mut buf).unwrap();
        assert_eq!(decode(&buf).unwrap(), msgs);
    }

    #[test]
    fn wrong_arguments_are_named() {
        let pkt = OscPacket::Message(OscMessage { addr: HIHAT_ADDR.into(), args: vec![OscType::Int(3)] });
        let bytes = rosc::encoder::encode(&pkt).unwrap();
        let err = decode(&bytes).unwrap_err().to_string();
        assert!(err.contains("/drumsim/hihat") && err.contains(",ff"), "{err}");
    }

    #[test]
    fn timed_decode_gives_each_message_its_bundles_time_tag() {
        let at = OscTime { seconds: 3_900_000_000, fractional: 1 << 31 };
        let mut buf = Vec::new();
        encode_bundle(&[contact()], at, &mut buf).unwrap();
        assert_eq!(decode_timed(&buf).unwrap(), vec![(Some(at), contact())]);
        encode(&contact(), &mut buf).unwrap();
        assert_eq!(decode_timed(&buf).unwrap(), vec![(None, contact())], "a bare message has no time");
        encode_bundle(&[contact()], OscTime { seconds: 0, fractional: 1 }, &mut buf).unwrap();
        assert_eq!(decode_timed(&buf).unwrap()[0].0, None, "'immediately' is no time");
    }

    #[test]
    fn numbers_that_are_not_finite_are_refused_naming_the_message() {
        let Message::Contact(mut c) = contact() else { unreachable!() };
        c.speed_mps = f32::NAN;
        let mut buf = Vec::new();
        encode(&Message::Contact(c), &mut buf).unwrap();
        let err = decode(&buf).unwrap_err().to_string();
        assert!(err.contains("/drumsim/contact") && err.contains("finite"), "{err}");
        encode(&Message::HiHat { time_s: f32::INFINITY, openness: 0.5 }, &mut buf).unwrap();
        assert!(decode(&buf).unwrap_err().to_string().contains("finite"));
    }

    #[test]
    fn bundles_nested_past_the_limit_are_refused_before_the_decoder_recurses() {
        let nest = |depth: usize| {
            let mut buf = Vec::new();
            encode(&contact(), &mut buf).unwrap();
            for _ in 0..depth {
                let mut outer = BUNDLE_TAG.to_vec();
                outer.extend_from_slice(&[0, 0, 0, 0, 0, 0, 0, 1]);
                outer.extend_from_slice(&(buf.len() as u32).to_be_bytes());
                outer.extend_from_slice(&buf);
                buf = outer;
            }
            buf
        };
        assert_eq!(decode(&nest(MAX_BUNDLE_DEPTH)).unwrap(), vec![contact()]);
        let err = decode(&nest(MAX_BUNDLE_DEPTH + 1)).unwrap_err().to_string();
        assert!(err.contains("nested deeper"), "{err}");
        // A whole datagram of bundle headers, as a hostile sender would send.
        let err = decode(&nest(3000)).unwrap_err().to_string();
        assert!(err.contains("nested deeper"), "{err}");
    }
}
