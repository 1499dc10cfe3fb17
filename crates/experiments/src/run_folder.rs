//! Run folders, written so that nothing is ever half-written and no user file is ever deleted.
//!
//! Every file of a run is queued in memory and written at the end into a *staging folder* next to the
//! target (`.NAME.partial-PID`), with a manifest [`MANIFEST`] that lists every file the run wrote. Only
//! when everything is written is the staging folder renamed into place:
//! - no target folder (or an empty one): the staging folder simply becomes it;
//! - a target that is a brachia run folder (it has a manifest): the old folder is renamed aside, the new
//!   one into place, and every file of the old folder that its manifest does not list (the user's own)
//!   is moved into the new folder (a name the new run also wrote is kept as `NAME.user`); only then is
//!   the old folder, holding nothing but files brachia wrote, removed;
//! - a non-empty folder without a manifest is refused by [`check_out_dir`] unless `force` is given;
//!   with `force` its files are kept as above.
//!
//! An interrupted run leaves the previous results as they were (and a hidden staging folder, removed by
//! the next run into the same place once its process is gone).

use crate::ExpError;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

/// The manifest of a run folder: one relative path per line (after a header line) of every file the run
/// wrote. Its presence marks a folder as a brachia run folder.
pub const MANIFEST: &str = ".brachia-run";

const MANIFEST_HEADER: &str =
    "# brachia run folder: the files this run wrote (a re-run replaces only these)";

/// The files of one run.
#[derive(Debug, Default, Clone)]
pub struct RunFolder {
    files: Vec<(String, Vec<u8>)>,
}

fn werr(path: &Path, source: std::io::Error) -> ExpError {
    ExpError::Write {
        path: path.to_path_buf(),
        source,
    }
}

impl RunFolder {
    /// Queue a file (a name relative to the run folder; may contain `/`).
    pub fn add(&mut self, name: &str, contents: impl Into<Vec<u8>>) {
        self.files.push((name.to_string(), contents.into()));
    }

    /// Queue a pretty-printed JSON file.
    pub fn add_json(&mut self, name: &str, value: &serde_json::Value) {
        let text = serde_json::to_string_pretty(value).unwrap_or_else(|_| "null".into());
        self.add(name, text + "\n");
    }

    /// Names of the queued files.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.files.iter().map(|(n, _)| n.as_str())
    }

    /// Contents of a queued file.
    pub fn get(&self, name: &str) -> Option<&[u8]> {
        self.files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, d)| d.as_slice())
    }

    /// Write the run folder `dir`: into a staging folder next to it, then renamed into place (see the
    /// module docs; the user's files in a previous run folder are kept).
    pub fn write(&self, dir: &Path) -> Result<(), ExpError> {
        let stage = stage_for(dir)?;
        let written = self.write_into(&stage);
        match written {
            // install removes the staging folder itself when it cannot be renamed into place
            Ok(()) => install(&stage, dir),
            Err(e) => {
                let _ = std::fs::remove_dir_all(&stage);
                Err(e)
            }
        }
    }

    /// Write every file into the existing folder `dir` (created if missing), each under a temporary name
    /// renamed into place; other files in `dir` are left alone. For pages published into folders that
    /// also hold the user's files.
    pub fn write_into(&self, dir: &Path) -> Result<(), ExpError> {
        std::fs::create_dir_all(dir).map_err(|e| werr(dir, e))?;
        for (name, data) in &self.files {
            let path = dir.join(name);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| werr(parent, e))?;
            }
            let file = path
                .file_name()
                .map(|f| f.to_string_lossy().to_string())
                .unwrap_or_default();
            let tmp = path.with_file_name(format!(".{file}.partial"));
            std::fs::write(&tmp, data).map_err(|e| werr(&tmp, e))?;
            std::fs::rename(&tmp, &path).map_err(|e| werr(&path, e))?;
        }
        Ok(())
    }
}

