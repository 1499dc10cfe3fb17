//! Regressions found by a hostile-input sweep, one test per finding, each opening with its story.

mod common;

use common::{brachia, report, root};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

const TRACKING: &str = "scenarios/tracking.toml";

fn run(c: &mut Command) -> Output {
    c.output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).to_string()
}

/// Every file under `dir` (relative path, contents), sorted.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap().flatten() {
            let p = e.path();
            if e.file_type().unwrap().is_dir() {
                stack.push(p);
            } else {
                let rel = p.strip_prefix(dir).unwrap().to_path_buf();
                out.push((rel, std::fs::read(&p).unwrap()));
            }
        }
    }
    out.sort();
    out
}

/// Names in `dir` that look like a staging folder (`.NAME.partial-...`).
fn staging_left(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .filter(|f| f.contains(".partial"))
        .collect()
}

fn plan_into(out: &Path) {
    let o = run(brachia()
        .args(["plan", "--scenario", TRACKING, "--out"])
        .arg(out));
    assert!(o.status.success(), "{}", stderr(&o));
}

/// F9: `brachia track --plan rf --out rf` exited 0 and deleted rf's trajectory.csv, knots.csv,
/// scenario.toml and params.toml: the run replaced its own input. Now an --out that is the --plan folder,
/// holds it or lies inside it (also through a symbolic link, or a path spelt differently) is refused with
/// exit 2 before any work, and the plan folder is left as it was.
#[test]
fn f9_track_out_on_its_own_plan_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let rf = dir.path().join("rf");
    plan_into(&rf);
    let before = snapshot(&rf);
    std::os::unix::fs::symlink(&rf, dir.path().join("rflink")).unwrap();
    // a track run folder whose plan/ is given back as --plan
    let top = dir.path().join("top");
    let o = run(brachia()
        .args(["track", "--scenario", TRACKING, "--plan"])
        .arg(&rf)
        .arg("--out")
        .arg(&top));
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::create_dir_all(top.join("plan")).unwrap();
    for f in [
        "scenario.toml",
        "params.toml",
        "trajectory.csv",
        "report.json",
        "knots.csv",
    ] {
        std::fs::copy(rf.join(f), top.join("plan").join(f)).unwrap();
    }
    let top_before = snapshot(&top);
    let cases: Vec<(PathBuf, PathBuf, &str)> = vec![
        (rf.clone(), rf.clone(), "same folder"),
        (rf.clone(), dir.path().join("rf/"), "same folder"),
        (rf.clone(), dir.path().join("x/../rf"), "same folder"),
        (dir.path().join("rflink"), rf.clone(), "same folder"),
        (rf.clone(), rf.join("sub"), "inside"),
        (top.join("plan"), top.clone(), "holds"),
    ];
    for (plan, out, words) in cases {
        let o = run(brachia()
            .args(["track", "--scenario", TRACKING, "--plan"])
            .arg(&plan)
            .arg("--out")
            .arg(&out));
        let e = stderr(&o);
        assert_eq!(
            o.status.code(),
            Some(2),
            "--plan {plan:?} --out {out:?}: {e}"
        );
        assert!(e.contains(words) && e.contains("--plan"), "{e}");
        assert_eq!(e.trim().lines().count(), 1, "{e}");
    }
    assert!(snapshot(&rf) == before, "the plan folder changed");
    assert!(snapshot(&top) == top_before, "the track folder changed");
    assert!(!rf.join("sub").exists() && !dir.path().join("x").exists());
    assert!(staging_left(dir.path()).is_empty() && staging_left(&rf).is_empty());
}

/// F9 (reproduce): `--out` the scenario folder (or a folder holding it) is refused the same way.
#[test]
fn f9_reproduce_out_on_its_scenario_folder_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("sc");
    std::fs::create_dir_all(&sc).unwrap();
    std::fs::write(sc.join("mine.txt"), "x").unwrap();
    for out in [sc.clone(), dir.path().to_path_buf()] {
        let o = run(brachia()
            .args([
                "reproduce",
                "--quick",
                "--no-progress",
                "--force",
                "--scenarios",
            ])
            .arg(&sc)
            .arg("--out")
            .arg(&out));
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.contains("--scenarios"), "{e}");
    }
    assert_eq!(std::fs::read_to_string(sc.join("mine.txt")).unwrap(), "x");
}

