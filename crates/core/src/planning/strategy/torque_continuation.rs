//! Plans that fail within the actuator limits: continuation on the limits, and a diagnosis of how much
//! torque the swing needs when no plan within them is found.
//!
//! A cold plan (no warm-start guess, no obstacles) that does not converge is planned again with every
//! joint's torque limits scaled by [`RELAX_SCALES`] (2, 4, then 8), cold. When one of those
//! converges, the limits are tightened towards the real ones, each solve warm-started from the last
//! converged plan: first the real limits directly; when that fails, bisection of the scale (geometric
//! midpoints) between the last converged and the last failed one, until they are within [`SCALE_TOL`]
//! of each other (relative) or [`MAX_STEPS`] plans were made. A plan converged at the real limits is the result (the cold guess
//! led the solver astray, the continuation did not). Otherwise the failed plan is returned with a
//! [`TorqueContinuation`] that says the swing is likely torque-limited and by how much: the smallest
//! scale reached and the plan's peak torque per joint there.
//!
//! This is evidence, not proof: a local method cannot certify that no swing within the limits exists
//! (another family of swings may need less), and the scale reached is an upper bound on what this
//! family needs. Measured on the parameter study's r2 = 0.1, T - 0.5 s cell in docs/parameter-study.md.
//!
//! Units: N m, s. Limit scales are dimensionless factors on `tau_min` and `tau_max` (which bracket 0, so
//! a scale above 1 widens them).

use crate::error::Result;
use crate::model::Robot;
use crate::planning::nlp::{NlpSettings, SolveStatus};
use crate::planning::outcome::Plan;
use crate::planning::outcome::SolveRole;
pub use crate::planning::report::MAX_STEPS;
use crate::planning::report::{ContinuationStop, TorqueContinuation};
use crate::planning::settings::ValidSettings;
use crate::planning::solve::plan_single;
use crate::planning::solve_log::SolveLog;
use crate::planning::task::ValidTask;
use std::time::Instant;

/// Limit scales of the relaxed cold solves, tried in order until one converges.
/// (Measured on the parameter study's r2 = 0.1, T - 0.5 s cell, docs/parameter-study.md: with 5 N m
/// limits the cold solve at 10 N m fails and the one at 20 N m converges; with 2.5 N m limits only 8x
/// converges.)
pub const RELAX_SCALES: [f64; 3] = [2.0, 4.0, 8.0];
/// Relative width of the final bracket: the bisection stops when the failed scale is within this
/// fraction of the converged one.
pub const SCALE_TOL: f64 = 0.05;
/// Iteration limit of each solver attempt of an intermediate tightening plan (the planner's retry
/// with the adaptive barrier can double it; the plan at the real limits keeps the settings'
/// `max_iter`).
pub const STEP_MAX_ITER: usize = 80;

/// `robot` with every actuated joint's torque limits scaled by `k` (> 0; the limits bracket 0, so
/// `k > 1` widens them).
pub fn with_torque_scale(robot: &Robot, k: f64) -> Result<Robot> {
    let mut prm = robot.params().clone();
    for v in prm
        .actuators
        .tau_min
        .iter_mut()
        .chain(prm.actuators.tau_max.iter_mut())
    {
        *v *= k;
    }
    Robot::from_params(prm, "planner (actuator-limit continuation)")
}

/// Whether a failed cold plan with status `status` gets the continuation: not after a refusal
/// (settings, problem), a spent time budget or a callback error, which a wider limit does not change.
pub fn worth_continuing(status: &SolveStatus) -> bool {
    matches!(
        status,
        SolveStatus::MaxIterations
            | SolveStatus::LocallyInfeasible
            | SolveStatus::RestorationFailed
            | SolveStatus::TinyStep
            | SolveStatus::Diverging
            | SolveStatus::NumericalError
    )
}

/// The largest |tau| per actuated joint over `p`'s collocation points, N m.
fn peak_torques(p: &Plan, m: usize) -> Vec<f64> {
    let mut peak = vec![0.0f64; m];
    for k in 0..p.points.len() {
        for (pk, t) in peak.iter_mut().zip(p.points.tau(k)) {
            *pk = pk.max(t.abs());
        }
    }
    peak
}

