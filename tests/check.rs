//! `drumsim check`, the stability suite, run as a user runs it: it passes on the default and
//! the shipped kits, fails naming the checks on a deliberately unstable setting, and refuses
//! a setting it does not know.

use std::process::{Command, Output};

fn drumsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_drumsim")).args(args).output().expect("run drumsim")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn the_checks_hold_on_the_default_and_the_shipped_kits() {
    // Both kits at once (two cores); a short continuous-play check keeps CI fast.
    let runs: Vec<_> = [None, Some("rearranged")]
        .into_iter()
        .map(|kit| {
            std::thread::spawn(move || {
                let mut args = vec!["check", "--minutes", "0.5", "--json"];
                if let Some(k) = kit {
                    args.extend(["--kit", k]);
                }
                (kit, drumsim(&args))
            })
        })
        .collect();
    for run in runs {
        let (kit, o) = run.join().unwrap();
        let report: serde_json::Value =
            serde_json::from_slice(&o.stdout).unwrap_or_else(|e| panic!("{kit:?}: {e}: {}", stderr(&o)));
        let failed: Vec<String> =
            report["checks"].as_array().unwrap().iter().filter(|c| c["ok"] != true).map(|c| c.to_string()).collect();
        assert!(failed.is_empty(), "{kit:?}: {failed:#?}");
        assert_eq!(o.status.code(), Some(0), "{kit:?}: {}", stderr(&o));
        let names: Vec<&str> =
            report["checks"].as_array().unwrap().iter().map(|c| c["name"].as_str().unwrap()).collect();
        for want in [
            "strokes/accent/300bpm",
            "strokes/legato/40bpm",
            "body/tall/accent/160bpm",
            "long-play/0.5min",
            "song/roll",
            "song/flams",
            "sound/barrage",
        ] {
            assert!(names.contains(&want), "{kit:?}: no check {want}: {names:?}");
        }
    }
}

#[test]
fn an_unstable_controller_forced_past_its_range_fails_naming_the_checks() {
    let o = drumsim(&["check", "--minutes", "0.1", "--body", "feedback=30", "--force"]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let table = String::from_utf8_lossy(&o.stdout);
    assert!(table.contains("FAIL strokes/legato/40bpm") && table.contains("!limit excess"), "{table}");
    assert!(stderr(&o).contains("checks failed: strokes/legato/40bpm"), "{}", stderr(&o));
}

#[test]
fn bad_settings_are_refused_naming_the_key() {
    let o = drumsim(&["check", "--body", "gain=3"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("gain") && stderr(&o).contains("natural_hz"), "{}", stderr(&o));
    // Past the stable range without --force.
    let o = drumsim(&["check", "--body", "feedback=30"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("feedback = 30") && stderr(&o).contains("0..=2"), "{}", stderr(&o));
    // A body size past its range, even with --force.
    let o = drumsim(&["check", "--body", "height_m=3", "--force"]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("height_m"), "{}", stderr(&o));
}
