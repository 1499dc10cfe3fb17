//! The planner's continuation on the torque limits (brachia::planning::strategy::torque_continuation), on the
//! parameter study's r2 = 0.1 robot at T - 0.5 s (T = 2 T_freefall - 0.5 s), the swing the study fails
//! within the paper's 5 N m (docs/parameter-study.md). Units: N m, s.
use brachia::model::Robot;
use brachia::planning::{
    freefall_time, plan_with_guess, solve_log, strategy::torque_continuation, ContinuationStop,
    Plan, PlannerSettings, SolveRole, SwingTask, SwingTime,
};
use brachia_experiments::parameter_study::{scaled_params, start_pose, ParameterStudySettings};

/// The study's r2 = 0.1 robot with symmetric limits `lim`, its task and T - 0.5 s planner settings.
fn cell(
    lim: f64,
    continuation: bool,
) -> (Robot, SwingTask, PlannerSettings, ParameterStudySettings) {
    let s = ParameterStudySettings::default();
    let mut p = scaled_params(Robot::paper().params(), 0.1, s.arm_length_m).unwrap();
    p.actuators.tau_min = vec![-lim; 3];
    p.actuators.tau_max = vec![lim; 3];
    let robot = Robot::from_params(p, "test").unwrap();
    let q0 = start_pose(&robot, s.start).unwrap();
    let ff = freefall_time(&robot, &q0, 0.5 * (s.start[0] + s.target[0])).unwrap();
    let task = SwingTask {
        q0,
        qd0: vec![],
        target: s.target,
        obstacles: vec![],
    };
    let planner = PlannerSettings {
        swing_time: SwingTime::Seconds(2.0 * ff - 0.5),
        torque_continuation: continuation,
        // the continuation on the limits alone (the search in T has tests of its own)
        swing_time_search: false,
        ..s.planner.clone()
    };
    (robot, task, planner, s)
}

fn peak(p: &Plan) -> f64 {
    (0..p.points.len())
        .flat_map(|k| p.points.tau(k).to_vec())
        .fold(0.0, |a: f64, b| a.max(b.abs()))
}

/// With 10 N m limits the cold solve fails (the premise, checked with the continuation off); the
/// continuation plans the swing at 20 N m and then within the real limits, and says so.
#[test]
fn a_cold_plan_that_fails_within_the_limits_is_rescued_by_widening_them() {
    let (robot, task, off, s) = cell(10.0, false);
    let first = plan_with_guess(&robot, &task, &off, &s.solver, None).unwrap();
    assert!(!first.converged(), "premise: {:?}", first.status);
    assert!(first.torque_continuation.is_none());

    let on = PlannerSettings {
        torque_continuation: true,
        ..off
    };
    let p = plan_with_guess(&robot, &task, &on, &s.solver, None).unwrap();
    assert!(p.converged(), "{:?}", p.failure_message());
    let t = p
        .torque_continuation
        .as_ref()
        .expect("the continuation ran");
    assert!(t.within_limits() && t.relaxed_converged, "{t:?}");
    assert_eq!(t.failed_scale, None);
    assert!(t.relaxed_scale > 1.0 && t.solves >= 2, "{t:?}");
    assert_eq!(t.limit_nm, vec![10.0; 3]);
    // the plan is within the real limits, and it is the continuation's, not the relaxed one
    assert!(peak(&p) <= 10.0 + 1e-6, "peak {}", peak(&p));
    assert!((peak(&p) - t.peak_torque_nm.iter().fold(0.0f64, |a, &b| a.max(b))).abs() < 1e-12);
    // every solve is counted: the failed cold plan and the continuation's
    assert_eq!(p.iterations, first.iterations + t.iterations);
    assert_eq!(p.attempts, first.attempts + t.solves);
    // and listed: the cold plan's attempts first, then the continuation's, the adopted one a solve
    // at the real limits
    assert_eq!(solve_log::audit(&p), Vec::<String>::new());
    assert!(p.solves[..first.attempts]
        .iter()
        .all(|a| a.role == SolveRole::Task && a.solve == 0));
    assert!(p.solves[first.attempts..]
        .iter()
        .all(|a| matches!(a.role, SolveRole::TorqueScale { .. }) && a.solve > 0));
    let adopted = p.solves.iter().find(|a| a.adopted).unwrap();
    assert_eq!(adopted.role, SolveRole::TorqueScale { scale: 1.0 });
    assert_eq!(
        p.solves[first.attempts].role,
        SolveRole::TorqueScale { scale: 2.0 }
    );
    // against the plan's own cold attempts (a separate run's time differs with the machine's load)
    let t_split: f64 = p.time_split.total_s();
    let cold: f64 = p.solves[..first.attempts]
        .iter()
        .map(|a| a.time_split.total_s())
        .sum();
    assert!(t_split > cold, "the continuation's time is in the split");
    assert!(p.replay_ee_error_m < 1e-3, "replay {}", p.replay_ee_error_m);
}

