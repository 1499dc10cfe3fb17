//! The sparse NLP seam: one problem trait, one settings struct, one [`solve`] function, two
//! interior-point backends behind it (pounce-rs and ripopt, the cross-check). The settings' default
//! backend is `ocp`, the planner's stage-structured solver, which [`solve`] refuses: a general NLP
//! names `backend: Backend::Pounce` (or `Ripopt`).
//!
//! ## The problem
//! ```text
//! min_x  f(x)          x in R^n
//! s.t.   g_l <= g(x) <= g_u     (m constraints; g_l[i] == g_u[i] is an equality)
//!        x_l <= x    <= x_u
//! ```
//! Bounds may be infinite (`f64::INFINITY` / `f64::NEG_INFINITY`); they are passed to the backends
//! as `+-2e19`, which both treat as "no bound" (their `nlp_*_bound_inf` is `+-1e19`).
//!
//! ## Sparse derivatives (all indices 0-based)
//! - Jacobian of `g`: triplets `(rows[k], cols[k])`, `rows[k] < m`, `cols[k] < n`.
//! - Hessian of the Lagrangian `L = obj_factor * f(x) + sum_i lambda_i g_i(x)`: triplets in the
//!   **lower triangle** (`row >= col`), `row, col < n`.
//! - **Duplicate triplets are allowed and summed** (by this module, before the backend sees them),
//!   so a transcription may emit one entry per term. Upper-triangle Hessian entries are rejected
//!   with [`SolveStatus::InvalidProblem`] (a full symmetric pattern would otherwise be double-counted).
//! - Values are written in the order of the structure.
//!
//! ## Multiplier sign convention
//! Both backends use `L = f + lambda^T g`: at a solution, `grad f + J^T lambda - z_l + z_u = 0`
//! with `z_l, z_u >= 0` the bound multipliers.
//!
//! ## Failure handling
//! [`solve`] never panics: invalid settings or structures, backend errors, backend panics, panics in
//! the problem's callbacks and non-finite callback values all end up in [`NlpSolution::status`].
//! A non-finite value (NaN, inf) from a callback is reported to the backend as an evaluation
//! failure: during a line search the step is shortened; at the starting point the solve stops with
//! [`SolveStatus::EvaluationError`].

mod pounce;
mod ripopt;
mod stop;
pub use ripopt::RIPOPT_MAX_UNKNOWNS;

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::CancelToken;
use stop::Stop;

/// Magnitude the backends read as an infinite bound (both treat `|b| >= 1e19` as infinite).
pub(crate) const BACKEND_INF: f64 = 2e19;

/// A sparse nonlinear program with exact first and second derivatives.
///
/// Evaluation methods take `&mut self` so that implementations may cache shared work between
/// calls at the same `x` (they are always called from the thread that called [`solve`]).
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
    /// the collocation rules and of general sparse NLPs ([`solve`]); a cross-check of `ocp`.
    Pounce,
    /// ripopt 0.8: an independent pure-Rust IPOPT-style solver, used as a cross-check.
    Ripopt,
    /// brachia-ocp: the stage-structured interior-point solver with a Riccati KKT step. It solves
    /// optimal-control problems, not general sparse NLPs: the planner uses it with
    /// `transcription = "multiple-shooting"` only, and [`solve`] refuses it with
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

/// Barrier-parameter update rule (IPOPT's `mu_strategy`; supported by both backends).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MuStrategy {
    /// Fiacco-McCormick monotone decrease (IPOPT's default).
    #[default]
    Monotone,
    /// Adaptive (quality-function / probing) update.
    Adaptive,
}

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

/// Result of [`solve`]: the final (or last) iterate and diagnostics.
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

/// One pass of a backend inside one call of [`solve`].
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

/// A fingerprint of one iteration's summary row, to recognise a row a backend sends again.
pub(crate) type IterFingerprint = [u64; 6];

/// Accumulator of one pass.
#[derive(Debug, Clone, Default)]
struct PassAcc {
    iterations: usize,
    seen_iteration: bool,
    split: TimeSplit,
    last_row: Option<IterFingerprint>,
}