/// F8a: `brachia plan --out link1 --force`, link1 a symbolic link to the user's folder, exited 0,
/// replaced the link by a real folder, moved the user's keep.txt into it and left the user's folder
/// empty. F8b: a link to an empty folder ran the whole plan, then exited 3 leaving a complete
/// `.link4.partial-PID-0/` behind. Now an --out that is a symbolic link is refused (exit 2, before any
/// work), with or without --force, also spelt with a trailing slash.
#[test]
fn f8_out_a_symbolic_link_is_refused_and_the_users_folder_kept() {
    let dir = tempfile::tempdir().unwrap();
    let user = dir.path().join("userdir");
    std::fs::create_dir_all(&user).unwrap();
    std::fs::write(user.join("keep.txt"), "x\n").unwrap();
    std::os::unix::fs::symlink(&user, dir.path().join("link1")).unwrap();
    let empty = dir.path().join("emptyd");
    std::fs::create_dir_all(&empty).unwrap();
    std::os::unix::fs::symlink(&empty, dir.path().join("link4")).unwrap();
    for (out, force) in [
        ("link1", true),
        ("link1", false),
        ("link1/", true),
        ("link4", false),
        ("link4/", false),
        ("link4", true),
    ] {
        let start = Instant::now();
        let mut c = brachia();
        c.args(["plan", "--scenario", TRACKING, "--out"])
            .arg(dir.path().join(out));
        if force {
            c.arg("--force");
        }
        let o = run(&mut c);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{out} force {force}: {e}");
        assert!(e.contains("symbolic link"), "{e}");
        assert!(
            start.elapsed() < Duration::from_secs(5),
            "work was done first"
        );
    }
    let link1 = dir.path().join("link1");
    assert!(link1.is_symlink(), "the link was replaced");
    assert_eq!(
        std::fs::read_to_string(user.join("keep.txt")).unwrap(),
        "x\n"
    );
    assert_eq!(std::fs::read_dir(&user).unwrap().count(), 1);
    assert_eq!(std::fs::read_dir(&empty).unwrap().count(), 0);
    assert!(dir.path().join("link4").is_symlink());
    assert!(
        staging_left(dir.path()).is_empty(),
        "{:?}",
        staging_left(dir.path())
    );
}

/// F10: `brachia plan --scenario fifo.toml`, a FIFO, blocked forever in open. Every input is read by
/// the one capped reader, which now refuses anything but a regular file by its metadata before opening
/// it (exit 2, "not a regular file", naming the file): a FIFO as scenario, as the robot file a scenario
/// names, or as a plan folder's CSV; /dev/null and /dev/stdin (a pipe) are clear exit-2 errors too.
#[test]
fn f10_a_fifo_or_device_as_input_is_refused_at_once() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("fifo.toml");
    let made = Command::new("mkfifo").arg(&fifo).status().unwrap();
    assert!(made.success());
    // a scenario naming a FIFO as its robot file
    let text = std::fs::read_to_string(root().join(TRACKING)).unwrap();
    let params_line = text
        .lines()
        .find(|l| l.trim_start().starts_with("params"))
        .unwrap();
    let sfile = dir.path().join("s.toml");
    std::fs::write(
        &sfile,
        text.replace(
            params_line,
            &format!("params = {:?}", fifo.display().to_string()),
        ),
    )
    .unwrap();
    // a plan folder whose trajectory.csv is a FIFO
    let rf = dir.path().join("rf");
    plan_into(&rf);
    std::fs::remove_file(rf.join("trajectory.csv")).unwrap();
    let made = Command::new("mkfifo")
        .arg(rf.join("trajectory.csv"))
        .status()
        .unwrap();
    assert!(made.success());
    let out = dir.path().join("o");
    let cases: Vec<(Vec<String>, String)> = vec![
        (
            vec![
                "plan".into(),
                "--scenario".into(),
                fifo.display().to_string(),
            ],
            fifo.display().to_string(),
        ),
        (
            vec![
                "plan".into(),
                "--scenario".into(),
                sfile.display().to_string(),
            ],
            fifo.display().to_string(),
        ),
        (
            vec![
                "simulate".into(),
                "--params".into(),
                fifo.display().to_string(),
                "--q0=-2.35,0,-1.55,0".into(),
            ],
            fifo.display().to_string(),
        ),
        (
            vec![
                "track".into(),
                "--scenario".into(),
                TRACKING.into(),
                "--plan".into(),
                rf.display().to_string(),
            ],
            "trajectory.csv".into(),
        ),
        (
            vec!["plan".into(), "--scenario".into(), "/dev/null".into()],
            "/dev/null".into(),
        ),
        (
            vec!["plan".into(), "--scenario".into(), "/dev/stdin".into()],
            "/dev/stdin".into(),
        ),
    ];
    for (args, names) in cases {
        let mut child = brachia()
            .args(&args)
            .arg("--out")
            .arg(&out)
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let start = Instant::now();
        let status = loop {
            if let Some(s) = child.try_wait().unwrap() {
                break s;
            }
            if start.elapsed() > Duration::from_secs(20) {
                let _ = child.kill();
                let _ = child.wait();
                panic!("{args:?} hangs");
            }
            std::thread::sleep(Duration::from_millis(20));
        };
        let mut e = String::new();
        std::io::Read::read_to_string(&mut child.stderr.take().unwrap(), &mut e).unwrap();
        assert_eq!(status.code(), Some(2), "{args:?}: {e}");
        assert!(
            e.contains("not a regular file") && e.contains(&names),
            "{args:?}: {e}"
        );
        assert!(!out.exists());
    }
}

