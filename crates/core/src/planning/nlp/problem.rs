//! The problem a backend solves ([`SparseNlp`]), the settings of a solve and what it returns.

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::{CancelToken, IterationMark};

/// Magnitude the backends read as an infinite bound (both treat `|b| >= 1e19` as infinite).
pub(crate) const BACKEND_INF: f64 = 2e19;

/// A sparse nonlinear program with exact first and second derivatives.
///
/// Evaluation methods take `&mut self` so that implementations may cache shared work between
/// calls at the same `x` (they are always called from the thread that called [`solve`](super::solve())).
/// Structure methods are called once per solve, before any evaluation.
pub trait SparseNlp {
    /// Number of variables n.
    fn n_vars(&self) -> usize;
    /// Number of constraints m.
    fn n_cons(&self) -> usize;
    /// Variable bounds `x_l, x_u` (n each) and constraint bounds `g_l, g_u` (m each).
    /// Infinite values (`f64::INFINITY`, `f64::NEG_INFINITY`) mean "unbounded"; `g_l[i] == g_u[i]`
    /// is an equality constraint. Buffers arrive filled with `-inf` / `+inf`.
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]);
    /// Initial primal point (n). The buffer arrives filled with zeros.
    fn initial_guess(&self, x: &mut [f64]);
    /// Objective f(x).
    fn objective(&mut self, x: &[f64]) -> f64;
    /// Objective gradient (n), dense.
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]);
    /// Constraint values g(x) (m).
    fn constraints(&mut self, x: &[f64], g: &mut [f64]);
    /// Jacobian sparsity of g as `(rows, cols)` triplets; duplicates are summed.
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>);
    /// Jacobian values at `x`, in the order of [`SparseNlp::jacobian_structure`].
    fn jacobian_values(&mut self, x: &[f64], vals: &mut [f64]);
    /// Lower-triangle (`row >= col`) sparsity of the Hessian of the Lagrangian as `(rows, cols)`;
    /// duplicates are summed.
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>);
    /// Values of the lower triangle of `obj_factor * Hess f(x) + sum_i lambda[i] * Hess g_i(x)`
    /// (lambda has m entries), in the order of [`SparseNlp::hessian_structure`].
    fn hessian_values(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]);
    /// Optional multipliers for a warm start (used only when [`NlpSettings::warm_start`] is set):
    /// constraint multipliers `lambda` (m) and bound multipliers `z_l`, `z_u` (n, >= 0), as returned
    /// in an earlier [`NlpSolution`]. Return `false` (the default) when none are available; the
    /// solve is then started cold from [`SparseNlp::initial_guess`].
    fn initial_multipliers(&self, _lambda: &mut [f64], _z_l: &mut [f64], _z_u: &mut [f64]) -> bool {
        false
    }
}

/// Which interior-point solver runs the NLP.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Backend {
    /// pounce-rs 0.14: a pure-Rust port of IPOPT (same options, same iteration path). The backend of
    /// the collocation rules and of general sparse NLPs ([`solve`](super::solve())); a cross-check of `ocp`.
    Pounce,
    /// ripopt 0.8: an independent pure-Rust IPOPT-style solver, used as a cross-check.
    Ripopt,
    /// brachia-ocp: the stage-structured interior-point solver with a Riccati KKT step. It solves
    /// optimal-control problems, not general sparse NLPs: the planner uses it with
    /// `transcription = "multiple-shooting"` only, and [`solve`](super::solve()) refuses it with
    /// [`SolveStatus::InvalidSettings`] (give a general NLP `backend: Backend::Pounce`). Default.
    #[default]
    Ocp,
}

impl Backend {
    /// Lowercase name as used in settings files (`"pounce"`, `"ripopt"`, `"ocp"`).
    pub fn name(self) -> &'static str {
        match self {
            Backend::Pounce => "pounce",
            Backend::Ripopt => "ripopt",
            Backend::Ocp => "ocp",
        }
    }
}

/// Barrier-parameter update rule (IPOPT's `mu_strategy`): the OCP solver's own type, which every
/// backend takes (pounce and ripopt map it onto theirs).
pub use brachia_ocp::MuStrategy;

