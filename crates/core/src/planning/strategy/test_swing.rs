//! The paper's unobstructed swing with the default settings, for the strategies' tests.

use crate::model::Robot;
use crate::planning::nlp::NlpSettings;
use crate::planning::outcome::Plan;
use crate::planning::settings::{PlannerSettings, ValidSettings};
use crate::planning::solve::plan_single;
use crate::planning::task::{SwingTask, ValidTask};

/// The paper's robot, the default settings, the paper's task and its plan (checked converged).
pub(crate) fn paper_swing() -> (Robot, ValidSettings, ValidTask, Plan) {
    let robot = Robot::paper();
    let s = ValidSettings::new(PlannerSettings::default(), robot.n, "test").unwrap();
    let task = ValidTask::new(&robot, SwingTask::paper(), &s, "task", "").unwrap();
    let p = plan_single(&robot, &task, &s, &NlpSettings::default(), None).unwrap();
    assert!(p.converged(), "{:?}", p.failure_message());
    (robot, s, task, p)
}
