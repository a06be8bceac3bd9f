//! Output files published together: every file of a job (a render's WAV, contacts and motion)
//! is written under a partial name unique to the process, and moved into place only when all
//! of them are complete. A failure (a full disk, a bad value found late) leaves the folder as
//! it was: no new file, no older one replaced, no partial left behind. Ctrl-C or SIGTERM
//! removes the partials of every set still being written ([`remove_partials_on_interrupt`]).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Partial files being written now, in every set of the process, for the interrupt handler.
static LIVE: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The exit status after Ctrl-C or SIGTERM (128 + SIGINT, as shells report an interrupt).
pub const INTERRUPTED_EXIT: i32 = 130;

fn live() -> std::sync::MutexGuard<'static, Vec<PathBuf>> {
    LIVE.lock().unwrap_or_else(|e| e.into_inner())
}

/// Set by [`stop_gracefully_on_interrupt`]: an interrupt then only raises [`interrupted`].
static GRACEFUL: AtomicBool = AtomicBool::new(false);
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// From now on the first Ctrl-C or SIGTERM only raises [`interrupted`], for a command that
/// stops itself cleanly (the sound server closes its audio client and shows its counts); a
/// second one exits at once.
pub fn stop_gracefully_on_interrupt() {
    GRACEFUL.store(true, Ordering::SeqCst);
}

/// Whether an interrupt asked a graceful command to stop.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::SeqCst)
}

/// Install a handler for SIGINT, SIGTERM and SIGHUP that removes the partial files of every
/// unpublished set and exits with [`INTERRUPTED_EXIT`]. A set being published at that moment
/// finishes first, so the folder holds the whole new set or the whole old one.
pub fn remove_partials_on_interrupt() -> Result<(), ctrlc::Error> {
    ctrlc::set_handler(|| {
        if GRACEFUL.load(Ordering::SeqCst) && !INTERRUPTED.swap(true, Ordering::SeqCst) {
            return;
        }
        let partials = live();
        for p in partials.iter() {
            let _ = std::fs::remove_file(p);
        }
        eprintln!("drumsim: interrupted; {} partial file(s) removed, nothing published", partials.len());
        std::process::exit(INTERRUPTED_EXIT);
    })
}

/// `dir/name.ext` -> `dir/.name.ext.PID-N.partial`: unique to this process and call, so two
/// renders of songs with the same name into one folder never write into each other's file.
pub fn partial_path(path: &Path) -> PathBuf {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.{}-{n}.partial", std::process::id()))
}

/// Why a set could not be published; names the file.
#[derive(Debug, thiserror::Error)]
#[error("cannot move {} into place as {}: {source}; nothing was published", .partial.display(), .target.display())]
pub struct PublishError {
    pub partial: PathBuf,
    pub target: PathBuf,
    pub source: std::io::Error,
}

/// Files written under partial names, moved into place together by [`OutputSet::publish`].
/// Dropped unpublished (an error on the way), it removes its partial files.
#[derive(Default)]
pub struct OutputSet {
    /// (partial, target), in the order staged.
    files: Vec<(PathBuf, PathBuf)>,
}

impl OutputSet {
    pub fn new() -> OutputSet {
        OutputSet::default()
    }

    /// The partial path to write `target`'s content to. The caller creates and fills it.
    pub fn stage(&mut self, target: &Path) -> PathBuf {
        let partial = partial_path(target);
        live().push(partial.clone());
        self.files.push((partial.clone(), target.to_path_buf()));
        partial
    }

    /// Move every staged file into place. An existing file under a target name is first set
    /// aside, and put back if any move fails, so the folder ends with the whole new set or
    /// the whole old one.
    pub fn publish(mut self) -> Result<(), PublishError> {
        let files = std::mem::take(&mut self.files);
        let mut registry = live();
        let result = publish_all(&files);
        registry.retain(|p| !files.iter().any(|(partial, _)| partial == p));
        drop(registry);
        if result.is_err() {
            for (partial, _) in &files {
                let _ = std::fs::remove_file(partial);
            }
        }
        result
    }
}