/// The folder `dir` lives in (`.` for a bare name).
fn parent_of(dir: &Path) -> PathBuf {
    match dir.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn name_of(dir: &Path) -> String {
    dir.file_name()
        .map(|f| f.to_string_lossy().to_string())
        .unwrap_or_else(|| "out".into())
}

fn pid_alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists()
}

/// Create a fresh, empty staging folder next to `dir` (`.NAME.partial-PID-K`), removing staging folders
/// of the same target left by processes that no longer run.
pub fn stage_for(dir: &Path) -> Result<PathBuf, ExpError> {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let parent = parent_of(dir);
    std::fs::create_dir_all(&parent).map_err(|e| werr(&parent, e))?;
    let name = name_of(dir);
    let prefix = format!(".{name}.partial-");
    if let Ok(entries) = std::fs::read_dir(&parent) {
        for e in entries.flatten() {
            let f = e.file_name().to_string_lossy().to_string();
            let Some(rest) = f.strip_prefix(&prefix) else {
                continue;
            };
            let pid = rest.split('-').next().and_then(|p| p.parse::<u32>().ok());
            if pid.is_some_and(|p| !pid_alive(p)) && e.path().join(MANIFEST).is_file() {
                let _ = std::fs::remove_dir_all(e.path());
            }
        }
    }
    let k = COUNTER.fetch_add(1, Ordering::Relaxed);
    let stage = parent.join(format!("{prefix}{}-{k}", std::process::id()));
    if stage.exists() {
        std::fs::remove_dir_all(&stage).map_err(|e| werr(&stage, e))?;
    }
    std::fs::create_dir(&stage).map_err(|e| werr(&stage, e))?;
    // mark it as ours at once, so a later run may clean it up if this one is interrupted
    std::fs::write(stage.join(MANIFEST), format!("{MANIFEST_HEADER}\n"))
        .map_err(|e| werr(&stage, e))?;
    Ok(stage)
}

/// Every file under `dir`, as paths relative to it (sorted).
fn files_under(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(dir.join(&rel)) else {
            continue;
        };
        for e in entries.flatten() {
            let r = rel.join(e.file_name());
            match e.file_type() {
                Ok(t) if t.is_dir() => stack.push(r),
                Ok(_) => out.push(r),
                Err(_) => {}
            }
        }
    }
    out.sort();
    out
}

/// The files a run folder's manifest lists, or `None` when `dir` has no manifest.
pub fn read_manifest(dir: &Path) -> Option<BTreeSet<PathBuf>> {
    // a regular file only: a FIFO named like the manifest would block the read forever
    if !dir.join(MANIFEST).is_file() {
        return None;
    }
    let text = std::fs::read_to_string(dir.join(MANIFEST)).ok()?;
    Some(
        text.lines()
            .filter(|l| !l.starts_with('#') && !l.is_empty())
            .map(PathBuf::from)
            .collect(),
    )
}

/// Rewrite the manifest of the run folder `dir` to list `files` (paths relative to `dir`), through a
/// temporary file renamed into place.
pub(crate) fn write_manifest(dir: &Path, files: &BTreeSet<PathBuf>) -> Result<(), ExpError> {
    let mut text = String::from(MANIFEST_HEADER);
    text.push('\n');
    for f in files {
        text.push_str(&f.to_string_lossy());
        text.push('\n');
    }
    let tmp = dir.join(format!("{MANIFEST}.partial"));
    std::fs::write(&tmp, text).map_err(|e| werr(&tmp, e))?;
    let path = dir.join(MANIFEST);
    std::fs::rename(&tmp, &path).map_err(|e| werr(&path, e))
}

/// `dir` without a trailing `/` or `/.` (through which the OS would follow a symbolic link).
fn normalized(dir: &Path) -> PathBuf {
    dir.components().collect()
}

/// Where `dir` points when it (its last component) is a symbolic link.
fn symlink_target(dir: &Path) -> Option<PathBuf> {
    let d = normalized(dir);
    if d.is_symlink() {
        Some(std::fs::read_link(&d).unwrap_or(d))
    } else {
        None
    }
}

