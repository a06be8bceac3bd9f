//! drumsim's kit held against recorded acoustic kits: every piece struck alone by
//! `drumsim audition`, measured with the same measures as the recorded kits in
//! assets/reference/recorded-kits.json (FluidR3 GM and Hydrogen's The Black Pearl, made by
//! `cargo run --release --example recorded_kits`). A measure passes inside the range the
//! two recorded kits span, widened by the tolerance each check names. The measures not yet
//! in range are listed in the README with their figures; they are not asserted here.

use drumsim::audition::{self, Audition, Stroke};
use drumsim::eval::timbre::{spectral_distance_db, HitMeasures};
use drumsim::kit::Kit;
use serde::Deserialize;
use std::sync::OnceLock;

#[derive(Deserialize)]
struct Reference {
    kits: Vec<RefKit>,
}

#[derive(Deserialize)]
struct RefKit {
    name: String,
    hits: Vec<RefHit>,
}

#[derive(Deserialize)]
struct RefHit {
    name: String,
    velocity: u8,
    measures: HitMeasures,
}

fn reference() -> &'static Reference {
    static R: OnceLock<Reference> = OnceLock::new();
    R.get_or_init(|| {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/reference/recorded-kits.json");
        serde_json::from_str(&std::fs::read_to_string(path).expect("the reference file")).expect("valid reference")
    })
}

fn ours(kit: &str) -> &'static Audition {
    static DEFAULT: OnceLock<Audition> = OnceLock::new();
    static REARRANGED: OnceLock<Audition> = OnceLock::new();
    static JAZZ: OnceLock<Audition> = OnceLock::new();
    static ROCK: OnceLock<Audition> = OnceLock::new();
    let cell = match kit {
        "default" => &DEFAULT,
        "rearranged" => &REARRANGED,
        "jazz" => &JAZZ,
        _ => &ROCK,
    };
    cell.get_or_init(|| audition::audition(&Kit::builtin(kit).unwrap(), None).expect("the audition renders"))
}

fn our_hit(a: &Audition, name: &str, velocity: u8) -> HitMeasures {
    a.hits
        .iter()
        .find(|h| h.stroke.name == name && h.velocity == velocity)
        .unwrap_or_else(|| panic!("no {name} at {velocity} in the audition"))
        .measures
}

/// The recorded kits' values of a measure for a stroke at a velocity (kits without it left out).
fn recorded(name: &str, velocity: u8, f: impl Fn(&HitMeasures) -> Option<f64>) -> Vec<(String, f64)> {
    reference()
        .kits
        .iter()
        .filter_map(|k| {
            let h = k.hits.iter().find(|h| h.name == name && h.velocity == velocity)?;
            Some((k.name.clone(), f(&h.measures)?))
        })
        .collect()
}

/// Level re the snare at the same velocity, dB.
fn level_re_snare(m: &HitMeasures, snare: &HitMeasures) -> f64 {
    m.level_db - snare.level_db
}

/// The lowest and highest of the recorded values.
fn span(rec: &[(String, f64)]) -> (f64, f64) {
    let lo = rec.iter().map(|r| r.1).fold(f64::MAX, f64::min);
    let hi = rec.iter().map(|r| r.1).fold(f64::MIN, f64::max);
    (lo, hi)
}

/// Check `value` against the recorded values widened by `below` and `above`; returns a
/// line for the report, and whether it passed.
fn check(what: &str, value: f64, rec: &[(String, f64)], below: f64, above: f64) -> (String, bool) {
    assert!(!rec.is_empty(), "{what}: no recorded kit has it");
    let (lo, hi) = span(rec);
    let ok = value >= lo - below && value <= hi + above;
    let kits: Vec<String> = rec.iter().map(|(k, v)| format!("{k} {v:.1}")).collect();
    (
        format!("{what}: ours {value:.1}, recorded {} (allowed {:.1}..{:.1})", kits.join(", "), lo - below, hi + above),
        ok,
    )
}

fn assert_all(lines: Vec<(String, bool)>) {
    let failed: Vec<&String> = lines.iter().filter(|l| !l.1).map(|l| &l.0).collect();
    for (l, ok) in &lines {
        eprintln!("{} {l}", if *ok { "ok  " } else { "FAIL" });
    }
    assert!(failed.is_empty(), "{} of {} out of range:\n{failed:#?}", failed.len(), lines.len());
}

