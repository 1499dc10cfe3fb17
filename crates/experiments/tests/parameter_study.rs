//! The parameter study (paper Section V-A): scaling rule, start pose, a small grid end to end, failed
//! cells kept, settings errors. Coarse knots (50 ms) keep every solve short. Units: m, kg, s, J.

use brachia::model::{Robot, RobotParams};
use brachia::planning::{freefall_time, NlpSettings, PlannerSettings, SolveStatus};
use brachia_experiments::{
    no_progress, parameter_study_folder, run_parameter_study, run_parameter_study_cancellable,
    scaled_params, start_pose, BaseParams, CancelToken, CellStart, ExpError,
    ParameterStudySettings, Progress,
};
use std::path::PathBuf;
use std::sync::Mutex;

fn paper() -> RobotParams {
    Robot::paper().params().clone()
}

fn quick(r2: Vec<f64>, offsets_s: Vec<f64>) -> ParameterStudySettings {
    ParameterStudySettings {
        r2,
        offsets_s,
        stick_r2: vec![],
        planner: PlannerSettings {
            knot_dt: 0.05,
            ..Default::default()
        },
        ..Default::default()
    }
}

#[test]
fn r2_one_half_is_table_one() {
    let base = paper();
    let p = scaled_params(&base, 0.5, 0.71).unwrap();
    assert_eq!(p.links, base.links);
    assert_eq!(p.actuators, base.actuators);
    assert_eq!(p.gravity, base.gravity);
}

#[test]
fn lengths_sum_to_the_arm_length_and_links_scale_with_length() {
    let base = paper();
    for r2 in [0.1, 0.2, 0.35, 0.8, 0.9] {
        let p = scaled_params(&base, r2, 0.71).unwrap();
        let l: Vec<f64> = p.links.iter().map(|l| l.length).collect();
        assert!((l[0] + l[1] - 0.71).abs() < 1e-15 && (l[2] + l[3] - 0.71).abs() < 1e-15);
        assert!((l[0] / (l[0] + l[1]) - r2).abs() < 1e-15 && l[0] == l[3] && l[1] == l[2]);
        for (new, old) in p.links.iter().zip(&base.links) {
            let s = new.length / old.length;
            assert!((new.mass / old.mass - s).abs() < 1e-12);
            assert!((new.com / new.length - old.com / old.length).abs() < 1e-12);
            assert!((new.inertia / old.inertia - s.powi(3)).abs() < 1e-12);
            assert_eq!(new.radius, old.radius);
        }
        Robot::from_params(p, "scaled").unwrap();
    }
    assert!(scaled_params(&base, 1.0, 0.71).is_err());
    let mut three = base.clone();
    three.links.pop();
    assert!(scaled_params(&three, 0.5, 0.71).is_err());
}

#[test]
fn start_pose_puts_the_ee_at_the_start_bar_with_straight_arms() {
    for r2 in [0.1, 0.5, 0.9] {
        let robot = Robot::from_params(scaled_params(&paper(), r2, 0.71).unwrap(), "r2").unwrap();
        let q = start_pose(&robot, [-1.0, 0.0]).unwrap();
        let ee = robot.ee_position(&q);
        assert!(
            (ee[0] + 1.0).abs() < 1e-12 && ee[1].abs() < 1e-12,
            "EE {ee:?}"
        );
        assert_eq!((q[1], q[3]), (0.0, 0.0));
        // the lower solution: shoulder below the bar, close to the paper's [-2.35, 0, -1.55, 0]
        let mut joints = [[0.0; 2]; 5];
        robot.joint_positions(&q, &mut joints);
        assert!(joints[2][1] < 0.0);
        assert!(
            (q[0] + 2.35).abs() < 0.01 && (q[2] + 1.55).abs() < 0.04,
            "{q:?}"
        );
    }
    let robot = Robot::paper();
    assert!(start_pose(&robot, [-1.5, 0.0]).is_err());
}

#[test]
fn freefall_time_grows_with_the_lower_arm() {
    // Fig. 4a of the paper
    let t: Vec<f64> = [0.2, 0.5, 0.8]
        .iter()
        .map(|&r2| {
            let robot =
                Robot::from_params(scaled_params(&paper(), r2, 0.71).unwrap(), "r2").unwrap();
            let q0 = start_pose(&robot, [-1.0, 0.0]).unwrap();
            freefall_time(&robot, &q0, 0.0).unwrap()
        })
        .collect();
    assert!(t[0] < t[1] && t[1] < t[2], "T_freefall {t:?}");
}

