//! Linear MPC tracker of the paper's Section IV (eqs. 14-17).
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; `q[0]` absolute from +x, the rest relative),
//! input `u = tau` = torques of joints 2..n (N m), EE output `y = [x_ee, y_ee]` (m), gravity along -y.
//!
//! Each control call at time `t` with measured state `x0`:
//! 1. Linearise `xdot = f(x, u)` at `(x0, u_last)` (the torque applied at the previous call) with exact
//!    AD (eq. 14), and the EE position at `q0` (eq. 16). With [`Linearization::AlongReference`] stages
//!    k >= 1 are instead linearised at the reference `(x^d(t + k dt), tau^d(t + k dt))` (LTV).
//! 2. Discretise over the MPC step `dt_mpc`: forward Euler (eq. 15) or the exact zero-order hold of the
//!    affine system (matrix exponential), see [`Discretization`].
//! 3. Condense the horizon: `X = Gamma U + xi`. The QP in `U = [u_0; ...; u_{N-1}]` is
//!    `min 1/2 U^T H U + g^T U, tau_min <= u_k <= tau_max`, where (halving eq. 17)
//!    `H = Gamma^T Qt Gamma + R`, `Qt_k = Q_k + C_k^T W_k C_k`. H is built in O(N^2) block products
//!    from the backward recursion `P_N = Qt_N, P_k = Qt_k + A_k^T P_{k+1} A_k`:
//!    `H_ij = Gamma_{j+1,i}^T P_{j+1} B_j` (i <= j), and g from `lambda_k = e_k + A_k^T lambda_{k+1}`.
//! 4. Solve with [`BoxQp`] warm-started from the previous solution shifted by the elapsed time; apply
//!    `u_0`.
//!
//! The cost is `sum_{k=1}^N |x_k - x^d_k|^2_Q + |y_k - y^d_k|^2_W + sum_{k=0}^{N-1} |u_k - u^r_k|^2_R`
//! with `Q, W` multiplied by `terminal_factor` at k = N, and `u^r` either zero (the paper: absolute
//! torque) or the planned torque ([`TorqueReference`]). All buffers are allocated in [`Mpc::new`]; a
//! control step does not allocate.

use super::boxqp::{BoxQp, BoxQpInfo, BoxQpSettings, BoxQpStatus};
use super::{ControlInfo, Controller};
use crate::error::{Error, Result};
use crate::model::{LinearModel, Linearizer, Robot};
use crate::trajectory::Trajectory;
use brachia_linalg::{dot_acc, gemm_nn, gemm_nt};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// How the continuous linear model is turned into a discrete one over `dt_mpc`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Discretization {
    /// Forward Euler, the paper's eq. 15: `Ad = I + dt A`, `Bd = dt B`, `Fd = dt F`.
    Euler,
    /// Exact zero-order hold of the affine system: `[Ad Bd Fd] = top rows of exp(dt [A B F; 0 0 0])`
    /// (scaling and squaring with a degree-12 Taylor series).
    Zoh,
}

/// What the torque penalty `|U - U_ref|^2_R` is measured from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TorqueReference {
    /// `U_ref = 0`: penalise the absolute torque (the paper's eq. 17).
    Zero,
    /// `U_ref` = the planned torques of the reference: penalise deviations from the plan.
    Planned,
}

/// Where the horizon is linearised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Linearization {
    /// One model at the measured state and last applied torque for the whole horizon (the paper).
    Measured,
    /// Stage 0 at the measured state; stages k >= 1 at the reference `(x^d_k, tau^d_k)` (LTV; costs
    /// N linearisations and discretisations per step).
    AlongReference,
}

/// Where the affine terms of the prediction model come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Prediction {
    /// The paper: `F` and `f` from the Taylor expansion at the linearisation point (eqs. 14, 16).
    /// Over a long horizon the linear model drifts from the true motion and the MPC "corrects"
    /// predicted errors that do not exist.
    Model,
    /// Error dynamics: keep `A, B, C` but choose the affine terms so that the reference is an exact
    /// solution of the prediction model, `Fd_k = x^d_{k+1} - Ad_k x^d_k - Bd_k tau^d_k` and
    /// `f_k = y^d_k - C_k x^d_k`. The prediction is then exact at the reference and the linear model
    /// only propagates deviations from it.
    ErrorDynamics,
}

/// Settings of the MPC (defaults are for the paper's 4-link robot: see `docs/mpc.md`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MpcSettings {
    /// Prediction horizon N (steps). Default 20.
    pub horizon: usize,
    /// MPC step, s (the control period is set by the caller; default 0.02 s, so the horizon spans 0.4 s).
    pub dt_mpc: f64,
    /// Diagonal of the state weight Q2 (2n values: q then qd; 1/rad^2, s^2/rad^2). Default empty:
    /// `[100 x n, 1 x n]` for n links, filled when the controller is built.
    pub q_diag: Vec<f64>,
    /// Diagonal of the EE weight W (2 values, 1/m^2). Default `[2000, 2000]`.
    pub w_diag: Vec<f64>,
    /// Diagonal of the torque weight R2 (n - 1 values, 1/(N m)^2). Default empty: `[0.01 x (n-1)]`,
    /// filled when the controller is built.
    pub r_diag: Vec<f64>,
    /// Factor on Q2 and W at the last stage (>= 0). Default 5.
    pub terminal_factor: f64,
    /// Diagonal of the input-rate weight Rd (n - 1 values, 1/(N m)^2; >= 0): adds
    /// `sum_{k=0}^{N-1} |u_k - u_{k-1}|^2_Rd` with `u_{-1}` the torque applied at the previous call.
    /// Default empty: `[0.1 x (n-1)]`, filled when the controller is built (zeros switch the penalty
    /// off).
    pub rate_diag: Vec<f64>,
    /// Discretisation over `dt_mpc`. Default [`Discretization::Zoh`].
    pub discretization: Discretization,
    /// Torque penalty reference. Default [`TorqueReference::Planned`].
    pub torque_reference: TorqueReference,
    /// Linearisation points over the horizon. Default [`Linearization::Measured`].
    pub linearization: Linearization,
    /// Affine terms of the prediction model. Default [`Prediction::ErrorDynamics`].
    pub prediction: Prediction,
    /// Options of the QP solver.
    pub qp: BoxQpSettings,
}

