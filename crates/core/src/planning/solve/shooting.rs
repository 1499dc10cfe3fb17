//! The planner's multiple-shooting path: the swing as a [`SwingOcp`], solved by the stage-structured
//! solver (`backend = "ocp"`) or by pounce / ripopt through [`OcpNlp`], and the [`Plan`] built from it.
//!
//! Units: s, m, rad, rad/s, N m, J. Angles as in the crate docs.

use super::common::{
    check_guess, clearance_rows, guess_from_trajectory, min_obstacle_clearance, smooth_step_guess,
    solve_with_retry, swing_time, target_pose, variable_bounds,
};
use crate::error::{Error, Result};
use crate::integrate;
use crate::model::{Robot, Scratch};
use crate::planning::clearance_check::check_clearance;
use crate::planning::nlp::OcpNlp;
use crate::planning::nlp::{Backend, NlpSettings, PassStats, SolveStatus, TimeSplit};
use crate::planning::outcome::SolveRole;
use crate::planning::outcome::{note_between_knots, Plan, SolveAttempt, Violations};
use crate::planning::profile::Clamped;
use crate::planning::settings::{PlannerSettings, Transcription, ValidSettings};
use crate::planning::solve_log::SolveLog;
use crate::planning::task::{SwingTask, ValidTask};
use crate::planning::transcription::clearance_fn::DistanceClearanceFn;
use crate::planning::transcription::collocation::{CallbackTimings, Layout};
use crate::planning::transcription::shooting::{SwingOcp, SwingOcpSpec};
use crate::sim::{ModelPlant, Plant};
use crate::trajectory::{hermite_basis, Trajectory};
use brachia_ocp::{
    EvalLevel, OcpProblem, OcpSettings, OcpSolver, OcpStats, OcpStatus, Primal, StageBounds,
};
use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Largest RK4 step of the independent open-loop replay, s.
pub const REPLAY_MAX_STEP_S: f64 = 2.5e-3;

/// Smallest number of replay steps per RK4 step of the plan's own mesh: the replay's own
/// discretisation error is then at most `1 / 4^4 = 1/256` of the plan's (RK4 is 4th order).
pub const REPLAY_REFINEMENT: usize = 4;

/// The solver outcome of the OCP solver as the planner's status.
pub(crate) fn status_of(s: &OcpStatus) -> SolveStatus {
    match s {
        OcpStatus::Solved => SolveStatus::Solved,
        OcpStatus::SolvedToAcceptableLevel => SolveStatus::SolvedToAcceptableLevel,
        OcpStatus::MaxIterations => SolveStatus::MaxIterations,
        OcpStatus::MaxWallTime => SolveStatus::MaxWallTime,
        OcpStatus::Cancelled => SolveStatus::Cancelled,
        OcpStatus::LocallyInfeasible => SolveStatus::LocallyInfeasible,
        OcpStatus::RestorationFailed => SolveStatus::RestorationFailed,
        OcpStatus::NumericalError(_) => SolveStatus::NumericalError,
        OcpStatus::EvaluationError(m) => SolveStatus::EvaluationError(m.clone()),
        OcpStatus::InvalidProblem(m) => SolveStatus::InvalidProblem(m.clone()),
        OcpStatus::InvalidSettings(m) => SolveStatus::InvalidSettings(m.clone()),
        other => SolveStatus::Other(format!("{other:?}")),
    }
}

/// The OCP solver's one pass as a planner attempt: callbacks are its evaluations and Hessians, the
/// linear algebra its condensing, factorisations and solves, the rest line search and bookkeeping;
/// `settings` are the ones the pass ran with (its barrier update is the attempt's label).
pub(crate) fn ocp_attempt(
    stats: &OcpStats,
    status: SolveStatus,
    settings: &OcpSettings,
) -> SolveAttempt {
    let t = stats.time;
    let callbacks_s = t.evaluation_s + t.hessian_s;
    let time_split = TimeSplit {
        callbacks_s,
        linear_algebra_s: t.linear_algebra_s,
        line_search_and_other_s: (t.total_s - callbacks_s - t.linear_algebra_s).max(0.0),
    };
    SolveAttempt {
        mu_strategy: settings.mu_strategy,
        status: status.clone(),
        adopted: true,
        iterations: stats.iterations,
        time_s: t.total_s,
        time_split,
        passes: vec![PassStats {
            what: "ocp".into(),
            iterations: stats.iterations,
            time_s: t.total_s,
            time: time_split,
            status: Some(status),
            returned: true,
        }],
        role: SolveRole::Task,
        solve: 0,
        within: None,
        between_knots: None,
        numerical_error: match &stats.status {
            OcpStatus::NumericalError(m) => Some(m.clone()),
            _ => None,
        },
    }
}

