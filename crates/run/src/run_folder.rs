//! Run folders, written so that nothing is ever half-written and no file but brachia's own is ever
//! removed or replaced.
//!
//! Every file of a run is queued in memory and written at the end into a *staging folder* next to the
//! target (`.NAME.partial-PID-K`, created afresh by this run). Only when everything is written is it
//! installed, under an exclusive lock held on the target folder (so two runs into one folder install one
//! after the other, never interleaved):
//! - each new file is renamed into the target folder, which is created if missing and otherwise kept as
//!   it is (its permissions, the user's files and empty sub-folders stay);
//! - a name that clashes with a file the previous run did not provably write (the user's) moves that file
//!   aside as `NAME.user` (or `NAME.user.2`, ...) first; nothing is overwritten;
//! - the files of the previous run that this run did not write again are removed, but only those brachia
//!   can prove it wrote ([`crate::manifest::proven`]: listed in the manifest [`MANIFEST`], a plain file
//!   inside the folder, of the listed size and CRC-32);
//! - last, the manifest is rewritten to list the new files.
//!
//! A non-empty folder without a manifest is refused by [`check_out_dir`] unless `force` is given. An
//! interrupted run leaves the previous results as they were (and, when it was killed outright, a hidden
//! staging folder, whose provable files the next run into the same place removes).

use crate::manifest::{self, manifest_text, proven_files, Stamp};
use crate::ExpError;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

pub use crate::manifest::MANIFEST;

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

/// A name no other write of this process uses (`PID-K`).
fn unique() -> String {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    format!(
        "{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    )
}

impl RunFolder {
    /// Queue a file (a name relative to the run folder; may contain `/`). A JSON object or a CSV file
    /// gets its schema version ([`crate::schema::stamp`]).
    pub fn add(&mut self, name: &str, contents: impl Into<Vec<u8>>) {
        let data = crate::schema::stamp(name, contents.into());
        self.files.push((name.to_string(), data));
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

    /// Write the run folder `dir`: into a staging folder next to it, then installed in place (see the
    /// module docs; the user's files, sub-folders and the folder's permissions are kept).
    pub fn write(&self, dir: &Path) -> Result<(), ExpError> {
        let stage = stage_for(dir)?;
        let written = list_in_stage(self, &stage).and_then(|()| self.write_into(&stage));
        match written {
            // install removes the staging folder itself
            Ok(()) => install(&stage, dir),
            Err(e) => {
                crate::staging::remove(&stage);
                Err(e)
            }
        }
    }

    /// Write every file into the folder `dir` (created if missing), each under a fresh temporary name
    /// renamed into place; other files in `dir` are left alone. Every name must be a plain relative
    /// path (no `..`, no absolute path). For staging folders and for pages published into folders that
    /// also hold the user's files.
    pub fn write_into(&self, dir: &Path) -> Result<(), ExpError> {
        std::fs::create_dir_all(dir).map_err(|e| werr(dir, e))?;
        for (name, data) in &self.files {
            let Some(rel) = manifest::inside_rel(name) else {
                return Err(ExpError::OutDir {
                    path: dir.join(name),
                    reason: "a file of a run must lie inside its folder".into(),
                });
            };
            let path = dir.join(&rel);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| werr(parent, e))?;
            }
            let file = path
                .file_name()
                .map(|f| f.to_string_lossy().to_string())
                .unwrap_or_default();
            let tmp = path.with_file_name(format!(".{file}.partial-{}", unique()));
            let created = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&tmp)
                .and_then(|mut f| std::io::Write::write_all(&mut f, data));
            if let Err(e) = created {
                let _ = std::fs::remove_file(&tmp);
                return Err(werr(&tmp, e));
            }
            std::fs::rename(&tmp, &path).map_err(|e| {
                let _ = std::fs::remove_file(&tmp);
                werr(&path, e)
            })?;
        }
        Ok(())
    }
}

