//! Ctrl-C (SIGINT) stops every long command promptly: exit 130, nothing written, the previous results
//! at `--out` kept. Each test starts a command on work that runs far longer than the test waits,
//! interrupts it and measures the time from the signal to the exit (printed; run with `--nocapture`
//! to see it). The bound asserted is generous (5 s) so that a loaded machine cannot fail it; the
//! measured times are in docs/limits.md.

mod common;

use common::{brachia, interrupt, root, run_expect, tracking_plan};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

/// A bound no prompt interruption comes near, for a loaded machine.
const GENEROUS: Duration = Duration::from_secs(5);

/// A brachia run folder at `dir/name` holding a previous result (listed in its manifest) and a file of
/// the user's.
fn previous_results(dir: &Path, name: &str) -> PathBuf {
    let out = dir.join(name);
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(
        out.join(".brachia-run"),
        "# brachia run folder\nreport.json\n",
    )
    .unwrap();
    std::fs::write(out.join("report.json"), "previous").unwrap();
    std::fs::write(out.join("notes.txt"), "the user's").unwrap();
    out
}

/// Every entry of `out` and its parent, to compare before and after.
fn listing(out: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(out.parent().unwrap())
        .unwrap()
        .chain(std::fs::read_dir(out).unwrap())
        .flatten()
        .map(|e| e.path().display().to_string())
        .collect();
    v.sort();
    v
}

fn assert_untouched(out: &Path, before: &[String]) {
    assert_eq!(listing(out), before, "files appeared or vanished");
    assert_eq!(
        std::fs::read_to_string(out.join("report.json")).unwrap(),
        "previous"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("notes.txt")).unwrap(),
        "the user's"
    );
}

/// A scenario of the paper's robot swinging for `swing_time` s at knots `knot_dt` apart, with more
/// `[planner]` lines and the `[solver]` section `solver`, written into `dir`.
fn long_swing(dir: &Path, swing_time: f64, knot_dt: f64, planner: &str, solver: &str) -> PathBuf {
    let path = dir.join("long.toml");
    std::fs::write(
        &path,
        format!(
            "params = \"{}\"\n\n[task]\nq0 = [-2.35, 0.0, -1.55, 0.0]\ntarget = [0.8, 0.0]\n\n\
             [planner]\nswing_time = {swing_time}\nknot_dt = {knot_dt}\ntranscription = \
             \"multiple-shooting\"\n{planner}\n\n[solver]\n{solver}\n",
            root().join("params/paper.toml").display()
        ),
    )
    .unwrap();
    path
}

fn check(what: &str, code: Option<i32>, took: Duration, stderr: &str) {
    eprintln!(
        "{what}: exit {code:?}, {:.3} s from SIGINT to exit",
        took.as_secs_f64()
    );
    assert_eq!(code, Some(130), "{what}: {stderr}");
    assert!(stderr.contains("interrupted"), "{what}: {stderr}");
    assert!(took < GENEROUS, "{what}: {took:?} from SIGINT to exit");
}

/// Interrupt `cmd`, which writes into `out` (a folder of previous results), `after` its start; check
/// the exit ([`check`]) and that `out` and its parent are as they were.
fn interrupt_and_check(what: &str, out: &Path, cmd: Command, after: Duration) {
    let before = listing(out);
    let (code, took, stderr) = interrupt(cmd, after);
    check(what, code, took, &stderr);
    assert_untouched(out, &before);
}