/// Continuation on the actuator limits after the cold plan `failed` of `task` did not converge (see
/// the module docs). `started` is when the whole planning call began: `nlp.max_wall_time_s` bounds it
/// all, each solve gets what is left and none starts once it is spent. Returns the plan within the
/// limits when the continuation found one, else `failed`; either carries the report, and its
/// `iterations`, `attempts` and `solve_time_s` count every solve.
pub(crate) fn plan_by_torque_continuation(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    failed: Plan,
    started: Instant,
) -> Result<Plan> {
    let m = robot.n - 1;
    let a = &robot.params().actuators;
    let mut rep = TorqueContinuation {
        relaxed_scale: RELAX_SCALES[0],
        relaxed_converged: false,
        reached_scale: None,
        failed_scale: None,
        stopped: ContinuationStop::NothingConverged,
        peak_torque_nm: vec![],
        limit_nm: (0..m)
            .map(|j| a.tau_min[j].abs().max(a.tau_max[j].abs()))
            .collect(),
        solves: 0,
        iterations: 0,
        solve_time_s: 0.0,
    };
    // what is left of the call's time budget; `None` when there is no budget
    let budget = |cap: usize| nlp.remaining(started).map(|n| n.capped(cap));
    let mut failed = failed;
    let mut log = SolveLog::default();
    log.record(&mut failed, SolveRole::Task);
    let mut ran = 0;
    let mut reached: Option<Plan> = None;
    for &k in &RELAX_SCALES {
        let Some(run) = budget(usize::MAX) else {
            rep.stopped = ContinuationStop::TimeSpent;
            break;
        };
        rep.relaxed_scale = k;
        let mut p = plan_single(&with_torque_scale(robot, k)?, task, settings, &run, None)?;
        log.record(&mut p, SolveRole::TorqueScale { scale: k });
        ran += 1;
        if p.converged() {
            rep.relaxed_converged = true;
            rep.reached_scale = Some(k);
            reached = Some(p);
            break;
        }
        if p.status == SolveStatus::MaxWallTime {
            rep.stopped = ContinuationStop::TimeSpent;
            break;
        }
    }
    if ran == 0 {
        // nothing ran (the budget was spent by the cold plan): no continuation to report
        return Ok(failed);
    }
    let mut within: Option<Plan> = None;
    if let Some(mut ok) = reached {
        let mut s_ok = rep.relaxed_scale;
        rep.stopped = ContinuationStop::StepsSpent;
        // the real limits first (warm from the relaxed plan), then the bisection; when the bracket
        // closes on the real limits, they are tried once more from the closest converged plan
        let (mut s_try, mut retried) = (1.0, false);
        for _ in 0..MAX_STEPS {
            let last = s_try == 1.0;
            let Some(run) = budget(if last { usize::MAX } else { STEP_MAX_ITER }) else {
                rep.stopped = ContinuationStop::TimeSpent;
                break;
            };
            let r = if last {
                robot.clone()
            } else {
                with_torque_scale(robot, s_try)?
            };
            let mut p = plan_single(&r, task, settings, &run, Some(&ok.points))?;
            log.record(&mut p, SolveRole::TorqueScale { scale: s_try });
            if p.converged() {
                s_ok = s_try;
                ok = p;
                if last {
                    rep.stopped = ContinuationStop::WithinLimits;
                    break;
                }
            } else if p.status == SolveStatus::MaxWallTime {
                // out of time, not out of torque: no failure to record
                rep.stopped = ContinuationStop::TimeSpent;
                break;
            } else {
                rep.failed_scale = Some(s_try);
            }
            let s_fail = rep.failed_scale.unwrap_or(1.0);
            if s_ok <= s_fail * (1.0 + SCALE_TOL) {
                if s_fail == 1.0 && !retried {
                    retried = true;
                    s_try = 1.0;
                    continue;
                }
                rep.stopped = ContinuationStop::Bracketed;
                break;
            }
            s_try = (s_ok * s_fail).sqrt();
        }
        rep.reached_scale = Some(s_ok);
        rep.peak_torque_nm = peak_torques(&ok, m);
        if s_ok == 1.0 {
            rep.failed_scale = None;
            within = Some(ok);
        }
    }
    // the continuation's own totals; the plan's are those of the failed cold plan and every solve
    let own = log.totals(|r| matches!(r, SolveRole::TorqueScale { .. }));
    (rep.solves, rep.iterations, rep.solve_time_s) = (own.attempts, own.iterations, own.time_s);
    let mut p = within.unwrap_or(failed);
    log.finish(&mut p);
    p.torque_continuation = Some(rep);
    Ok(p)
}
