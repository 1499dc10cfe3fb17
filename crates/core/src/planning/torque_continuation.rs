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

use super::nlp::{NlpSettings, SolveStatus};
use super::planner::{plan_single, Plan};
use super::settings::PlannerSettings;
use super::solve_log::{SolveLog, SolveRole};
use super::task::SwingTask;
use crate::error::Result;
use crate::model::Robot;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Instant;

/// Limit scales of the relaxed cold solves, tried in order until one converges.
/// (Measured on the parameter study's r2 = 0.1, T - 0.5 s cell, docs/parameter-study.md: with 5 N m
/// limits the cold solve at 10 N m fails and the one at 20 N m converges; with 2.5 N m limits only 8x
/// converges.)
pub const RELAX_SCALES: [f64; 3] = [2.0, 4.0, 8.0];
/// Relative width of the final bracket: the bisection stops when the failed scale is within this
/// fraction of the converged one.
pub const SCALE_TOL: f64 = 0.05;
/// Most warm plans of the tightening (the real limits first, then the bisection, then the real limits
/// once more): enough to close a bracket from 8x to [`SCALE_TOL`] by geometric midpoints (6 steps).
pub const MAX_STEPS: usize = 10;
/// Iteration limit of each solver attempt of an intermediate tightening plan (the planner's retry
/// with the adaptive barrier can double it; the plan at the real limits keeps the settings'
/// `max_iter`).
pub const STEP_MAX_ITER: usize = 80;

/// Why the continuation on the actuator limits stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContinuationStop {
    /// A plan converged within the real limits (it is the plan returned).
    WithinLimits,
    /// The converged and the failed scale are within [`SCALE_TOL`] of each other.
    Bracketed,
    /// [`MAX_STEPS`] plans were made before the bracket closed.
    StepsSpent,
    /// The call's `max_wall_time_s` ran out (a solve ended for lack of time, or none could start).
    TimeSpent,
    /// No relaxed cold plan converged.
    NothingConverged,
}

/// What the continuation on the actuator limits found (`Plan::torque_continuation`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorqueContinuation {
    /// The scale of the last relaxed cold solve (the first that converged, or the last tried).
    pub relaxed_scale: f64,
    /// Whether a relaxed cold solve converged. When none did, widening the limits did not help (the
    /// swing fails for another reason, or needs more than the widest scale).
    pub relaxed_converged: bool,
    /// Smallest limit scale at which a plan of the continuation converged; `Some(1.0)`: the plan returned
    /// is within the real limits. `None` when no relaxed solve converged.
    pub reached_scale: Option<f64>,
    /// The largest scale below `reached_scale` whose plan failed (the last failure of the bisection,
    /// warm-started from the converged plan of that moment, not necessarily `reached_scale`'s): the
    /// bracket's lower end. `None` when the real limits converged or no warm plan failed.
    pub failed_scale: Option<f64>,
    /// Why the continuation stopped.
    pub stopped: ContinuationStop,
    /// Largest |tau| of the plan at `reached_scale` per actuated joint, over its collocation points, N m
    /// (empty when none converged).
    pub peak_torque_nm: Vec<f64>,
    /// The real limit of each actuated joint, `max(|tau_min|, |tau_max|)`, N m.
    pub limit_nm: Vec<f64>,
    /// Solver attempts of the continuation (not counting the failed cold plan before it).
    pub solves: usize,
    /// Solver iterations of the continuation.
    pub iterations: usize,
    /// Solve time of the continuation, s.
    pub solve_time_s: f64,
}

impl TorqueContinuation {
    /// True when the continuation planned the swing within the real limits.
    pub fn within_limits(&self) -> bool {
        self.stopped == ContinuationStop::WithinLimits
    }

    /// The actuated joint (0-based among the actuated ones) whose peak torque exceeds its limit the
    /// most, relative to the limit, with that peak and limit; `None` when nothing converged.
    pub fn worst_joint(&self) -> Option<(usize, f64, f64)> {
        self.peak_torque_nm
            .iter()
            .zip(&self.limit_nm)
            .enumerate()
            .map(|(j, (&p, &l))| (j, p, l))
            .fold(None, |b: Option<(usize, f64, f64)>, c| match b {
                Some(b) if b.1 / b.2 >= c.1 / c.2 => Some(b),
                _ => Some(c),
            })
    }
}

impl fmt::Display for TorqueContinuation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.reached_scale {
            Some(1.0) => write!(
                f,
                "planned by continuation on the torque limits (from {:.2}x the limits)",
                self.relaxed_scale
            ),
            Some(s) => {
                write!(
                    f,
                    "likely torque-limited: it converges with the torque limits scaled by {s:.3}"
                )?;
                if let Some((j, p, l)) = self.worst_joint() {
                    // joints are numbered from 1 with the passive grip joint first
                    write!(f, " (peak |tau| {p:.2} N m at joint {}, limit {l} N m)", j + 2)?;
                }
                if let Some(lo) = self.failed_scale {
                    write!(f, ", not at {lo:.3}")?;
                }
                match self.stopped {
                    ContinuationStop::StepsSpent => write!(
                        f,
                        " (the bracket was not closed within {MAX_STEPS} plans)"
                    )?,
                    ContinuationStop::TimeSpent => {
                        write!(f, " (the continuation ran out of max_wall_time_s)")?
                    }
                    _ => {}
                }
                write!(f, " (a local estimate, not a proof)")
            }
            None if self.stopped == ContinuationStop::TimeSpent => write!(
                f,
                "the continuation on the torque limits ran out of max_wall_time_s before a widened \
                 plan (up to {:.0}x) converged",
                self.relaxed_scale
            ),
            None => write!(
                f,
                "widening the torque limits up to {:.0}x did not help: no plan converged with them either",
                self.relaxed_scale
            ),
        }
    }
}

/// `robot` with every actuated joint's torque limits scaled by `k` (> 0; the limits bracket 0, so
/// `k > 1` widens them).
pub(super) fn with_torque_scale(robot: &Robot, k: f64) -> Result<Robot> {
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
pub(super) fn plan_by_torque_continuation(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
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
