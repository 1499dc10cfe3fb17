//! `brachia plan` as a user runs it: the run folder contract, exit codes 0 / 1 / 2.

mod common;

use common::{brachia, report, root};
use std::path::PathBuf;

#[test]
fn plan_writes_the_run_folder_contract() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plan");
    let o = brachia()
        .args(["plan", "--scenario", "scenarios/tracking.toml", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&out);
    for key in [
        "status",
        "converged",
        "iterations",
        "solve_time_s",
        "objective",
        "energy_j",
        "positive_work_j",
        "max_violation",
        "ee_final",
        "swing_time_s",
        "knots",
        "transcription",
        "replay_ee_error_m",
        "min_obstacle_clearance_m",
    ] {
        assert!(r.get(key).is_some(), "report.json lacks {key}");
    }
    assert_eq!(r["converged"], true);
    assert!(r["min_obstacle_clearance_m"].is_null());
    let ee = r["ee_final"].as_array().unwrap();
    assert!((ee[0].as_f64().unwrap() - 0.8).abs() < 1e-3 && ee[1].as_f64().unwrap().abs() < 1e-3);
    let traj = std::fs::read_to_string(out.join("trajectory.csv")).unwrap();
    let traj = traj
        .strip_prefix("# brachia trajectory schema 1\n")
        .expect("the schema line");
    assert!(traj.starts_with("t,q1,q2,q3,q4,qd1,qd2,qd3,qd4,tau2,tau3,tau4,ee_x,ee_y\n"));
    let rows = traj.lines().count() - 1;
    let t = r["swing_time_s"].as_f64().unwrap();
    assert_eq!(
        rows,
        (t / 1e-3 - 1e-6).ceil() as usize + 1,
        "1 ms rows over the swing and one at T"
    );
    let last_t: f64 = traj
        .lines()
        .last()
        .and_then(|l| l.split(',').next())
        .unwrap()
        .parse()
        .unwrap();
    assert!((last_t - t).abs() < 1e-6, "last row at {last_t}, T = {t}");
    assert_eq!(r["trajectory_end_s"].as_f64(), Some(t));
    // the solver's work: totals over the attempts and their passes, and the time split
    assert!(r["solver"].is_string());
    let solves = r["solves"].as_array().unwrap();
    assert_eq!(solves.len() as u64, r["attempts"].as_u64().unwrap());
    let passes: Vec<&serde_json::Value> = solves
        .iter()
        .flat_map(|a| a["passes"].as_array().unwrap())
        .collect();
    let it: u64 = passes
        .iter()
        .map(|p| p["iterations"].as_u64().unwrap())
        .sum();
    assert_eq!(r["iterations"].as_u64(), Some(it));
    let split = &r["time_split_s"];
    let total: f64 = ["callbacks_s", "linear_algebra_s", "line_search_and_other_s"]
        .iter()
        .map(|k| split[k].as_f64().unwrap())
        .sum();
    assert!((total - r["solve_time_s"].as_f64().unwrap()).abs() < 1e-6);
    assert!(std::fs::read_to_string(out.join("knots.csv"))
        .unwrap()
        .contains("is_midpoint"));
    let resolved = std::fs::read_to_string(out.join("scenario.toml")).unwrap();
    assert!(
        resolved.contains("swing_time = 2.") && resolved.contains("r1_diag"),
        "{resolved}"
    );
}

