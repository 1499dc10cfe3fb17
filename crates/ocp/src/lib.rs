//! brachia-ocp: a primal-dual interior-point solver for discrete-time optimal-control problems whose
//! Newton step is a Riccati recursion over the stages (O(K) in the horizon). It knows nothing of
//! robots.
//!
//! # The problem
//! Stages `k = 0..=K`, state `x_k` (nx_k >= 1), input `u_k` (nu_k >= 0), `z_k = [x_k, u_k]`:
//! ```text
//! min   sum_{k=0..=K} l_k(x_k, u_k)
//! s.t.  x_{k+1} = f_k(x_k, u_k)                 k = 0..K-1   (dynamics)
//!       c_lo_k <= c_k(x_k, u_k) <= c_hi_k       k = 0..=K    (stage inequalities, c_lo < c_hi)
//!       x_lo_k <= x_k <= x_hi_k,  u_lo_k <= u_k <= u_hi_k    (simple bounds, +-inf allowed)
//!       r(x_K) = 0                                          (terminal equalities, nr rows)
//! ```
//! with twice continuously differentiable `l`, `f`, `c`, `r` given through [`OcpProblem`] (values,
//! first derivatives and the Hessian of the stage Lagrangian). A component with `lo == hi` is fixed:
//! in `x_0` or in any input it is eliminated from the Newton step; in a state after stage 0 it becomes
//! an equality row of the terminal Schur complement (see the limits). Components of `x_0` that are not
//! fixed are decision variables (a free swing time is a constant state with a free `x_0` entry).
//! Multiplier signs: see [`problem`]; `OcpSolver::multipliers` returns `lam_k`, `mu_k` (positive at
//! an active upper stage bound) and `nu`.
//!
//! # The method (details and derivations in `docs/ocp.md`)
//! IPOPT's algorithm (Waechter & Biegler 2006) on the stage structure:
//! - **Barrier problem.** Bounds on z are barriered directly; each stage row gets a slack
//!   `s = c_k(z_k)` with barriered bounds. Primal-dual bound multipliers are eliminated, so every
//!   inequality condenses into the stage Hessian (`Sigma` diagonals and `J_c^T Sigma J_c`) and
//!   gradient, as in HPIPM.
//! - **Newton step.** The condensed KKT system is an equality-constrained QP on the stage chain,
//!   solved by a Riccati recursion: backward factorisation (Cholesky of the reduced input Hessians
//!   `R + B^T P B`, eigendecomposition of `P_0`), then backward gradient and forward passes. The
//!   terminal rows (and fixed states after stage 0), `m` rows in all, are handled exactly by a dense
//!   `m x m` Schur complement: one backward and forward pass with `m` right-hand sides per
//!   factorisation, and 2 chain solves per right-hand side.
//! - **Inertia test and correction.** The KKT matrix must have the inertia of a local minimiser:
//!   the reduced input Hessians have a Cholesky, `P_0` (eigendecomposition) has q negative
//!   eigenvalues, and the Schur matrix of the equality rows exactly q as well (so a free swing
//!   time, convex only with the terminal rows, needs no regularisation). Otherwise the test is
//!   repeated with a penalty `rho a_j a_j^T` on the equality rows (rho = 1 .. 1e8; same step, same
//!   inertia, but it lets the recursion see a Hessian convex only on the null space of the rows,
//!   e.g. of a nonlinear terminal constraint), and then `delta_w` is added to the Hessian diagonal
//!   with IPOPT's rules (first 1e-4, later a third of the last value, growth 8x or 100x, give up
//!   above 1e40); a singular Schur matrix gets a `delta_c`.
//! - **Line search.** IPOPT's filter with the switching condition, Armijo test on the barrier
//!   function, fraction-to-the-boundary `tau = max(0.99, 1 - mu)` separately for primal and dual
//!   variables, the `kappa_sigma` safeguard on the bound multipliers, and up to `max_soc`
//!   second-order corrections (re-solves with the same factorisation) when a full step raises the
//!   constraint violation.
//! - **Barrier update** ([`MuStrategy`]). Monotone (Fiacco-McCormick, the default):
//!   `mu <- max(tol/10, min(0.2 mu, mu^1.5))` whenever the barrier error is below `10 mu`; the
//!   filter is reset. Or adaptive: Mehrotra's probing (an affine step with the same factorisation
//!   sets mu every iteration), falling back to the monotone rule while the optimality error stalls.
//! - **Restoration.** When the line search fails, IPOPT's l1 restoration phase: minimise
//!   `1000 ||p + n||_1 + sqrt(mu)/2 ||D (z - z_R)||^2` s.t. `c(z) - p + n = 0` (all equality rows:
//!   dynamics, slack rows, terminal rows) with the same machinery; the slacks `p, n` condense into a
//!   diagonal per row, which turns the dynamics into soft dynamics in the Riccati recursion. It
//!   returns when the violation fell to 0.9 of its value at entry and the original filter accepts
//!   the point; then the multipliers are re-estimated by least squares (a Riccati solve with H = I,
//!   as at a cold start).
//! - **Warm start** ([`OcpSettings::warm_start`]): the stored primal (e.g. shifted in time through
//!   [`OcpSolver::primal_mut`]) pushed inside by `warm_bound_push`; the multipliers by
//!   [`WarmDuals`] (default: reset as at a cold start, which pays after a disturbed x_0).
//! - **Termination.** IPOPT's scaled optimality error `E_0 <= tol` together with
//!   `max |constraint| <= constr_viol_tol`; or the acceptable test (`acceptable_tol`) for
//!   `acceptable_iter` consecutive iterations.
//!
//! # One iteration
//! residuals and termination test -> barrier update -> [`OcpProblem::hessians`] -> condensing,
//! factorisation with inertia correction, Schur complement, solves -> filter line search
//! ([`OcpProblem::evaluate`] with values only at trial points) -> accept, update multipliers ->
//! `evaluate` with first derivatives at the new point. Restoration iterations have the same shape.
//!
//! # Statuses
//! [`OcpStatus::Solved`], [`OcpStatus::SolvedToAcceptableLevel`] (acceptable test, or the line
//! search failed at an acceptable point), [`OcpStatus::MaxIterations`], [`OcpStatus::MaxWallTime`],
//! [`OcpStatus::LocallyInfeasible`] (restoration converged or stalled without reducing the
//! violation by half), [`OcpStatus::RestorationFailed`] (restoration reduced the violation but never
//! returned), [`OcpStatus::NumericalError`] (regularisation failed, non-finite step, internal panic),
//! [`OcpStatus::EvaluationError`] (a callback returned `Err`, non-finite values or panicked at the
//! current point; at a line-search trial point the step is only shortened),
//! [`OcpStatus::InvalidProblem`] (dims differ from the solver's, `lo > hi`, `c_lo >= c_hi`, too many
//! equality rows), [`OcpStatus::InvalidSettings`], [`OcpStatus::Cancelled`] ([`OcpSettings::cancel`]
//! was set; checked once per iteration, restoration iterations included).
//!
//! # Timings ([`OcpTimings`])
//! `evaluation_s` in `evaluate` (trials included), `hessian_s` in `hessians`, `linear_algebra_s` in
//! condensing, factorisation, Schur complement, solves and step recovery, `line_search_s` in the line
//! search and restoration bookkeeping without the evaluations it calls, `total_s` the whole solve.
//!
//! # Limits
//! At least 2 stages; `nx_k >= 1`; `nx_k + nu_k <=` [`MAX_STAGE_VARIABLES`]; terminal rows plus
//! fixed state components after stage 0 `<=` [`MAX_EQUALITY_ROWS`] (each costs one extra Riccati
//! solve per factorisation). The inertia test needs positive definite reduced input Hessians and a
//! non-singular `P_0` (after the equality-row penalty); otherwise the step is regularised
//! (harmless, but slowing).
//!
//! # Memory
//! [`OcpSolver::new`] allocates the whole workspace; the first solve reserves the filter
//! (`max_iter` entries) and the Schur responses (`m` columns). Later solves with the same or smaller `max_iter` do not allocate (tested),
//! except for the message of a failure status.
//!
//! # Example
//! A scalar integrator `x+ = x + u` from `x_0 = 1` to `x_K = 0` with `sum u^2 / 2`: the optimum is
//! `u_k = -1 / K`.
//! ```
//! use brachia_ocp::*;
//! struct Integrator(OcpDims);
//! impl OcpProblem for Integrator {
//!     fn dims(&self) -> &OcpDims { &self.0 }
//!     fn bounds(&self, k: usize, b: &mut StageBounds) {
//!         if k == 0 { b.x_lo[0] = 1.0; b.x_hi[0] = 1.0; }
//!     }
//!     fn initial_guess(&self, _z: &mut Primal) {}
//!     fn evaluate(&mut self, z: &Primal, level: EvalLevel, st: &mut [StageEval],
//!                 t: &mut TerminalEval) -> Result<(), EvalError> {
//!         let kk = st.len() - 1;
//!         for k in 0..=kk {
//!             let u = z.u[k].first().copied().unwrap_or(0.0);
//!             st[k].cost = 0.5 * u * u;
//!             if k < kk {
//!                 st[k].f[0] = z.x[k][0] + u;
//!             }
//!             if level == EvalLevel::FirstOrder && k < kk {
//!                 st[k].grad.copy_from_slice(&[0.0, u]);
//!                 st[k].jac_f.copy_from_slice(&[1.0, 1.0]);
//!             }
//!         }
//!         t.r[0] = z.x[kk][0];
//!         t.jac_r[0] = 1.0;
//!         Ok(())
//!     }
//!     fn hessians(&mut self, _z: &Primal, sigma: f64, _m: &Multipliers,
//!                 st: &mut [StageEval]) -> Result<(), EvalError> {
//!         let kk = st.len() - 1;
//!         for k in 0..kk {
//!             st[k].hess.copy_from_slice(&[0.0, 0.0, 0.0, sigma]);
//!         }
//!         Ok(())
//!     }
//! }
//! let kk = 10;
//! let mut stages = vec![StageDims { nx: 1, nu: 1, nc: 0 }; kk + 1];
//! stages[kk].nu = 0;
//! let mut p = Integrator(OcpDims { stages, n_terminal: 1 });
//! let mut solver = OcpSolver::new(p.dims()).unwrap();
//! let stats = solver.solve(&mut p, &OcpSettings::default());
//! assert_eq!(stats.status, OcpStatus::Solved);
//! assert!((solver.primal().u[3][0] + 0.1).abs() < 1e-9);
//! ```
#![warn(missing_docs)]

mod cancel;
mod mark;
pub mod problem;
mod riccati;
mod settings;
mod solver;

pub use cancel::{CancelToken, Cancelled};
pub use mark::IterationMark;
pub use problem::{
    EvalError, EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageBounds, StageDims,
    StageEval, TerminalEval,
};
pub use settings::{
    MuStrategy, OcpError, OcpSettings, OcpStats, OcpStatus, OcpTimings, WarmDuals,
    MAX_CENTRALITY_CORRECTORS, MAX_EQUALITY_ROWS, MAX_STAGE_VARIABLES,
};
pub use solver::{OcpSolver, WarmState};