/// Settings of one NLP solve. Plain data with [`Default`], serde and [`NlpSettings::validate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct NlpSettings {
    /// Solver backend. Default [`Backend::Ocp`] (the planner's multiple shooting); collocation and
    /// general NLPs need [`Backend::Pounce`] or [`Backend::Ripopt`].
    pub backend: Backend,
    /// Maximum number of interior-point iterations (0 allowed: evaluate the start only).
    /// Default 500.
    pub max_iter: usize,
    /// Desired (scaled) overall optimality tolerance, IPOPT's `tol`. Default 1e-8.
    pub tol: f64,
    /// Desired absolute constraint-violation tolerance (unscaled), IPOPT's `constr_viol_tol`.
    /// Default 1e-8. (ripopt's own default is 1e-4; this seam always sets it.)
    pub constr_viol_tol: f64,
    /// "Acceptable" optimality tolerance, IPOPT's `acceptable_tol`. Default 1e-6.
    /// pounce honours it; ripopt has it fixed at 1e-6 and ignores this value.
    pub acceptable_tol: f64,
    /// Number of consecutive acceptable iterates that end the solve as
    /// [`SolveStatus::SolvedToAcceptableLevel`]; 0 disables acceptable termination. Default 15.
    /// Honoured by both backends.
    pub acceptable_iter: usize,
    /// Wall-clock budget in seconds; `None` = unlimited. Default `None`.
    pub max_wall_time_s: Option<f64>,
    /// Console verbosity of the backend, 0..=12 (0 = silent; 5 = one line per iteration).
    /// Output goes to the backends' own streams (pounce: stdout, ripopt: stderr). Default 0.
    pub print_level: u8,
    /// Barrier-parameter strategy. Default [`MuStrategy::Monotone`].
    pub mu_strategy: MuStrategy,
    /// Initial barrier parameter, IPOPT's `mu_init`; `None` = the backend's default (0.1). A small
    /// value (1e-4) keeps a good primal starting point from being pushed back towards the centre
    /// of the feasible region, which is what makes a primal warm start pay off (see
    /// `brachia::planning::plan_with_guess`). Default `None`.
    pub mu_init: Option<f64>,
    /// Warm start from [`SparseNlp::initial_guess`] and [`SparseNlp::initial_multipliers`]
    /// (IPOPT's `warm_start_init_point`; ripopt's `warm_start`). Ignored when the problem has no
    /// multipliers to offer. Default `false`.
    pub warm_start: bool,
    /// A cancel flag checked once per iteration by every backend and before every solve of a
    /// planning strategy ([`NlpSettings::remaining`]): once it is set, the solve running ends with
    /// [`SolveStatus::Cancelled`] at its next iteration and no further solve starts. Not part of a
    /// settings file (skipped by serde). Default `None`.
    #[serde(skip)]
    pub cancel: Option<CancelToken>,
    /// A flag every backend raises at the top of the solve's iteration
    /// [`IterationMark::after`] (0-based, restoration iterations included): for a caller that acts
    /// on a solve's progress from another thread (the obstacle race: a candidate's first chance).
    /// It changes nothing of the solve. Not part of a settings file (skipped by serde). Default
    /// `None`.
    #[serde(skip)]
    pub iteration_mark: Option<IterationMark>,
}

impl Default for NlpSettings {
    fn default() -> Self {
        NlpSettings {
            backend: Backend::Ocp,
            max_iter: 500,
            tol: 1e-8,
            constr_viol_tol: 1e-8,
            acceptable_tol: 1e-6,
            acceptable_iter: 15,
            max_wall_time_s: None,
            print_level: 0,
            mu_strategy: MuStrategy::Monotone,
            mu_init: None,
            warm_start: false,
            cancel: None,
            iteration_mark: None,
        }
    }
}

impl NlpSettings {
    /// What is left of `max_wall_time_s` at this moment for a call that began at `since`, s (may be
    /// <= 0 once it is spent); `None` without a limit. The one place where a planning call shares its
    /// time limit among its solves (retry, starts, continuation).
    pub fn time_left(&self, since: std::time::Instant) -> Option<f64> {
        self.max_wall_time_s
            .map(|w| w - since.elapsed().as_secs_f64())
    }

