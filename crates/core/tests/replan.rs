//! The persistent planner (`SwingPlanner`) on the paper's tracking swing (params/paper.toml, T auto,
//! 10 ms knots, multiple shooting on the Riccati solver): a cold plan, then re-plans from the planned
//! state at t = 0.6 s disturbed by uniform +-0.1 rad and +-0.5 rad/s on each joint (seeded; only the
//! disturbed states inside the bounds). Warm re-plans converge, reach the bar and take fewer
//! iterations than the same re-plans started cold; the re-plan of the undisturbed state keeps the
//! plan; misuse is refused. Units: s, m, rad, rad/s.

use brachia::model::Robot;
use brachia::planning::workload::{disturbed_starts, replan_settings};
use brachia::planning::{
    Bounds, MuStrategy, NlpSettings, PlannerSettings, SwingPlanner, SwingTask,
};
use brachia::Error;

fn tracking_task() -> SwingTask {
    SwingTask::paper()
}

fn settings() -> (PlannerSettings, NlpSettings) {
    replan_settings(0.01)
}

/// `count` disturbed copies of `x` (seeded), those inside the default bounds.
fn disturbed(x: &[f64], count: usize, seed: u64) -> Vec<Vec<f64>> {
    disturbed_starts(x, &Bounds::default(), count, seed)
}

#[test]
fn warm_replans_from_disturbed_states_converge_reach_the_bar_and_beat_cold_starts() {
    let robot = Robot::paper();
    let task = tracking_task();
    let (s, nlp) = settings();
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp).unwrap();
    let p = planner.plan().unwrap();
    assert!(p.converged(), "{:?}", p.status);
    assert!(p.replay_ee_error_m < 1e-3);
    let t_now = 0.6;
    let j = p
        .trajectory
        .t
        .iter()
        .position(|t| (t - t_now).abs() < 1e-9)
        .unwrap();
    let x_nom = [p.trajectory.q(j), p.trajectory.qd(j)].concat();
    let cp = planner.checkpoint();

    let states = disturbed(&x_nom, 8, 7);
    assert!(
        states.len() >= 6,
        "{} states inside the bounds",
        states.len()
    );
    let (mut warm_iters, mut cold_iters, mut converged, mut same) = (0, 0, 0, 0);
    for x in &states {
        assert!(planner.restore(&cp).unwrap().converged());
        let w = planner.replan(t_now, x).unwrap();
        assert!(w.converged(), "warm {:?} from {x:?}", w.status);
        assert!(
            w.ee_error_m < 1e-6,
            "warm ends {} m from the bar",
            w.ee_error_m
        );
        assert!((w.t_start - t_now).abs() < 1e-15);
        assert!(
            (w.interval_s * planner.intervals() as f64 - (planner.swing_time() - t_now)).abs()
                < 1e-12
        );
        assert_eq!(planner.knots().x[0], *x);
        converged += 1;
        warm_iters += w.iterations;

        assert!(planner.restore(&cp).unwrap().converged());
        let c = planner.replan_cold(t_now, x).unwrap();
        assert!(c.converged(), "cold {:?} from {x:?}", c.status);
        // the same local optimum, or (the cold start is the planner's IK guess, not the plan being
        // tracked) another one: one of these
        // draws goes cold to a lower optimum (5.352 against 6.487; no self-collision row is near
        // active, it is the barrier path that differs) while warm stays in the tracked plan's basin
        if (c.objective - w.objective).abs() <= 1e-5 * w.objective.abs().max(1.0) {
            same += 1;
        }
        cold_iters += c.iterations;
    }
    assert_eq!(converged, states.len());
    assert!(
        same + 1 >= states.len(),
        "warm and cold agree on {same} of {}",
        states.len()
    );
    assert!(
        warm_iters < cold_iters,
        "warm {warm_iters} vs cold {cold_iters} iterations over {} re-plans",
        states.len()
    );

    // the plan of the last (cold) re-plan: its own clock, the held torques replayed reach the bar
    let rp = planner.current_plan().unwrap();
    assert!(rp.converged());
    assert!((rp.swing_time_s - (planner.swing_time() - t_now)).abs() < 1e-12);
    assert!(
        rp.replay_ee_error_m < 1e-3,
        "replay {}",
        rp.replay_ee_error_m
    );
}

