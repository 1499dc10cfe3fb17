//! A robot read from a URDF file (crates/core/tests/data/urdf/hook2.urdf: two links turning about the
//! world's x axis, centres of mass off the links, a reversed elbow) is an ordinary robot for the
//! experiments: a scenario names it with `params = "...urdf"` and a `[urdf]` table, plans a swing from
//! its bar to the next (0.45 m along) and tracks it with the MPC on the model and the rapier plants,
//! ending within the 2 cm success radius of the bar.
//!
//! Conventions: SI units; positions in the grip frame of the imported robot's plane.

use brachia::urdf::{load_robot, Tip, UrdfOptions};
use brachia_run::{run_track, track_plan, ControllerKind, PlantKind, Scenario};
use std::path::PathBuf;

fn hook_urdf() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("../core/tests/data/urdf/hook2.urdf")
        .canonicalize()
        .unwrap()
}

#[test]
fn an_imported_hook_robot_plans_and_tracks_a_swing_between_two_bars() {
    let urdf = hook_urdf();
    let opts = UrdfOptions::new("hand", "hook:0,0.03,-0.05".parse::<Tip>().unwrap());
    let robot = load_robot(&urdf, Some(&opts), "<test>").unwrap();
    assert_eq!(robot.n(), 2);
    // the start: hanging back from the bar, the elbow bent
    let q0 = [-2.3, -0.6];
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("hook.toml");
    std::fs::write(
        &file,
        format!(
            r#"
params = "{}"
[urdf]
grip = "hand"
tip = "hook:0,0.03,-0.05"
[task]
q0 = [{}, {}]
target = [0.45, 0.0]
[planner]
swing_time = "auto"
knot_dt = 0.03
transcription = "multiple-shooting"
[planner.bounds]
q_rel_max = 2.0
qd_max = 10.0
"#,
            urdf.display(),
            q0[0],
            q0[1]
        ),
    )
    .unwrap();
    let ls = Scenario::load(&file).unwrap();
    assert_eq!(ls.robot.params(), robot.params());
    let mpc = run_track(&ls, ControllerKind::Mpc, PlantKind::Model, None)
        .unwrap()
        .into_tracked()
        .unwrap_or_else(|p| panic!("the plan did not converge: {:?}", p.plan.status));
    let plan = mpc.plan.as_ref().expect("planned here");
    assert!(plan.plan.converged());
    assert!(plan.plan.violations.ee_position < 1e-6);
    let bar = |r: &brachia_run::TrackRun| r.report.bar_error_m.expect("a swing to a bar");
    assert!(
        bar(&mpc) < 0.02 && mpc.report.reaches_bar == Some(true),
        "model plant: ends {} m from the bar",
        bar(&mpc)
    );
    let r = track_plan(
        &ls,
        ControllerKind::Mpc,
        PlantKind::Rapier,
        None,
        mpc.reference.clone(),
        mpc.plan_report.clone(),
    )
    .unwrap();
    assert!(
        bar(&r) < 0.02 && r.report.reaches_bar == Some(true),
        "rapier plant: ends {} m from the bar",
        bar(&r)
    );
}

/// The joint filter of the mass estimate needs every centre of mass on its link's axis: a scenario
/// with the off-axis hook robot and the default estimate is refused when it is read, naming the
/// field, before anything is planned; the windowed method is accepted.
#[test]
fn the_default_mass_estimate_on_an_off_axis_robot_is_refused_when_read() {
    let urdf = hook_urdf();
    let dir = tempfile::tempdir().unwrap();
    let write = |method: &str| {
        let file = dir.path().join(format!("hook-{method}.toml"));
        let estimate = if method.is_empty() {
            "{}".to_string()
        } else {
            format!("{{ method = \"{method}\" }}")
        };
        std::fs::write(
            &file,
            format!(
                "params = \"{}\"\n[urdf]\ngrip = \"hand\"\ntip = \"hook:0,0.03,-0.05\"\n\
                 [task]\nq0 = [-2.3, -0.6]\ntarget = [0.45, 0.0]\n\
                 [planner.bounds]\nq_rel_max = 2.0\nqd_max = 10.0\n\
                 [tracking]\nestimate_params = {estimate}\n",
                urdf.display()
            ),
        )
        .unwrap();
        file
    };
    let e = Scenario::load(&write("")).unwrap_err().to_string();
    assert!(
        e.contains("tracking.estimate_params.method") && e.contains("windows"),
        "{e}"
    );
    Scenario::load(&write("windows")).unwrap();
}
