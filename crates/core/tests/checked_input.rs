//! The planner's input checked once where it enters: `plan` of plain settings and a plain task against
//! `plan_validated` of the checked ones (`ValidSettings`, `ValidTask`), and the errors of bad input,
//! which are the ones `PlannerSettings::validate` and `validate_task` give. Tracking swing of the paper
//! (Section V-B). Units: m, rad, s.

use brachia::model::Robot;
use brachia::planning::{
    plan, plan_validated, validate_task, NlpSettings, PlannerSettings, SwingTask, ValidSettings,
    ValidTask,
};
use brachia::Error;

#[test]
fn checked_input_plans_as_plain_input() {
    let robot = Robot::paper();
    let settings = PlannerSettings::default();
    let nlp = NlpSettings::default();
    let plain = plan(&robot, &SwingTask::paper(), &settings, &nlp).unwrap();
    let vs = ValidSettings::new(settings, robot.n(), "s.toml").unwrap();
    let vt = ValidTask::new(&robot, SwingTask::paper(), &vs, "s.toml", "task.").unwrap();
    let checked = plan_validated(&robot, &vt, &vs, &nlp, None).unwrap();
    assert!(plain.converged(), "{:?}", plain.status);
    assert_eq!(
        (checked.objective, checked.iterations, checked.swing_time_s),
        (plain.objective, plain.iterations, plain.swing_time_s)
    );
}

#[test]
fn bad_input_is_refused_with_the_rules_message() {
    let robot = Robot::paper();
    let nlp = NlpSettings::default();
    let bad = PlannerSettings {
        obstacle_margin: -1.0,
        ..PlannerSettings::default()
    };
    let want = bad.validate(robot.n(), "planner").unwrap_err().to_string();
    let got = plan(&robot, &SwingTask::paper(), &bad, &nlp)
        .unwrap_err()
        .to_string();
    assert_eq!(got, want);
    assert!(got.contains("obstacle_margin"), "{got}");

    let far = SwingTask {
        target: [3.0, 0.0],
        ..SwingTask::paper()
    };
    let settings = PlannerSettings::default();
    let want = validate_task(&robot, &far, &settings, "task", "")
        .unwrap_err()
        .to_string();
    let got = plan(&robot, &far, &settings, &nlp).unwrap_err().to_string();
    assert_eq!(got, want);
    assert!(got.contains("target"), "{got}");
}

#[test]
fn settings_checked_for_another_robot_are_refused() {
    let robot = Robot::paper();
    let vs = ValidSettings::new(PlannerSettings::default(), 3, "s.toml").unwrap();
    let vt = {
        let own = ValidSettings::new(PlannerSettings::default(), robot.n(), "s.toml").unwrap();
        ValidTask::new(&robot, SwingTask::paper(), &own, "s.toml", "task.").unwrap()
    };
    let e = plan_validated(&robot, &vt, &vs, &NlpSettings::default(), None).unwrap_err();
    assert!(
        matches!(
            e,
            Error::Dimension {
                expected: 4,
                got: 3,
                ..
            }
        ),
        "{e}"
    );
}