/// Level re snare per piece within 4 dB of the recorded kits' balance (velocities 64 and 127).
fn balance(kit: &str) {
    let a = ours(kit);
    let mut lines = Vec::new();
    for name in [
        "kick",
        "tom1",
        "tom2",
        "floor_tom",
        "snare rim shot",
        "snare cross-stick",
        "hihat closed",
        "hihat open",
        "hihat pedal",
        "crash bow",
        "ride bow",
        "ride bell",
        "splash bow",
        "china bow",
    ] {
        for v in [64, 127] {
            let snare = our_hit(a, "snare", v);
            let ours = level_re_snare(&our_hit(a, name, v), &snare);
            let rec: Vec<(String, f64)> = reference()
                .kits
                .iter()
                .filter_map(|k| {
                    let find = |n: &str| k.hits.iter().find(|h| h.name == n && h.velocity == v).map(|h| h.measures);
                    Some((k.name.clone(), level_re_snare(&find(name)?, &find("snare")?)))
                })
                .collect();
            lines.push(check(&format!("{kit}: {name} at {v}, level re snare, dB"), ours, &rec, 4.0, 4.0));
        }
    }
    assert_all(lines);
}

#[test]
fn each_piece_sits_in_the_recorded_kits_balance() {
    balance("default");
}

#[test]
fn the_rearranged_kit_keeps_the_balance() {
    balance("rearranged");
}

#[test]
fn the_jazz_and_rock_kits_are_balanced_too() {
    balance("jazz");
    balance("rock");
}

#[test]
fn cymbals_and_hihats_are_as_bright_as_recorded_ones() {
    let a = ours("default");
    let mut lines = Vec::new();
    // The first 50 ms's centroid within 1/1.5 .. 1.5 times the recorded range.
    for name in ["hihat closed", "hihat open", "crash bow", "ride bow", "splash bow", "china bow"] {
        let ours = our_hit(a, name, 127).centroid_50ms_hz;
        let rec = recorded(name, 127, |m| Some(m.centroid_50ms_hz));
        let (lo, hi) = span(&rec);
        lines.push(check(&format!("{name}: centroid of the first 50 ms, Hz"), ours, &rec, lo / 3.0, hi / 2.0));
    }
    // Energy above 4 kHz 0.5-1 s after the hit: the tail is high, not a gong's low hum.
    for name in ["hihat open", "crash bow", "ride bow", "china bow"] {
        let ours = our_hit(a, name, 127).tail_above_4k_db.expect("a tail");
        lines.push(check(
            &format!("{name}: tail above 4 kHz re all, dB"),
            ours,
            &recorded(name, 127, |m| m.tail_above_4k_db),
            3.0,
            3.0,
        ));
    }
    assert_all(lines);
}

#[test]
fn a_hard_hit_cymbal_tail_is_a_wash_not_a_gong() {
    // Spectral flatness 0.5-1 s after a hit at 127 (near 0: a few clean partials; recorded
    // crashes 0.03-0.15): within half to twice the recorded range. Not the open hi-hat,
    // whose recorded sizzle (0.24-0.42) is its two cymbals touching (README, "Not yet").
    let a = ours("default");
    let mut lines = Vec::new();
    for name in ["crash bow", "ride bow", "china bow"] {
        let ours = our_hit(a, name, 127).tail_flatness.expect("a tail");
        let rec = recorded(name, 127, |m| m.tail_flatness);
        let (lo, hi) = span(&rec);
        let (what, ok) = check(&format!("{name}: tail flatness"), ours, &rec, lo / 2.0, hi);
        lines.push((format!("{what} [{ours:.4}]"), ok));
    }
    // ... and a soft hit stays nearer a ring: the wash grows with the hit.
    for name in ["crash bow", "crash edge", "china bow"] {
        let (soft, hard) = (our_hit(a, name, 40).tail_flatness, our_hit(a, name, 127).tail_flatness);
        let (soft, hard) = (soft.expect("a tail"), hard.expect("a tail"));
        lines.push((format!("{name}: tail flatness at 40 {soft:.4} < at 127 {hard:.4}"), soft < hard));
    }
    assert_all(lines);
}

#[test]
fn hihats_and_crash_decay_like_recorded_ones() {
    let a = ours("default");
    let mut lines = Vec::new();
    for name in ["hihat closed", "hihat open", "hihat pedal", "crash bow"] {
        let ours = our_hit(a, name, 127).decay_20db_ms.expect("decays");
        let rec = recorded(name, 127, |m| m.decay_20db_ms);
        let (lo, hi) = span(&rec);
        // Within 1/1.5 .. 1.5 times the recorded range.
        lines.push(check(&format!("{name}: decay to -20 dB, ms"), ours, &rec, lo / 3.0, hi / 2.0));
    }
    assert_all(lines);
}