#[test]
fn small_grid_runs_and_fills_the_run_folder() {
    let s = ParameterStudySettings {
        stick_r2: vec![0.3, 0.7],
        ..quick(vec![0.3, 0.7], vec![-0.2, 0.0, 0.2])
    };
    let heard = Mutex::new(Vec::<Progress>::new());
    let record = |p: Progress| heard.lock().unwrap().push(p);
    let study = run_parameter_study(&s, &record).unwrap();
    assert_eq!(study.cells.len(), 6);
    // one report per solve (6 cells; both stick swings are grid centres), counting 1..=6
    let mut heard = heard.into_inner().unwrap();
    heard.sort_by_key(|p| p.done);
    let done: Vec<u64> = heard.iter().map(|p| p.done).collect();
    assert_eq!(done, (1..=6).collect::<Vec<u64>>());
    assert!(heard.iter().all(|p| p.total == 6 && !p.what.is_empty()));
    assert_eq!(study.rows.len(), 2);
    for (i, &r2) in s.r2.iter().enumerate() {
        let row = &study.rows[i];
        assert!((row.swing_time_s - 2.0 * row.freefall_time_s).abs() < 1e-12);
        for (j, &off) in s.offsets_s.iter().enumerate() {
            let c = study.cell(i, j);
            assert_eq!((c.r2, c.offset_s), (r2, off));
            assert!((c.swing_time_s - row.swing_time_s - off).abs() < 1e-12);
            assert_eq!(c.converged, c.status.is_converged());
            assert_eq!(c.converged, c.energy_j.is_some());
            if let Some(e) = c.energy_j {
                let w = c.positive_work_j.unwrap();
                assert!(
                    e.is_finite() && w >= 0.0 && w >= e - 1e-9,
                    "energy {e} J, positive work {w} J at r2 {r2} offset {off}"
                );
            }
        }
        if let Some(t) = row.argmin_swing_time_s {
            let best = row.min_energy_j.unwrap();
            assert!(study
                .cells
                .iter()
                .filter(|c| c.r2 == r2)
                .all(|c| c.energy_j.is_none_or(|e| e >= best)));
            assert!(s
                .offsets_s
                .iter()
                .any(|o| (row.swing_time_s + o - t).abs() < 1e-9));
        }
    }
    assert!(study.failed_cells() < 6, "every cell failed");
    assert_eq!(study.sticks.len(), 2);
    for st in &study.sticks {
        let tr = &st.trajectory;
        assert!((tr.t[1] - 1e-3).abs() < 1e-12);
        // eq. (18) is the work of the actuated joints, so it equals the gain in mechanical energy
        // (up to the 1 ms quadrature and the transcription's error at 50 ms knots: ~1 % measured)
        let last = tr.len() - 1;
        let gain = st.robot.energy(tr.q(last), tr.qd(last)) - st.robot.energy(tr.q(0), tr.qd(0));
        let e = st.energy_j.unwrap();
        eprintln!(
            "r2 {}: eq. (18) {e} J, mechanical energy gain {gain} J",
            st.r2
        );
        assert!(
            (e - gain).abs() < 0.05 * e.abs().max(1.0),
            "r2 {}: eq. (18) {e} J, mechanical energy gain {gain} J",
            st.r2
        );
    }

    let f = parameter_study_folder(&study);
    let names: Vec<&str> = f.names().collect();
    for want in [
        "cells.csv",
        "freefall.csv",
        "report.json",
        "stick_r2_0.30.csv",
        "stick_r2_0.30_params.toml",
        "stick_r2_0.70.csv",
        "stick_r2_0.70_params.toml",
    ] {
        assert!(names.contains(&want), "{want} missing from {names:?}");
    }
    let cells = std::str::from_utf8(f.get("cells.csv").unwrap()).unwrap();
    let cells = cells
        .strip_prefix("# brachia cells schema 1\n")
        .expect("the schema line");
    assert!(cells.starts_with("r2,offset_s,swing_time_s,status,converged,energy_j,"));
    assert_eq!(cells.lines().count(), 7);
    let report: serde_json::Value = serde_json::from_slice(f.get("report.json").unwrap()).unwrap();
    assert_eq!(report["failed_cells"], study.failed_cells());
    assert_eq!(report["rows"].as_array().unwrap().len(), 2);
    assert!(report["settings"]["base_params"]["inline"]["links"].is_array());
    let toml_text = std::str::from_utf8(f.get("stick_r2_0.30_params.toml").unwrap()).unwrap();
    let p = RobotParams::from_toml_str(toml_text, "stick").unwrap();
    assert_eq!(&p, study.sticks[0].robot.params());
    let traj = std::str::from_utf8(f.get("stick_r2_0.70.csv").unwrap()).unwrap();
    let traj = traj
        .strip_prefix("# brachia stick schema 1\n")
        .expect("the schema line");
    assert!(traj.starts_with("t,q1,q2,q3,q4,qd1"));
}

