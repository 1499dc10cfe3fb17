//! Warm starts of the planner (`plan_with_guess`): a converged plan handed back as its own guess, a
//! neighbouring swing time, and malformed guesses. Tracking scenario of the paper (Section V-B) at
//! 20 ms knots to keep the test short. Units: m, rad, s, N m.

use brachia::model::Robot;
use brachia::planning::{
    plan, plan_with_guess, NlpSettings, PlannerSettings, SwingTask, SwingTime,
};
use brachia::trajectory::Trajectory;
use brachia::Error;

fn tracking_task() -> SwingTask {
    SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    }
}

fn coarse() -> PlannerSettings {
    PlannerSettings {
        knot_dt: 0.02,
        ..Default::default()
    }
}

#[test]
fn own_solution_as_guess_converges_faster_to_the_same_objective() {
    let robot = Robot::paper();
    let (task, settings, nlp) = (tracking_task(), coarse(), NlpSettings::default());
    let cold = plan(&robot, &task, &settings, &nlp).unwrap();
    assert!(cold.converged(), "{:?}", cold.status);
    let warm = plan_with_guess(&robot, &task, &settings, &nlp, Some(&cold.points)).unwrap();
    assert!(warm.converged(), "{:?}", warm.status);
    let rel = (warm.objective - cold.objective).abs() / cold.objective.abs();
    assert!(
        rel < 1e-6,
        "objective cold {} warm {} (rel {rel:e})",
        cold.objective,
        warm.objective
    );
    // measured: 16 cold, 6 warm (docs/planner.md)
    assert!(
        2 * warm.iterations <= cold.iterations,
        "iterations cold {} warm {}",
        cold.iterations,
        warm.iterations
    );
    // the start state is the task's, exactly
    assert_eq!(warm.points.q(0), task.q0.as_slice());
    assert!(warm.points.qd(0).iter().all(|v| *v == 0.0));
}

#[test]
fn longer_swing_time_converges_from_the_shorter_solution() {
    let robot = Robot::paper();
    let (task, nlp) = (tracking_task(), NlpSettings::default());
    let short = plan(&robot, &task, &coarse(), &nlp).unwrap();
    assert!(short.converged(), "{:?}", short.status);
    let longer = PlannerSettings {
        swing_time: SwingTime::Seconds(short.swing_time_s + 0.2),
        ..coarse()
    };
    // from the 1 ms trajectory (any sampling works: the time axis is rescaled)
    let warm = plan_with_guess(&robot, &task, &longer, &nlp, Some(&short.trajectory)).unwrap();
    assert!(warm.converged(), "{:?}", warm.status);
    assert!((warm.swing_time_s - short.swing_time_s - 0.2).abs() < 1e-12);
    assert!(warm.violations.ee_position < 1e-6 && warm.violations.dynamics < 1e-6);
}

#[test]
fn malformed_guesses_are_errors() {
    let robot = Robot::paper();
    let (task, settings, nlp) = (tracking_task(), coarse(), NlpSettings::default());
    let three_links = {
        let mut t = Trajectory::new(3);
        t.push(0.0, &[0.0; 3], &[0.0; 3], &[0.0; 2]);
        t.push(1.0, &[0.0; 3], &[0.0; 3], &[0.0; 2]);
        t
    };
    let e = plan_with_guess(&robot, &task, &settings, &nlp, Some(&three_links)).unwrap_err();
    assert!(matches!(e, Error::Dimension { .. }), "{e}");
    let mut one = Trajectory::new(4);
    one.push(0.0, &[0.0; 4], &[0.0; 4], &[0.0; 3]);
    let e = plan_with_guess(&robot, &task, &settings, &nlp, Some(&one)).unwrap_err();
    assert!(e.to_string().contains("at least 2 samples"), "{e}");
    let mut backwards = one.clone();
    backwards.push(-1.0, &[0.0; 4], &[0.0; 4], &[0.0; 3]);
    let e = plan_with_guess(&robot, &task, &settings, &nlp, Some(&backwards)).unwrap_err();
    assert!(e.to_string().contains("t[1]"), "{e}");
    let mut nan = one.clone();
    nan.push(1.0, &[f64::NAN; 4], &[0.0; 4], &[0.0; 3]);
    let e = plan_with_guess(&robot, &task, &settings, &nlp, Some(&nan)).unwrap_err();
    assert!(e.to_string().contains("finite"), "{e}");
}
