//! A joint plan over several swings of a ladder that shares the switch states, and its comparison with
//! planning swing by swing (docs/ladders.md, "The joint multi-swing plan").
//!
//! ## The stage chain
//! Swing i (phase i) is the multiple-shooting problem of that swing ([`SwingOcp`], its own chain:
//! the robot as written for even i, re-rooted for odd i, [`Robot::rerooted`]), K_i intervals of
//! h_i. After the last knot of every phase but the last comes a **boundary stage** with state
//! `[x (2n); s (4)]`:
//! - the transition from the phase's last knot is `[x; r_i(x)]`, `r_i = [ee(x) - bar_{i+1}; ee_vel(x)]`
//!   (the phase's own terminal rows, bar in its grip frame), and `s` is fixed to 0 by its bounds: the
//!   hand on the bar and at rest (paper eq. 9), four equality rows of the solver's Schur complement;
//! - the transition from the boundary to the next phase's knot 0 is the grasp-switch map
//!   ([`crate::model::reroot_state`]): affine with the constant linear part `P`
//!   ([`crate::model::reroot_jacobian`]), `q'_1 = q_1 + ... + q_n + shift_i` with `shift_i` = pi plus
//!   the multiple of 2 pi chosen from the warm start (the representative [`crate::planning::Bounds::nearest_q1`]
//!   picks), so the map has no wrap inside the solve. The EE is at rest there, so the switch is
//!   impulse-free and the next grip is the bar itself: the next target in its grip frame is constant.
//!
//! The last phase ends with its terminal rows (EE at the last bar, at rest). The rest condition
//! `qd_end_max` holds at the last knot of the last phase; at the inner switches only when asked
//! ([`JointSwingTask::rest_at_switches`]). The objective is the sum of the phases' costs (each
//! its own `Q1 qd^2 + R1 tau^2` quadrature at its own h); the boundary stages cost nothing.
//!
//! Every phase is evaluated by its own [`SwingOcp`] on its slice of the stage chain (no second
//! transcription); the problem adds only the boundary transitions.
//!
//! ## The comparison
//! [`plan_joint_swings`] first plans the swings one by one as a traverse does (swing i + 1 from the
//! map of swing i's **planned** end state, q1 as [`crate::planning::Bounds::nearest_q1`], bounds widened for the start
//! as [`crate::planning::Bounds::widened_for_start`], the rest condition at every swing end), then starts the joint
//! solve from those plans put end to end. That point is feasible for the joint problem (its
//! constraints are the sequence's, less the rest condition at inner switches), so a converged joint
//! solve near it lowers the summed objective.
//!
//! Units: s, m, rad, rad/s, N m, J; world frame x right, y up.

use super::outcome::{Plan, SolveAttempt};
use super::planner::plan_validated;
use super::solve::common::{swing_time, WARM_START_MU_INIT};
use crate::error::{Error, Result};
use crate::model::{reroot_jacobian, reroot_state, Circle, Robot};
use crate::planning::nlp::{Backend, NlpSettings, SolveStatus};
use crate::planning::settings::{PlannerSettings, SwingTime, Transcription, ValidSettings};
use crate::planning::solve::shooting::{
    finish_plan, ocp_attempt, ocp_settings, setup_shooting, status_of, ShootingSetup, SolveSummary,
};
use crate::planning::task::{validate_task, SwingTask, ValidTask};
use crate::planning::transcription::shooting::SwingOcp;
use brachia_ocp::{
    EvalError, EvalLevel, Multipliers, OcpDims, OcpProblem, OcpSolver, Primal, StageBounds,
    StageDims, StageEval, TerminalEval, MAX_EQUALITY_ROWS,
};
use std::f64::consts::{PI, TAU};
use std::sync::Arc;

/// Most swings of one joint plan: four equality rows per switch and four terminal rows must fit the
/// solver's [`MAX_EQUALITY_ROWS`].
pub const MAX_JOINT_SWINGS: usize = MAX_EQUALITY_ROWS / 4;