/// Within the paper's 5 N m the cell fails; the plan says how far the continuation got: a bracket
/// above the limits whose converged end's plan exceeds them and stays within the widened ones.
#[test]
fn a_swing_that_needs_more_torque_fails_with_the_scale_it_reached() {
    let (robot, task, planner, s) = cell(5.0, true);
    let p = plan_with_guess(&robot, &task, &planner, &s.solver, None).unwrap();
    assert!(!p.converged(), "{:?}", p.status);
    let t = p
        .torque_continuation
        .as_ref()
        .expect("the continuation ran");
    // 10 N m cold fails, 20 N m converges (docs/planner.md)
    assert!(t.relaxed_converged && t.relaxed_scale == 4.0, "{t:?}");
    assert_eq!(t.stopped, ContinuationStop::Bracketed, "{t:?}");
    let (hi, lo) = (t.reached_scale.unwrap(), t.failed_scale.unwrap());
    assert!(1.0 <= lo && lo < hi && hi <= t.relaxed_scale, "{t:?}");
    assert!(hi <= lo * (1.0 + torque_continuation::SCALE_TOL), "{t:?}");
    let (j, pk, lim) = t.worst_joint().unwrap();
    assert!(j < 3 && lim == 5.0, "{t:?}");
    assert!(pk > 5.0 && pk <= 5.0 * hi + 1e-6, "{t:?}");
    let msg = p.failure_message().unwrap();
    assert!(msg.contains("likely torque-limited"), "{msg}");
    assert!(msg.contains(&format!("{hi:.3}")), "{msg}");
    // the failed plan returned is the cold one at the real limits, with the continuation's cost added
    let off = PlannerSettings {
        torque_continuation: false,
        ..planner
    };
    let cold = plan_with_guess(&robot, &task, &off, &s.solver, None).unwrap();
    assert_eq!(p.status, cold.status);
    assert_eq!(p.objective.to_bits(), cold.objective.to_bits());
    assert_eq!(p.points.q, cold.points.q);
    assert_eq!(p.iterations, cold.iterations + t.iterations);
    assert_eq!(p.attempts, cold.attempts + t.solves);
    // every solve listed, the cold one's attempt adopted, the bracket's ends among the scales tried
    assert_eq!(solve_log::audit(&p), Vec::<String>::new());
    let adopted = p.solves.iter().find(|a| a.adopted).unwrap();
    assert_eq!((adopted.role, adopted.solve), (SolveRole::Task, 0));
    let scales: Vec<f64> = p
        .solves
        .iter()
        .filter_map(|a| match a.role {
            SolveRole::TorqueScale { scale } => Some(scale),
            _ => None,
        })
        .collect();
    assert!(scales.contains(&hi) && scales.contains(&lo), "{scales:?}");
}

/// With an iteration cap too small for any solve, no widened plan converges and the message says that
/// widening did not help (all three scales tried).
#[test]
fn when_no_widened_plan_converges_the_report_says_so() {
    let (robot, task, planner, s) = cell(5.0, true);
    let few = brachia::planning::NlpSettings {
        max_iter: 2,
        ..s.solver.clone()
    };
    let p = plan_with_guess(&robot, &task, &planner, &few, None).unwrap();
    assert!(!p.converged());
    let t = p.torque_continuation.as_ref().unwrap();
    assert_eq!(t.stopped, ContinuationStop::NothingConverged, "{t:?}");
    assert!(!t.relaxed_converged && t.reached_scale.is_none() && t.peak_torque_nm.is_empty());
    assert_eq!(t.relaxed_scale, 8.0);
    assert!(t.solves >= 3, "{t:?}");
    let msg = p.failure_message().unwrap();
    assert!(msg.contains("up to 8x did not help"), "{msg}");
}