/// Counts iterations and splits time by pass, from the callbacks and the per-iteration events of
/// a backend (see [`TimeSplit`] for the attribution).
#[derive(Debug, Clone)]
pub(crate) struct Meter {
    /// End of the last event (callback or iteration), or the start.
    last: Instant,
    /// The last callback was a Hessian evaluation.
    after_hessian: bool,
    /// Time since the last iteration event, not yet given to a pass.
    pending: TimeSplit,
    passes: Vec<PassAcc>,
    /// A pass whose final row the backend sent again to mark its point as the one returned.
    returned: Option<usize>,
}

impl Meter {
    fn new() -> Self {
        Meter {
            last: Instant::now(),
            after_hessian: false,
            pending: TimeSplit::default(),
            passes: vec![PassAcc::default()],
            returned: None,
        }
    }

    /// Give the solver time since the last event to the linear algebra or the rest.
    fn gap(&mut self, now: Instant) {
        let g = now.saturating_duration_since(self.last).as_secs_f64();
        if self.after_hessian {
            self.pending.linear_algebra_s += g;
        } else {
            self.pending.line_search_and_other_s += g;
        }
        self.last = now;
    }

    /// Run one callback, timing it.
    fn timed<R>(&mut self, hessian: bool, f: impl FnOnce() -> R) -> R {
        self.gap(Instant::now());
        let r = f();
        let end = Instant::now();
        self.pending.callbacks_s += end.saturating_duration_since(self.last).as_secs_f64();
        self.last = end;
        self.after_hessian = hessian;
        r
    }

    fn current(&mut self) -> &mut PassAcc {
        self.passes.last_mut().expect("a meter always has a pass")
    }

    fn fold_pending(&mut self) {
        let p = std::mem::take(&mut self.pending);
        self.current().split.add(&p);
    }

    /// The backend reports iteration `iter` of its current pass with the summary row `row`
    /// (`restoration`: a row of the restoration phase, whose counter continues the pass's). A regular
    /// iteration 0 after iterations starts a new pass; a row equal to the final row of an earlier
    /// pass (sent again by pounce when it keeps an earlier pass's point) marks that pass as
    /// returned and is not counted.
    pub fn iteration(&mut self, iter: usize, restoration: bool, row: IterFingerprint) {
        self.gap(Instant::now());
        self.after_hessian = false;
        let cur = self.passes.len() - 1;
        if iter > 0 {
            if let Some(k) = self.passes[..cur]
                .iter()
                .rposition(|p| p.last_row == Some(row))
            {
                self.returned = Some(k);
                self.fold_pending();
                return;
            }
        }
        if iter == 0 && !restoration && self.current().seen_iteration {
            self.passes.push(PassAcc::default());
            self.returned = None;
        }
        self.fold_pending();
        let p = self.current();
        p.iterations = p.iterations.max(iter);
        p.seen_iteration = true;
        p.last_row = Some(row);
    }

    /// Close the meter: per pass (iterations, time split, seen an iteration event), and the pass
    /// marked as returned, if any.
    fn finish(&mut self) -> (Vec<(usize, TimeSplit, bool)>, Option<usize>) {
        self.gap(Instant::now());
        self.fold_pending();
        let passes = self
            .passes
            .iter()
            .map(|p| (p.iterations, p.split, p.seen_iteration))
            .collect();
        (passes, self.returned)
    }
}

/// A Jacobian or Hessian sparsity pattern with duplicates merged (and, for the Hessian, every
/// diagonal entry present).
#[derive(Debug, Clone)]
pub(crate) struct Pattern {
    /// Unique rows, 0-based.
    pub rows: Vec<usize>,
    /// Unique columns, 0-based.
    pub cols: Vec<usize>,
    /// For each user triplet, its position in the unique list; `None` when the user pattern has
    /// no duplicates (identity map).
    map: Option<Vec<usize>>,
    /// Number of user triplets.
    pub raw_nnz: usize,
}