#[test]
fn replan_of_the_undisturbed_state_keeps_the_plan_and_a_new_target_is_reached() {
    let robot = Robot::paper();
    let task = tracking_task();
    let (s, nlp) = settings();
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp).unwrap();
    let p = planner.plan().unwrap();
    // the cold plan runs the monotone barrier update, a warm re-plan the adaptive one, and the
    // reports say so
    assert_eq!(p.solves.len(), 1);
    assert_eq!(p.solves[0].mu_strategy, MuStrategy::Monotone);
    // at a knot time the shifted solution's start is the plan's own knot
    let k = 60;
    let t_now = planner.knot_time(k);
    let x_nom = planner.knots().x[k].clone();
    let w = planner.replan(t_now, &x_nom).unwrap();
    assert!(w.converged(), "{:?}", w.status);
    // the tail of the optimal swing is optimal for the remaining time (up to the finer grid)
    let rp = planner.current_plan().unwrap();
    assert_eq!(rp.solves[0].mu_strategy, MuStrategy::Adaptive);
    let kk = planner.intervals();
    let end = planner.knots().x[kk].clone();
    let n = robot.n();
    for i in 0..n {
        assert!(
            (end[i] - p.points.q(p.points.len() - 1)[i]).abs() < 0.05,
            "{end:?}"
        );
    }
    assert!(rp.replay_ee_error_m < 1e-3);

    // move the bar 2 cm and re-plan from the same point
    planner.set_target([0.82, 0.0]).unwrap();
    let w = planner.replan(t_now, &x_nom).unwrap();
    assert!(w.converged(), "{:?}", w.status);
    assert!(w.ee_error_m < 1e-6);
    let ee = w.ee_final;
    assert!((ee[0] - 0.82).abs() < 1e-6 && ee[1].abs() < 1e-6, "{ee:?}");
}

#[test]
fn replan_refuses_misuse() {
    let robot = Robot::paper();
    let task = tracking_task();
    let (s, nlp) = settings();
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp).unwrap();
    let x = vec![0.0; 8];
    // before any plan
    assert!(matches!(
        planner.replan(0.1, &x),
        Err(Error::InvalidValue { .. })
    ));
    assert!(planner.plan_outcome().unwrap().converged());
    let t_f = planner.swing_time();
    for t in [-0.1, t_f, t_f + 1.0, f64::NAN] {
        assert!(
            matches!(planner.replan(t, &x), Err(Error::InvalidValue { .. })),
            "{t}"
        );
    }
    assert!(matches!(
        planner.replan(0.1, &x[..7]),
        Err(Error::Dimension { .. })
    ));
    let mut bad = x.clone();
    bad[3] = f64::INFINITY;
    assert!(matches!(
        planner.replan(0.1, &bad),
        Err(Error::InvalidValue { .. })
    ));
    assert!(matches!(
        planner.set_target([f64::NAN, 0.0]),
        Err(Error::InvalidValue { .. })
    ));
}