/// The OCP solver's settings from the NLP seam's (the same names and meanings).
pub(crate) fn ocp_settings(nlp: &NlpSettings) -> OcpSettings {
    let d = OcpSettings::default();
    OcpSettings {
        mu_strategy: nlp.mu_strategy,
        max_iter: nlp.max_iter,
        tol: nlp.tol,
        constr_viol_tol: nlp.constr_viol_tol,
        acceptable_tol: nlp.acceptable_tol.max(nlp.tol),
        acceptable_iter: nlp.acceptable_iter,
        mu_init: nlp.mu_init.unwrap_or(d.mu_init),
        max_wall_time_s: nlp.max_wall_time_s,
        cancel: nlp.cancel.clone(),
        iteration_mark: nlp.iteration_mark.clone(),
        ..d
    }
}

/// Plan the swing by multiple shooting (called by [`super::plan_single`], which has checked the
/// guess and set the warm-start `mu_init`; the settings and the task are valid by their types).
pub(crate) fn plan_shooting(
    robot: &Arc<Robot>,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    if settings.free_range().is_none() || settings.swing_time_starts <= 1 {
        return plan_shooting_once(robot, task, settings, nlp, guess);
    }
    let starts = swing_time_starts(robot, task, settings)?;
    // a free swing time from several starts: the converged plan of lowest objective (the first
    // start's if none converged), every start's attempts and times in its report (a solve each,
    // `SolveRole::FreeTimeStart`, adopted only the chosen one's)
    // the wall-time limit is the whole search's: each start gets what is left, and none starts
    // once it is spent
    let t_start = std::time::Instant::now();
    let mut plans = Vec::with_capacity(starts.len());
    for &t0 in &starts {
        // the first start always runs (a plan is returned), with at least 1 ms
        let nlp_left = match nlp.remaining(t_start) {
            Some(n) => n,
            None if plans.is_empty() => NlpSettings {
                max_wall_time_s: Some(1e-3),
                ..nlp.clone()
            },
            None => break,
        };
        let s = settings.with_swing_time(t0)?;
        plans.push(plan_shooting_once(robot, task, &s, &nlp_left, guess)?);
    }
    let best = (0..plans.len())
        .filter(|&i| plans[i].converged())
        .min_by(|&a, &b| plans[a].objective.total_cmp(&plans[b].objective))
        .unwrap_or(0);
    let mut log = SolveLog::default();
    for (p, &t0_s) in plans.iter_mut().zip(&starts) {
        log.record(p, SolveRole::FreeTimeStart { t0_s });
    }
    let mut plan = plans.swap_remove(best);
    log.finish(&mut plan);
    // the task's free-fall time, not the start's (each start ran with its T in seconds)
    plan.freefall_time_s = swing_time(robot, task, settings)?.1;
    Ok(plan)
}

/// Where a free swing time's solves start, s: the task's swing time clamped into the range, then
/// `swing_time_starts - 1` more at the centres of as many equal parts of the range. Without a free
/// range (or with one start), the task's swing time alone.
fn swing_time_starts(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
) -> Result<Vec<f64>> {
    let (t, _) = swing_time(robot, task, settings)?;
    let t0 = settings.start_swing_time(t);
    let k = settings.swing_time_starts;
    let Some([lo, hi]) = settings.free_range().filter(|_| k > 1) else {
        return Ok(vec![t0]);
    };
    let mut v = vec![t0];
    for i in 0..k - 1 {
        v.push(lo + (i as f64 + 0.5) * (hi - lo) / (k - 1) as f64);
    }
    Ok(v)
}

/// `left` as the settings of a solve warm from a plan: the barrier parameter starts at
/// [`super::common::WARM_START_MU_INIT`] unless `left` sets it.
fn warm(left: NlpSettings) -> NlpSettings {
    NlpSettings {
        mu_init: Some(left.mu_init.unwrap_or(super::common::WARM_START_MU_INIT)),
        ..left
    }
}