/// One phase of a [`MultiSwingOcp`].
struct Phase {
    ocp: SwingOcp,
    /// Stage index of the phase's knot 0 in the joint chain.
    offset: usize,
    /// K_i.
    horizon: usize,
    /// `q'_1 = q_1 + ... + q_n + shift` at the switch after this phase (unused for the last).
    shift: f64,
    /// The phase's terminal rows (the capture residual) at its last knot, for the boundary transition.
    term: TerminalEval,
}

/// Where a stage of the joint chain belongs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Stage {
    /// Knot `j` of phase `phase`.
    Knot { phase: usize, j: usize },
    /// The boundary stage after phase `phase`.
    Boundary { phase: usize },
}

/// Several swings as one [`OcpProblem`] (see the module docs): one [`SwingOcp`] per phase, joined by
/// boundary stages that fix the capture (EE on the bar, at rest) and apply the grasp-switch map.
pub struct MultiSwingOcp {
    phases: Vec<Phase>,
    dims: OcpDims,
    n: usize,
    guess: Primal,
}

impl MultiSwingOcp {
    /// Join `phases` (phase i's problem: its chain, knots, target in its grip frame, bounds; the
    /// start state of phase 0 stays fixed, the start states of the others are set by the map);
    /// `shifts[i]` the constant of `q'_1` at the switch after phase i (`phases.len() - 1` values,
    /// pi plus a multiple of 2 pi). The initial guess is the phases' guesses with each boundary state
    /// `[x_K; 0]`. Errors on no phase, more than [`MAX_JOINT_SWINGS`], phases of different link
    /// counts, a phase with a free swing time ([`SwingOcp::with_free_swing_time`]: the joint
    /// problem's states are `[q, qd]`), a wrong number of shifts or a non-finite one.
    pub fn new(phases: Vec<SwingOcp>, shifts: &[f64]) -> Result<Self> {
        let count = phases.len();
        if let Some(i) = phases.iter().position(|p| p.free_swing_time().is_some()) {
            return Err(Error::invalid(
                "<joint swings>",
                "phases",
                format!("phase {i} with a free swing time"),
                "a joint multi-swing problem has fixed swing times",
            ));
        }
        if count == 0 || count > MAX_JOINT_SWINGS {
            return Err(Error::invalid(
                "<joint swings>",
                "phases",
                count,
                format!("must be 1 to {MAX_JOINT_SWINGS}"),
            ));
        }
        if shifts.len() + 1 != count {
            return Err(Error::Dimension {
                what: "joint swings: shifts".into(),
                expected: count - 1,
                got: shifts.len(),
            });
        }
        if let Some(v) = shifts.iter().find(|v| !v.is_finite()) {
            return Err(Error::invalid(
                "<joint swings>",
                "shifts",
                *v,
                "must be finite",
            ));
        }
        let n = phases[0].robot().n;
        if let Some(p) = phases.iter().find(|p| p.robot().n != n) {
            return Err(Error::Dimension {
                what: "joint swings: links of a phase".into(),
                expected: n,
                got: p.robot().n,
            });
        }
        let mut stages = Vec::new();
        let mut out = Vec::with_capacity(count);
        for (i, ocp) in phases.into_iter().enumerate() {
            let offset = stages.len();
            let d = ocp.dims();
            let horizon = d.horizon();
            stages.extend_from_slice(&d.stages);
            if i + 1 < count {
                stages.push(StageDims {
                    nx: 2 * n + 4,
                    nu: 0,
                    nc: 0,
                });
            }
            out.push(Phase {
                ocp,
                offset,
                horizon,
                shift: shifts.get(i).copied().unwrap_or(PI),
                term: TerminalEval::zeros(4, 2 * n),
            });
        }
        let dims = OcpDims {
            stages,
            n_terminal: 4,
        };
        let mut guess = Primal::zeros(&dims);
        for (i, p) in out.iter().enumerate() {
            let g = p.ocp.guess();
            for j in 0..=p.horizon {
                guess.x[p.offset + j].copy_from_slice(&g.x[j]);
                guess.u[p.offset + j].copy_from_slice(&g.u[j]);
            }
            if i + 1 < count {
                let b = p.offset + p.horizon + 1;
                guess.x[b][..2 * n].copy_from_slice(&g.x[p.horizon]);
            }
        }
        Ok(MultiSwingOcp {
            phases: out,
            dims,
            n,
            guess,
        })
    }

