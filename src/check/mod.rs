//! `drumsim check`: the stability suite a user runs on their own kit, map and body settings.
//!
//! Each check runs part of drumsim under stress and holds its measures to limits:
//! - `strokes/STYLE/BPM` (`body.rs`): the body at 10 kHz through every stroke style, both
//!   hands, at tempos from 40 to 300 bpm: finite, energy bounded, joints held together and
//!   inside their limits, sticks out of the drums, one contact per stroke.
//! - `body/...` (`body.rs`): the same at the extremes of the allowed body sizes and gains.
//! - `long-play` (`body.rs`): `--minutes` of continuous strokes (10 by default).
//! - `song/...` (`songs.rs`): rolls, flams, a fast groove, a fill and the user's songs played
//!   physically through the whole pipeline (motion stage, rehearsal, body): finite, energy
//!   bounded, notes hit, contacts that play no note, sticks out of the drums.
//! - `sound/barrage` (`sound.rs`): the sound engine under every piece struck at once and
//!   often, hardest speeds, chokes and hi-hat moves: no non-finite sample, peak at most full
//!   scale, no queue overflow.
//!
//! `run` returns every check's measures; exit status 0 only if all hold.

mod body;
mod songs;
mod sound;

use crate::body::sim::DrummerSettings;
use crate::kit::Kit;
use crate::midi::NoteMap;
use serde::Serialize;
use std::path::PathBuf;

/// What `drumsim check` checks.
#[derive(Debug, Clone)]
pub struct CheckOptions {
    pub kit: Kit,
    pub map: NoteMap,
    pub drummer: DrummerSettings,
    /// The user's songs, played physically.
    pub songs: Vec<PathBuf>,
    /// Simulated minutes of continuous play.
    pub minutes: f64,
    /// Print each check as it finishes (to stderr).
    pub progress: bool,
    /// Run only the checks whose name contains this text (`--only strokes/accent`).
    pub only: Option<String>,
}

impl CheckOptions {
    /// Whether the check of this name runs.
    pub fn runs(&self, name: &str) -> bool {
        self.only.as_ref().is_none_or(|o| name.contains(o.as_str()))
    }
}

/// One measure of a check against its limit.
#[derive(Debug, Clone, Serialize)]
pub struct Measure {
    pub name: &'static str,
    pub value: f64,
    pub unit: &'static str,
    /// "< 150", ">= 0.95", "= 0".
    pub limit: String,
    pub ok: bool,
}

impl Measure {
    /// `value` must stay below `max` (and be finite).
    pub fn below(name: &'static str, value: f64, max: f64, unit: &'static str) -> Measure {
        Measure { name, value, unit, limit: format!("< {max}"), ok: value.is_finite() && value < max }
    }

    /// `value` must reach at least `min`.
    pub fn at_least(name: &'static str, value: f64, min: f64, unit: &'static str) -> Measure {
        Measure { name, value, unit, limit: format!(">= {min}"), ok: value.is_finite() && value >= min }
    }

    /// `value` must be exactly `want` (counts).
    pub fn equals(name: &'static str, value: f64, want: f64, unit: &'static str) -> Measure {
        Measure { name, value, unit, limit: format!("= {want}"), ok: value == want }
    }

    /// A yes/no measure: 1 holds, 0 fails.
    pub fn holds(name: &'static str, ok: bool) -> Measure {
        Measure { name, value: if ok { 1.0 } else { 0.0 }, unit: "", limit: "yes".into(), ok }
    }
}

/// A check and its measures.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    pub name: String,
    pub ok: bool,
    pub measures: Vec<Measure>,
    /// Simulated or rendered seconds.
    pub seconds: f64,
}

impl Check {
    pub fn new(name: String, seconds: f64, measures: Vec<Measure>) -> Check {
        Check { name, ok: measures.iter().all(|m| m.ok), measures, seconds }
    }

    /// A check that could not run (the setting was refused, the song did not read).
    pub fn failed(name: String, why: String) -> Check {
        let m = Measure { name: "ran", value: 0.0, unit: "", limit: why, ok: false };
        Check { name, ok: false, measures: vec![m], seconds: 0.0 }
    }
}

/// Every check of a run.
#[derive(Debug, Clone, Serialize)]
pub struct CheckReport {
    pub kit: String,
    pub map: String,
    pub ok: bool,
    pub checks: Vec<Check>,
}

impl CheckReport {
    /// The checks that failed.
    pub fn failures(&self) -> impl Iterator<Item = &Check> {
        self.checks.iter().filter(|c| !c.ok)
    }

    /// One line per check: PASS or FAIL, its name, and its measures (a failing one marked !).
    pub fn table(&self) -> String {
        let width = self.checks.iter().map(|c| c.name.len()).max().unwrap_or(0);
        let mut out = format!("drumsim check: kit {}, map {}\n", self.kit, self.map);
        for c in &self.checks {
            let measures: Vec<String> = c.measures.iter().map(describe).collect();
            out.push_str(&format!(
                "{} {:width$}  {}\n",
                if c.ok { "PASS" } else { "FAIL" },
                c.name,
                measures.join(", ")
            ));
        }
        let failed = self.failures().count();
        out.push_str(&if failed == 0 {
            format!("all {} checks hold\n", self.checks.len())
        } else {
            format!("{failed} of {} checks failed\n", self.checks.len())
        });
        out
    }
}