/// Continuation in r2: without self-collision rows the r2 = 0.9 robot's centre cell does not converge
/// from the planner's own guess within 80 iterations (it stops at the cap), but it does warm-started
/// from the converged r2 = 0.8 centre, its time axis rescaled (41 iterations). The study solves it
/// that way: the cell converges, says `warm-from-row`, counts both attempts, and its plan meets the
/// replay accuracy of its own mesh (1 mm). (With self-collision on, the r2 = 0.9 centre does not converge on this
/// mesh even so: docs/parameter-study.md.)
#[test]
fn a_centre_that_fails_cold_is_continued_from_the_neighbouring_row() {
    let cap = 80;
    let mut s = ParameterStudySettings {
        solver: NlpSettings {
            max_iter: cap,
            ..Default::default()
        },
        stick_r2: vec![0.9],
        r2: vec![0.8, 0.9],
        offsets_s: vec![0.0],
        ..Default::default()
    };
    s.planner.self_collision = false;
    // the continuation in r2 is tested, not the one on the torque limits
    s.planner.torque_continuation = false;
    let study = run_parameter_study(&s, &no_progress).unwrap();
    let (lower, upper) = (study.cell(0, 0), study.cell(1, 0));
    assert!(lower.converged, "r2 = 0.8: {:?}", lower.status);
    assert_eq!(lower.start, CellStart::Cold);
    assert!(upper.converged, "r2 = 0.9: {:?}", upper.status);
    assert_eq!(upper.start, CellStart::WarmFromRow, "{upper:?}");
    // the cold attempt ran to the cap, the warm one converged: both are counted
    assert!(upper.iterations > cap, "{upper:?}");
    assert!(upper.replay_ee_error_m.unwrap() < 1e-2, "{upper:?}");
    // the stick diagram is the continued centre's swing
    assert_eq!(study.sticks.len(), 1);
    assert_eq!(study.sticks[0].energy_j, upper.energy_j);
    let f = parameter_study_folder(&study);
    let cells = std::str::from_utf8(f.get("cells.csv").unwrap()).unwrap();
    let cells = cells
        .strip_prefix("# brachia cells schema 1\n")
        .expect("the schema line");
    assert_eq!(cells.matches(",warm-from-row,").count(), 1);
}

#[test]
fn failed_cells_are_kept_with_their_status_and_no_energy() {
    let s = ParameterStudySettings {
        solver: NlpSettings {
            max_iter: 2,
            ..Default::default()
        },
        stick_r2: vec![0.5],
        ..quick(vec![0.5], vec![-0.1, 0.0, 0.1])
    };
    let study = run_parameter_study(&s, &no_progress).unwrap();
    assert_eq!(study.cells.len(), 3);
    assert_eq!(study.failed_cells(), 3);
    for c in &study.cells {
        assert_eq!(c.status, SolveStatus::MaxIterations);
        assert!(!c.converged && c.energy_j.is_none() && c.iterations >= 2);
        assert!(c.solve_time_s > 0.0);
    }
    let row = &study.rows[0];
    assert_eq!(row.failed_cells, 3);
    assert!(row.argmin_swing_time_s.is_none() && row.energy_at_t_j.is_none());
    assert_eq!(study.sticks.len(), 1);
    assert!(study.sticks[0].energy_j.is_none());
    let f = parameter_study_folder(&study);
    let cells = std::str::from_utf8(f.get("cells.csv").unwrap()).unwrap();
    let cells = cells
        .strip_prefix("# brachia cells schema 1\n")
        .expect("the schema line");
    assert_eq!(cells.matches(",max_iterations,false,,,,").count(), 3);
}

