//! Run folders read back. A plan folder and a track folder (rapier plant, a ball that is hit:
//! contacts and obstacle tracks) are written, read with `PlanFolder::read` / `TrackFolder::read`, and
//! the data must equal what was written (to the CSVs' 9 decimals, times to 6); damaged files are refused
//! with the file, the field and the value named.

use brachia::control::{EstimateReport, EstimateSample};
use brachia_run::{
    run_plan, track_plan, ControllerKind, PlanFolder, PlanReport, PlantKind, RunFolder, Scenario,
    TrackFolder, TrackReport,
};
use serde_json::Value;
use std::path::Path;

/// `folder` with its file `name` replaced by `json`, written as the run writes it.
fn with_json(folder: &RunFolder, name: &str, json: &Value) -> RunFolder {
    let mut out = RunFolder::default();
    for n in folder.names().filter(|n| *n != name) {
        out.add(n, folder.get(n).unwrap().to_vec());
    }
    out.add_json(name, json);
    out
}

/// `rep` with the numbers a failed solve leaves not finite (a NaN iterate: objective, energies,
/// violations, final hand and its errors), `x` in each.
fn plan_not_finite(rep: &PlanReport, x: f64) -> PlanReport {
    let mut r = rep.clone();
    r.objective = x;
    r.energy_j = x;
    r.positive_work_j = x;
    r.max_violation = x;
    r.violations.dynamics = x;
    r.violations.ee_position = x;
    r.violations.ee_velocity = x;
    r.ee_final = [x, x];
    r.ee_final_error_m = x;
    r.replay_ee_error_m = x;
    r
}

/// `rep` with every number of a track run that can end up not finite (`x`): a diverged estimate
/// (its values, deviations and history), a failed plan's numbers, the closed loop's metrics and the
/// distance to the bar.
fn track_not_finite(rep: &TrackReport, x: f64) -> TrackReport {
    let mut r = rep.clone();
    r.plan = plan_not_finite(&r.plan, x);
    r.bar_error_m = Some(x);
    r.summary.ee_final_error_m = x;
    r.summary.joint_rms_error_rad = x;
    r.summary.qp_iterations_mean = x;
    r.summary.control_step_us_max = x;
    r.estimate = Some(EstimateReport {
        names: vec!["ZZR_1".into(), "MXR_1".into()],
        nominal: vec![0.2, 0.5],
        theta: vec![x, 0.5],
        std: vec![0.01, x],
        windows: 4,
        rejected: 1,
        history: vec![
            EstimateSample {
                t_s: 0.1,
                theta: vec![0.21, 0.5],
                std: vec![0.02, 0.01],
            },
            EstimateSample {
                t_s: 0.2,
                theta: vec![x, x],
                std: vec![x, 0.01],
            },
        ],
        used_from_s: Some(0.15),
    });
    r
}

/// The track report as `brachia track` writes it (schema 2).
fn track_json(rep: &TrackReport) -> Value {
    let mut json = rep.to_json();
    json["schema_version"] = 2.into();
    json
}

/// The robustness scenario (a ball on the path) on a coarse grid: a plan in about a second.
fn scenario() -> brachia_run::scenario::LoadedScenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/robustness.toml");
    let mut ls = Scenario::load(&path).unwrap();
    ls.scenario.planner.knot_dt = 0.04;
    ls.scenario.planner.transcription = brachia::planning::Transcription::Trapezoidal;
    ls.scenario.solver.backend = brachia::planning::Backend::Pounce;
    ls
}

/// Two JSON values equal up to a relative 1e-12 on numbers (a float's text may read back one ulp off).
fn same_json(a: &Value, b: &Value, at: &str) {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-12 * x.abs().max(1.0),
                "{at}: {x} vs {y}"
            );
        }
        (Value::Object(x), Value::Object(y)) => {
            assert_eq!(x.len(), y.len(), "{at}: keys differ");
            for (k, v) in x {
                same_json(v, &y[k], &format!("{at}.{k}"));
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{at}: lengths differ");
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                same_json(u, v, &format!("{at}[{i}]"));
            }
        }
        _ => assert_eq!(a, b, "{at}"),
    }
}

fn close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!((x - y).abs() <= tol, "{what}[{i}]: {x} vs {y}");
    }
}

