//! Staging folders that a run killed outright (SIGKILL, a power cut) leaves behind, recognised and
//! removed by the next run.
//!
//! Every staging folder brachia creates (a run folder's `.NAME.partial-PID-K` next to `--out`, a
//! report's `.report.partial-PID-K` inside the run folder, a ladder traverse's
//! `.brachia-traverse-PID-NANOS` in the temporary folder, the Python viewer's `.brachia-view-PID-NANOS`
//! in the temporary folder, `brachia robot import`/`export`'s `.NAME.partial-PID-K` next to the file it
//! writes) is made with [`create`]: a folder new to
//! this run, holding at once a lock file [`STAGE_LOCK`] that starts with brachia's header and on
//! which this process holds an exclusive lock (`flock`) for as long as the folder lives. The
//! operating system drops that lock when the process dies, however it dies. A folder is proven
//! stale ([`clear_stale`]) only when its name has the expected form, it is a real folder (not a
//! link), its lock file is a plain file with brachia's header, and the lock can be taken: then no
//! live process owns it, and it is removed whole (links inside it are removed, never followed).
//! Anything else with a similar name (a user's folder, a folder of a run still working, a folder
//! without the lock file) is left alone, except an empty folder without a lock file, which holds
//! nothing (a process killed between making a folder and marking it): it is removed, as is a lock file
//! still being made (`.brachia-stage.new`) that no process holds. A folder is
//! removed with its lock file last, so a process killed while removing it leaves it marked.

use std::collections::HashMap;
use std::fs::File;
use std::io::{Read, Write};
use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock, PoisonError};

/// How the name of a report's staging folder inside a run folder starts (`brachia report` redraws a
/// reproduction's figures there).
pub const REPORT_STAGE_PREFIX: &str = ".report.partial-";

/// How the name of a traverse's drawing folder in the temporary folder starts (a staging folder,
/// [`crate::staging`]).
pub const DRAW_STAGE_PREFIX: &str = ".brachia-traverse-";

/// How the name of the Python viewer's folder in the temporary folder starts (a run folder written
/// there to draw its page, then removed).
pub const VIEW_STAGE_PREFIX: &str = ".brachia-view-";

/// The lock file inside every staging folder brachia creates.
pub const STAGE_LOCK: &str = ".brachia-stage";

/// The lock file while it is made: locked and given its header under this name, then renamed to
/// [`STAGE_LOCK`], so a [`STAGE_LOCK`] always carries the header of an owner that locked it.
const STAGE_LOCK_NEW: &str = ".brachia-stage.new";

/// First line of [`STAGE_LOCK`].
const STAGE_HEADER: &str = "# brachia staging folder, schema 1\n";

/// The lock files of this process's live staging folders (each holding its lock).
fn held() -> std::sync::MutexGuard<'static, HashMap<PathBuf, File>> {
    static HELD: OnceLock<Mutex<HashMap<PathBuf, File>>> = OnceLock::new();
    HELD.get_or_init(Default::default)
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
}

/// Create the staging folder `path` (an error if anything exists there) and mark it as this
/// process's: its lock file is written and locked before this returns, and stays locked until
/// [`remove`] or [`release`] (or the process's death).
pub fn create(path: &Path) -> std::io::Result<()> {
    loop {
        std::fs::create_dir(path)?;
        match mark(path) {
            Ok(f) => {
                held().insert(path.to_path_buf(), f);
                return Ok(());
            }
            // another process's [`clear_stale`] removed the folder (or its lock file being made)
            // while it was still unmarked: make it again
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                let _ = std::fs::remove_dir(path);
                continue;
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(path);
                return Err(e);
            }
        }
    }
}

/// Write and lock the lock file of the new folder `path`: made under [`STAGE_LOCK_NEW`], locked,
/// given the header, then renamed to [`STAGE_LOCK`] (the lock stays with the file), so a folder
/// whose lock file exists always has a live owner or a dead one. A process killed before the
/// rename leaves [`STAGE_LOCK_NEW`] unlocked, which [`clear_stale`] removes; a live one whose file
/// another run removed that early gets `NotFound` and makes its folder again.
fn mark(path: &Path) -> std::io::Result<File> {
    let new = path.join(STAGE_LOCK_NEW);
    let mut f = std::fs::OpenOptions::new()
        .read(true)
        .write(true)
        .create_new(true)
        .open(&new)?;
    f.lock()?;
    f.write_all(format!("{STAGE_HEADER}pid {}\n", std::process::id()).as_bytes())?;
    std::fs::rename(&new, path.join(STAGE_LOCK))?;
    Ok(f)
}

