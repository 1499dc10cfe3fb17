//! A run killed outright (SIGKILL: no handler runs, nothing is cleaned up) at any moment of its work,
//! alone or while other runs work on the same folder.
//! Each test makes a complete result first, adds files of the user's beside and inside it, then
//! starts the same command again and kills it with `kill -9` at several points of a full run's
//! duration (planning, drawing, writing). After every kill:
//! - the output folder holds one complete result: every file its manifest lists is there with the
//!   listed size and CRC-32, and no file is there that neither the manifest nor the user put there;
//! - the user's files are as they were (none deleted, changed or moved aside).
//!
//! After the kills the next run succeeds and leaves no staging folder anywhere: not beside the
//! output, not inside it, not in the temporary folder (`TMPDIR` is a folder of the test's own).

mod common;

use common::brachia;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// CRC-32 (IEEE), as the run-folder manifest records it.
fn crc32(data: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in data {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0xEDB8_8320
            } else {
                c >> 1
            };
        }
    }
    !c
}

/// Every file under `dir` (relative path, contents), links and folders not followed.
fn files_under(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![PathBuf::new()];
    while let Some(rel) = stack.pop() {
        for e in std::fs::read_dir(dir.join(&rel)).unwrap().flatten() {
            let r = rel.join(e.file_name());
            let t = e.file_type().unwrap();
            if t.is_dir() {
                stack.push(r);
            } else {
                out.insert(r, std::fs::read(e.path()).unwrap_or_default());
            }
        }
    }
    out
}

/// Names of staging folders, lock files and half-written files anywhere under `dirs`.
fn staging_left(dirs: &[&Path]) -> Vec<String> {
    let mut v = Vec::new();
    let mut stack: Vec<PathBuf> = dirs.iter().map(|d| d.to_path_buf()).collect();
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let name = e.file_name().to_string_lossy().to_string();
            if name.contains(".partial")
                || name.starts_with(".brachia-stage")
                || name.starts_with(".brachia-traverse-")
                || name.starts_with(".brachia-probe")
                || name.contains(".old-")
                || name.ends_with(".user")
            {
                v.push(e.path().display().to_string());
            }
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(e.path());
            }
        }
    }
    v
}

/// The files of the user's put into and beside the output folder `out`.
fn user_files(out: &Path) -> Vec<(PathBuf, &'static [u8])> {
    let files: Vec<(PathBuf, &'static [u8])> = vec![
        (out.join("notes.txt"), b"the user's notes\n"),
        (out.join("mine/data.csv"), b"1,2,3\n"),
        (out.parent().unwrap().join("beside.txt"), b"beside\n"),
    ];
    for (p, data) in &files {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, data).unwrap();
    }
    files
}

/// `out` holds one complete result: the manifest's files with their listed size and CRC-32, the
/// user's files unchanged, and nothing else.
fn assert_one_complete_result(out: &Path, user: &[(PathBuf, &[u8])], when: &str) {
    let all = files_under(out);
    let manifest = String::from_utf8(all[Path::new(".brachia-run")].clone()).unwrap();
    let mut listed = Vec::new();
    for line in manifest.lines().filter(|l| !l.starts_with('#')) {
        let mut parts = line.splitn(3, ' ');
        let (size, crc, rel) = (
            parts.next().unwrap(),
            parts.next().unwrap(),
            parts.next().unwrap(),
        );
        let data = all
            .get(Path::new(rel))
            .unwrap_or_else(|| panic!("{when}: {rel}, listed in the manifest, is missing"));
        assert_eq!(data.len().to_string(), size, "{when}: size of {rel}");
        assert_eq!(
            format!("{:08x}", crc32(data)),
            crc.to_lowercase(),
            "{when}: {rel} is not the file the manifest lists (half-written?)"
        );
        listed.push(PathBuf::from(rel));
    }
    assert!(!listed.is_empty(), "{when}: an empty manifest");
    for (p, data) in user {
        assert_eq!(
            std::fs::read(p).ok().as_deref(),
            Some(*data),
            "{when}: the user's file {} was changed or lost",
            p.display()
        );
    }
    for rel in all.keys() {
        let user_file = user.iter().any(|(p, _)| p == &out.join(rel));
        // a killed run's staging folder (cleared by the next run; checked after it)
        let staged = rel
            .components()
            .any(|c| c.as_os_str().to_string_lossy().contains(".partial-"));
        assert!(
            rel == Path::new(".brachia-run") || listed.contains(rel) || user_file || staged,
            "{when}: {} is in the output folder but in no result",
            rel.display()
        );
    }
}

/// The command `args` with `TMPDIR` set to `tmp`.
fn command(args: &[&std::ffi::OsStr], tmp: &Path) -> Command {
    let mut c = brachia();
    c.args(args).env("TMPDIR", tmp);
    c
}

/// Run `args` to the end; returns how long it took.
fn run_ok(args: &[&std::ffi::OsStr], tmp: &Path) -> Duration {
    let t = Instant::now();
    let o = command(args, tmp).output().unwrap();
    assert!(
        o.status.success(),
        "exit {:?}: {}",
        o.status.code(),
        String::from_utf8_lossy(&o.stderr)
    );
    t.elapsed()
}

