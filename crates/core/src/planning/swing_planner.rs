//! A persistent swing planner: the multiple-shooting problem ([`SwingOcp`]) and the Riccati
//! interior-point workspace ([`OcpSolver`]) built once, then re-planned from measured states.
//!
//! ## Re-planning (docs/planner.md, "Re-planning")
//! [`SwingPlanner::replan`] re-plans from the measured state `x_now` at time `t_now` to the same bar
//! over the remaining time `T - t_now`. The horizon keeps its K intervals and the interval shrinks to
//! `h' = (T - t_now) / K`: the problem's dimensions never change, so the solver's workspace, its stored
//! iterate and its stored multipliers (stage k to stage k) stay valid and nothing is allocated. The
//! previous solution (knot times `t0 + k h`) is shifted onto the new knot times `t_now + k h'`: states
//! linearly interpolated between the old knots, torques held (the one of the old interval holding the
//! new knot time), `x_0` replaced by `x_now`. The solve then starts warm (the solver's stored bound and
//! constraint multipliers, a small barrier parameter).
//!
//! Times: a [`Plan`] or [`ReplanOutcome`] of a re-plan runs on its own clock, 0 at `t_now`; absolute
//! knot times come from [`SwingPlanner::knot_time`]. Units: s, m, rad, rad/s, N m.

use super::collocation::Layout;
use super::nlp::{Backend, NlpSettings, SolveStatus};
use super::plan_shooting::{
    finish_plan, ocp_attempt, ocp_settings, setup_shooting, status_of, ShootingSetup, SolveSummary,
};
use super::planner::{Plan, WARM_START_MU_INIT};
use super::settings::PlannerSettings;
use super::shooting::SwingOcp;
use super::task::SwingTask;
use crate::error::{Error, Result};
use crate::model::Robot;
use brachia_ocp::{OcpProblem, OcpSettings, OcpSolver, OcpStats, Primal, WarmDuals};
use std::sync::Arc;

/// How one (re-)plan ended, without allocating: the solver's status and diagnostics and the grid of
/// the solution (read the knots with [`SwingPlanner::knots`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ReplanOutcome {
    /// How the solve ended.
    pub status: SolveStatus,
    /// Interior-point iterations.
    pub iterations: usize,
    /// Wall time of the solve, s.
    pub solve_time_s: f64,
    /// Objective at the solution.
    pub objective: f64,
    /// Absolute time of knot 0 (`t_now`; 0 for a full plan), s.
    pub t_start: f64,
    /// Interval between knots, s.
    pub interval_s: f64,
    /// End-effector position at the last knot, m.
    pub ee_final: [f64; 2],
    /// Its distance from the target, m.
    pub ee_error_m: f64,
}

impl ReplanOutcome {
    /// Solved, or solved to the acceptable level.
    pub fn converged(&self) -> bool {
        self.status.is_converged()
    }
}

/// A solution the planner can shift from (see [`SwingPlanner::checkpoint`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Checkpoint {
    z: Primal,
    t0: f64,
    h: f64,
}

