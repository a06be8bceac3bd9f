//! Segment masses, lengths and inertias of the drummer from its body mass and height.
//!
//! Mass fractions are those of DESIGN.md 1b (per cent of body mass; paired segments share
//! their fraction equally between the two sides): head 4, neck 4, trunk 46, upper arms 4,
//! forearms 2, hands 1, pelvis 18, upper legs 14, lower legs 5, feet 1.5 (sum 99.5). Each
//! stick adds 0.5 % of body mass on top. The shoulder girdle (clavicle and scapula) is not
//! listed; it takes 1 % of body mass per side out of the trunk's 46 %.
//!
//! Segment lengths are fractions of standing height from Winter, *Biomechanics and Motor
//! Control of Human Movement* (4th ed., 2009), fig. 4.1: upper arm 0.186 H, forearm
//! 0.146 H, hand 0.108 H, thigh 0.245 H, shank 0.246 H, foot 0.152 H, shoulder width
//! 0.259 H, hip (greater trochanter) height 0.530 H, shoulder height 0.818 H, chin height
//! 0.870 H. Pelvis, trunk, neck and head split the span 0.530 H .. 1.0 H at those marks.
//! Centre-of-mass positions along each segment (fraction from the proximal end) are Winter's
//! table 4.1 (Dempster's data). Every segment is a solid capsule for its inertia.

/// Body mass and height, validated.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BodySettings {
    /// Total body mass, kg (30..=200).
    pub mass_kg: f32,
    /// Standing height, m (1.2..=2.2).
    pub height_m: f32,
    /// Drumstick length, m (0.3..=0.5).
    pub stick_length_m: f32,
}

impl Default for BodySettings {
    fn default() -> Self {
        BodySettings { mass_kg: 75.0, height_m: 1.75, stick_length_m: 0.40 }
    }
}

/// Bad body settings; the message names the key and the allowed range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum BodyError {
    #[error("body settings: {key} = {value} is outside {min}..={max} {unit}")]
    OutOfRange { key: &'static str, value: f32, min: f32, max: f32, unit: &'static str },
}

impl BodySettings {
    /// Check every field; NaN and infinities are out of range.
    pub fn validate(self) -> Result<BodySettings, BodyError> {
        check("mass_kg", self.mass_kg, 30.0, 200.0, "kg")?;
        check("height_m", self.height_m, 1.2, 2.2, "m")?;
        check("stick_length_m", self.stick_length_m, 0.3, 0.5, "m")?;
        Ok(self)
    }
}

fn check(key: &'static str, value: f32, min: f32, max: f32, unit: &'static str) -> Result<(), BodyError> {
    // `contains` is false for NaN.
    if (min..=max).contains(&value) {
        Ok(())
    } else {
        Err(BodyError::OutOfRange { key, value, min, max, unit })
    }
}

/// The segments of the figure. Paired segments are listed once per side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Segment {
    Pelvis,
    Trunk,
    Neck,
    Head,
    Clavicle,
    UpperArm,
    Forearm,
    Hand,
    Stick,
    UpperLeg,
    LowerLeg,
    Foot,
}

impl Segment {
    pub const ALL: [Segment; 12] = [
        Segment::Pelvis,
        Segment::Trunk,
        Segment::Neck,
        Segment::Head,
        Segment::Clavicle,
        Segment::UpperArm,
        Segment::Forearm,
        Segment::Hand,
        Segment::Stick,
        Segment::UpperLeg,
        Segment::LowerLeg,
        Segment::Foot,
    ];

    /// Fraction of body mass of ONE such segment (one side for paired segments).
    pub fn mass_fraction(self) -> f32 {
        match self {
            Segment::Pelvis => 0.18,
            Segment::Trunk => 0.46 - 2.0 * 0.01,
            Segment::Neck => 0.04,
            Segment::Head => 0.04,
            Segment::Clavicle => 0.01,
            Segment::UpperArm => 0.04 / 2.0,
            Segment::Forearm => 0.02 / 2.0,
            Segment::Hand => 0.01 / 2.0,
            Segment::Stick => 0.005,
            Segment::UpperLeg => 0.14 / 2.0,
            Segment::LowerLeg => 0.05 / 2.0,
            Segment::Foot => 0.015 / 2.0,
        }
    }