/// One multiple-shooting plan from one start (see [`plan_shooting`]).
///
/// The problem has clearance rows at the knots. When its solve converged but the resampled
/// trajectory breaks the clearance between them ([`Plan::clearance_violation`]) and
/// `settings.shooting.substep_clearance` is on, the task is solved again, warm from that plan, with
/// the rows also at the RK4 sub-step states of every interval (a solve of its own,
/// [`SolveRole::SubstepClearance`]; a candidate of the obstacle race yields to a later one from
/// there, [`yield_to_later`]). When that plan converges and still breaks the clearance between
/// its rows, it is solved once more, warm from it, with [`DENSER_SUBSTEP_FACTOR`] times the RK4
/// sub-steps (and so rows that many times denser), if time is left; that plan is returned when it
/// converges with the trajectory clear, otherwise the plan of the sub-step rows (whose status says
/// where it breaks the clearance). Every solve is in the report.
fn plan_shooting_once(
    robot: &Arc<Robot>,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    let started = std::time::Instant::now();
    let mut p = solve_shooting(robot, task, settings, nlp, guess, false)?;
    let refine = settings.shooting.substep_clearance
        && settings.shooting.substeps > 1
        && p.status.is_converged()
        && p.clearance_violation.is_some();
    let Some(left) = nlp.remaining(started).filter(|_| refine) else {
        return Ok(p);
    };
    // past its first converged solve: a later candidate of a race that has converged may win now
    yield_to_later();
    let q = solve_shooting(robot, task, settings, &warm(left), Some(&p.points), true)?;
    let mut log = SolveLog::default();
    log.record(&mut p, SolveRole::Task);
    let mut out = with_denser_rows(robot, task, settings, nlp, started, q, &mut log)?;
    log.finish(&mut out);
    out.freefall_time_s = p.freefall_time_s;
    Ok(out)
}

/// The plan of a solve with the rows at the sub-steps, `q` (recorded in `log` as
/// [`SolveRole::SubstepClearance`]), or, when `q` converged but its trajectory still breaks the
/// clearance between its rows and time is left of `nlp` counted from `started`, the plan solved
/// warm from it with [`DENSER_SUBSTEP_FACTOR`] times the sub-steps when that converges clear
/// (recorded too). The plan returned is not finished ([`SolveLog::finish`]).
#[allow(clippy::too_many_arguments)]
fn with_denser_rows(
    robot: &Arc<Robot>,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
    mut q: Plan,
    log: &mut SolveLog,
) -> Result<Plan> {
    log.record(&mut q, SolveRole::SubstepClearance);
    let denser = q.status.is_converged() && q.clearance_violation.is_some();
    let Some(left) = nlp.remaining(started).filter(|_| denser) else {
        return Ok(q);
    };
    let dense = settings.with_substeps(settings.shooting.substeps * DENSER_SUBSTEP_FACTOR);
    let mut d = solve_shooting(robot, task, &dense, &warm(left), Some(&q.points), true)?;
    log.record(&mut d, SolveRole::SubstepClearance);
    Ok(if d.converged() { d } else { q })
}

thread_local! {
    /// The flag of the race candidate running on this thread ([`with_yield_flag`]); none outside
    /// a race.
    static YIELD_FLAG: RefCell<Option<Arc<AtomicBool>>> = const { RefCell::new(None) };
}

/// Run `f` on this thread as a candidate of a race whose flag is `flag`: [`yield_to_later`]
/// raises it from within `f` (the solves of the candidate), and the race reads it.
pub(crate) fn with_yield_flag<R>(flag: &Arc<AtomicBool>, f: impl FnOnce() -> R) -> R {
    let before = YIELD_FLAG.with(|c| c.replace(Some(Arc::clone(flag))));
    let r = f();
    YIELD_FLAG.with(|c| *c.borrow_mut() = before);
    r
}

/// Mark the race candidate running on this thread as past its first chance (its first converged
/// solve broke the clearance between its rows, or its solve at the task's mesh ended without a
/// clear plan): from here a later candidate that has converged wins over it
/// ([`crate::planning::strategy::race`]). Nothing outside a race.
pub(crate) fn yield_to_later() {
    YIELD_FLAG.with(|c| {
        if let Some(f) = c.borrow().as_ref() {
            f.store(true, Ordering::SeqCst);
        }
    });
}

/// The mark that makes the race candidate running on this thread yield to a later one that has
/// converged once a solve has run `after` iterations ([`yield_to_later`] from within the solve,
/// which goes on unchanged); `None` outside a race.
pub(crate) fn yield_mark(after: usize) -> Option<crate::IterationMark> {
    YIELD_FLAG.with(|c| {
        c.borrow().as_ref().map(|f| crate::IterationMark {
            after,
            flag: Arc::clone(f),
        })
    })
}

/// Factor the RK4 sub-steps (and so the clearance rows between the knots) are multiplied by in the
/// last re-solve of a plan whose sub-step rows still leave its trajectory inside the margin between
/// them (the multiple-shooting plan of one start).
pub const DENSER_SUBSTEP_FACTOR: usize = 2;