    /// Number of phases (swings).
    pub fn n_phases(&self) -> usize {
        self.phases.len()
    }

    /// Phase i's problem.
    pub fn phase(&self, i: usize) -> &SwingOcp {
        &self.phases[i].ocp
    }

    /// The stage indices of phase i's knots 0..=K_i in the joint chain.
    pub fn phase_stages(&self, i: usize) -> std::ops::RangeInclusive<usize> {
        let p = &self.phases[i];
        p.offset..=p.offset + p.horizon
    }

    /// The initial guess handed to the solver.
    pub fn guess_mut(&mut self) -> &mut Primal {
        &mut self.guess
    }

    /// The phases' problems, in order.
    pub fn into_phases(self) -> Vec<SwingOcp> {
        self.phases.into_iter().map(|p| p.ocp).collect()
    }

    fn locate(&self, k: usize) -> Stage {
        for (i, p) in self.phases.iter().enumerate() {
            if k <= p.offset + p.horizon {
                return Stage::Knot {
                    phase: i,
                    j: k - p.offset,
                };
            }
            if k == p.offset + p.horizon + 1 {
                return Stage::Boundary { phase: i };
            }
        }
        Stage::Knot {
            phase: self.phases.len() - 1,
            j: k,
        }
    }

    /// The grasp-switch map of the boundary after phase `i`: `x' = P x + shift e_1` into `out` (2n).
    fn switch_map(&self, i: usize, x: &[f64], out: &mut [f64]) {
        let n = self.n;
        reroot_state(&x[..2 * n], out);
        out[0] = x[..n].iter().sum::<f64>() + self.phases[i].shift;
    }
}

fn shift_stage(k0: usize) -> impl Fn(EvalError) -> EvalError {
    move |e| EvalError {
        stage: e.stage + k0,
        reason: e.reason,
    }
}

