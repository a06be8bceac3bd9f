//! The kit: where each piece is (for the body) and how it sounds (for the synthesizer).
//! Raw TOML (serde) is validated once into [`Kit`]; errors name the file, the key and the range.

pub(crate) mod geometry;
mod raw;

use std::path::{Path, PathBuf};

pub use geometry::{
    strike_miss, strike_point, strike_point_uv, surface_basis, toward_drummer, toward_drummer_angle, StrikeMiss,
};
pub use raw::{BUILTIN_KITS, DEFAULT_KIT_TOML};

/// How a piece vibrates.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PieceKind {
    /// Ideal circular membrane, fixed edge: modes at the zeros of J_m.
    Membrane,
    /// Circular plate with a free edge: dense inharmonic modes (Chladni's law).
    Plate,
}

/// Snare wires: collision noise driven by the head's excursion.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Wires {
    pub gap_m: f32,
    pub gain: f32,
    /// The rattle grows as the excursion past the gap to this power (1 mm: the same for
    /// any power): above 1, a ghost note is mostly head and a hard hit mostly wires.
    pub exponent: f32,
    pub decay_s: f32,
    pub center_hz: f32,
    pub q: f32,
}

/// One validated kit piece.
#[derive(Debug, Clone, PartialEq)]
pub struct Piece {
    pub id: String,
    pub kind: PieceKind,
    pub position_m: [f32; 3],
    /// Unit outward normal of the playing surface.
    pub normal: [f32; 3],
    pub radius_m: f32,
    /// Frequency of the lowest mode.
    pub fundamental_hz: f32,
    /// T60 of the lowest mode, seconds.
    pub decay_s: f32,
    /// Decay rate of mode k scales as (f_k / f_0)^damping_exponent.
    pub damping_exponent: f32,
    pub areal_density_kg_m2: f32,
    pub max_hz: f32,
    pub max_modes: usize,
    /// How much the surface stiffens as it stretches under large motion, as a multiple of
    /// its material's: polyester film for a membrane (Berger's approximation: its tension),
    /// B20 bronze for a plate (the von Karman in-plane stress: the wash) (1.0); 0 is linear
    /// (an ideal membrane, a gong-like plate).
    pub stretch: f32,
    /// Plates: f ~ (m + 2n)^chladni_exponent.
    pub chladni_exponent: f32,
    /// Hertz contact F = k c^alpha for hardness 1.0.
    pub hertz_k: f32,
    pub hertz_alpha: f32,
    /// Radius of the patch a strike presses on a head (a stick's tip, a beater's face), m:
    /// each mode is driven by its shape's mean over that disc, 2 J1(k b) / (k b) of its value
    /// at the point (exact for a membrane's modes), so modes shorter than the patch are
    /// hardly struck. Membranes; 0 on plates (a point).
    pub contact_radius_m: f32,
    pub gain_db: f32,
    pub wires: Option<Wires>,
    /// Hi-hat: how much faster every mode decays when fully closed (None: not a hi-hat).
    pub closed_damping_factor: Option<f32>,
    /// How much faster modes decay while a hand holds the cymbal.
    pub choke_damping_factor: f32,
}

/// Zone radii as fractions of a piece's radius.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Zones {
    pub center: f32,
    pub head: f32,
    pub rim: f32,
    pub cross_stick: f32,
    pub bow: f32,
    pub edge: f32,
    pub bell: f32,
    pub pedal: f32,
}

/// A hi-hat pedal note closes the hi-hat at this share of the stroke speed the kit's speed
/// map gives its velocity: a foot is slower than a stick (direct mode and the simulated
/// pedal alike; `drumsim eval` divides it out again to compare a chick's speed with the
/// others').
pub const CHICK_SPEED_SCALE: f32 = 0.4;

/// How MIDI velocity becomes striking speed, and the striking masses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StrikeSettings {
    pub speed_min_mps: f32,
    pub speed_max_mps: f32,
    pub velocity_exponent: f32,
    pub stick_mass_kg: f32,
    pub beater_mass_kg: f32,
    pub hihat_foot_mass_kg: f32,
}