/// The persistent multiple-shooting planner (see the module docs). Owns everything it uses: a shared
/// handle to the robot (`Arc<Robot>`, shared with a controller), the task, the settings, the problem
/// and the solver's workspace, all allocated in [`SwingPlanner::new`]; so a controller can hold one
/// across calls and move it between threads (it is `Send`).
///
/// A cold plan of the paper's swing, then a warm re-plan from a measured state later in the swing:
///
/// ```
/// use brachia::planning::{NlpSettings, PlannerSettings, SwingPlanner, SwingTask};
/// use brachia::Robot;
/// use std::sync::Arc;
///
/// let robot = Arc::new(Robot::paper());
/// let task = SwingTask {
///     q0: vec![-2.35, 0.0, -1.55, 0.0], // hanging, rad
///     qd0: vec![],                      // at rest
///     target: [0.8, 0.0],               // the next bar, m in the grip frame
///     obstacles: vec![],
/// };
/// let settings = PlannerSettings { knot_dt: 0.03, ..Default::default() }; // 30 ms knots
/// let mut planner = SwingPlanner::new(Arc::clone(&robot), task, &settings, &NlpSettings::default())?;
/// let cold = planner.plan_outcome()?;
/// assert!(cold.converged(), "{:?}", cold.status);
/// // 0.6 s into the swing, the measured state (here the planned one, nudged by 0.02 rad)
/// let k = (0.6 / cold.interval_s).round() as usize;
/// let t_now = planner.knot_time(k);
/// let mut x_now = planner.knots().x[k].clone();
/// x_now[0] += 0.02;
/// let warm = planner.replan(t_now, &x_now)?;
/// assert!(warm.converged() && warm.ee_error_m < 1e-3, "{warm:?}");
/// // the plan as a trajectory (1 ms samples) from t_now to the end of the swing
/// let plan = planner.current_plan()?;
/// assert!(plan.converged());
/// # Ok::<(), brachia::Error>(())
/// ```
pub struct SwingPlanner {
    robot: Arc<Robot>,
    task: SwingTask,
    settings: PlannerSettings,
    cold: OcpSettings,
    warm: OcpSettings,
    ocp: SwingOcp,
    solver: OcpSolver,
    layout: Layout,
    t_final: f64,
    freefall: Option<f64>,
    /// The setup's initial guess (for [`SwingPlanner::plan`]).
    guess: Primal,
    /// The solution re-plans shift from, its knot-0 time and interval.
    prev: Checkpoint,
    has_prev: bool,
    /// Absolute time of knot 0 of the problem as it stands.
    t0: f64,
    x_full: Vec<f64>,
    /// Status and statistics of the last solve and whether it was warm (for the [`Plan`]); `None`
    /// before the first.
    last: Option<(SolveStatus, OcpStats, bool)>,
}

