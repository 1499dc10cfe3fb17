//! Any n from 2 to 12 end to end, as a user runs it: the 3- and 6-link scenarios of
//! scenarios/ (robots params/three-link.toml and params/six-link.toml) are planned with `brachia plan`
//! and the plan folder is tracked with `brachia track` on the model plant and on the rapier plant, each
//! command exiting 0 with files for n joints; a plan of one link count tracked with the other's scenario
//! is refused (exit 2). `brachia simulate` of both robots: `cli_simulate.rs`,
//! `three_and_six_link_robots_simulate`. Conventions: SI units, EE errors are distances to the bar.

mod common;

use common::{brachia, report};
use std::path::Path;

fn run(args: &[&str], out: &Path) -> std::process::Output {
    brachia().args(args).arg("--out").arg(out).output().unwrap()
}

fn plan_and_track(scenario: &str, n: usize, dir: &Path) {
    let plan = dir.join(format!("plan{n}"));
    let o = run(&["plan", "--scenario", scenario], &plan);
    assert_eq!(
        o.status.code(),
        Some(0),
        "{scenario}: plan: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let r = report(&plan);
    assert_eq!(r["status"], "solved", "{scenario}: {r}");
    let csv = std::fs::read_to_string(plan.join("trajectory.csv")).unwrap();
    let csv = csv
        .strip_prefix("# brachia trajectory schema 1\n")
        .expect("the schema line");
    let header = csv.lines().next().unwrap();
    assert!(
        header.contains(&format!(",q{n},qd1,")) && header.contains(&format!(",tau{n},ee_x")),
        "{header}"
    );
    for (plant, tol) in [("model", 0.01), ("rapier", 0.02)] {
        let out = dir.join(format!("track{n}-{plant}"));
        let o = brachia()
            .args(["track", "--scenario", scenario, "--plant", plant, "--plan"])
            .arg(&plan)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        assert_eq!(
            o.status.code(),
            Some(0),
            "{scenario} on {plant}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let r = report(&out);
        assert_eq!(r["plant"], plant);
        let err = r["ee_final_error_m"].as_f64().unwrap();
        assert!(
            err < tol,
            "{scenario} on {plant}: ends {err} m from the bar"
        );
        let log = std::fs::read_to_string(out.join("closed_loop.csv")).unwrap();
        let log = log
            .strip_prefix("# brachia closed_loop schema 2\n")
            .expect("the schema line");
        let head = log.lines().next().unwrap();
        assert!(
            head.starts_with("t,q1,") && head.contains(&format!(",tau{n},")),
            "{head}"
        );
    }
}

#[test]
fn a_three_link_robot_plans_and_tracks_on_both_plants() {
    let dir = tempfile::tempdir().unwrap();
    plan_and_track("scenarios/three-link.toml", 3, dir.path());
    // the 3-link plan is refused by the 6-link scenario, before any work
    let out = dir.path().join("wrong");
    let o = brachia()
        .args(["track", "--scenario", "scenarios/six-link.toml", "--plan"])
        .arg(dir.path().join("plan3"))
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("trajectory.csv") && err.contains("3-link") && err.contains("6 links"),
        "{err}"
    );
    assert!(!out.exists());
}

#[test]
fn a_six_link_robot_plans_and_tracks_on_both_plants() {
    let dir = tempfile::tempdir().unwrap();
    plan_and_track("scenarios/six-link.toml", 6, dir.path());
}