impl Pattern {
    /// Check the triplets and merge duplicates. `lower` requires `row >= col`.
    pub fn new(
        what: &str,
        rows: Vec<usize>,
        cols: Vec<usize>,
        n_rows: usize,
        n_cols: usize,
        lower: bool,
    ) -> std::result::Result<Pattern, String> {
        if rows.len() != cols.len() {
            return Err(format!(
                "{what} structure: {} rows but {} columns",
                rows.len(),
                cols.len()
            ));
        }
        if rows.len() > i32::MAX as usize {
            return Err(format!("{what} structure: too many entries"));
        }
        for (k, (&r, &c)) in rows.iter().zip(&cols).enumerate() {
            if r >= n_rows || c >= n_cols {
                return Err(format!(
                    "{what} structure entry {k}: ({r}, {c}) outside {n_rows} x {n_cols}"
                ));
            }
            if lower && r < c {
                return Err(format!(
                    "{what} structure entry {k}: ({r}, {c}) is in the upper triangle (need row >= col)"
                ));
            }
        }
        let raw_nnz = rows.len();
        let mut seen = std::collections::HashMap::with_capacity(raw_nnz);
        let mut map = Vec::with_capacity(raw_nnz);
        let (mut ur, mut uc) = (Vec::with_capacity(raw_nnz), Vec::with_capacity(raw_nnz));
        for (&r, &c) in rows.iter().zip(&cols) {
            let next = ur.len();
            let slot = *seen.entry((r, c)).or_insert(next);
            if slot == next {
                ur.push(r);
                uc.push(c);
            }
            map.push(slot);
        }
        if lower {
            // Every diagonal entry is made structural (zero-valued when the user has none): the
            // backends add their inertia-correcting shifts on the diagonal, and ripopt's faer
            // LDL^T cannot place a shift where the pattern has no entry (observed: a
            // `NumericalError` at iteration 0 on the double integrator, whose states have no
            // Hessian entries).
            let mut has_diag = vec![false; n_rows];
            for (&r, &c) in ur.iter().zip(&uc) {
                if r == c {
                    has_diag[r] = true;
                }
            }
            for (i, _) in has_diag.iter().enumerate().filter(|(_, &d)| !d) {
                ur.push(i);
                uc.push(i);
            }
        }
        let map = (ur.len() != raw_nnz).then_some(map);
        Ok(Pattern {
            rows: ur,
            cols: uc,
            map,
            raw_nnz,
        })
    }

    /// Number of unique entries (what the backends see).
    pub fn nnz(&self) -> usize {
        self.rows.len()
    }

    /// Sum the user's values `raw` (raw_nnz) into `out` (nnz; added diagonal entries get 0).
    fn merge(&self, raw: &[f64], out: &mut [f64]) {
        match &self.map {
            None => out.copy_from_slice(raw),
            Some(map) => {
                out.fill(0.0);
                for (&k, &v) in map.iter().zip(raw) {
                    out[k] += v;
                }
            }
        }
    }
}

/// Warm-start multipliers gathered from the problem.
#[derive(Debug, Clone)]
pub(crate) struct WarmStart {
    pub lambda: Vec<f64>,
    pub z_l: Vec<f64>,
    pub z_u: Vec<f64>,
}

/// Everything about the problem that is fixed during a solve, gathered and checked up front.
#[derive(Debug, Clone)]
pub(crate) struct Prepared {
    pub n: usize,
    pub m: usize,
    /// Bounds with infinities mapped to `+-BACKEND_INF`.
    pub x_l: Vec<f64>,
    pub x_u: Vec<f64>,
    pub g_l: Vec<f64>,
    pub g_u: Vec<f64>,
    /// User bounds as given (for the violation measure).
    raw_bounds: [Vec<f64>; 4],
    pub x0: Vec<f64>,
    pub warm: Option<WarmStart>,
    pub jac: Pattern,
    pub hess: Pattern,
}

fn to_backend_bound(b: f64) -> f64 {
    b.clamp(-BACKEND_INF, BACKEND_INF)
}