/// One multiple-shooting solve from one start, with the clearance rows at the knots, and also at
/// the interior RK4 sub-step states when `substep_rows`.
fn solve_shooting(
    robot: &Arc<Robot>,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
    substep_rows: bool,
) -> Result<Plan> {
    let ShootingSetup {
        mut ocp,
        mut layout,
        mut t_final,
        freefall,
    } = setup_shooting_rows(robot, task, settings, guess, substep_rows)?;
    // (a range of one value, or narrower than MIN_FREE_SWING_TIME_RANGE_S, is that fixed T, which
    // the setup has already clamped to)
    if let Some([lo, hi]) = settings.free_range() {
        ocp = ocp.with_free_swing_time(lo, hi)?;
    }

    // solve
    let (mut z, status, objective, solves, mut ocp) = match nlp.backend {
        Backend::Ocp => {
            let mut solver = OcpSolver::new(ocp.dims()).map_err(|e| {
                Error::invalid("ocp solver", "problem dimensions", e.to_string(), "refused")
            })?;
            let mut ocp = ocp;
            let st = ocp_settings(nlp);
            let stats = solver.solve(&mut ocp, &st);
            let status = status_of(&stats.status);
            let solves = vec![ocp_attempt(&stats, status.clone(), &st)];
            (
                solver.primal().clone(),
                status,
                stats.objective,
                solves,
                ocp,
            )
        }
        Backend::Pounce | Backend::Ripopt => {
            let mut prob = OcpNlp::new(ocp);
            let (sol, solves) = solve_with_retry(&mut prob, nlp);
            let mut z = Primal::zeros(prob.problem().dims());
            if sol.x.len() == crate::planning::nlp::SparseNlp::n_vars(&prob) {
                prob.unstack(&sol.x, &mut z);
            } else {
                prob.problem().initial_guess(&mut z);
            }
            (z, sol.status, sol.objective, solves, prob.into_problem())
        }
    };
    if ocp.free_swing_time().is_some() {
        // the plan at the optimal T: the same knots in the fixed-T layout
        // (a solve that never started leaves a point without a valid T: keep the start's)
        let t = ocp.swing_time_of(&z);
        if let (true, Some([lo, hi])) = (t.is_finite(), ocp.free_swing_time()) {
            t_final = t.clamp(lo, hi);
        }
        ocp = ocp.with_fixed_swing_time(t_final)?;
        z = ocp.strip_swing_time(&z);
        layout = Layout::new(
            robot.n,
            robot.n - 1,
            layout.intervals,
            t_final,
            Transcription::MultipleShooting,
        );
    }
    finish_plan(
        robot,
        task,
        settings,
        &layout,
        t_final,
        freefall,
        &z,
        &mut ocp,
        SolveSummary {
            status,
            objective,
            backend: nlp.backend,
            solves,
        },
    )
}

/// The multiple-shooting problem of a task, built with its initial guess, and its grid.
pub(crate) struct ShootingSetup {
    /// The problem (guess set).
    pub ocp: SwingOcp,
    /// The knot grid.
    pub layout: Layout,
    /// Swing time T, s.
    pub t_final: f64,
    /// The free-fall time when T is `"auto"`, s.
    pub freefall: Option<f64>,
}

/// How a solve ended, for [`finish_plan`].
pub(crate) struct SolveSummary {
    pub status: SolveStatus,
    pub objective: f64,
    pub backend: Backend,
    /// Every solver attempt (exactly one adopted).
    pub solves: Vec<SolveAttempt>,
}

/// Build the multiple-shooting problem of `task` with its initial guess (from `guess`, or the
/// smoothstep towards the inverse-kinematics target pose), whatever the settings' `transcription`
/// says (the entries refuse the `ocp` backend with a collocation rule).
pub(crate) fn setup_shooting(
    robot: &Arc<Robot>,
    task: &ValidTask,
    settings: &ValidSettings,
    guess: Option<&Trajectory>,
) -> Result<ShootingSetup> {
    setup_shooting_rows(robot, task, settings, guess, false)
}