impl Default for MpcSettings {
    /// The defaults for any number of links: `q_diag`, `r_diag` and `rate_diag` empty (filled per
    /// link by [`MpcSettings::resolved`] when the controller is built).
    fn default() -> Self {
        MpcSettings {
            q_diag: Vec::new(),
            r_diag: Vec::new(),
            rate_diag: Vec::new(),
            ..Self::for_links(0)
        }
    }
}

impl MpcSettings {
    /// Default settings sized for an n-link robot.
    pub fn for_links(n: usize) -> Self {
        let mut q_diag = vec![100.0; n];
        q_diag.extend(std::iter::repeat_n(1.0, n));
        MpcSettings {
            horizon: 20,
            dt_mpc: 0.02,
            q_diag,
            w_diag: vec![2000.0, 2000.0],
            r_diag: vec![0.01; n.saturating_sub(1)],
            terminal_factor: 5.0,
            rate_diag: vec![0.1; n.saturating_sub(1)],
            discretization: Discretization::Zoh,
            torque_reference: TorqueReference::Planned,
            linearization: Linearization::Measured,
            prediction: Prediction::ErrorDynamics,
            qp: BoxQpSettings::default(),
        }
    }

    /// These settings with the empty weight vectors (`q_diag`, `r_diag`, `rate_diag`) filled with
    /// the per-link defaults of [`MpcSettings::for_links`].
    pub fn resolved(&self, n: usize) -> Self {
        let d = Self::for_links(n);
        let mut s = self.clone();
        if s.q_diag.is_empty() {
            s.q_diag = d.q_diag;
        }
        if s.r_diag.is_empty() {
            s.r_diag = d.r_diag;
        }
        if s.rate_diag.is_empty() {
            s.rate_diag = d.rate_diag;
        }
        s
    }

    /// Check the values for an n-link robot (empty `q_diag` / `r_diag` stand for the per-link
    /// defaults). Errors name the field as written in a scenario's `[tracking.mpc]`.
    pub fn validate(&self, n: usize) -> Result<()> {
        let src = "MpcSettings";
        let hmax = crate::limits::MAX_MPC_HORIZON;
        if self.horizon == 0 || self.horizon > hmax {
            return Err(Error::invalid(
                src,
                "horizon",
                self.horizon,
                format!("must be 1..={hmax} steps (brachia::limits::MAX_MPC_HORIZON)"),
            ));
        }
        if !(self.dt_mpc.is_finite() && self.dt_mpc > 0.0) {
            return Err(Error::invalid(src, "dt_mpc", self.dt_mpc, "must be > 0"));
        }
        let span = self.horizon as f64 * self.dt_mpc;
        let smax = crate::limits::MAX_MPC_SPAN_S;
        if span > smax {
            return Err(Error::invalid(
                src,
                "dt_mpc",
                self.dt_mpc,
                format!(
                    "horizon * dt_mpc = {span} s; the horizon may span at most {smax} s \
                     (brachia::limits::MAX_MPC_SPAN_S)"
                ),
            ));
        }
        let s = self.resolved(n);
        super::check_tracking_weights(
            src,
            n,
            [&s.q_diag, &s.w_diag, &s.r_diag],
            "keeps the QP strictly convex",
        )?;
        super::check_weights(
            src,
            n,
            "rate_diag",
            &s.rate_diag,
            n.saturating_sub(1),
            "n - 1 values, or none for the default",
        )?;
        if !(self.terminal_factor.is_finite()
            && self.terminal_factor >= 0.0
            && self.terminal_factor <= 1e6)
        {
            return Err(Error::invalid(
                src,
                "terminal_factor",
                self.terminal_factor,
                "must be finite and in [0, 1e6]",
            ));
        }
        self.qp.validate()
    }
}

/// Matrix exponential workspace for the zero-order hold (allocated once).
#[derive(Debug, Clone)]
struct Expm {
    m: usize,
    /// Only the first `top` rows of `a` may be non-zero (the ZOH block matrix `[A B f; 0 0 0]`).
    top: usize,
    a: Vec<f64>,
    term: Vec<f64>,
    sum: Vec<f64>,
    tmp: Vec<f64>,
}

impl Expm {
    fn new(m: usize, top: usize) -> Self {
        Expm {
            m,
            top,
            a: vec![0.0; m * m],
            term: vec![0.0; m * m],
            sum: vec![0.0; m * m],
            tmp: vec![0.0; m * m],
        }
    }

