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
//! new knot time), `x_0` replaced by `x_now`. By default ([`WarmPrimal::FeedbackRollout`]) the shifted
//! torques are then rolled out from `x_now` through the stage flows under the previous solve's Riccati
//! feedback gains, clipped into the torque bounds, so that the start follows the new `x_0` with no
//! defects; if the rollout leaves the state bounds, the shifted start is kept. The solve then starts
//! warm: the solver's stored bound duals, moved with the shifted solution (each new knot takes those
//! of the previous solution's knot nearest in time), the equality multipliers re-estimated by least
//! squares, a small barrier parameter.
//!
//! Times: a [`Plan`] or [`ReplanOutcome`] of a re-plan runs on its own clock, 0 at `t_now`; absolute
//! knot times come from [`SwingPlanner::knot_time`]. Units: s, m, rad, rad/s, N m.

use super::outcome::Plan;
use super::solve::WARM_START_MU_INIT;
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::planning::nlp::{Backend, NlpSettings, SolveStatus};
use crate::planning::settings::Bounds;
use crate::planning::settings::{PlannerSettings, ValidSettings};
use crate::planning::solve::common::check_guess;
use crate::planning::solve::shooting::{
    finish_plan, ocp_attempt, ocp_settings, setup_shooting, status_of, ShootingSetup, SolveSummary,
};
use crate::planning::task::{SwingTask, ValidTask};
use crate::planning::transcription::collocation::Layout;
use crate::planning::transcription::shooting::SwingOcp;
use crate::trajectory::Trajectory;
use brachia_ocp::{
    OcpProblem, OcpSettings, OcpSolver, OcpStats, Primal, StageBounds, WarmDuals, WarmState,
};
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

/// The id of the next [`SwingPlanner`] built in this process.
static NEXT_PLANNER_ID: AtomicU64 = AtomicU64::new(0);

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
    /// The Riccati feedback gains `K_k` (`nu x nx`, row-major) of the solve that produced `z`
    /// ([`OcpSolver::feedback_gain`]), zero before the first factorisation.
    gains: Vec<Vec<f64>>,
    /// The planner it was taken from ([`SwingPlanner`]'s `id`): a restore takes only its own.
    planner: u64,
    /// The knot bounds of the problem `z` solves (a re-plan's are widened for its start).
    bounds: Bounds,
    /// The solver's state at `z` (slacks, multipliers) and how that solve ended, when the
    /// checkpoint was taken right after it converged; `None` in the planner's own copy.
    solved: Option<Box<Solved>>,
}

/// The solver's state after the converged solve of a [`Checkpoint`], and its outcome.
#[derive(Debug, Clone, PartialEq)]
struct Solved {
    state: WarmState,
    last: Last,
    /// The target and the end box that solve had: the state fits only the same problem.
    target: [f64; 2],
    end_box: Option<Vec<[f64; 2]>>,
}

/// The last solve: its outcome, the solver's statistics and whether it started warm (for the
/// [`Plan`]).
#[derive(Debug, Clone, PartialEq)]
struct Last {
    outcome: ReplanOutcome,
    stats: OcpStats,
    warm: bool,
}

/// The primal point a warm re-plan starts from (docs/planner.md, "Re-planning").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WarmPrimal {
    /// The previous solution shifted onto the new knots (states interpolated, torques held), `x_0`
    /// replaced by the measured state: the defect of the disturbance sits at stage 0.
    Shifted,
    /// The shifted torques rolled out from the measured state through the stage flows under the
    /// previous solve's Riccati feedback, `u_k = clamp(u~_k + K_k (x_k - x~_k))`, each state
    /// projected into its bounds: the start follows the new `x_0` (no defects but where a state was
    /// projected).
    #[default]
    FeedbackRollout,
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
    /// Unique in the process (checkpoints name their planner).
    id: u64,
    robot: Arc<Robot>,
    task: SwingTask,
    settings: PlannerSettings,
    cold: OcpSettings,
    warm: OcpSettings,
    warm_primal: WarmPrimal,
    /// Whether warm re-plans move the stored bound duals with the shifted knots.
    shift_duals: bool,
    /// The solver's stored bound duals are those of the solution in `prev` (the last solve
    /// converged).
    duals_of_prev: bool,
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
    /// Scratch of the feedback rollout.
    roll: RolloutScratch,
    /// The last solve; `None` before the first.
    last: Option<Last>,
    /// With a free swing time: the problem with T free and its solver, for the cold plan.
    free: Option<Box<FreePlan>>,
}