impl Prepared {
    fn new(nlp: &dyn SparseNlp, settings: &NlpSettings) -> std::result::Result<Prepared, String> {
        let (n, m) = (nlp.n_vars(), nlp.n_cons());
        if n == 0 {
            return Err("the problem has no variables".into());
        }
        if n > i32::MAX as usize || m > i32::MAX as usize {
            return Err(format!("too many variables or constraints ({n}, {m})"));
        }
        let (mut x_l, mut x_u) = (vec![f64::NEG_INFINITY; n], vec![f64::INFINITY; n]);
        let (mut g_l, mut g_u) = (vec![f64::NEG_INFINITY; m], vec![f64::INFINITY; m]);
        nlp.bounds(&mut x_l, &mut x_u, &mut g_l, &mut g_u);
        for (what, lo, hi) in [("x", &x_l, &x_u), ("g", &g_l, &g_u)] {
            for (i, (&l, &u)) in lo.iter().zip(hi.iter()).enumerate() {
                if l.is_nan() || u.is_nan() || l > u || l == f64::INFINITY || u == f64::NEG_INFINITY
                {
                    return Err(format!("bounds of {what}[{i}]: [{l}, {u}] is empty or NaN"));
                }
            }
        }
        let mut x0 = vec![0.0; n];
        nlp.initial_guess(&mut x0);
        if let Some(i) = x0.iter().position(|v| !v.is_finite()) {
            return Err(format!("initial guess x[{i}] = {} is not finite", x0[i]));
        }
        let warm = if settings.warm_start {
            let mut w = WarmStart {
                lambda: vec![0.0; m],
                z_l: vec![0.0; n],
                z_u: vec![0.0; n],
            };
            let ok = nlp.initial_multipliers(&mut w.lambda, &mut w.z_l, &mut w.z_u);
            let finite = w
                .lambda
                .iter()
                .chain(&w.z_l)
                .chain(&w.z_u)
                .all(|v| v.is_finite());
            (ok && finite).then_some(w)
        } else {
            None
        };
        let (jr, jc) = nlp.jacobian_structure();
        let jac = Pattern::new("Jacobian", jr, jc, m, n, false)?;
        let (hr, hc) = nlp.hessian_structure();
        let hess = Pattern::new("Hessian", hr, hc, n, n, true)?;
        let map = |v: &[f64]| v.iter().map(|&b| to_backend_bound(b)).collect::<Vec<_>>();
        Ok(Prepared {
            n,
            m,
            x_l: map(&x_l),
            x_u: map(&x_u),
            g_l: map(&g_l),
            g_u: map(&g_u),
            raw_bounds: [x_l, x_u, g_l, g_u],
            x0,
            warm,
            jac,
            hess,
        })
    }

    /// Largest bound violation of x and of g(x) = `g`.
    fn violation(&self, x: &[f64], g: &[f64]) -> f64 {
        let [x_l, x_u, g_l, g_u] = &self.raw_bounds;
        let viol = |v: &[f64], lo: &[f64], hi: &[f64]| {
            v.iter()
                .zip(lo.iter().zip(hi))
                .map(|(&v, (&l, &u))| {
                    if v.is_nan() {
                        f64::INFINITY
                    } else {
                        (l - v).max(v - u).max(0.0)
                    }
                })
                .fold(0.0, f64::max)
        };
        viol(x, x_l, x_u).max(viol(g, g_l, g_u))
    }
}

/// Calls into the user's problem for the backends: merges duplicate triplets and turns non-finite
/// values into evaluation failures (`false` / `None`).
pub(crate) struct Evaluator<'a> {
    nlp: &'a mut dyn SparseNlp,
    prep: &'a Prepared,
    jac_raw: Vec<f64>,
    hess_raw: Vec<f64>,
    /// Iterations and time by pass.
    pub meter: Meter,
}