    /// `sum = exp(a)` (a: m x m row-major, overwritten); `m` and `top` are the workspace's (passed in
    /// so that constant sizes reach the loops).
    #[inline(always)]
    fn compute(&mut self, m: usize, top: usize) {
        debug_assert!(m == self.m && top == self.top);
        // 1-norm for scaling.
        let mut norm: f64 = 0.0;
        for j in 0..m {
            let s: f64 = (0..m).map(|i| self.a[i * m + j].abs()).sum();
            norm = norm.max(s);
        }
        let mut s = 0u32;
        if norm > 0.5 {
            s = (norm / 0.5).log2().ceil() as u32;
        }
        let scale = 0.5f64.powi(s as i32);
        for v in self.a.iter_mut() {
            *v *= scale;
        }
        // Taylor series to degree 12 (error < 0.5^13/13! ~ 2e-14 relative for |a| <= 0.5).
        self.sum.fill(0.0);
        self.term.fill(0.0);
        for i in 0..m {
            self.sum[i * m + i] = 1.0;
            self.term[i * m + i] = 1.0;
        }
        // With a's rows top.. zero, term_k = term_{k-1} a has zero rows top.. too (k >= 1) and only
        // the rows 0..top of a contribute: the terms that are skipped would add exact zeros.
        self.tmp.fill(0.0);
        for k in 1..=12 {
            mat_mul_rows(&self.term, &self.a, &mut self.tmp, m, top);
            let inv = 1.0 / k as f64;
            // Rows top.. of the terms are zero (those of the sum stay the identity's).
            for (t, &v) in self.term[..top * m].iter_mut().zip(&self.tmp[..top * m]) {
                *t = v * inv;
            }
            for (acc, &t) in self.sum[..top * m].iter_mut().zip(&self.term[..top * m]) {
                *acc += t;
            }
        }
        // Squaring keeps the form [[E, F], [0, I]]: only the top rows change,
        // [E F] <- [E E, E F + F] (the entries of the full product, summed in the same order).
        self.tmp[top * m..].copy_from_slice(&self.sum[top * m..]);
        for _ in 0..s {
            square_top_rows(&self.sum, &mut self.tmp, m, top);
            std::mem::swap(&mut self.sum, &mut self.tmp);
        }
    }
}

/// `c[..top] = (a a)[..top]` for an m x m row-major `a` whose rows top.. are those of the identity
/// (rows top.. of c untouched): the full product's sum over k, whose terms k >= top reduce to
/// `a[i][j]` at k = j and exact zeros otherwise.
#[inline(always)]
fn square_top_rows(a: &[f64], c: &mut [f64], m: usize, top: usize) {
    for (ai, ci) in a[..top * m]
        .chunks_exact(m)
        .zip(c[..top * m].chunks_exact_mut(m))
    {
        let mut acc = [0.0; EXPM_MAX];
        let acc = &mut acc[..m];
        for (&v, bl) in ai[..top].iter().zip(a[..top * m].chunks_exact(m)) {
            for (x, &y) in acc.iter_mut().zip(bl) {
                *x += v * y;
            }
        }
        for (x, &v) in acc[top..].iter_mut().zip(&ai[top..]) {
            *x += v;
        }
        ci.copy_from_slice(acc);
    }
}

/// `c[..top] = a[..top, ..top] b[..top]` for m x m row-major matrices (rows top.. of c untouched):
/// the product `a b` when rows top.. of `b` are zero and rows top.. of `a` are zero too.
#[inline(always)]
fn mat_mul_rows(a: &[f64], b: &[f64], c: &mut [f64], m: usize, top: usize) {
    for (ai, ci) in a[..top * m]
        .chunks_exact(m)
        .zip(c[..top * m].chunks_exact_mut(m))
    {
        let mut acc = [0.0; EXPM_MAX];
        let acc = &mut acc[..m];
        for (&v, bl) in ai[..top].iter().zip(b[..top * m].chunks_exact(m)) {
            for (x, &y) in acc.iter_mut().zip(bl) {
                *x += v * y;
            }
        }
        ci.copy_from_slice(acc);
    }
}

/// Largest size of the ZOH block matrix `[A B f; 0 0 0]`: 2n + (n - 1) + 1 for n = `MAX_LINKS`.
const EXPM_MAX: usize = 3 * crate::model::MAX_LINKS;

/// Discrete affine model of one stage: `x_{k+1} = Ad x_k + Bd u_k + Fd`, `y_k = C x_k + fy`.
#[derive(Debug, Clone, Copy)]
pub struct StageModel<'m> {
    /// 2n x 2n, row-major.
    pub ad: &'m [f64],
    /// 2n x (n-1), row-major.
    pub bd: &'m [f64],
    /// 2n.
    pub fd: &'m [f64],
    /// EE output Jacobian, 2 x 2n, row-major.
    pub c: &'m [f64],
    /// EE output offset, 2.
    pub fy: &'m [f64],
}

/// The linear MPC controller; see the module docs. Owns shared handles to the robot and the reference
/// (`Arc`), so it can be kept across calls, moved between threads and re-targeted with
/// [`Mpc::set_reference`].
#[derive(Debug, Clone)]
pub struct Mpc {
    robot: Arc<Robot>,
    reference: Arc<Trajectory>,
    settings: MpcSettings,
    lin: Linearizer,
    lm: LinearModel,
    expm: Expm,
    /// Number of distinct stage models (1 for `Measured`, N for `AlongReference`).
    n_models: usize,
    ad: Vec<f64>,
    bd: Vec<f64>,
    /// Affine terms of the model slots.
    fd_model: Vec<f64>,
    /// Affine terms per stage k = 0..N-1 (N x nx).
    fd: Vec<f64>,
    /// Output offsets per stage k = 1..N (N x 2).
    fy_stage: Vec<f64>,
    /// Reference state at t.
    xd0: Vec<f64>,
    cy: Vec<f64>,
    fy: Vec<f64>,
    /// Reference states x^d_k, k = 1..N (N x 2n).
    xref: Vec<f64>,
    /// Reference EE y^d_k, k = 1..N (N x 2).
    yref: Vec<f64>,
    /// Planned torques at t + k dt, k = 0..N-1 (N x nu).
    tauref: Vec<f64>,
    /// Cost weights per stage k = 1..N: `Qt_k` (dense nx x nx), `e_k` (nx).
    qt: Vec<f64>,
    e: Vec<f64>,
    /// Free response xi_k, k = 0..N ((N + 1) x nx).
    xi: Vec<f64>,
    /// Transposes of the model slots' `Ad` (nx x nx) and `Bd` (nu x nx), row-major: the products
    /// below run over rows of length nx instead of nu.
    adt: Vec<f64>,
    bdt: Vec<f64>,
    /// Gamma blocks, each stored transposed (nu x nx): LTI `Phi_d = A^d B` (N blocks), LTV
    /// `Gamma_{j+1,i}` (N x N blocks).
    gam: Vec<f64>,
    /// `(P_{j+1} B_j)^T = B_j^T P_{j+1}` for j = 0..N-1 (N x nu x nx).
    pb: Vec<f64>,
    /// One column of the Hessian's blocks on and above the diagonal block (N nu).
    hcol: Vec<f64>,
    p: Vec<f64>,
    ptmp: Vec<f64>,
    lam: Vec<f64>,
    lamtmp: Vec<f64>,
    h: Vec<f64>,
    g: Vec<f64>,
    lb: Vec<f64>,
    ub: Vec<f64>,
    u: Vec<f64>,
    u_prev: Vec<f64>,
    t_prev: Option<f64>,
    tau_last: Vec<f64>,
    xbuf: Vec<f64>,
    qp: BoxQp,
    last_qp: Option<BoxQpInfo>,
}