impl OcpProblem for MultiSwingOcp {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }

    fn bounds(&self, k: usize, b: &mut StageBounds) {
        match self.locate(k) {
            Stage::Knot { phase, j } => {
                self.phases[phase].ocp.bounds(j, b);
                if j == 0 && phase > 0 {
                    // set by the map, not fixed to a start state
                    b.x_lo.fill(f64::NEG_INFINITY);
                    b.x_hi.fill(f64::INFINITY);
                }
            }
            Stage::Boundary { .. } => {
                let nx = 2 * self.n;
                b.x_lo[nx..].fill(0.0);
                b.x_hi[nx..].fill(0.0);
            }
        }
    }

    fn initial_guess(&self, z: &mut Primal) {
        z.copy_from(&self.guess);
    }

    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> std::result::Result<(), EvalError> {
        let nstages = self.dims.stages.len();
        if stages.len() != nstages || z.x.len() != nstages || z.u.len() != nstages {
            return Err(EvalError {
                stage: 0,
                reason: "primal point or buffers not shaped like the problem's dims".into(),
            });
        }
        let nx = 2 * self.n;
        let first = level == EvalLevel::FirstOrder;
        let count = self.phases.len();
        for i in 0..count {
            let last = i + 1 == count;
            let ph = &mut self.phases[i];
            let (a, b) = (ph.offset, ph.offset + ph.horizon);
            let term = if last { &mut *terminal } else { &mut ph.term };
            ph.ocp
                .evaluate_parts(&z.x[a..=b], &z.u[a..=b], level, &mut stages[a..=b], term)
                .map_err(shift_stage(a))?;
            if last {
                break;
            }
            // the capture: [x; r_i(x)] into the boundary stage
            let ev = &mut stages[b];
            ev.f[..nx].copy_from_slice(&z.x[b]);
            ev.f[nx..].copy_from_slice(&ph.term.r);
            if first {
                ev.jac_f.fill(0.0);
                for e in 0..nx {
                    ev.jac_f[e * nx + e] = 1.0;
                }
                ev.jac_f[nx * nx..].copy_from_slice(&ph.term.jac_r[..4 * nx]);
            }
            // the grasp-switch map into the next phase's knot 0
            let bs = b + 1;
            let ev = &mut stages[bs];
            ev.cost = 0.0;
            self.switch_map(i, &z.x[bs], &mut ev.f);
            if first {
                ev.grad.fill(0.0);
                reroot_jacobian(self.n, nx + 4, &mut ev.jac_f);
            }
        }
        Ok(())
    }

    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        mult: &Multipliers,
        stages: &mut [StageEval],
    ) -> std::result::Result<(), EvalError> {
        let nstages = self.dims.stages.len();
        if stages.len() != nstages || mult.lam.len() != nstages || mult.mu.len() != nstages {
            return Err(EvalError {
                stage: 0,
                reason: "multipliers or buffers not shaped like the problem's dims".into(),
            });
        }
        let nx = 2 * self.n;
        let count = self.phases.len();
        for (i, ph) in self.phases.iter_mut().enumerate() {
            let last = i + 1 == count;
            let (a, b) = (ph.offset, ph.offset + ph.horizon);
            // the capture rows' multipliers: the terminal ones, or the boundary transition's last four
            let nu = if last {
                &mult.nu[..]
            } else {
                match mult.lam[b].get(nx..nx + 4) {
                    Some(v) => v,
                    None => {
                        return Err(EvalError {
                            stage: b,
                            reason: "boundary multipliers not shaped like the problem's dims"
                                .into(),
                        })
                    }
                }
            };
            ph.ocp
                .hessians_parts(
                    &z.x[a..=b],
                    &z.u[a..=b],
                    sigma,
                    &mult.lam[a..=b],
                    &mult.mu[a..=b],
                    nu,
                    &mut stages[a..=b],
                )
                .map_err(shift_stage(a))?;
            if !last {
                // the map is affine: no curvature
                stages[b + 1].hess.fill(0.0);
            }
        }
        Ok(())
    }
}

/// What a joint multi-swing plan is asked for. World frame, m; rad, rad/s.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSwingTask {
    /// The start state `[q, qd]` (2n) of the chain as written (hand A holding `bars[0]`), in the grip
    /// frame of `bars[0]`.
    pub x0: Vec<f64>,
    /// The grip `bars[0]`, then the bar each swing goes to (2 to [`MAX_JOINT_SWINGS`] + 1 bars).
    pub bars: Vec<[f64; 2]>,
    /// Circular obstacles (world frame).
    pub obstacles: Vec<Circle>,
    /// Keep the rest condition `bounds.qd_end_max` at the inner switches of the joint plan too
    /// (false: only at the last knot, the inner switch states free but for the capture).
    pub rest_at_switches: bool,
}

/// How a joint multi-swing plan ended.
#[derive(Debug, Clone, PartialEq)]
pub enum JointStatus {
    /// The joint solve converged (solved or to the acceptable level).
    Converged,
    /// The joint solve did not converge; the phases hold its last iterate.
    JointFailed {
        /// The solver's status.
        status: SolveStatus,
    },
    /// The joint solve converged, but the resampled trajectory of swing `swing` breaks the
    /// required clearance between its checked points ([`crate::planning::clearance_check`]).
    ClearanceViolated {
        /// The swing (0-based).
        swing: usize,
        /// Where and by how much.
        violation: crate::planning::clearance_check::ClearanceViolation,
    },
    /// The swing-by-swing plan of `swing` failed (so there is no warm start); no joint solve ran.
    ReferenceFailed {
        /// The swing (0-based).
        swing: usize,
        /// What went wrong.
        message: String,
    },
}