/// Remove this process's staging folder `path` whole and release its lock. Its lock file goes last,
/// so that a process killed while removing leaves a folder still marked (cleared by a later run).
pub fn remove(path: &Path) {
    if std::fs::symlink_metadata(path).is_ok_and(|m| m.is_dir()) {
        remove_marked(path);
    }
    release(path);
}

/// Remove the folder `dir` (not a link): everything in it but its lock file (links removed, never
/// followed), then the lock file, then the folder.
fn remove_marked(dir: &Path) {
    for e in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        if e.file_name() == STAGE_LOCK {
            continue;
        }
        let p = e.path();
        let _ = if e.file_type().is_ok_and(|t| t.is_dir()) {
            std::fs::remove_dir_all(&p)
        } else {
            std::fs::remove_file(&p)
        };
    }
    let _ = std::fs::remove_file(dir.join(STAGE_LOCK));
    let _ = std::fs::remove_dir(dir);
}

/// Release the lock of this process's staging folder `path` (already removed or renamed).
pub fn release(path: &Path) {
    held().remove(path);
}

/// The lock file of `dir`, locked by this call, when `dir` is a staging folder brachia marked and
/// no live process owns; `None` otherwise (not a real folder, no lock file, a lock file without
/// brachia's header, or an owner still running).
fn dead_owners_lock(dir: &Path) -> Option<File> {
    if !std::fs::symlink_metadata(dir).ok()?.is_dir() {
        return None;
    }
    let lock = dir.join(STAGE_LOCK);
    let meta = std::fs::symlink_metadata(&lock).ok()?;
    if !meta.is_file() || meta.len() > 4096 {
        return None;
    }
    let f = File::open(&lock).ok()?;
    let mut text = String::new();
    (&f).take(4096).read_to_string(&mut text).ok()?;
    if !text.starts_with(STAGE_HEADER) {
        return None;
    }
    f.try_lock().ok()?;
    Some(f)
}

/// Whether `dir` is a staging folder brachia marked (whatever its owner's state).
fn marked(dir: &Path) -> bool {
    std::fs::symlink_metadata(dir.join(STAGE_LOCK)).is_ok_and(|m| m.is_file())
}

/// Remove every staging folder in `parent` whose name starts with `prefix` that brachia marked and
/// whose owner is dead (see the module docs). Returns the folders with such a name that carry no
/// lock file at all (left for the caller to judge; a folder with a lock file of another form, or a
/// live owner, is neither removed nor returned).
pub fn clear_stale(parent: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut unmarked = Vec::new();
    let Ok(entries) = std::fs::read_dir(parent) else {
        return unmarked;
    };
    for e in entries.flatten() {
        let name = e.file_name();
        if !name.to_string_lossy().starts_with(prefix) {
            continue;
        }
        if !e.file_type().is_ok_and(|t| t.is_dir()) {
            continue;
        }
        let dir = e.path();
        if held().contains_key(&dir) {
            continue;
        }
        if let Some(lock) = dead_owners_lock(&dir) {
            // removed while holding its lock: a second run clearing at the same time waits for it
            remove_marked(&dir);
            drop(lock);
        } else if !marked(&dir) {
            // a lock file being made that no process holds: its maker died before marking the
            // folder (or has not locked it yet, and then makes its folder again)
            let new = dir.join(STAGE_LOCK_NEW);
            if std::fs::symlink_metadata(&new).is_ok_and(|m| m.is_file() && m.len() <= 4096) {
                if let Ok(f) = File::open(&new) {
                    if f.try_lock().is_ok() {
                        let _ = std::fs::remove_file(&new);
                    }
                }
            }
            // an empty folder of a staging name holds nothing to lose: a process killed between
            // making it and marking it (or between removing its lock file and it); `remove_dir`
            // fails on a folder that is not empty
            if std::fs::remove_dir(&dir).is_err() {
                unmarked.push(dir);
            }
        }
    }
    unmarked
}