#[test]
fn bad_settings_name_the_field() {
    let ok = ParameterStudySettings::default();
    ok.validate().unwrap();
    let cases: Vec<(ParameterStudySettings, &str)> = vec![
        (
            ParameterStudySettings {
                r2: vec![0.2, 1.2],
                ..ok.clone()
            },
            "r2[1]",
        ),
        (
            ParameterStudySettings {
                r2: vec![0.5, 0.4],
                ..ok.clone()
            },
            "r2[1]",
        ),
        (
            ParameterStudySettings {
                offsets_s: vec![],
                ..ok.clone()
            },
            "offsets_s",
        ),
        (
            ParameterStudySettings {
                arm_length_m: -0.7,
                ..ok.clone()
            },
            "arm_length_m",
        ),
        (
            ParameterStudySettings {
                stick_r2: vec![0.0],
                ..ok.clone()
            },
            "stick_r2[0]",
        ),
        (
            ParameterStudySettings {
                planner: PlannerSettings {
                    knot_dt: 0.0,
                    ..Default::default()
                },
                ..ok.clone()
            },
            "planner.knot_dt",
        ),
        (
            ParameterStudySettings {
                planner: PlannerSettings {
                    swing_time: brachia::planning::SwingTime::Seconds(2.0),
                    ..Default::default()
                },
                ..ok.clone()
            },
            "planner.swing_time",
        ),
        (
            ParameterStudySettings {
                solver: NlpSettings {
                    tol: -1.0,
                    ..Default::default()
                },
                ..ok.clone()
            },
            "solver.tol",
        ),
        (
            ParameterStudySettings {
                target: [f64::NAN, 0.0],
                ..ok.clone()
            },
            "target",
        ),
        (
            // the default backend (ocp) solves multiple shooting only
            ParameterStudySettings {
                planner: PlannerSettings {
                    transcription: brachia::planning::Transcription::HermiteSimpson,
                    ..Default::default()
                },
                ..ok.clone()
            },
            "solver.backend, planner.transcription",
        ),
    ];
    for (s, field) in cases {
        let e = s.validate().unwrap_err().to_string();
        assert!(e.contains(&format!("`{field}`")), "{field}: {e}");
        let e = run_parameter_study(&s, &no_progress)
            .unwrap_err()
            .to_string();
        assert!(e.contains(&format!("`{field}`")), "{field}: {e}");
    }
    // a swing time T + offset <= 0 is refused before solving
    let s = quick(vec![0.5], vec![-10.0, 0.0]);
    let e = run_parameter_study(&s, &no_progress)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`offsets_s[0]`"), "{e}");
    // a missing base parameters file
    let s = ParameterStudySettings {
        base_params: BaseParams::File(PathBuf::from("/nonexistent/params.toml")),
        ..quick(vec![0.5], vec![0.0])
    };
    assert!(run_parameter_study(&s, &no_progress).is_err());
}

#[test]
fn a_cancelled_study_stops_between_solves_and_returns_nothing() {
    // a cancel flag set from the progress callback after the first solve; the rest of the
    // grid (3 x 2 cells, one row per worker) is skipped, the study ends with Cancelled
    let s = quick(vec![0.3, 0.5, 0.7], vec![0.0, 0.2]);
    let cancel = CancelToken::new();
    let solves = std::sync::atomic::AtomicU64::new(0);
    let stop_after_first = |_: Progress| {
        solves.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
        cancel.cancel();
    };
    let r = run_parameter_study_cancellable(&s, &stop_after_first, &cancel);
    assert!(matches!(r, Err(ExpError::Cancelled)), "{r:?}");
    let n = solves.into_inner();
    // each worker finishes the solve it had started, then stops
    assert!((1..6).contains(&n), "{n} of 6 solves ran");
    // a flag set before the start: nothing is solved at all
    let cancel = CancelToken::new();
    cancel.cancel();
    let heard = std::sync::atomic::AtomicU64::new(0);
    let count = |_: Progress| {
        heard.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
    };
    let r = run_parameter_study_cancellable(&s, &count, &cancel);
    assert!(matches!(r, Err(ExpError::Cancelled)), "{r:?}");
    assert_eq!(heard.into_inner(), 0);
}

#[test]
fn a_cancelled_reproduction_writes_nothing() {
    // the flag is set before the start: the scenarios load, the output place is checked, then the run
    // stops; neither the output folder nor its staging folder is left behind, a previous run's files
    // are untouched
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("rep");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(
        out.join(brachia_experiments::MANIFEST),
        "# brachia run folder\nold.txt\n",
    )
    .unwrap();
    std::fs::write(out.join("old.txt"), "previous results").unwrap();
    let opts = brachia_experiments::reproduce::ReproduceOptions {
        scenarios: root.join("scenarios"),
        quick: true,
        ..Default::default()
    };
    let cancel = CancelToken::new();
    cancel.cancel();
    let r =
        brachia_experiments::reproduce::reproduce_cancellable(&opts, &out, &no_progress, &cancel);
    assert!(matches!(r, Err(ExpError::Cancelled)), "{:?}", r.err());
    assert_eq!(
        std::fs::read_to_string(out.join("old.txt")).unwrap(),
        "previous results"
    );
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().to_string())
        .collect();
    assert_eq!(names, vec!["rep".to_string()]);
}