impl SwingPlanner {
    /// Build the problem of `task` for `robot` (a `Robot` or a shared `Arc<Robot>`) once (the
    /// multiple-shooting transcription of `settings`, whatever its `transcription` field says;
    /// tolerances and limits from `nlp`). Errors as [`super::plan_with_guess`] on invalid settings,
    /// tasks or dimensions.
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        task: SwingTask,
        settings: &PlannerSettings,
        nlp: &NlpSettings,
    ) -> Result<Self> {
        let robot: Arc<Robot> = robot.into();
        let settings = PlannerSettings {
            transcription: super::settings::Transcription::MultipleShooting,
            ..settings.clone()
        };
        settings.validate(robot.n, "planner")?;
        nlp.validate()?;
        let ShootingSetup {
            ocp,
            layout,
            t_final,
            freefall,
        } = setup_shooting(&robot, &task, &settings, None)?;
        let solver = OcpSolver::new(ocp.dims()).map_err(|e| {
            Error::invalid("ocp solver", "problem dimensions", e.to_string(), "refused")
        })?;
        let cold = ocp_settings(nlp);
        // the stored multipliers, a small barrier parameter and bound push, the adaptive barrier
        // update: the fewest iterations of the variants measured in benches/replan.rs and
        // examples/replan_profile.rs (docs/planner.md, "Re-planning"; docs/ocp.md section 12)
        let warm = OcpSettings {
            warm_start: true,
            mu_init: nlp.mu_init.unwrap_or(WARM_START_MU_INIT),
            mu_strategy: brachia_ocp::MuStrategy::Adaptive,
            warm_duals: WarmDuals::Stored,
            warm_bound_push: 1e-9,
            ..cold.clone()
        };
        let mut guess = Primal::zeros(ocp.dims());
        ocp.initial_guess(&mut guess);
        let x_full = ocp.start().to_vec();
        Ok(SwingPlanner {
            robot,
            task,
            settings,
            cold,
            warm,
            prev: Checkpoint {
                z: guess.clone(),
                t0: 0.0,
                h: layout.h,
            },
            guess,
            solver,
            ocp,
            layout,
            t_final,
            freefall,
            has_prev: false,
            t0: 0.0,
            x_full,
            last: None,
        })
    }

    /// True once a solve converged (a re-plan has a solution to shift from).
    pub fn has_plan(&self) -> bool {
        self.has_prev
    }

    /// The robot planned for (shared).
    pub fn robot(&self) -> &Arc<Robot> {
        &self.robot
    }

    /// The task the planner was built for, its target the current one ([`SwingPlanner::set_target`]).
    pub fn task(&self) -> &SwingTask {
        &self.task
    }

    /// Settings of the warm solves (warm start on, the stored multipliers, `mu_init` from the NLP
    /// settings or [`WARM_START_MU_INIT`], `warm_bound_push` 1e-9, the adaptive barrier update);
    /// edit to tune.
    pub fn warm_settings_mut(&mut self) -> &mut OcpSettings {
        &mut self.warm
    }

    /// The full swing time T, s.
    pub fn swing_time(&self) -> f64 {
        self.t_final
    }

    /// Number of intervals K (fixed for the planner's life).
    pub fn intervals(&self) -> usize {
        self.layout.intervals
    }

    /// The solver's current solution (the last solve's), K + 1 knots.
    pub fn knots(&self) -> &Primal {
        self.solver.primal()
    }

    /// Absolute time of knot k of the current solution, s.
    pub fn knot_time(&self, k: usize) -> f64 {
        self.t0 + k as f64 * self.ocp.interval()
    }

    /// The target bar position, m.
    pub fn target(&self) -> [f64; 2] {
        self.ocp.target()
    }

    /// Move the target bar (m) for the next (re-)plan; the previous solution stays the warm start.
    pub fn set_target(&mut self, target: [f64; 2]) -> Result<()> {
        if !(target[0].is_finite() && target[1].is_finite()) {
            return Err(Error::invalid(
                "planner",
                "target",
                format!("{target:?}"),
                "must be finite",
            ));
        }
        self.ocp.set_target(target);
        self.task.target = target;
        Ok(())
    }

    /// Cold plan of the whole swing from the task's start state (the setup's initial guess); the
    /// solution becomes the one re-plans shift from. Allocates the [`Plan`].
    pub fn plan(&mut self) -> Result<Plan> {
        self.plan_outcome()?;
        self.current_plan()
    }

    /// [`SwingPlanner::plan`] without building the [`Plan`].
    pub fn plan_outcome(&mut self) -> Result<ReplanOutcome> {
        self.ocp.set_start(&self.x_full)?;
        self.ocp.set_knot_bounds(&self.settings.bounds);
        self.ocp.set_swing_time(self.t_final)?;
        self.t0 = 0.0;
        let g = self.ocp.guess_mut();
        for (d, s) in g.x.iter_mut().zip(&self.guess.x) {
            d.copy_from_slice(s);
        }
        for (d, s) in g.u.iter_mut().zip(&self.guess.u) {
            d.copy_from_slice(s);
        }
        let out = self.solve(false);
        self.adopt(&out);
        Ok(out)
    }

    /// Warm re-plan from the measured state `x_now` (2n) at time `t_now` (s, in `[0, T)`) to the
    /// target over the remaining `T - t_now` (see the module docs). Does not allocate (but for a
    /// failure status's message). Errors on a wrong-sized or non-finite state, a time outside
    /// `[0, T)`, or no previous plan.
    pub fn replan(&mut self, t_now: f64, x_now: &[f64]) -> Result<ReplanOutcome> {
        self.prepare(t_now, x_now, true)?;
        let out = self.solve(true);
        self.adopt(&out);
        Ok(out)
    }

    /// The same re-plan started cold (the shifted solution as the initial guess, the solver's cold
    /// initialisation: default barrier parameter and bound push, multipliers reset), for comparison.
    pub fn replan_cold(&mut self, t_now: f64, x_now: &[f64]) -> Result<ReplanOutcome> {
        self.prepare(t_now, x_now, false)?;
        let out = self.solve(false);
        self.adopt(&out);
        Ok(out)
    }

    /// The [`Plan`] of the current solution (knot times from 0 at its start). Allocates.
    pub fn current_plan(&mut self) -> Result<Plan> {
        let z = self.solver.primal().clone();
        let (status, stats, warm) = self.last.clone().ok_or_else(|| {
            Error::invalid(
                "planner",
                "current_plan",
                "no solve yet",
                "call plan() or replan() first",
            )
        })?;
        let t_rem = self.ocp.swing_time();
        let layout = Layout {
            h: self.ocp.interval(),
            ..self.layout
        };
        finish_plan(
            &self.robot,
            &self.task,
            &self.settings,
            &layout,
            t_rem,
            if self.t0 == 0.0 { self.freefall } else { None },
            &z,
            &mut self.ocp,
            SolveSummary {
                status: status.clone(),
                objective: stats.objective,
                backend: Backend::Ocp,
                solves: vec![ocp_attempt(
                    &stats,
                    status,
                    if warm { &self.warm } else { &self.cold },
                )],
            },
        )
    }

    /// A copy of the solution re-plans shift from (allocates; restore it with
    /// [`SwingPlanner::restore`]).
    pub fn checkpoint(&self) -> Checkpoint {
        self.prev.clone()
    }

    /// Make `cp` the solution re-plans shift from again, and re-solve its own problem warm from it
    /// (so that the solver's stored multipliers are that solution's). No allocation.
    pub fn restore(&mut self, cp: &Checkpoint) -> Result<ReplanOutcome> {
        for (d, s) in self.prev.z.x.iter_mut().zip(&cp.z.x) {
            d.copy_from_slice(s);
        }
        for (d, s) in self.prev.z.u.iter_mut().zip(&cp.z.u) {
            d.copy_from_slice(s);
        }
        self.prev.t0 = cp.t0;
        self.prev.h = cp.h;
        self.has_prev = true;
        let k = self.layout.intervals;
        self.ocp.set_start(&cp.z.x[0])?;
        self.ocp.set_swing_time(cp.h * k as f64)?;
        self.t0 = cp.t0;
        let z = self.solver.primal_mut();
        for (d, s) in z.x.iter_mut().zip(&cp.z.x) {
            d.copy_from_slice(s);
        }
        for (d, s) in z.u.iter_mut().zip(&cp.z.u) {
            d.copy_from_slice(s);
        }
        let out = self.solve(true);
        self.adopt(&out);
        Ok(out)
    }

    /// The solution re-plans shift from, shifted onto the knots of a re-plan from `x_now` at `t_now`
    /// (what [`SwingPlanner::replan`] starts from), into `out` (shaped like [`SwingPlanner::knots`]).
    /// Errors as [`SwingPlanner::replan`].
    pub fn shifted_into(&self, t_now: f64, x_now: &[f64], out: &mut Primal) -> Result<()> {
        self.check_replan(t_now, x_now)?;
        let h_new = (self.t_final - t_now) / self.layout.intervals as f64;
        shift(&self.prev, t_now, h_new, x_now, out);
        Ok(())
    }

    fn check_replan(&self, t_now: f64, x_now: &[f64]) -> Result<()> {
        if !self.has_prev {
            return Err(Error::invalid(
                "planner",
                "replan",
                "no previous plan",
                "call plan() first",
            ));
        }
        if !(t_now.is_finite() && t_now >= 0.0 && t_now < self.t_final) {
            return Err(Error::invalid(
                "planner",
                "t_now",
                t_now,
                format!("must lie in [0, T = {})", self.t_final),
            ));
        }
        let nx = 2 * self.robot.n;
        if x_now.len() != nx {
            return Err(Error::Dimension {
                what: "planner: x_now".into(),
                expected: nx,
                got: x_now.len(),
            });
        }
        if let Some(v) = x_now.iter().find(|v| !v.is_finite()) {
            return Err(Error::invalid("planner", "x_now", *v, "must be finite"));
        }
        Ok(())
    }

    fn prepare(&mut self, t_now: f64, x_now: &[f64], warm: bool) -> Result<()> {
        self.check_replan(t_now, x_now)?;
        let k_last = self.layout.intervals;
        self.ocp.set_start(x_now)?;
        // the measured state may lie a little outside the planned bounds (the tracked chain follows
        // the plan within its tracking error): knot 1 must be reachable from it
        let widened = self.settings.bounds.widened_for_start(x_now);
        self.ocp.set_knot_bounds(&widened);
        let t_rem = self.t_final - t_now;
        self.ocp.set_swing_time(t_rem)?;
        let h_new = t_rem / k_last as f64;
        let dst = if warm {
            self.solver.primal_mut()
        } else {
            self.ocp.guess_mut()
        };
        shift(&self.prev, t_now, h_new, x_now, dst);
        self.t0 = t_now;
        Ok(())
    }

    fn solve(&mut self, warm: bool) -> ReplanOutcome {
        let st = if warm { &self.warm } else { &self.cold };
        let stats = self.solver.solve(&mut self.ocp, st);
        let status = status_of(&stats.status);
        let n = self.robot.n;
        let k_last = self.layout.intervals;
        let ee = self.robot.ee_position(&self.solver.primal().x[k_last][..n]);
        let tg = self.ocp.target();
        self.last = Some((status.clone(), stats.clone(), warm));
        ReplanOutcome {
            status,
            iterations: stats.iterations,
            solve_time_s: stats.time.total_s,
            objective: stats.objective,
            t_start: self.t0,
            interval_s: self.ocp.interval(),
            ee_final: ee,
            ee_error_m: (ee[0] - tg[0]).hypot(ee[1] - tg[1]),
        }
    }

    /// A converged solution becomes the one the next re-plan shifts from.
    fn adopt(&mut self, out: &ReplanOutcome) {
        if out.converged() {
            let z = self.solver.primal();
            for (d, s) in self.prev.z.x.iter_mut().zip(&z.x) {
                d.copy_from_slice(s);
            }
            for (d, s) in self.prev.z.u.iter_mut().zip(&z.u) {
                d.copy_from_slice(s);
            }
            self.prev.t0 = out.t_start;
            self.prev.h = out.interval_s;
            self.has_prev = true;
        }
    }
}