/// A copy of `scenario` (relative to the repository) in `dir` with its robot file made absolute and
/// `extra` appended.
fn scenario_with(dir: &Path, scenario: &str, extra: &str) -> PathBuf {
    let path = root().join(scenario);
    let text = std::fs::read_to_string(&path).unwrap();
    let params_line = text
        .lines()
        .find(|l| l.trim_start().starts_with("params"))
        .unwrap();
    let rel = params_line.split('"').nth(1).unwrap();
    let abs = path.parent().unwrap().join(rel);
    let text = text.replace(
        params_line,
        &format!("params = {:?}", abs.display().to_string()),
    );
    let out = dir.join(Path::new(scenario).file_name().unwrap());
    std::fs::write(&out, format!("{text}\n{extra}\n")).unwrap();
    out
}

/// F3: the tracking scenario on a plant a billion times lighter (`[plant] mass_scale = 1e-9`) diverged
/// at once, yet `brachia track` exited 0 printing `EE final error NaN m`, wrote NaN rows into
/// closed_loop.csv and `"ee_final_error_m": null` into report.json (which `brachia report` then refused).
/// Now it is exit 1 naming the time of the divergence, on the model and the rapier plant; the run folder
/// is still written for diagnosis, holds only finite rows, records `diverged_at_s` and reads back.
#[test]
fn f3_a_diverged_closed_loop_is_exit_1_and_its_folder_reads_back() {
    let dir = tempfile::tempdir().unwrap();
    let s = scenario_with(dir.path(), TRACKING, "[plant]\nmass_scale = 1e-9");
    for plant in ["model", "rapier"] {
        let out = dir.path().join(plant);
        let o = run(brachia()
            .args(["track", "--plant", plant, "--scenario"])
            .arg(&s)
            .arg("--out")
            .arg(&out));
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{plant}: {e}");
        assert!(e.contains("diverged at t = "), "{e}");
        assert!(!e.contains("NaN"), "{e}");
        let r = report(&out);
        assert!(r["diverged_at_s"].as_f64().is_some(), "{r}");
        for key in ["ee_final_error_m", "energy_j", "joint_rms_error_rad"] {
            assert!(
                r[key].as_f64().is_some_and(f64::is_finite),
                "{key}: {}",
                r[key]
            );
        }
        let csv = std::fs::read_to_string(out.join("closed_loop.csv")).unwrap();
        let csv = csv
            .strip_prefix("# brachia closed_loop schema 2\n")
            .expect("the schema line");
        assert!(!csv.to_lowercase().contains("nan") && !csv.contains("inf"));
        // `brachia report` reads it back
        let o = run(brachia().arg("report").arg(&out));
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
}

/// F3 (traverse): the same divergence on a ladder traverse exited 3 (a figure of NaN poses could not be
/// drawn). Now it is exit 1 with the swing and time of the divergence, and the run folder is written.
#[test]
fn f3_a_diverged_traverse_is_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let s = scenario_with(
        dir.path(),
        "scenarios/ladder-even.toml",
        "[plant]\nmass_scale = 1e-9",
    );
    let out = dir.path().join("t");
    let o = run(brachia()
        .args(["traverse", "--scenario"])
        .arg(&s)
        .arg("--out")
        .arg(&out));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("diverged at t = "), "{e}");
    let r = report(&out);
    assert_eq!(r["status"]["kind"], "diverged", "{}", r["status"]);
}

/// F3 (reproduce): with a diverging tracking scenario, `brachia reproduce` failed with exit 2 on its own
/// staging output (the NaN rows it wrote did not read back for the figures). Now the divergence is one
/// of its failures (exit 1), the folder is written and `brachia report` redraws it (exit 1, the same
/// failures).
#[test]
fn f3_reproduce_with_a_diverging_tracking_run_is_exit_1() {
    let dir = tempfile::tempdir().unwrap();
    let sc = dir.path().join("sc");
    std::fs::create_dir_all(&sc).unwrap();
    for e in std::fs::read_dir(root().join("scenarios"))
        .unwrap()
        .flatten()
    {
        let name = e.file_name().to_string_lossy().to_string();
        if name.ends_with(".toml") {
            let extra = if name == "tracking.toml" {
                "[plant]\nmass_scale = 1e-9"
            } else {
                ""
            };
            scenario_with(&sc, &format!("scenarios/{name}"), extra);
        }
    }
    let out = dir.path().join("rq");
    let o = run(brachia()
        .args(["reproduce", "--quick", "--no-progress", "--scenarios"])
        .arg(&sc)
        .arg("--out")
        .arg(&out));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("tracking: the closed loop diverged at t = "),
        "{e}"
    );
    assert!(out.join("REPORT.md").is_file());
    let o = run(brachia().arg("report").arg(&out));
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("diverged"), "{e}");
}