/// The scaling rule written for 4 links alone, an independent statement that pins the n-link rule to it
/// bit for bit.
fn four_link_rule(base: &RobotParams, r2: f64, arm: f64) -> RobotParams {
    let (lower, upper) = (r2 * arm, (1.0 - r2) * arm);
    let mut p = base.clone();
    for (i, l) in p.links.iter_mut().enumerate() {
        let length = if i == 0 || i == 3 { lower } else { upper };
        let s = length / l.length;
        l.length = length;
        l.mass *= s;
        l.com *= s;
        l.inertia *= s * s * s;
    }
    p.name = format!("{} scaled to r2 = {r2}", base.name);
    p
}

fn params_file(name: &str) -> RobotParams {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    RobotParams::from_toml_file(&root.join("params").join(name)).unwrap()
}

#[test]
fn the_n_link_rule_is_the_four_link_rule_bit_for_bit() {
    // every r2 of the default grid, of reproduce --quick and of the stick diagrams, on both 4-link
    // bases of params/, at the paper's arm length and another one
    let d = ParameterStudySettings::default();
    let mut r2s: Vec<f64> = d.r2.clone();
    r2s.extend([0.2, 0.5, 0.8, 0.25, 0.35, 1.0 / 3.0]);
    for base in [paper(), params_file("paper-uniform-rod.toml")] {
        for &r2 in &r2s {
            for arm in [0.71, 0.6] {
                assert_eq!(
                    scaled_params(&base, r2, arm).unwrap(),
                    four_link_rule(&base, r2, arm),
                    "{} at r2 {r2}, arm {arm}",
                    base.name
                );
            }
        }
    }
}

/// A mirrored n-link robot of equal links 0.3 m long (n in 3..=12).
fn uniform(n: usize) -> RobotParams {
    let mut text = String::from("name = \"uniform\"\ngravity = 9.81\n");
    for _ in 0..n {
        text.push_str(
            "[[links]]\nlength = 0.3\nmass = 0.4\ncom = 0.15\ninertia = 0.003\nradius = 0.02\n",
        );
    }
    text.push_str(&format!(
        "[actuators]\ntau_min = {:?}\ntau_max = {:?}\n",
        vec![-5.0; n - 1],
        vec![5.0; n - 1]
    ));
    RobotParams::from_toml_str(&text, "uniform").unwrap()
}

