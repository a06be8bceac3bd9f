//! The kit file as written (serde), and its validation into [`super::Kit`].

use super::{Kit, KitError, Pedals, Piece, PieceKind, StrikeSettings, Wires, Zones};
use serde::Deserialize;
use std::path::Path;

pub const DEFAULT_KIT_TOML: &str = include_str!("../../config/kits/default.toml");

/// The kits compiled into the binary, by the name `--kit` knows them by.
pub const BUILTIN_KITS: [(&str, &str); 4] = [
    ("default", DEFAULT_KIT_TOML),
    ("rearranged", include_str!("../../config/kits/rearranged.toml")),
    ("jazz", include_str!("../../config/kits/jazz.toml")),
    ("rock", include_str!("../../config/kits/rock.toml")),
];

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawKit {
    name: String,
    pieces: Vec<RawPiece>,
    zones: RawZones,
    strike: RawStrike,
    pedals: Option<RawPedals>,
}

/// Oscillators per piece when the kit does not say: membranes, plates.
const DEFAULT_MAX_MODES: [usize; 2] = [1024, 2048];
/// `contact_radius_m` when the kit does not say: a stick's tip pressed into a head, a point on
/// a plate.
const DEFAULT_CONTACT_RADIUS_M: [f32; 2] = [0.003, 0.0];
/// `stretch` when the kit does not say: membranes, plates.
const DEFAULT_STRETCH: [f32; 2] = [1.0, 1.0];

