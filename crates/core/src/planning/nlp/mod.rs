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

mod ocp_nlp;
mod pounce;
mod prepare;
mod problem;
mod ripopt;
mod solve;
mod stop;

pub use ocp_nlp::{AdapterTimings, OcpNlp};
pub(crate) use prepare::panic_text;
pub use problem::{
    Backend, MuStrategy, NlpSettings, NlpSolution, PassStats, SolveStatus, SparseNlp, TimeSplit,
};
pub use ripopt::RIPOPT_MAX_UNKNOWNS;
pub use solve::solve;