    /// True once [`NlpSettings::cancel`] is set.
    pub fn is_cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(|c| c.is_cancelled())
    }

    /// These settings for a solve of a call that began at `since`: `max_wall_time_s` cut to what
    /// is left of it (see [`NlpSettings::time_left`]); `None` once it is spent or once
    /// [`NlpSettings::cancel`] is set, so no further solve starts. Without a limit, a copy.
    pub fn remaining(&self, since: std::time::Instant) -> Option<NlpSettings> {
        if self.is_cancelled() {
            return None;
        }
        match self.time_left(since) {
            Some(w) if w <= 0.0 => None,
            left => Some(NlpSettings {
                max_wall_time_s: left,
                ..self.clone()
            }),
        }
    }

    /// These settings with at most `cap` iterations.
    pub fn capped(self, cap: usize) -> NlpSettings {
        NlpSettings {
            max_iter: self.max_iter.min(cap),
            ..self
        }
    }

    /// Check every field; the error names the offending field and value.
    pub fn validate(&self) -> Result<()> {
        let src = "<nlp settings>";
        let positive = |field: &str, v: f64| -> Result<()> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(src, field, v, "must be finite and > 0"))
            }
        };
        for (field, v) in [
            ("tol", self.tol),
            ("constr_viol_tol", self.constr_viol_tol),
            ("acceptable_tol", self.acceptable_tol),
        ] {
            positive(field, v)?;
            if v > crate::limits::MAX_SOLVER_TOL {
                return Err(Error::invalid(
                    src,
                    field,
                    v,
                    format!(
                        "must be at most {} (brachia::limits::MAX_SOLVER_TOL): a looser tolerance \
                         calls points far from the optimum solved",
                        crate::limits::MAX_SOLVER_TOL
                    ),
                ));
            }
        }
        if let Some(t) = self.max_wall_time_s {
            positive("max_wall_time_s", t)?;
        }
        if let Some(mu) = self.mu_init {
            positive("mu_init", mu)?;
        }
        if self.print_level > 12 {
            return Err(Error::invalid(
                src,
                "print_level",
                self.print_level,
                "must be in 0..=12",
            ));
        }
        if self.max_iter > i32::MAX as usize {
            return Err(Error::invalid(
                src,
                "max_iter",
                self.max_iter,
                "must fit in an i32",
            ));
        }
        if self.acceptable_iter > i32::MAX as usize {
            return Err(Error::invalid(
                src,
                "acceptable_iter",
                self.acceptable_iter,
                "must fit in an i32",
            ));
        }
        Ok(())
    }
}

/// Outcome of a solve. Only [`SolveStatus::Solved`] and [`SolveStatus::SolvedToAcceptableLevel`]
/// count as converged; every other status still comes with the last iterate in [`NlpSolution`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum SolveStatus {
    /// Converged to the desired tolerances.
    Solved,
    /// Converged to the relaxed "acceptable" tolerances.
    SolvedToAcceptableLevel,
    /// Iteration limit reached.
    MaxIterations,
    /// Wall-clock (or CPU) time budget exhausted.
    MaxWallTime,
    /// Converged to a point of locally minimal infeasibility: the constraints look infeasible.
    LocallyInfeasible,
    /// Iterates diverged (the problem may be unbounded).
    Diverging,
    /// The feasibility-restoration phase failed.
    RestorationFailed,
    /// The search direction became too small to make progress (often nearly optimal; check
    /// [`NlpSolution::max_constraint_violation`]).
    TinyStep,
    /// Numerical trouble in the step computation (singular KKT system, ...).
    NumericalError,
    /// A callback failed or returned non-finite values where the solver could not recover; the text
    /// says which.
    EvaluationError(String),
    /// The problem is malformed (sizes, index ranges, upper-triangle Hessian entries, too few
    /// degrees of freedom, ...).
    InvalidProblem(String),
    /// The settings were rejected (by [`NlpSettings::validate`] or by the backend).
    InvalidSettings(String),
    /// Anything else the backend reported (including a backend panic), with its description.
    Other(String),
    /// [`NlpSettings::cancel`] was set: the solve stopped at its next iteration (or never started).
    Cancelled,
}

impl SolveStatus {
    /// `true` for [`SolveStatus::Solved`] and [`SolveStatus::SolvedToAcceptableLevel`].
    pub fn is_converged(&self) -> bool {
        matches!(
            self,
            SolveStatus::Solved | SolveStatus::SolvedToAcceptableLevel
        )
    }
}