#[test]
fn ctrl_c_stops_a_long_plan_inside_its_solve() {
    let dir = tempfile::tempdir().unwrap();
    // a free swing time from 16 starts, each a plan of up to 2000 intervals
    let sc = long_swing(
        dir.path(),
        20.0,
        0.01,
        "free_swing_time = [10.0, 20.0]\nswing_time_starts = 16",
        "backend = \"ocp\"",
    );
    let out = previous_results(dir.path(), "plan");
    let mut cmd = brachia();
    cmd.args(["plan", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(&out);
    interrupt_and_check(
        "plan, free swing time, 16 starts (ocp)",
        &out,
        cmd,
        Duration::from_millis(1500),
    );
}

#[test]
fn ctrl_c_stops_a_plan_on_pounce_inside_its_solve() {
    let dir = tempfile::tempdir().unwrap();
    let sc = long_swing(dir.path(), 20.0, 0.01, "", "backend = \"pounce\"");
    let out = previous_results(dir.path(), "plan");
    let mut cmd = brachia();
    cmd.args(["plan", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(&out);
    interrupt_and_check(
        "plan, 20 s swing (pounce)",
        &out,
        cmd,
        Duration::from_millis(1500),
    );
}

#[test]
fn ctrl_c_stops_a_benchmark_between_and_inside_its_runs() {
    let dir = tempfile::tempdir().unwrap();
    let out = previous_results(dir.path(), "bench");
    let mut cmd = brachia();
    cmd.args([
        "benchmark",
        "--scenario",
        "scenarios/tracking.toml",
        "--quick",
        "--no-progress",
        "--out",
    ])
    .arg(&out);
    interrupt_and_check("benchmark --quick", &out, cmd, Duration::from_millis(3000));
}

#[test]
fn ctrl_c_stops_a_report_inside_its_animation() {
    let dir = tempfile::tempdir().unwrap();
    // a plan folder of an 8 s swing (stopped after a few iterations: its report is written all the
    // same), whose figures (a stick diagram, then an animation of 201 frames) take longer to draw than
    // the test waits
    let sc = long_swing(dir.path(), 8.0, 0.03, "", "backend = \"ocp\"\nmax_iter = 3");
    let plan = dir.path().join("plan");
    run_expect(
        brachia()
            .args(["plan", "--scenario"])
            .arg(&sc)
            .arg("--out")
            .arg(&plan),
        1,
    );
    let before = listing(&plan);
    let report_before = std::fs::read(plan.join("report.json")).unwrap();
    let mut cmd = brachia();
    cmd.arg("report").arg(&plan);
    let (code, took, stderr) = interrupt(cmd, Duration::from_millis(300));
    check("report of an 8 s plan", code, took, &stderr);
    assert_eq!(listing(&plan), before, "files appeared or vanished");
    assert_eq!(
        std::fs::read(plan.join("report.json")).unwrap(),
        report_before
    );
}

/// The tracking swing followed by a minute of hold: a closed loop of about 62 000 control steps.
fn held_swing(dir: &Path) -> PathBuf {
    let sc = dir.join("hold.toml");
    let text = std::fs::read_to_string(root().join("scenarios/tracking.toml"))
        .unwrap()
        .replace(
            "\"../params/paper.toml\"",
            &format!("{:?}", root().join("params/paper.toml")),
        );
    std::fs::write(&sc, format!("{text}\n[tracking]\nhold_s = 60.0\n")).unwrap();
    sc
}

fn ctrl_c_stops_a_long_track(plant: &str) {
    let dir = tempfile::tempdir().unwrap();
    let plan = tracking_plan(dir.path(), "tracking-plan", &[]);
    let sc = held_swing(dir.path());
    let out = previous_results(dir.path(), "track");
    let mut cmd = brachia();
    cmd.args(["track", "--plant", plant, "--scenario"])
        .arg(&sc)
        .arg("--plan")
        .arg(&plan)
        .arg("--out")
        .arg(&out);
    interrupt_and_check(
        &format!("track, MPC on the {plant} plant, 60 s hold"),
        &out,
        cmd,
        Duration::from_millis(1500),
    );
}

#[test]
fn ctrl_c_stops_a_track_on_the_model_plant_in_its_closed_loop() {
    ctrl_c_stops_a_long_track("model");
}

#[test]
fn ctrl_c_stops_a_track_on_the_rapier_plant_in_its_closed_loop() {
    ctrl_c_stops_a_long_track("rapier");
}

#[test]
fn ctrl_c_stops_a_long_simulation() {
    let dir = tempfile::tempdir().unwrap();
    let out = previous_results(dir.path(), "sim");
    let mut cmd = brachia();
    // 600 s at 1 ms rows with 30 RK4 steps each: 18 million steps (the limit is 20 million)
    cmd.args([
        "simulate",
        "--params",
        "params/paper.toml",
        "--q0=-2.35,0,-1.55,0",
        "--duration",
        "600",
        "--substeps",
        "30",
        "--out",
    ])
    .arg(&out);
    interrupt_and_check("simulate 600 s", &out, cmd, Duration::from_millis(1000));
}

#[test]
fn ctrl_c_stops_a_traverse() {
    let dir = tempfile::tempdir().unwrap();
    let out = previous_results(dir.path(), "traverse");
    let mut cmd = brachia();
    // the ladder around an obstacle: its later swings take thousands of solver iterations (several
    // seconds on an idle machine), so the interrupt falls inside the work
    cmd.args([
        "traverse",
        "--scenario",
        "scenarios/ladder-obstacle.toml",
        "--out",
    ])
    .arg(&out);
    interrupt_and_check("traverse", &out, cmd, Duration::from_millis(1000));
}

#[test]
fn ctrl_c_stops_a_reproduction() {
    let dir = tempfile::tempdir().unwrap();
    let out = previous_results(dir.path(), "reproduce");
    let mut cmd = brachia();
    cmd.args(["reproduce", "--quick", "--no-progress", "--out"])
        .arg(&out);
    interrupt_and_check("reproduce --quick", &out, cmd, Duration::from_millis(2000));
}