#[test]
fn every_link_count_scales_to_two_mirrored_arms_with_the_hand_share_r2() {
    for n in 3..=12 {
        let base = uniform(n);
        for r2 in [0.2, 0.5, 0.7] {
            let p = scaled_params(&base, r2, 0.71).unwrap();
            let l: Vec<f64> = p.links.iter().map(|l| l.length).collect();
            // mirrored: link i and link n+1-i alike (length, mass, com fraction, inertia)
            for i in 0..n {
                let (a, b) = (&p.links[i], &p.links[n - 1 - i]);
                assert!(
                    (a.length - b.length).abs() < 1e-15
                        && (a.mass - b.mass).abs() < 1e-15
                        && (a.com - b.com).abs() < 1e-15
                        && (a.inertia - b.inertia).abs() < 1e-15,
                    "n {n} r2 {r2}: links {} and {} differ",
                    i + 1,
                    n - i
                );
            }
            // each arm (n/2 links from its hand, plus half a middle link) is 0.71 m, the hand r2 of it
            let k = n / 2;
            let mut arm: f64 = l[..k].iter().sum();
            if n % 2 == 1 {
                arm += 0.5 * l[k];
            }
            assert!((arm - 0.71).abs() < 1e-14, "n {n} r2 {r2}: arm {arm}");
            assert!((l[0] / arm - r2).abs() < 1e-14, "n {n} r2 {r2}");
            // equal base links stay equal inside: a middle link, of which each arm counts half,
            // is as long as the other inner links
            let inner = (1.0 - r2) * 0.71 / (k as f64 - 1.0 + if n % 2 == 1 { 0.5 } else { 0.0 });
            for (i, &li) in l.iter().enumerate().take(n - 1).skip(1) {
                assert!(
                    (li - inner).abs() < 1e-14,
                    "n {n} r2 {r2}: L{} = {li}",
                    i + 1
                );
            }
            // mass with length, com with length, inertia with its cube
            for (new, old) in p.links.iter().zip(&base.links) {
                let s = new.length / old.length;
                assert!((new.mass / old.mass - s).abs() < 1e-12);
                assert!((new.com / new.length - old.com / old.length).abs() < 1e-12);
                assert!((new.inertia / old.inertia - s.powi(3)).abs() < 1e-12);
            }
            let robot = Robot::from_params(p, "scaled").unwrap();
            // the start pose puts the EE on the start bar with both arms straight
            match start_pose(&robot, [-1.0, 0.0]) {
                Ok(q) => {
                    let ee = robot.ee_position(&q);
                    assert!(
                        (ee[0] + 1.0).abs() < 1e-12 && ee[1].abs() < 1e-12,
                        "n {n} r2 {r2}: EE {ee:?}"
                    );
                    let bends: Vec<usize> = (1..n).filter(|&i| q[i] != 0.0).collect();
                    let want: Vec<usize> = if n % 2 == 0 { vec![k] } else { vec![k, k + 1] };
                    assert_eq!(bends, want, "n {n} r2 {r2}: q {q:?}");
                    if n % 2 == 1 {
                        // symmetric: both ends of the middle link bend alike
                        assert!((q[k] - q[k + 1]).abs() < 1e-12, "{q:?}");
                    }
                    let mut joints = vec![[0.0; 2]; n + 1];
                    robot.joint_positions(&q, &mut joints);
                    assert!(joints[k][1] < 0.0, "n {n}: the arm's end is below the bar");
                }
                Err(e) => {
                    // only an odd robot whose middle link is too long has none
                    let mid = l[k];
                    assert!(n % 2 == 1 && mid > 0.71 + 0.5, "n {n} r2 {r2}: {e}");
                }
            }
        }
    }
    // three links: the middle link is the 4-link robot's two upper arms joined
    let four = scaled_params(&uniform(4), 0.4, 0.71).unwrap();
    let three = scaled_params(&uniform(3), 0.4, 0.71).unwrap();
    assert_eq!(three.links[0].length, four.links[0].length);
    assert!((three.links[1].length - 2.0 * four.links[1].length).abs() < 1e-15);
}

#[test]
fn a_two_link_base_is_refused_with_the_rule_and_three_links_come_back_at_their_own_r2() {
    let mut two = uniform(3);
    two.links.pop();
    two.actuators.tau_min.pop();
    two.actuators.tau_max.pop();
    let s = ParameterStudySettings {
        base_params: BaseParams::Inline(two.clone()),
        ..quick(vec![0.5], vec![0.0])
    };
    let e = s.validate().unwrap_err().to_string();
    assert!(
        e.contains("`base_params.inline.links`") && e.contains("2 links") && e.contains("3 to 12"),
        "{e}"
    );
    assert!(scaled_params(&two, 0.5, 0.71).is_err());
    // a file: the error names it
    let dir = tempfile::tempdir().unwrap();
    let f = dir.path().join("two.toml");
    std::fs::write(&f, toml::to_string(&two).unwrap()).unwrap();
    let s = ParameterStudySettings {
        base_params: BaseParams::File(f.clone()),
        ..quick(vec![0.5], vec![0.0])
    };
    let e = run_parameter_study(&s, &no_progress)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains(&f.display().to_string()) && e.contains("`links`") && e.contains("2 links"),
        "{e}"
    );
    // params/three-link.toml: arms of 0.4 + 0.2 m, hand share 2/3; scaled at that r2 and arm length
    // it comes back (to rounding)
    let three = params_file("three-link.toml");
    let p = scaled_params(&three, 0.4 / 0.6, 0.6).unwrap();
    for (a, b) in p.links.iter().zip(&three.links) {
        assert!((a.length - b.length).abs() < 1e-15 && (a.mass - b.mass).abs() < 1e-15);
        assert!((a.inertia - b.inertia).abs() < 1e-15 && (a.com - b.com).abs() < 1e-15);
    }
}