fn publish_all(files: &[(PathBuf, PathBuf)]) -> Result<(), PublishError> {
    let fail = |partial: &Path, target: &Path, source| PublishError {
        partial: partial.to_path_buf(),
        target: target.to_path_buf(),
        source,
    };
    // Older files set aside: (backup, target).
    let mut aside: Vec<(PathBuf, PathBuf)> = Vec::new();
    let restore = |aside: &[(PathBuf, PathBuf)]| {
        for (backup, target) in aside {
            let _ = std::fs::rename(backup, target);
        }
    };
    for (partial, target) in files {
        match std::fs::symlink_metadata(target) {
            Ok(meta) if meta.is_dir() => {
                restore(&aside);
                let e = std::io::Error::new(std::io::ErrorKind::IsADirectory, "a folder has that name");
                return Err(fail(partial, target, e));
            }
            Ok(_) => {
                let backup = partial.with_extension("old");
                if let Err(e) = std::fs::rename(target, &backup) {
                    restore(&aside);
                    return Err(fail(partial, target, e));
                }
                aside.push((backup, target.clone()));
            }
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => {
                restore(&aside);
                return Err(fail(partial, target, e));
            }
        }
    }
    for (i, (partial, target)) in files.iter().enumerate() {
        if let Err(e) = std::fs::rename(partial, target) {
            // Take back what was moved in; the partials are removed by the caller.
            for (p, t) in &files[..i] {
                let _ = std::fs::rename(t, p);
            }
            restore(&aside);
            return Err(fail(partial, target, e));
        }
    }
    for (backup, _) in &aside {
        let _ = std::fs::remove_file(backup);
    }
    Ok(())
}

impl Drop for OutputSet {
    fn drop(&mut self) {
        if self.files.is_empty() {
            return;
        }
        let mut registry = live();
        for (partial, _) in &self.files {
            let _ = std::fs::remove_file(partial);
            registry.retain(|p| p != partial);
        }
    }
}

/// Write a whole file atomically: a partial file, synced, then moved into place.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let mut set = OutputSet::new();
    let partial = set.stage(path);
    write_synced(&partial, bytes)?;
    set.publish().map_err(|e| e.source)
}

/// Create `path` with `bytes` and sync it to disk.
pub fn write_synced(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write;
    let mut file = std::fs::File::create(path)?;
    file.write_all(bytes)?;
    file.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("drumsim-outputs-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn listing(dir: &Path) -> Vec<(String, String)> {
        let mut v: Vec<(String, String)> = std::fs::read_dir(dir)
            .unwrap()
            .map(|e| {
                let e = e.unwrap();
                let text = std::fs::read_to_string(e.path()).unwrap_or_else(|_| "<dir>".into());
                (e.file_name().to_string_lossy().into_owned(), text)
            })
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_set_replaces_the_older_set_whole() {
        let dir = scratch("whole");
        for name in ["a.wav", "a.json"] {
            std::fs::write(dir.join(name), "old").unwrap();
        }
        let mut set = OutputSet::new();
        for name in ["a.wav", "a.json", "a.glb"] {
            std::fs::write(set.stage(&dir.join(name)), "new").unwrap();
        }
        set.publish().unwrap();
        let want: Vec<(String, String)> =
            ["a.glb", "a.json", "a.wav"].iter().map(|n| (n.to_string(), "new".to_string())).collect();
        assert_eq!(listing(&dir), want);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_set_that_cannot_be_published_leaves_the_older_set_and_no_partial() {
        let dir = scratch("blocked");
        std::fs::write(dir.join("a.wav"), "old").unwrap();
        // A folder under the last name: that move must fail, after the WAV's could succeed.
        std::fs::create_dir(dir.join("a.glb")).unwrap();
        std::fs::write(dir.join("a.glb").join("keep"), "x").unwrap();
        let before = listing(&dir);
        let mut set = OutputSet::new();
        for name in ["a.wav", "a.json", "a.glb"] {
            std::fs::write(set.stage(&dir.join(name)), "new").unwrap();
        }
        let e = set.publish().unwrap_err();
        assert!(e.to_string().contains("a.glb") && e.to_string().contains("nothing was published"), "{e}");
        assert_eq!(listing(&dir), before);
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn a_dropped_set_removes_its_partials() {
        let dir = scratch("dropped");
        {
            let mut set = OutputSet::new();
            std::fs::write(set.stage(&dir.join("a.wav")), "new").unwrap();
            assert_eq!(listing(&dir).len(), 1);
        }
        assert!(listing(&dir).is_empty());
        assert!(!live().iter().any(|p| p.starts_with(&dir)));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