/// The cold plan's problem with a free swing time ([`PlannerSettings::free_swing_time`]) and its
/// own solver: [`SwingPlanner::plan`] solves it for T, then the fixed-T problem at that T from its
/// solution, so that re-plans shift from a fixed-T solution and its solver state.
struct FreePlan {
    ocp: SwingOcp,
    solver: OcpSolver,
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
        Self::with_guess(robot, task, settings, nlp, None)
    }

    /// [`SwingPlanner::new`] whose cold plan ([`SwingPlanner::plan`]) starts from `guess` (a
    /// trajectory of the same swing, resampled onto the knots, as [`super::plan_with_guess`] takes
    /// it; e.g. the plan a controller tracks) instead of the setup's own guess (`None`). Errors as
    /// [`SwingPlanner::new`] and on a guess that does not fit the robot.
    pub fn with_guess(
        robot: impl Into<Arc<Robot>>,
        task: SwingTask,
        settings: &PlannerSettings,
        nlp: &NlpSettings,
        guess: Option<&Trajectory>,
    ) -> Result<Self> {
        let robot: Arc<Robot> = robot.into();
        let settings = ValidSettings::new(
            PlannerSettings {
                transcription: crate::planning::settings::Transcription::MultipleShooting,
                ..settings.clone()
            },
            robot.n,
            "planner",
        )?;
        nlp.validate()?;
        if let Some(g) = guess {
            check_guess(&robot, g)?;
        }
        let task = ValidTask::new(&robot, task, &settings, "task", "")?;
        let ShootingSetup {
            ocp,
            layout,
            t_final,
            freefall,
        } = setup_shooting(&robot, &task, &settings, guess)?;
        let solver_for = |ocp: &SwingOcp| {
            OcpSolver::new(ocp.dims()).map_err(|e| {
                Error::invalid("ocp solver", "problem dimensions", e.to_string(), "refused")
            })
        };
        let solver = solver_for(&ocp)?;
        let free = match settings.free_range() {
            Some([lo, hi]) => {
                let ocp = setup_shooting(&robot, &task, &settings, guess)?
                    .ocp
                    .with_free_swing_time(lo, hi)?;
                let solver = solver_for(&ocp)?;
                Some(Box::new(FreePlan { ocp, solver }))
            }
            None => None,
        };
        let cold = ocp_settings(nlp);
        // the stored bound duals (the equality multipliers re-estimated at the moved start), a
        // small barrier parameter and bound push, the adaptive barrier update: the fewest
        // iterations of the variants measured in benches/replan.rs and crates/tools/src/bin/replan_profile.rs
        // (docs/planner.md, "Re-planning"; docs/ocp.md section 13)
        let warm = OcpSettings {
            warm_start: true,
            mu_init: nlp.mu_init.unwrap_or(WARM_START_MU_INIT),
            mu_strategy: brachia_ocp::MuStrategy::Adaptive,
            warm_duals: WarmDuals::StoredBounds,
            warm_bound_push: 1e-9,
            ..cold.clone()
        };
        let mut guess = Primal::zeros(ocp.dims());
        ocp.initial_guess(&mut guess);
        let x_full = ocp.start().to_vec();
        let dims = ocp.dims();
        let gains = dims.stages.iter().map(|d| vec![0.0; d.nu * d.nx]).collect();
        let nx = dims.stages[0].nx;
        let roll_bounds = StageBounds::unbounded(dims.stages[0]);
        let bounds0 = settings.bounds.clone();
        let id = NEXT_PLANNER_ID.fetch_add(1, Ordering::Relaxed);
        Ok(SwingPlanner {
            id,
            robot,
            task: task.into_inner(),
            settings: settings.into_inner(),
            cold,
            warm,
            prev: Checkpoint {
                z: guess.clone(),
                t0: 0.0,
                h: layout.h,
                gains,
                planner: id,
                bounds: bounds0,
                solved: None,
            },
            warm_primal: WarmPrimal::default(),
            shift_duals: true,
            duals_of_prev: false,
            roll: RolloutScratch {
                x_ref: vec![0.0; nx],
                x_next: vec![0.0; nx],
                bounds: roll_bounds,
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
            free,
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

    /// Settings of the warm solves (warm start on, the stored bound duals with least-squares
    /// equality multipliers ([`WarmDuals::StoredBounds`]), `mu_init` from the NLP
    /// settings or [`WARM_START_MU_INIT`], `warm_bound_push` 1e-9, the adaptive barrier update);
    /// edit to tune.
    pub fn warm_settings_mut(&mut self) -> &mut OcpSettings {
        &mut self.warm
    }

    /// Settings of the cold solves ([`SwingPlanner::plan`], [`SwingPlanner::replan_cold`]): those of
    /// the NLP settings, as [`crate::planning::plan`] uses them; edit to tune.
    pub fn cold_settings_mut(&mut self) -> &mut OcpSettings {
        &mut self.cold
    }

    /// Which primal point warm re-plans start from (default [`WarmPrimal::FeedbackRollout`]).
    pub fn set_warm_primal(&mut self, w: WarmPrimal) {
        self.warm_primal = w;
    }

    /// Whether warm re-plans move the solver's stored bound duals onto the new knots with the
    /// shifted solution, each knot taking the duals of the previous solution's knot nearest in time
    /// ([`OcpSolver::remap_bound_duals`]; default true). False keeps them stage by stage (the
    /// alternative measured in docs/ocp.md, section 13).
    pub fn set_warm_shift_duals(&mut self, on: bool) {
        self.shift_duals = on;
    }

    /// The solver's statistics of the last (re-)plan (iterations, factorisations, regularisations
    /// and the time split); `None` before the first.
    pub fn last_stats(&self) -> Option<&OcpStats> {
        self.last.as_ref().map(|l| &l.stats)
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

    /// A box on the state at the last knot of every (re-)plan (2n entries `[lo, hi]`: q then qd;
    /// rad, rad/s), intersected with that knot's bounds (the rest condition `bounds.qd_end_max`
    /// included); `None` removes it. What a re-plan inside a swing of a joint multi-swing plan aims
    /// at: near that plan's switch state (docs/ladders.md, "Lookahead"). Errors on a wrong length or
    /// a range that is not `lo <= hi`.
    pub fn set_end_box(&mut self, b: Option<&[[f64; 2]]>) -> Result<()> {
        self.ocp.set_end_box(b)
    }

    /// The box set by [`SwingPlanner::set_end_box`], if any.
    pub fn end_box(&self) -> Option<&[[f64; 2]]> {
        self.ocp.end_box()
    }

    /// Cold plan of the whole swing from the task's start state (the setup's initial guess); the
    /// solution becomes the one re-plans shift from. Allocates the [`Plan`].
    pub fn plan(&mut self) -> Result<Plan> {
        self.plan_outcome()?;
        self.current_plan()
    }

    /// [`SwingPlanner::plan`] without building the [`Plan`]. With a free swing time
    /// ([`PlannerSettings::free_swing_time`]) the plan first solves for T, then re-solves the
    /// fixed-T problem at that T from that solution (the outcome counts the iterations and time of
    /// both); [`SwingPlanner::swing_time`] is then the optimum and re-plans keep it. If the free
    /// solve does not converge, its outcome is returned and the planner keeps its swing time.
    pub fn plan_outcome(&mut self) -> Result<ReplanOutcome> {
        self.ocp.set_start(&self.x_full)?;
        self.ocp.set_knot_bounds(&self.settings.bounds);
        self.t0 = 0.0;
        if self.free.is_some() {
            return self.plan_free_swing_time();
        }
        self.ocp.set_swing_time(self.t_final)?;
        self.ocp.guess_mut().copy_from(&self.guess);
        let out = self.solve(false);
        self.adopt(&out);
        Ok(out)
    }

    /// [`SwingPlanner::plan_outcome`] with a free swing time: the free problem cold, then the
    /// fixed-T problem at its T started exactly at its solution (the primal without T, the
    /// solver state by [`OcpSolver::warm_state_without_state`], stored duals): so the plan is the
    /// free plan's, and re-plans shift from a fixed-T solution with its multipliers.
    fn plan_free_swing_time(&mut self) -> Result<ReplanOutcome> {
        let f = self.free.as_mut().expect("a free swing time");
        f.ocp.set_start(&self.x_full)?;
        f.ocp.set_knot_bounds(&self.settings.bounds);
        let first = f.solver.solve(&mut f.ocp, &self.cold);
        let z = f.solver.primal();
        let t_star = f.ocp.swing_time_of(z);
        // the free solve's point in the fixed-T layout, at its own T (a failed solve's too, so
        // that current_plan shows where it stopped)
        f.ocp.strip_swing_time_into(z, self.solver.primal_mut());
        if let (true, Some([lo, hi])) = (t_star.is_finite(), f.ocp.free_swing_time()) {
            self.ocp.set_swing_time(t_star.clamp(lo, hi))?;
        }
        if !first.status.is_converged() {
            let out = self.outcome(&first, self.solver.primal(), self.ocp.interval());
            self.last = Some(Last {
                outcome: out.clone(),
                stats: first,
                warm: false,
            });
            self.adopt(&out);
            return Ok(out);
        }
        let nx = 2 * self.robot.n;
        let ws = f.solver.warm_state_without_state(nx).map_err(|e| {
            Error::invalid("ocp solver", "free_swing_time", e.to_string(), "refused")
        })?;
        self.solver.set_warm_state(&ws).map_err(|e| {
            Error::invalid("ocp solver", "free_swing_time", e.to_string(), "refused")
        })?;
        self.t_final = self.ocp.swing_time();
        let fix = OcpSettings {
            warm_duals: WarmDuals::Stored,
            ..self.warm.clone()
        };
        let stats = self.solver.solve(&mut self.ocp, &fix);
        let mut out = self.record(stats, true);
        out.iterations += first.iterations;
        out.solve_time_s += first.time.total_s;
        self.adopt(&out);
        if out.converged()
            && self
                .last
                .as_ref()
                .is_some_and(|l| l.stats.factorizations == 0)
        {
            // no factorisation of the fixed problem yet: the free plan's gains without the T column
            let f = self.free.as_ref().expect("a free swing time");
            for (k, d) in self.prev.gains.iter_mut().enumerate() {
                let g = f.solver.feedback_gain(k);
                let nu = self.prev.z.u[k].len();
                for r in 0..nu {
                    d[r * nx..(r + 1) * nx].copy_from_slice(&g[r * (nx + 1)..r * (nx + 1) + nx]);
                }
            }
        }
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
        let Last {
            outcome: ReplanOutcome { status, .. },
            stats,
            warm,
        } = self.last.clone().ok_or_else(|| {
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
    /// [`SwingPlanner::restore`]). Taken right after the solve that produced that solution
    /// converged, it also holds the solver's state there (slacks and multipliers) and that solve's
    /// target and end box, so that a restore to the same target and end box puts the planner back
    /// exactly as it was.
    pub fn checkpoint(&self) -> Checkpoint {
        let mut cp = self.prev.clone();
        if self.duals_of_prev {
            if let Some(last) = &self.last {
                cp.solved = Some(Box::new(Solved {
                    state: self.solver.warm_state(),
                    last: last.clone(),
                    target: self.ocp.target(),
                    end_box: self.ocp.end_box().map(<[_]>::to_vec),
                }));
            }
        }
        cp
    }

    /// Make `cp` the solution re-plans shift from again, with its problem (start state, swing time,
    /// knot bounds; the target and the end box stay as they are now). If `cp` was taken right after
    /// its solve converged ([`SwingPlanner::checkpoint`]) and the target and end box are that
    /// solve's, the solver's state is put back as it was then and nothing is solved, so that what
    /// follows (a warm re-plan, the [`Plan`] of [`SwingPlanner::current_plan`]) is the same, bit for
    /// bit, whatever the planner solved in between; it returns that solve's outcome. Otherwise
    /// `cp`'s solution is re-solved warm on the current target and end box (so that the solver's
    /// stored multipliers are that solution's), and the outcome is that solve's. No allocation.
    /// Errors, before changing anything, if `cp` comes from another planner (of another robot,
    /// task or mesh, or the same ones built again).
    pub fn restore(&mut self, cp: &Checkpoint) -> Result<ReplanOutcome> {
        if cp.planner != self.id {
            return Err(Error::invalid(
                "planner",
                "checkpoint",
                format!("a checkpoint of planner #{}", cp.planner),
                format!("must come from this planner (#{})", self.id),
            ));
        }
        let k = self.layout.intervals;
        // the checkpoint's own start and swing time (valid: this planner solved them)
        self.ocp.set_start(&cp.z.x[0])?;
        self.ocp.set_swing_time(cp.h * k as f64)?;
        self.ocp.set_knot_bounds(&cp.bounds);
        self.prev.z.copy_from(&cp.z);
        for (d, s) in self.prev.gains.iter_mut().zip(&cp.gains) {
            d.copy_from_slice(s);
        }
        self.prev.t0 = cp.t0;
        self.prev.h = cp.h;
        self.prev.bounds.clone_from(&cp.bounds);
        self.has_prev = true;
        self.t0 = cp.t0;
        self.solver.primal_mut().copy_from(&cp.z);
        let exact = cp.solved.as_deref().filter(|sv| {
            sv.target == self.ocp.target() && sv.end_box.as_deref() == self.ocp.end_box()
        });
        // a state read from this planner's own solver always fits it
        if let Some(sv) = exact.filter(|sv| self.solver.set_warm_state(&sv.state).is_ok()) {
            self.duals_of_prev = true;
            self.last = Some(sv.last.clone());
            return Ok(sv.last.outcome.clone());
        }
        let out = self.solve(true);
        self.adopt(&out);
        Ok(out)
    }

    /// The solution re-plans shift from, shifted onto the knots of a re-plan from `x_now` at `t_now`
    /// (what [`SwingPlanner::replan`] starts from with [`WarmPrimal::Shifted`], or when the feedback
    /// rollout leaves the bounds), into `out` (shaped like [`SwingPlanner::knots`]). Errors as
    /// [`SwingPlanner::replan`].
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
        if warm {
            let dst = self.solver.primal_mut();
            warm_start(
                &self.prev,
                self.warm_primal,
                &mut self.ocp,
                &mut self.roll,
                (t_now, h_new, x_now),
                dst,
            );
            if self.shift_duals && self.duals_of_prev {
                let prev = &self.prev;
                self.solver
                    .remap_bound_duals(|k| nearest_old_knot(prev, t_now, h_new, k));
            }
        } else {
            shift(&self.prev, t_now, h_new, x_now, self.ocp.guess_mut());
        }
        self.t0 = t_now;
        Ok(())
    }

    fn solve(&mut self, warm: bool) -> ReplanOutcome {
        let st = if warm { &self.warm } else { &self.cold };
        let stats = self.solver.solve(&mut self.ocp, st);
        self.record(stats, warm)
    }

    /// The outcome of the solve that ended with `stats` on the planner's own solver, recorded as
    /// the last solve.
    fn record(&mut self, stats: OcpStats, warm: bool) -> ReplanOutcome {
        let out = self.outcome(&stats, self.solver.primal(), self.ocp.interval());
        self.last = Some(Last {
            outcome: out.clone(),
            stats,
            warm,
        });
        out
    }

    /// The outcome of a solve that ended with `stats` at `z` on knots `interval_s` apart.
    fn outcome(&self, stats: &OcpStats, z: &Primal, interval_s: f64) -> ReplanOutcome {
        outcome_of(
            &self.robot,
            self.ocp.target(),
            self.t0,
            stats,
            z,
            interval_s,
        )
    }

    /// A converged solution becomes the one the next re-plan shifts from.
    fn adopt(&mut self, out: &ReplanOutcome) {
        self.duals_of_prev = out.converged();
        if out.converged() {
            self.prev.z.copy_from(self.solver.primal());
            self.prev.t0 = out.t_start;
            self.prev.h = out.interval_s;
            self.prev.bounds.clone_from(self.ocp.knot_bounds());
            self.has_prev = true;
            if self
                .last
                .as_ref()
                .is_some_and(|l| l.stats.factorizations > 0)
            {
                for (k, d) in self.prev.gains.iter_mut().enumerate() {
                    d.copy_from_slice(self.solver.feedback_gain(k));
                }
            }
        }
    }
}

/// The outcome of a solve that ended with `stats` at `z` (knot 0 at `t0`, knots `interval_s` apart)
/// for the bar at `target`.
fn outcome_of(
    robot: &Robot,
    target: [f64; 2],
    t0: f64,
    stats: &OcpStats,
    z: &Primal,
    interval_s: f64,
) -> ReplanOutcome {
    let n = robot.n;
    let ee = robot.ee_position(&z.x[z.x.len() - 1][..n]);
    ReplanOutcome {
        status: status_of(&stats.status),
        iterations: stats.iterations,
        solve_time_s: stats.time.total_s,
        objective: stats.objective,
        t_start: t0,
        interval_s,
        ee_final: ee,
        ee_error_m: (ee[0] - target[0]).hypot(ee[1] - target[1]),
    }
}

/// The start of a warm re-plan from `x_now` at `t_now` on the interval `h` ([`WarmPrimal`]) into
/// `dst`; `ocp` has the new start state and swing time.
fn warm_start(
    prev: &Checkpoint,
    mode: WarmPrimal,
    ocp: &mut SwingOcp,
    roll: &mut RolloutScratch,
    (t_now, h, x_now): (f64, f64, &[f64]),
    dst: &mut Primal,
) {
    shift(prev, t_now, h, x_now, dst);
    if mode == WarmPrimal::FeedbackRollout {
        let r = Rollout { prev, t_now, h };
        if !r.run(ocp, roll, dst) {
            shift(prev, t_now, h, x_now, dst);
        }
    }
}

/// Buffers of [`Rollout::run`], allocated with the planner.
struct RolloutScratch {
    /// The shifted previous solution at the current knot (2n).
    x_ref: Vec<f64>,
    /// The flow to the next knot (2n).
    x_next: Vec<f64>,
    /// Bounds of the current stage.
    bounds: StageBounds,
}

/// The feedback rollout of [`WarmPrimal::FeedbackRollout`] from the previous solution `prev` onto
/// the knots `t_now + k h` (docs/planner.md, "Re-planning").
struct Rollout<'a> {
    prev: &'a Checkpoint,
    t_now: f64,
    h: f64,
}

impl Rollout<'_> {
    /// Into `dst`, which holds the shifted start ([`shift`], `x_0 = x_now`): for k = 0..K-1,
    /// `u_k = clamp(u~_k + K_j (x_k - x~_k))` into the torque bounds, with `x~_k`, `u~_k` the shifted
    /// previous solution at the knot and `K_j` the feedback gain of the old interval holding it
    /// (stage 1's for stage 0, whose fixed `x_0` zeroes its gain), then `x_{k+1} = Phi_k(x_k,
    /// u_k)`. False (and `dst` partly overwritten) as soon as a state leaves its bounds or is not
    /// finite: the rollout then crosses the bounds the solution is pressed against, and a start
    /// projected back into them converges more slowly than the shifted one (docs/ocp.md, section
    /// 13). No allocation.
    fn run(&self, ocp: &mut SwingOcp, w: &mut RolloutScratch, dst: &mut Primal) -> bool {
        let k_last = dst.x.len() - 1;
        let nx = w.x_ref.len();
        w.x_next.copy_from_slice(&dst.x[0]);
        for k in 0..=k_last {
            let b = &mut w.bounds;
            reset_bounds(b);
            ocp.bounds(k, b);
            let x = &mut dst.x[k];
            for (i, v) in x.iter_mut().enumerate() {
                let y = w.x_next[i];
                // also false on NaN
                if !(y >= b.x_lo[i] && y <= b.x_hi[i]) {
                    return false;
                }
                *v = y;
            }
            if k == k_last {
                break;
            }
            let (j, a, ju) = old_interval(self.prev, self.t_now, self.h, k);
            let (xa, xb) = (&self.prev.z.x[j], &self.prev.z.x[j + 1]);
            for (d, (va, vb)) in w.x_ref.iter_mut().zip(xa.iter().zip(xb)) {
                *d = (1.0 - a) * va + a * vb;
            }
            let g = &self.prev.gains[ju.max(1)];
            for (r, u) in dst.u[k].iter_mut().enumerate() {
                let row = &g[r * nx..(r + 1) * nx];
                let du: f64 = (0..nx).map(|i| row[i] * (x[i] - w.x_ref[i])).sum();
                *u = (*u + du).clamp(b.u_lo[r], b.u_hi[r]);
            }
            ocp.flow(k, &dst.x[k], &dst.u[k], &mut w.x_next);
        }
        true
    }
}

/// All bounds of `b` back to +-inf.
fn reset_bounds(b: &mut StageBounds) {
    for v in [&mut b.x_lo, &mut b.u_lo, &mut b.c_lo] {
        v.fill(f64::NEG_INFINITY);
    }
    for v in [&mut b.x_hi, &mut b.u_hi, &mut b.c_hi] {
        v.fill(f64::INFINITY);
    }
}

/// Where knot k of a re-plan from `t_now` with interval `h` falls on the knots of `prev`: the old
/// interval j and the fraction a in it (the state is `(1 - a) x_j + a x_{j+1}`), and the old
/// interval whose torque holds at the knot's time (a knot exactly on an old knot takes that knot's).
fn old_interval(prev: &Checkpoint, t_now: f64, h: f64, k: usize) -> (usize, f64, usize) {
    let j_last = prev.z.x.len() - 1;
    let s = ((t_now + k as f64 * h - prev.t0) / prev.h).clamp(0.0, j_last as f64);
    let j = (s.floor() as usize).min(j_last - 1);
    let a = (s - j as f64).clamp(0.0, 1.0);
    let ju = if a >= 1.0 - 1e-9 {
        (j + 1).min(j_last - 1)
    } else {
        j
    };
    (j, a, ju)
}

/// The knot of `prev` nearest in time to knot k of a re-plan from `t_now` with interval `h`.
fn nearest_old_knot(prev: &Checkpoint, t_now: f64, h: f64, k: usize) -> usize {
    let (j, a, _) = old_interval(prev, t_now, h, k);
    if a < 0.5 {
        j
    } else {
        j + 1
    }
}

/// `prev` (knots at `prev.t0 + j prev.h`) on the knots `t_now + k h` into `dst`: states linearly
/// interpolated, torques held, `x_0 = x_now`.
fn shift(prev: &Checkpoint, t_now: f64, h: f64, x_now: &[f64], dst: &mut Primal) {
    let k_last = dst.x.len() - 1;
    for k in 0..=k_last {
        let (j, a, ju) = old_interval(prev, t_now, h, k);
        let (xa, xb) = (&prev.z.x[j], &prev.z.x[j + 1]);
        for (d, (va, vb)) in dst.x[k].iter_mut().zip(xa.iter().zip(xb)) {
            *d = (1.0 - a) * va + a * vb;
        }
        if k < k_last {
            dst.u[k].copy_from_slice(&prev.z.u[ju]);
        }
    }
    dst.x[0].copy_from_slice(x_now);
}

#[cfg(test)]
mod tests {
    //! The feedback-rollout warm start on the re-planning mesh of the tracking swing (30 ms knots,
    //! one RK4 step, K = 74; the set of `benches/replan.rs`: the planned state at t = 0.6 s disturbed
    //! by uniform +-0.1 rad and +-0.5 rad/s per joint, seeded).
    use super::*;
    use crate::planning::workload::{
        disturbed_starts, replan_settings, REPLAN_SEED, REPLAN_T_NOW as T_NOW,
    };

    /// The planner after its cold plan, and the 100 seeded disturbed states (those inside the
    /// bounds).
    fn planned() -> (SwingPlanner, Vec<Vec<f64>>) {
        let (s, nlp) = replan_settings(0.03);
        let mut planner = SwingPlanner::new(Robot::paper(), SwingTask::paper(), &s, &nlp).unwrap();
        let p = planner.plan().unwrap();
        assert!(p.converged(), "{:?}", p.status);
        let j = p
            .trajectory
            .t
            .iter()
            .position(|t| (t - T_NOW).abs() < 1e-9)
            .unwrap();
        let x_nom = [p.trajectory.q(j), p.trajectory.qd(j)].concat();
        let states = disturbed_starts(&x_nom, &s.bounds, 100, REPLAN_SEED);
        (planner, states)
    }

    /// Largest |Phi_k(x_k, u_k) - x_{k+1}| of `z` on the planner's problem as it stands.
    fn largest_defect(planner: &mut SwingPlanner, z: &Primal) -> f64 {
        let mut next = vec![0.0; z.x[0].len()];
        let mut worst = 0.0_f64;
        for k in 0..z.x.len() - 1 {
            planner.ocp.flow(k, &z.x[k], &z.u[k], &mut next);
            for (a, b) in next.iter().zip(&z.x[k + 1]) {
                worst = worst.max((a - b).abs());
            }
        }
        worst
    }

    /// An end box moves the last knot into it (a re-plan of the tracking swing whose end pose must
    /// lie 0.05 rad past the free plan's on joint 2), the box is intersected with the knot's
    /// bounds, and it is refused with the wrong length or `lo > hi`; `None` restores the plain
    /// bounds.
    #[test]
    fn an_end_box_holds_the_last_knot_and_is_checked() {
        let (s, nlp) = replan_settings(0.03);
        let mut planner = SwingPlanner::new(Robot::paper(), SwingTask::paper(), &s, &nlp).unwrap();
        let p = planner.plan().unwrap();
        let tr = p.trajectory.clone();
        let k_end = planner.intervals();
        let q2_free = planner.knots().x[k_end][1];
        let n = 4;
        let mut b = vec![[f64::NEG_INFINITY, f64::INFINITY]; 2 * n];
        b[1] = [q2_free + 0.05, q2_free + 0.1];
        planner.set_end_box(Some(&b)).unwrap();
        let mut sb = StageBounds::unbounded(planner.ocp.dims().stages[k_end]);
        planner.ocp.bounds(k_end, &mut sb);
        assert_eq!([sb.x_lo[1], sb.x_hi[1]], b[1]);
        // the infinite ends keep the knot's own bounds
        assert_eq!([sb.x_lo[0], sb.x_hi[0]], s.bounds.q1);
        let j = tr.t.iter().position(|t| (t - T_NOW).abs() < 1e-9).unwrap();
        let x = [tr.q(j), tr.qd(j)].concat();
        let out = planner.replan(T_NOW, &x).unwrap();
        assert!(out.converged(), "{:?}", out.status);
        let q2 = planner.knots().x[k_end][1];
        assert!(
            q2 >= b[1][0] - 1e-8 && q2 <= b[1][1] + 1e-8,
            "{q2} {:?}",
            b[1]
        );
        assert!(out.ee_error_m < 1e-3, "{out:?}");
        assert!(planner.set_end_box(Some(&b[..n])).is_err());
        b[1] = [1.0, 0.0];
        assert!(planner.set_end_box(Some(&b)).is_err());
        planner.set_end_box(None).unwrap();
        planner.ocp.bounds(k_end, &mut sb);
        assert_eq!(
            [sb.x_lo[1], sb.x_hi[1]],
            [-s.bounds.q_rel_max, s.bounds.q_rel_max]
        );
    }

    #[test]
    fn the_rollout_start_follows_the_new_start_state_inside_the_bounds_with_no_defects() {
        let (mut planner, states) = planned();
        let mut bounds = StageBounds::unbounded(planner.ocp.dims().stages[0]);
        let mut rolled = 0;
        for x in &states {
            // the start the warm re-plan gets (prepare only, no solve)
            planner.prepare(T_NOW, x, true).unwrap();
            let z = planner.solver.primal().clone();
            let mut shifted = z.clone();
            planner.shifted_into(T_NOW, x, &mut shifted).unwrap();
            assert_eq!(z.x[0], *x);
            if z == shifted {
                continue; // the rollout left the bounds: the shifted start is kept
            }
            rolled += 1;
            let d_roll = largest_defect(&mut planner, &z);
            let d_shift = largest_defect(&mut planner, &shifted);
            assert!(d_roll < 1e-12, "rollout defect {d_roll}");
            assert!(d_shift > 1e-3, "shifted defect {d_shift}");
            for (k, (xk, uk)) in z.x.iter().zip(&z.u).enumerate() {
                reset_bounds(&mut bounds);
                planner.ocp.bounds(k, &mut bounds);
                for (i, v) in xk.iter().enumerate() {
                    assert!(
                        bounds.x_lo[i] <= *v && *v <= bounds.x_hi[i],
                        "x_{k}[{i}] = {v}"
                    );
                }
                for (i, v) in uk.iter().enumerate() {
                    assert!(
                        bounds.u_lo[i] <= *v && *v <= bounds.u_hi[i],
                        "u_{k}[{i}] = {v}"
                    );
                }
            }
        }
        // 86 of the 100 draws stay inside the bounds (measured)
        assert!(rolled >= 70, "{rolled} rollouts of {}", states.len());
    }

    #[test]
    fn a_warm_start_takes_the_bound_duals_of_the_knots_nearest_in_time() {
        let (mut planner, states) = planned();
        let k_last = planner.intervals();
        let stored = |p: &SwingPlanner| -> Vec<(Vec<f64>, Vec<f64>)> {
            (0..=k_last)
                .map(|k| {
                    let (l, u) = p.solver.bound_duals(k);
                    (l.to_vec(), u.to_vec())
                })
                .collect()
        };
        let before = stored(&planner);
        // (the plan rests on no bound: its bound duals are ~ mu / slack, at most ~1e-8, and differ
        // from knot to knot)
        let h_old = planner.ocp.interval();
        planner.prepare(T_NOW, &states[0], true).unwrap();
        let h_new = planner.ocp.interval();
        let after = stored(&planner);
        let nx = planner.ocp.dims().stages[0].nx;
        let mut moved = 0;
        for (k, (l, u)) in after.iter().enumerate() {
            // the plan's knots are at j h_old from 0
            let j = ((T_NOW + k as f64 * h_new) / h_old).round() as usize;
            let (bl, bu) = &before[j.min(k_last)];
            let n = if l.len() == bl.len() { l.len() } else { nx };
            assert_eq!(&l[..n], &bl[..n], "knot {k} from {j}");
            assert_eq!(&u[..n], &bu[..n], "knot {k} from {j}");
            moved += usize::from(*l != before[k].0);
        }
        assert!(moved > k_last / 2, "the duals of {moved} knots moved");
    }

    #[test]
    fn moving_the_bound_duals_with_the_knots_reaches_the_same_optima_with_a_shorter_tail() {
        let (mut planner, states) = planned();
        let cp = planner.checkpoint();
        let mut worst = [0usize; 2];
        for x in &states {
            let mut objective = [0.0; 2];
            for (m, on) in [false, true].into_iter().enumerate() {
                planner.set_warm_shift_duals(on);
                planner.restore(&cp).unwrap();
                let o = planner.replan(T_NOW, x).unwrap();
                assert!(o.converged() && o.ee_error_m < 1e-6, "{on}: {o:?}");
                worst[m] = worst[m].max(o.iterations);
                objective[m] = o.objective;
            }
            let rel = (objective[1] - objective[0]).abs() / objective[0].abs();
            assert!(rel < 1e-6, "objectives {objective:?}");
        }
        // measured 48 against 41 with crates/tools/src/bin/replan_profile.rs (docs/ocp.md, section 13)
        assert!(
            worst[1] < worst[0],
            "slowest draw: kept {} moved {}",
            worst[0],
            worst[1]
        );
    }

    #[test]
    fn rollout_warm_starts_take_fewer_iterations_to_the_same_optima() {
        let (mut planner, states) = planned();
        let cp = planner.checkpoint();
        let mut iterations = [0usize; 2];
        for x in &states {
            let mut objective = [0.0; 2];
            for (m, mode) in [WarmPrimal::Shifted, WarmPrimal::FeedbackRollout]
                .into_iter()
                .enumerate()
            {
                planner.set_warm_primal(mode);
                planner.restore(&cp).unwrap();
                let o = planner.replan(T_NOW, x).unwrap();
                assert!(o.converged() && o.ee_error_m < 1e-6, "{mode:?}: {o:?}");
                iterations[m] += o.iterations;
                objective[m] = o.objective;
            }
            let rel = (objective[1] - objective[0]).abs() / objective[0].abs();
            assert!(rel < 1e-6, "objectives {objective:?}");
        }
        // measured 648 against 546 over the 100 draws with the default warm settings (docs/ocp.md,
        // section 13)
        assert!(
            iterations[1] + 25 <= iterations[0],
            "shifted {} rollout {}",
            iterations[0],
            iterations[1]
        );
    }
}
