//! Any link count 2..12 works end to end. A 3-link and a 6-link robot (params/three-link.toml,
//! params/six-link.toml) plan their swing and are tracked by the MPC and the PD baseline on the model plant
//! and by the MPC on the rapier plant, with the per-link default weights and gains (their scenarios have no
//! `[tracking]` section). Before the fix the 4-link MPC and PD defaults made every other link count fail
//! validation ("`tracking.mpc: MpcSettings.q_diag` = 8 values: needs 12"), even for `brachia plan`.
//!
//! Conventions: SI units; EE errors are distances to the bar.

use brachia_run::scenario::LoadedScenario;
use brachia_run::{run_track, track_plan, ControllerKind, PlantKind, Scenario, Uses};
use std::path::Path;

fn scenario(name: &str) -> LoadedScenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios")
        .join(name);
    Scenario::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn plan_and_track(name: &str, links: usize) {
    let ls = scenario(name);
    assert_eq!(ls.robot.n(), links);
    let mpc = run_track(&ls, ControllerKind::Mpc, PlantKind::Model, None)
        .unwrap()
        .into_tracked()
        .unwrap_or_else(|p| panic!("{name}: the plan did not converge: {:?}", p.plan.status));
    let plan = mpc.plan.as_ref().expect("planned here");
    assert!(plan.plan.converged());
    assert!(
        plan.plan.violations.ee_position < 1e-6,
        "{name}: planned EE misses the bar by {} m",
        plan.plan.violations.ee_position
    );
    assert!(
        plan.plan.replay_ee_error_m < 0.03,
        "{name}: open-loop replay misses by {} m",
        plan.plan.replay_ee_error_m
    );
    assert!(
        mpc.summary.ee_final_error_m < 0.01,
        "{name}: MPC ends {} m from the reference",
        mpc.summary.ee_final_error_m
    );
    let csv = String::from_utf8_lossy(mpc.folder.get("closed_loop.csv").unwrap());
    let csv = csv
        .strip_prefix("# brachia closed_loop schema 2\n")
        .expect("the schema line");
    let header = csv.lines().next().unwrap_or_default();
    assert!(
        header.starts_with("t,q1,") && header.contains(&format!("tau{links}")),
        "{header}"
    );
    for (controller, plant, tol) in [
        (ControllerKind::Pd, PlantKind::Model, 0.05),
        (ControllerKind::Mpc, PlantKind::Rapier, 0.02),
    ] {
        let r = track_plan(
            &ls,
            controller,
            plant,
            None,
            mpc.reference.clone(),
            mpc.plan_report.clone(),
        )
        .unwrap();
        assert!(
            r.summary.ee_final_error_m < tol,
            "{name} {controller:?} on {plant:?}: ends {} m from the reference",
            r.summary.ee_final_error_m
        );
    }
}

#[test]
fn a_three_link_robot_plans_and_tracks() {
    plan_and_track("three-link.toml", 3);
}

#[test]
fn a_six_link_robot_plans_and_tracks() {
    plan_and_track("six-link.toml", 6);
}

#[test]
fn plan_validates_only_the_sections_it_uses() {
    // a wrong [tracking.mpc] does not stop `brachia plan` (which does not use it), but stops `track`
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let text = std::fs::read_to_string(root.join("scenarios/three-link.toml"))
        .unwrap()
        .replace(
            "\"../params/three-link.toml\"",
            &format!("{:?}", root.join("params/three-link.toml")),
        )
        + "\n[tracking.mpc]\nq_diag = [1.0, 1.0]\n";
    let path = dir.path().join("s.toml");
    std::fs::write(&path, text).unwrap();
    Scenario::load_for(&path, Uses::Plan).expect("plan does not read [tracking]");
    let e = Scenario::load_for(&path, Uses::Track)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("s.toml") && e.contains("tracking.mpc.q_diag") && e.contains("needs 6"),
        "{e}"
    );
}

#[test]
fn tracking_section_takes_tvlqr_and_the_kalman_filter() {
    // `controller = "tvlqr"`, `kalman = true` and the [tracking.estimator] / [tracking.tvlqr] tables
    // load; a bad value names its field; an unknown field is refused.
    let dir = tempfile::tempdir().unwrap();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let base = std::fs::read_to_string(root.join("scenarios/three-link.toml"))
        .unwrap()
        .replace(
            "\"../params/three-link.toml\"",
            &format!("{:?}", root.join("params/three-link.toml")),
        );
    let path = dir.path().join("s.toml");
    let load = |extra: &str| {
        std::fs::write(&path, format!("{base}\n{extra}")).unwrap();
        Scenario::load_for(&path, Uses::Track)
    };
    let ls = load(
        "[tracking]\ncontroller = \"tvlqr\"\nkalman = true\n[tracking.estimator]\n\
         actuation_delay_s = 0.005\n[tracking.tvlqr]\ndt = 0.01\n",
    )
    .unwrap();
    let t = &ls.scenario.tracking;
    assert_eq!(t.controller, ControllerKind::Tvlqr);
    assert!(t.kalman && t.estimator.actuation_delay_s == 0.005 && t.tvlqr.dt == 0.01);
    for (extra, want) in [
        (
            "[tracking.estimator]\nmeas_q_std = 0.0\n",
            "tracking.estimator.meas_q_std",
        ),
        (
            "[tracking.estimator]\nactuation_delay_s = 2.0\n",
            "tracking.estimator.actuation_delay_s",
        ),
        (
            "[tracking.tvlqr]\nr_diag = [1.0]\n",
            "tracking.tvlqr.r_diag",
        ),
        (
            "[tracking.mpc]\nrate_diag = [-1.0, 0.0]\n",
            "tracking.mpc.rate_diag",
        ),
        ("[tracking.estimator]\ndelay_ms = 5\n", "delay_ms"),
    ] {
        let e = load(extra).unwrap_err().to_string();
        assert!(e.contains("s.toml") && e.contains(want), "{extra}: {e}");
    }
}