#[test]
fn plan_and_track_folders_read_back_equal_and_damage_is_named() {
    let ls = scenario();
    let plan = run_plan(&ls).unwrap();
    assert!(plan.plan.converged(), "{:?}", plan.plan.status);
    let dir = tempfile::tempdir().unwrap();
    let pdir = dir.path().join("plan");
    plan.folder.write(&pdir).unwrap();
    // the plan folder alone, read from another working place: scenario.toml names params.toml beside it
    let back = PlanFolder::read(&pdir).unwrap();
    same_json(
        &back.report.to_json(),
        &plan.report.to_json(),
        "plan report",
    );
    assert_eq!(back.scenario.scenario.task, ls.scenario.task);
    assert_eq!(back.scenario.robot.params(), ls.robot.params());
    let (a, b) = (&back.trajectory, &plan.plan.trajectory);
    close(&a.t, &b.t, 1e-6, "t");
    close(&a.q, &b.q, 1e-9, "q");
    close(&a.qd, &b.qd, 1e-9, "qd");
    close(&a.tau, &b.tau, 1e-9, "tau");

    // a plan whose numbers are not finite is written with nulls; they read back infinite, the rest
    // as written, and the folder's page is drawn
    let bad = plan_not_finite(&plan.report, f64::NAN);
    let bdir = dir.path().join("plan-not-finite");
    with_json(&plan.folder, "report.json", &bad.to_json())
        .write(&bdir)
        .unwrap();
    let back = PlanFolder::read(&bdir).unwrap();
    assert_eq!(back.report, plan_not_finite(&back.report, f64::INFINITY));
    same_json(&back.report.to_json(), &bad.to_json(), "plan report");
    brachia_run::view::view_html(&bdir).unwrap();

    // track it with the MPC on the rapier plant: the ball is hit, so contacts and ball tracks are written
    let rep = plan.report.clone();
    let reference = plan.plan.trajectory.clone();
    let run = track_plan(
        &ls,
        ControllerKind::Mpc,
        PlantKind::Rapier,
        Some(plan),
        reference,
        rep,
    )
    .unwrap();
    assert!(!run.world.contacts.is_empty(), "the ball is never touched");
    let tdir = dir.path().join("track");
    run.folder.write(&tdir).unwrap();
    let back = TrackFolder::read(&tdir).unwrap();
    same_json(
        &back.report.to_json(),
        &run.report.to_json(),
        "track report",
    );
    // a re-plan whose predictions diverged: the report holds nulls and still reads back
    let mut diverged = run.report.clone();
    diverged.replans = vec![brachia::control::ReplanEvent {
        t_trigger_s: 1.0,
        predicted_miss_m: f64::INFINITY,
        status: brachia::planning::SolveStatus::MaxIterations,
        iterations: 3000,
        solve_time_s: 0.1,
        wall_time_s: 0.1,
        latency_s: 0.02,
        t_switch_s: None,
        plan_ee_error_m: f64::INFINITY,
        adopted: false,
        end_box_dropped: false,
        predicted_continue_m: Some(f64::NAN),
        predicted_replan_m: Some(0.01),
        planned_on_estimate: false,
        predicted_at_switch_m: Some([f64::INFINITY, 0.01]),
    }];
    diverged.replan_count = 1;
    let text = serde_json::to_string(&diverged.to_json()).unwrap();
    let read: brachia_run::TrackReport = serde_json::from_str(&text).unwrap();
    let e = &read.replans[0];
    assert_eq!(e.predicted_at_switch_m, Some([f64::INFINITY, 0.01]));
    assert_eq!(e.plan_ee_error_m, f64::INFINITY);
    assert_eq!(e.predicted_miss_m, f64::INFINITY);
    assert_eq!(e.predicted_continue_m, Some(f64::INFINITY));
    assert_eq!(e.predicted_replan_m, Some(0.01));
    // every number of the report that was not finite (NaN or infinite) is written `null` and read
    // back infinite; the folder reads back and its page is drawn
    for x in [f64::NAN, f64::INFINITY] {
        let bad = track_not_finite(&diverged, x);
        let bdir = dir.path().join("track-not-finite");
        with_json(&run.folder, "report.json", &track_json(&bad))
            .write(&bdir)
            .unwrap();
        let read = TrackFolder::read(&bdir).unwrap().report;
        assert_eq!(read.bar_error_m, Some(f64::INFINITY));
        assert_eq!(read.summary.control_step_us_max, f64::INFINITY);
        let est = read.estimate.as_ref().unwrap();
        assert_eq!((est.theta[0], est.std[1]), (f64::INFINITY, f64::INFINITY));
        assert_eq!(est.history[1].theta, [f64::INFINITY; 2]);
        assert_eq!(read.plan, plan_not_finite(&read.plan, f64::INFINITY));
        assert_eq!(read.replans[0].predicted_miss_m, f64::INFINITY);
        assert_eq!(read.summary, track_not_finite(&read, f64::INFINITY).summary);
        same_json(&read.to_json(), &bad.to_json(), "track report");
        brachia_run::view::view_html(&bdir).unwrap();
    }
    let (l, m) = (&back.log, &run.log);
    assert_eq!(
        (l.n, &l.controller, &l.plant),
        (m.n, &m.controller, &m.plant)
    );
    close(&l.t, &m.t, 1e-6, "log t");
    close(&l.x, &m.x, 1e-9, "log x");
    close(&l.tau, &m.tau, 1e-9, "log tau");
    close(&l.ref_x, &m.ref_x, 1e-9, "log ref_x");
    let flat = |v: &[[f64; 2]]| v.iter().flatten().copied().collect::<Vec<_>>();
    close(&flat(&l.ee), &flat(&m.ee), 1e-9, "log ee");
    close(&flat(&l.ref_ee), &flat(&m.ref_ee), 1e-9, "log ref_ee");
    let (w, v) = (&back.world, &run.world);
    assert_eq!(w.obstacles, v.obstacles);
    assert_eq!(w.contacts.len(), v.contacts.len());
    for (c, d) in w.contacts.iter().zip(&v.contacts) {
        assert_eq!((c.link, c.body), (d.link, d.body));
        assert!((c.t - d.t).abs() < 1e-6 && (c.impulse - d.impulse).abs() < 1e-9);
    }
    assert_eq!(w.track.len(), v.track.len());
    for (r, s) in w.track.iter().zip(&v.track) {
        close(r, s, 1e-6, "obstacle track");
    }
    assert!(back.plan.is_some(), "plan/ is read with the track folder");

    // damage: a non-finite value, a short row, a missing report, a bad contact body
    let log = tdir.join("closed_loop.csv");
    let text = std::fs::read_to_string(&log).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let good = lines[3].clone();
    let mut cols: Vec<&str> = good.split(',').collect();
    cols[2] = "NaN";
    lines[3] = cols.join(",");
    std::fs::write(&log, lines.join("\n")).unwrap();
    let err = TrackFolder::read(&tdir).unwrap_err().to_string();
    assert!(
        err.contains("closed_loop.csv") && err.contains("line 4, q2") && err.contains("NaN"),
        "{err}"
    );
    lines[3] = good.rsplit_once(',').unwrap().0.to_string();
    std::fs::write(&log, lines.join("\n")).unwrap();
    let err = TrackFolder::read(&tdir).unwrap_err().to_string();
    assert!(
        err.contains("line 4, control_us") && err.contains("too few"),
        "{err}"
    );
    std::fs::write(&log, &text).unwrap();
    let contacts = tdir.join("contacts.csv");
    let ctext = std::fs::read_to_string(&contacts).unwrap();
    std::fs::write(&contacts, ctext.replacen("obstacle_0", "obstacle_7", 1)).unwrap();
    let err = TrackFolder::read(&tdir).unwrap_err().to_string();
    assert!(
        err.contains("contacts.csv") && err.contains("body") && err.contains("obstacle_7"),
        "{err}"
    );
    std::fs::remove_file(tdir.join("report.json")).unwrap();
    let err = TrackFolder::read(&tdir).unwrap_err().to_string();
    assert!(
        err.contains("report.json") && err.contains("missing"),
        "{err}"
    );
    std::fs::remove_file(pdir.join("params.toml")).unwrap();
    let err = PlanFolder::read(&pdir).unwrap_err().to_string();
    assert!(err.contains("params.toml"), "{err}");
}

#[test]
fn a_free_swing_time_plan_folder_re_runs_to_the_same_plan() {
    // The resolved scenario.toml of a free-swing-time plan keeps the range and the start of the
    // search (not the optimum, a result): planning it again gives the same T and objective.
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/tracking.toml");
    let mut ls = Scenario::load(&path).unwrap();
    ls.scenario.planner.free_swing_time = Some([2.0, 2.6]);
    let first = run_plan(&ls).unwrap();
    assert!(first.plan.converged(), "{:?}", first.plan.status);
    let dir = tempfile::tempdir().unwrap();
    let pdir = dir.path().join("plan");
    first.folder.write(&pdir).unwrap();
    let back = PlanFolder::read(&pdir).unwrap();
    let sp = &back.scenario.scenario.planner;
    assert_eq!(sp.free_swing_time, Some([2.0, 2.6]));
    assert_ne!(
        sp.swing_time,
        brachia::planning::SwingTime::Seconds(first.plan.swing_time_s)
    );
    let again = run_plan(&back.scenario).unwrap();
    assert_eq!(again.plan.swing_time_s, first.plan.swing_time_s);
    assert_eq!(again.plan.objective, first.plan.objective);
}