/// `path` made absolute with every symbolic link resolved, also when its last components do not exist
/// yet: component by component, each existing prefix canonicalized, `..` after a missing folder taken
/// lexically (as creating the missing folders first would make it).
pub(crate) fn resolved(path: &Path) -> Option<PathBuf> {
    use std::path::Component;
    let abs = if path.is_absolute() {
        path.to_path_buf()
    } else {
        std::env::current_dir().ok()?.join(path)
    };
    let mut cur = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::Prefix(_) | Component::RootDir => cur.push(c.as_os_str()),
            Component::CurDir => {}
            Component::ParentDir => {
                cur.pop();
            }
            Component::Normal(name) => {
                cur.push(name);
                if let Ok(canon) = cur.canonicalize() {
                    cur = canon;
                }
            }
        }
    }
    Some(cur)
}

/// Refuse an output folder `out` that would overwrite an input folder `input` (named by its flag, e.g.
/// `--plan`) before any work: `out` is that folder (also through a symbolic link), or holds it (a run
/// replaces the files of its output folder, and the input's files would be among them); with
/// `refuse_inside`, also an `out` inside `input` (a run must not add folders to its input). Paths are
/// compared canonicalized; `out` need not exist yet.
pub fn check_out_apart(
    out: &Path,
    input: &Path,
    flag: &str,
    refuse_inside: bool,
) -> Result<(), ExpError> {
    let (Some(o), Some(i)) = (resolved(out), resolved(input)) else {
        return Ok(());
    };
    let relation = if o == i {
        "is the same folder as"
    } else if i.starts_with(&o) {
        "holds"
    } else if refuse_inside && o.starts_with(&i) {
        "lies inside"
    } else {
        return Ok(());
    };
    Err(ExpError::OutDir {
        path: out.to_path_buf(),
        reason: format!(
            "--out {relation} the {flag} folder {}: the run would replace or change the files it \
             reads; choose an --out outside it",
            input.display()
        ),
    })
}