fn all_finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl<'a> Evaluator<'a> {
    pub fn new(nlp: &'a mut dyn SparseNlp, prep: &'a Prepared) -> Self {
        Evaluator {
            nlp,
            prep,
            jac_raw: vec![0.0; prep.jac.raw_nnz],
            hess_raw: vec![0.0; prep.hess.raw_nnz],
            meter: Meter::new(),
        }
    }

    /// f(x), or `None` if it is not finite.
    pub fn objective(&mut self, x: &[f64]) -> Option<f64> {
        let nlp = &mut *self.nlp;
        let f = self.meter.timed(false, || nlp.objective(x));
        f.is_finite().then_some(f)
    }

    /// Gradient into `out` (n).
    pub fn gradient(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        let nlp = &mut *self.nlp;
        self.meter.timed(false, || nlp.gradient(x, out));
        all_finite(out)
    }

    /// g(x) into `out` (m).
    pub fn constraints(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        let nlp = &mut *self.nlp;
        self.meter.timed(false, || nlp.constraints(x, out));
        all_finite(out)
    }

    /// Merged Jacobian values into `out` (unique nnz).
    pub fn jacobian(&mut self, x: &[f64], out: &mut [f64]) -> bool {
        let (nlp, raw, prep) = (&mut *self.nlp, &mut self.jac_raw, self.prep);
        self.meter.timed(false, || {
            raw.fill(0.0);
            nlp.jacobian_values(x, raw);
            prep.jac.merge(raw, out);
        });
        all_finite(out)
    }

    /// Merged Hessian-of-the-Lagrangian values into `out` (unique nnz).
    pub fn hessian(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], out: &mut [f64]) -> bool {
        let (nlp, raw, prep) = (&mut *self.nlp, &mut self.hess_raw, self.prep);
        self.meter.timed(true, || {
            raw.fill(0.0);
            nlp.hessian_values(x, obj_factor, lambda, raw);
            prep.hess.merge(raw, out);
        });
        all_finite(out)
    }

    /// The passes of the backend's run, labelled `first` (the first pass) and `resolve` (any
    /// later one), with `iterations` (the backend's own count) standing in for a backend that
    /// reported no iteration events. `status` goes to the returned pass: the one marked by
    /// [`Meter::iteration`], else the last.
    pub fn passes(
        &mut self,
        first: &str,
        resolve: &str,
        iterations: usize,
        status: &SolveStatus,
    ) -> Vec<PassStats> {
        let (raw, marked) = self.meter.finish();
        let seen_any = raw.iter().any(|p| p.2);
        let returned = marked.unwrap_or(raw.len() - 1);
        raw.iter()
            .enumerate()
            .map(|(k, &(it, split, _))| PassStats {
                what: if k == 0 { first } else { resolve }.to_string(),
                iterations: if seen_any { it } else { iterations },
                time_s: split.total_s(),
                time: split,
                status: (k == returned).then(|| status.clone()),
                returned: k == returned,
            })
            .collect()
    }
}

/// What a backend hands back to [`solve`].
#[derive(Debug, Clone)]
pub(crate) struct BackendOutcome {
    pub status: SolveStatus,
    pub backend_status: String,
    /// Final iterate, if the backend produced one.
    pub x: Option<Vec<f64>>,
    pub lambda: Option<Vec<f64>>,
    pub z_l: Option<Vec<f64>>,
    pub z_u: Option<Vec<f64>>,
    /// Iterations over every pass.
    pub iterations: usize,
    /// Every pass (see [`Evaluator::passes`]); empty when the backend could not start.
    pub passes: Vec<PassStats>,
}

impl BackendOutcome {
    /// A backend that panicked: no iterate, no iterations, the passes it recorded.
    pub(crate) fn panicked(status: SolveStatus, passes: Vec<PassStats>) -> Self {
        BackendOutcome {
            status,
            backend_status: "panic".into(),
            x: None,
            lambda: None,
            z_l: None,
            z_u: None,
            iterations: 0,
            passes,
        }
    }
}

/// Text of a caught panic payload.
pub(crate) fn panic_text(p: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = p.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = p.downcast_ref::<String>() {
        s.clone()
    } else {
        "non-string panic payload".to_string()
    }
}