impl std::fmt::Display for JointStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            JointStatus::Converged => write!(f, "converged"),
            JointStatus::JointFailed { status } => {
                write!(f, "the joint solve did not converge ({status:?})")
            }
            JointStatus::ClearanceViolated { swing, violation } => {
                write!(
                    f,
                    "the joint solve converged, but swing {swing} breaks the clearance: {violation}"
                )
            }
            JointStatus::ReferenceFailed { swing, message } => {
                write!(
                    f,
                    "the swing-by-swing plan of swing {swing} failed: {message}"
                )
            }
        }
    }
}

/// One swing of a joint plan.
#[derive(Debug, Clone, PartialEq)]
pub struct JointPhase {
    /// The swing as a [`Plan`] on its own clock (knots, held-torque trajectory, eq. 18 energy,
    /// violations of its own rows: `violations.ee_position` and `ee_velocity` are the capture
    /// residuals at its bar; `violations.bounds` is measured against its start as the joint plan
    /// reached it). Status of the joint solve; `iterations`, `solves` and times empty (one solve for
    /// all phases: [`JointSwingPlan::solve`]).
    pub plan: Plan,
    /// The chain: 0 = as written (hand A holds), 1 = re-rooted (hand B holds).
    pub holding_hand: usize,
    /// The grip (the bar held), world, m.
    pub grip: [f64; 2],
    /// The phase's cost in the joint plan.
    pub objective: f64,
    /// The same cost of the swing-by-swing plan of this swing.
    pub reference_objective: f64,
}

/// A joint plan over several swings and the swing-by-swing plans it is compared with.
#[derive(Debug, Clone, PartialEq)]
pub struct JointSwingPlan {
    /// How it ended.
    pub status: JointStatus,
    /// The swing-by-swing plans (as many as were planned; all of them unless a reference failed).
    pub reference: Vec<Plan>,
    /// The joint solve (`None` when no joint solve ran).
    pub solve: Option<SolveAttempt>,
    /// The swings of the joint plan (empty when no joint solve ran).
    pub phases: Vec<JointPhase>,
    /// The joint objective (sum of the phases' costs; NaN when no joint solve ran).
    pub objective: f64,
    /// The same sum over the swing-by-swing plans (the joint problem's objective at its warm start;
    /// NaN when no joint solve ran).
    pub reference_objective: f64,
    /// Largest defect of the joint plan's transitions (shooting, capture and switch map), rad or rad/s
    /// (NaN when no joint solve ran).
    pub max_defect: f64,
}

impl JointSwingPlan {
    /// True when the joint solve converged and every swing keeps the required clearance.
    pub fn converged(&self) -> bool {
        self.status == JointStatus::Converged
    }

    /// Paper eq. 18 summed over the joint plan's swings, J.
    pub fn energy_j(&self) -> f64 {
        self.phases.iter().map(|p| p.plan.energy_j).sum()
    }

    /// Paper eq. 18 summed over the swing-by-swing plans, J.
    pub fn reference_energy_j(&self) -> f64 {
        self.reference.iter().map(|p| p.energy_j).sum()
    }

    /// The largest capture residuals of the joint plan over its switches and its last bar: EE
    /// distance from the bar (m) and EE speed (m/s).
    pub fn capture_residual(&self) -> (f64, f64) {
        self.phases.iter().fold((0.0, 0.0), |(p, v), ph| {
            (
                p.max(ph.plan.violations.ee_position),
                v.max(ph.plan.violations.ee_velocity),
            )
        })
    }
}