/// `prev` (knots at `prev.t0 + j prev.h`) on the knots `t_now + k h` into `dst`: states linearly
/// interpolated, torques held, `x_0 = x_now`.
fn shift(prev: &Checkpoint, t_now: f64, h: f64, x_now: &[f64], dst: &mut Primal) {
    let k_last = dst.x.len() - 1;
    let j_last = prev.z.x.len() - 1;
    for k in 0..=k_last {
        let s = ((t_now + k as f64 * h - prev.t0) / prev.h).clamp(0.0, j_last as f64);
        let j = (s.floor() as usize).min(j_last - 1);
        let a = (s - j as f64).clamp(0.0, 1.0);
        let (xa, xb) = (&prev.z.x[j], &prev.z.x[j + 1]);
        for (d, (va, vb)) in dst.x[k].iter_mut().zip(xa.iter().zip(xb)) {
            *d = (1.0 - a) * va + a * vb;
        }
        if k < k_last {
            // the interval holding t (a knot exactly on an old knot takes that knot's torque)
            let ju = if a >= 1.0 - 1e-9 {
                (j + 1).min(j_last - 1)
            } else {
                j
            };
            dst.u[k].copy_from_slice(&prev.z.u[ju]);
        }
    }
    dst.x[0].copy_from_slice(x_now);
}