    /// True for segments that come in a left and a right copy.
    pub fn paired(self) -> bool {
        !matches!(self, Segment::Pelvis | Segment::Trunk | Segment::Neck | Segment::Head)
    }

    /// Length as a fraction of height (the stick's length is a setting, not a fraction).
    fn length_fraction(self) -> f32 {
        match self {
            Segment::Pelvis => 0.100,
            Segment::Trunk => 0.818 - 0.630,
            Segment::Neck => 0.870 - 0.818,
            Segment::Head => 1.0 - 0.870,
            Segment::Clavicle => 0.259 / 2.0 - 0.02,
            Segment::UpperArm => 0.186,
            Segment::Forearm => 0.146,
            Segment::Hand => 0.108,
            Segment::Stick => 0.0,
            Segment::UpperLeg => 0.245,
            Segment::LowerLeg => 0.246,
            Segment::Foot => 0.152,
        }
    }

    /// Capsule radius as a fraction of length (round segment of plausible girth).
    fn radius_ratio(self) -> f32 {
        match self {
            Segment::Pelvis => 0.8,
            Segment::Trunk => 0.5,
            Segment::Neck => 0.6,
            Segment::Head => 0.45,
            Segment::Clavicle => 0.12,
            Segment::UpperArm | Segment::Forearm => 0.15,
            Segment::Hand => 0.2,
            Segment::Stick => 0.0175,
            Segment::UpperLeg | Segment::LowerLeg => 0.15,
            Segment::Foot => 0.2,
        }
    }

    /// Centre of mass, fraction of length from the proximal end (Winter table 4.1).
    pub fn com_fraction(self) -> f32 {
        match self {
            Segment::Pelvis => 0.5,
            Segment::Trunk => 0.5,
            Segment::Neck => 0.5,
            Segment::Head => 0.5,
            Segment::Clavicle => 0.5,
            Segment::UpperArm => 0.436,
            Segment::Forearm => 0.430,
            Segment::Hand => 0.506,
            Segment::Stick => 0.5,
            Segment::UpperLeg => 0.433,
            Segment::LowerLeg => 0.433,
            Segment::Foot => 0.5,
        }
    }
}

/// Mass, size and inertia of one segment, a solid capsule along its own axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SegmentProps {
    pub mass_kg: f32,
    /// Proximal-to-distal length, m.
    pub length_m: f32,
    pub radius_m: f32,
    /// Moment of inertia about the long axis through the centre of mass, kg m^2.
    pub axial_inertia: f32,
    /// Moment of inertia about a transverse axis through the centre of mass, kg m^2.
    pub transverse_inertia: f32,
}

impl SegmentProps {
    /// Principal moments (transverse, axial, transverse) for a capsule along local y.
    pub fn principal_inertia_y(&self) -> [f32; 3] {
        [self.transverse_inertia, self.axial_inertia, self.transverse_inertia]
    }
}

/// Per-segment properties for one body.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Anthropometry {
    pub settings: BodySettings,
}

impl Anthropometry {
    pub fn new(settings: BodySettings) -> Result<Anthropometry, BodyError> {
        Ok(Anthropometry { settings: settings.validate()? })
    }

    pub fn length_m(&self, seg: Segment) -> f32 {
        match seg {
            Segment::Stick => self.settings.stick_length_m,
            _ => seg.length_fraction() * self.settings.height_m,
        }
    }

    pub fn segment(&self, seg: Segment) -> SegmentProps {
        let mass = seg.mass_fraction() * self.settings.mass_kg;
        let length = self.length_m(seg);
        let radius = seg.radius_ratio() * length;
        let (axial, transverse) = capsule_inertia(mass, length, radius);
        SegmentProps {
            mass_kg: mass,
            length_m: length,
            radius_m: radius,
            axial_inertia: axial,
            transverse_inertia: transverse,
        }
    }
}

