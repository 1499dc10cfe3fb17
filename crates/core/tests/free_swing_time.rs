//! A free swing time (`PlannerSettings::free_swing_time = [t_min, t_max]`): T as a decision variable
//! of the multiple-shooting plan. The plan's T is a minimum of the fixed-T objective on the same
//! mesh, the stage-structured solver and pounce agree on the identical problem, a bound stops T, a
//! one-value range is that fixed T, and what is not a range is refused naming the field. Units: s, m,
//! rad, rad/s, N m.

use brachia::model::Robot;
use brachia::planning::{
    plan, plan_with_guess, solve_log, Backend, NlpSettings, Plan, PlannerSettings,
    ShootingSettings, SolveRole, SwingPlanner, SwingTask, SwingTime, Transcription,
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
    // knots at most about knot_dt apart: K from the range's top
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
    // the persistent planner too, before it builds anything
    let e = SwingPlanner::new(
        Robot::paper(),
        tracking_task(),
        &settings(Some([3.0, 1.5])),
        &nlp(Backend::Ocp),
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(e.contains("free_swing_time"), "{e}");
}

#[test]
fn the_persistent_planner_plans_the_free_swing_time_then_re_plans_at_it() {
    // (the wide range: from the default guess a cold solve of the fixed-T problem at T* finds
    // another optimum, so the planner must carry the free solve's state over, not re-solve)
    let robot = Robot::paper();
    let s = settings(Some([1.2, 4.0]));
    let p = plan(&robot, &tracking_task(), &s, &nlp(Backend::Ocp)).unwrap();
    let mut planner =
        SwingPlanner::new(robot.clone(), tracking_task(), &s, &nlp(Backend::Ocp)).unwrap();
    let out = planner.plan_outcome().unwrap();
    assert!(out.converged(), "{out:?}");
    // the same free solve as plan(), then the fixed-T problem at that T from its solution
    assert_eq!(planner.swing_time(), p.swing_time_s);
    assert!(
        rel(out.objective, p.objective) < 1e-9,
        "{} vs {}",
        out.objective,
        p.objective
    );
    let k = planner.intervals();
    assert_eq!(k, p.layout.intervals);
    assert!((out.interval_s * k as f64 - p.swing_time_s).abs() < 1e-12);
    // the fixed-T solve starts exactly at the free solution (its multipliers too): it has nothing
    // left to do
    assert_eq!(out.iterations, p.iterations, "the free solve's, plus none");
    // the plan is the free plan's, to the last digit of the knots
    let cp = planner.current_plan().unwrap();
    assert!(cp.converged());
    assert_eq!(cp.swing_time_s, p.swing_time_s);
    assert_eq!(cp.points.q(k), p.points.q(k));
    // a re-plan from the plan's own state at 0.6 s keeps T*: its interval is (T* - 0.6) / K
    let j = (0..=k)
        .min_by(|&a, &b| {
            let d = |i: usize| (planner.knot_time(i) - 0.6).abs();
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let t_now = planner.knot_time(j);
    let mut x = planner.knots().x[j].clone();
    x[1] += 0.02;
    let r = planner.replan(t_now, &x).unwrap();
    assert!(r.converged() && r.ee_error_m < 1e-6, "{r:?}");
    assert!((r.interval_s * k as f64 - (p.swing_time_s - t_now)).abs() < 1e-12);
    assert_eq!(planner.swing_time(), p.swing_time_s);
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

#[test]
fn starts_that_all_fail_return_the_first_with_every_attempt() {
    let robot = Robot::paper();
    let s = PlannerSettings {
        swing_time_starts: 3,
        // the starts' accounting is tested, not the continuation on the torque limits or the
        // search in T after them
        torque_continuation: false,
        swing_time_search: false,
        ..settings(Some([1.5, 3.0]))
    };
    let few = NlpSettings {
        max_iter: 2,
        ..nlp(Backend::Ocp)
    };
    let p = plan(&robot, &tracking_task(), &s, &few).unwrap();
    assert!(!p.converged(), "{:?}", p.status);
    assert_eq!(p.solves.len(), 3);
    assert!(p.solves[0].adopted && !p.solves[1].adopted && !p.solves[2].adopted);
    // each start is its own solve, labelled with its swing time
    for (k, a) in p.solves.iter().enumerate() {
        assert_eq!(a.solve, k);
        assert!(
            matches!(a.role, SolveRole::FreeTimeStart { .. }),
            "{:?}",
            a.role
        );
    }
    let SolveRole::FreeTimeStart { t0_s } = p.solves[0].role else {
        unreachable!()
    };
    assert!((t0_s - 2.2298).abs() < 1e-4, "{t0_s}");
    assert_eq!(solve_log::audit(&p), Vec::<String>::new());
    // the task's free-fall time is kept though every start ran with its T in seconds
    assert!(p.freefall_time_s.is_some());
    assert_eq!(p.iterations, 6);
}

#[test]
fn a_free_swing_time_plans_around_an_obstacle() {
    // Section V-C's obstacle (radius 0.1 m at (0.55, -0.2), target (0.5, 0)) with T free in
    // [1.8, 2.6] s: converged, every link clear of it by the margin on the 1 ms trajectory (3 RK4
    // steps per interval: one step per 30 ms knot leaves the trajectory within the margin between
    // the knots, which is no converged plan), the replay at the bar.
    let robot = Robot::paper();
    let task = SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.5, 0.0],
        obstacles: vec![brachia::model::Circle {
            center: [0.55, -0.2],
            radius: 0.1,
        }],
    };
    let p = plan(
        &robot,
        &task,
        &PlannerSettings {
            shooting: ShootingSettings {
                substeps: 3,
                ..Default::default()
            },
            ..settings(Some([1.8, 2.6]))
        },
        &nlp(Backend::Ocp),
    )
    .unwrap();
    assert!(p.converged(), "{:?}", p.failure_message());
    assert!((1.8..=2.6).contains(&p.swing_time_s));
    assert!(
        p.min_obstacle_clearance_m.unwrap() > 0.009,
        "{:?}",
        p.min_obstacle_clearance_m
    );
    assert!(p.replay_ee_error_m < 1e-3, "{}", p.replay_ee_error_m);
}

#[test]
fn a_joint_multi_swing_plan_refuses_a_free_swing_time() {
    let task = brachia::planning::JointSwingTask {
        x0: [tracking_task().q0, vec![0.0; 4]].concat(),
        bars: vec![[0.0, 0.0], [0.8, 0.0], [1.6, 0.0]],
        obstacles: vec![],
        rest_at_switches: false,
    };
    let e = match brachia::planning::plan_joint_swings(
        &Robot::paper(),
        &task,
        &settings(Some([1.5, 3.0])),
        &nlp(Backend::Ocp),
    ) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a joint plan with a free swing time was accepted"),
    };
    assert!(e.contains("free_swing_time") && e.contains("joint"), "{e}");
}

#[test]
fn a_bad_task_is_refused_before_the_starts_are_computed() {
    // the starts need the task's swing time (its free fall): a task of the wrong size is an error,
    // not a panic in the kinematics
    let s = PlannerSettings {
        swing_time_starts: 3,
        ..settings(Some([1.5, 3.0]))
    };
    let bad = SwingTask {
        q0: vec![0.0; 3],
        ..tracking_task()
    };
    let e = plan(&Robot::paper(), &bad, &s, &nlp(Backend::Ocp)).unwrap_err();
    assert!(e.to_string().contains("q0"), "{e}");
}

#[test]
fn odd_ranges_wall_time_and_array_lengths() {
    let robot = Robot::paper();
    // a three-value array is an error, not a truncation
    let e = toml::from_str::<PlannerSettings>("free_swing_time = [1.2, 2.0, 4.0]")
        .unwrap_err()
        .to_string();
    assert!(e.contains("exactly 2"), "{e}");
    let ok: PlannerSettings = toml::from_str("free_swing_time = [1.2, 4.0]").unwrap();
    assert_eq!(ok.free_swing_time, Some([1.2, 4.0]));
    // a range narrower than MIN_FREE_SWING_TIME_RANGE_S is the fixed T it starts from
    let narrow = plan(
        &robot,
        &tracking_task(),
        &settings(Some([2.0, 2.000001])),
        &nlp(Backend::Ocp),
    )
    .unwrap();
    assert!(narrow.converged(), "{:?}", narrow.status);
    assert_eq!(narrow.swing_time_s, 2.000001);
    // a range whose longest swing does not fit the grid names the range
    let e = plan(
        &robot,
        &tracking_task(),
        &settings(Some([1e-9, 1e-8])),
        &nlp(Backend::Ocp),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("free_swing_time") && e.contains("knot_dt"),
        "{e}"
    );
    // the wall-time limit bounds the whole multi-start search
    let s = PlannerSettings {
        swing_time_starts: 8,
        ..settings(Some([1.2, 4.0]))
    };
    let short = NlpSettings {
        max_wall_time_s: Some(0.02),
        ..nlp(Backend::Ocp)
    };
    let p = plan(&robot, &tracking_task(), &s, &short).unwrap();
    assert!(p.solves.len() < 8, "{} starts ran", p.solves.len());
    assert!(!p.converged());
}

#[test]
fn a_free_swing_time_plan_that_does_not_converge_is_a_status_of_the_persistent_planner() {
    let few = NlpSettings {
        max_iter: 2,
        ..nlp(Backend::Ocp)
    };
    let mut planner = SwingPlanner::new(
        Robot::paper(),
        tracking_task(),
        &settings(Some([1.5, 3.0])),
        &few,
    )
    .unwrap();
    let p = planner.plan().unwrap();
    assert!(!p.converged(), "{:?}", p.status);
    assert!((1.5..=3.0).contains(&p.swing_time_s));
    assert!(!planner.has_plan());
}