#[test]
fn an_odd_robot_whose_middle_link_cannot_reach_the_start_bar_is_refused_naming_its_r2() {
    // 3 links, 0.71 m arms: at r2 = 0.1 the middle link is 1.278 m, the hands 0.071 m: the EE is never
    // nearer the grip than 1.136 m, so the start bar 1 m away cannot be reached
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let s = ParameterStudySettings {
        base_params: BaseParams::File(root.join("params/three-link.toml")),
        ..quick(vec![0.1, 0.5], vec![0.0])
    };
    let e = s.validate().unwrap_err().to_string();
    assert!(
        e.contains("`r2[0]`") && e.contains("0.1") && e.contains("no start pose"),
        "{e}"
    );
    let e = run_parameter_study(&s, &no_progress)
        .unwrap_err()
        .to_string();
    assert!(e.contains("`r2[0]`"), "{e}");
}

/// A small grid (2 x 2 cells) on an n-link base runs: every cell is present, converged or failed with
/// a status; the run folder names n links.
fn small_grid_on(file: &str, n: usize) {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let s = ParameterStudySettings {
        base_params: BaseParams::File(root.join("params").join(file)),
        stick_r2: vec![0.5],
        ..quick(vec![0.4, 0.6], vec![0.0, 0.2])
    };
    let study = run_parameter_study(&s, &no_progress).unwrap();
    assert_eq!(study.cells.len(), 4);
    assert_eq!(study.base.links.len(), n);
    for (i, row) in study.rows.iter().enumerate() {
        assert_eq!(row.lengths_m.len(), n);
        assert_eq!(row.start_q.len(), n);
        let robot =
            Robot::from_params(scaled_params(&study.base, row.r2, 0.71).unwrap(), "r").unwrap();
        let ee = robot.ee_position(&row.start_q);
        assert!((ee[0] + 1.0).abs() < 1e-9 && ee[1].abs() < 1e-9, "{ee:?}");
        for j in 0..2 {
            let c = study.cell(i, j);
            assert_eq!(c.converged, c.status.is_converged());
            assert_eq!(c.converged, c.energy_j.is_some());
            if let Some(e) = c.energy_j {
                assert!(e.is_finite() && c.positive_work_j.unwrap() >= e - 1e-9);
            }
        }
    }
    eprintln!(
        "{file}: {} of 4 cells converged; statuses {:?}",
        4 - study.failed_cells(),
        study.cells.iter().map(|c| &c.status).collect::<Vec<_>>()
    );
    let f = parameter_study_folder(&study);
    let ff = std::str::from_utf8(f.get("freefall.csv").unwrap()).unwrap();
    let ff = ff
        .strip_prefix("# brachia freefall schema 1\n")
        .expect("the schema line");
    assert!(
        ff.starts_with("r2,l1_m,") && ff.contains(&format!(",l{n}_m,freefall_time_s")),
        "{ff}"
    );
    assert_eq!(ff.lines().nth(1).unwrap().split(',').count(), n + 8);
    let traj = std::str::from_utf8(f.get("stick_r2_0.50.csv").unwrap()).unwrap();
    let traj = traj
        .strip_prefix("# brachia stick schema 1\n")
        .expect("the schema line");
    assert!(traj.starts_with("t,q1,") && traj.contains(&format!("tau{n},ee_x")));
    let report: serde_json::Value = serde_json::from_slice(f.get("report.json").unwrap()).unwrap();
    assert_eq!(
        report["settings"]["planner"]["q1_diag"]
            .as_array()
            .unwrap()
            .len(),
        n
    );
}

#[test]
fn a_three_link_base_runs_a_small_grid() {
    small_grid_on("three-link.toml", 3);
}

#[test]
fn a_six_link_base_runs_a_small_grid() {
    small_grid_on("six-link.toml", 6);
}

#[test]
fn a_grid_too_large_is_refused_before_anything_is_allocated() {
    let s = ParameterStudySettings {
        r2: (1..=999).map(|i| i as f64 / 1000.0).collect(),
        offsets_s: (0..20).map(|i| i as f64 * 0.01).collect(),
        ..Default::default()
    };
    let e = s.validate().unwrap_err().to_string();
    assert!(e.contains("`r2, offsets_s`") && e.contains("10000"), "{e}");
}

