//! Closed-loop tracking on the rapier physics-engine plant (paper V-B on a physics engine, and the
//! robustness experiment of V-D): the MPC must reach the bar, a ball on the planned path must be hit
//! near 0.6 s and knocked away, and the MPC must still end within 2 cm of the bar.
//!
//! Conventions: SI units (s, m, rad, N s); ee errors are distances to the reference EE position.

use brachia_run::scenario::LoadedScenario;
use brachia_run::{run_track, track_plan, ControllerKind, PlantKind, Scenario, TrackRun};
use std::path::{Path, PathBuf};

fn scenario(name: &str) -> LoadedScenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenarios")
        .join(name);
    Scenario::load(&path).unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// Plan once, then track that plan with each controller on the rapier plant.
fn track_all(ls: &LoadedScenario, controllers: &[ControllerKind]) -> Vec<TrackRun> {
    let first = run_track(ls, controllers[0], PlantKind::Rapier, None)
        .unwrap()
        .into_tracked()
        .expect("the plan converges");
    let mut runs = vec![first];
    for &c in &controllers[1..] {
        let (r, rep) = (runs[0].reference.clone(), runs[0].plan_report.clone());
        runs.push(track_plan(ls, c, PlantKind::Rapier, None, r, rep).unwrap());
    }
    runs
}

#[test]
fn mpc_tracks_the_paper_swing_on_rapier_within_a_centimetre() {
    let ls = scenario("tracking.toml");
    let run = &track_all(&ls, &[ControllerKind::Mpc])[0];
    let s = &run.summary;
    assert_eq!(run.log.plant, "rapier");
    assert!(
        s.ee_final_error_m < 0.01,
        "final EE error {} m",
        s.ee_final_error_m
    );
    // no obstacles: nothing to touch, the contact log holds its schema line and header only
    assert!(run.world.obstacles.is_empty() && run.world.contacts.is_empty());
    assert_eq!(
        run.folder.get("contacts.csv"),
        Some(&b"# brachia contacts schema 1\nt,link,body,impulse\n"[..])
    );
}

#[test]
fn ball_on_the_path_is_hit_near_0_6_s_and_the_mpc_still_reaches_the_bar() {
    let ls = scenario("robustness.toml");
    let runs = track_all(
        &ls,
        &[
            ControllerKind::Mpc,
            ControllerKind::Pd,
            ControllerKind::OpenLoop,
        ],
    );
    let mpc = &runs[0];
    let t_hit = mpc.world.first_contact_s().expect("the ball is hit");
    assert!((0.5..=0.7).contains(&t_hit), "first contact at {t_hit} s");
    // the ball was knocked away: it ends far from where it started
    let first = &mpc.world.track[0];
    let last = mpc.world.track.last().unwrap();
    let moved = (last[1] - first[1]).hypot(last[2] - first[2]);
    assert!(moved > 0.2, "the ball moved only {moved} m");
    // the hit disturbs the swing (larger EE error than on the undisturbed tracking run) ...
    assert!(
        mpc.summary.ee_error_max_m > 0.01,
        "max EE error {} m",
        mpc.summary.ee_error_max_m
    );
    // ... but the MPC still ends within 2 cm of the bar
    assert!(
        mpc.summary.ee_final_error_m < 0.02,
        "MPC final EE error {} m",
        mpc.summary.ee_final_error_m
    );
    // the baselines run on the same scenario; open loop cannot correct the hit
    for r in &runs[1..] {
        assert!(
            r.world.first_contact_s().is_some(),
            "{} never hit",
            r.log.controller
        );
    }
    let open = runs[2].summary.ee_final_error_m;
    assert!(
        open > mpc.summary.ee_final_error_m,
        "open loop {open} m vs MPC {} m",
        mpc.summary.ee_final_error_m
    );
    // the run folder carries the contact log and the ball track
    let csv = String::from_utf8(mpc.folder.get("contacts.csv").unwrap().to_vec()).unwrap();
    let csv = csv
        .strip_prefix("# brachia contacts schema 1\n")
        .expect("the schema line");
    assert!(csv.starts_with("t,link,body,impulse\n") && csv.lines().count() > 1);
    let obs = String::from_utf8(mpc.folder.get("obstacles.csv").unwrap().to_vec()).unwrap();
    let obs = obs
        .strip_prefix("# brachia obstacles schema 1\n")
        .expect("the schema line");
    assert!(obs.starts_with("t,obstacle_0_x,obstacle_0_y\n"));
    assert_eq!(obs.lines().count(), mpc.log.len() + 1);
}

#[test]
fn the_papers_ball_placement_is_never_hit() {
    let ls = scenario("robustness-paper.toml");
    let run = &track_all(&ls, &[ControllerKind::Mpc])[0];
    assert_eq!(run.world.obstacles.len(), 1);
    assert_eq!(run.world.first_contact_s(), None);
    assert!(run.summary.ee_final_error_m < 0.01);
}

#[test]
fn plant_obstacles_on_the_model_plant_are_refused_with_the_field_named() {
    let ls = scenario("robustness.toml");
    let err = run_track(&ls, ControllerKind::Mpc, PlantKind::Model, None).expect_err("refused");
    let msg = err.to_string();
    assert!(
        msg.contains("plant.obstacles") && msg.contains("robustness.toml"),
        "{msg}"
    );
}

#[test]
fn bad_plant_obstacles_name_file_and_field() {
    let dir = tempfile::tempdir().unwrap();
    let root: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let text = std::fs::read_to_string(root.join("scenarios/robustness.toml"))
        .unwrap()
        .replace(
            "params = \"../params/paper.toml\"",
            &format!("params = {:?}", root.join("params/paper.toml")),
        )
        .replace("mass = 0.4", "mass = -0.4");
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, text).unwrap();
    let msg = Scenario::load(&path).unwrap_err().to_string();
    assert!(
        msg.contains("bad.toml") && msg.contains("plant.obstacles[0].mass") && msg.contains("-0.4"),
        "{msg}"
    );
}