impl Mpc {
    /// An MPC tracking `reference` (states and planned torques, any sampling; usually 1 ms) for `robot`.
    /// `robot` and `reference` may be owned values or `Arc`s shared with other users. All buffers are
    /// allocated here.
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        reference: impl Into<Arc<Trajectory>>,
        settings: MpcSettings,
    ) -> Result<Self> {
        let (robot, reference): (Arc<Robot>, Arc<Trajectory>) = (robot.into(), reference.into());
        let n = robot.n;
        settings.validate(n)?;
        let settings = settings.resolved(n);
        reference.check_reference(&robot)?;
        let (nx, nu, hn) = (2 * n, n - 1, settings.horizon);
        let nu_all = hn * nu;
        let n_models = match settings.linearization {
            Linearization::Measured => 1,
            Linearization::AlongReference => hn,
        };
        let n_gam = match settings.linearization {
            Linearization::Measured => hn,
            Linearization::AlongReference => hn * hn,
        };
        let mut lb = vec![0.0; nu_all];
        let mut ub = vec![0.0; nu_all];
        for k in 0..hn {
            lb[k * nu..(k + 1) * nu].copy_from_slice(&robot.tau_min);
            ub[k * nu..(k + 1) * nu].copy_from_slice(&robot.tau_max);
        }
        let mut qp = BoxQp::new(nu_all);
        qp.settings = settings.qp;
        Ok(Mpc {
            lin: Linearizer::new(Arc::clone(&robot)),
            robot,
            reference,
            lm: LinearModel::zeros(n),
            expm: Expm::new(nx + nu + 1, nx),
            n_models,
            ad: vec![0.0; n_models * nx * nx],
            bd: vec![0.0; n_models * nx * nu],
            adt: vec![0.0; n_models * nx * nx],
            bdt: vec![0.0; n_models * nx * nu],
            fd_model: vec![0.0; n_models * nx],
            fd: vec![0.0; hn * nx],
            fy_stage: vec![0.0; hn * 2],
            xd0: vec![0.0; nx],
            cy: vec![0.0; n_models * 2 * nx],
            fy: vec![0.0; n_models * 2],
            xref: vec![0.0; hn * nx],
            yref: vec![0.0; hn * 2],
            tauref: vec![0.0; hn * nu],
            qt: vec![0.0; hn * nx * nx],
            e: vec![0.0; hn * nx],
            xi: vec![0.0; (hn + 1) * nx],
            gam: vec![0.0; n_gam * nx * nu],
            pb: vec![0.0; hn * nx * nu],
            hcol: vec![0.0; nu_all],
            p: vec![0.0; nx * nx],
            ptmp: vec![0.0; nx * nx],
            lam: vec![0.0; nx],
            lamtmp: vec![0.0; nx],
            h: vec![0.0; nu_all * nu_all],
            g: vec![0.0; nu_all],
            lb,
            ub,
            u: vec![0.0; nu_all],
            u_prev: vec![0.0; nu_all],
            t_prev: None,
            tau_last: vec![0.0; nu],
            xbuf: vec![0.0; nx],
            qp,
            settings,
            last_qp: None,
        })
    }

    /// The settings in use.
    pub fn settings(&self) -> &MpcSettings {
        &self.settings
    }

    /// Track another plan from the next call on, without rebuilding the controller: the reference is
    /// checked like in [`Mpc::new`] (same number of links, at least one sample, consistent arrays; on
    /// error the current plan is kept). The MPC's buffers are sized by the horizon, not by the
    /// reference, so any length fits; passing an `Arc` does not allocate (an owned `Trajectory` is
    /// moved into one new `Arc`). The warm start (the previous solution, shifted by the elapsed time)
    /// and the last applied torque are kept, which suits a re-plan from the current state; call
    /// [`Mpc::reset`] as well to start cold.
    pub fn set_reference(&mut self, reference: impl Into<Arc<Trajectory>>) -> Result<()> {
        super::swap_reference(&self.robot, &mut self.reference, reference)
    }

    /// The plan being tracked.
    pub fn reference(&self) -> &Arc<Trajectory> {
        &self.reference
    }

    /// The robot controlled.
    pub fn robot(&self) -> &Arc<Robot> {
        &self.robot
    }

    /// Forget the previous solution and the last applied torque (next call starts cold, linearising
    /// at the planned torque).
    pub fn reset(&mut self) {
        self.t_prev = None;
    }

    /// Diagnostics of the last QP solve (None before the first call).
    pub fn last_qp_info(&self) -> Option<BoxQpInfo> {
        self.last_qp
    }

    /// The condensed QP of the last call: `(H (Nnu x Nnu row-major), g, lb, ub)`.
    pub fn qp_data(&self) -> (&[f64], &[f64], &[f64], &[f64]) {
        (&self.h, &self.g, &self.lb, &self.ub)
    }

    /// The whole input sequence `U` (N x nu) found at the last call, N m.
    pub fn solution(&self) -> &[f64] {
        &self.u
    }

    /// Discrete model used at the last call: dynamics of stage k (`x_k -> x_{k+1}`, k = 0..N-1) and the
    /// output model of `x_k` (k = 1..N; k = 0 gives the linearisation at the measured state).
    pub fn stage_model(&self, k: usize) -> StageModel<'_> {
        let n = self.robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let m = k.min(self.n_models - 1);
        StageModel {
            ad: &self.ad[m * nx * nx..(m + 1) * nx * nx],
            bd: &self.bd[m * nx * nu..(m + 1) * nx * nu],
            fd: &self.fd[k.min(self.settings.horizon - 1) * nx..][..nx],
            c: &self.cy[m * 2 * nx..(m + 1) * 2 * nx],
            fy: if k == 0 {
                &self.fy[..2]
            } else {
                &self.fy_stage[2 * (k.min(self.settings.horizon) - 1)..][..2]
            },
        }
    }

    /// The output model used for stage k = 1..N (the linearisation at the measured state for
    /// `Measured`, at the reference x^d_k for `AlongReference`).
    fn out_model_index(&self, k: usize) -> usize {
        match self.settings.linearization {
            Linearization::Measured => 0,
            Linearization::AlongReference => k.min(self.n_models - 1),
        }
    }

    /// References used at the last call: `(x^d_k for k = 1..N (N x 2n), y^d_k (N x 2), planned
    /// torques at k = 0..N-1 (N x nu))`.
    pub fn reference_window(&self) -> (&[f64], &[f64], &[f64]) {
        (&self.xref, &self.yref, &self.tauref)
    }

    /// Planned torque at time t (linear interpolation, held past the ends), written into `out`.
    fn tau_at(&self, t: f64, out: &mut [f64]) {
        self.reference.tau_at(t, out);
    }

    /// Linearise at `(x, u)` and discretise into model slot `m`.
    /// `n` is the robot's link count (a constant for the paper's robot, see [`Mpc::step`]).
    #[inline(always)]
    fn build_model(&mut self, m: usize, x_is_buf: bool, x0: &[f64], u: &[f64], n: usize) {
        let (nx, nu) = (2 * n, n - 1);
        let dt = self.settings.dt_mpc;
        if x_is_buf {
            self.lin.linearize_into(&self.xbuf, u, &mut self.lm);
        } else {
            self.lin.linearize_into(x0, u, &mut self.lm);
        }
        let ad = &mut self.ad[m * nx * nx..][..nx * nx];
        let bd = &mut self.bd[m * nx * nu..][..nx * nu];
        let fd = &mut self.fd_model[m * nx..][..nx];
        match self.settings.discretization {
            Discretization::Euler => {
                for i in 0..nx {
                    for j in 0..nx {
                        ad[i * nx + j] =
                            dt * self.lm.a[i * nx + j] + if i == j { 1.0 } else { 0.0 };
                    }
                    for j in 0..nu {
                        bd[i * nu + j] = dt * self.lm.b[i * nu + j];
                    }
                    fd[i] = dt * self.lm.f[i];
                }
            }
            Discretization::Zoh => {
                let me = nx + nu + 1;
                let ea = &mut self.expm.a;
                ea.fill(0.0);
                for i in 0..nx {
                    for j in 0..nx {
                        ea[i * me + j] = dt * self.lm.a[i * nx + j];
                    }
                    for j in 0..nu {
                        ea[i * me + nx + j] = dt * self.lm.b[i * nu + j];
                    }
                    ea[i * me + nx + nu] = dt * self.lm.f[i];
                }
                self.expm.compute(me, nx);
                let s = &self.expm.sum;
                for i in 0..nx {
                    ad[i * nx..][..nx].copy_from_slice(&s[i * me..i * me + nx]);
                    bd[i * nu..][..nu].copy_from_slice(&s[i * me + nx..i * me + nx + nu]);
                    fd[i] = s[i * me + nx + nu];
                }
            }
        }
        let adt = &mut self.adt[m * nx * nx..][..nx * nx];
        let bdt = &mut self.bdt[m * nx * nu..][..nx * nu];
        for i in 0..nx {
            for j in 0..nx {
                adt[j * nx + i] = ad[i * nx + j];
            }
            for j in 0..nu {
                bdt[j * nx + i] = bd[i * nu + j];
            }
        }
        self.cy[m * 2 * nx..][..2 * nx].copy_from_slice(&self.lm.c);
        self.fy[m * 2..][..2].copy_from_slice(&self.lm.fy);
    }

    /// One MPC step: returns the QP diagnostics; the first input is `self.u[..nu]`.
    fn step(&mut self, t: f64, x0: &[f64]) -> BoxQpInfo {
        // the paper's 4 links with constant sizes, any other count through the same body
        with_link_count!(self.robot.n, |n| self.step_n(t, x0, n))
    }

    /// [`Mpc::step`] for `n` links (`n` = the robot's; constant sizes when called with a constant):
    /// the references and the warm start, the stage models, the condensed QP, its solution.
    #[inline(always)]
    fn step_n(&mut self, t: f64, x0: &[f64], n: usize) -> BoxQpInfo {
        self.fill_references(t, n);
        self.warm_start(t, n);
        self.build_models(x0, n);
        self.fill_affine_terms(t, n);
        self.free_response(x0, n);
        self.stage_weights(n);
        self.gamma_blocks(n);
        self.backward_recursion(n);
        self.hessian(n);
        let info = self
            .qp
            .solve(&self.h, &self.g, &self.lb, &self.ub, &mut self.u);
        self.last_qp = Some(info);
        info
    }

    /// The reference states `x^d_k` and EE positions `y^d_k` at `t + k dt` (k = 1..N) and the planned
    /// torques at `t + k dt` (k = 0..N-1).
    #[inline(always)]
    fn fill_references(&mut self, t: f64, n: usize) {
        let (nx, nu, hn) = (2 * n, n - 1, self.settings.horizon);
        let dt = self.settings.dt_mpc;
        for k in 0..hn {
            let tk = t + (k + 1) as f64 * dt;
            self.reference.state_at(tk, &mut self.xref[k * nx..][..nx]);
            let ee = self.robot.ee_position(&self.xref[k * nx..k * nx + n]);
            self.yref[2 * k] = ee[0];
            self.yref[2 * k + 1] = ee[1];
            let mut tmp = [0.0; crate::model::MAX_LINKS];
            self.tau_at(t + k as f64 * dt, &mut tmp[..nu]);
            self.tauref[k * nu..][..nu].copy_from_slice(&tmp[..nu]);
        }
    }

    /// The QP's warm start: the previous solution shifted by the elapsed time (linear interpolation),
    /// or the planned torques at the first call.
    #[inline(always)]
    fn warm_start(&mut self, t: f64, n: usize) {
        let (nu, hn) = (n - 1, self.settings.horizon);
        let dt = self.settings.dt_mpc;
        match self.t_prev {
            None => {
                self.tau_last.copy_from_slice(&self.tauref[..nu]);
                self.u.copy_from_slice(&self.tauref);
            }
            Some(tp) => {
                let s = ((t - tp) / dt).max(0.0);
                for k in 0..hn {
                    let pos = k as f64 + s;
                    let k0 = (pos.floor() as usize).min(hn - 1);
                    let k1 = (k0 + 1).min(hn - 1);
                    let r = (pos - k0 as f64).clamp(0.0, 1.0);
                    for j in 0..nu {
                        let a = self.u_prev[k0 * nu + j];
                        let b = self.u_prev[k1 * nu + j];
                        self.u[k * nu + j] = a + r * (b - a);
                    }
                }
            }
        }
    }

    /// The stage models: slot 0 linearised at the measured state and the last applied torque, slots
    /// 1.. (`AlongReference`) at the reference.
    #[inline(always)]
    fn build_models(&mut self, x0: &[f64], n: usize) {
        let (nx, nu) = (2 * n, n - 1);
        let tau_last = {
            let mut tmp = [0.0; crate::model::MAX_LINKS];
            tmp[..nu].copy_from_slice(&self.tau_last);
            tmp
        };
        self.build_model(0, false, x0, &tau_last[..nu], n);
        for k in 1..self.n_models {
            self.xbuf.copy_from_slice(&self.xref[(k - 1) * nx..][..nx]);
            let mut tmp = [0.0; crate::model::MAX_LINKS];
            tmp[..nu].copy_from_slice(&self.tauref[k * nu..][..nu]);
            self.build_model(k, true, x0, &tmp[..nu], n);
        }
    }

    /// The affine terms of the stages (`Fd_k`, k = 0..N-1) and of the outputs (`fy_k`, k = 1..N).
    #[inline(always)]
    fn fill_affine_terms(&mut self, t: f64, n: usize) {
        let (nx, nu, hn) = (2 * n, n - 1, self.settings.horizon);
        self.reference.state_at(t, &mut self.xd0);
        for k in 0..hn {
            let m = k.min(self.n_models - 1);
            let fdk = &mut self.fd[k * nx..][..nx];
            match self.settings.prediction {
                Prediction::Model => {
                    fdk.copy_from_slice(&self.fd_model[m * nx..][..nx]);
                }
                Prediction::ErrorDynamics => {
                    let ad = &self.ad[m * nx * nx..][..nx * nx];
                    let bd = &self.bd[m * nx * nu..][..nx * nu];
                    let xa = if k == 0 {
                        &self.xd0[..]
                    } else {
                        &self.xref[(k - 1) * nx..][..nx]
                    };
                    let xb = &self.xref[k * nx..][..nx];
                    let ua = &self.tauref[k * nu..][..nu];
                    for i in 0..nx {
                        let mut v = xb[i];
                        for j in 0..nx {
                            v -= ad[i * nx + j] * xa[j];
                        }
                        for j in 0..nu {
                            v -= bd[i * nu + j] * ua[j];
                        }
                        fdk[i] = v;
                    }
                }
            }
        }
        for k in 1..=hn {
            let mo = self.out_model_index(k);
            let c = &self.cy[mo * 2 * nx..][..2 * nx];
            for r in 0..2 {
                self.fy_stage[2 * (k - 1) + r] = match self.settings.prediction {
                    Prediction::Model => self.fy[mo * 2 + r],
                    Prediction::ErrorDynamics => {
                        let xd = &self.xref[(k - 1) * nx..][..nx];
                        let cx: f64 = (0..n).map(|j| c[r * nx + j] * xd[j]).sum();
                        self.yref[2 * (k - 1) + r] - cx
                    }
                };
            }
        }
    }

    /// The free response `xi_0 = x0`, `xi_{k+1} = A_k xi_k + F_k`.
    #[inline(always)]
    fn free_response(&mut self, x0: &[f64], n: usize) {
        let (nx, hn) = (2 * n, self.settings.horizon);
        self.xi[..nx].copy_from_slice(x0);
        for k in 0..hn {
            let m = k.min(self.n_models - 1);
            let ad = &self.ad[m * nx * nx..][..nx * nx];
            let fd = &self.fd[k * nx..][..nx];
            let (done, rest) = self.xi.split_at_mut((k + 1) * nx);
            let xk = &done[k * nx..];
            let xn = &mut rest[..nx];
            for i in 0..nx {
                let mut v = fd[i];
                for j in 0..nx {
                    v += ad[i * nx + j] * xk[j];
                }
                xn[i] = v;
            }
        }
    }

    /// The stage weights `Qt_k` and gradients `e_k`, k = 1..N (stored at index k - 1).
    #[inline(always)]
    fn stage_weights(&mut self, n: usize) {
        let (nx, hn) = (2 * n, self.settings.horizon);
        let q = &self.settings.q_diag;
        let w = &self.settings.w_diag;
        for k in 1..=hn {
            let fac = if k == hn {
                self.settings.terminal_factor
            } else {
                1.0
            };
            let mo = self.out_model_index(k);
            let c = &self.cy[mo * 2 * nx..][..2 * nx];
            let fy = &self.fy_stage[2 * (k - 1)..2 * k];
            let qt = &mut self.qt[(k - 1) * nx * nx..][..nx * nx];
            let xk = &self.xi[k * nx..][..nx];
            let xd = &self.xref[(k - 1) * nx..][..nx];
            let yd = &self.yref[2 * (k - 1)..2 * k];
            // C has zero velocity columns: C^T W C lives in the q-q block.
            qt.fill(0.0);
            for i in 0..nx {
                qt[i * nx + i] = fac * q[i];
            }
            for i in 0..n {
                for j in 0..n {
                    qt[i * nx + j] += fac * (w[0] * c[i] * c[j] + w[1] * c[nx + i] * c[nx + j]);
                }
            }
            // Output residual at the free response.
            let mut ry = [0.0; 2];
            for r in 0..2 {
                let mut v = fy[r] - yd[r];
                for j in 0..n {
                    v += c[r * nx + j] * xk[j];
                }
                ry[r] = fac * w[r] * v;
            }
            let e = &mut self.e[(k - 1) * nx..][..nx];
            for i in 0..nx {
                e[i] = fac * q[i] * (xk[i] - xd[i]);
            }
            for i in 0..n {
                e[i] += c[i] * ry[0] + c[nx + i] * ry[1];
            }
        }
    }

    /// The Gamma blocks, stored transposed: `Gamma^T_d = Gamma^T_{d-1} A^T` runs over rows of length
    /// nx (the products and their order of summation per entry are those of `A Gamma_{d-1}`).
    #[inline(always)]
    fn gamma_blocks(&mut self, n: usize) {
        let (nx, nu, hn) = (2 * n, n - 1, self.settings.horizon);
        match self.settings.linearization {
            Linearization::Measured => {
                // Phi_0 = B, Phi_d = A Phi_{d-1}.
                let (adt, bdt) = (&self.adt[..nx * nx], &self.bdt[..nx * nu]);
                self.gam[..nx * nu].copy_from_slice(bdt);
                for d in 1..hn {
                    let (prev, cur) = self.gam.split_at_mut(d * nx * nu);
                    let prev = &prev[(d - 1) * nx * nu..];
                    gemm_nn(prev, adt, &mut cur[..nx * nu], nu, nx, nx);
                }
            }
            Linearization::AlongReference => {
                // Gamma_{j+1,i} at block (j, i): Gamma_{i+1,i} = B_i, Gamma_{j+1,i} = A_j Gamma_{j,i}.
                let blk = nx * nu;
                for i in 0..hn {
                    let bi = &self.bdt[i * blk..][..blk];
                    self.gam[(i * hn + i) * blk..(i * hn + i + 1) * blk].copy_from_slice(bi);
                    for j in i + 1..hn {
                        let (lo, hi) = self.gam.split_at_mut((j * hn + i) * blk);
                        let prev = &lo[((j - 1) * hn + i) * blk..((j - 1) * hn + i + 1) * blk];
                        let ajt = &self.adt[j * nx * nx..][..nx * nx];
                        gemm_nn(prev, ajt, &mut hi[..blk], nu, nx, nx);
                    }
                }
            }
        }
    }

    /// The backward recursion: `P_N = Qt_N`; `PB_j = P_{j+1} B_j`; `P_j = Qt_j + A_j^T P_{j+1} A_j`;
    /// `lambda_N = e_N`; `g_j = B_j^T lambda_{j+1} - R u^r_j`; `lambda_j = e_j + A_j^T lambda_{j+1}`.
    #[inline(always)]
    fn backward_recursion(&mut self, n: usize) {
        let (nx, nu, hn) = (2 * n, n - 1, self.settings.horizon);
        self.p
            .copy_from_slice(&self.qt[(hn - 1) * nx * nx..][..nx * nx]);
        self.lam.copy_from_slice(&self.e[(hn - 1) * nx..][..nx]);
        let r = &self.settings.r_diag;
        let planned = self.settings.torque_reference == TorqueReference::Planned;
        for j in (0..hn).rev() {
            let m = j.min(self.n_models - 1);
            let ad = &self.ad[m * nx * nx..][..nx * nx];
            let adt = &self.adt[m * nx * nx..][..nx * nx];
            let bdt = &self.bdt[m * nx * nu..][..nx * nu];
            // (P B)^T from the rows of P and of B^T (P_N = Qt_N is symmetric only to rounding, so
            // the rows of P, not its columns, keep the sums of P B).
            let pb = &mut self.pb[j * nx * nu..][..nx * nu];
            gemm_nt(bdt, &self.p, pb, nu, nx, nx);
            let lam = &self.lam[..nx];
            for (a, bta) in bdt.chunks_exact(nx).enumerate() {
                let mut v = dot_acc(0.0, bta, lam);
                if planned {
                    v -= r[a] * self.tauref[j * nu + a];
                }
                self.g[j * nu + a] = v;
            }
            if j == 0 {
                break;
            }
            // P <- Qt_j + A^T P A  (ptmp = P A, then P = Qt + A^T ptmp).
            gemm_nn(&self.p, ad, &mut self.ptmp, nx, nx, nx);
            let qt = &self.qt[(j - 1) * nx * nx..][..nx * nx];
            // P is symmetric: compute the upper triangle and mirror it. Row i is accumulated over k
            // into independent sums (the same order per entry as a dot product over k, so the same
            // rounding, without one long dependency chain per entry).
            let (p, ptmp) = (&mut self.p[..nx * nx], &self.ptmp[..nx * nx]);
            for i in 0..nx {
                let mut acc = [0.0; 2 * crate::model::MAX_LINKS];
                acc[i..nx].copy_from_slice(&qt[i * nx + i..(i + 1) * nx]);
                for k in 0..nx {
                    let aki = adt[i * nx + k];
                    let pk = &ptmp[k * nx + i..(k + 1) * nx];
                    for (v, &b) in acc[i..nx].iter_mut().zip(pk) {
                        *v += aki * b;
                    }
                }
                for c in i..nx {
                    p[i * nx + c] = acc[c];
                    p[c * nx + i] = acc[c];
                }
            }
            let e = &self.e[(j - 1) * nx..][..nx];
            for ((v, &ei), ati) in self.lamtmp[..nx]
                .iter_mut()
                .zip(e)
                .zip(adt.chunks_exact(nx))
            {
                *v = dot_acc(ei, ati, lam);
            }
            std::mem::swap(&mut self.lam, &mut self.lamtmp);
        }
    }

    /// The QP's Hessian from the Gamma blocks and `P B` (and the input-rate penalty's terms in the
    /// Hessian and the gradient).
    #[inline(always)]
    fn hessian(&mut self, n: usize) {
        let (nx, nu, hn) = (2 * n, n - 1, self.settings.horizon);
        let nall = hn * nu;
        let r = &self.settings.r_diag;
        // Hessian blocks: H_ij = Gamma_{j+1,i}^T (P_{j+1} B_j) for i <= j. Both factors are stored
        // transposed (rows of length nx: `gam` block rows a, `pb` rows b), so each entry is one dot
        // product over nx (for `Measured` the block c = j - i holds Gamma_c = A^c B). Column
        // `col = j nu + b` of the blocks i <= j is collected in `hcol` and stored as the first
        // (j + 1) nu entries of row `col`; the rest of each row is mirrored afterwards.
        let blk = nx * nu;
        let lti = self.settings.linearization == Linearization::Measured;
        for j in 0..hn {
            let len = (j + 1) * nu;
            let gam_j = if lti {
                &self.gam[..len * nx]
            } else {
                &self.gam[j * hn * blk..][..len * nx]
            };
            for b in 0..nu {
                let mut pr = [0.0; 2 * crate::model::MAX_LINKS];
                pr[..nx].copy_from_slice(&self.pb[(j * nu + b) * nx..][..nx]);
                let pr = &pr[..nx];
                for (c, gb) in gam_j.chunks_exact(blk).enumerate() {
                    let i = if lti { j - c } else { c };
                    let hc = &mut self.hcol[i * nu..(i + 1) * nu];
                    for (v, ga) in hc.iter_mut().zip(gb.chunks_exact(nx)) {
                        *v = dot_acc(0.0, ga, pr);
                    }
                }
                let col = j * nu + b;
                self.h[col * nall..col * nall + len].copy_from_slice(&self.hcol[..len]);
            }
            for a in 0..nu {
                let d = j * nu + a;
                self.h[d * nall + d] += r[a];
            }
        }
        for row in 0..nall {
            for col in (row / nu + 1) * nu..nall {
                self.h[row * nall + col] = self.h[col * nall + row];
            }
        }

        // Input-rate penalty sum_k |u_k - u_{k-1}|^2_Rd (u_{-1} = the last applied torque): a block
        // tridiagonal term in H and -Rd u_{-1} in the first block of g.
        if self.settings.rate_diag.iter().any(|&v| v > 0.0) {
            let rd = &self.settings.rate_diag;
            for k in 0..hn {
                for a in 0..nu {
                    let d = k * nu + a;
                    let diag = if k + 1 < hn { 2.0 } else { 1.0 };
                    self.h[d * nall + d] += diag * rd[a];
                    if k + 1 < hn {
                        let e = d + nu;
                        self.h[d * nall + e] -= rd[a];
                        self.h[e * nall + d] -= rd[a];
                    }
                }
            }
            for a in 0..nu {
                self.g[a] -= rd[a] * self.tau_last[a];
            }
        }
    }
}

