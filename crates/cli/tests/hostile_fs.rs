//! Hostile file-system inputs: nothing outside the output folder is ever touched, whatever a manifest,
//! a plan folder or a run folder read back says; concurrent runs into one `--out` lose no user file;
//! `--out` forms that name a folder only through `.` or `..` are refused before any work; a re-run keeps
//! the folder's permissions and the user's empty sub-folders; files of an unknown schema version are
//! refused. Each case checks the exit code, the message, and every user file byte for byte.

mod common;

use common::root;
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The corpus' plan run folder (as `brachia plan` writes it).
fn corpus_run() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile/runs/plan")
}

/// A plan folder the tracking scenario can track.
fn corpus_plan() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/hostile/plans/good")
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

/// brachia with `args`, run in `cwd`.
fn run_in(cwd: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_brachia"))
        .current_dir(cwd)
        .args(args)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// Assert exit 2 with every `needle` in stderr.
fn refused(o: &Output, needles: &[&str]) {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "{e}");
    assert!(!e.contains("panicked"), "{e}");
    for n in needles {
        assert!(e.contains(n), "stderr does not name `{n}`: {e}");
    }
}

/// A user file that must survive unchanged.
struct Keep(PathBuf, Vec<u8>);

impl Keep {
    fn new(p: PathBuf, data: &[u8]) -> Self {
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, data).unwrap();
        Keep(p, data.to_vec())
    }
    fn check(&self) {
        let now = std::fs::read(&self.0).unwrap_or_else(|e| panic!("{}: {e}", self.0.display()));
        assert_eq!(now, self.1, "{} was changed", self.0.display());
    }
}

fn params() -> String {
    root().join("params/paper.toml").display().to_string()
}

/// `brachia simulate` of 0.05 s into `out`, run in `cwd`.
fn simulate(cwd: &Path, out: &str) -> Output {
    let p = params();
    run_in(
        cwd,
        &[
            "simulate",
            "--params",
            &p,
            "--q0=-2.35,0,-1.55,0",
            "--duration",
            "0.05",
            "--out",
            out,
        ],
    )
}

/// Names left by an interrupted or interleaved run.
fn leftovers(dir: &Path) -> Vec<String> {
    let mut v = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).into_iter().flatten().flatten() {
            let n = e.file_name().to_string_lossy().to_string();
            if n.contains(".partial") || n.contains(".old-") || n.contains("brachia-probe") {
                v.push(e.path().display().to_string());
            }
            if e.file_type().is_ok_and(|t| t.is_dir()) {
                stack.push(e.path());
            }
        }
    }
    v
}

fn set_manifest_line(dir: &Path, line: &str) {
    let m = dir.join(".brachia-run");
    let mut text = std::fs::read_to_string(&m).unwrap();
    text.push_str(line);
    text.push('\n');
    std::fs::write(&m, text).unwrap();
}

// ---- path escapes through a manifest ----

#[test]
fn report_refuses_a_manifest_entry_that_leaves_the_folder() {
    for entry in [
        "0 00000000 figures/../../../elsewhere/X.txt",
        "3 00000000 /ABS/elsewhere/X.txt",
        "3 00000000 figures/./../../elsewhere/X.txt",
    ] {
        let t = tempfile::tempdir().unwrap();
        let x = Keep::new(t.path().join("elsewhere/X.txt"), b"not brachia's");
        let d = t.path().join("a/b/run");
        copy_dir(&corpus_run(), &d);
        let entry = entry.replace("/ABS", &t.path().display().to_string());
        set_manifest_line(&d, &entry);
        let o = run_in(t.path(), &["report", d.to_str().unwrap()]);
        refused(&o, &[".brachia-run", "inside the folder"]);
        x.check();
    }
}

