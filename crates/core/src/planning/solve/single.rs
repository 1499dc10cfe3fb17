//! One plan from one initial guess: the guess checked, the warm start's barrier, then the
//! collocation solve here or the shooting solve ([`super::shooting`]), and the plan's report.

use super::common::{
    check_guess, clearance_rows, guess_from_trajectory, min_obstacle_clearance, smooth_step_guess,
    solve_with_retry, swing_time, target_pose, variable_bounds, WARM_START_MU_INIT,
};
use crate::error::Result;
use crate::model::{DynamicsFn, Robot};
use crate::planning::clearance_check::check_clearance;
use crate::planning::nlp::{NlpSettings, SparseNlp, TimeSplit};
use crate::planning::outcome::{note_between_knots, Plan, Violations};
use crate::planning::profile::{replay_ee_error, resample};
use crate::planning::settings::{Transcription, ValidSettings};
use crate::planning::task::ValidTask;
use crate::planning::transcription::clearance_fn::DistanceClearanceFn;
use crate::planning::transcription::collocation::{CollocationNlp, EeTerminalFn, Layout};
use crate::trajectory::Trajectory;
use std::sync::Arc;

/// One plan from one initial guess (the guess given, or the smooth step): [`plan_with_guess`] without
/// the obstacle strategies. The input was checked where it entered: the settings and the task (their
/// types), the solver settings and the settings against its backend (the strategies change neither
/// the backend nor the transcription, and derive the solver settings for each solve only by a time
/// left, an iteration cap or a warm start's barrier). The guess is checked here: the strategies
/// start solves from their plans' points.
///
/// [`plan_with_guess`]: crate::planning::plan_with_guess
pub(crate) fn plan_single(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    debug_assert_eq!(settings.links(), robot.n);
    if let Some(g) = guess {
        check_guess(robot, g)?;
    }
    let warm_nlp;
    let nlp = match (guess, nlp.mu_init) {
        (Some(_), None) => {
            warm_nlp = NlpSettings {
                mu_init: Some(WARM_START_MU_INIT),
                ..nlp.clone()
            };
            &warm_nlp
        }
        _ => nlp,
    };
    if settings.transcription == Transcription::MultipleShooting
        || nlp.backend == crate::planning::nlp::Backend::Ocp
    {
        return super::shooting::plan_shooting(
            &Arc::new(robot.clone()),
            task,
            settings,
            nlp,
            guess,
        );
    }
    // the evaluators the problem holds share one copy of the robot
    let shared = Arc::new(robot.clone());
    let n = robot.n;
    let qd0 = task.qd0();
    let (t_final, freefall) = swing_time(robot, task, settings)?;
    let intervals = settings.grid(robot.n, t_final, "planner")?;
    let layout = Layout::new(n, n - 1, intervals, t_final, settings.transcription);
    let path = clearance_rows(&shared, task, settings)?.map(DistanceClearanceFn::new);
    let bounds = variable_bounds(robot, &layout, settings, &task.q0, qd0);
    let mut x0 = vec![0.0; layout.n_vars()];
    if let Some(g) = guess {
        guess_from_trajectory(g, &layout, t_final, &bounds, &mut x0);
    } else {
        // initial guess: smooth-step from q0 to the target pose, zero torque
        let q_t = target_pose(robot, task, settings, path.as_ref().map(|p| &p.inner))?;
        smooth_step_guess(&layout, t_final, &task.q0, &q_t, qd0, &mut x0);
    }
    let (q1, r1) = (settings.q1(n), settings.r1(n));
    let target = vec![task.target[0], task.target[1], 0.0, 0.0];
    let mut problem = CollocationNlp::new(
        DynamicsFn::new(Arc::clone(&shared)),
        EeTerminalFn::new(shared),
        layout,
        target,
        bounds.clone(),
        x0,
        (&q1, &r1),
        path,
    );
    let (sol, mut solves) = solve_with_retry(&mut problem, nlp);
    let mut time_split = TimeSplit::default();
    for a in &solves {
        time_split.add(&a.time_split);
    }
    let callback_timings = problem.timings;
    let x = if sol.x.len() == layout.n_vars() {
        sol.x.clone()
    } else {
        problem_guess(&problem)
    };

    // collocation points and their accelerations
    let mut points = Trajectory::new(n);
    let nz = layout.nz;
    for p in 0..layout.points {
        let z = &x[p * nz..(p + 1) * nz];
        points.push(layout.time(p), &z[..n], &z[n..2 * n], &z[2 * n..]);
    }
    let points_qdd = problem.accelerations(&x).to_vec();
    let (trajectory, resample_clamped) = resample(
        robot,
        &points,
        &points_qdd,
        &layout,
        settings.transcription,
        &settings.bounds,
        settings.output_dt,
    );
    let (energy_j, positive_work_j) = trajectory.work();
    let ql = points.q(layout.points - 1);
    let ee_final = robot.ee_position(ql);

    // violations by kind
    let mut g = vec![0.0; SparseNlp::n_cons(&problem)];
    SparseNlp::constraints(&mut problem, &x, &mut g);
    let rows = problem.row_blocks(&g);
    let maxabs = |s: &[f64]| s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let ee = rows.terminal;
    let violations = Violations {
        dynamics: maxabs(rows.defects),
        ee_position: (ee[0] - task.target[0]).hypot(ee[1] - task.target[1]),
        ee_velocity: ee[2].hypot(ee[3]),
        clearance: rows.path.iter().fold(0.0f64, |m, v| m.max(-v)),
        bounds: x
            .iter()
            .zip(bounds.0.iter().zip(&bounds.1))
            .fold(0.0f64, |m, (v, (lo, hi))| m.max(lo - v).max(v - hi)),
    };
    let replay_ee_error_m =
        replay_ee_error(robot, &points, &layout, settings.transcription, task.target);
    let min_obstacle_clearance_m = min_obstacle_clearance(robot, &task.obstacles, &trajectory)?;
    let clearance_violation = check_clearance(robot, task, settings, &trajectory)?;
    note_between_knots(&mut solves, &sol.status, clearance_violation.as_ref());
    Ok(Plan {
        status: sol.status,
        backend: sol.backend,
        iterations: solves.iter().map(|a| a.iterations).sum(),
        attempts: solves.len(),
        solve_time_s: solves.iter().map(|a| a.time_s).sum(),
        solves,
        time_split,
        callback_timings,
        objective: sol.objective,
        swing_time_s: t_final,
        freefall_time_s: freefall,
        layout,
        points,
        points_qdd,
        trajectory,
        resample_clamped,
        energy_j,
        positive_work_j,
        ee_final,
        violations,
        replay_ee_error_m,
        min_obstacle_clearance_m,
        clearance_violation,
        guess: None,
        blockage: None,
        diagnosis: None,
        torque_continuation: None,
        swing_time_search: None,
    })
}

fn problem_guess(p: &dyn SparseNlp) -> Vec<f64> {
    let mut x = vec![0.0; p.n_vars()];
    p.initial_guess(&mut x);
    x
}
