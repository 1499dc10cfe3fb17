//! Answers that must not be wrong: the benchmark's sweeps add to the scenario's own disturbances and
//! its Monte Carlo keeps them; a ladder is checked where it stands in the world (moved, or running
//! leftward), and one that returns to an earlier bar is refused; the one success rule measures the
//! plant's hand against the bar.
//!
//! Units: s, m, rad, N m, N s.

use brachia::sim::{ClosedLoopLog, Disturbances, Push};
use brachia::Robot;
use brachia_experiments::benchmark::{sweeps, with_scenario, SweepContext};
use brachia_experiments::{
    capture, hand_at_bar, judged_log, LadderScenario, CAPTURE_SPEED_M_S, SUCCESS_RADIUS_M,
};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn paper() -> Robot {
    Robot::from_toml_file(&root().join("params/paper.toml")).unwrap()
}

/// A scenario's own disturbances: a mismatch, friction, noise, a delay, a start offset and a push.
fn base() -> Disturbances {
    Disturbances {
        mass_scale: vec![3.0, 1.0, 1.0, 2.0],
        com_scale: vec![1.1, 1.0, 1.0, 1.0],
        coulomb_nm: 0.3,
        viscous_nm_s: 0.05,
        noise_q_std: 0.001,
        measurement_delay_s: 0.002,
        torque_limit_nm: Some(2.0),
        start_offset: vec![0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        pushes: vec![Push {
            t_s: 0.3,
            link: 2,
            point_m: 0.1,
            impulse_n_s: [0.1, 0.0],
        }],
        ..Disturbances::default()
    }
}

/// `brachia benchmark --help` promises that a sweep adds to the scenario's value of the swept field:
/// at level 0 every sweep leaves the scenario's disturbances as written (it used to replace them, so
/// `coulomb_nm = 100` in the scenario was tracked frictionless at level 0), and at a level l the
/// field is the scenario's value plus l (a factor: times 1 + l).
#[test]
fn every_sweep_adds_to_the_scenarios_disturbances() {
    let ctx = SweepContext {
        robot: paper(),
        swing_time_s: 2.0,
    };
    let b = base();
    // an empty list of factors is 1 for every link
    let ones = |mut d: Disturbances| {
        for v in [
            &mut d.mass_scale,
            &mut d.com_scale,
            &mut d.inertia_scale,
            &mut d.length_scale,
        ] {
            if v.is_empty() {
                *v = vec![1.0; 4];
            }
        }
        d
    };
    for s in sweeps() {
        let mut d = b.clone();
        s.apply(&mut d, 0.0, &ctx);
        if s.name == "torque_limit" {
            // removing nothing keeps the scenario's limit
            assert_eq!(d.torque_limit_nm, Some(2.0), "{}", s.name);
        } else {
            assert_eq!(ones(d), ones(b.clone()), "{} at level 0", s.name);
        }
    }
    let at = |name: &str, l: f64| {
        let s = sweeps().into_iter().find(|s| s.name == name).unwrap();
        let mut d = b.clone();
        s.apply(&mut d, l, &ctx);
        d
    };
    assert_eq!(at("mass", 0.5).mass_scale, vec![4.5, 1.5, 1.5, 3.0]);
    assert_eq!(at("com", 0.5).com_scale[0], 1.1 * 1.5);
    assert_eq!(at("inertia", 0.5).inertia_scale, vec![1.5; 4]);
    assert!((at("coulomb", 0.25).coulomb_nm - 0.55).abs() < 1e-12);
    assert!((at("viscous", 0.1).viscous_nm_s - 0.15).abs() < 1e-12);
    assert!((at("noise_q", 0.01).noise_q_std - 0.011).abs() < 1e-12);
    assert!((at("measurement_delay", 0.01).measurement_delay_s - 0.012).abs() < 1e-12);
    assert_eq!(at("torque_limit", 0.5).torque_limit_nm, Some(1.0));
    assert!((at("start_offset", 0.05).start_offset[0] - 0.06).abs() < 1e-12);
    let pushed = at("push", 0.2).pushes;
    assert_eq!(
        pushed.len(),
        2,
        "the scenario's push is kept beside the sweep's"
    );
    assert_eq!(pushed[0], b.pushes[0]);
    assert_eq!(pushed[1].impulse_n_s, [0.0, -0.2]);
}

/// The Monte Carlo used to ignore the scenario's `[disturbances]` entirely: a draw's mass factors now
/// multiply the scenario's, its sensor noise adds to the scenario's, everything else of the scenario
/// is kept, and the seed is the draw's.
#[test]
fn a_monte_carlo_draw_keeps_the_scenarios_disturbances() {
    let draw = Disturbances {
        mass_scale: vec![0.9, 1.1, 1.0, 1.05],
        noise_q_std: 0.002,
        seed: 77,
        ..Disturbances::default()
    };
    let b = base();
    let d = with_scenario(&b, &draw);
    let want = [2.7, 1.1, 1.0, 2.1];
    for (g, w) in d.mass_scale.iter().zip(want) {
        assert!((g - w).abs() < 1e-12, "{:?}", d.mass_scale);
    }
    assert!((d.noise_q_std - 0.003).abs() < 1e-12);
    assert_eq!(d.seed, 77);
    assert_eq!(d.coulomb_nm, b.coulomb_nm);
    assert_eq!(d.pushes, b.pushes);
    assert_eq!(d.torque_limit_nm, b.torque_limit_nm);
    assert_eq!(d.com_scale, b.com_scale);
    assert_eq!(d.start_offset, b.start_offset);
    // no scenario disturbances: the draw itself
    let plain = with_scenario(&Disturbances::default(), &draw);
    assert_eq!(plain, draw);
}

fn ladder_file(dir: &Path, bars: &[(f64, f64)], extra: &str) -> PathBuf {
    let bars: Vec<String> = bars
        .iter()
        .map(|(x, y)| format!("{{ x = {x}, y = {y} }}"))
        .collect();
    let text = format!(
        "params = {:?}\n[ladder]\nbars = [{}]\n{extra}\n[planner]\nswing_time = \"auto\"\nknot_dt = 0.03\n\
         transcription = \"multiple-shooting\"\n[solver]\nbackend = \"ocp\"\n",
        root().join("params/paper.toml").display().to_string(),
        bars.join(", ")
    );
    let p = dir.join("ladder.toml");
    std::fs::write(&p, text).unwrap();
    p
}

/// The traverse checked its first swing as if bar 0 stood at the origin: a ladder moved by 1, 10 or
/// 998 m was refused with "bars[1] is 11.000 m from the grip". Every check now uses the world frame:
/// the same ladder loads wherever it stands, running right or left, with the same start state.
#[test]
fn a_ladder_is_checked_where_it_stands() {
    let dir = tempfile::tempdir().unwrap();
    let shape = [(0.0, 0.0), (1.0, 0.0), (2.0, 0.1)];
    let at = |dx: f64, dy: f64, mirror: bool| -> Vec<(f64, f64)> {
        shape
            .iter()
            .map(|&(x, y)| (if mirror { -x } else { x } + dx, y + dy))
            .collect()
    };
    let home = LadderScenario::load(&ladder_file(dir.path(), &at(0.0, 0.0, false), "")).unwrap();
    for (dx, dy) in [(1.0, 0.0), (10.0, 0.0), (998.0 - 2.0, 0.0), (-500.0, 3.0)] {
        let ll = LadderScenario::load(&ladder_file(dir.path(), &at(dx, dy, false), ""))
            .unwrap_or_else(|e| panic!("ladder moved by ({dx}, {dy}): {e}"));
        assert_eq!(ll.x0, home.x0, "moved by ({dx}, {dy})");
    }
    let left = LadderScenario::load(&ladder_file(dir.path(), &at(5.0, 0.0, true), ""));
    assert!(left.is_ok(), "a leftward ladder: {:?}", left.err());
}

/// The obstacles of a moved ladder are checked in the world frame: one on the robot's real start pose
/// is refused before any work (it passed the check and failed after the work), one clear of the robot
/// in the world is accepted (it was refused).
#[test]
fn a_moved_ladders_obstacles_are_checked_in_the_world_frame() {
    let dir = tempfile::tempdir().unwrap();
    let bars = [(10.0, 0.0), (11.0, 0.0), (12.0, 0.0)];
    // the start pose hangs below and behind bar 0, about (9.5, -0.5)
    let on_start = "obstacles = [{ center = [9.5, -0.5], radius = 0.08 }]";
    let e = LadderScenario::load(&ladder_file(dir.path(), &bars, on_start))
        .expect_err("an obstacle on the start pose")
        .to_string();
    assert!(
        e.contains("ladder.q0") && e.contains("overlaps an obstacle"),
        "{e}"
    );
    // clear of the robot in the world (but where the robot would be if bar 0 stood at the origin)
    let clear = "obstacles = [{ center = [-0.5, -0.5], radius = 0.08 }]";
    let ok = LadderScenario::load(&ladder_file(dir.path(), &bars, clear));
    assert!(ok.is_ok(), "{:?}", ok.err());
}

/// A ladder that returns to an earlier bar ran a whole swing and then failed with a message about
/// `knot_dt`; it is refused before any work, naming the bars.
#[test]
fn a_ladder_returning_to_an_earlier_bar_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    for bars in [
        vec![(0.0, 0.0), (1.0, 0.0), (0.0, 0.0)],
        vec![(0.0, 0.0), (1.0, 0.0), (2.0, 0.0), (1.05, 0.0)],
    ] {
        let e = LadderScenario::load(&ladder_file(dir.path(), &bars, ""))
            .expect_err("a ladder going back")
            .to_string();
        assert!(e.contains("earlier bar") && !e.contains("knot_dt"), "{e}");
    }
}