#[test]
fn report_never_removes_a_listed_figure_reached_through_a_link() {
    let t = tempfile::tempdir().unwrap();
    let x = Keep::new(t.path().join("elsewhere/old.png"), b"the user's picture");
    let d = t.path().join("run");
    copy_dir(&corpus_run(), &d);
    std::fs::create_dir_all(d.join("figures")).unwrap();
    std::os::unix::fs::symlink(t.path().join("elsewhere"), d.join("figures/link")).unwrap();
    // listed with the right size and checksum: only the link on the way betrays it
    let crc = crc32(b"the user's picture");
    set_manifest_line(&d, &format!("18 {crc:08x} figures/link/old.png"));
    let o = run_in(t.path(), &["report", d.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    x.check();
    assert!(d.join("figures/link").is_symlink());
}

#[test]
fn a_rerun_refuses_a_manifest_that_leaves_the_folder_before_any_work() {
    let t = tempfile::tempdir().unwrap();
    let victim = Keep::new(t.path().join("victim.txt"), b"outside");
    let out = t.path().join("out");
    assert!(simulate(t.path(), "out").status.success());
    for entry in ["0 00000000 ../victim.txt", "7 00000000 /etc/hostname"] {
        let before = std::fs::read(out.join(".brachia-run")).unwrap();
        set_manifest_line(&out, entry);
        let o = simulate(t.path(), "out");
        refused(&o, &[".brachia-run", "inside the folder"]);
        victim.check();
        std::fs::write(out.join(".brachia-run"), before).unwrap();
    }
}

#[test]
fn a_rerun_keeps_listed_files_it_cannot_prove_it_wrote() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out");
    assert!(simulate(t.path(), "out").status.success());
    // a user's file listed in the manifest with a wrong checksum, and a report.json replaced by a
    // link to a file outside: neither is brachia's
    let notes = Keep::new(out.join("notes.txt"), b"mine");
    set_manifest_line(&out, "4 00000000 notes.txt");
    let outside = Keep::new(t.path().join("outside.json"), b"{\"mine\": true}\n");
    std::fs::remove_file(out.join("report.json")).unwrap();
    std::os::unix::fs::symlink(&outside.0, out.join("report.json")).unwrap();
    let edited = out.join("trajectory.csv");
    let mut data = std::fs::read(&edited).unwrap();
    data.extend_from_slice(b"# my note\n");
    std::fs::write(&edited, &data).unwrap();
    let o = simulate(t.path(), "out");
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    notes.check();
    outside.check();
    // the link and the edited file were moved aside, not replaced
    assert!(out.join("report.json.user").is_symlink());
    assert_eq!(
        std::fs::read(out.join("trajectory.csv.user")).unwrap(),
        data
    );
    assert!(out.join("report.json").is_file() && !out.join("report.json").is_symlink());
    assert!(leftovers(t.path()).is_empty(), "{:?}", leftovers(t.path()));
}

// ---- path escapes through a plan folder ----

fn tracking_scenario(t: &Path) -> PathBuf {
    let s = t.join("case.toml");
    let text = std::fs::read_to_string(root().join("scenarios/tracking.toml"))
        .unwrap()
        .replace("../params/paper.toml", &params());
    std::fs::write(&s, text).unwrap();
    s
}

#[test]
fn track_refuses_plan_files_that_lead_outside_the_plan_folder() {
    for file in ["trajectory.csv", "report.json"] {
        let t = tempfile::tempdir().unwrap();
        let s = tracking_scenario(t.path());
        let plan = t.path().join("plan");
        copy_dir(&corpus_plan(), &plan);
        // the real file lives outside; the plan folder holds a link to it
        let outside = t.path().join(format!("elsewhere/{file}"));
        std::fs::create_dir_all(outside.parent().unwrap()).unwrap();
        std::fs::rename(plan.join(file), &outside).unwrap();
        std::os::unix::fs::symlink(&outside, plan.join(file)).unwrap();
        let o = run_in(
            t.path(),
            &[
                "track",
                "--scenario",
                s.to_str().unwrap(),
                "--plan",
                plan.to_str().unwrap(),
                "--out",
                "out",
            ],
        );
        refused(&o, &[file, "outside the folder"]);
        assert!(!t.path().join("out").exists());
    }
}

#[test]
fn report_refuses_a_plan_folder_whose_robot_file_lies_outside() {
    for params_line in ["params = \"../robot.toml\"", "params = \"/ABS/robot.toml\""] {
        let t = tempfile::tempdir().unwrap();
        let robot = Keep::new(
            t.path().join("robot.toml"),
            &std::fs::read(corpus_run().join("params.toml")).unwrap(),
        );
        let d = t.path().join("run");
        copy_dir(&corpus_run(), &d);
        let sc = std::fs::read_to_string(d.join("scenario.toml")).unwrap();
        let line = params_line.replace("/ABS", &t.path().display().to_string());
        let sc = sc.replace("params = \"params.toml\"", &line);
        std::fs::write(d.join("scenario.toml"), sc).unwrap();
        // the manifest no longer proves scenario.toml; the folder is read all the same
        let o = run_in(t.path(), &["report", d.to_str().unwrap()]);
        refused(&o, &["scenario.toml", "params", "inside the folder"]);
        robot.check();
    }
}

#[test]
fn report_refuses_a_track_folder_whose_plan_is_a_link_outside() {
    let t = tempfile::tempdir().unwrap();
    let d = t.path().join("run");
    std::fs::create_dir_all(&d).unwrap();
    copy_dir(&corpus_run(), &t.path().join("elsewhere"));
    std::os::unix::fs::symlink(t.path().join("elsewhere"), d.join("plan")).unwrap();
    let r = read_back_inside(&d);
    assert!(
        r.contains("plan") && r.contains("outside the folder"),
        "{r}"
    );
}

/// The error of reading `dir` back as a track folder, as text (library call: the folder need not be a
/// complete track run for its `plan/` to be checked).
fn read_back_inside(dir: &Path) -> String {
    match brachia_experiments::read::inside_dir(dir, "plan") {
        Ok(_) => String::from("accepted"),
        Err(e) => e.to_string(),
    }
}

// ---- concurrent runs into one --out ----

fn concurrent(t: &Path, runs: usize) -> Vec<Output> {
    std::thread::scope(|s| {
        let hs: Vec<_> = (0..runs)
            .map(|_| s.spawn(move || simulate(t, "out")))
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

fn user_files(out: &Path) -> Vec<Keep> {
    vec![
        Keep::new(out.join("notes.txt"), b"the user's notes\n"),
        Keep::new(out.join("sub/mine.csv"), b"a,b\n1,2\n"),
        Keep::new(out.join(".hidden"), b"hidden but mine"),
    ]
}

#[test]
fn six_concurrent_runs_into_one_run_folder_keep_every_user_file() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out");
    assert!(simulate(t.path(), "out").status.success());
    let keep = user_files(&out);
    std::fs::create_dir_all(out.join("empty")).unwrap();
    for round in 0..3 {
        for o in concurrent(t.path(), 6) {
            assert_eq!(o.status.code(), Some(0), "round {round}: {}", stderr(&o));
        }
        for k in &keep {
            k.check();
        }
        assert!(out.join("empty").is_dir());
        assert!(leftovers(t.path()).is_empty(), "{:?}", leftovers(t.path()));
        // one run's results, complete, and no copy of a user file under another name
        let names: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .flatten()
            .map(|e| e.file_name().to_string_lossy().to_string())
            .collect();
        assert!(!names.iter().any(|n| n.contains(".user")), "{names:?}");
        let report = common::report(&out);
        assert_eq!(report["schema_version"], 1);
        let m = std::fs::read_to_string(out.join(".brachia-run")).unwrap();
        assert!(!m.contains("notes.txt") && !m.contains("mine.csv"), "{m}");
    }
}

#[test]
fn concurrent_first_runs_into_a_new_folder_all_succeed() {
    let t = tempfile::tempdir().unwrap();
    for o in concurrent(t.path(), 4) {
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    let out = t.path().join("out");
    assert!(out.join("trajectory.csv").is_file() && out.join("report.json").is_file());
    let names: Vec<_> = std::fs::read_dir(&out).unwrap().flatten().collect();
    // trajectory.csv, report.json, params.toml, view.html and the manifest: nothing moved aside
    assert_eq!(names.len(), 5, "{names:?}");
    assert!(leftovers(t.path()).is_empty(), "{:?}", leftovers(t.path()));
}

#[test]
fn concurrent_forced_runs_into_a_user_folder_keep_every_user_file() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out");
    let keep = user_files(&out);
    let p = params();
    let outs: Vec<Output> = std::thread::scope(|s| {
        let hs: Vec<_> = (0..4)
            .map(|_| {
                let (t, p) = (t.path(), p.as_str());
                s.spawn(move || {
                    run_in(
                        t,
                        &[
                            "simulate",
                            "--params",
                            p,
                            "--q0=-2.35,0,-1.55,0",
                            "--duration",
                            "0.05",
                            "--force",
                            "--out",
                            "out",
                        ],
                    )
                })
            })
            .collect();
        hs.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for o in outs {
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    for k in &keep {
        k.check();
    }
    assert!(leftovers(t.path()).is_empty(), "{:?}", leftovers(t.path()));
}

// ---- --out forms ----

#[test]
fn out_forms_through_dot_or_dotdot_are_refused_before_any_work() {
    let t = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(t.path().join("EMPTY")).unwrap();
    std::fs::create_dir_all(t.path().join("SUB")).unwrap();
    let keep = Keep::new(t.path().join("mine.txt"), b"mine");
    for out in [".", "./", "EMPTY/.", "SUB/..", "..", "SUB/../.."] {
        let o = simulate(t.path(), out);
        refused(&o, &["--out", "plainly"]);
        keep.check();
        assert!(!t.path().join("trajectory.csv").exists());
        assert_eq!(
            std::fs::read_dir(t.path().join("EMPTY")).unwrap().count(),
            0
        );
    }
    // the current folder or an ancestor, named plainly
    let cwd = t.path().join("SUB");
    for out in [cwd.display().to_string(), t.path().display().to_string()] {
        let o = simulate(&cwd, &out);
        refused(&o, &["current folder"]);
    }
    assert!(leftovers(t.path()).is_empty());
}

// ---- permissions and empty sub-folders ----

#[test]
fn a_rerun_keeps_the_folder_permissions_and_empty_sub_folders() {
    for mode in [0o700, 0o750, 0o2770] {
        let t = tempfile::tempdir().unwrap();
        let out = t.path().join("out");
        assert!(simulate(t.path(), "out").status.success());
        std::fs::create_dir_all(out.join("empty/deeper")).unwrap();
        std::fs::create_dir_all(out.join("also-empty")).unwrap();
        std::fs::set_permissions(&out, std::fs::Permissions::from_mode(mode)).unwrap();
        std::fs::set_permissions(out.join("empty"), std::fs::Permissions::from_mode(0o711))
            .unwrap();
        let o = simulate(t.path(), "out");
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
        let got = std::fs::metadata(&out).unwrap().permissions().mode() & 0o7777;
        assert_eq!(got, mode, "mode {mode:o} became {got:o}");
        let sub = std::fs::metadata(out.join("empty"))
            .unwrap()
            .permissions()
            .mode()
            & 0o777;
        assert_eq!(sub, 0o711);
        assert!(out.join("empty/deeper").is_dir() && out.join("also-empty").is_dir());
    }
}

// ---- schema versions ----

#[test]
fn report_refuses_files_of_an_unknown_or_missing_schema_version() {
    let cases: [(&str, &str, &str, &str); 4] = [
        (
            "report.json",
            "\"schema_version\": 1",
            "\"schema_version\": 99",
            "99",
        ),
        ("report.json", "\"schema_version\": 1,", "", "older brachia"),
        (
            "trajectory.csv",
            "# brachia trajectory schema 1",
            "# brachia trajectory schema 2",
            "schema 1",
        ),
        (
            "trajectory.csv",
            "# brachia trajectory schema 1\n",
            "",
            "older brachia",
        ),
    ];
    for (file, old, new, needle) in cases {
        let t = tempfile::tempdir().unwrap();
        let d = t.path().join("run");
        copy_dir(&corpus_run(), &d);
        let text = std::fs::read_to_string(d.join(file)).unwrap();
        assert!(text.contains(old), "{file} lacks {old}");
        std::fs::write(d.join(file), text.replacen(old, new, 1)).unwrap();
        let o = run_in(t.path(), &["report", d.to_str().unwrap()]);
        refused(&o, &[file, needle]);
        assert!(!d.join("figures").exists());
    }
}

#[test]
fn a_manifest_of_an_unknown_schema_is_refused() {
    let t = tempfile::tempdir().unwrap();
    let out = t.path().join("out");
    assert!(simulate(t.path(), "out").status.success());
    let m = out.join(".brachia-run");
    let text = std::fs::read_to_string(&m).unwrap();
    std::fs::write(&m, text.replacen("schema 1", "schema 5", 1)).unwrap();
    let before = std::fs::read(out.join("report.json")).unwrap();
    refused(&simulate(t.path(), "out"), &[".brachia-run", "schema"]);
    assert_eq!(std::fs::read(out.join("report.json")).unwrap(), before);
    let d = t.path().join("run");
    copy_dir(&corpus_run(), &d);
    let m = d.join(".brachia-run");
    let text = std::fs::read_to_string(&m).unwrap();
    std::fs::write(&m, text.replacen("schema 1", "schema 5", 1)).unwrap();
    refused(
        &run_in(t.path(), &["report", d.to_str().unwrap()]),
        &[".brachia-run", "schema"],
    );
}

#[test]
fn track_refuses_a_plan_of_another_schema_version() {
    for (file, old, new) in [
        ("trajectory.csv", "schema 1", "schema 3"),
        (
            "report.json",
            "\"schema_version\": 1",
            "\"schema_version\": \"1\"",
        ),
        ("trajectory.csv", "# brachia trajectory schema 1\n", ""),
    ] {
        let t = tempfile::tempdir().unwrap();
        let s = tracking_scenario(t.path());
        let plan = t.path().join("plan");
        copy_dir(&corpus_plan(), &plan);
        let text = std::fs::read_to_string(plan.join(file)).unwrap();
        std::fs::write(plan.join(file), text.replacen(old, new, 1)).unwrap();
        let o = run_in(
            t.path(),
            &[
                "track",
                "--scenario",
                s.to_str().unwrap(),
                "--plan",
                plan.to_str().unwrap(),
                "--out",
                "out",
            ],
        );
        refused(&o, &[file, "schema"]);
    }
}

/// CRC-32 (IEEE), as the manifest lists it.
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