/// `max_wall_time_s` bounds the whole call: a budget the cold plan and part of the continuation fit in
/// ends it with `TimeSpent` (or, when the cold plan used it all, with no continuation), and the solve
/// time stays near the budget (slack for one iteration and the planner's own work between solves).
#[test]
fn the_time_budget_bounds_the_continuation() {
    let (robot, task, planner, s) = cell(5.0, true);
    let budget = 0.5;
    let nlp = brachia::planning::NlpSettings {
        max_wall_time_s: Some(budget),
        ..s.solver.clone()
    };
    let p = plan_with_guess(&robot, &task, &planner, &nlp, None).unwrap();
    assert!(!p.converged());
    assert!(p.solve_time_s <= budget + 0.25, "{} s", p.solve_time_s);
    if let Some(t) = &p.torque_continuation {
        assert_eq!(t.stopped, ContinuationStop::TimeSpent, "{t:?}");
        assert!(t.solves >= 1);
    }
}

/// The study carries the diagnosis of its failing cell into the cell and `cells.csv`.
#[test]
fn the_study_records_the_scale_of_its_failing_cell() {
    let s = ParameterStudySettings {
        r2: vec![0.1],
        offsets_s: vec![-0.5],
        stick_r2: vec![],
        ..Default::default()
    };
    let study =
        brachia_experiments::run_parameter_study(&s, &brachia_experiments::no_progress).unwrap();
    let c = &study.cells[0];
    assert!(!c.converged, "{c:?}");
    let k = c.torque_scale_reached.expect("a scale");
    assert!(k > 1.0 && k <= 4.0, "{c:?}");
    let f = brachia_experiments::parameter_study_folder(&study);
    let csv = std::str::from_utf8(f.get("cells.csv").unwrap()).unwrap();
    let csv = csv
        .strip_prefix("# brachia cells schema 1\n")
        .expect("the schema line");
    let last = csv.lines().nth(1).unwrap().rsplit(',').next().unwrap();
    assert!(
        (last.parse::<f64>().unwrap() - k).abs() < 1e-9,
        "{last} against {k}"
    );
}

/// A warm-started plan (the caller's guess) gets no continuation, nor does a plan whose time budget
/// is spent.
#[test]
fn no_continuation_with_a_guess_or_without_time() {
    let (robot, task, planner, s) = cell(5.0, true);
    let wide = cell(20.0, true);
    let g = plan_with_guess(&wide.0, &wide.1, &wide.2, &s.solver, None).unwrap();
    assert!(g.converged() && g.torque_continuation.is_none());
    let p = plan_with_guess(&robot, &task, &planner, &s.solver, Some(&g.points)).unwrap();
    assert!(!p.converged(), "{:?}", p.status);
    assert!(p.torque_continuation.is_none());

    let spent = brachia::planning::NlpSettings {
        max_wall_time_s: Some(1e-9),
        ..s.solver.clone()
    };
    let p = plan_with_guess(&robot, &task, &planner, &spent, None).unwrap();
    assert!(!p.converged());
    assert!(
        !torque_continuation::worth_continuing(&p.status),
        "{:?}",
        p.status
    );
    assert!(p.torque_continuation.is_none());
}

/// A free swing time with two starts inside the continuation: every plan of the continuation is a
/// search over two starts, and the report keeps each start a solve of its own (its role
/// `free-time-start`, the continuation's step as `within`), with indices in order and one adopted.
#[test]
fn each_start_of_a_free_swing_time_stays_a_solve_of_its_own() {
    let (robot, task, mut planner, s) = cell(5.0, true);
    let SwingTime::Seconds(t) = planner.swing_time else {
        unreachable!()
    };
    planner.transcription = brachia::planning::Transcription::MultipleShooting;
    planner.free_swing_time = Some([t - 0.02, t]);
    planner.swing_time_starts = 2;
    let p = plan_with_guess(&robot, &task, &planner, &s.solver, None).unwrap();
    assert!(!p.converged());
    assert!(p.torque_continuation.is_some());
    assert_eq!(solve_log::audit(&p), Vec::<String>::new());
    let starts_of = |within: fn(&SolveRole) -> bool| {
        let mut idx: Vec<usize> = p
            .solves
            .iter()
            .filter(|a| a.within.as_ref().is_some_and(within))
            .inspect(|a| assert!(matches!(a.role, SolveRole::FreeTimeStart { .. }), "{a:?}"))
            .map(|a| a.solve)
            .collect();
        idx.dedup();
        idx
    };
    // the failed cold plan's two starts, then the continuation's, each its own solve
    assert_eq!(starts_of(|r| *r == SolveRole::Task), [0, 1]);
    let steps = starts_of(|r| matches!(r, SolveRole::TorqueScale { .. }));
    assert!(steps.len() >= 2 && steps[0] == 2, "{steps:?}");
    // the returned plan is the cold one's chosen start
    let adopted = p.solves.iter().find(|a| a.adopted).unwrap();
    assert_eq!(adopted.within, Some(SolveRole::Task));
}