/// [`setup_shooting`], with the clearance rows also at the interior RK4 sub-step states when
/// `substep_rows`.
fn setup_shooting_rows(
    robot: &Arc<Robot>,
    task: &ValidTask,
    settings: &ValidSettings,
    guess: Option<&Trajectory>,
    substep_rows: bool,
) -> Result<ShootingSetup> {
    if let Some(g) = guess {
        check_guess(robot, g)?;
    }
    let n = robot.n;
    let qd0 = task.qd0();
    let (t_final, freefall) = swing_time(robot, task, settings)?;
    // a free swing time starts from the task's T clamped into its range
    let t_final = settings.start_swing_time(t_final);
    // the interval count follows from input: checked against brachia::limits before any allocation
    // (with a free swing time, from its largest value: the knots are at most about knot_dt apart,
    // whatever T the plan ends at)
    let intervals = settings.grid(n, settings.longest_swing_time(t_final), "planner")?;
    let layout = Layout::new(
        n,
        n - 1,
        intervals,
        t_final,
        Transcription::MultipleShooting,
    );
    let cf = clearance_rows(robot, task, settings)?;

    // initial guess, on the knots (stacked [q, qd, tau] per knot as for collocation)
    let bounds = variable_bounds(robot, &layout, settings, &task.q0, qd0);
    let nz = layout.nz;
    let mut x0 = vec![0.0; layout.n_vars()];
    if let Some(g) = guess {
        guess_from_trajectory(g, &layout, t_final, &bounds, &mut x0);
    } else {
        let q_t = target_pose(robot, task, settings, cf.as_ref())?;
        smooth_step_guess(&layout, t_final, &task.q0, &q_t, qd0, &mut x0);
    }
    let spec = SwingOcpSpec {
        intervals,
        swing_time_s: t_final,
        substeps: settings.shooting.substeps,
        q1_diag: settings.q1(n),
        r1_diag: settings.r1(n),
        x_start: [task.q0.as_slice(), qd0].concat(),
        target: task.target,
        bounds: settings.bounds.clone(),
        parallel_min_stages: settings.shooting.parallel_min_stages,
        substep_clearance: substep_rows,
    };
    let mut ocp = SwingOcp::new(Arc::clone(robot), spec, cf.map(DistanceClearanceFn::new))?;
    {
        let g = ocp.guess_mut();
        for k in 0..=intervals {
            g.x[k].copy_from_slice(&x0[k * nz..k * nz + 2 * n]);
            let nu = g.u[k].len();
            g.u[k].copy_from_slice(&x0[k * nz + 2 * n..k * nz + 2 * n + nu]);
        }
    }

    Ok(ShootingSetup {
        ocp,
        layout,
        t_final,
        freefall,
    })
}