/// The swing of a traverse from `grip` to `bar` with the start state `x` (2n).
fn swing_task(x: &[f64], grip: [f64; 2], bar: [f64; 2], obstacles: &[Circle]) -> SwingTask {
    let n = x.len() / 2;
    SwingTask::on_ladder(&x[..n], &x[n..], grip, bar, obstacles)
}

/// The cost of `ocp` at its knots `z` (values only; infinite when the evaluation fails).
fn phase_cost(ocp: &mut SwingOcp, z: &Primal) -> f64 {
    let (mut st, mut term) = (ocp.dims().stage_evals(), ocp.dims().terminal_eval());
    match ocp.evaluate(z, EvalLevel::Values, &mut st, &mut term) {
        Ok(()) => st.iter().map(|s| s.cost).sum(),
        Err(_) => f64::INFINITY,
    }
}

/// The largest defect of `ocp`'s transitions at `z` (values only; infinite when the evaluation fails).
fn max_defect(ocp: &mut MultiSwingOcp, z: &Primal) -> f64 {
    let k_last = ocp.dims().horizon();
    let (mut st, mut term) = (ocp.dims().stage_evals(), ocp.dims().terminal_eval());
    if ocp
        .evaluate(z, EvalLevel::Values, &mut st, &mut term)
        .is_err()
    {
        return f64::INFINITY;
    }
    (0..k_last)
        .flat_map(|k| st[k].f.iter().zip(&z.x[k + 1]).map(|(f, x)| (f - x).abs()))
        .fold(0.0, f64::max)
}