/// Inertia (axial, transverse through the centre) of a solid capsule of total `length`
/// (tip to tip) and `radius`, with uniform density, scaled to `mass`.
fn capsule_inertia(mass: f32, length: f32, radius: f32) -> (f32, f32) {
    let r = radius.min(0.5 * length);
    let h = (length - 2.0 * r).max(0.0); // cylinder part
    let v_cyl = std::f32::consts::PI * r * r * h;
    let v_sph = 4.0 / 3.0 * std::f32::consts::PI * r * r * r;
    let rho = mass / (v_cyl + v_sph);
    let (mc, ms) = (rho * v_cyl, rho * v_sph);
    let axial = mc * r * r / 2.0 + ms * 2.0 * r * r / 5.0;
    // Cylinder about its centre; two hemispheres moved out by h/2 (parallel axis on their
    // own centre of mass, 3r/8 from the flat face).
    let cyl_t = mc * (r * r / 4.0 + h * h / 12.0);
    let d = h / 2.0 + 3.0 * r / 8.0;
    let hemi_own = ms * (2.0 * r * r / 5.0) - ms * (3.0 * r / 8.0).powi(2);
    let sph_t = hemi_own + ms * d * d;
    (axial, cyl_t + sph_t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn body_fractions_are_those_of_the_design_and_sticks_add_one_percent() {
        let body: f32 = Segment::ALL
            .iter()
            .filter(|s| **s != Segment::Stick)
            .map(|s| s.mass_fraction() * if s.paired() { 2.0 } else { 1.0 })
            .sum();
        // DESIGN.md 1b lists fractions that sum to 99.5 % without the sticks.
        assert!((body - 0.995).abs() < 1e-5, "body fractions sum to {body}");
        assert!((2.0 * Segment::Stick.mass_fraction() - 0.01).abs() < 1e-7);
    }

    #[test]
    fn masses_and_lengths_scale_with_settings() {
        let a = Anthropometry::new(BodySettings::default()).unwrap();
        let b = Anthropometry::new(BodySettings { mass_kg: 150.0, height_m: 1.75, ..Default::default() }).unwrap();
        let ua = a.segment(Segment::UpperArm);
        assert!((ua.mass_kg - 1.5).abs() < 1e-5);
        assert!((ua.length_m - 0.186 * 1.75).abs() < 1e-6);
        assert!((b.segment(Segment::UpperArm).mass_kg - 3.0).abs() < 1e-5);
        assert!((a.segment(Segment::Stick).length_m - 0.40).abs() < 1e-7);
    }

    #[test]
    fn capsule_inertia_matches_limits() {
        // A thin rod: m L^2 / 12 transverse, almost no axial inertia.
        let (ax, tr) = capsule_inertia(1.0, 1.0, 1e-4);
        assert!((tr - 1.0 / 12.0).abs() < 1e-4, "{tr}");
        assert!(ax < 1e-7);
        // A sphere (length = diameter): 2/5 m r^2 about every axis.
        let (ax, tr) = capsule_inertia(2.0, 0.2, 0.1);
        assert!((ax - 0.4 * 2.0 * 0.01).abs() < 1e-6, "{ax}");
        assert!((tr - 0.4 * 2.0 * 0.01).abs() < 1e-6, "{tr}");
    }

    #[test]
    fn every_segment_has_positive_mass_and_inertia() {
        for settings in [
            BodySettings { mass_kg: 30.0, height_m: 1.2, stick_length_m: 0.3 },
            BodySettings { mass_kg: 200.0, height_m: 2.2, stick_length_m: 0.5 },
        ] {
            let a = Anthropometry::new(settings).unwrap();
            for s in Segment::ALL {
                let p = a.segment(s);
                assert!(p.mass_kg > 0.0 && p.length_m > 0.0 && p.radius_m > 0.0, "{s:?}: {p:?}");
                assert!(p.axial_inertia > 0.0 && p.transverse_inertia >= p.axial_inertia * 0.5, "{s:?}: {p:?}");
            }
        }
    }

    #[test]
    fn bad_settings_name_the_key() {
        let cases = [
            (BodySettings { mass_kg: 10.0, ..Default::default() }, "mass_kg"),
            (BodySettings { mass_kg: f32::NAN, ..Default::default() }, "mass_kg"),
            (BodySettings { height_m: 3.0, ..Default::default() }, "height_m"),
            (BodySettings { height_m: f32::INFINITY, ..Default::default() }, "height_m"),
            (BodySettings { stick_length_m: 0.0, ..Default::default() }, "stick_length_m"),
        ];
        for (s, key) in cases {
            let err = Anthropometry::new(s).unwrap_err().to_string();
            assert!(err.contains(key) && err.contains("outside"), "{err}");
        }
    }
}
