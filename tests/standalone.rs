//! A binary that stands on its own: copied into an empty folder, with no `assets/` beside it
//! and no environment, it renders the bundled demo with the compiled-in hand model, exactly as
//! the source tree's weights do; `--version` names the features it was built with.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

fn fresh_dir(tag: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("standalone-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A fresh folder holding a copy of the release binary, and that copy's path.
fn binary_alone(tag: &str) -> (PathBuf, PathBuf) {
    let dir = fresh_dir(tag);
    let exe = dir.join("drumsim");
    std::fs::copy(env!("CARGO_BIN_EXE_drumsim"), &exe).unwrap();
    (dir, exe)
}

/// Runs `exe` in `cwd` with an empty environment.
fn run_bare(exe: &Path, cwd: &Path, args: &[&str]) -> Output {
    // A test thread forking while the copy was still open for writing holds a write handle
    // to it for a moment ("text file busy"): try again.
    for _ in 0..100 {
        match Command::new(exe).args(args).current_dir(cwd).env_clear().output() {
            Err(e) if e.kind() == std::io::ErrorKind::ExecutableFileBusy => {
                std::thread::sleep(std::time::Duration::from_millis(20))
            }
            r => return r.expect("run drumsim"),
        }
    }
    panic!("{} stayed busy", exe.display())
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn a_copied_binary_renders_the_demo_with_the_compiled_in_model() {
    // The binary alone in an empty folder, with the demo song beside it and nothing else.
    let (alone, exe) = binary_alone("alone");
    std::fs::copy(root().join("assets/demo/demo.mid"), alone.join("demo.mid")).unwrap();
    let r = run_bare(&exe, &alone, &["render", "demo.mid", "--out", "out"]);
    assert!(r.status.success(), "{}", stderr(&r));
    let summary = stderr(&r);
    assert!(summary.contains("hands from model compiled-in assets/hands/best.bpk"), "{summary}");
    assert!(!summary.contains("teacher"), "{summary}");
    // The same song rendered from the source tree with the shipped weights file.
    let tree = fresh_dir("tree");
    let weights = root().join("assets/hands/best.bpk");
    let song = root().join("assets/demo/demo.mid");
    let r = Command::new(env!("CARGO_BIN_EXE_drumsim"))
        .args(["render", song.to_str().unwrap(), "--out", tree.to_str().unwrap()])
        .args(["--weights", weights.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(stderr(&r).contains(&format!("hands from model {}", weights.display())), "{}", stderr(&r));
    for file in ["demo.motion.json", "demo.bvh", "demo.glb", "demo.vrma", "demo.wav"] {
        let a = std::fs::read(alone.join("out").join(file)).unwrap();
        let b = std::fs::read(tree.join(file)).unwrap();
        assert!(a == b, "{file} differs between the copied binary and the source tree's weights");
    }
}

#[test]
fn the_teacher_plays_only_when_asked_for() {
    let (dir, exe) = binary_alone("teacher");
    let song = root().join("assets/demo/demo.mid");
    let r = run_bare(&exe, &dir, &["render", song.to_str().unwrap(), "--out", "out", "--teacher"]);
    assert!(r.status.success(), "{}", stderr(&r));
    assert!(stderr(&r).contains("hands from the corpus teacher (--teacher)"), "{}", stderr(&r));
    // Weights that are not there are an error naming them, never a quiet switch to the teacher.
    let r = run_bare(&exe, &dir, &["render", song.to_str().unwrap(), "--out", "out2", "--weights", "nope.bpk"]);
    assert_eq!(r.status.code(), Some(2), "{}", stderr(&r));
    assert!(stderr(&r).contains("nope.bpk"), "{}", stderr(&r));
    assert!(!dir.join("out2").join("demo.wav").exists());
}

#[test]
fn version_names_the_features_built_in() {
    let r = Command::new(env!("CARGO_BIN_EXE_drumsim")).arg("--version").output().unwrap();
    assert!(r.status.success());
    let text = String::from_utf8_lossy(&r.stdout).into_owned();
    assert!(text.starts_with(&format!("drumsim {}", env!("CARGO_PKG_VERSION"))), "{text}");
    let jack = if cfg!(feature = "jack") { "features: jack" } else { "features: none" };
    assert!(text.contains(jack) && text.contains("hand model"), "{text}");
}

#[test]
fn built_in_kits_are_chosen_by_name_from_anywhere() {
    let (dir, exe) = binary_alone("kits");
    let song = root().join("assets/demo/demo.mid");
    let r =
        run_bare(&exe, &dir, &["render", song.to_str().unwrap(), "--out", "out", "--kit", "rearranged", "--no-motion"]);
    assert!(r.status.success(), "{}", stderr(&r));
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("out/demo.contacts.json")).unwrap()).unwrap();
    assert_eq!(json["kit"], "rearranged");
}