/// Exactly three numbers: serde's arrays let a fourth through unseen.
fn three<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f32; 3], D::Error> {
    let v: Vec<f32> = Deserialize::deserialize(d)?;
    <[f32; 3]>::try_from(v.as_slice())
        .map_err(|_| serde::de::Error::custom(format!("expected 3 numbers (x, y, z), found {}", v.len())))
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPedals {
    #[serde(deserialize_with = "three")]
    kick_axle_m: [f32; 3],
    beater_length_m: f32,
    beater_rest_deg: f32,
    #[serde(deserialize_with = "three")]
    hihat_pedal_m: [f32; 3],
    hihat_travel_m: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPiece {
    id: String,
    kind: String,
    #[serde(deserialize_with = "three")]
    position_m: [f32; 3],
    #[serde(deserialize_with = "three")]
    normal: [f32; 3],
    radius_m: f32,
    fundamental_hz: f32,
    decay_s: f32,
    damping_exponent: f32,
    areal_density_kg_m2: f32,
    max_hz: f32,
    max_modes: Option<usize>,
    stretch: Option<f32>,
    chladni_exponent: Option<f32>,
    hertz_k: f32,
    hertz_alpha: f32,
    contact_radius_m: Option<f32>,
    gain_db: f32,
    wires: Option<RawWires>,
    closed_damping_factor: Option<f32>,
    choke_damping_factor: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWires {
    gap_m: f32,
    gain: f32,
    exponent: Option<f32>,
    decay_s: f32,
    center_hz: f32,
    q: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawZones {
    center: f32,
    head: f32,
    rim: f32,
    cross_stick: f32,
    bow: f32,
    edge: f32,
    bell: f32,
    pedal: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawStrike {
    speed_min_mps: f32,
    speed_max_mps: f32,
    velocity_exponent: f32,
    stick_mass_kg: f32,
    beater_mass_kg: f32,
    hihat_foot_mass_kg: f32,
}

struct Check<'a> {
    path: &'a Path,
}

impl Check<'_> {
    fn range(&self, key: &str, value: f32, lo: f32, hi: f32) -> Result<f32, KitError> {
        if value.is_finite() && value >= lo && value <= hi {
            Ok(value)
        } else {
            Err(KitError::Invalid {
                path: self.path.to_path_buf(),
                key: key.to_string(),
                message: format!("{value} is outside the allowed range {lo} ..= {hi}"),
            })
        }
    }

    fn fail(&self, key: &str, message: impl Into<String>) -> KitError {
        KitError::Invalid { path: self.path.to_path_buf(), key: key.to_string(), message: message.into() }
    }
}

/// Where a seated drummer can play, in the kit's frame (origin on the floor under the stool):
/// a piece's nearest edge at most this far from the stool, horizontally, and its centre at
/// most this high, m (an arm and a stick reach about 1 m from the shoulder).
const MAX_REACH_M: f32 = 1.4;
const MAX_HEIGHT_M: f32 = 2.2;
/// The seated body: within this radius of the stool's axis, from the seat to the top of the
/// head, no piece can be, m.
const BODY_RADIUS_M: f32 = 0.15;
const SEAT_HEIGHT_M: f32 = 0.5;
const HEAD_TOP_M: f32 = 1.4;

pub(super) fn parse(text: &str, path: &Path) -> Result<Kit, KitError> {
    let raw: RawKit =
        toml::from_str(text).map_err(|e| KitError::Parse { path: path.to_path_buf(), message: e.to_string() })?;
    let c = Check { path };
    if raw.pieces.is_empty() {
        return Err(c.fail("pieces", "the kit has no pieces"));
    }
    let mut pieces = Vec::with_capacity(raw.pieces.len());
    for (i, p) in raw.pieces.into_iter().enumerate() {
        let key = |k: &str| format!("pieces[{i}] ({}).{k}", p.id);
        if p.id.is_empty() || !p.id.chars().all(|ch| ch.is_ascii_alphanumeric() || ch == '_' || ch == '-') {
            return Err(c.fail(
                &format!("pieces[{i}].id"),
                format!("{:?} must be a non-empty word of letters, digits, _ or -", p.id),
            ));
        }
        if pieces.iter().any(|q: &Piece| q.id == p.id) {
            return Err(c.fail(&format!("pieces[{i}].id"), format!("{:?} appears twice", p.id)));
        }
        let kind = match p.kind.as_str() {
            "membrane" => PieceKind::Membrane,
            "plate" => PieceKind::Plate,
            other => return Err(c.fail(&key("kind"), format!("{other:?} is not one of \"membrane\", \"plate\""))),
        };
        for (axis, v) in p.position_m.iter().enumerate() {
            c.range(&key(&format!("position_m[{axis}]")), *v, -3.0, 3.0)?;
        }
        let [x, y, z] = p.position_m;
        let from_seat = x.hypot(y);
        if z <= 0.0 {
            return Err(c.fail(&key("position_m"), format!("is under the floor (z = {z} m; the floor is z = 0)")));
        }
        if from_seat - p.radius_m > MAX_REACH_M || z > MAX_HEIGHT_M {
            return Err(c.fail(
                &key("position_m"),
                format!(
                    "is out of the drummer's reach: its nearest edge is {:.2} m from the stool and its centre {z} m \
                     high (at most {MAX_REACH_M} m and {MAX_HEIGHT_M} m)",
                    (from_seat - p.radius_m).max(0.0)
                ),
            ));
        }
        if from_seat < BODY_RADIUS_M && z > SEAT_HEIGHT_M && z < HEAD_TOP_M {
            return Err(c.fail(
                &key("position_m"),
                format!(
                    "is inside the drummer: {from_seat:.2} m from the stool's axis at {z} m high (the body fills \
                     {BODY_RADIUS_M} m around it from {SEAT_HEIGHT_M} m to {HEAD_TOP_M} m)"
                ),
            ));
        }
        // Any finite direction, its length found in f64 (the squares of 1e30 overflow f32).
        let n = p.normal;
        let len = n.iter().map(|&x| f64::from(x) * f64::from(x)).sum::<f64>().sqrt();
        if !len.is_finite() || len < 1e-3 {
            return Err(c.fail(&key("normal"), format!("{n:?} is not a direction: it must be finite and not zero")));
        }
        let n = n.map(|x| (f64::from(x) / len) as f32);
        let fundamental_hz = c.range(&key("fundamental_hz"), p.fundamental_hz, 20.0, 5000.0)?;
        let max_hz = c.range(&key("max_hz"), p.max_hz, fundamental_hz, 22_000.0)?;
        let wires = match p.wires {
            None => None,
            Some(w) => Some(Wires {
                gap_m: c.range(&key("wires.gap_m"), w.gap_m, 0.0, 0.01)?,
                gain: c.range(&key("wires.gain"), w.gain, 0.0, 1e6)?,
                exponent: c.range(&key("wires.exponent"), w.exponent.unwrap_or(1.0), 0.5, 4.0)?,
                decay_s: c.range(&key("wires.decay_s"), w.decay_s, 0.005, 5.0)?,
                center_hz: c.range(&key("wires.center_hz"), w.center_hz, 200.0, 16_000.0)?,
                q: c.range(&key("wires.q"), w.q, 0.1, 20.0)?,
            }),
        };
        if wires.is_some() && kind != PieceKind::Membrane {
            return Err(c.fail(&key("wires"), "only a membrane can have snare wires"));
        }
        pieces.push(Piece {
            kind,
            position_m: p.position_m,
            normal: n,
            radius_m: c.range(&key("radius_m"), p.radius_m, 0.01, 0.6)?,
            fundamental_hz,
            decay_s: c.range(&key("decay_s"), p.decay_s, 0.01, 60.0)?,
            damping_exponent: c.range(&key("damping_exponent"), p.damping_exponent, 0.0, 3.0)?,
            areal_density_kg_m2: c.range(&key("areal_density_kg_m2"), p.areal_density_kg_m2, 0.01, 100.0)?,
            max_hz,
            // A membrane's modes up to max_hz: the lowest 320 one by one, a thinned band above.
            max_modes: c.range(
                &key("max_modes"),
                p.max_modes.unwrap_or(DEFAULT_MAX_MODES[kind as usize]) as f32,
                1.0,
                8192.0,
            )? as usize,
            // Heads stretch as polyester film does, plates as bronze does (their in-plane stress).
            stretch: c.range(&key("stretch"), p.stretch.unwrap_or(DEFAULT_STRETCH[kind as usize]), 0.0, 1000.0)?,
            chladni_exponent: c.range(&key("chladni_exponent"), p.chladni_exponent.unwrap_or(1.4), 1.0, 2.5)?,
            hertz_k: c.range(&key("hertz_k"), p.hertz_k, 1e4, 1e12)?,
            hertz_alpha: c.range(&key("hertz_alpha"), p.hertz_alpha, 1.0, 4.0)?,
            contact_radius_m: c.range(
                &key("contact_radius_m"),
                p.contact_radius_m.unwrap_or(DEFAULT_CONTACT_RADIUS_M[kind as usize]),
                0.0,
                0.05,
            )?,
            gain_db: c.range(&key("gain_db"), p.gain_db, -60.0, 24.0)?,
            wires,
            closed_damping_factor: match p.closed_damping_factor {
                Some(f) => Some(c.range(&key("closed_damping_factor"), f, 1.0, 1000.0)?),
                None => None,
            },
            choke_damping_factor: c.range(
                &key("choke_damping_factor"),
                p.choke_damping_factor.unwrap_or(100.0),
                1.0,
                10_000.0,
            )?,
            id: p.id,
        });
    }
    let z = raw.zones;
    let zones = Zones {
        center: c.range("zones.center", z.center, 0.0, 1.0)?,
        head: c.range("zones.head", z.head, 0.0, 1.0)?,
        rim: c.range("zones.rim", z.rim, 0.0, 1.0)?,
        cross_stick: c.range("zones.cross_stick", z.cross_stick, 0.0, 1.0)?,
        bow: c.range("zones.bow", z.bow, 0.0, 1.0)?,
        edge: c.range("zones.edge", z.edge, 0.0, 1.0)?,
        bell: c.range("zones.bell", z.bell, 0.0, 1.0)?,
        pedal: c.range("zones.pedal", z.pedal, 0.0, 1.0)?,
    };
    let s = raw.strike;
    let speed_min_mps = c.range("strike.speed_min_mps", s.speed_min_mps, 0.01, 30.0)?;
    let strike = StrikeSettings {
        speed_min_mps,
        speed_max_mps: c.range("strike.speed_max_mps", s.speed_max_mps, speed_min_mps, 30.0)?,
        velocity_exponent: c.range("strike.velocity_exponent", s.velocity_exponent, 0.2, 5.0)?,
        stick_mass_kg: c.range("strike.stick_mass_kg", s.stick_mass_kg, 0.001, 1.0)?,
        beater_mass_kg: c.range("strike.beater_mass_kg", s.beater_mass_kg, 0.001, 2.0)?,
        hihat_foot_mass_kg: c.range("strike.hihat_foot_mass_kg", s.hihat_foot_mass_kg, 0.001, 5.0)?,
    };
    let pedals = match raw.pedals {
        None => None,
        Some(p) => {
            let inside = |key: &str, v: [f32; 3]| -> Result<[f32; 3], KitError> {
                for (i, x) in v.iter().enumerate() {
                    c.range(&format!("{key}[{i}]"), *x, -3.0, 3.0)?;
                }
                Ok(v)
            };
            Some(Pedals {
                kick_axle_m: inside("pedals.kick_axle_m", p.kick_axle_m)?,
                beater_length_m: c.range("pedals.beater_length_m", p.beater_length_m, 0.05, 0.5)?,
                beater_rest_deg: c.range("pedals.beater_rest_deg", p.beater_rest_deg, 5.0, 80.0)?,
                hihat_pedal_m: inside("pedals.hihat_pedal_m", p.hihat_pedal_m)?,
                hihat_travel_m: c.range("pedals.hihat_travel_m", p.hihat_travel_m, 0.002, 0.05)?,
            })
        }
    };
    Ok(Kit { name: raw.name, pieces, zones, strike, pedals })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_kit_is_valid_and_has_the_named_pieces() {
        let kit = Kit::builtin_default();
        for id in ["kick", "snare", "tom1", "tom2", "floor_tom", "hihat", "crash", "ride"] {
            assert!(kit.piece(id).is_some(), "missing {id}");
        }
        assert!(kit.piece("snare").unwrap().wires.is_some());
        assert!(kit.piece("hihat").unwrap().closed_damping_factor.is_some());
    }

    #[test]
    fn every_builtin_kit_loads_by_name_and_equals_its_file() {
        for (name, _) in BUILTIN_KITS {
            let by_name = Kit::load(Path::new(name)).unwrap();
            let file = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("config/kits/{name}.toml"));
            assert_eq!(by_name.name, Kit::load(&file).unwrap().name, "{name}");
        }
        let e = Kit::load(Path::new("no-such-kit")).unwrap_err().to_string();
        assert!(e.contains("no-such-kit") && e.contains("built-in kits: default, rearranged, jazz, rock"), "{e}");
    }

    #[test]
    fn out_of_range_value_names_file_and_key() {
        let text = DEFAULT_KIT_TOML.replacen("radius_m = 0.178", "radius_m = 7.0", 1);
        let err = Kit::from_toml_str(&text, Path::new("my.toml")).unwrap_err().to_string();
        assert!(
            err.contains("my.toml") && err.contains("pieces[1] (snare).radius_m") && err.contains("0.01 ..= 0.6"),
            "{err}"
        );
    }

    #[test]
    fn broken_toml_names_the_file() {
        let err = Kit::from_toml_str("name = [", Path::new("broken.toml")).unwrap_err().to_string();
        assert!(err.contains("broken.toml"), "{err}");
    }

    #[test]
    fn faster_velocity_is_faster_strike() {
        let s = Kit::builtin_default().strike;
        assert!(s.speed_for_velocity(127) > s.speed_for_velocity(64));
        assert!((s.speed_for_velocity(127) - s.speed_max_mps).abs() < 1e-5);
    }
}