/// Create a fresh staging folder in `parent` named `PREFIXPID-K` (the first `K` from 0 that no entry
/// has), after removing the staging folders of that prefix whose owner died ([`clear_stale`]).
pub fn create_unique(parent: &Path, prefix: &str) -> std::io::Result<PathBuf> {
    clear_stale(parent, prefix);
    let pid = std::process::id();
    for k in 0u32.. {
        let stage = parent.join(format!("{prefix}{pid}-{k}"));
        match create(&stage) {
            Ok(()) => return Ok(stage),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(std::io::Error::other("no free staging folder name"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_lock_file_being_made_is_cleared_only_when_no_process_holds_it() {
        let d = tempfile::tempdir().unwrap();
        let s = d.path().join(".x.partial-1-0");
        std::fs::create_dir(&s).unwrap();
        let new = s.join(STAGE_LOCK_NEW);
        let f = File::create(&new).unwrap();
        f.lock().unwrap();
        // its maker holds it (between locking and renaming): kept, and given back as unmarked
        assert_eq!(clear_stale(d.path(), ".x.partial-"), vec![s.clone()]);
        assert!(new.is_file());
        // its maker died before the rename: the folder holds nothing to lose and is cleared
        drop(f);
        assert!(clear_stale(d.path(), ".x.partial-").is_empty());
        assert!(!s.exists());
    }

    #[test]
    fn a_live_stage_is_kept_and_a_released_one_is_cleared() {
        let d = tempfile::tempdir().unwrap();
        let s = d.path().join(".x.partial-1-0");
        create(&s).unwrap();
        std::fs::write(s.join("a.png"), b"drawn").unwrap();
        // this process owns it: kept
        assert!(clear_stale(d.path(), ".x.partial-").is_empty());
        assert!(s.join("a.png").is_file());
        // its owner gone (the lock released without removing it): cleared
        release(&s);
        assert!(clear_stale(d.path(), ".x.partial-").is_empty());
        assert!(!s.exists());
    }

    #[test]
    fn folders_brachia_cannot_prove_are_kept() {
        let d = tempfile::tempdir().unwrap();
        // no lock file: returned, untouched
        let plain = d.path().join(".x.partial-2-0");
        std::fs::create_dir(&plain).unwrap();
        std::fs::write(plain.join("mine.txt"), b"mine").unwrap();
        // a lock file without the header
        let other = d.path().join(".x.partial-3-0");
        std::fs::create_dir(&other).unwrap();
        std::fs::write(other.join(STAGE_LOCK), b"not brachia's\n").unwrap();
        // a link to a folder of the user's, named like a stage
        let user = d.path().join("user");
        std::fs::create_dir(&user).unwrap();
        std::fs::write(user.join(STAGE_LOCK), STAGE_HEADER).unwrap();
        std::os::unix::fs::symlink(&user, d.path().join(".x.partial-4-0")).unwrap();
        let unmarked = clear_stale(d.path(), ".x.partial-");
        assert_eq!(unmarked, vec![plain.clone()]);
        assert!(plain.join("mine.txt").is_file());
        assert!(other.join(STAGE_LOCK).is_file());
        assert!(user.join(STAGE_LOCK).is_file());
    }

    #[test]
    fn unique_stages_take_fresh_names_and_clear_dead_ones() {
        let d = tempfile::tempdir().unwrap();
        let a = create_unique(d.path(), ".f.partial-").unwrap();
        let b = create_unique(d.path(), ".f.partial-").unwrap();
        assert_ne!(a, b);
        assert!(a.join(STAGE_LOCK).is_file() && b.join(STAGE_LOCK).is_file());
        // `a`'s owner gone: the next stage clears it, and keeps the live `b`
        std::fs::write(a.join("drawn.png"), b"left by a dead run").unwrap();
        release(&a);
        let c = create_unique(d.path(), ".f.partial-").unwrap();
        // `a` was cleared (its name is free again and may be `c`'s), `b` kept
        assert!(!a.join("drawn.png").exists() && b.join(STAGE_LOCK).is_file() && c.is_dir());
        remove(&b);
        remove(&c);
        assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 0);
    }
}