#[test]
fn snare_wires_grow_with_the_hit_and_leave_the_body_audible() {
    let a = ours("default");
    let mut lines = Vec::new();
    let hi_lo: Vec<f64> = [20, 64, 127].iter().map(|&v| our_hit(a, "snare", v).hi_lo_100ms_db).collect();
    // A ghost note is mostly head, a hard hit mostly wires.
    lines.push((
        format!("snare: wires re body rise with velocity 20 / 64 / 127: {hi_lo:.1?} dB"),
        hi_lo[0] < hi_lo[1] - 3.0 && hi_lo[1] < hi_lo[2],
    ));
    for v in [64, 127] {
        let ours = our_hit(a, "snare", v).hi_lo_100ms_db;
        lines.push(check(
            &format!("snare at {v}: above 2 kHz re below 1 kHz, first 100 ms, dB"),
            ours,
            &recorded("snare", v, |m| Some(m.hi_lo_100ms_db)),
            4.0,
            4.0,
        ));
    }
    assert_all(lines);
}

#[test]
fn a_stick_leaves_the_snare_within_the_measured_contact_time_and_a_kick_clicks() {
    // Wagner (KTH 2006) measured 3-6 ms of stick contact on a snare head.
    let a = ours("default");
    let mut lines = Vec::new();
    for v in [20, 64, 127] {
        let h = a.hits.iter().find(|h| h.stroke.name == "snare" && h.velocity == v).unwrap();
        lines
            .push((format!("snare at {v}: contact {:.1} ms (1-6)", h.contact_ms), (1.0..=6.0).contains(&h.contact_ms)));
    }
    let click = our_hit(a, "kick", 127).first_5ms_db;
    lines.push(check(
        "kick: first 5 ms re first 50 ms, dB",
        click,
        &recorded("kick", 127, |m| Some(m.first_5ms_db)),
        3.0,
        3.0,
    ));
    assert_all(lines);
}

#[test]
fn a_hard_tom_hit_starts_sharp_and_falls_in_pitch() {
    let a = ours("default");
    let mut lines = Vec::new();
    for name in ["tom1", "tom2", "floor_tom"] {
        let soft = our_hit(a, name, 20).pitch_change().unwrap_or(0.0) * 100.0;
        let hard = our_hit(a, name, 127).pitch_change().expect("a pitch at 350 ms") * 100.0;
        lines.push((
            format!("{name}: pitch over 350 ms, velocity 20 {soft:+.1} %, 127 {hard:+.1} %"),
            hard < -5.0 && hard < soft - 4.0,
        ));
    }
    assert_all(lines);
}

/// A tom's first 50 ms has the bright attack of a recorded tom, not only its boom: the
/// centroid and the energy above 2 kHz at velocities 64 and 127 sit in the range of every
/// recorded tom (rack and floor, both kits, at those velocities), the centroid within half
/// to 1.5 times it and the energy above 2 kHz within 6 dB. (At stop 47, before the heads
/// radiated as pistons, were struck over a patch and rang longer above: centroids
/// 0.18-0.38 kHz, energy above 2 kHz -37 to -63 dB; the recorded toms 0.9-1.4 kHz, -19 to
/// -27 dB.) The kick is printed.
#[test]
fn toms_attack_as_bright_as_recorded_toms() {
    let a = ours("default");
    let toms = ["tom1", "tom2", "floor_tom"];
    let every_recorded = |f: fn(&HitMeasures) -> f64| -> Vec<(String, f64)> {
        toms.iter()
            .flat_map(|t| [64, 127].map(|v| (t, v)))
            .flat_map(|(t, v)| {
                recorded(t, v, |m| Some(f(m))).into_iter().map(move |(k, x)| (format!("{k} {t} {v}"), x))
            })
            .collect()
    };
    let centroids = every_recorded(|m| m.centroid_50ms_hz);
    let highs = every_recorded(|m| m.above_2k_50ms_db);
    let (lo, hi) = span(&centroids);
    let (hlo, hhi) = span(&highs);
    let mut lines = Vec::new();
    for name in toms {
        for v in [64, 127] {
            let m = our_hit(a, name, v);
            let c = m.centroid_50ms_hz;
            lines.push((
                format!("{name} at {v}: centroid of the first 50 ms {c:.0} Hz (recorded toms {lo:.0}-{hi:.0})"),
                c >= lo / 2.0 && c <= hi * 1.5,
            ));
            let h = m.above_2k_50ms_db;
            lines.push((
                format!("{name} at {v}: above 2 kHz in the first 50 ms {h:.1} dB (recorded toms {hlo:.1}..{hhi:.1})"),
                h >= hlo - 6.0 && h <= hhi + 6.0,
            ));
        }
    }
    for v in [64, 127] {
        let m = our_hit(a, "kick", v);
        let rec = recorded("kick", v, |m| Some(m.centroid_50ms_hz));
        eprintln!(
            "(not asserted) kick at {v}: centroid {:.0} Hz, above 2 kHz {:.1} dB (recorded centroids {rec:.0?})",
            m.centroid_50ms_hz, m.above_2k_50ms_db
        );
    }
    assert_all(lines);
}

