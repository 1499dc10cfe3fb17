//! Torque timing and the robustness benchmark: open loop on the exact model
//! plant replays a plan to the plan's own accuracy; the plant clock counts steps; `[disturbances]` is
//! validated; the benchmark is deterministic for any number of worker threads.
//!
//! Units: s, m, rad, N m.

use brachia_experiments::benchmark::{run_benchmark_on, BenchmarkSettings};
use brachia_experiments::scenario::LoadedScenario;
use brachia_experiments::{no_progress, run_plan, track_plan, ControllerKind, PlantKind, Scenario};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn tiny() -> LoadedScenario {
    Scenario::load(&data("benchmark-tiny.toml")).unwrap()
}

/// A held-torque plan (multiple shooting): open loop on the exact model plant ends within 2x the
/// plan's own replay error (it was 21.6 mm on the uniform-rod robot and 9.7 mm on the paper's when the
/// runner held each sample from the start of its period, half a period off the profile), and the
/// plant clock reads k * dt.
#[test]
fn open_loop_on_the_exact_model_replays_the_plan() {
    let ls = tiny();
    let plan = run_plan(&ls).unwrap();
    assert!(plan.plan.converged());
    let replay = plan.plan.replay_ee_error_m;
    let (r, rep) = (plan.plan.trajectory.clone(), plan.report.clone());
    let run = track_plan(
        &ls,
        ControllerKind::OpenLoop,
        PlantKind::Model,
        None,
        r,
        rep,
    )
    .unwrap();
    let got = run.summary.ee_final_error_m;
    let target = ls.scenario.task.target;
    let last = run.log.len() - 1;
    let ee = run.log.ee[last];
    let to_bar = (ee[0] - target[0]).hypot(ee[1] - target[1]);
    eprintln!("open loop: {got:.3e} m from the reference, {to_bar:.3e} m from the bar; replay {replay:.3e} m");
    assert!(to_bar <= 2.0 * replay + 1e-9, "{to_bar} vs replay {replay}");
    for (k, &t) in run.log.t.iter().enumerate() {
        assert_eq!(t, k as f64 * 1e-3, "row {k}");
    }
}

