//! The swing by multiple shooting, as a stage-structured optimal-control problem
//! ([`brachia_ocp::OcpProblem`]).
//!
//! ## Transcription
//! Stages `k = 0..=K` on a uniform grid `t_k = k h`, `h = T / K`. Stage variables `z_k = [x_k, u_k]` with
//! `x_k = [q_k (n), qd_k (n)]` (rad, rad/s) and `u_k = tau_k` (n - 1, N m) held constant over
//! `[t_k, t_{k+1})` (zero-order hold); the last stage has no input (`nu_K = 0`).
//! - **Dynamics**: `x_{k+1} = Phi(x_k, u_k)`, `substeps` classical RK4 steps of `h / substeps` on
//!   `xdot = f(x, u) = [qd, qdd(q, qd, u)]` (the same arithmetic as [`crate::integrate::Rk4`]).
//! - **Cost** (paper eq. 5 as a quadrature): `l_k = w_k ||qd_k||^2_Q1 + h ||u_k||^2_R1` with trapezoid
//!   weights `w_k = h / 2` at the two ends and `h` inside (no torque term at k = K).
//! - **Stage inequalities** `c_k(q_k) >= 0`, k >= 1: the clearance rows of a [`DistanceClearanceFn`](crate::planning::DistanceClearanceFn)
//!   (obstacles and non-adjacent links), when there are any; their value, Jacobian and weighted
//!   Hessian in closed form ([`crate::model::ClearanceDerivatives`], AD the test oracle). With
//!   [`SwingOcpSpec::substep_clearance`], stage k < K also carries the same rows at the states after
//!   each of its first `substeps - 1` RK4 steps, `c(q_{k,s}) >= 0` (rows after the knot's, sub-step
//!   by sub-step): the constraint holds every `h / substeps` s, not only at the knots. Their
//!   Jacobian is the rows' times the sub-step state's sensitivity `S_{k,s} = d x_{k,s} / d z_k` (the
//!   forward pass has it); their Hessian `S^T [Hess mu . c] S` plus the second-order term, which the
//!   reverse sweep of the dynamics Hessian carries by adding `J^T mu` to the state adjoint where it
//!   passes the sub-step state. Stage 0's sub-step rows are relaxed to `c >= min(0, c(q_start))`,
//!   so a start pose within the margin stays feasible.
//! - **Bounds**: `x_0` fixed to the start state; q1, the relative joints and qd from
//!   [`Bounds`](crate::planning::Bounds); torques from the robot's limits.
//! - **Terminal equalities** (eqs. 8-9): `r(x_K) = [ee_x - target_x, ee_y - target_y, ee_vx, ee_vy]`.
//! - **Free swing time** (optional, [`SwingOcp::with_free_swing_time`]): `x_k = [q_k, qd_k, T_k]`,
//!   `T_{k+1} = T_k`, T bounded by `[t_min, t_max]` at every stage and not fixed at stage 0; stage k
//!   integrates over `h_k = T_k / K` and its cost is that quadrature's; stage variables
//!   `[q, qd, T, u]`.
//!
//! ## Derivatives (exact; derivation in docs/planner.md)
//! The forward pass of `Phi` carries, through every RK4 evaluation `i`, the sensitivity `S_i = d y_i / d z_k`
//! of that evaluation's input `y_i = [x_i, u_k]`, so `d Phi / d z_k` comes out of the chain rule
//! through the stages. The Hessian of `lam^T Phi` is the second-order adjoint of the composition:
//! `sum_i S_i^T [Hess_y (w_i . qdd)(y_i)] S_i`, with `w_i` the adjoint weight of evaluation i's
//! acceleration output (a reverse sweep through the RK4 stages). Every other operation in `Phi` is
//! linear, so nothing else contributes. Per-point derivatives of qdd come through [`PointDynamics`]:
//! [`AnalyticDynamics`] (closed form, the default) or [`AdDynamics`] (forward-mode AD through
//! [`crate::ad::Diff`], the test oracle). Each RK4 evaluation of a stage has its own [`PointDynamics`],
//! so the Hessian at the point of the last first-order evaluation reuses that evaluation's
//! factorisation and first derivatives ([`PointDynamics::hessian_weighted_reuse`]).
//!
//! Everything is allocated in [`SwingOcp::new`]; no evaluation allocates. When the horizon has at
//! least `parallel_min_stages` stages and rayon has more than one thread, the problem owns a helper
//! thread (`worker.rs`) that evaluates the second half of the stages while the
//! calling thread evaluates the first; called from inside a rayon worker (a parameter study's cells),
//! every stage is evaluated on the calling thread.
//!
//! ## Files
//! - [`dynamics`]: the per-point derivatives of the forward dynamics ([`PointDynamics`] and its two
//!   implementations).
//! - `stage.rs`: one stage's RK4 steps with their sensitivities and the reverse sweep of the Hessian.
//! - `kernels.rs`: the dense products of the stage.
//! - `parallel.rs`: the job that evaluates the tail of the stages on the helper thread (`worker.rs`).
//! - [`ocp`]: [`SwingOcp`], the problem itself.

pub mod dynamics;
mod kernels;
pub mod ocp;
mod parallel;
mod stage;
pub(crate) mod worker;

pub use dynamics::{AdDynamics, AnalyticDynamics, PointDynamics};
pub use ocp::{ShootingTimings, SwingOcp, SwingOcpSpec};