/// Result of [`solve`](super::solve()): the final (or last) iterate and diagnostics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NlpSolution {
    /// How the solve ended.
    pub status: SolveStatus,
    /// Final primal iterate (n). When the backend stopped before producing one, the initial guess;
    /// empty when the problem or the settings were rejected before the solve started.
    pub x: Vec<f64>,
    /// f(x) at [`NlpSolution::x`], re-evaluated by this module (NaN if the evaluation failed).
    pub objective: f64,
    /// Constraint multipliers (m), sign convention `L = f + lambda^T g`. Zeros when unavailable.
    pub lambda: Vec<f64>,
    /// Lower-bound multipliers (n, >= 0). Zeros when unavailable.
    pub z_l: Vec<f64>,
    /// Upper-bound multipliers (n, >= 0). Zeros when unavailable.
    pub z_u: Vec<f64>,
    /// Interior-point iterations performed: the sum over [`NlpSolution::passes`].
    pub iterations: usize,
    /// Wall-clock time of the whole call, s (structure checks, solve, final re-evaluation): the sum
    /// of the passes' `time_s`.
    pub solve_time_s: f64,
    /// Where `solve_time_s` went: the sum of the passes' splits.
    pub time_split: TimeSplit,
    /// Every pass the backend ran inside this call, in order: its first run, then any re-solve it
    /// started on its own (pounce's scale audit, its barrier-strategy and dual-divergence fallbacks),
    /// whether or not the re-solve's point was returned. Never empty after a solve was started.
    pub passes: Vec<PassStats>,
    /// Largest violation at [`NlpSolution::x`] of the constraint bounds and the variable bounds
    /// (absolute, unscaled; 0 when feasible; infinite if g(x) could not be evaluated).
    pub max_constraint_violation: f64,
    /// The backend that ran.
    pub backend: Backend,
    /// The backend's own status name (e.g. `Solve_Succeeded`, `Optimal`), for diagnostics.
    pub backend_status: String,
}

/// Where the wall-clock time of a solve (or of one pass) went, s. The split is measured at the seam,
/// from the order of the callbacks, as far as a backend lets an outside observer tell: the time in
/// the callbacks is exact; the solver's own time between callbacks is attributed by what precedes
/// it. An interior-point iteration evaluates the Hessian of the Lagrangian, then computes the
/// Newton step (factorisation of the KKT matrix, inertia correction, back-solves) and only then
/// evaluates the objective and constraints at a trial point, so the solver time from the return of
/// a Hessian evaluation to the next callback is the step's linear algebra; every other gap (the
/// line search between trial points, the barrier update and convergence test, the initial
/// multiplier estimate, setup, the thread hand-offs of the pounce bridge) is in
/// `line_search_and_other_s`. The three parts add up to the time they split.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct TimeSplit {
    /// In the problem's callbacks: objective, constraints and their first and second derivatives
    /// (evaluation and assembly), s.
    pub callbacks_s: f64,
    /// In the solver from the end of a Hessian evaluation to the next callback: the Newton step, s.
    pub linear_algebra_s: f64,
    /// The rest of the solver's own time (line search, barrier and convergence tests, setup), s.
    pub line_search_and_other_s: f64,
}

impl TimeSplit {
    /// The time split, s.
    pub fn total_s(&self) -> f64 {
        self.callbacks_s + self.linear_algebra_s + self.line_search_and_other_s
    }

    /// Add `other` to `self`, part by part.
    pub fn add(&mut self, other: &TimeSplit) {
        self.callbacks_s += other.callbacks_s;
        self.linear_algebra_s += other.linear_algebra_s;
        self.line_search_and_other_s += other.line_search_and_other_s;
    }
}

/// One pass of a backend inside one call of [`solve`](super::solve()).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PassStats {
    /// What the pass was: `"pounce"` / `"ripopt"` for the backend's first run, `"pounce re-solve"`
    /// for a run pounce started on its own after it (its scale audit or a fallback; pounce does not
    /// say which to an outside observer).
    pub what: String,
    /// Interior-point iterations of this pass (restoration iterations included).
    pub iterations: usize,
    /// Wall-clock time of this pass, s (`time.total_s()`).
    pub time_s: f64,
    /// Where the time of this pass went.
    pub time: TimeSplit,
    /// The outcome of the pass whose point the solve returns (the solve's status); `None` for a
    /// pass whose point was discarded or superseded (the backend reports no status for it).
    pub status: Option<SolveStatus>,
    /// True for the pass whose point the solve returns.
    pub returned: bool,
}
