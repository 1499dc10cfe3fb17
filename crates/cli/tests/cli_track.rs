//! `brachia track` as a user runs it: the tracking scenario on the model plant, the output contract, a
//! plant-mass mismatch, and reading a plan folder.

mod common;

use common::{brachia, report, root};

#[test]
fn mpc_tracks_the_paper_swing_on_the_model_plant() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("track");
    let o = brachia()
        .args(["track", "--scenario", "scenarios/tracking.toml", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&out);
    for key in [
        "controller",
        "plant",
        "ee_final_error_m",
        "ee_error_max_m",
        "joint_rms_error_rad",
        "energy_j",
        "planned_energy_j",
        "tau_min",
        "tau_max",
        "control_step_us_p50",
        "control_step_us_p99",
        "control_step_us_max",
        "qp_iterations_mean",
        "plan",
    ] {
        assert!(r.get(key).is_some(), "report.json lacks {key}");
    }
    assert_eq!(r["controller"], "mpc");
    assert_eq!(r["plant"], "model");
    let err = r["ee_final_error_m"].as_f64().unwrap();
    assert!(err < 5e-3, "final EE error {err}");
    let (e, ep) = (
        r["energy_j"].as_f64().unwrap(),
        r["planned_energy_j"].as_f64().unwrap(),
    );
    assert!(
        (e - ep).abs() / ep.abs() < 0.02,
        "executed {e} J vs planned {ep} J"
    );
    let csv = std::fs::read_to_string(out.join("closed_loop.csv")).unwrap();
    let csv = csv
        .strip_prefix("# brachia closed_loop schema 2\n")
        .expect("the schema line");
    assert!(
        csv.starts_with("t,q1,q2,q3,q4,qd1,qd2,qd3,qd4,tau2,tau3,tau4,ee_x,ee_y,ref_q1"),
        "{}",
        &csv[..100]
    );
    assert!(out.join("plan/trajectory.csv").exists() && out.join("plan/report.json").exists());

    // track the same plan from its folder with the open-loop baseline
    let out2 = dir.path().join("open");
    let o = brachia()
        .args([
            "track",
            "--scenario",
            "scenarios/tracking.toml",
            "--controller",
            "open-loop",
            "--plan",
        ])
        .arg(out.join("plan"))
        .arg("--out")
        .arg(&out2)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r2 = report(&out2);
    assert_eq!(r2["controller"], "open-loop");
    // open loop on the exact model: the plan's mean torque held over each 1 ms period replays the
    // plan (its replay within 1 mm); the MPC, starting on the plan, stays within it too
    let open = r2["ee_final_error_m"].as_f64().unwrap();
    let mpc = r["ee_final_error_m"].as_f64().unwrap();
    assert!(open < 1e-3 && mpc < 1e-3, "open loop {open} m, MPC {mpc} m");
}

#[test]
fn mpc_absorbs_ten_percent_heavier_links() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(root().join("scenarios/tracking.toml"))
        .unwrap()
        .replace(
            "params = \"../params/paper.toml\"",
            &format!("params = {:?}", root().join("params/paper.toml")),
        )
        + "\n[plant]\nmass_scale = 1.1\n";
    let sc = dir.path().join("heavy.toml");
    std::fs::write(&sc, text).unwrap();
    let mut errs = vec![];
    for ctrl in ["mpc", "pd", "open-loop"] {
        let out = dir.path().join(ctrl);
        let o = brachia()
            .args(["track", "--controller", ctrl, "--scenario"])
            .arg(&sc)
            .arg("--out")
            .arg(&out)
            .output()
            .unwrap();
        let e = report(&out)["bar_error_m"].as_f64().unwrap();
        // a miss is a failure (exit 1, said, the run folder kept); a catch is exit 0
        let said = String::from_utf8_lossy(&o.stderr).contains("this swing misses the bar");
        assert_eq!(said, e > 0.02, "{ctrl}: error {e} m");
        assert_eq!(
            o.status.code(),
            Some(if e > 0.02 { 1 } else { 0 }),
            "{ctrl}: error {e} m: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        assert_eq!(
            report(&out)["reaches_bar"],
            e <= 0.02,
            "{ctrl}: error {e} m"
        );
        // a catch has its capture time (the first slow pass within 2 cm), a miss has none
        let t = report(&out)["capture_t_s"].as_f64();
        assert_eq!(t.is_some(), e <= 0.02, "{ctrl}: capture at {t:?}");
        assert!(t.is_none_or(|t| t > 0.0), "{ctrl}: capture at {t:?}");
        errs.push(e);
    }
    // the open loop on the heavier plant misses (the note above was printed for it)
    assert!(errs[2] > 0.02, "{errs:?}");
    assert!(
        errs[0] < 0.02,
        "MPC final EE error with +10 % masses: {}",
        errs[0]
    );
    assert!(errs[0] < errs[2], "MPC {errs:?} should beat open loop");
}

#[test]
fn robustness_on_rapier_writes_contacts_and_obstacle_tracks() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("robust");
    let o = brachia()
        .args([
            "track",
            "--plant",
            "rapier",
            "--scenario",
            "scenarios/robustness.toml",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&out);
    assert_eq!(r["plant"], "rapier");
    assert_eq!(r["plant_substeps"], 1);
    let hit = r["first_contact_s"].as_f64().expect("first_contact_s");
    assert!((0.5..=0.7).contains(&hit), "first contact {hit} s");
    assert!(r["ee_final_error_m"].as_f64().unwrap() < 0.02);
    let contacts = std::fs::read_to_string(out.join("contacts.csv")).unwrap();
    let contacts = contacts
        .strip_prefix("# brachia contacts schema 1\n")
        .expect("the schema line");
    let first: Vec<&str> = contacts.lines().nth(1).unwrap().split(',').collect();
    assert_eq!(first.len(), 4);
    assert_eq!(first[2], "obstacle_0");
    let obstacles = std::fs::read_to_string(out.join("obstacles.csv")).unwrap();
    let obstacles = obstacles
        .strip_prefix("# brachia obstacles schema 1\n")
        .expect("the schema line");
    assert!(obstacles.starts_with("t,obstacle_0_x,obstacle_0_y\n"));
    let (start, end) = (
        obstacles.lines().nth(1).unwrap(),
        obstacles.lines().last().unwrap(),
    );
    assert_ne!(
        start.split(',').nth(1),
        end.split(',').nth(1),
        "the ball never moved"
    );

    // the same scenario on the model plant is refused: it cannot simulate the ball
    let o = brachia()
        .args([
            "track",
            "--plant",
            "model",
            "--scenario",
            "scenarios/robustness.toml",
            "--out",
        ])
        .arg(dir.path().join("model"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("plant.obstacles"), "{err}");
    assert!(!dir.path().join("model").exists());
}