/// A checkpoint taken right after its solve puts the planner back exactly: a warm re-plan after a
/// restore is the same, bit for bit, whether the planner re-planned (warm and cold, from other states)
/// in between or not; the restore returns the checkpoint's own outcome and `current_plan` is the
/// checkpoint's plan. (A restore that re-solved the checkpoint's problem from whatever multipliers the
/// last solve left would make a re-plan's iterations depend on what came before it.)
#[test]
fn a_restore_puts_the_planner_back_exactly_whatever_was_solved_in_between() {
    let robot = Robot::paper();
    let (s, nlp) = replan_settings(0.03);
    let mut planner = SwingPlanner::new(robot.clone(), tracking_task(), &s, &nlp).unwrap();
    let cold = planner.plan_outcome().unwrap();
    assert!(cold.converged(), "{:?}", cold.status);
    let plan = planner.current_plan().unwrap();
    let cp = planner.checkpoint();
    let k = (0.6 / cold.interval_s).round() as usize;
    let t_now = planner.knot_time(k);
    let x_nom = planner.knots().x[k].clone();
    let states = disturbed(&x_nom, 4, 11);
    assert!(
        states.len() >= 3,
        "{} states inside the bounds",
        states.len()
    );

    let first = planner.replan(t_now, &states[0]).unwrap();
    assert!(first.converged(), "{:?}", first.status);
    let knots = planner.knots().clone();
    // other solves in between: warm and cold re-plans from other states, a re-plan of a re-plan
    assert!(planner.replan(t_now, &states[1]).unwrap().converged());
    assert!(planner.replan_cold(t_now, &states[2]).unwrap().converged());
    let later = planner.knot_time(5);
    let x_later = planner.knots().x[5].clone();
    assert!(planner.replan(later, &x_later).unwrap().converged());

    let back = planner.restore(&cp).unwrap();
    assert_eq!(back, cold, "the restore returns the checkpoint's outcome");
    let replot = planner.current_plan().unwrap();
    assert_eq!(replot.objective.to_bits(), plan.objective.to_bits());
    assert_eq!(replot.trajectory.t, plan.trajectory.t);
    let again = planner.replan(t_now, &states[0]).unwrap();
    assert_eq!(again.iterations, first.iterations);
    assert_eq!(again.objective.to_bits(), first.objective.to_bits());
    assert_eq!(*planner.knots(), knots);

    // a checkpoint of another planner is refused and changes nothing: another mesh, or the same
    // robot, task and mesh built again
    let (s2, _) = replan_settings(0.05);
    let other = SwingPlanner::new(robot.clone(), tracking_task(), &s2, &nlp).unwrap();
    let twin = SwingPlanner::new(robot, tracking_task(), &s, &nlp).unwrap();
    for cp in [other.checkpoint(), twin.checkpoint()] {
        let e = planner.restore(&cp).unwrap_err().to_string();
        assert!(
            e.contains("checkpoint") && e.contains("this planner"),
            "{e}"
        );
        assert_eq!(*planner.knots(), knots);
    }

    // another target: the checkpoint's solution is re-solved for it (the stored state belongs to
    // the old target); back on the old target the restore is exact again
    let target = planner.target();
    planner
        .set_target([target[0] - 0.02, target[1] + 0.01])
        .unwrap();
    let moved = planner.restore(&cp).unwrap();
    assert!(moved.converged() && moved.iterations > 0, "{moved:?}");
    assert!(moved.ee_error_m < 1e-6, "{moved:?}");
    assert!(planner.current_plan().unwrap().replay_ee_error_m < 1e-3);
    planner.set_target(target).unwrap();
    assert_eq!(planner.restore(&cp).unwrap(), cold);
    let again = planner.replan(t_now, &states[0]).unwrap();
    assert_eq!(again.objective.to_bits(), first.objective.to_bits());
}

/// A checkpoint taken after a solve that did not converge holds no solver state: its restore
/// re-solves the last converged solution warm.
#[test]
fn a_checkpoint_after_a_failed_solve_is_re_solved() {
    let robot = Robot::paper();
    let (s, nlp) = replan_settings(0.03);
    let mut planner = SwingPlanner::new(robot, tracking_task(), &s, &nlp).unwrap();
    let before = planner.checkpoint();
    let cold = planner.plan_outcome().unwrap();
    assert!(cold.converged(), "{:?}", cold.status);
    let k = (0.6 / cold.interval_s).round() as usize;
    let (t_now, x_nom) = (planner.knot_time(k), planner.knots().x[k].clone());
    let x = &disturbed(&x_nom, 4, 11)[0];
    planner.warm_settings_mut().max_iter = 1;
    let failed = planner.replan(t_now, x).unwrap();
    assert!(!failed.converged(), "{failed:?}");
    let cp = planner.checkpoint();
    planner.warm_settings_mut().max_iter = 200;
    let back = planner.restore(&cp).unwrap();
    assert!(back.converged() && back.iterations > 0, "{back:?}");
    assert_eq!(back.t_start, 0.0);
    assert!((back.objective - cold.objective).abs() < 1e-6 * cold.objective);
    // a checkpoint taken before any plan restores the initial guess's problem and solves it
    let fresh = planner.restore(&before).unwrap();
    assert_eq!(fresh.t_start, 0.0);
    assert!(fresh.iterations > 0, "{fresh:?}");
}