/// When a run is killed.
#[derive(Debug, Clone)]
enum Kill {
    /// This fraction of a full run's duration after its start.
    After(f64),
    /// This long (ms) after an entry whose name starts with the prefix appears in the folder (a
    /// staging folder: the run is drawing or writing).
    When(PathBuf, &'static str, u64),
}

/// Whether `dir` has an entry whose name starts with `prefix`.
fn has_entry(dir: &Path, prefix: &str) -> bool {
    std::fs::read_dir(dir)
        .into_iter()
        .flatten()
        .flatten()
        .any(|e| e.file_name().to_string_lossy().starts_with(prefix))
}

/// Start `args` and kill it with SIGKILL as `kill` says (a run of a full run's duration `full`), if
/// it is still running then; true when it was killed.
fn kill_at(args: &[&std::ffi::OsStr], tmp: &Path, kill: &Kill, full: Duration) -> bool {
    let mut child = command(args, tmp)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut seen: Option<Instant> = None;
    loop {
        if child.try_wait().unwrap().is_some() {
            return false;
        }
        let due = match kill {
            Kill::After(f) => start.elapsed() >= full.mul_f64(*f),
            Kill::When(dir, prefix, ms) => {
                if seen.is_none() && has_entry(dir, prefix) {
                    seen = Some(Instant::now());
                }
                seen.is_some_and(|t| t.elapsed() >= Duration::from_millis(*ms))
            }
        };
        if due {
            break;
        }
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    true
}

/// The whole check for one command writing the run folder `out` (`check` is the folder whose
/// result is judged; `out` unless the command redraws a folder in place).
fn killed_at_every_point(args: &[&std::ffi::OsStr], out: &Path, points: &[Kill], tmp: &Path) {
    let full = run_ok(args, tmp);
    let user = user_files(out);
    assert_one_complete_result(out, &user, "after the first run");
    let mut killed = 0;
    for k in points {
        if kill_at(args, tmp, k, full) {
            killed += 1;
        }
        assert_one_complete_result(out, &user, &format!("after a kill ({k:?})"));
    }
    assert!(killed > 0, "no run was killed: the work is too short");
    run_ok(args, tmp);
    assert_one_complete_result(out, &user, "after the next run");
    let left = staging_left(&[out.parent().unwrap(), tmp]);
    assert!(left.is_empty(), "left behind after the next run: {left:?}");
    eprintln!(
        "{:?}: a full run {full:?}, killed {killed} of {} times",
        args[0],
        points.len()
    );
}

/// A fresh folder holding `tmp/` (the runs' temporary folder) and `plan/`, the plan folder of
/// scenarios/tracking.toml.
fn planned_folder() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let plan = dir.path().join("plan");
    run_ok(
        &[
            os("plan"),
            os("--scenario"),
            os("scenarios/tracking.toml"),
            os("--out"),
            plan.as_os_str(),
        ],
        &tmp,
    );
    (dir, tmp, plan)
}

fn os(s: &str) -> &std::ffi::OsStr {
    std::ffi::OsStr::new(s)
}

#[test]
fn a_simulation_killed_at_any_point_keeps_the_previous_result() {
    let dir = tempfile::tempdir().unwrap();
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let out = dir.path().join("runs/sim");
    let args = [
        os("simulate"),
        os("--params"),
        os("params/paper.toml"),
        os("--q0=-2.35,0,-1.55,0"),
        os("--duration"),
        os("20"),
        os("--out"),
        out.as_os_str(),
    ];
    let runs = dir.path().join("runs");
    let points = [
        Kill::After(0.1),
        Kill::After(0.4),
        Kill::After(0.7),
        Kill::When(runs.clone(), ".sim.partial-", 0),
        Kill::When(runs.clone(), ".sim.partial-", 2),
        Kill::After(0.95),
    ];
    killed_at_every_point(&args, &out, &points, &tmp);
}

#[test]
fn a_report_killed_while_drawing_leaves_nothing_the_next_one_keeps() {
    let (_dir, tmp, plan) = planned_folder();
    let args = [os("report"), plan.as_os_str()];
    let points = [
        Kill::After(0.2),
        Kill::When(plan.clone(), ".report.partial-", 0),
        Kill::When(plan.clone(), ".report.partial-", 100),
        Kill::When(plan.clone(), ".report.partial-", 400),
        Kill::After(0.95),
    ];
    killed_at_every_point(&args, &plan, &points, &tmp);
}

#[test]
fn a_traverse_killed_while_drawing_leaves_no_temporary_folder_behind() {
    let dir = tempfile::tempdir().unwrap();
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let out = dir.path().join("traverse");
    let args = [
        os("traverse"),
        os("--scenario"),
        os("scenarios/ladder-even.toml"),
        os("--no-view"),
        os("--out"),
        out.as_os_str(),
    ];
    // killed while planning, while drawing its figures in the temporary folder, and while writing
    let points = [
        Kill::After(0.3),
        Kill::When(tmp.clone(), ".brachia-traverse-", 50),
        Kill::When(tmp.clone(), ".brachia-traverse-", 500),
        Kill::When(dir.path().to_path_buf(), ".traverse.partial-", 0),
    ];
    killed_at_every_point(&args, &out, &points, &tmp);
}

/// Overlapping runs on one folder, one of them killed: two `report`s and a `view` of one plan folder
/// at once, with a third `report` killed in the middle. Every surviving run exits 0, and the folder
/// holds one complete result, the user's files unchanged, no staging folder left.
#[test]
fn overlapping_reports_and_views_with_one_killed_leave_one_complete_result() {
    let (dir, tmp, plan) = planned_folder();
    let user = user_files(&plan);
    let report = [os("report"), plan.as_os_str()];
    let view = [os("view"), plan.as_os_str()];
    let full = run_ok(&report, &tmp);
    for round in 0..2 {
        let spawn = |args: &[&std::ffi::OsStr]| {
            command(args, &tmp)
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        };
        let runs = [spawn(&report), spawn(&view), spawn(&report)];
        let killed = kill_at(
            &report,
            &tmp,
            &Kill::When(plan.clone(), ".report.partial-", 100),
            full,
        );
        for r in runs {
            let o = r.wait_with_output().unwrap();
            assert!(
                o.status.success(),
                "round {round}: exit {:?}: {}",
                o.status.code(),
                String::from_utf8_lossy(&o.stderr)
            );
        }
        assert_one_complete_result(&plan, &user, &format!("round {round} (killed: {killed})"));
    }
    run_ok(&report, &tmp);
    assert_one_complete_result(&plan, &user, "after the last report");
    let left = staging_left(&[dir.path(), &tmp]);
    assert!(left.is_empty(), "left behind: {left:?}");
}

/// `copies` runs of `args` at once; each must exit 0 (the caller checks what they left).
fn all_at_once(args: &[&std::ffi::OsStr], tmp: &Path, copies: usize) {
    let runs: Vec<_> = (0..copies)
        .map(|_| {
            command(args, tmp)
                .stdout(Stdio::null())
                .stderr(Stdio::piped())
                .spawn()
                .unwrap()
        })
        .collect();
    for r in runs {
        let o = r.wait_with_output().unwrap();
        assert!(
            o.status.success(),
            "{:?}: exit {:?}: {}",
            args[0],
            o.status.code(),
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

/// Every entry of `dir` (names), sorted.
fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    v.sort();
    v
}

#[test]
fn robot_exports_and_imports_onto_one_file_at_once_leave_one_whole_file() {
    let dir = tempfile::tempdir().unwrap();
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    std::fs::write(dir.path().join("mine.txt"), "the user's").unwrap();
    let urdf = dir.path().join("paper.urdf");
    let export = [
        os("robot"),
        os("export"),
        os("--params"),
        os("params/paper.toml"),
        os("--format"),
        os("urdf"),
        os("--force"),
        os("--out"),
        urdf.as_os_str(),
    ];
    run_ok(&export, &tmp);
    let whole = std::fs::read(&urdf).unwrap();
    all_at_once(&export, &tmp, 6);
    assert_eq!(
        std::fs::read(&urdf).unwrap(),
        whole,
        "a torn or mixed export"
    );
    let toml = dir.path().join("paper.toml");
    let import = [
        os("robot"),
        os("import"),
        urdf.as_os_str(),
        os("--grip"),
        os("grip"),
        os("--tip"),
        os("tip"),
        os("--force"),
        os("--out"),
        toml.as_os_str(),
    ];
    run_ok(&import, &tmp);
    let whole = std::fs::read(&toml).unwrap();
    all_at_once(&import, &tmp, 6);
    assert_eq!(
        std::fs::read(&toml).unwrap(),
        whole,
        "a torn or mixed import"
    );
    assert_eq!(
        names(dir.path()),
        ["mine.txt", "paper.toml", "paper.urdf", "tmp"],
        "files appeared beside the outputs"
    );
    assert_eq!(
        std::fs::read_to_string(dir.path().join("mine.txt")).unwrap(),
        "the user's"
    );
}

#[test]
fn views_of_one_folder_at_once_leave_one_page_listed() {
    let dir = tempfile::tempdir().unwrap();
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let out = dir.path().join("sim");
    run_ok(
        &[
            os("simulate"),
            os("--params"),
            os("params/paper.toml"),
            os("--q0=-2.35,0,-1.55,0"),
            os("--duration"),
            os("1"),
            os("--out"),
            out.as_os_str(),
        ],
        &tmp,
    );
    let user = user_files(&out);
    all_at_once(&[os("view"), out.as_os_str()], &tmp, 6);
    assert_one_complete_result(&out, &user, "after six views at once");
    let left = staging_left(&[dir.path()]);
    assert!(left.is_empty(), "left behind: {left:?}");
}