/// Solve `nlp` with the backend chosen in `settings`. Never panics: every failure is a
/// [`SolveStatus`] (see the module docs). The callbacks of `nlp` run on the calling thread.
pub fn solve(nlp: &mut dyn SparseNlp, settings: &NlpSettings) -> NlpSolution {
    let start = Instant::now();
    let backend = settings.backend;
    let fail = |status: SolveStatus, x: Vec<f64>, lambda_len: usize| NlpSolution {
        status,
        objective: f64::NAN,
        lambda: vec![0.0; lambda_len],
        z_l: vec![0.0; x.len()],
        z_u: vec![0.0; x.len()],
        x,
        iterations: 0,
        solve_time_s: start.elapsed().as_secs_f64(),
        time_split: TimeSplit {
            line_search_and_other_s: start.elapsed().as_secs_f64(),
            ..TimeSplit::default()
        },
        passes: Vec::new(),
        max_constraint_violation: f64::INFINITY,
        backend,
        backend_status: String::new(),
    };
    if let Err(e) = settings.validate() {
        return fail(SolveStatus::InvalidSettings(e.to_string()), Vec::new(), 0);
    }
    let stop = Stop::new(settings, start);
    let prep = match catch_unwind(AssertUnwindSafe(|| Prepared::new(&*nlp, settings))) {
        Ok(Ok(p)) => p,
        Ok(Err(msg)) => return fail(SolveStatus::InvalidProblem(msg), Vec::new(), 0),
        Err(p) => {
            return fail(
                SolveStatus::EvaluationError(format!(
                    "panic while reading the problem: {}",
                    panic_text(&*p)
                )),
                Vec::new(),
                0,
            )
        }
    };
    if stop.cancelled() {
        return fail(SolveStatus::Cancelled, prep.x0.clone(), prep.m);
    }
    let backend_start = Instant::now();
    let mut outcome =
        match backend {
            Backend::Pounce => pounce::run(nlp, &prep, settings, &stop),
            Backend::Ripopt => ripopt::run(nlp, &prep, settings, &stop),
            Backend::Ocp => return fail(
                SolveStatus::InvalidSettings(
                    "backend \"ocp\" solves stage-structured optimal-control problems only (the \
                     planner's transcription = \"multiple-shooting\"); a sparse NLP needs \
                     \"pounce\" or \"ripopt\""
                        .into(),
                ),
                prep.x0.clone(),
                prep.m,
            ),
        };
    outcome.status = stop.verdict(outcome.status);
    if let Some(p) = outcome.passes.iter_mut().find(|p| p.returned) {
        p.status = Some(outcome.status.clone());
    }
    let x = outcome
        .x
        .filter(|x| x.len() == prep.n)
        .unwrap_or_else(|| prep.x0.clone());
    let vec_or_zeros = |v: Option<Vec<f64>>, len: usize| {
        v.filter(|v| v.len() == len)
            .unwrap_or_else(|| vec![0.0; len])
    };
    // Re-evaluate f and g at the returned point: one definition of the objective and of the
    // violation for both backends.
    let (objective, viol) = catch_unwind(AssertUnwindSafe(|| {
        let f = nlp.objective(&x);
        let mut g = vec![0.0; prep.m];
        nlp.constraints(&x, &mut g);
        (f, prep.violation(&x, &g))
    }))
    .unwrap_or((f64::NAN, f64::INFINITY));
    // The passes cover the backend's run; the checks before it go to the first pass and the final
    // re-evaluation (a callback) to the last, so the passes add up to the whole call.
    let before = backend_start.saturating_duration_since(start).as_secs_f64();
    let solve_time_s = start.elapsed().as_secs_f64();
    if outcome.passes.is_empty() {
        outcome.passes.push(PassStats {
            what: backend.name().to_string(),
            iterations: outcome.iterations,
            time_s: 0.0,
            time: TimeSplit::default(),
            status: Some(outcome.status.clone()),
            returned: true,
        });
    }
    outcome.passes[0].time.line_search_and_other_s += before;
    let covered: f64 = outcome.passes.iter().map(|p| p.time.total_s()).sum();
    if let Some(last) = outcome.passes.last_mut() {
        last.time.callbacks_s += (solve_time_s - covered).max(0.0);
    }
    let mut time_split = TimeSplit::default();
    for p in &mut outcome.passes {
        p.time_s = p.time.total_s();
        time_split.add(&p.time);
    }
    NlpSolution {
        status: outcome.status,
        lambda: vec_or_zeros(outcome.lambda, prep.m),
        z_l: vec_or_zeros(outcome.z_l, prep.n),
        z_u: vec_or_zeros(outcome.z_u, prep.n),
        x,
        objective,
        iterations: outcome.passes.iter().map(|p| p.iterations).sum(),
        solve_time_s,
        time_split,
        passes: outcome.passes,
        max_constraint_violation: viol,
        backend,
        backend_status: outcome.backend_status,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_meter_tells_passes_apart_and_recognises_a_row_sent_again() {
        let row = |i: u64, f: f64| [i, f.to_bits(), 0, 0, 0, 0];
        let mut m = Meter::new();
        for i in 0..=7 {
            m.iteration(i, false, row(i as u64, 1.0 / (1.0 + i as f64)));
        }
        // restoration rows continue the counter and do not start a pass, even at 0
        m.iteration(0, true, row(0, 9.0));
        m.iteration(8, true, row(8, 9.0));
        // a re-solve from iteration 0
        for i in 0..=5 {
            m.iteration(i, false, row(i as u64, 2.0 + i as f64));
        }
        let (passes, returned) = m.clone().finish();
        assert_eq!(
            passes.iter().map(|p| p.0).collect::<Vec<_>>(),
            [8, 5],
            "iterations per pass"
        );
        assert_eq!(returned, None, "no pass marked: the last is returned");
        // the backend sends the first pass's final row again: its point is the one returned
        m.iteration(8, true, row(8, 9.0));
        let (passes, returned) = m.finish();
        assert_eq!(passes.iter().map(|p| p.0).collect::<Vec<_>>(), [8, 5]);
        assert_eq!(returned, Some(0));
    }

    #[test]
    fn pattern_merges_duplicates_and_sums_values() {
        let p = Pattern::new("J", vec![0, 1, 0, 1], vec![2, 0, 2, 1], 2, 3, false).unwrap();
        assert_eq!(p.nnz(), 3);
        assert_eq!(p.rows, vec![0, 1, 1]);
        assert_eq!(p.cols, vec![2, 0, 1]);
        let mut out = [0.0; 3];
        p.merge(&[1.0, 2.0, 10.0, 3.0], &mut out);
        assert_eq!(out, [11.0, 2.0, 3.0]);
    }

    #[test]
    fn hessian_pattern_gets_a_structural_diagonal() {
        // 3 x 3 lower triangle with only (2, 0) and (1, 1): (0, 0) and (2, 2) are added as zeros.
        let p = Pattern::new("H", vec![2, 1], vec![0, 1], 3, 3, true).unwrap();
        assert_eq!(p.rows, vec![2, 1, 0, 2]);
        assert_eq!(p.cols, vec![0, 1, 0, 2]);
        let mut out = [f64::NAN; 4];
        p.merge(&[5.0, 7.0], &mut out);
        assert_eq!(out, [5.0, 7.0, 0.0, 0.0]);
    }

    #[test]
    fn pattern_rejects_upper_triangle_and_out_of_range() {
        assert!(Pattern::new("H", vec![0], vec![1], 2, 2, true).is_err());
        assert!(Pattern::new("J", vec![2], vec![0], 2, 2, false).is_err());
        assert!(Pattern::new("J", vec![0, 1], vec![0], 2, 2, false).is_err());
        assert!(Pattern::new("H", vec![1], vec![0], 2, 2, true).is_ok());
    }

    #[test]
    fn settings_default_validate_and_round_trip() {
        let s = NlpSettings::default();
        s.validate().unwrap();
        let text = toml::to_string(&s).unwrap();
        let back: NlpSettings = toml::from_str(&text).unwrap();
        assert_eq!(back, s);
        let r: NlpSettings =
            toml::from_str("backend = \"ripopt\"\nmu_strategy = \"adaptive\"").unwrap();
        assert_eq!(r.backend, Backend::Ripopt);
        assert_eq!(r.mu_strategy, MuStrategy::Adaptive);
        assert_eq!(r.max_iter, 500);
        assert_eq!(r.mu_init, None);
        let m: NlpSettings = toml::from_str("mu_init = 1e-4").unwrap();
        assert_eq!(m.mu_init, Some(1e-4));
        assert!(toml::from_str::<NlpSettings>("backend = \"ipopt\"").is_err());
        for bad in [
            NlpSettings {
                tol: 0.0,
                ..s.clone()
            },
            NlpSettings {
                constr_viol_tol: f64::NAN,
                ..s.clone()
            },
            NlpSettings {
                max_wall_time_s: Some(-1.0),
                ..s.clone()
            },
            NlpSettings {
                print_level: 13,
                ..s.clone()
            },
            NlpSettings {
                mu_init: Some(0.0),
                ..s.clone()
            },
            NlpSettings {
                tol: 1e308,
                ..s.clone()
            },
            NlpSettings {
                constr_viol_tol: 0.03,
                ..s.clone()
            },
            NlpSettings {
                acceptable_tol: 1.0,
                ..s.clone()
            },
        ] {
            assert!(bad.validate().is_err(), "{bad:?} should be rejected");
        }
        // the largest tolerance is accepted, and the message names the rule
        let edge = NlpSettings {
            tol: crate::limits::MAX_SOLVER_TOL,
            ..s.clone()
        };
        assert!(edge.validate().is_ok());
        let e = NlpSettings {
            tol: 0.5,
            ..s.clone()
        }
        .validate()
        .unwrap_err()
        .to_string();
        assert!(e.contains("tol") && e.contains("MAX_SOLVER_TOL"), "{e}");
    }
}