/// The [`Plan`] of a multiple-shooting solution `z` of `ocp` (knots, held-torque trajectory,
/// violations, independent replay).
pub(crate) fn finish_plan(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    layout: &Layout,
    t_final: f64,
    freefall: Option<f64>,
    z: &Primal,
    ocp: &mut SwingOcp,
    sum: SolveSummary,
) -> Result<Plan> {
    let SolveSummary {
        status,
        objective,
        backend,
        mut solves,
    } = sum;
    let mut time_split = TimeSplit::default();
    for a in &solves {
        time_split.add(&a.time_split);
    }
    let n = robot.n;
    let intervals = layout.intervals;
    let st = ocp.timings;
    let callback_timings = CallbackTimings {
        objective_s: 0.0,
        constraints_s: st.values_s,
        jacobian_s: st.first_order_s,
        hessian_s: st.hessian_s,
        hessian_calls: st.hessian_calls,
    };

    // knots: tau at knot k = u_k, the last knot repeats u_{K-1}
    let mut points = Trajectory::new(n);
    let mut points_qdd = vec![0.0; (intervals + 1) * n];
    let mut ws = Scratch::new(n);
    for k in 0..=intervals {
        let tau = &z.u[k.min(intervals - 1)];
        let (q, qd) = z.x[k].split_at(n);
        points.push(layout.time(k), q, qd, tau);
        robot.forward_dynamics_into(&mut ws, q, qd, tau, &mut points_qdd[k * n..(k + 1) * n]);
    }
    let max_step = REPLAY_MAX_STEP_S.min(layout.h / settings.shooting.substeps as f64);
    let trajectory =
        held_torque_trajectory(robot, z, layout.h, t_final, settings.output_dt, max_step);
    let (energy_j, positive_work_j) = trajectory.work();
    let ee_final = robot.ee_position(&z.x[intervals][..n]);
    let violations = violations(ocp, z);
    let replay_ee_error_m =
        replay_held_torques(robot, z, layout.h, settings.shooting.substeps, task.target);
    let min_obstacle_clearance_m = min_obstacle_clearance(robot, &task.obstacles, &trajectory)?;
    let clearance_violation = check_clearance(robot, task, settings, &trajectory)?;
    note_between_knots(&mut solves, &status, clearance_violation.as_ref());
    Ok(Plan {
        status,
        backend,
        iterations: solves.iter().map(|a| a.iterations).sum(),
        attempts: solves.len(),
        solve_time_s: solves.iter().map(|a| a.time_s).sum(),
        solves,
        time_split,
        callback_timings,
        objective,
        swing_time_s: t_final,
        freefall_time_s: freefall,
        layout: *layout,
        points,
        points_qdd,
        trajectory,
        // integrated with the held torques, not interpolated: nothing to clamp
        resample_clamped: Clamped::default(),
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

/// Largest violations of the shooting problem at `z`, by kind (its own evaluation, values only).
fn violations(ocp: &mut SwingOcp, z: &Primal) -> Violations {
    let dims = ocp.dims().clone();
    let k_last = dims.horizon();
    let (mut stages, mut term) = (dims.stage_evals(), dims.terminal_eval());
    if ocp
        .evaluate(z, EvalLevel::Values, &mut stages, &mut term)
        .is_err()
    {
        let inf = f64::INFINITY;
        return Violations {
            dynamics: inf,
            ee_position: inf,
            ee_velocity: inf,
            clearance: inf,
            bounds: inf,
        };
    }
    let (mut dynamics, mut clearance, mut bounds) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..=k_last {
        if k < k_last {
            for (f, x) in stages[k].f.iter().zip(&z.x[k + 1]) {
                dynamics = dynamics.max((f - x).abs());
            }
        }
        for c in &stages[k].c {
            clearance = clearance.max(-c);
        }
        let mut b = StageBounds::unbounded(dims.stages[k]);
        ocp.bounds(k, &mut b);
        let out = |v: &[f64], lo: &[f64], hi: &[f64]| {
            v.iter()
                .zip(lo.iter().zip(hi))
                .fold(0.0f64, |m, (v, (l, h))| m.max(l - v).max(v - h))
        };
        bounds = bounds
            .max(out(&z.x[k], &b.x_lo, &b.x_hi))
            .max(out(&z.u[k], &b.u_lo, &b.u_hi));
    }
    let r = &term.r;
    Violations {
        dynamics,
        ee_position: r[0].hypot(r[1]),
        ee_velocity: r[2].hypot(r[3]),
        clearance,
        bounds,
    }
}

/// The swing at period `dt` (s) with the plan's held torques: every interval integrated from its knot
/// by RK4 in equal steps of at most `max_step`, the samples inside a step by the cubic Hermite
/// interpolant of the state and its derivative `f(x, u)` at the step's two ends (error O(step^4): below
/// 1e-9 rad and 1e-7 rad/s at 2.5 ms on the tracking swing, tested); samples at `j dt` and a last one
/// exactly at `t_final`. The torque of a sample is the mean of the held torques over its period
/// `[t_j, t_j+1)` ([`hold_means`]; the last sample's, the one held at `t_final`).
pub(crate) fn held_torque_trajectory(
    robot: &Robot,
    z: &Primal,
    h: f64,
    t_final: f64,
    dt: f64,
    max_step: f64,
) -> Trajectory {
    let (n, nx) = (robot.n, robot.nx());
    let k_last = z.x.len() - 1;
    let mut out = Trajectory::new(n);
    let n_samples = ((t_final / dt) * (1.0 - 1e-12)).ceil() as usize; // samples j dt < t_final
    let sample_t = |j: usize| {
        if j == n_samples {
            t_final
        } else {
            j as f64 * dt
        }
    };
    let mut ws = Scratch::new(n);
    let mut buf = vec![0.0; 8 * nx];
    let (x, rest) = buf.split_at_mut(nx);
    let (x1, rest) = rest.split_at_mut(nx);
    let (f0, rest) = rest.split_at_mut(nx);
    let (k2, rest) = rest.split_at_mut(nx);
    let (k3, rest) = rest.split_at_mut(nx);
    let (k4, rest) = rest.split_at_mut(nx);
    let (tmp, xs) = rest.split_at_mut(nx);
    let m = (h / max_step).ceil().max(1.0) as usize;
    let ds = h / m as f64;
    let mut j = 0;
    for k in 0..k_last {
        let u = &z.u[k];
        let ta = k as f64 * h;
        // samples before the next knot belong to interval k; the last interval holds t_final
        let tb = if k + 1 == k_last {
            f64::INFINITY
        } else {
            (k + 1) as f64 * h
        };
        x.copy_from_slice(&z.x[k]);
        integrate::deriv(robot, &mut ws, x, u, f0);
        for s in 0..m {
            let t0 = ta + s as f64 * ds;
            // one RK4 step x -> x1 (the arithmetic of `Rk4::step`, its k1 = f0)
            for i in 0..nx {
                tmp[i] = x[i] + 0.5 * ds * f0[i];
            }
            integrate::deriv(robot, &mut ws, tmp, u, k2);
            for i in 0..nx {
                tmp[i] = x[i] + 0.5 * ds * k2[i];
            }
            integrate::deriv(robot, &mut ws, tmp, u, k3);
            for i in 0..nx {
                tmp[i] = x[i] + ds * k3[i];
            }
            integrate::deriv(robot, &mut ws, tmp, u, k4);
            for i in 0..nx {
                x1[i] = x[i] + ds / 6.0 * (f0[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            // f1 = f(x1) is the next step's k1: computed into k4 (free now), then swapped in
            integrate::deriv(robot, &mut ws, x1, u, k4);
            let end = if s + 1 == m { tb } else { t0 + ds };
            while j <= n_samples && sample_t(j) < end {
                let t = sample_t(j);
                let r = ((t - t0) / ds).clamp(0.0, 1.0);
                let (h00, h10, h01, h11) = hermite_basis(r);
                for i in 0..nx {
                    xs[i] = h00 * x[i] + h10 * ds * f0[i] + h01 * x1[i] + h11 * ds * k4[i];
                }
                out.push(t, &xs[..n], &xs[n..], u);
                j += 1;
            }
            x.copy_from_slice(x1);
            f0.copy_from_slice(k4);
        }
    }
    hold_means(&mut out, z, h);
    out
}

/// Replace each sample's torque by the mean of the held profile over its period `[t_j, t_j+1)`
/// (interval k holds `u_k` over `[k h, (k + 1) h)`, the last interval from then on): the torque a
/// zero-order hold must apply over the period (docs/conventions.md). The last sample keeps its own.
fn hold_means(out: &mut Trajectory, z: &Primal, h: f64) {
    let (nu, k_max) = (out.n - 1, z.u.len().saturating_sub(2));
    let u_at = |k: usize| &z.u[k.min(k_max)];
    let mut acc = [0.0; crate::model::MAX_LINKS];
    for j in 0..out.len().saturating_sub(1) {
        let (t0, t1) = (out.t[j], out.t[j + 1]);
        acc[..nu].fill(0.0);
        let mut a = t0;
        let mut k = ((t0 / h).floor().max(0.0) as usize).min(k_max);
        while a < t1 {
            let b = if k >= k_max {
                t1
            } else {
                t1.min((k + 1) as f64 * h)
            };
            for (i, v) in acc[..nu].iter_mut().enumerate() {
                *v += (b - a) * u_at(k)[i];
            }
            a = b;
            k += 1;
        }
        let tau = &mut out.tau[j * nu..(j + 1) * nu];
        for (i, v) in tau.iter_mut().enumerate() {
            *v = acc[i] / (t1 - t0);
        }
    }
}

/// Replay the held torque profile open loop on the model plant from the start state, without
/// restarting at the knots: every interval in `m` equal RK4 steps, `m` the larger of
/// [`REPLAY_REFINEMENT`] times the plan's `substeps` and `ceil(h / REPLAY_MAX_STEP_S)`. These steps
/// are not the plan's own (an independent integration of the same torques; its own error is at most
/// 1/256 of the plan's discretisation error, tested against 0.1 ms steps). The final EE distance from
/// `target`, m.
pub(crate) fn replay_held_torques(
    robot: &Robot,
    z: &Primal,
    h: f64,
    substeps: usize,
    target: [f64; 2],
) -> f64 {
    let m = (REPLAY_REFINEMENT * substeps).max((h / REPLAY_MAX_STEP_S).ceil() as usize);
    replay_held_torques_in(robot, z, h, m, target)
}

/// [`replay_held_torques`] in `m` RK4 steps per interval.
pub(crate) fn replay_held_torques_in(
    robot: &Robot,
    z: &Primal,
    h: f64,
    m: usize,
    target: [f64; 2],
) -> f64 {
    let n = robot.n;
    let mut plant = ModelPlant::new(robot.clone(), &z.x[0]);
    plant.substeps = m.max(1);
    for u in &z.u[..z.u.len() - 1] {
        plant.step(u, h);
    }
    let mut x = vec![0.0; 2 * n];
    plant.state(&mut x);
    let ee = robot.ee_position(&x[..n]);
    (ee[0] - target[0]).hypot(ee[1] - target[1])
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planning::plan;

    /// The OCP solver's numerical-error message stays in the attempt's record (and its JSON);
    /// other outcomes carry none and serialise without the field.
    #[test]
    fn an_attempt_keeps_the_numerical_error_message_of_the_solver() {
        let msg = "the Hessian could not be regularised (delta_w > 1e40)";
        let mut stats = OcpStats {
            status: OcpStatus::NumericalError(msg.into()),
            iterations: 197,
            objective: 0.0,
            primal_infeasibility: 0.0,
            dual_infeasibility: 0.0,
            final_mu: 1e-4,
            regularizations: 0,
            factorizations: 0,
            centrality_correctors: 0,
            time: Default::default(),
        };
        let st = OcpSettings::default();
        let a = ocp_attempt(&stats, status_of(&stats.status), &st);
        assert_eq!(a.status, SolveStatus::NumericalError);
        assert_eq!(a.numerical_error.as_deref(), Some(msg));
        let json = serde_json::to_string(&a).unwrap();
        assert!(json.contains(msg), "{json}");
        stats.status = OcpStatus::MaxIterations;
        let a = ocp_attempt(&stats, status_of(&stats.status), &st);
        assert_eq!(a.numerical_error, None);
        assert!(!serde_json::to_string(&a)
            .unwrap()
            .contains("numerical_error"));
    }

    /// The replay at [`REPLAY_MAX_STEP_S`] / [`REPLAY_REFINEMENT`] measures the same miss as a replay
    /// at 0.1 ms steps (the old reference), on the tracking swing at 10 and 30 ms knots.
    #[test]
    fn coarse_replay_matches_the_fine_replay() {
        let robot = Robot::paper();
        let task = SwingTask {
            q0: vec![-2.35, 0.0, -1.55, 0.0],
            qd0: vec![],
            target: [0.8, 0.0],
            obstacles: vec![],
        };
        let nlp = NlpSettings {
            backend: Backend::Ocp,
            ..Default::default()
        };
        for knot_dt in [0.01, 0.03] {
            // one RK4 step per interval: the replay below integrates the knots' held torques with 1
            let mut s = PlannerSettings {
                transcription: Transcription::MultipleShooting,
                knot_dt,
                ..Default::default()
            };
            s.shooting.substeps = 1;
            let p = plan(&robot, &task, &s, &nlp).unwrap();
            assert!(p.converged(), "{:?}", p.status);
            let dims = brachia_ocp::OcpDims {
                stages: (0..=p.layout.intervals)
                    .map(|k| brachia_ocp::StageDims {
                        nx: 8,
                        nu: if k < p.layout.intervals { 3 } else { 0 },
                        nc: 0,
                    })
                    .collect(),
                n_terminal: 4,
            };
            let mut z = Primal::zeros(&dims);
            for k in 0..=p.layout.intervals {
                z.x[k] = [p.points.q(k), p.points.qd(k)].concat();
                if k < p.layout.intervals {
                    z.u[k].copy_from_slice(p.points.tau(k));
                }
            }
            let h = p.layout.h;
            let fine =
                replay_held_torques_in(&robot, &z, h, (h / 1e-4).ceil() as usize, task.target);
            let coarse = replay_held_torques(&robot, &z, h, 1, task.target);
            assert_eq!(coarse, p.replay_ee_error_m);
            assert!(
                (coarse - fine).abs() <= 0.02 * fine + 1e-10,
                "knot_dt {knot_dt}: replay {coarse:e} m, at 0.1 ms {fine:e} m"
            );
            // the 1 ms trajectory (RK4 at <= 2.5 ms from each knot, Hermite between steps) against
            // RK4 at 10 us from the knot
            let tr = &p.trajectory;
            let mut rk4 = integrate::Rk4::new(&robot);
            let (mut dq, mut dqd) = (0.0f64, 0.0f64);
            for j in (0..tr.len()).step_by(53).chain([tr.len() - 1]) {
                let t = tr.t[j];
                let k = ((t / h).floor() as usize).min(p.layout.intervals - 1);
                let span = t - k as f64 * h;
                let mut x = z.x[k].clone();
                if span > 0.0 {
                    rk4.advance(&robot, &mut x, &z.u[k], span, (span / 1e-5).ceil() as usize);
                }
                for i in 0..4 {
                    dq = dq.max((tr.q(j)[i] - x[i]).abs());
                    dqd = dqd.max((tr.qd(j)[i] - x[4 + i]).abs());
                }
            }
            assert!(
                dq < 1e-9 && dqd < 1e-7,
                "knot_dt {knot_dt}: trajectory off by {dq:e} rad, {dqd:e} rad/s"
            );
        }
    }
}