/// The one success rule: the plant's hand within [`SUCCESS_RADIUS_M`] of the bar and no faster than
/// [`CAPTURE_SPEED_M_S`], at any row of the run (the first such row is the capture, and the run is
/// judged there), measured to the bar, never to the reference's end.
#[test]
fn success_is_the_first_slow_capture_at_the_bar_at_any_time() {
    let robot = paper();
    let q_end = [-0.3, 0.6, 0.0, 0.0];
    let ee = robot.ee_position(&q_end);
    let far = [-2.35, 0.0, -1.55, 0.0];
    let other = [-1.0, 0.3, 0.2, 0.1];
    let ee_other = robot.ee_position(&other);
    let rows = |qs: &[[f64; 4]], qd: [f64; 4]| -> Vec<f64> {
        qs.iter().flat_map(|q| [*q, qd].concat()).collect()
    };
    let mut log = ClosedLoopLog {
        n: 4,
        t: vec![0.0, 1.0, 2.0],
        x: rows(&[far, q_end, other], [0.0; 4]),
        tau: vec![0.5; 9],
        ..ClosedLoopLog::default()
    };
    // the hand rests on the bar at 1 s: captured there, whatever comes after
    let c = capture(&robot, &log, 1.0, ee);
    assert!(c.reaches_bar && c.bar_error_m < 1e-12, "{c:?}");
    assert_eq!((c.t_s, c.row, c.capture_t_s), (1.0, 1, Some(1.0)));
    // the run is judged up to the capture: two rows of the three
    let judged = judged_log(&log, &c);
    assert_eq!((judged.len(), judged.tau.len()), (2, 6));
    // a capture after the swing's end counts too (any time of the run)
    let c = capture(&robot, &log, 1.0, ee_other);
    assert_eq!((c.reaches_bar, c.capture_t_s), (true, Some(2.0)), "{c:?}");
    // 3 cm from the bar: a miss, measured at the end of the swing, whatever the reference says
    let c = capture(&robot, &log, 1.0, [ee[0] + 0.03, ee[1]]);
    assert!(
        !c.reaches_bar && (c.bar_error_m - 0.03).abs() < 1e-12 && c.capture_t_s.is_none(),
        "{c:?}"
    );
    assert!(c.bar_error_m > SUCCESS_RADIUS_M);
    assert_eq!(judged_log(&log, &c).len(), 3);
    // on the bar but fast: no capture
    log.x = rows(&[far, q_end, far], [0.0, 0.0, 0.0, 3.0]);
    let fast = hand_at_bar(&robot, log.x(1), ee);
    assert!(fast.distance_m < 1e-12 && fast.speed_m_s > CAPTURE_SPEED_M_S && !fast.captures);
    assert!(!capture(&robot, &log, 1.0, ee).reaches_bar);
    // a loop that diverged after its capture was caught before; one that never captured misses
    log.x = rows(&[far, q_end, far], [0.0; 4]);
    log.diverged_at_s = Some(2.5);
    assert!(capture(&robot, &log, 1.0, ee).reaches_bar);
    assert!(!capture(&robot, &log, 1.0, [ee[0] + 0.03, ee[1]]).reaches_bar);
}