/// Write scenario `text` as `dir/name`, run `brachia plan` on it into `dir/plan`: its output and the
/// folder.
fn plan_in(dir: &std::path::Path, name: &str, text: &str) -> (std::process::Output, PathBuf) {
    let sc = dir.join(name);
    std::fs::write(&sc, text).unwrap();
    let out = dir.join("plan");
    let o = brachia()
        .args(["plan", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    (o, out)
}

#[test]
fn non_convergence_writes_the_report_and_exits_1() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("scenarios/tracking.toml"))
        .unwrap()
        .replace(
            "params = \"../params/paper.toml\"",
            &format!("params = {:?}", root().join("params/paper.toml")),
        )
        .replace("backend = \"ocp\"", "backend = \"ocp\"\nmax_iter = 2");
    let (o, out) = plan_in(dir.path(), "short.toml", &text);
    assert_eq!(
        o.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    assert!(String::from_utf8_lossy(&o.stderr).contains("did not converge"));
    let r = report(&out);
    assert_eq!(r["converged"], false);
    assert_eq!(r["status"], "max_iterations");
}

/// The tracking swing with every torque limit at 0.4 N m fails; the message and the report say how far
/// the continuation on the limits got (brachia::planning::strategy::torque_continuation).
#[test]
fn a_swing_short_of_torque_says_how_much_it_needs() {
    let dir = tempfile::tempdir().unwrap();
    let params = std::fs::read_to_string(root().join("params/paper.toml"))
        .unwrap()
        .replace(
            "tau_min = [-5.0, -5.0, -5.0]",
            "tau_min = [-0.4, -0.4, -0.4]",
        )
        .replace("tau_max = [5.0, 5.0, 5.0]", "tau_max = [0.4, 0.4, 0.4]");
    assert!(params.contains("[0.4, 0.4, 0.4]"));
    std::fs::write(dir.path().join("weak.toml"), params).unwrap();
    let text = std::fs::read_to_string(root().join("scenarios/tracking.toml"))
        .unwrap()
        .replace(
            "params = \"../params/paper.toml\"",
            "params = \"weak.toml\"",
        )
        // the continuation on the limits alone: the search in T would plan "auto" at another T
        .replace("[planner]", "[planner]\nswing_time_search = false");
    assert!(text.contains("swing_time_search = false"));
    let (o, out) = plan_in(dir.path(), "weak_swing.toml", &text);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("likely torque-limited"), "{err}");
    let r = report(&out);
    assert_eq!(r["converged"], false);
    let t = &r["torque_continuation"];
    assert_eq!(t["relaxed_converged"], true, "{t}");
    let (hi, lo) = (
        t["reached_scale"].as_f64().unwrap(),
        t["failed_scale"].as_f64().unwrap(),
    );
    assert!(1.0 <= lo && lo < hi, "{t}");
    assert_eq!(t["limit_nm"], serde_json::json!([0.4, 0.4, 0.4]));
    let peak = t["peak_torque_nm"].as_array().unwrap();
    assert!(peak.iter().any(|p| p.as_f64().unwrap() > 0.4), "{t}");
    assert!(r["iterations"].as_u64().unwrap() > t["iterations"].as_u64().unwrap());
    // every solve is in the report, tagged: the cold plan, then the continuation's scales
    let solves = r["solves"].as_array().unwrap();
    assert_eq!(solves.len() as u64, r["attempts"].as_u64().unwrap());
    assert_eq!(solves[0]["role"]["kind"], "task", "{}", solves[0]);
    let scaled: Vec<f64> = solves
        .iter()
        .filter(|a| a["role"]["kind"] == "torque-scale")
        .map(|a| a["role"]["scale"].as_f64().unwrap())
        .collect();
    assert!(scaled.contains(&hi) && scaled.contains(&lo), "{scaled:?}");
    let it: u64 = solves
        .iter()
        .map(|a| a["iterations"].as_u64().unwrap())
        .sum();
    assert_eq!(it, r["iterations"].as_u64().unwrap());
    // and in the message's account of the work
    let out_text = String::from_utf8_lossy(&o.stdout) + err.clone();
    assert!(out_text.contains("torque limits x"), "{out_text}");
}

#[test]
fn an_obstacle_that_blocks_the_grasp_is_refused_with_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    // the obstacle's surface 0.01 m below the bar: the last link (radius 0.02 m, margin 0.01 m) ends
    // there, so no pose grasping the bar clears it; refused before any solve
    let text = format!(
        "params = {:?}\n[task]\nq0 = [-2.35, 0.0, -1.55, 0.0]\ntarget = [0.8, 0.0]\n\
         obstacles = [{{ center = [-0.6, 0.3], radius = 0.05 }}, \
         {{ center = [0.8, -0.09], radius = 0.08 }}]\n[planner]\nknot_dt = 0.05\n\
         transcription = \"multiple-shooting\"\n[solver]\nbackend = \"ocp\"\nmax_iter = 40\n",
        root().join("params/paper.toml")
    );
    let (o, out) = plan_in(dir.path(), "bar.toml", &text);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for want in [
        "bar.toml",
        "task.obstacles[1]",
        "0.0100 m from the target bar",
        "no pose that grasps the bar clears it",
        "planner.obstacle_margin = 0.01",
    ] {
        assert!(err.contains(want), "{want}: {err}");
    }
    assert!(!out.exists());
    // the same obstacle 0.05 m lower leaves the last link room: it is planned (exit 0 or 1)
    let (o, _) = plan_in(
        dir.path(),
        "lower.toml",
        &text.replace("[0.8, -0.09]", "[0.8, -0.14]"),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{err}");
}

#[test]
fn bad_scenarios_exit_2_and_write_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let base = std::fs::read_to_string(root().join("scenarios/tracking.toml"))
        .unwrap()
        .replace(
            "params = \"../params/paper.toml\"",
            &format!("params = {:?}", root().join("params/paper.toml")),
        );
    let cases = [
        (
            base.replace("target = [0.8, 0.0]", "target = [3.0, 0.0]"),
            "reaches at most",
        ),
        (base.replace("knot_dt = 0.03", "knot_dt = -0.01"), "knot_dt"),
        (
            base.replace(
                "transcription = \"multiple-shooting\"",
                "transcription = \"rk45\"",
            ),
            "transcription",
        ),
        (
            base.replace("q0 = [-2.35, 0.0, -1.55, 0.0]", "q0 = [-2.35, 0.0]"),
            "task.q0",
        ),
        (
            base.replace(
                "[task]",
                "[task]\nobstacles = [{ center = [-0.5, -0.5], radius = 0.1 }]",
            ),
            "overlaps",
        ),
    ];
    for (k, (text, needle)) in cases.iter().enumerate() {
        let sc = dir.path().join(format!("bad{k}.toml"));
        std::fs::write(&sc, text).unwrap();
        let out = dir.path().join(format!("out{k}"));
        let o = brachia()
            .args(["plan", "--scenario"])
            .arg(&sc)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "case {k}: {err}");
        assert!(
            err.contains(needle),
            "case {k}: {err:?} should mention {needle:?}"
        );
        assert!(!out.exists(), "case {k}: nothing may be written");
    }
}
