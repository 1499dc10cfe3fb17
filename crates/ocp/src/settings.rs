//! Settings, outcome (status, statistics, timings) and errors of a solve.

use serde::{Deserialize, Serialize};

/// Settings of [`crate::OcpSolver::solve`]. Plain data; [`OcpSettings::validate`] is called by
/// every solve. Tolerances follow IPOPT's names and meanings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OcpSettings {
    /// Largest number of interior-point iterations (restoration iterations included). Default 200.
    pub max_iter: usize,
    /// Convergence tolerance on the scaled optimality error (IPOPT's `tol`, dimensionless). Default 1e-8.
    pub tol: f64,
    /// Largest unscaled constraint violation (infinity norm, units of the constraints) at a solution.
    /// Default 1e-8.
    pub constr_viol_tol: f64,
    /// "Acceptable" tolerance on the scaled optimality error; reached for `acceptable_iter` consecutive
    /// iterations it ends the solve with [`OcpStatus::SolvedToAcceptableLevel`]. Default 1e-6.
    pub acceptable_tol: f64,
    /// Consecutive acceptable iterations that end the solve (0 disables the acceptable test). Default 15.
    pub acceptable_iter: usize,
    /// Initial barrier parameter mu (dimensionless, > 0), used for cold and warm starts. Default 0.1;
    /// a warm start from a nearby solution wants a small value (1e-6 .. 1e-4).
    pub mu_init: f64,
    /// How the barrier parameter is updated. Default [`MuStrategy::Monotone`].
    pub mu_strategy: MuStrategy,
    /// Wall-clock budget of one solve in seconds (checked once per iteration); `None` = unlimited.
    /// Default `None`.
    pub max_wall_time_s: Option<f64>,
    /// Start from the stored iterate (primal, slacks and all multipliers of the previous solve, with
    /// any edit made through [`crate::OcpSolver::primal_mut`]) instead of
    /// [`crate::OcpProblem::initial_guess`]. Ignored (cold start) if there is no previous solve.
    /// Default false.
    pub warm_start: bool,
    /// Relative distance by which a cold initial point is pushed inside its bounds (IPOPT's
    /// `bound_push` and `bound_frac`), in (0, 0.5). Default 1e-2.
    pub bound_push: f64,
    /// The same for a warm start, in (0, 0.5). Default 1e-2; a small value (1e-9) keeps the active
    /// set of the stored solution (the robot's warm re-plans take 1e-9).
    pub warm_bound_push: f64,
    /// What a warm start does with the stored multipliers. Default [`WarmDuals::Reset`].
    pub warm_duals: WarmDuals,
    /// Largest number of consecutive restoration iterations before [`OcpStatus::RestorationFailed`].
    /// Default 50.
    pub max_restoration_iter: usize,
    /// Largest number of second-order corrections tried when a full step raises the constraint
    /// violation (IPOPT's `max_soc`; 0 disables them). Default 4.
    pub max_soc: usize,
    /// Largest number of Gondzio's multiple centrality correctors per iteration (0 = off, at most
    /// [`MAX_CENTRALITY_CORRECTORS`]). When the Newton step is cut by the fraction to the boundary,
    /// each corrector aims at a longer step, moves the complementarity products of that trial point
    /// back into a band around mu (outliers only) by one more right-hand side with the same
    /// factorisation, and is kept only if the step to the boundary grows enough (docs/ocp.md,
    /// sections 6 and 13). Not in the restoration phase. Default 0.
    pub centrality_correctors: usize,
    /// A cancel flag checked at the top of every iteration (restoration iterations included), beside
    /// `max_wall_time_s`, and again between its phases (after the Hessians, after the Newton step,
    /// after the line search): once it is set the solve ends with [`OcpStatus::Cancelled`] at the
    /// next of these, returning the last accepted iterate. Not part of a settings file (skipped by serde).
    /// Default `None`.
    #[serde(skip)]
    pub cancel: Option<crate::CancelToken>,
    /// A flag raised at the top of the iteration [`crate::IterationMark::after`] (restoration
    /// iterations included): what a caller watching the solve's progress from another thread reads.
    /// It changes nothing of the solve. Not part of a settings file (skipped by serde). Default `None`.
    #[serde(skip)]
    pub iteration_mark: Option<crate::IterationMark>,
}

/// Limit on [`OcpSettings::centrality_correctors`].
pub const MAX_CENTRALITY_CORRECTORS: usize = 10;

impl Default for OcpSettings {
    fn default() -> Self {
        OcpSettings {
            max_iter: 200,
            tol: 1e-8,
            constr_viol_tol: 1e-8,
            acceptable_tol: 1e-6,
            acceptable_iter: 15,
            mu_init: 0.1,
            mu_strategy: MuStrategy::Monotone,
            max_wall_time_s: None,
            warm_start: false,
            bound_push: 1e-2,
            warm_bound_push: 1e-2,
            warm_duals: WarmDuals::Reset,
            max_restoration_iter: 50,
            max_soc: 4,
            centrality_correctors: 0,
            cancel: None,
            iteration_mark: None,
        }
    }
}