impl Controller for Mpc {
    /// One MPC step. A measured state of the wrong length or with NaNs yields the planned torque
    /// (clamped) and 0 iterations; a QP that does not reach `Solved` still returns a feasible input
    /// (see [`Mpc::last_qp_info`]).
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let n = self.robot.n;
        let nu = n - 1;
        if x.len() != 2 * n || tau.len() != nu || x.iter().any(|v| !v.is_finite()) {
            let mut tmp = [0.0; crate::model::MAX_LINKS];
            self.tau_at(t, &mut tmp[..nu]);
            for (j, o) in tau.iter_mut().enumerate().take(nu) {
                *o = tmp[j].clamp(self.robot.tau_min[j], self.robot.tau_max[j]);
            }
            self.last_qp = None;
            return ControlInfo { iterations: 0 };
        }
        let info = self.step(t, x);
        let ok = !matches!(
            info.status,
            BoxQpStatus::DimensionMismatch | BoxQpStatus::InvalidBounds
        );
        for j in 0..nu {
            let v = if ok { self.u[j] } else { self.tauref[j] };
            tau[j] = v.clamp(self.robot.tau_min[j], self.robot.tau_max[j]);
        }
        self.tau_last.copy_from_slice(tau);
        self.u_prev.copy_from_slice(&self.u);
        self.t_prev = Some(t);
        ControlInfo {
            iterations: info.iterations,
        }
    }

    fn name(&self) -> &'static str {
        "mpc"
    }
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        Mpc::set_reference(self, reference)
    }
    /// Linearise on `robot` from the next step on (its linearisation buffers are rebuilt, which
    /// allocates); the reference and the warm start are kept.
    fn set_model(&mut self, robot: Arc<Robot>) -> Result<()> {
        super::base_params::check_model(&self.robot, &robot)?;
        self.lin = Linearizer::new(Arc::clone(&robot));
        self.robot = robot;
        Ok(())
    }
    fn clone_box(&self) -> Option<Box<dyn Controller>> {
        Some(Box::new(self.clone()))
    }
}