/// "energy 23.1 J (< 150)", with a ! before a measure that fails.
fn describe(m: &Measure) -> String {
    let value = if m.value.abs() >= 100.0 || m.value == m.value.round() {
        format!("{:.0}", m.value)
    } else {
        format!("{:.3}", m.value)
    };
    let unit = if m.unit.is_empty() { String::new() } else { format!(" {}", m.unit) };
    format!("{}{} {value}{unit} ({})", if m.ok { "" } else { "!" }, m.name, m.limit)
}

/// Run every check.
pub fn run(opts: &CheckOptions) -> anyhow::Result<CheckReport> {
    let mut checks = Vec::new();
    let mut add = |c: Check| {
        if opts.progress {
            eprintln!("{} {}", if c.ok { "PASS" } else { "FAIL" }, c.name);
        }
        checks.push(c);
    };
    for c in body::stroke_matrix(opts) {
        add(c);
    }
    for c in body::extremes(opts) {
        add(c);
    }
    if let Some(c) = body::long_play(opts) {
        add(c);
    }
    for c in songs::check_songs(opts)? {
        add(c);
    }
    if opts.runs(sound::NAME) {
        add(sound::barrage(&opts.kit));
    }
    if checks.is_empty() {
        return Err(RunNothing { only: opts.only.clone().unwrap_or_default() }.into());
    }
    let ok = checks.iter().all(|c| c.ok);
    Ok(CheckReport { kit: opts.kit.name.clone(), map: opts.map.name.clone(), ok, checks })
}

/// `--body KEY=VALUE`: set one body or controller setting by its name.
pub fn set_body(settings: &mut DrummerSettings, assignment: &str) -> Result<(), BodyKeyError> {
    let (key, value) =
        assignment.split_once('=').ok_or_else(|| BodyKeyError::Form { given: assignment.to_string() })?;
    let (key, value) = (key.trim(), value.trim());
    let number: f32 =
        value.parse().map_err(|_| BodyKeyError::Value { key: key.to_string(), value: value.to_string() })?;
    match key {
        "mass_kg" => settings.body.mass_kg = number,
        "height_m" => settings.body.height_m = number,
        "stick_length_m" => settings.body.stick_length_m = number,
        "natural_hz" => settings.natural_hz = number,
        "damping_ratio" => settings.damping_ratio = number,
        "limit_hz" => settings.limit_hz = number,
        "feedback" => settings.feedback = number,
        "solver_iterations" if number >= 0.0 && number.fract() == 0.0 => settings.solver_iterations = number as usize,
        "solver_iterations" => return Err(BodyKeyError::Value { key: key.into(), value: value.into() }),
        "ik.damping_m" => settings.ik.damping_m = number,
        "ik.posture_gain" => settings.ik.posture_gain = number,
        "ik.max_step_m" => settings.ik.max_step_m = number,
        _ => return Err(BodyKeyError::Key { key: key.to_string() }),
    }
    Ok(())
}

/// The keys `--body` takes.
pub const BODY_KEYS: [&str; 11] = [
    "mass_kg",
    "height_m",
    "stick_length_m",
    "natural_hz",
    "damping_ratio",
    "limit_hz",
    "feedback",
    "solver_iterations",
    "ik.damping_m",
    "ik.posture_gain",
    "ik.max_step_m",
];

/// `--only` matched no check (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("--only {only:?} matches no check (names start strokes/, body/, gains/, long-play/, song/, sound/)")]
pub struct RunNothing {
    pub only: String,
}

/// Some checks failed (exit code 1).
#[derive(Debug, thiserror::Error)]
#[error("{failed} of {total} checks failed: {names}")]
pub struct ChecksFailed {
    pub names: String,
    pub failed: usize,
    pub total: usize,
}

/// A `--body` argument that does not parse (exit code 2).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BodyKeyError {
    #[error("--body {given:?}: write KEY=VALUE, for example --body natural_hz=30")]
    Form { given: String },
    #[error("--body {key}: {value:?} is not a number")]
    Value { key: String, value: String },
    #[error("--body {key}: not a setting; the settings are {}", BODY_KEYS.join(", "))]
    Key { key: String },
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn body_keys_set_their_setting_and_bad_ones_name_the_key() {
        let mut s = DrummerSettings::default();
        for key in BODY_KEYS {
            set_body(&mut s, &format!("{key}=2")).unwrap();
        }
        assert_eq!((s.natural_hz, s.solver_iterations, s.body.height_m), (2.0, 2, 2.0));
        let e = set_body(&mut s, "gain=3").unwrap_err().to_string();
        assert!(e.contains("gain") && e.contains("natural_hz"), "{e}");
        let e = set_body(&mut s, "natural_hz=fast").unwrap_err().to_string();
        assert!(e.contains("natural_hz") && e.contains("fast"), "{e}");
        assert!(set_body(&mut s, "natural_hz").unwrap_err().to_string().contains("KEY=VALUE"));
    }

    #[test]
    fn a_failing_measure_fails_its_check_and_is_marked_in_the_table() {
        let ok = Check::new("a".into(), 1.0, vec![Measure::below("energy", 3.0, 150.0, "J")]);
        let bad = Check::new("b".into(), 1.0, vec![Measure::below("energy", f64::NAN, 150.0, "J")]);
        assert!(ok.ok && !bad.ok);
        let report = CheckReport { kit: "k".into(), map: "m".into(), ok: false, checks: vec![ok, bad] };
        let table = report.table();
        assert!(table.contains("PASS a") && table.contains("FAIL b") && table.contains("!energy NaN"), "{table}");
        assert!(table.ends_with("1 of 2 checks failed\n"), "{table}");
    }
}