/// One stroke struck `n` times, `spacing_s` apart, on one engine (each strike meets what
/// the last left ringing; the strike point varies as under a player's hand).
fn repeated(kit: &Kit, stroke: &Stroke, n: usize, spacing_s: f64) -> Vec<(Vec<f32>, Vec<f32>)> {
    let mut messages = Vec::new();
    for i in 0..n {
        messages.extend(audition::stroke_messages(kit, stroke, 100, 0.01 + i as f64 * spacing_s, i));
    }
    let (l, r, _) = audition::play(kit, &messages, 0.01 + n as f64 * spacing_s).unwrap();
    let per = (spacing_s * audition::SAMPLE_RATE_HZ as f64) as usize;
    (0..n).map(|i| (l[i * per..(i + 1) * per].to_vec(), r[i * per..(i + 1) * per].to_vec())).collect()
}

/// Eight hits of `name` 250 ms apart: the closest two's spectral distance (dB RMS over
/// third-octave bands, level removed) and the hits' level spread, dB.
fn machine_gun(kit: &Kit, name: &str) -> (f64, f64) {
    let stroke = audition::strokes(kit).into_iter().find(|s| s.name == name).unwrap();
    let hits = repeated(kit, &stroke, 8, 0.25);
    let levels: Vec<f64> = hits
        .iter()
        .map(|(l, r)| {
            let p: f64 = l.iter().zip(r).map(|(a, b)| (*a as f64).powi(2) + (*b as f64).powi(2)).sum();
            10.0 * (p / l.len() as f64).log10()
        })
        .collect();
    let spread = levels.iter().cloned().fold(f64::MIN, f64::max) - levels.iter().cloned().fold(f64::MAX, f64::min);
    let mut least = f64::MAX;
    for i in 0..8 {
        for j in i + 1..8 {
            let d = spectral_distance_db(
                (&hits[i].0, &hits[i].1),
                (&hits[j].0, &hits[j].1),
                audition::SAMPLE_RATE_HZ as f64,
            );
            least = least.min(d);
        }
    }
    (least, spread)
}

#[test]
fn eight_identical_snare_hits_are_not_a_machine_gun() {
    let kit = Kit::builtin_default();
    // Measured and printed; asserted on the snare only: eight closed hi-hat hits come out
    // 0.1 dB apart and a ride's ring adds up over eight hits 250 ms apart (README, "Not yet").
    for name in ["hihat closed", "hihat open", "ride bow", "crash bow", "tom1", "kick"] {
        let (least, spread) = machine_gun(&kit, name);
        eprintln!("{name}: closest pair {least:.2} dB apart in spectrum, levels within {spread:.2} dB");
    }
    let (least, spread) = machine_gun(&kit, "snare");
    // Floor: 0.5 dB RMS across third-octave bands, about the smallest change of timbre
    // listeners notice between successive sounds; eight copies of one sample give 0.
    eprintln!("snare: closest pair {least:.2} dB apart in spectrum, levels within {spread:.2} dB");
    assert!(least > 0.5, "two of eight snare hits are only {least:.2} dB apart in spectrum");
    assert!(spread <= 1.5, "eight snare hits span {spread:.2} dB in level");
}

/// The strokes whose first 50 ms brighten from velocity 20 to 64 to 127 (the hi-hats by
/// their in-plane stress). The others (toms 1 and 2, ride edge and bell, splash bell, rim
/// shot and cross-stick) do not yet (README, "Not yet").
const BRIGHTER_WHEN_HARDER: [&str; 16] = [
    "kick",
    "snare",
    "floor_tom",
    "hihat closed",
    "hihat open",
    "hihat half-open edge",
    "hihat pedal",
    "crash bow",
    "crash edge",
    "crash bell",
    "ride bow",
    "splash bow",
    "splash edge",
    "china bow",
    "china edge",
    "china bell",
];

#[test]
fn a_harder_hit_is_brighter() {
    let a = ours("default");
    let mut lines = Vec::new();
    for stroke in audition::strokes(&Kit::builtin_default()) {
        let c: Vec<f64> = [20, 64, 127].iter().map(|&v| our_hit(a, &stroke.name, v).centroid_50ms_hz).collect();
        let rising = c[0] < c[1] && c[1] < c[2];
        if BRIGHTER_WHEN_HARDER.contains(&stroke.name.as_str()) {
            lines.push((format!("{}: centroid at 20 / 64 / 127: {c:.0?} Hz", stroke.name), rising));
        } else {
            eprintln!("(not asserted) {}: centroid at 20 / 64 / 127: {c:.0?} Hz", stroke.name);
        }
    }
    assert_all(lines);
}