#[test]
fn settings_read_from_toml_with_defaults_and_a_relative_params_file() {
    let dir = tempfile::tempdir().unwrap();
    let params = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../params/paper-uniform-rod.toml");
    std::fs::copy(&params, dir.path().join("rod.toml")).unwrap();
    let path = dir.path().join("study.toml");
    std::fs::write(
        &path,
        "base_params = { file = \"rod.toml\" }\nr2 = [0.2, 0.8]\n[planner]\nknot_dt = 0.03\n",
    )
    .unwrap();
    let s = ParameterStudySettings::from_toml_file(&path).unwrap();
    assert_eq!(s.r2, vec![0.2, 0.8]);
    assert_eq!(s.offsets_s.len(), 11);
    assert_eq!(s.planner.knot_dt, 0.03);
    let base = s.base_params.load().unwrap();
    assert_eq!(base.name, "paper-uniform-rod");
    std::fs::write(&path, "r2 = [0.2]\nknot_dt = 0.03\n").unwrap();
    let e = ParameterStudySettings::from_toml_file(&path)
        .unwrap_err()
        .to_string();
    assert!(e.contains("knot_dt"), "{e}");
    let d = ParameterStudySettings::default();
    let back: ParameterStudySettings = toml::from_str(&toml::to_string(&d).unwrap()).unwrap();
    assert_eq!(back, d);
}

/// A cell the planner refuses before solving (here: a target bar no pose reaches) is a failed cell of
/// the study with the planner's message, not an error of the whole study; a stick swing that cannot be
/// planned is left out.
#[test]
fn cells_the_planner_refuses_are_failed_cells_not_a_failed_study() {
    let s = ParameterStudySettings {
        target: [1.5, 0.0], // 1.5 m from the grip, beyond the 1.42 m reach; its midpoint x = 0.25 is swung past
        stick_r2: vec![0.25],
        ..quick(vec![0.3, 0.5], vec![-0.1, 0.0])
    };
    let study = run_parameter_study(&s, &no_progress).expect("the study itself runs");
    assert_eq!(study.cells.len(), 4);
    assert_eq!(study.failed_cells(), 4);
    for c in &study.cells {
        match &c.status {
            SolveStatus::Other(m) => assert!(m.contains("refused"), "{m}"),
            other => panic!("status {other:?}"),
        }
        assert!(c.energy_j.is_none() && c.iterations == 0);
    }
    assert!(study.rows.iter().all(|r| r.failed_cells == 2));
    assert!(study.sticks.is_empty());
    let f = parameter_study_folder(&study);
    let cells = std::str::from_utf8(f.get("cells.csv").unwrap()).unwrap();
    let cells = cells
        .strip_prefix("# brachia cells schema 1\n")
        .expect("the schema line");
    assert_eq!(cells.lines().count(), 5);
}

/// A study folder reads back to the same cells, the torque scale of the last column included; a
/// `cells.csv` of an older brachia (no schema line, 12 columns) or of another schema version is refused
/// naming the file, not guessed at; so is a `report.json` without its schema version.
#[test]
fn cells_read_back_and_other_schema_versions_are_refused() {
    let mut study = run_parameter_study(&quick(vec![0.5], vec![0.0]), &no_progress).unwrap();
    study.cells[0].torque_scale_reached = Some(1.703125);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("study");
    parameter_study_folder(&study).write(&out).unwrap();
    let back = brachia_experiments::read_parameter_study(&out).unwrap();
    assert_eq!(back.cells.len(), 1);
    assert_eq!(back.cells[0].torque_scale_reached, Some(1.703125));
    assert_eq!(back.cells[0].status, study.cells[0].status);

    let path = out.join("cells.csv");
    let text = std::fs::read_to_string(&path).unwrap();
    let old: String = text
        .lines()
        .skip(1)
        .map(|l| format!("{}\n", &l[..l.rfind(',').unwrap()]))
        .collect();
    assert!(old.starts_with("r2,") && old.lines().next().unwrap().ends_with(",replay_ee_error_m"));
    std::fs::write(&path, old).unwrap();
    let err = brachia_experiments::read_parameter_study(&out)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("cells.csv") && err.contains("older brachia"),
        "{err}"
    );
    std::fs::write(&path, text.replacen("schema 1", "schema 2", 1)).unwrap();
    let err = brachia_experiments::read_parameter_study(&out)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("cells.csv") && err.contains("2") && err.contains("schema 1"),
        "{err}"
    );
    std::fs::write(&path, &text).unwrap();
    let rpath = out.join("report.json");
    let mut report: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&rpath).unwrap()).unwrap();
    report.as_object_mut().unwrap().remove("schema_version");
    std::fs::write(&rpath, report.to_string()).unwrap();
    let err = brachia_experiments::read_parameter_study(&out)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("report.json") && err.contains("older brachia"),
        "{err}"
    );
}