fn bad_scenario(extra: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(data("benchmark-tiny.toml"))
        .unwrap()
        .replace(
            "../../../../params/paper.toml",
            &format!(
                "{}",
                Path::new(env!("CARGO_MANIFEST_DIR"))
                    .join("../../params/paper.toml")
                    .display()
            ),
        );
    let path = dir.path().join("bad.toml");
    std::fs::write(&path, format!("{text}\n[disturbances]\n{extra}\n")).unwrap();
    match Scenario::load(&path) {
        Ok(_) => panic!("accepted: {extra}"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn the_disturbances_section_refuses_bad_values() {
    for (extra, field) in [
        ("delay_s = 0.005", "delay_s"),
        (
            "actuation_delay_s = -0.001",
            "disturbances.actuation_delay_s",
        ),
        (
            "motor_time_constant_s = nan",
            "disturbances.motor_time_constant_s",
        ),
        ("mass_scale = [1.0, 1.0]", "disturbances.mass_scale"),
        ("com_scale = [1.0, 1.0, 1.0, 5.0]", "disturbances"),
        ("torque_noise_std = 1e9", "disturbances.torque_noise_std"),
        (
            "pushes = [{ t_s = 0.5, link = 9, point_m = 0.1, impulse_n_s = [0.0, 1.0] }]",
            "disturbances.pushes[0].link",
        ),
        ("start_offset = [0.1]", "disturbances.start_offset"),
    ] {
        let e = bad_scenario(extra);
        assert!(e.contains(field), "{extra}: {e}");
    }
}

#[test]
fn the_benchmark_is_deterministic_for_any_number_of_jobs() {
    let ls = tiny();
    let plan = run_plan(&ls).unwrap();
    let reference = Arc::new(plan.plan.trajectory.clone());
    let settings = |jobs| BenchmarkSettings {
        levels: 2,
        monte_carlo_runs: 2,
        family_runs: 0,
        run_sweeps: true,
        jobs: Some(jobs),
        only_sweeps: vec!["actuation_delay".into(), "push".into(), "noise_q".into()],
        only_controllers: vec!["pd".into(), "open-loop".into(), "mpc+replan".into()],
        seed: 3,
        cancel: None,
    };
    let a = run_benchmark_on(&ls, Arc::clone(&reference), &settings(1), &no_progress).unwrap();
    let b = run_benchmark_on(&ls, Arc::clone(&reference), &settings(2), &no_progress).unwrap();
    assert_eq!(a.rows.len(), 3 * (3 * 2 + 2));
    assert_eq!(a.rows, b.rows);
    assert_eq!(a.runs_csv(), b.runs_csv());
    assert_eq!(a.scorecard_json(), b.scorecard_json());
    // level 0 of every sweep is the undisturbed run: the same for every sweep
    let nominal: Vec<_> = a
        .rows
        .iter()
        .filter(|r| r.controller == "pd" && r.level == 0.0 && r.disturbance != "monte_carlo")
        .map(|r| r.final_error_m)
        .collect();
    assert_eq!(nominal.len(), 3);
    assert!(nominal.iter().all(|&e| e == nominal[0]), "{nominal:?}");
    // the largest push moves the open-loop end far more than nothing does
    let ol = |d: &str, l: f64| {
        a.rows
            .iter()
            .find(|r| r.controller == "open-loop" && r.disturbance == d && r.level == l)
            .unwrap()
            .final_error_m
    };
    assert!(ol("push", 0.5) > 10.0 * ol("push", 0.0) + 0.01);
    // a written folder holds every file, plots included
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("bench");
    a.write(&out).unwrap();
    for f in [
        "runs.csv",
        "scorecard.json",
        "summary.md",
        "success_push.png",
        "success_push.svg",
    ] {
        assert!(out.join(f).is_file(), "{f}");
    }
}

/// A scorecard whose statistics are not finite (NaN or infinite) is written with `null`s, which
/// read back as infinite: the folder's page is drawn and shows them as `inf`.
#[test]
fn a_scorecard_with_numbers_that_are_not_finite_reads_back() {
    use brachia_experiments::benchmark::{BenchRow, ControllerScore, Score};
    use brachia_experiments::Benchmark;
    let row = BenchRow {
        controller: "mpc".into(),
        disturbance: "monte_carlo".into(),
        level: 0.0,
        seed: 1,
        success: false,
        capture_t_s: None,
        final_error_m: 0.05,
        energy_j: 1.0,
        peak_torque_nm: 2.0,
        smoothness_nm: 0.1,
        ball_kg: 0.0,
        ball_t_s: None,
        contact_s: None,
        replans: 1,
        replans_adopted: 0,
        replan_latency_s: 0.02,
        replan_iterations: 10,
        contact_last_s: None,
        contact_impulse_n_s: 0.0,
        replan_t_s: vec![1.0],
        replan_miss_m: vec![f64::INFINITY],
    };
    let score = |x: f64| Score {
        runs: 1,
        success_pct: 0.0,
        energy_j: x,
        peak_torque_nm: 2.0,
        smoothness_nm: x,
        final_error_m: x,
        replans_per_run: 1.0,
    };
    let bench = Benchmark {
        scenario: "not-finite".into(),
        levels: 2,
        monte_carlo_runs: 1,
        success_radius_m: 0.02,
        sweeps: vec![],
        rows: vec![row],
        scores: vec![ControllerScore {
            controller: "mpc".into(),
            per_disturbance: vec![("monte_carlo".into(), score(f64::INFINITY))],
            overall: score(f64::NAN),
            robustness_score: f64::NAN,
        }],
        wall_time_s: 1.0,
    };
    let text = bench.scorecard_json().to_string();
    assert!(text.contains("\"final_error_m\":null"), "{text}");
    let dir = tempfile::tempdir().unwrap();
    bench.folder().write(dir.path()).unwrap();
    let page = brachia_experiments::view::view_html(dir.path()).unwrap();
    assert!(
        page.contains("<td>inf</td>"),
        "the page shows the infinite score"
    );
}