/// Write the manifest of the staging folder `stage` listing every file of `folder` (size and CRC-32)
/// before they are written: a run killed half-way leaves a staging folder whose files the next run
/// can prove are brachia's.
pub fn list_in_stage(folder: &RunFolder, stage: &Path) -> Result<(), ExpError> {
    let stamps: BTreeMap<PathBuf, Stamp> = folder
        .files
        .iter()
        .filter_map(|(n, d)| manifest::inside_rel(n).map(|p| (p, Stamp::of(d))))
        .collect();
    std::fs::write(stage.join(MANIFEST), manifest_text(&stamps)).map_err(|e| werr(stage, e))
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

/// Create a fresh, empty staging folder next to `dir` (`.NAME.partial-PID-K`, a name no folder has
/// yet), first clearing staging folders of the same target left by processes that no longer run (only
/// the files their manifest proves are brachia's).
pub fn stage_for(dir: &Path) -> Result<PathBuf, ExpError> {
    let parent = parent_of(dir);
    std::fs::create_dir_all(&parent).map_err(|e| werr(&parent, e))?;
    let name = name_of(dir);
    let prefix = format!(".{name}.partial-");
    // staging folders brachia marked whose owner died (crate::staging); then unmarked ones of a
    // process that no longer runs, cleared of what their manifests prove
    for stale in crate::staging::clear_stale(&parent, &prefix) {
        let rest = stale
            .file_name()
            .map(|f| f.to_string_lossy().to_string())
            .unwrap_or_default();
        let pid = rest[prefix.len().min(rest.len())..]
            .split('-')
            .next()
            .and_then(|p| p.parse::<u32>().ok());
        if pid.is_some_and(|p| !pid_alive(p)) {
            remove_stale_stage(&stale);
        }
    }
    // a report's drawing killed inside this run folder, and a traverse's drawing folder
    crate::staging::clear_stale(dir, crate::staging::REPORT_STAGE_PREFIX);
    crate::staging::clear_stale(&std::env::temp_dir(), crate::staging::DRAW_STAGE_PREFIX);
    loop {
        let stage = parent.join(format!("{prefix}{}", unique()));
        match crate::staging::create(&stage) {
            Ok(()) => {
                // list it as a run folder at once (an empty listing until its files are known)
                std::fs::write(stage.join(MANIFEST), manifest_text(&BTreeMap::new()))
                    .map_err(|e| werr(&stage, e))?;
                return Ok(stage);
            }
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(werr(&stage, e)),
        }
    }
}

/// Clear the staging folder `stage` of a run that no longer runs: in it and in every folder under it
/// that holds a manifest (the run folders a reproduction had written into its stage, a nested staging
/// folder), remove the files that manifest proves brachia wrote, then the manifest; then every folder
/// left empty. Anything else stays.
fn remove_stale_stage(stage: &Path) {
    let (_, dirs) = entries_under(stage);
    // deepest first, so a folder's manifest is read before its parent's clearing could touch it
    for rel in std::iter::once(PathBuf::new()).chain(dirs).rev() {
        let dir = stage.join(&rel);
        if let Ok(Some(m)) = manifest::read_manifest(&dir) {
            for f in proven_files(&dir, &m) {
                let _ = std::fs::remove_file(dir.join(f));
            }
            if manifest::plain_file(&dir, Path::new(MANIFEST)) {
                let _ = std::fs::remove_file(dir.join(MANIFEST));
            }
        }
    }
    let (_, dirs) = entries_under(stage);
    // deepest first; remove_dir removes only an empty folder
    for d in dirs.iter().rev() {
        let _ = std::fs::remove_dir(stage.join(d));
    }
    let _ = std::fs::remove_dir(stage);
}

/// Every file (not a folder) and every folder under `dir`, as paths relative to it, without following
/// symbolic links (a link is listed as a file); folders listed parents first.
fn entries_under(dir: &Path) -> (Vec<PathBuf>, Vec<PathBuf>) {
    let (mut files, mut dirs) = (Vec::new(), Vec::new());
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(dir.join(&rel)) else {
            continue;
        };
        for e in entries.flatten() {
            let r = rel.join(e.file_name());
            match e.file_type() {
                Ok(t) if t.is_dir() => {
                    dirs.push(r.clone());
                    stack.push(r);
                }
                Ok(_) => files.push(r),
                Err(_) => {}
            }
        }
    }
    files.sort();
    dirs.sort_by_key(|d| d.components().count());
    (files, dirs)
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
pub fn resolved(path: &Path) -> Option<PathBuf> {
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

/// Refuse an `--out` written so that it names a folder only through `.` or `..` (`.`, `EMPTY/.`,
/// `SUB/..`), the current folder or one of its ancestors (a run would write among the files it was
/// started from), or the root.
pub fn check_out_form(dir: &Path) -> Result<(), ExpError> {
    let bad = |reason: String| ExpError::OutDir {
        path: dir.to_path_buf(),
        reason,
    };
    let text = dir.to_string_lossy();
    let trimmed = text.trim_end_matches('/');
    let last = trimmed.rsplit('/').next().unwrap_or("");
    if text.is_empty() {
        return Err(bad("is empty; --out needs a folder name".into()));
    }
    if trimmed.is_empty() || last == "." || last == ".." {
        return Err(bad(
            "ends in `.`, `..` or is the root; --out must name its folder plainly (e.g. runs/swing), \
             not through `.` or `..`"
                .into(),
        ));
    }
    let (Some(out), Some(cwd)) = (resolved(dir), std::env::current_dir().ok()) else {
        return Ok(());
    };
    let cwd = cwd.canonicalize().unwrap_or(cwd);
    if cwd.starts_with(&out) {
        return Err(bad(format!(
            "is the current folder or one of its ancestors ({}); --out must be a folder of its own \
             (e.g. runs/swing)",
            out.display()
        )));
    }
    Ok(())
}

/// Refuse an output folder before any work: `--out` forms [`check_out_form`] refuses, a symbolic link (with or without `force`), a path that
/// exists but is not a folder, a non-empty folder that is not a brachia run folder (unless `force`), or a
/// place where nothing can be written.
pub fn check_out_dir(dir: &Path, force: bool) -> Result<(), ExpError> {
    let bad = |reason: String| ExpError::OutDir {
        path: dir.to_path_buf(),
        reason,
    };
    check_out_form(dir)?;
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
        // a manifest brachia cannot read (another schema, a path leaving the folder) is refused here,
        // before any work
        manifest::read_manifest(dir)?;
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

/// Install the finished staging folder `stage` (created by [`stage_for`] in this run) as the run folder
/// `dir` (see the module docs): under an exclusive lock on `dir`, every file of `stage` is renamed into
/// `dir`, the previous run's provable files that were not written again are removed, and the manifest
/// is rewritten. The staging folder is removed in every case.
pub fn install(stage: &Path, dir: &Path) -> Result<(), ExpError> {
    let installed = install_stage(stage, dir);
    // created by this run; whatever is left in it was not installed
    crate::staging::remove(stage);
    installed
}

/// An exclusive lock on the folder `dir` (created if missing), held until dropped; waits for another
/// run's lock. Refused when `dir` is a symbolic link or is replaced while the lock is taken.
fn lock_dir(dir: &Path) -> Result<std::fs::File, ExpError> {
    use std::os::unix::fs::MetadataExt;
    let changed = |what: &str| ExpError::OutDir {
        path: dir.to_path_buf(),
        reason: format!("{what} while the run was writing; nothing was installed"),
    };
    loop {
        if let Some(target) = symlink_target(dir) {
            return Err(ExpError::OutDir {
                path: dir.to_path_buf(),
                reason: format!(
                    "is a symbolic link (to {}); --out must be a real folder",
                    target.display()
                ),
            });
        }
        match std::fs::create_dir(dir) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(werr(dir, e)),
        }
        let meta = std::fs::symlink_metadata(dir).map_err(|e| werr(dir, e))?;
        if !meta.is_dir() {
            return Err(changed("became something other than a folder"));
        }
        let f = std::fs::File::open(dir).map_err(|e| werr(dir, e))?;
        f.lock().map_err(|e| werr(dir, e))?;
        // the folder locked must still be the one at `dir` (not removed or replaced meanwhile)
        let held = f.metadata().map_err(|e| werr(dir, e))?;
        match std::fs::symlink_metadata(dir) {
            Ok(now) if now.is_dir() && now.ino() == held.ino() && now.dev() == held.dev() => {
                return Ok(f)
            }
            Ok(now) if now.is_dir() => continue,
            Ok(_) => return Err(changed("became something other than a folder")),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => continue,
            Err(e) => return Err(werr(dir, e)),
        }
    }
}

/// A free name beside `path` for a user's entry moved out of the way: `NAME.user`, `NAME.user.2`, ...
fn aside_name(path: &Path) -> PathBuf {
    let f = path
        .file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .to_string();
    let mut k = 1;
    loop {
        let name = if k == 1 {
            format!("{f}.user")
        } else {
            format!("{f}.user.{k}")
        };
        let p = path.with_file_name(name);
        if std::fs::symlink_metadata(&p).is_err() {
            return p;
        }
        k += 1;
    }
}

/// Move the user's entry at `path` (a file, link, folder or anything else) aside to a free name.
pub fn move_aside(path: &Path) -> Result<(), ExpError> {
    let to = aside_name(path);
    std::fs::rename(path, &to).map_err(|e| werr(&to, e))
}

/// Make `dir/rel`'s parent folders real folders inside `dir`: a missing one is created, a file or link
/// in the way (the user's) is moved aside.
fn make_parents(dir: &Path, rel: &Path) -> Result<(), ExpError> {
    let mut cur = dir.to_path_buf();
    let parts: Vec<_> = rel.components().collect();
    for c in &parts[..parts.len().saturating_sub(1)] {
        cur.push(c.as_os_str());
        match std::fs::symlink_metadata(&cur) {
            Ok(m) if m.is_dir() => continue,
            Ok(_) => move_aside(&cur)?,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(werr(&cur, e)),
        }
        std::fs::create_dir(&cur).map_err(|e| werr(&cur, e))?;
    }
    Ok(())
}

fn install_stage(stage: &Path, dir: &Path) -> Result<(), ExpError> {
    install_part(stage, dir, &|_| true).map(|_| ())
}

/// Install every file of the folder `stage` (a staging folder this run created) into the run folder
/// `dir`, under the lock on `dir`: a user's entry in the way is moved aside as `NAME.user`, a file the
/// previous run provably wrote is replaced; of the previous run's provable files that are not written
/// again, those `replaced` selects are removed and the others stay listed; the manifest is rewritten.
/// Returns the installed files (paths under `dir`).
pub fn install_part(
    stage: &Path,
    dir: &Path,
    replaced: &dyn Fn(&Path) -> bool,
) -> Result<Vec<PathBuf>, ExpError> {
    let (staged, _) = entries_under(stage);
    let mut stamps = BTreeMap::new();
    let own = |r: &&PathBuf| {
        r.as_path() != Path::new(MANIFEST) && r.as_path() != Path::new(crate::staging::STAGE_LOCK)
    };
    for rel in staged.iter().filter(own) {
        let from = stage.join(rel);
        let data = std::fs::read(&from).map_err(|e| werr(&from, e))?;
        stamps.insert(rel.clone(), Stamp::of(&data));
    }
    let dir = &normalized(dir);
    if std::fs::symlink_metadata(dir).is_err() {
        // a new folder: the staging folder, with its manifest, becomes it in one rename
        let mpath = stage.join(MANIFEST);
        std::fs::write(&mpath, manifest_text(&stamps)).map_err(|e| werr(&mpath, e))?;
        // the staging mark stays behind: the folder becomes a run folder (its manifest proves it)
        let _ = std::fs::remove_file(stage.join(crate::staging::STAGE_LOCK));
        match std::fs::rename(stage, dir) {
            Ok(()) => return Ok(stamps.keys().map(|r| dir.join(r)).collect()),
            // another run created it meanwhile: install into it under its lock
            Err(_) if std::fs::symlink_metadata(dir).is_ok() => {}
            Err(e) => return Err(werr(dir, e)),
        }
    }
    let _lock = lock_dir(dir)?;
    // read under the lock: what the previous run (perhaps one that just finished) provably wrote
    let previous = manifest::read_manifest(dir)?;
    if previous.is_none() {
        // mark the folder as a run folder before anything moves in
        write_manifest(dir, &BTreeMap::new())?;
    }
    let previous = previous.unwrap_or_default();
    let ours = proven_files(dir, &previous);
    let mut installed = Vec::with_capacity(stamps.len());
    for rel in stamps.keys() {
        make_parents(dir, rel)?;
        let to = dir.join(rel);
        match std::fs::symlink_metadata(&to) {
            Ok(m) if m.is_file() && ours.contains(rel) => {}
            Ok(_) => move_aside(&to)?,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(werr(&to, e)),
        }
        std::fs::rename(stage.join(rel), &to).map_err(|e| werr(&to, e))?;
        installed.push(to);
    }
    let mut listing = stamps;
    let gone: Vec<&PathBuf> = ours.iter().filter(|r| !listing.contains_key(*r)).collect();
    for rel in gone {
        if replaced(rel) {
            let p = dir.join(rel);
            std::fs::remove_file(&p).map_err(|e| werr(&p, e))?;
        } else if let Some(Some(s)) = previous.files.get(rel) {
            listing.insert(rel.clone(), *s);
        }
    }
    write_manifest(dir, &listing)?;
    Ok(installed)
}

/// Rewrite the manifest of the run folder `dir` to list `files` (paths relative to `dir` with their
/// stamps), through a fresh temporary file renamed into place. A manifest that is not a regular file
/// (the user's) is moved aside first.
pub(crate) fn write_manifest(dir: &Path, files: &BTreeMap<PathBuf, Stamp>) -> Result<(), ExpError> {
    let mut f = RunFolder::default();
    f.add(MANIFEST, manifest_text(files));
    let path = dir.join(MANIFEST);
    if let Ok(m) = std::fs::symlink_metadata(&path) {
        if !m.is_file() {
            move_aside(&path)?;
        }
    }
    f.write_into(dir)
}