impl OcpSettings {
    /// Checks every field; the error names the first bad field and its value.
    pub fn validate(&self) -> Result<(), OcpError> {
        fn positive(field: &'static str, v: f64) -> Result<(), OcpError> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(OcpError::InvalidSetting {
                    field,
                    value: format!("{v}"),
                    reason: "must be finite and > 0",
                })
            }
        }
        positive("tol", self.tol)?;
        positive("constr_viol_tol", self.constr_viol_tol)?;
        positive("acceptable_tol", self.acceptable_tol)?;
        positive("mu_init", self.mu_init)?;
        if self.acceptable_tol < self.tol {
            return Err(OcpError::InvalidSetting {
                field: "acceptable_tol",
                value: format!("{}", self.acceptable_tol),
                reason: "must be >= tol",
            });
        }
        if let Some(t) = self.max_wall_time_s {
            positive("max_wall_time_s", t)?;
        }
        if self.centrality_correctors > MAX_CENTRALITY_CORRECTORS {
            return Err(OcpError::InvalidSetting {
                field: "centrality_correctors",
                value: format!("{}", self.centrality_correctors),
                reason: "must be at most 10 (MAX_CENTRALITY_CORRECTORS)",
            });
        }
        for (field, v) in [
            ("bound_push", self.bound_push),
            ("warm_bound_push", self.warm_bound_push),
        ] {
            if !(v.is_finite() && v > 0.0 && v < 0.5) {
                return Err(OcpError::InvalidSetting {
                    field,
                    value: format!("{v}"),
                    reason: "must lie in (0, 0.5)",
                });
            }
        }
        Ok(())
    }
}

/// The barrier update ([`OcpSettings::mu_strategy`]; IPOPT's `mu_strategy`), written in lowercase in
/// settings files (`"monotone"`, `"adaptive"`). The one barrier-update type of brachia: the planner's
/// `NlpSettings::mu_strategy` is this type too, and the pounce and ripopt backends map it onto theirs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MuStrategy {
    /// Fiacco-McCormick: mu is kept until the barrier problem is solved to `10 mu`, then
    /// `mu <- max(tol/10, min(0.2 mu, mu^1.5))` (IPOPT's `monotone`).
    #[default]
    Monotone,
    /// Mehrotra's probing heuristic (IPOPT's `adaptive` with the `probing` oracle): every
    /// iteration an affine-scaling step (mu = 0, same factorisation) predicts the complementarity
    /// it reaches, and `mu = (mu_aff / mu_avg)^3 mu_avg`. It falls back to the monotone rule while
    /// the optimality error fails to fall below 0.9999 times its largest of the last 4 iterations,
    /// and returns once the barrier problem of that mu is solved.
    Adaptive,
}

/// The multipliers of a warm start ([`OcpSettings::warm_duals`]); the primal iterate is always the
/// stored one, pushed inside its bounds by `warm_bound_push`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum WarmDuals {
    /// The stored bound duals (floored at 1e-20) and equality multipliers: right for a re-solve of
    /// the same or a very slightly changed problem (with a small `mu_init` and `warm_bound_push`).
    Stored,
    /// The stored bound duals (as [`WarmDuals::Stored`]), the equality multipliers re-estimated by
    /// least squares at the warm point (as at a cold start, from those bound duals): for a start
    /// whose primal moved (a disturbed and rolled-out start state), where the stored equality
    /// multipliers belong to the old point.
    StoredBounds,
    /// Bound duals `mu_init / slack` (on the central path of the new barrier parameter), equality
    /// multipliers by least squares.
    Centered,
    /// Bound duals 1 and equality multipliers by least squares, as at a cold start: only the
    /// primal is warm. Pays for moderate changes (a disturbed start state), where stored duals of
    /// active bounds hold the old active set too firmly.
    Reset,
}

/// How a solve ended. Not an error: every solve returns one, with [`OcpStats`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum OcpStatus {
    /// The scaled optimality error is below `tol` and the constraint violation below `constr_viol_tol`.
    Solved,
    /// The acceptable test held for `acceptable_iter` consecutive iterations, or the line search
    /// failed at an acceptable point.
    SolvedToAcceptableLevel,
    /// `max_iter` iterations without convergence.
    MaxIterations,
    /// `max_wall_time_s` exceeded.
    MaxWallTime,
    /// [`OcpSettings::cancel`] was set: the solve stopped at the next iteration.
    Cancelled,
    /// The restoration phase could not reduce the constraint violation: the constraints are (locally)
    /// infeasible.
    LocallyInfeasible,
    /// The restoration phase reduced the violation but did not return to a point the filter accepts.
    RestorationFailed,
    /// A factorisation could not be regularised, or the solver hit non-finite numbers.
    NumericalError(String),
    /// A callback failed (error, non-finite value or panic) where no shorter step could avoid it.
    EvaluationError(String),
    /// The problem does not match the solver's dimensions or its bounds are inconsistent.
    InvalidProblem(String),
    /// [`OcpSettings::validate`] refused the settings.
    InvalidSettings(String),
}