impl StrikeSettings {
    /// Striking speed for a MIDI velocity 1..=127.
    pub fn speed_for_velocity(&self, velocity: u8) -> f32 {
        let v = (velocity.clamp(1, 127) as f32) / 127.0;
        self.speed_min_mps + (self.speed_max_mps - self.speed_min_mps) * v.powf(self.velocity_exponent)
    }

    /// The MIDI velocity (1..=127, fractional) whose striking speed is `speed_mps`: the
    /// inverse of [`Self::speed_for_velocity`], clamped to its range.
    pub fn velocity_for_speed(&self, speed_mps: f32) -> f32 {
        let span = (self.speed_max_mps - self.speed_min_mps).max(1e-6);
        let x = ((speed_mps - self.speed_min_mps) / span).clamp(0.0, 1.0);
        (127.0 * x.powf(1.0 / self.velocity_exponent.max(1e-3))).clamp(1.0, 127.0)
    }
}

/// Where the pedals are (the `[pedals]` table of a kit file).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pedals {
    /// The kick pedal's beater axle, kit frame, m (below the kick head, in front of it).
    pub kick_axle_m: [f32; 3],
    /// From the axle to the beater ball's centre, m.
    pub beater_length_m: f32,
    /// The beater's rest angle back from the head, degrees.
    pub beater_rest_deg: f32,
    /// The hi-hat pedal's heel, kit frame, m (where the left foot sits).
    pub hihat_pedal_m: [f32; 3],
    /// Travel of the top hi-hat cymbal from closed to fully open, m.
    pub hihat_travel_m: f32,
}

/// A validated kit.
#[derive(Debug, Clone, PartialEq)]
pub struct Kit {
    pub name: String,
    pub pieces: Vec<Piece>,
    pub zones: Zones,
    pub strike: StrikeSettings,
    /// The pedals; `None` when the kit file has no `[pedals]` table (the feet then play no
    /// pedal: kick and hi-hat pedal notes are counted as unplayed in physical renders).
    pub pedals: Option<Pedals>,
}

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum KitError {
    #[error("kit config {path}: cannot read: {source} (built-in kits: default, rearranged, jazz, rock)")]
    Read { path: PathBuf, source: std::io::Error },
    #[error("kit config {path}: {message}")]
    Parse { path: PathBuf, message: String },
    #[error("kit config {path}: {key}: {message}")]
    Invalid { path: PathBuf, key: String, message: String },
}

impl Kit {
    /// The built-in default kit (config/kits/default.toml, compiled in).
    pub fn builtin_default() -> Kit {
        Kit::from_toml_str(DEFAULT_KIT_TOML, Path::new("config/kits/default.toml"))
            .expect("the built-in kit config is valid (tested)")
    }

    /// A built-in kit by name ("default", "rearranged"; `config/kits/NAME.toml`, compiled in).
    pub fn builtin(name: &str) -> Option<Kit> {
        let (_, text) = BUILTIN_KITS.iter().find(|(n, _)| *n == name)?;
        let path = format!("config/kits/{name}.toml");
        Some(Kit::from_toml_str(text, Path::new(&path)).expect("the built-in kit configs are valid (tested)"))
    }

    /// A built-in kit's name, else a kit file to load and validate (a built-in name wins:
    /// write `./default` for a file named default).
    pub fn load(path: &Path) -> Result<Kit, KitError> {
        if let Some(kit) = path.to_str().and_then(Kit::builtin) {
            return Ok(kit);
        }
        let text = crate::files::read_to_string_bounded(path, crate::files::MAX_CONFIG_BYTES)
            .map_err(|source| KitError::Read { path: path.to_path_buf(), source })?;
        Kit::from_toml_str(&text, path)
    }

    /// Parse and validate kit TOML; `path` is only used in error messages.
    pub fn from_toml_str(text: &str, path: &Path) -> Result<Kit, KitError> {
        raw::parse(text, path)
    }

    /// Index of the piece with this id.
    pub fn index_of(&self, id: &str) -> Option<usize> {
        self.pieces.iter().position(|p| p.id == id)
    }

    pub fn piece(&self, id: &str) -> Option<&Piece> {
        self.pieces.iter().find(|p| p.id == id)
    }
}
