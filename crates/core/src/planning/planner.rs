//! The planner's entry: a plan of one swing, with the strategies that recover a failed solve (the
//! obstacle chain, the torque continuation).
//!
//! Units: s, m, rad, rad/s, N m, J. Angles as in the crate docs (q1 absolute from +x, the rest relative).

use super::nlp::{NlpSettings, SolveStatus};
use super::outcome::Plan;
use super::settings::{PlannerSettings, ValidSettings};
use super::solve::common::check_guess;
use super::solve::plan_single;
use super::task::{validate_task, SwingTask, ValidTask};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::trajectory::Trajectory;

/// Plan an energy-optimal swing. Bad input and impossible tasks are errors (nothing is solved); a solve
/// that does not converge is a [`Plan`] whose `status` says so. Same as [`plan_with_guess`] without a
/// guess: the initial guess is the smooth step to an inverse-kinematics target pose.
pub fn plan(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
) -> Result<Plan> {
    plan_with_guess(robot, task, settings, nlp, None)
}

/// [`plan`] with an optional initial guess. `guess` is any trajectory of the robot (a neighbouring
/// plan's `points` or `trajectory`, possibly of another swing time): its time axis is scaled linearly
/// onto `[0, T]` of this problem and every collocation point takes q, qd (scaled by `T_guess / T`, so
/// the path is the same and only its speed changes) and tau interpolated linearly from it. The start
/// state and the zero final torque are fixed by the bounds; the guess is clamped into the bounds so it
/// agrees with them. With a guess the inverse-kinematics target pose is not computed. Errors on a
/// guess with the wrong number of links, fewer than two samples, non-finite values or times that do
/// not increase. Unless `nlp.mu_init` is set, a warm-started solve starts its barrier parameter at
/// [`WARM_START_MU_INIT`](crate::planning::WARM_START_MU_INIT).
///
/// Without a guess, on a task whose obstacles are avoided, the initial guess comes from
/// [`crate::planning::strategy::obstacles`] (`settings.obstacle_guess`): detour seeds, then continuation on the
/// obstacle radii, when the solve from the smooth step fails; the plan then reports the strategy and
/// the summed cost of every solve, and names what blocks the swing when nothing converged, with what
/// the best detour found would need ([`crate::planning::strategy::diagnosis`]).
///
/// Without a guess and without obstacles, a plan that does not converge is continued on the torque
/// limits (`settings.torque_continuation`, [`crate::planning::strategy::torque_continuation`]): up to 3 widened
/// cold plans and [`crate::planning::strategy::torque_continuation::MAX_STEPS`] warm ones, about 1-2 s on the
/// parameter study's failing cell; the plan within the limits when one is found, else the failure
/// with how much torque the swing likely needs. `nlp.max_wall_time_s` bounds the solves and
/// strategies of the call; the task check before them has a bound of its own (with obstacles near the
/// target bar, the grasp proof's [`crate::planning::grasp::PROOF_MAX_BOXES`]).
pub fn plan_with_guess(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    // the one check of the input: everything below takes the validated types
    let settings = ValidSettings::new(settings.clone(), robot.n, "planner")?;
    check_solver_and_guess(robot, &settings, nlp, guess)?;
    let task = ValidTask::new(robot, task.clone(), &settings, "task", "")?;
    plan_checked(robot, &task, &settings, nlp, guess)
}

/// [`plan_with_guess`] of settings and a task checked where they entered (a scenario file, a
/// caller that plans many swings with one set of settings): the solver settings `nlp`, the settings
/// against its backend (`ocp` solves multiple shooting only) and the guess are checked here. Errors
/// as [`plan_with_guess`] on those, on settings checked for a robot of another number of links, and
/// on a task that does not pass [`validate_task`] for this robot and these settings.
pub fn plan_validated(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    if settings.links() != robot.n {
        return Err(Error::Dimension {
            what: "planner settings: links of the robot they were checked for".into(),
            expected: robot.n,
            got: settings.links(),
        });
    }
    // the task was checked by its maker for some robot and settings: checked again for these, so a
    // task of another robot or other bounds never reaches the solver
    validate_task(robot, task, settings, "planner", "task.")?;
    check_solver_and_guess(robot, settings, nlp, guess)?;
    plan_checked(robot, task, settings, nlp, guess)
}

/// The checks of the input besides the settings and the task: the solver settings, the settings
/// against the backend, the guess.
fn check_solver_and_guess(
    robot: &Robot,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<()> {
    nlp.validate()?;
    settings.check_backend(nlp, "planner")?;
    if let Some(g) = guess {
        check_guess(robot, g)?;
    }
    Ok(())
}

/// [`plan_with_guess`] of checked input.
fn plan_checked(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    let mut p = plan_strategies(robot, task, settings, nlp, guess)?;
    // a cancelled call ends between strategies or inside a solve: whatever it returns did not
    // converge and is no failure of the task
    if nlp.is_cancelled() && !p.converged() {
        p.status = SolveStatus::Cancelled;
    }
    Ok(p)
}

/// The strategies of [`plan_with_guess`] (obstacles, torque continuation), each stopping once
/// `nlp.max_wall_time_s` is spent or `nlp.cancel` is set.
fn plan_strategies(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    if guess.is_none() && settings.avoid_obstacles && !task.obstacles.is_empty() {
        let started = std::time::Instant::now();
        // the strategies leave a share of the time limit to the diagnosis of a failure
        let chain = super::strategy::diagnosis::strategies_share(nlp);
        let (p, probed) =
            super::strategy::obstacles::plan_around_obstacles(robot, task, settings, &chain)?;
        return super::strategy::diagnosis::diagnose_failure(
            robot, task, settings, nlp, p, started, &probed,
        );
    }
    let started = std::time::Instant::now();
    let centred =
        match super::strategy::swing_time::before_plan(robot, task, settings, nlp, guess, started)?
        {
            super::strategy::swing_time::Before::Planned(p) => return Ok(*p),
            super::strategy::swing_time::Before::Plan(s) => s,
        };
    let settings = centred.as_ref().unwrap_or(settings);
    let mut p = plan_single(robot, task, settings, nlp, guess)?;
    if guess.is_none()
        && !p.converged()
        && settings.torque_continuation
        && super::strategy::torque_continuation::worth_continuing(&p.status)
    {
        p = super::strategy::torque_continuation::plan_by_torque_continuation(
            robot, task, settings, nlp, p, started,
        )?;
    }
    super::strategy::swing_time::after_plan(robot, task, settings, nlp, guess, p, started)
}