impl OcpStatus {
    /// `Solved` or `SolvedToAcceptableLevel`.
    pub fn is_converged(&self) -> bool {
        matches!(self, OcpStatus::Solved | OcpStatus::SolvedToAcceptableLevel)
    }
}

/// Where the time of a solve went, in seconds of wall clock.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct OcpTimings {
    /// In [`crate::OcpProblem::evaluate`] (values and first derivatives, line-search trials included).
    pub evaluation_s: f64,
    /// In [`crate::OcpProblem::hessians`].
    pub hessian_s: f64,
    /// Condensing, Riccati factorisations (with inertia correction), Schur complement and solves.
    pub linear_algebra_s: f64,
    /// Line search and restoration bookkeeping, excluding the evaluations it calls.
    pub line_search_s: f64,
    /// The whole solve.
    pub total_s: f64,
}

/// Outcome and diagnostics of one solve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct OcpStats {
    /// How the solve ended.
    pub status: OcpStatus,
    /// Iterations done (restoration iterations included).
    pub iterations: usize,
    /// `sum_k l_k` at the returned iterate.
    pub objective: f64,
    /// Largest absolute violation of the dynamics, terminal equalities, fixed components, stage
    /// inequalities `c_lo <= c_k <= c_hi` and simple bounds at the returned iterate.
    pub primal_infeasibility: f64,
    /// Infinity norm of the gradient of the Lagrangian (unscaled) at the returned iterate.
    pub dual_infeasibility: f64,
    /// Barrier parameter at the end.
    pub final_mu: f64,
    /// Number of factorisations with a Hessian regularisation delta_w > 0.
    pub regularizations: usize,
    /// Number of Riccati factorisations with their inertia test (one per iteration when the first
    /// attempt passes; more while the equality-row penalty or delta_w is searched).
    #[serde(default)]
    pub factorizations: usize,
    /// Centrality correctors kept ([`OcpSettings::centrality_correctors`]), summed over the iterations.
    #[serde(default)]
    pub centrality_correctors: usize,
    /// Time split.
    pub time: OcpTimings,
}

/// Limit on `nx_k + nu_k` of a stage (dense stage blocks).
pub const MAX_STAGE_VARIABLES: usize = 512;
/// Limit on the equality rows handled by the Schur complement: terminal rows `nr` plus fixed state
/// components (`lo == hi`) at stages `k >= 1`.
pub const MAX_EQUALITY_ROWS: usize = 64;

/// Errors of [`crate::OcpSolver::new`] and [`OcpSettings::validate`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OcpError {
    /// Fewer than two stages.
    #[error("the problem needs at least 2 stages (K >= 1), got {stages}")]
    TooFewStages {
        /// Number of stages given.
        stages: usize,
    },
    /// A stage without states.
    #[error("stage {stage}: nx = 0; every stage needs at least one state")]
    EmptyState {
        /// The stage.
        stage: usize,
    },
    /// A stage too large for the dense stage blocks.
    #[error("stage {stage}: nx + nu = {nz} exceeds the limit {limit}")]
    StageTooLarge {
        /// The stage.
        stage: usize,
        /// Its nx + nu.
        nz: usize,
        /// [`MAX_STAGE_VARIABLES`].
        limit: usize,
    },
    /// Too many terminal equalities.
    #[error("n_terminal = {n_terminal} exceeds nx_K = {nx_last} or the limit {limit}")]
    TooManyTerminalRows {
        /// nr given.
        n_terminal: usize,
        /// nx of the last stage.
        nx_last: usize,
        /// [`MAX_EQUALITY_ROWS`].
        limit: usize,
    },
    /// A [`crate::WarmState`] read from a solver of other dimensions.
    #[error(
        "a warm state of {state_variables} variables and {state_slacks} slacks (or of other \
         dynamics, stage or terminal rows) for a solver of {solver_variables} variables and \
         {solver_slacks} slacks"
    )]
    WarmStateMismatch {
        /// Variables (sum of nx_k + nu_k) of the state given.
        state_variables: usize,
        /// Slacks (stage inequality rows) of the state given.
        state_slacks: usize,
        /// Variables of this solver.
        solver_variables: usize,
        /// Slacks of this solver.
        solver_slacks: usize,
    },
    /// [`crate::OcpSolver::warm_state_without_state`] asked for a component it cannot remove.
    #[error("state component {component} at stage {stage} cannot be removed: {reason}")]
    StateComponent {
        /// The component asked for.
        component: usize,
        /// The first stage where it cannot be removed.
        stage: usize,
        /// Why.
        reason: &'static str,
    },
    /// A setting out of its range.
    #[error("setting {field} = {value}: {reason}")]
    InvalidSetting {
        /// Field name.
        field: &'static str,
        /// Its value.
        value: String,
        /// The rule it breaks.
        reason: &'static str,
    },
}