/// Plan `task`'s swings swing by swing and then jointly (see the module docs) for `robot` (the chain
/// as written, hand A holding `bars[0]`) with the planner's settings (multiple shooting whatever
/// `settings.transcription` says; `swing_time = "auto"` gives each swing `2 T_freefall` from its
/// start, the same T for both plans) on the Riccati backend (`nlp.backend` must be `ocp`).
///
/// Errors (before any planning) on invalid settings, a backend other than `ocp`, a start state of the
/// wrong size or not finite, fewer than 2 or more than [`MAX_JOINT_SWINGS`] + 1 bars, a non-finite
/// bar, or a first swing its planner refuses ([`validate_task`]). Everything later is a status: a
/// swing-by-swing plan that fails ([`JointStatus::ReferenceFailed`]), a joint solve that does not
/// converge ([`JointStatus::JointFailed`]).
pub fn plan_joint_swings(
    robot: &Robot,
    task: &JointSwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
) -> Result<JointSwingPlan> {
    let src = "joint swings";
    let n = robot.n;
    let settings = ValidSettings::new(
        PlannerSettings {
            transcription: Transcription::MultipleShooting,
            ..settings.clone()
        },
        n,
        "planner",
    )?;
    nlp.validate()?;
    settings.refuse_free_swing_time("planner", "a joint multi-swing plan")?;
    if nlp.backend != Backend::Ocp {
        return Err(Error::invalid(
            src,
            "solver.backend",
            format!("{:?}", nlp.backend),
            "a joint multi-swing plan needs the Riccati backend `ocp`",
        ));
    }
    if task.x0.len() != 2 * n {
        return Err(Error::Dimension {
            what: "joint swings: x0".into(),
            expected: 2 * n,
            got: task.x0.len(),
        });
    }
    if let Some(v) = task.x0.iter().find(|v| !v.is_finite()) {
        return Err(Error::invalid(src, "x0", *v, "must be finite"));
    }
    let count = task.bars.len().saturating_sub(1);
    if !(1..=MAX_JOINT_SWINGS).contains(&count) {
        return Err(Error::invalid(
            src,
            "bars",
            task.bars.len(),
            format!(
                "must be 2 to {} (the grip, then one bar per swing)",
                MAX_JOINT_SWINGS + 1
            ),
        ));
    }
    if let Some((i, b)) = task
        .bars
        .iter()
        .enumerate()
        .find(|(_, b)| !(b[0].is_finite() && b[1].is_finite()))
    {
        return Err(Error::invalid(
            src,
            format!("bars[{i}]"),
            format!("{b:?}"),
            "must be finite",
        ));
    }
    let first = swing_task(&task.x0, task.bars[0], task.bars[1], &task.obstacles);
    validate_task(robot, &first, &settings, src, "swing 0.")?;
    // the first swing's interval count, checked against brachia::limits before anything is planned
    let (t_first, _) = swing_time(robot, &first, &settings)?;
    settings.grid(robot.n, t_first, "planner")?;
    let chains = [Arc::new(robot.clone()), Arc::new(robot.rerooted()?)];

    // swing by swing, each from the map of the last one's planned end state
    let mut reference: Vec<Plan> = Vec::with_capacity(count);
    let mut tasks = Vec::with_capacity(count);
    let mut phase_settings = Vec::with_capacity(count);
    let mut shifts = Vec::with_capacity(count.saturating_sub(1));
    let mut x = task.x0.clone();
    let failed = |reference, swing, message| JointSwingPlan {
        status: JointStatus::ReferenceFailed { swing, message },
        reference,
        solve: None,
        phases: Vec::new(),
        objective: f64::NAN,
        reference_objective: f64::NAN,
        max_defect: f64::NAN,
    };
    for i in 0..count {
        let t = swing_task(&x, task.bars[i], task.bars[i + 1], &task.obstacles);
        let s = settings.derive(|s| {
            if i > 0 {
                s.bounds = s.bounds.widened_for_start(&x);
            }
            // the automatic swing time fixed for this swing, so that its plan and the joint
            // problem's phase share one mesh (a strategy may not lengthen the swing of one and not
            // the other)
            if matches!(s.swing_time, SwingTime::Auto(_)) {
                if let Ok((t_auto, _)) = swing_time(&chains[i % 2], &t, s) {
                    s.swing_time = SwingTime::Seconds(t_auto);
                }
            }
        });
        let checked = s.and_then(|s| {
            let t = ValidTask::new(&chains[i % 2], t, &s, "task", "")?;
            Ok((s, t))
        });
        let (s, t) = match checked {
            Ok(st) => st,
            Err(e) => return Ok(failed(reference, i, e.to_string())),
        };
        let p = match plan_validated(&chains[i % 2], &t, &s, nlp, None) {
            Ok(p) => p,
            Err(e) => return Ok(failed(reference, i, e.to_string())),
        };
        if !p.converged() {
            let m = p.failure_message().unwrap_or_default();
            reference.push(p);
            return Ok(failed(reference, i, m));
        }
        if i + 1 < count {
            let k = p.layout.intervals;
            let xe = [p.points.q(k), p.points.qd(k)].concat();
            let mut xn = vec![0.0; 2 * n];
            reroot_state(&xe, &mut xn);
            let sum: f64 = xe[..n].iter().sum();
            let q1 = settings.bounds.nearest_q1(xn[0]);
            // pi plus the multiple of 2 pi that gives the representative, exactly
            let shift = PI + TAU * ((q1 - sum - PI) / TAU).round();
            xn[0] = sum + shift;
            shifts.push(shift);
            x = xn;
        }
        reference.push(p);
        tasks.push(t);
        phase_settings.push(s);
    }

    // the joint problem: each phase's own problem, warm-started at its swing-by-swing plan
    let mut ocps = Vec::with_capacity(count);
    let mut layouts = Vec::with_capacity(count);
    for i in 0..count {
        let mut s = phase_settings[i].clone();
        if i + 1 < count && !task.rest_at_switches {
            s = s.without_end_rest();
        }
        let p = &reference[i];
        let ShootingSetup {
            mut ocp,
            layout,
            t_final,
            freefall,
        } = setup_shooting(&chains[i % 2], &tasks[i], &s, Some(&p.points))?;
        if layout.intervals != p.layout.intervals {
            return Err(Error::Dimension {
                what: format!("joint swings: intervals of swing {i}"),
                expected: p.layout.intervals,
                got: layout.intervals,
            });
        }
        let g = ocp.guess_mut();
        for k in 0..=layout.intervals {
            g.x[k][..n].copy_from_slice(p.points.q(k));
            g.x[k][n..].copy_from_slice(p.points.qd(k));
            let nu = g.u[k].len();
            g.u[k].copy_from_slice(&p.points.tau(k)[..nu]);
        }
        phase_settings[i] = s;
        ocps.push(ocp);
        layouts.push((layout, t_final, freefall));
    }
    let mut reference_costs = Vec::with_capacity(count);
    for o in &mut ocps {
        let g = o.guess().clone();
        reference_costs.push(phase_cost(o, &g));
    }
    let mut joint = MultiSwingOcp::new(ocps, &shifts)?;
    let mut solver = OcpSolver::new(joint.dims())
        .map_err(|e| Error::invalid(src, "problem dimensions", e.to_string(), "refused"))?;
    let st = brachia_ocp::OcpSettings {
        mu_init: nlp.mu_init.unwrap_or(WARM_START_MU_INIT),
        ..ocp_settings(nlp)
    };
    let stats = solver.solve(&mut joint, &st);
    let status = status_of(&stats.status);
    let attempt = ocp_attempt(&stats, status.clone(), &st);
    let z = solver.primal().clone();
    let defect = max_defect(&mut joint, &z);
    let ranges: Vec<_> = (0..count).map(|i| joint.phase_stages(i)).collect();
    let mut phases = Vec::with_capacity(count);
    for (i, mut ocp) in joint.into_phases().into_iter().enumerate() {
        let r = ranges[i].clone();
        let zp = Primal {
            x: z.x[r.clone()].to_vec(),
            u: z.u[r].to_vec(),
        };
        ocp.set_start(&zp.x[0])?;
        let objective = phase_cost(&mut ocp, &zp);
        let mut t = tasks[i].task().clone();
        t.q0 = zp.x[0][..n].to_vec();
        t.qd0 = zp.x[0][n..].to_vec();
        let (layout, t_final, freefall) = layouts[i];
        let p = finish_plan(
            &chains[i % 2],
            &t,
            &phase_settings[i],
            &layout,
            t_final,
            freefall,
            &zp,
            &mut ocp,
            SolveSummary {
                status: status.clone(),
                objective,
                backend: Backend::Ocp,
                solves: Vec::new(),
            },
        )?;
        phases.push(JointPhase {
            plan: p,
            holding_hand: i % 2,
            grip: task.bars[i],
            objective,
            reference_objective: reference_costs[i],
        });
    }
    let violated = phases
        .iter()
        .enumerate()
        .find_map(|(i, ph)| ph.plan.clearance_violation.map(|v| (i, v)));
    Ok(JointSwingPlan {
        status: match (status.is_converged(), violated) {
            (true, None) => JointStatus::Converged,
            (true, Some((swing, violation))) => JointStatus::ClearanceViolated { swing, violation },
            (false, _) => JointStatus::JointFailed { status },
        },
        reference,
        solve: Some(attempt),
        objective: stats.objective,
        reference_objective: reference_costs.iter().sum(),
        phases,
        max_defect: defect,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planning::Bounds;

    /// The representative of the map's q'_1 and the shift agree: pi plus a whole number of turns.
    #[test]
    fn bounds_pick_the_representative_nearest_their_range() {
        let b = Bounds::default();
        assert_eq!(b.nearest_q1(-1.0), -1.0);
        assert!((b.nearest_q1(3.0) - (3.0 - TAU)).abs() < 1e-15);
        assert!((b.nearest_q1(4.0) - (4.0 - TAU)).abs() < 1e-15);
        assert_eq!(b.nearest_q1(-4.0), -4.0);
    }
}
