//! A free swing time (`PlannerSettings::free_swing_time = [t_min, t_max]`): T as a decision variable
//! of the multiple-shooting plan. The plan's T is a minimum of the fixed-T objective on the same
//! mesh, the stage-structured solver and pounce agree on the identical problem, a bound stops T, a
//! one-value range is that fixed T, and what is not a range is refused naming the field. Units: s, m,
//! rad, rad/s, N m.

use brachia::model::Robot;
use brachia::planning::{
    plan, plan_with_guess, Backend, NlpSettings, Plan, PlannerSettings, ShootingSettings,
    SwingPlanner, SwingTask, SwingTime, Transcription,
};

fn tracking_task() -> SwingTask {
    SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    }
}

fn settings(free: Option<[f64; 2]>) -> PlannerSettings {
    PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.03,
        free_swing_time: free,
        shooting: ShootingSettings {
            substeps: 1,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn nlp(b: Backend) -> NlpSettings {
    NlpSettings {
        backend: b,
        ..Default::default()
    }
}

/// The fixed-T plan on the mesh of `free` (the same K intervals, of T / K), started from it (so that
/// it finds the same local optimum, time-scaled).
fn fixed_on_mesh(robot: &Robot, t: f64, free: &Plan) -> Plan {
    let intervals = free.layout.intervals;
    let s = PlannerSettings {
        swing_time: SwingTime::Seconds(t),
        knot_dt: t / intervals as f64,
        ..settings(None)
    };
    let p = plan_with_guess(
        robot,
        &tracking_task(),
        &s,
        &nlp(Backend::Ocp),
        Some(&free.points),
    )
    .unwrap();
    assert!(p.converged(), "fixed T = {t}: {:?}", p.status);
    assert_eq!(p.layout.intervals, intervals);
    p
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / a.abs().max(b.abs())
}

#[test]
fn a_free_swing_time_plan_is_the_minimum_over_fixed_swing_times_on_its_mesh() {
    let robot = Robot::paper();
    let p = plan(
        &robot,
        &tracking_task(),
        &settings(Some([1.2, 4.0])),
        &nlp(Backend::Ocp),
    )
    .unwrap();
    assert!(p.converged(), "{:?}", p.status);
    let t = p.swing_time_s;
    assert!(t > 1.3 && t < 3.9, "T* = {t} should be inside the range");
    // the start was 2 T_freefall (2.23 s): the optimum moved well away from it
    assert!((t - 2.23).abs() > 0.2, "T* = {t}");
    let v = p.violations;
    assert!(
        v.dynamics < 1e-8 && v.ee_position < 1e-8 && v.ee_velocity < 1e-8,
        "{v:?}"
    );
    assert!(p.replay_ee_error_m < 1e-3, "replay {}", p.replay_ee_error_m);
    assert!((p.trajectory.t.last().unwrap() - t).abs() < 1e-9);
    let k = p.layout.intervals;
    assert!((p.layout.h * k as f64 - t).abs() < 1e-12);
    // knots never further apart than knot_dt: K from the range's top
    assert_eq!(k, (4.0f64 / 0.03).round() as usize);
    // a local minimum in T: the same objective as the fixed-T plan at T* from it, and a lower one
    // than at T* -+ 0.05 s (the swing has other local optima: from the default guess the fixed-T
    // plan at T* finds a lower one, see docs/planner.md "Free swing time")
    let at = fixed_on_mesh(&robot, t, &p);
    assert!(
        rel(at.objective, p.objective) < 1e-6,
        "{} vs {}",
        at.objective,
        p.objective
    );
    for dt in [-0.05, 0.05] {
        let o = fixed_on_mesh(&robot, t + dt, &p).objective;
        assert!(
            o > p.objective * (1.0 + 1e-7),
            "T* {dt:+}: {o} is not above the free plan's {}",
            p.objective
        );
    }
}

#[test]
fn ocp_and_pounce_agree_on_the_identical_free_swing_time_problem() {
    let robot = Robot::paper();
    let s = settings(Some([1.2, 4.0]));
    let a = plan(&robot, &tracking_task(), &s, &nlp(Backend::Ocp)).unwrap();
    let b = plan(&robot, &tracking_task(), &s, &nlp(Backend::Pounce)).unwrap();
    assert!(
        a.converged() && b.converged(),
        "{:?} {:?}",
        a.status,
        b.status
    );
    assert!(
        rel(a.objective, b.objective) < 1e-6,
        "{} vs {}",
        a.objective,
        b.objective
    );
    assert!(
        (a.swing_time_s - b.swing_time_s).abs() < 1e-5,
        "{} vs {}",
        a.swing_time_s,
        b.swing_time_s
    );
}

#[test]
fn a_free_swing_time_stops_at_its_bound() {
    // the optimum (about 3.45 s) lies above the range: T ends on its upper bound
    let robot = Robot::paper();
    let p = plan(
        &robot,
        &tracking_task(),
        &settings(Some([2.0, 2.2])),
        &nlp(Backend::Ocp),
    )
    .unwrap();
    assert!(p.converged(), "{:?}", p.status);
    assert!(
        (p.swing_time_s - 2.2).abs() < 1e-6,
        "T = {}",
        p.swing_time_s
    );
    let at = fixed_on_mesh(&robot, 2.2, &p);
    assert!(
        rel(at.objective, p.objective) < 1e-6,
        "{} vs {}",
        at.objective,
        p.objective
    );
}

#[test]
fn a_range_of_one_value_is_that_fixed_swing_time() {
    let robot = Robot::paper();
    let one = plan(
        &robot,
        &tracking_task(),
        &settings(Some([2.5, 2.5])),
        &nlp(Backend::Ocp),
    )
    .unwrap();
    let fixed = plan(
        &robot,
        &tracking_task(),
        &PlannerSettings {
            swing_time: SwingTime::Seconds(2.5),
            ..settings(None)
        },
        &nlp(Backend::Ocp),
    )
    .unwrap();
    assert!(one.converged());
    assert_eq!(one.swing_time_s, 2.5);
    assert_eq!(one.objective, fixed.objective);
    assert_eq!(one.iterations, fixed.iterations);
}

#[test]
fn what_is_not_a_range_is_refused_naming_the_field() {
    let robot = Robot::paper();
    let bad: [[f64; 2]; 5] = [
        [3.0, 1.0],
        [0.0, 2.0],
        [-1.0, 2.0],
        [f64::NAN, 2.0],
        [1.0, 1e9],
    ];
    for r in bad {
        let e = plan(
            &robot,
            &tracking_task(),
            &settings(Some(r)),
            &nlp(Backend::Ocp),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("free_swing_time"), "{r:?}: {e}");
    }
    // the collocation rules plan at a fixed T
    let s = PlannerSettings {
        transcription: Transcription::HermiteSimpson,
        ..settings(Some([1.5, 3.0]))
    };
    let e = plan(&robot, &tracking_task(), &s, &nlp(Backend::Pounce))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("free_swing_time") && e.contains("multiple-shooting"),
        "{e}"
    );
    // the persistent re-planner too, before it builds anything
    let e = SwingPlanner::new(
        Robot::paper(),
        tracking_task(),
        &settings(Some([1.5, 3.0])),
        &nlp(Backend::Ocp),
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(
        e.contains("free_swing_time") && e.contains("fixed swing time"),
        "{e}"
    );
}

#[test]
fn several_starts_keep_the_lowest_local_optimum_and_report_every_start() {
    // The objective has several local optima in T (docs/planner.md, "Free swing time"): with
    // swing_time_starts = 4 the plan is the best of the four single-start plans, and its report
    // carries all four starts' attempts, one adopted.
    let robot = Robot::paper();
    let s = PlannerSettings {
        swing_time_starts: 4,
        ..settings(Some([1.2, 4.0]))
    };
    let multi = plan(&robot, &tracking_task(), &s, &nlp(Backend::Ocp)).unwrap();
    assert!(multi.converged());
    assert_eq!(multi.solves.len(), 4);
    assert_eq!(multi.solves.iter().filter(|a| a.adopted).count(), 1);
    assert_eq!(
        multi.iterations,
        multi.solves.iter().map(|a| a.iterations).sum::<usize>()
    );
    // the task's T (2 T_freefall, "auto"), then the centres of three equal parts of the range
    let starts = [
        SwingTime::default(),
        SwingTime::Seconds(1.2 + 2.8 / 6.0),
        SwingTime::Seconds(1.2 + 2.8 / 2.0),
        SwingTime::Seconds(1.2 + 2.8 * 5.0 / 6.0),
    ];
    let singles: Vec<f64> = starts
        .iter()
        .map(|&t0| {
            let s1 = PlannerSettings {
                swing_time: t0,
                ..settings(Some([1.2, 4.0]))
            };
            let p = plan(&robot, &tracking_task(), &s1, &nlp(Backend::Ocp)).unwrap();
            assert!(p.converged(), "from {t0:?}: {:?}", p.status);
            p.objective
        })
        .collect();
    let best = singles.iter().copied().fold(f64::INFINITY, f64::min);
    assert!(
        rel(multi.objective, best) < 1e-9,
        "{} vs {singles:?}",
        multi.objective
    );
    // on this swing the starts find different optima: the first start's is not the best
    assert!(singles[0] > best * 1.1, "{singles:?}");
    for (bad, what) in [(0, "1..="), (17, "1..="), (2, "needs free_swing_time")] {
        let s = PlannerSettings {
            swing_time_starts: bad,
            free_swing_time: if what.starts_with("needs") {
                None
            } else {
                Some([1.2, 4.0])
            },
            ..settings(None)
        };
        let e = plan(&robot, &tracking_task(), &s, &nlp(Backend::Ocp))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("swing_time_starts") && e.contains(what),
            "{bad}: {e}"
        );
    }
}