/// Refuse an output folder before any work: a symbolic link (with or without `force`), a path that
/// exists but is not a folder, a non-empty folder that is not a brachia run folder (unless `force`), or a
/// place where nothing can be written.
pub fn check_out_dir(dir: &Path, force: bool) -> Result<(), ExpError> {
    let bad = |reason: String| ExpError::OutDir {
        path: dir.to_path_buf(),
        reason,
    };
    if let Some(target) = symlink_target(dir) {
        return Err(bad(format!(
            "is a symbolic link (to {}); --out must be a real folder, not a link: pass the folder it \
             points to (a run replaces --out, and would replace the link and move your files)",
            target.display()
        )));
    }
    if dir.exists() || dir.is_symlink() {
        if !dir.is_dir() {
            return Err(bad(
                "exists and is not a folder; --out needs a folder (new, empty or a brachia run folder)"
                    .into(),
            ));
        }
        let empty = std::fs::read_dir(dir)
            .map_err(|e| bad(format!("cannot be read: {e}")))?
            .next()
            .is_none();
        if !empty && !dir.join(MANIFEST).is_file() && !force {
            return Err(bad(format!(
                "is not empty and is not a brachia run folder (it has no {MANIFEST}); choose a new \
                 folder, or pass --force to write into it (its files are kept, a clashing name is kept \
                 as NAME.user)"
            )));
        }
    }
    // the staging folder is created next to the target: probe the nearest existing ancestor
    let mut anc = parent_of(dir);
    while !anc.exists() {
        match anc.parent() {
            Some(p) if !p.as_os_str().is_empty() => anc = p.to_path_buf(),
            _ => {
                anc = PathBuf::from(".");
                break;
            }
        }
    }
    if !anc.is_dir() {
        return Err(bad(format!(
            "{} is not a folder, so nothing can be created there",
            anc.display()
        )));
    }
    let probe = anc.join(format!(".brachia-probe-{}", std::process::id()));
    match std::fs::create_dir(&probe) {
        Ok(()) => {
            let _ = std::fs::remove_dir(&probe);
        }
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
        Err(e) => {
            return Err(bad(format!(
                "nothing can be written in {}: {e}",
                anc.display()
            )))
        }
    }
    if dir.is_dir() {
        let probe = dir.join(format!(".brachia-probe-{}", std::process::id()));
        match std::fs::create_dir(&probe) {
            Ok(()) => {
                let _ = std::fs::remove_dir(&probe);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(bad(format!("nothing can be written in it: {e}"))),
        }
    }
    Ok(())
}

/// Write the manifest of the finished staging folder `stage` and move it into place as `dir` (see the
/// module docs). Files of a previous run folder at `dir` that its manifest does not list are moved into
/// the new folder; nothing but files brachia wrote is ever removed.
pub fn install(stage: &Path, dir: &Path) -> Result<(), ExpError> {
    let installed = install_stage(stage, dir);
    if installed.is_err() && stage.is_dir() {
        // not renamed into place: nothing of this run may be left behind
        let _ = std::fs::remove_dir_all(stage);
    }
    installed
}

fn install_stage(stage: &Path, dir: &Path) -> Result<(), ExpError> {
    if let Some(target) = symlink_target(dir) {
        return Err(ExpError::OutDir {
            path: dir.to_path_buf(),
            reason: format!(
                "is a symbolic link (to {}); --out must be a real folder",
                target.display()
            ),
        });
    }
    let mut manifest = String::from(MANIFEST_HEADER);
    manifest.push('\n');
    for f in files_under(stage) {
        if f != Path::new(MANIFEST) {
            manifest.push_str(&f.to_string_lossy());
            manifest.push('\n');
        }
    }
    let mpath = stage.join(MANIFEST);
    std::fs::write(&mpath, manifest).map_err(|e| werr(&mpath, e))?;
    if !(dir.exists() || dir.is_symlink()) {
        return std::fs::rename(stage, dir).map_err(|e| werr(dir, e));
    }
    if !dir.is_dir() {
        return Err(ExpError::OutDir {
            path: dir.to_path_buf(),
            reason: "exists and is not a folder".into(),
        });
    }
    let empty = std::fs::read_dir(dir)
        .map_err(|e| werr(dir, e))?
        .next()
        .is_none();
    if empty {
        std::fs::remove_dir(dir).map_err(|e| werr(dir, e))?;
        return std::fs::rename(stage, dir).map_err(|e| werr(dir, e));
    }
    let ours = read_manifest(dir).unwrap_or_default();
    let old = parent_of(dir).join(format!(".{}.old-{}", name_of(dir), std::process::id()));
    if old.exists() {
        std::fs::remove_dir_all(&old).map_err(|e| werr(&old, e))?;
    }
    std::fs::rename(dir, &old).map_err(|e| werr(dir, e))?;
    if let Err(e) = std::fs::rename(stage, dir) {
        let _ = std::fs::rename(&old, dir);
        return Err(werr(dir, e));
    }
    // the user's files come along into the new folder
    let mut kept_all = true;
    for rel in files_under(&old) {
        if rel == Path::new(MANIFEST) || ours.contains(&rel) {
            continue;
        }
        let mut to = dir.join(&rel);
        if to.exists() || to.is_symlink() {
            let f = to
                .file_name()
                .unwrap_or_default()
                .to_string_lossy()
                .to_string();
            to = to.with_file_name(format!("{f}.user"));
        }
        let moved = to
            .parent()
            .map_or(Ok(()), std::fs::create_dir_all)
            .and_then(|()| std::fs::rename(old.join(&rel), &to));
        if moved.is_err() {
            kept_all = false;
        }
    }
    if kept_all {
        std::fs::remove_dir_all(&old).map_err(|e| werr(&old, e))?;
        Ok(())
    } else {
        Err(ExpError::OutDir {
            path: dir.to_path_buf(),
            reason: format!(
                "the new results are in place, but some of your files could not be moved back from {}: \
                 they are still there",
                old.display()
            ),
        })
    }
}
