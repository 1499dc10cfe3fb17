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
//! - **Stage inequalities** `c_k(q_k) >= 0`, k >= 1: the clearance rows of a [`DistanceClearanceFn`]
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
//!   [`Bounds`]; torques from the robot's limits.
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
//! thread (`planning::worker::SpinWorker`) that evaluates the second half of the stages while the
//! calling thread evaluates the first; called from inside a rayon worker (a parameter study's cells),
//! every stage is evaluated on the calling thread.

use super::collocation::EeTerminalFn;
use super::planner::DistanceClearanceFn;
use super::settings::Bounds;
use super::worker::{Job, SpinWorker};
use crate::ad::{Diff, LocalFn};
use crate::error::{Error, Result};
use crate::model::{
    ClearanceDerivatives, ClearanceRecord, DynamicsDerivatives, DynamicsFn, Robot, Scratch,
};
use brachia_linalg::add_lincomb;
use brachia_ocp::{
    EvalError, EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageBounds, StageDims,
    StageEval, TerminalEval,
};
use std::sync::Arc;
use std::time::Instant;

/// Exact derivatives of the forward dynamics `qdd(y)`, `y = [q (n), qd (n), tau (n - 1)]`, at one point:
/// the seam through which the shooting problem gets them (automatic differentiation now, the closed
/// form later; the AD path then stays as the test oracle). Layouts as [`crate::ad::Diff`]:
/// Jacobian row-major `n x (3n - 1)`, Hessian full symmetric row-major `(3n - 1) x (3n - 1)`.
pub trait PointDynamics: Send + Sized + 'static {
    /// Buffers for `robot` (allocated once; the robot shared, not copied).
    fn new(robot: &Arc<Robot>) -> Self;
    /// `qdd = f(y)`.
    fn value(&mut self, y: &[f64], qdd: &mut [f64]);
    /// `qdd = f(y)` and its Jacobian.
    fn jacobian(&mut self, y: &[f64], qdd: &mut [f64], jac: &mut [f64]);
    /// Hessian of `w . qdd(y)` (w: n weights).
    fn hessian_weighted(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]);
    /// [`Self::hessian_weighted`] where `y` may be the input of this object's last
    /// [`Self::jacobian`] call (`value` calls in between allowed), whose work an implementation may
    /// reuse; it must check that `y` is that input. The default recomputes.
    fn hessian_weighted_reuse(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        self.hessian_weighted(y, w, hess);
    }
}

/// [`PointDynamics`] by forward-mode automatic differentiation ([`DynamicsFn`] through [`Diff`]).
pub struct AdDynamics {
    f: DynamicsFn,
    diff: Diff<DynamicsFn>,
}

impl PointDynamics for AdDynamics {
    fn new(robot: &Arc<Robot>) -> Self {
        let f = DynamicsFn::new(Arc::clone(robot));
        AdDynamics {
            diff: Diff::new(&f),
            f,
        }
    }
    fn value(&mut self, y: &[f64], qdd: &mut [f64]) {
        self.diff.value(&self.f, y, qdd);
    }
    fn jacobian(&mut self, y: &[f64], qdd: &mut [f64], jac: &mut [f64]) {
        self.diff.jacobian(&self.f, y, qdd, jac);
    }
    fn hessian_weighted(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        self.diff.hessian_weighted(&self.f, y, w, hess);
    }
}

/// [`PointDynamics`] in closed form ([`DynamicsDerivatives`]); values by
/// [`Robot::forward_dynamics_into`], the same arithmetic as [`crate::integrate::Rk4`]. The default.
pub struct AnalyticDynamics {
    robot: Arc<Robot>,
    ws: Scratch<f64>,
    d: DynamicsDerivatives,
    /// Input of the last `jacobian` call (`d` still holds its factorisation), if any.
    jac_y: Vec<f64>,
    jac_valid: bool,
}

impl PointDynamics for AnalyticDynamics {
    fn new(robot: &Arc<Robot>) -> Self {
        AnalyticDynamics {
            ws: Scratch::new(robot.n),
            d: DynamicsDerivatives::new(robot),
            jac_y: vec![0.0; 3 * robot.n - 1],
            jac_valid: false,
            robot: Arc::clone(robot),
        }
    }
    fn value(&mut self, y: &[f64], qdd: &mut [f64]) {
        let n = self.robot.n;
        self.robot
            .forward_dynamics_into(&mut self.ws, &y[..n], &y[n..2 * n], &y[2 * n..], qdd);
        // a first-order evaluation at the same point (the accepted trial point) reuses them
        let (sn, cs) = self.ws.trig();
        self.d.provide_trig(&y[..n], sn, cs);
    }
    fn jacobian(&mut self, y: &[f64], qdd: &mut [f64], jac: &mut [f64]) {
        self.d.jacobian(&self.robot, y, qdd, jac);
        self.jac_y.copy_from_slice(y);
        self.jac_valid = true;
    }
    fn hessian_weighted(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        self.d.hessian_weighted(&self.robot, y, w, hess);
        self.jac_y.copy_from_slice(y);
        self.jac_valid = true;
    }
    fn hessian_weighted_reuse(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        if self.jac_valid && self.jac_y == y {
            self.d.hessian_weighted_after_jacobian(&self.robot, w, hess);
        } else {
            self.hessian_weighted(y, w, hess);
        }
    }
}

/// What defines a [`SwingOcp`] besides the robot and the clearance rows. Units: s, rad, rad/s, m.
#[derive(Debug, Clone, PartialEq)]
pub struct SwingOcpSpec {
    /// Number of shooting intervals K (>= 1); K + 1 stages.
    pub intervals: usize,
    /// Swing time T, s.
    pub swing_time_s: f64,
    /// RK4 steps per interval (>= 1).
    pub substeps: usize,
    /// Diagonal of Q1 (n), the weight on qd.
    pub q1_diag: Vec<f64>,
    /// Diagonal of R1 (n - 1), the weight on tau.
    pub r1_diag: Vec<f64>,
    /// Start state `[q0, qd0]` (2n), fixed.
    pub x_start: Vec<f64>,
    /// Target bar position, m.
    pub target: [f64; 2],
    /// Box bounds on q and qd (torque limits come from the robot).
    pub bounds: Bounds,
    /// Evaluate half the stages on the problem's helper thread when there are at least this many
    /// (module docs); `usize::MAX` never.
    pub parallel_min_stages: usize,
    /// Impose the clearance rows also at the interior RK4 sub-step states of every interval
    /// (module docs).
    pub substep_clearance: bool,
}

/// Wall time spent in the problem's evaluations, s (accumulated over a solve).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ShootingTimings {
    /// Value-only evaluations (line search).
    pub values_s: f64,
    /// Evaluations with first derivatives.
    pub first_order_s: f64,
    /// Hessian evaluations.
    pub hessian_s: f64,
    /// Number of evaluations with first derivatives.
    pub first_order_calls: usize,
    /// Number of Hessian evaluations.
    pub hessian_calls: usize,
}

/// The classical RK4 tableau: the nodes `c_j` (evaluation j's input is `x + c_j s k_{j-1}` for a
/// step s) and the weights times 6, `b_j` (`x+ = x + s/6 sum_j b_j k_j`).
const RK4_C: [f64; 4] = [0.0, 0.5, 0.5, 1.0];
const RK4_B6: [f64; 4] = [1.0, 2.0, 2.0, 1.0];

/// Data shared by the stages (the helper thread keeps a copy, whose `h` and `free` are refreshed
/// before each of its jobs).
#[derive(Clone)]
struct Ctx {
    n: usize,
    nx: usize,
    nz: usize,
    horizon: usize,
    h: f64,
    substeps: usize,
    q1: Vec<f64>,
    r1: Vec<f64>,
    clearance: Option<DistanceClearanceFn>,
    n_clear: usize,
    /// Clearance rows also at the interior RK4 sub-step states of every interval.
    sub_clear: bool,
    /// A free swing time `[T_min, T_max]` (s): then every state carries T as its last component
    /// (`x_k = [q, qd, T]`, constant along the stages) and stage k's interval is `T_k / K`
    /// ([`SwingOcp::with_free_swing_time`]); `None`: T fixed, the interval is `h`.
    free: Option<[f64; 2]>,
}

impl Ctx {
    /// Trapezoid weight of the state term at stage k for the interval `h`.
    fn state_weight(&self, k: usize, h: f64) -> f64 {
        if k == 0 || k == self.horizon {
            0.5 * h
        } else {
            h
        }
    }

    /// The interval of a stage whose (problem-layout) state is `x`: `T_k / K` with a free swing
    /// time, `h` otherwise.
    fn stage_h(&self, x: &[f64]) -> f64 {
        match self.free {
            Some(_) => x[self.nx] / self.horizon as f64,
            None => self.h,
        }
    }

    /// Sub-step states of an interval that carry clearance rows (`substeps - 1`, or 0).
    fn sub_states(&self) -> usize {
        if self.sub_clear && self.n_clear > 0 {
            self.substeps - 1
        } else {
            0
        }
    }

    /// Clearance rows of stage k: the knot's (k >= 1), then each interior sub-step state's (k < K).
    fn stage_rows(&self, k: usize) -> usize {
        let knot = usize::from(k >= 1);
        let sub = if k < self.horizon {
            self.sub_states()
        } else {
            0
        };
        self.n_clear * (knot + sub)
    }

    /// Size of a stage's state in the problem's layout (`2n`, or `2n + 1` with a free swing time).
    fn nx_problem(&self) -> usize {
        self.nx + usize::from(self.free.is_some())
    }
}

/// Column of internal stage variable `c` (`[q, qd, u]`) in the problem's layout, where a free swing
/// time sits between the state and the input (`[q, qd, T, u]`).
fn col(c: usize, nx: usize, free: bool) -> usize {
    if free && c >= nx {
        c + 1
    } else {
        c
    }
}

/// Per-stage scratch, allocated once.
struct StageWork<D> {
    /// One per RK4 evaluation of the stage, so that the Hessian reuses each evaluation's
    /// factorisation and first derivatives from the forward pass.
    dynamics: Vec<D>,
    clear: Option<ClearanceDerivatives>,
    /// The clearance rows at the knot of the last first-order evaluation, for the Hessian there.
    crec: Option<ClearanceRecord>,
    /// The stage point `[x_k, u_k]` of the recorded forward pass, and whether it is valid.
    rec_z: Vec<f64>,
    rec_valid: bool,
    /// Inputs of the RK4 evaluations, `ne x nz`.
    y: Vec<f64>,
    /// `d qdd / d y` at each evaluation, `ne x (n x nz)`.
    jq: Vec<f64>,
    /// `S_i = d y_i / d z_k`, `ne x (nz x nz)`.
    sens: Vec<f64>,
    /// Current sub-step state and its sensitivity `nx x nz`.
    xs: Vec<f64>,
    xsens: Vec<f64>,
    /// RK4 stage derivatives `4 x nx` and their sensitivities `4 x (nx x nz)`.
    kv: Vec<f64>,
    kz: Vec<f64>,
    /// Input of a value-only evaluation.
    yv: Vec<f64>,
    qdd: Vec<f64>,
    /// Reverse sweep: state adjoint, one transposed-Jacobian product per evaluation, weights.
    abar: Vec<f64>,
    g: Vec<f64>,
    w: Vec<f64>,
    hbuf: Vec<f64>,
    tmp: Vec<f64>,
    /// Clearance Jacobian (`nc x n`) and weighted Hessian (`n x n`).
    cjac: Vec<f64>,
    chess: Vec<f64>,
    /// The state after each RK4 sub-step of the last forward pass, `substeps x nx`.
    xsub: Vec<f64>,
    /// The clearance rows' records at the interior sub-step states, one each.
    crec_sub: Vec<ClearanceRecord>,
    /// Scratch of the sub-step rows: values (`nc`), `J^T mu` (`n`), products (`n x nz`, `n`).
    cval: Vec<f64>,
    cadj: Vec<f64>,
    ctmp: Vec<f64>,
    cvec: Vec<f64>,
    /// The interval of the recorded forward pass, s.
    rec_h: f64,
    /// Free swing time only: each evaluation's acceleration `ne x n`, the derivatives w.r.t. the
    /// interval h of each evaluation's state input `ne x nx` and stage derivative `ne x nx`, and of
    /// Phi (`nx`); the h column of the Hessian (`nz`), a scratch row (`nz`) and the stage's Hessian
    /// in the internal layout (`nz x nz`).
    qdds: Vec<f64>,
    ty: Vec<f64>,
    tk: Vec<f64>,
    tphi: Vec<f64>,
    colh: Vec<f64>,
    vrow: Vec<f64>,
    hint: Vec<f64>,
}

impl<D: PointDynamics> StageWork<D> {
    fn new(robot: &Arc<Robot>, ctx: &Ctx) -> Self {
        let (n, nx, nz) = (ctx.n, ctx.nx, ctx.nz);
        let ne = 4 * ctx.substeps;
        let nc = ctx.n_clear;
        let clear = ctx.clearance.as_ref().map(DistanceClearanceFn::derivatives);
        let crec_sub = match &clear {
            Some(c) => (0..ctx.sub_states()).map(|_| c.record()).collect(),
            None => Vec::new(),
        };
        StageWork {
            dynamics: (0..ne).map(|_| D::new(robot)).collect(),
            crec: clear.as_ref().map(ClearanceDerivatives::record),
            clear,
            rec_z: vec![0.0; nz],
            rec_valid: false,
            y: vec![0.0; ne * nz],
            jq: vec![0.0; ne * n * nz],
            sens: vec![0.0; ne * nz * nz],
            xs: vec![0.0; nx],
            xsens: vec![0.0; nx * nz],
            kv: vec![0.0; 4 * nx],
            kz: vec![0.0; 4 * nx * nz],
            yv: vec![0.0; nz],
            qdd: vec![0.0; n],
            abar: vec![0.0; nx],
            g: vec![0.0; 4 * nx],
            w: vec![0.0; 4 * nx],
            hbuf: vec![0.0; nz * nz],
            tmp: vec![0.0; nz * nz],
            cjac: vec![0.0; nc * n],
            chess: vec![0.0; n * n],
            xsub: vec![0.0; ctx.substeps * nx],
            crec_sub,
            cval: vec![0.0; nc],
            cadj: vec![0.0; n],
            ctmp: vec![0.0; n * nz],
            cvec: vec![0.0; n],
            rec_h: 0.0,
            qdds: vec![0.0; ne * n],
            ty: vec![0.0; ne * nx],
            tk: vec![0.0; ne * nx],
            tphi: vec![0.0; nx],
            colh: vec![0.0; nz],
            vrow: vec![0.0; nz],
            hint: vec![0.0; nz * nz],
        }
    }

    /// Integrate `Phi(x, u)` over the interval `h` into `self.xs`; with `jac`, also record every
    /// evaluation and leave `d Phi / d z` in `self.xsens` (and, with a free swing time, the
    /// derivatives w.r.t. h in `self.ty`, `self.tk` and `self.tphi`).
    fn forward(&mut self, ctx: &Ctx, x: &[f64], u: &[f64], jac: bool, h: f64) {
        // the paper's 4 links with constant sizes (unrolled loops), any other count through the
        // same body: the same arithmetic either way
        with_link_count!(ctx.n, |n| self.forward_n(ctx, x, u, jac, n, h));
        if jac && ctx.free.is_some() {
            self.tangent(ctx, h);
        }
    }

    /// The derivatives w.r.t. the interval h at the recorded forward pass (x and u fixed): of each
    /// RK4 evaluation's state input (`ty`) and stage derivative (`tk`), and of Phi (`tphi`). The
    /// step h enters RK4 only through the coefficients of `y_j = x_s + c_j (h/m) k_{j-1}` and
    /// `x_{s+1} = x_s + (h/6m) sum b_j k_j`, so `ty_j = tx_s + c_j (h/m) tk_{j-1} + (c_j/m) k_{j-1}`
    /// and `tk_j = F_y(y_j) [ty_j; 0]`.
    fn tangent(&mut self, ctx: &Ctx, h: f64) {
        let (n, nx, nz) = (ctx.n, ctx.nx, ctx.nz);
        let m = ctx.substeps as f64;
        let hs = h / m;
        let coef = RK4_C.map(|c| c * hs);
        let dcoef = RK4_C.map(|c| c / m);
        let (c6, dc6) = (hs / 6.0, 1.0 / (6.0 * m));
        let bw = RK4_B6;
        // stage derivative k_i = [qd part of y_i, qdd_i]
        let kval = |y: &[f64], qdds: &[f64], i: usize, a: usize| {
            if a < n {
                y[i * nz + n + a]
            } else {
                qdds[i * n + a - n]
            }
        };
        self.tphi[..nx].fill(0.0);
        for s in 0..ctx.substeps {
            for j in 0..4 {
                let i = 4 * s + j;
                for a in 0..nx {
                    let mut v = self.tphi[a];
                    if j > 0 {
                        v += coef[j] * self.tk[(i - 1) * nx + a]
                            + dcoef[j] * kval(&self.y, &self.qdds, i - 1, a);
                    }
                    self.ty[i * nx + a] = v;
                }
                let (ty, tk) = (
                    &self.ty[i * nx..(i + 1) * nx],
                    &mut self.tk[i * nx..(i + 1) * nx],
                );
                tk[..n].copy_from_slice(&ty[n..]);
                let jq = &self.jq[i * n * nz..(i + 1) * n * nz];
                for r in 0..n {
                    let mut v = 0.0;
                    for c in 0..nx {
                        v += jq[r * nz + c] * ty[c];
                    }
                    tk[n + r] = v;
                }
            }
            for a in 0..nx {
                let (mut dv, mut kv) = (0.0, 0.0);
                for (j, b) in bw.iter().enumerate() {
                    let i = 4 * s + j;
                    dv += b * self.tk[i * nx + a];
                    kv += b * kval(&self.y, &self.qdds, i, a);
                }
                self.tphi[a] += c6 * dv + dc6 * kv;
            }
        }
    }

    /// [`Self::forward`] with the link count `n = ctx.n` as an argument (a stage with inputs:
    /// `nx = 2n`, `nz = 3n - 1`).
    #[inline(always)]
    fn forward_n(&mut self, ctx: &Ctx, x: &[f64], u: &[f64], jac: bool, n: usize, h: f64) {
        let (nx, nz) = (2 * n, 3 * n - 1);
        debug_assert!(ctx.nx == nx && ctx.nz == nz && u.len() == nz - nx);
        let (x, u) = (&x[..nx], &u[..nz - nx]);
        let ne = 4 * ctx.substeps;
        let (xs, xsens) = (&mut self.xs[..nx], &mut self.xsens[..nx * nz]);
        let (kv, kza) = (&mut self.kv[..4 * nx], &mut self.kz[..4 * nx * nz]);
        let (yv, qdd) = (&mut self.yv[..nz], &mut self.qdd[..n]);
        let (ya, jqa) = (&mut self.y[..ne * nz], &mut self.jq[..ne * n * nz]);
        let sensa = &mut self.sens[..ne * nz * nz];
        let hs = h / ctx.substeps as f64;
        let coef = RK4_C.map(|c| c * hs);
        xs.copy_from_slice(x);
        if jac {
            xsens.fill(0.0);
            for a in 0..nx {
                xsens[a * nz + a] = 1.0;
            }
        }
        for s in 0..ctx.substeps {
            for j in 0..4 {
                let i = 4 * s + j;
                let y = if jac {
                    &mut ya[i * nz..(i + 1) * nz]
                } else {
                    &mut yv[..]
                };
                if j == 0 {
                    y[..nx].copy_from_slice(xs);
                } else {
                    let kp = &kv[(j - 1) * nx..j * nx];
                    for a in 0..nx {
                        y[a] = xs[a] + coef[j] * kp[a];
                    }
                }
                y[nx..].copy_from_slice(u);
                if jac {
                    let sens = &mut sensa[i * nz * nz..(i + 1) * nz * nz];
                    if j == 0 {
                        sens[..nx * nz].copy_from_slice(xsens);
                    } else {
                        let kzp = &kza[(j - 1) * nx * nz..j * nx * nz];
                        for e in 0..nx * nz {
                            sens[e] = xsens[e] + coef[j] * kzp[e];
                        }
                    }
                    sens[nx * nz..].fill(0.0);
                    for m in 0..nz - nx {
                        sens[(nx + m) * nz + nx + m] = 1.0;
                    }
                    let jq = &mut jqa[i * n * nz..(i + 1) * n * nz];
                    self.dynamics[i].jacobian(y, qdd, jq);
                    // K_j = [S_i rows n..2n ; Jq S_i]
                    let kz = &mut kza[j * nx * nz..(j + 1) * nx * nz];
                    let (kq, kqd) = kz.split_at_mut(n * nz);
                    kq.copy_from_slice(&sens[n * nz..2 * n * nz]);
                    if i == 0 {
                        // the stage's first evaluation: S_0 = I, the product is Jq itself
                        kqd.copy_from_slice(jq);
                    } else {
                        // Jq_x Sx row by row; the input rows of S_i are [0 I]: their products are
                        // the input columns of Jq
                        kqd.fill(0.0);
                        for (out, jr) in kqd.chunks_exact_mut(nz).zip(jq.chunks_exact(nz)) {
                            add_lincomb(out, jr, 1, sens, nz, nx);
                        }
                        for (out, jr) in kqd.chunks_exact_mut(nz).zip(jq.chunks_exact(nz)) {
                            for (o, &a) in out[nx..].iter_mut().zip(&jr[nx..]) {
                                *o += a;
                            }
                        }
                    }
                    self.qdds[i * n..(i + 1) * n].copy_from_slice(qdd);
                } else {
                    self.dynamics[i].value(y, qdd);
                }
                let k = &mut kv[j * nx..(j + 1) * nx];
                k[..n].copy_from_slice(&y[n..nx]);
                k[n..].copy_from_slice(qdd);
            }
            let c6 = hs / 6.0;
            let (k1, rest) = kv.split_at(nx);
            let (k2, rest) = rest.split_at(nx);
            let (k3, k4) = rest.split_at(nx);
            for a in 0..nx {
                xs[a] += c6 * (k1[a] + 2.0 * k2[a] + 2.0 * k3[a] + k4[a]);
            }
            self.xsub[s * nx..(s + 1) * nx].copy_from_slice(xs);
            if jac {
                let m = nx * nz;
                let (z1, rest) = kza.split_at(m);
                let (z2, rest) = rest.split_at(m);
                let (z3, z4) = rest.split_at(m);
                for e in 0..m {
                    xsens[e] += c6 * (z1[e] + 2.0 * z2[e] + 2.0 * z3[e] + z4[e]);
                }
            }
        }
        if jac {
            self.rec_z[..nx].copy_from_slice(x);
            self.rec_z[nx..].copy_from_slice(u);
            self.rec_h = h;
            self.rec_valid = true;
        }
    }

    /// Cost, dynamics and clearance of stage k into `ev` (problem layout: with a free swing time
    /// `x` is `[q, qd, T]` and the stage variables `[q, qd, T, u]`).
    fn evaluate(
        &mut self,
        ctx: &Ctx,
        k: usize,
        x: &[f64],
        u: &[f64],
        level: EvalLevel,
        ev: &mut StageEval,
    ) {
        let (n, nx) = (ctx.n, ctx.nx);
        let free = ctx.free.is_some();
        let nxp = ctx.nx_problem();
        let h = ctx.stage_h(x);
        let first = level == EvalLevel::FirstOrder;
        let wq = ctx.state_weight(k, h);
        let mut cost = 0.0;
        for i in 0..n {
            cost += wq * ctx.q1[i] * x[n + i] * x[n + i];
        }
        for (j, &v) in u.iter().enumerate() {
            cost += h * ctx.r1[j] * v * v;
        }
        ev.cost = cost;
        if first {
            ev.grad.fill(0.0);
            for i in 0..n {
                ev.grad[n + i] = 2.0 * wq * ctx.q1[i] * x[n + i];
            }
            for (j, &v) in u.iter().enumerate() {
                ev.grad[nxp + j] = 2.0 * h * ctx.r1[j] * v;
            }
            if free {
                // the cost is linear in h = T / K
                ev.grad[nx] = cost / (h * ctx.horizon as f64);
            }
        }
        if k < ctx.horizon {
            self.forward(ctx, x, u, first, h);
            ev.f[..nx].copy_from_slice(&self.xs);
            if free {
                ev.f[nx] = x[nx];
            }
            if first {
                if free {
                    let (nz, nzp) = (ctx.nz, ctx.nz + 1);
                    let kf = ctx.horizon as f64;
                    ev.jac_f.fill(0.0);
                    for a in 0..nx {
                        let row = &mut ev.jac_f[a * nzp..(a + 1) * nzp];
                        for c in 0..nz {
                            row[col(c, nx, true)] = self.xsens[a * nz + c];
                        }
                        row[nx] = self.tphi[a] / kf;
                    }
                    ev.jac_f[nx * nzp + nx] = 1.0;
                } else {
                    ev.jac_f.copy_from_slice(&self.xsens);
                }
            }
        }
        let nc = ctx.n_clear;
        let nzk = ev.grad.len();
        if first && ctx.stage_rows(k) > 0 {
            ev.jac_c.fill(0.0);
        }
        if let (Some(cd), true) = (&self.clear, k >= 1) {
            if first {
                let rec = self
                    .crec
                    .as_mut()
                    .expect("a record with the clearance rows");
                cd.jacobian_recorded(&x[..n], &mut ev.c[..nc], &mut self.cjac, rec);
                for r in 0..nc {
                    ev.jac_c[r * nzk..r * nzk + n].copy_from_slice(&self.cjac[r * n..(r + 1) * n]);
                }
            } else {
                cd.value(&x[..n], &mut ev.c[..nc]);
            }
        }
        if k < ctx.horizon {
            self.substep_rows(ctx, k, first, ev);
        }
    }

    /// The clearance rows at the interior sub-step states of stage k's last forward pass (made
    /// with first derivatives when `first`) into `ev.c` and `ev.jac_c` after the knot's rows:
    /// `c(q_s)` and `J(q_s) S_s` (`S_s` the q rows of the sub-step state's sensitivity; with a free
    /// swing time, its T column `J(q_s) ty_s / K`).
    fn substep_rows(&mut self, ctx: &Ctx, k: usize, first: bool, ev: &mut StageEval) {
        let Some(cd) = &self.clear else { return };
        let (n, nx, nz, nc) = (ctx.n, ctx.nx, ctx.nz, ctx.n_clear);
        let free = ctx.free.is_some();
        let nzk = ev.grad.len();
        let knot = if k >= 1 { nc } else { 0 };
        for s in 0..ctx.sub_states() {
            let q = &self.xsub[s * nx..s * nx + n];
            let off = knot + s * nc;
            if !first {
                cd.value(q, &mut ev.c[off..off + nc]);
                continue;
            }
            cd.jacobian_recorded(
                q,
                &mut ev.c[off..off + nc],
                &mut self.cjac,
                &mut self.crec_sub[s],
            );
            // the state after sub-step s starts sub-step s + 1: evaluation 4 (s + 1)
            let i = 4 * (s + 1);
            let sens = &self.sens[i * nz * nz..i * nz * nz + n * nz];
            for r in 0..nc {
                let row = &mut ev.jac_c[(off + r) * nzk..(off + r + 1) * nzk];
                let jr = &self.cjac[r * n..(r + 1) * n];
                for (a, &ja) in jr.iter().enumerate() {
                    if ja == 0.0 {
                        continue;
                    }
                    for (c, &sv) in sens[a * nz..(a + 1) * nz].iter().enumerate() {
                        row[col(c, nx, free)] += ja * sv;
                    }
                }
                if free {
                    let ty = &self.ty[i * nx..i * nx + n];
                    let dt: f64 = jr.iter().zip(ty).map(|(a, b)| a * b).sum();
                    row[nx] = dt / ctx.horizon as f64;
                }
            }
        }
    }

    /// The sub-step rows' part of the Hessian in the reverse sweep of [`Self::hessian_internal`],
    /// at the state after sub-step `s` (interior), with their multipliers `mu_s`: adds `J^T mu_s`
    /// to the state adjoint `abar` (the second-order term through the flow), the upper triangle of
    /// `S^T [Hess mu_s . c] S` to `hess` (`nz x nz`) and, with a free swing time, its h column
    /// `S^T H ty` to `colh`; returns `ty^T H ty` (0 with a fixed swing time).
    fn substep_hessian(&mut self, ctx: &Ctx, s: usize, mu_s: &[f64], hess: &mut [f64]) -> f64 {
        let Some(cd) = &self.clear else { return 0.0 };
        let (n, nx, nz, nc) = (ctx.n, ctx.nx, ctx.nz, ctx.n_clear);
        if mu_s.iter().all(|&m| m == 0.0) {
            return 0.0;
        }
        // the recorded forward pass's state after sub-step s: the input of evaluation 4 (s + 1)
        // (`xsub` may hold a later value-only pass)
        let i = 4 * (s + 1);
        let q = &self.y[i * nz..i * nz + n];
        cd.jacobian_recorded(q, &mut self.cval, &mut self.cjac, &mut self.crec_sub[s]);
        for a in 0..n {
            let mut v = 0.0;
            for r in 0..nc {
                v += mu_s[r] * self.cjac[r * n + a];
            }
            self.cadj[a] = v;
        }
        for a in 0..n {
            self.abar[a] += self.cadj[a];
        }
        cd.hessian_weighted_recorded(q, mu_s, &mut self.chess, &self.crec_sub[s]);
        let sens = &self.sens[i * nz * nz..i * nz * nz + n * nz];
        // T = H S (n x nz), then S^T T on the upper triangle
        let t = &mut self.ctmp[..n * nz];
        t.fill(0.0);
        for r in 0..n {
            for c in 0..n {
                let hv = self.chess[r * n + c];
                if hv == 0.0 {
                    continue;
                }
                for e in 0..nz {
                    t[r * nz + e] += hv * sens[c * nz + e];
                }
            }
        }
        for r in 0..n {
            let srow = &sens[r * nz..(r + 1) * nz];
            let trow = &t[r * nz..(r + 1) * nz];
            for a in 0..nz {
                let sa = srow[a];
                if sa == 0.0 {
                    continue;
                }
                for b in a..nz {
                    hess[a * nz + b] += sa * trow[b];
                }
            }
        }
        if ctx.free.is_none() {
            return 0.0;
        }
        let ty = &self.ty[i * nx..i * nx + n];
        let hty = &mut self.cvec[..n];
        for r in 0..n {
            hty[r] = (0..n).map(|c| self.chess[r * n + c] * ty[c]).sum();
        }
        for c in 0..nz {
            let mut v = 0.0;
            for r in 0..n {
                v += sens[r * nz + c] * hty[r];
            }
            self.colh[c] += v;
        }
        ty.iter().zip(hty.iter()).map(|(a, b)| a * b).sum()
    }

    /// Hessian of `sigma l_k + lam^T Phi + mu^T c` w.r.t. z_k into `hess` (nz_k x nz_k, problem
    /// layout).
    #[allow(clippy::too_many_arguments)]
    fn hessian(
        &mut self,
        ctx: &Ctx,
        k: usize,
        x: &[f64],
        u: &[f64],
        sigma: f64,
        lam: &[f64],
        mu: &[f64],
        hess: &mut [f64],
    ) {
        if ctx.free.is_none() {
            self.hessian_internal(ctx, k, x, u, sigma, lam, mu, ctx.h, hess);
            return;
        }
        // free swing time: the Hessian in [q, qd, u] (with its h column in `colh` and the h-h entry
        // returned), then spread into [q, qd, T, u] with d/dT = (1/K) d/dh
        let (n, nx) = (ctx.n, ctx.nx);
        let h = ctx.stage_h(x);
        let kf = ctx.horizon as f64;
        let nzi = nx + u.len();
        let nzp = nzi + 1;
        let mut hint = std::mem::take(&mut self.hint);
        let hh = self.hessian_internal(
            ctx,
            k,
            &x[..nx],
            u,
            sigma,
            &lam[..lam.len().min(nx)],
            mu,
            h,
            &mut hint[..nzi * nzi],
        );
        hess.fill(0.0);
        for a in 0..nzi {
            for b in 0..nzi {
                hess[col(a, nx, true) * nzp + col(b, nx, true)] = hint[a * nzi + b];
            }
        }
        self.hint = hint;
        let t = nx;
        if k < ctx.horizon {
            for c in 0..nzi {
                let v = self.colh[c] / kf;
                let e = col(c, nx, true);
                hess[t * nzp + e] += v;
                hess[e * nzp + t] += v;
            }
            hess[t * nzp + t] += hh / (kf * kf);
        }
        // the cost is linear in h: d^2 l / dT dz = (d l / dz) / T
        let wq = ctx.state_weight(k, h);
        let tt = h * kf;
        for i in 0..n {
            let v = sigma * 2.0 * wq * ctx.q1[i] * x[n + i] / tt;
            hess[t * nzp + n + i] += v;
            hess[(n + i) * nzp + t] += v;
        }
        for (j, &uj) in u.iter().enumerate() {
            let v = sigma * 2.0 * h * ctx.r1[j] * uj / tt;
            hess[t * nzp + nx + 1 + j] += v;
            hess[(nx + 1 + j) * nzp + t] += v;
        }
    }

    /// [`Self::hessian`] in the internal layout `[q, qd, u]` (`x` the 2n state, `lam` 2n) for the
    /// interval `h`. With a free swing time it also leaves the mixed derivatives
    /// `d^2 (lam^T Phi) / dz dh` in `self.colh` (nz) and returns `d^2 (lam^T Phi) / dh^2` (0 otherwise):
    /// by the second-order adjoint, each RK4 evaluation i adds `S_i^T (Hq_i [ty_i; 0] + F_y(y_i)^T w_i / h)`
    /// and `ty_i^T Hq_i ty_i + 2 w_i . tk_i / h` (the coefficients of the combinations are `h` times
    /// constants, whose adjoint weights are the stage derivatives' `w_i`; docs/planner.md, "Free swing time").
    #[allow(clippy::too_many_arguments)]
    fn hessian_internal(
        &mut self,
        ctx: &Ctx,
        k: usize,
        x: &[f64],
        u: &[f64],
        sigma: f64,
        lam: &[f64],
        mu: &[f64],
        h: f64,
        hess: &mut [f64],
    ) -> f64 {
        let (n, nx) = (ctx.n, ctx.nx);
        let free = ctx.free.is_some();
        let nzk = nx + u.len();
        let mut hh = 0.0;
        hess.fill(0.0);
        if k < ctx.horizon {
            let nz = ctx.nz;
            let current = self.rec_valid
                && self.rec_h == h
                && self.rec_z[..nx] == *x
                && self.rec_z[nx..] == *u;
            if !current {
                self.forward(ctx, x, u, true, h);
            }
            if free {
                self.colh.fill(0.0);
            }
            let hs = h / ctx.substeps as f64;
            self.abar.copy_from_slice(lam);
            let knot = if k >= 1 { ctx.n_clear } else { 0 };
            for s in (0..ctx.substeps).rev() {
                if s < ctx.sub_states() {
                    // the clearance rows at the state after sub-step s (its adjoint is `abar` now)
                    let off = knot + s * ctx.n_clear;
                    hh += self.substep_hessian(ctx, s, &mu[off..off + ctx.n_clear], hess);
                }
                // Reverse sweep through the four evaluations of sub-step s (j = 3, 2, 1, 0):
                // w_j = b_j hs abar + a_{j+1} hs g_{j+1}, g_j = F_x(y_j)^T w_j.
                let b = [hs / 6.0, hs / 3.0, hs / 3.0, hs / 6.0];
                let a_next = [RK4_C[1] * hs, RK4_C[2] * hs, RK4_C[3] * hs];
                for j in (0..4).rev() {
                    for e in 0..nx {
                        let mut v = b[j] * self.abar[e];
                        if j < 3 {
                            v += a_next[j] * self.g[(j + 1) * nx + e];
                        }
                        self.w[j * nx + e] = v;
                    }
                    let i = 4 * s + j;
                    let jq = &self.jq[i * n * nz..(i + 1) * n * nz];
                    let (w, g) = (
                        &self.w[j * nx..(j + 1) * nx],
                        &mut self.g[j * nx..(j + 1) * nx],
                    );
                    fx_transpose_times(n, nz, jq, w, g);
                    // S_i^T [Hess (w_v . qdd)(y_i)] S_i
                    let y = &self.y[i * nz..(i + 1) * nz];
                    self.dynamics[i].hessian_weighted_reuse(
                        y,
                        &self.w[j * nx + n..(j + 1) * nx],
                        &mut self.hbuf,
                    );
                    let sens = &self.sens[i * nz * nz..(i + 1) * nz * nz];
                    add_sandwich_upper(nx, nz, sens, i, &self.hbuf, &mut self.tmp, hess);
                    if free {
                        hh += self.h_terms(ctx, i, j, h);
                    }
                }
                for j in 0..4 {
                    for e in 0..nx {
                        self.abar[e] += self.g[j * nx + e];
                    }
                }
            }
            // the sum of S^T H S was accumulated on the upper triangle: mirror it (exactly symmetric)
            for a in 0..nz {
                for b in 0..a {
                    hess[a * nz + b] = hess[b * nz + a];
                }
            }
        }
        let wq = ctx.state_weight(k, h);
        for i in 0..n {
            hess[(n + i) * nzk + n + i] += 2.0 * sigma * wq * ctx.q1[i];
        }
        for j in 0..u.len() {
            hess[(nx + j) * nzk + nx + j] += 2.0 * sigma * h * ctx.r1[j];
        }
        if let (Some(cd), true) = (&self.clear, k >= 1) {
            let rec = self
                .crec
                .as_ref()
                .expect("a record with the clearance rows");
            cd.hessian_weighted_recorded(&x[..n], &mu[..ctx.n_clear], &mut self.chess, rec);
            for a in 0..n {
                for b in 0..n {
                    hess[a * nzk + b] += self.chess[a * n + b];
                }
            }
        }
        hh
    }

    /// The h terms of RK4 evaluation i (sub-step position j) in the reverse sweep, with its weights
    /// `w_j`, its state adjoint `g_j` and its `Hq_i` in `hbuf` (see [`Self::hessian_internal`]):
    /// adds `S_i^T v` to `colh`, `v = Hq_i [ty_i; 0] + [g_j; Jq_u^T w_j[n..]] / h`, and returns
    /// `ty_i^T Hq_i ty_i + 2 w_j . tk_i / h`.
    fn h_terms(&mut self, ctx: &Ctx, i: usize, j: usize, h: f64) -> f64 {
        let (n, nx, nz) = (ctx.n, ctx.nx, ctx.nz);
        let ty = &self.ty[i * nx..(i + 1) * nx];
        let tk = &self.tk[i * nx..(i + 1) * nx];
        let w = &self.w[j * nx..(j + 1) * nx];
        let g = &self.g[j * nx..(j + 1) * nx];
        let jq = &self.jq[i * n * nz..(i + 1) * n * nz];
        let hq = &self.hbuf[..nz * nz];
        let v = &mut self.vrow[..nz];
        // Hq [ty; 0] by its first nx rows (Hq is symmetric; those rows are filled in full)
        v.fill(0.0);
        for (c, &t) in ty.iter().enumerate() {
            let hrow = &hq[c * nz..(c + 1) * nz];
            for a in 0..nz {
                v[a] += hrow[a] * t;
            }
        }
        let mut hh = 0.0;
        for a in 0..nx {
            hh += ty[a] * v[a];
        }
        for a in 0..nx {
            hh += 2.0 * w[a] * tk[a] / h;
            v[a] += g[a] / h;
        }
        for m in 0..nz - nx {
            let mut sum = 0.0;
            for r in 0..n {
                sum += jq[r * nz + nx + m] * w[n + r];
            }
            v[nx + m] += sum / h;
        }
        let sens = &self.sens[i * nz * nz..(i + 1) * nz * nz];
        for (r, &vr) in v.iter().enumerate() {
            if vr == 0.0 {
                continue;
            }
            let srow = &sens[r * nz..(r + 1) * nz];
            for c in 0..nz {
                self.colh[c] += srow[c] * vr;
            }
        }
        hh
    }
}

/// `g = F_x^T w` for `F_x = [[0, I], [Jq_x]]` (`2n x 2n`; `Jq` row-major `n x nz`, its first `2n`
/// columns `Jq_x`): `g_e = [e >= n] w_{e-n} + sum_r Jq[r][e] w_{n+r}`.
fn fx_transpose_times(n: usize, nz: usize, jq: &[f64], w: &[f64], g: &mut [f64]) {
    // the paper's 4 links with constant sizes (unrolled, no bounds checks), any other count
    // through the same body: the same arithmetic either way
    match (n, nz) {
        (4, 11) => fx_transpose_times_body(4, 11, jq, w, g),
        _ => fx_transpose_times_body(n, nz, jq, w, g),
    }
}

#[inline(always)]
fn fx_transpose_times_body(n: usize, nz: usize, jq: &[f64], w: &[f64], g: &mut [f64]) {
    let nx = 2 * n;
    let (jq, w, g) = (&jq[..n * nz], &w[..nx], &mut g[..nx]);
    g[..n].fill(0.0);
    g[n..].copy_from_slice(&w[..n]);
    add_lincomb(g, &w[n..], 1, jq, nz, n);
}

/// Add the upper triangle (`a <= b`) of `S^T H S` to `hess` (`nz x nz` row-major), for an evaluation's
/// sensitivity `S = [Sx; 0 I]` (`Sx` its first `nx` rows, `nz x nz` in all) and the symmetric Hessian `H`
/// of `w . qdd` at that evaluation. With `H = [Hxx Hxu; Hux Huu]`:
/// `S^T H S = Sx^T Hxx Sx + Sx^T Hxu E + E^T Hux Sx + E^T Huu E`, `E = [0 I]` (the input rows), so
/// the input rows of `S` are never multiplied. `i`: the evaluation's index in the stage; the first
/// (`i = 0`) has `S = I` (`H` itself), the second (`i = 1`, `y = x + (h/2) k_1` with `k_1`'s q rows
/// the qd rows of `S = I`) has the q rows of `Sx` zero but at columns `r` and `n + r` (checked): the
/// products with those zeros are skipped (they would add exact zeros). `tmp` holds at least
/// `(nx + nu) nz` values.
fn add_sandwich_upper(
    nx: usize,
    nz: usize,
    sens: &[f64],
    i: usize,
    h: &[f64],
    tmp: &mut [f64],
    hess: &mut [f64],
) {
    let half = nx / 2;
    let identity = i == 0;
    let sparse_q = i == 1
        && (0..half).all(|r| {
            sens[r * nz..(r + 1) * nz]
                .iter()
                .enumerate()
                .all(|(c, &v)| c == r || c == half + r || v == 0.0)
        });
    // the paper's 4-link robot with constant sizes (unrolled, no bounds checks), any other size
    // through the same code with run-time sizes
    match (nx, nz, sparse_q) {
        (8, 11, false) => sandwich_upper_body::<false>(8, 11, sens, identity, h, tmp, hess),
        (8, 11, true) => sandwich_upper_body::<true>(8, 11, sens, identity, h, tmp, hess),
        (_, _, false) => sandwich_upper_body::<false>(nx, nz, sens, identity, h, tmp, hess),
        (_, _, true) => sandwich_upper_body::<true>(nx, nz, sens, identity, h, tmp, hess),
    }
}

#[inline(always)]
fn sandwich_upper_body<const SPARSE_Q: bool>(
    nx: usize,
    nz: usize,
    sens: &[f64],
    identity: bool,
    h: &[f64],
    tmp: &mut [f64],
    hess: &mut [f64],
) {
    let nu = nz - nx;
    let h = &h[..nz * nz];
    let hess = &mut hess[..nz * nz];
    if identity {
        for a in 0..nz {
            for b in a..nz {
                hess[a * nz + b] += h[a * nz + b];
            }
        }
        return;
    }
    let sx = &sens[..nx * nz];
    let (t, rest) = tmp.split_at_mut(nx * nz);
    let g = &mut rest[..nz * nu];
    // T = Hxx Sx (nx x nz), G = Sx^T Hxu (nz x nu). Rows of Hxu that are exactly zero add nothing to
    // G: the second half of x (qd) when qd and tau never multiply in qdd (true of the dynamics;
    // checked, so any H is right)
    let half = nx / 2;
    let g_rows = if (half..nx).all(|r| h[r * nz + nx..(r + 1) * nz].iter().all(|&v| v == 0.0)) {
        half
    } else {
        nx
    };
    t.fill(0.0);
    g.fill(0.0);
    // with `SPARSE_Q`, the q rows c < half of Sx have their non-zeros at c and half + c only: the
    // terms with the other entries (exact zeros) are left out, every other term in the same order
    for r in 0..nx {
        let out = &mut t[r * nz..(r + 1) * nz];
        for c in 0..nx {
            let hv = h[r * nz + c];
            let srow = &sx[c * nz..(c + 1) * nz];
            if SPARSE_Q && c < half {
                out[c] += hv * srow[c];
                out[half + c] += hv * srow[half + c];
                continue;
            }
            for e in 0..nz {
                out[e] += hv * srow[e];
            }
        }
        if r >= g_rows {
            continue;
        }
        let srow = &sx[r * nz..(r + 1) * nz];
        let hrow = &h[r * nz + nx..(r + 1) * nz];
        if SPARSE_Q && r < half {
            for a in [r, half + r] {
                let sa = srow[a];
                let grow = &mut g[a * nu..(a + 1) * nu];
                for m in 0..nu {
                    grow[m] += sa * hrow[m];
                }
            }
            continue;
        }
        for a in 0..nz {
            let sa = srow[a];
            let grow = &mut g[a * nu..(a + 1) * nu];
            for m in 0..nu {
                grow[m] += sa * hrow[m];
            }
        }
    }
    // Sx^T T, upper triangle
    for r in 0..nx {
        let srow = &sx[r * nz..(r + 1) * nz];
        let trow = &t[r * nz..(r + 1) * nz];
        if SPARSE_Q && r < half {
            for a in [r, half + r] {
                let sa = srow[a];
                let out = &mut hess[a * nz..(a + 1) * nz];
                for b in a..nz {
                    out[b] += sa * trow[b];
                }
            }
            continue;
        }
        for a in 0..nz {
            let sa = srow[a];
            let out = &mut hess[a * nz..(a + 1) * nz];
            for b in a..nz {
                out[b] += sa * trow[b];
            }
        }
    }
    // G into the input columns (a, nx + m), its mirror E^T Hux Sx on the entries (nx + m, a), a >= nx + m
    for a in 0..nz {
        for m in 0..nu {
            let v = g[a * nu + m];
            let col = nx + m;
            if a <= col {
                hess[a * nz + col] += v;
            }
            if a >= col {
                hess[col * nz + a] += v;
            }
        }
    }
    // E^T Huu E
    for a in nx..nz {
        for b in a..nz {
            hess[a * nz + b] += h[a * nz + b];
        }
    }
}

/// What the helper thread computes for its stages.
#[derive(Debug, Clone, Copy)]
enum TailJob {
    /// [`StageWork::evaluate`] at this level.
    Evaluate(EvalLevel),
    /// [`StageWork::hessian`] with this cost factor.
    Hessian(f64),
}

/// The stages `first..=K` of a [`SwingOcp`] with a helper thread: their scratch, and copies of
/// their inputs and outputs (allocated once; the owner copies in before and out after each job).
struct Tail<D> {
    first: usize,
    ctx: Ctx,
    work: Vec<StageWork<D>>,
    zx: Vec<Vec<f64>>,
    zu: Vec<Vec<f64>>,
    lam: Vec<Vec<f64>>,
    mu: Vec<Vec<f64>>,
    out: Vec<StageEval>,
    job: TailJob,
}

impl TailJob {
    /// Run the job on stage k (its scratch `w`, point `x`, `u`, multipliers `lam`, `mu`: read by a
    /// Hessian job only).
    #[allow(clippy::too_many_arguments)]
    fn run<D: PointDynamics>(
        self,
        w: &mut StageWork<D>,
        ctx: &Ctx,
        k: usize,
        x: &[f64],
        u: &[f64],
        lam: &[f64],
        mu: &[f64],
        ev: &mut StageEval,
    ) {
        match self {
            TailJob::Evaluate(level) => w.evaluate(ctx, k, x, u, level, ev),
            TailJob::Hessian(sigma) => w.hessian(ctx, k, x, u, sigma, lam, mu, &mut ev.hess),
        }
    }
}

/// Entry k of per-stage multipliers, empty where there are none (an evaluation job).
fn at(v: &[Vec<f64>], k: usize) -> &[f64] {
    v.get(k).map_or(&[], Vec::as_slice)
}

impl<D: PointDynamics> Job for Tail<D> {
    fn run(&mut self) {
        for (j, w) in self.work.iter_mut().enumerate() {
            let (x, u) = (&self.zx[j], &self.zu[j]);
            let (lam, mu) = (&self.lam[j], &self.mu[j]);
            let ev = &mut self.out[j];
            self.job
                .run(w, &self.ctx, self.first + j, x, u, lam, mu, ev);
        }
    }
}

/// The swing as an [`OcpProblem`] by multiple shooting (see the module docs). Generic over the source
/// of the per-point dynamics derivatives.
pub struct SwingOcp<D: PointDynamics = AnalyticDynamics> {
    ctx: Ctx,
    /// The scratch of stages `0..first` ([`Tail::first`]; all stages without a helper thread).
    work: Vec<StageWork<D>>,
    /// The stages `first..=K`, evaluated on the helper thread.
    tail: Option<SpinWorker<Tail<D>>>,
    dims: OcpDims,
    x_start: Vec<f64>,
    target: [f64; 2],
    bounds: Bounds,
    /// A box `[lo, hi]` on each of the 2n state components at the last knot (rad, rad/s),
    /// intersected with that knot's bounds (`None`: those bounds alone).
    end_box: Option<Vec<[f64; 2]>>,
    tau_lo: Vec<f64>,
    tau_hi: Vec<f64>,
    guess: Primal,
    term_fn: EeTerminalFn,
    term: Diff<EeTerminalFn>,
    term_val: Vec<f64>,
    term_jac: Vec<f64>,
    term_hess: Vec<f64>,
    /// The clearance rows at the start pose (the lower bound of stage 0's sub-step rows is
    /// `min(0, start_c)`).
    start_c: Vec<f64>,
    /// Wall time spent in evaluations since construction (or the last reset by the caller).
    pub timings: ShootingTimings,
}

impl SwingOcp {
    /// Build the problem for `robot` with the closed-form per-point derivatives ([`AnalyticDynamics`]; see
    /// [`SwingOcp::with_dynamics`] for the arguments and errors).
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        spec: SwingOcpSpec,
        clearance: Option<DistanceClearanceFn>,
    ) -> Result<Self> {
        Self::with_dynamics(robot, spec, clearance)
    }
}

impl<D: PointDynamics> SwingOcp<D> {
    /// Build the problem for `robot` with per-point derivatives from `D`. `clearance` gives the stage
    /// inequalities (rows on q_k, k >= 1; `None`: none). The initial guess is zero but for the start
    /// state (set it with [`SwingOcp::guess_mut`]). Errors on sizes that do not match the robot,
    /// `intervals` or `substeps` of 0, or a swing time that is not finite and positive.
    pub fn with_dynamics(
        robot: impl Into<Arc<Robot>>,
        spec: SwingOcpSpec,
        clearance: Option<DistanceClearanceFn>,
    ) -> Result<Self> {
        let robot: Arc<Robot> = robot.into();
        let n = robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let src = "<shooting>";
        for (what, expected, got) in [
            ("shooting: x_start", nx, spec.x_start.len()),
            ("shooting: q1_diag", n, spec.q1_diag.len()),
            ("shooting: r1_diag", nu, spec.r1_diag.len()),
        ] {
            if expected != got {
                return Err(Error::Dimension {
                    what: what.into(),
                    expected,
                    got,
                });
            }
        }
        if spec.intervals == 0 {
            return Err(Error::invalid(src, "intervals", 0, "must be >= 1"));
        }
        if spec.substeps == 0 {
            return Err(Error::invalid(src, "substeps", 0, "must be >= 1"));
        }
        if !(spec.swing_time_s.is_finite() && spec.swing_time_s > 0.0) {
            return Err(Error::invalid(
                src,
                "swing_time_s",
                spec.swing_time_s,
                "must be finite and > 0",
            ));
        }
        if let Some(c) = &clearance {
            if c.n_in() != n {
                return Err(Error::Dimension {
                    what: "shooting: clearance inputs".into(),
                    expected: n,
                    got: c.n_in(),
                });
            }
        }
        let k_last = spec.intervals;
        let n_clear = clearance.as_ref().map_or(0, |c| c.n_out());
        let ctx = Ctx {
            n,
            nx,
            nz: nx + nu,
            horizon: k_last,
            h: spec.swing_time_s / k_last as f64,
            substeps: spec.substeps,
            q1: spec.q1_diag.clone(),
            r1: spec.r1_diag.clone(),
            clearance,
            n_clear,
            sub_clear: spec.substep_clearance,
            free: None,
        };
        let stages: Vec<StageDims> = (0..=k_last)
            .map(|k| StageDims {
                nx,
                nu: if k < k_last { nu } else { 0 },
                nc: ctx.stage_rows(k),
            })
            .collect();
        let dims = OcpDims {
            stages,
            n_terminal: 4,
        };
        let parallel = k_last + 1 >= spec.parallel_min_stages
            && rayon::current_num_threads() > 1
            && rayon::current_thread_index().is_none();
        let first = if parallel {
            k_last.div_ceil(2)
        } else {
            k_last + 1
        };
        let work = (0..first).map(|_| StageWork::new(&robot, &ctx)).collect();
        let tail = parallel.then(|| {
            SpinWorker::spawn(Tail {
                first,
                ctx: ctx.clone(),
                work: (first..=k_last)
                    .map(|_| StageWork::new(&robot, &ctx))
                    .collect(),
                zx: Vec::new(),
                zu: Vec::new(),
                lam: Vec::new(),
                mu: Vec::new(),
                out: Vec::new(),
                job: TailJob::Evaluate(EvalLevel::Values),
            })
        });
        let mut guess = Primal::zeros(&dims);
        guess.x[0].copy_from_slice(&spec.x_start);
        let tau_lo = robot.tau_min.clone();
        let tau_hi = robot.tau_max.clone();
        let term_fn = EeTerminalFn::new(robot);
        let mut ocp = SwingOcp {
            ctx,
            work,
            tail,
            x_start: spec.x_start,
            target: spec.target,
            bounds: spec.bounds,
            end_box: None,
            tau_lo,
            tau_hi,
            guess,
            term: Diff::new(&term_fn),
            term_fn,
            term_val: vec![0.0; 4],
            term_jac: vec![0.0; 4 * nx],
            term_hess: vec![0.0; nx * nx],
            dims,
            start_c: vec![0.0; n_clear],
            timings: ShootingTimings::default(),
        };
        ocp.size_tail();
        ocp.update_start_clearance();
        Ok(ocp)
    }

    /// (Re)size the helper's input and output buffers to the problem's dims (construction, and a
    /// change between a fixed and a free swing time).
    fn size_tail(&mut self) {
        let Some(tail) = &self.tail else { return };
        let mut t = tail.state();
        let first = t.first;
        let stages = &self.dims.stages;
        let nx_next = |k: usize| stages.get(k + 1).map_or(0, |d| d.nx);
        t.zx = stages[first..].iter().map(|d| vec![0.0; d.nx]).collect();
        t.zu = stages[first..].iter().map(|d| vec![0.0; d.nu]).collect();
        t.lam = (first..stages.len())
            .map(|k| vec![0.0; nx_next(k)])
            .collect();
        t.mu = stages[first..].iter().map(|d| vec![0.0; d.nc]).collect();
        t.out = (first..stages.len())
            .map(|k| StageEval::zeros(stages[k], nx_next(k)))
            .collect();
    }

    /// Mark every stage's recorded forward pass stale (the interval or the layout changed).
    fn invalidate_records(&mut self) {
        for w in &mut self.work {
            w.rec_valid = false;
        }
        if let Some(tail) = &self.tail {
            for w in &mut tail.state().work {
                w.rec_valid = false;
            }
        }
    }

    /// Whether half the stages are evaluated on the problem's helper thread (module docs).
    pub fn has_helper_thread(&self) -> bool {
        self.tail.as_ref().is_some_and(SpinWorker::has_thread)
    }

    /// The robot (shared).
    pub fn robot(&self) -> &Arc<Robot> {
        &self.term_fn.robot
    }

    /// The initial guess handed to the solver.
    pub fn guess(&self) -> &Primal {
        &self.guess
    }

    /// The initial guess handed to the solver (x_0 should stay the start state).
    pub fn guess_mut(&mut self) -> &mut Primal {
        &mut self.guess
    }

    /// Shooting interval h = T / K, s (with a free swing time, the start's).
    pub fn interval(&self) -> f64 {
        self.ctx.h
    }

    /// Swing time T = K h, s (with a free swing time, the start's: a point's own is
    /// [`Self::swing_time_of`]).
    pub fn swing_time(&self) -> f64 {
        self.ctx.h * self.ctx.horizon as f64
    }

    /// The fixed start state `x_0` (2n).
    pub fn start(&self) -> &[f64] {
        &self.x_start
    }

    /// The target bar position, m.
    pub fn target(&self) -> [f64; 2] {
        self.target
    }

    /// Set the start state `x_0` in place (2n values; the bounds of stage 0 follow). Errors on the
    /// wrong length or a non-finite value.
    pub fn set_start(&mut self, x: &[f64]) -> Result<()> {
        if x.len() != self.x_start.len() {
            return Err(Error::Dimension {
                what: "shooting: x_start".into(),
                expected: self.x_start.len(),
                got: x.len(),
            });
        }
        if let Some(v) = x.iter().find(|v| !v.is_finite()) {
            return Err(Error::invalid(
                "<shooting>",
                "x_start",
                *v,
                "must be finite",
            ));
        }
        self.x_start.copy_from_slice(x);
        self.guess.x[0][..x.len()].copy_from_slice(x);
        self.update_start_clearance();
        Ok(())
    }

    /// Recompute the clearance rows at the start pose (no allocation).
    fn update_start_clearance(&mut self) {
        let n = self.ctx.n;
        if let Some(cd) = self.work.first().and_then(|w| w.clear.as_ref()) {
            cd.value(&self.x_start[..n], &mut self.start_c);
        }
    }

    /// Set the swing time T in place, keeping K: the interval becomes h = T / K (the recorded
    /// forward passes are dropped). Errors on a time that is not finite and positive, and with a
    /// free swing time (T is then each point's own; see [`Self::with_fixed_swing_time`]).
    pub fn set_swing_time(&mut self, t: f64) -> Result<()> {
        if self.ctx.free.is_some() {
            return Err(Error::invalid(
                "<shooting>",
                "swing_time_s",
                t,
                "the swing time is free (a decision variable): fix it with with_fixed_swing_time",
            ));
        }
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::invalid(
                "<shooting>",
                "swing_time_s",
                t,
                "must be finite and > 0",
            ));
        }
        self.ctx.h = t / self.ctx.horizon as f64;
        self.invalidate_records();
        Ok(())
    }

    /// Make the swing time a decision variable in `[t_min, t_max]` (s): every state gets T as its
    /// last component (`x_k = [q, qd, T]`, `2n + 1` values, carried unchanged from stage to stage by
    /// the dynamics; stage k's interval is `T_k / K`, so all stages share one T at any feasible
    /// point), bounded by `[t_min, t_max]` at every stage (and, unlike q and qd, not fixed at stage
    /// 0: a decision variable). The cost (a quadrature
    /// in time) and the flow then depend on T, the clearance and terminal rows do not. The guess
    /// keeps its knots and takes the current swing time clamped into the range as its T. K is
    /// unchanged. Errors on a range that is not `0 < t_min <= t_max < inf`. Fixes the problem's
    /// dimensions: call it before building a solver on them.
    pub fn with_free_swing_time(mut self, t_min: f64, t_max: f64) -> Result<Self> {
        if !(t_min.is_finite() && t_max.is_finite() && t_min > 0.0 && t_min <= t_max) {
            return Err(Error::invalid(
                "<shooting>",
                "free_swing_time",
                format!("[{t_min}, {t_max}]"),
                "must be 0 < min <= max, finite",
            ));
        }
        let nx = self.ctx.nx;
        let t0 = self.swing_time().clamp(t_min, t_max);
        self.ctx.h = t0 / self.ctx.horizon as f64;
        self.ctx.free = Some([t_min, t_max]);
        for s in &mut self.dims.stages {
            s.nx = nx + 1;
        }
        let mut guess = Primal::zeros(&self.dims);
        for (dst, src) in guess.x.iter_mut().zip(&self.guess.x) {
            dst[..nx].copy_from_slice(&src[..nx]);
            dst[nx] = t0;
        }
        for (dst, src) in guess.u.iter_mut().zip(&self.guess.u) {
            dst.copy_from_slice(src);
        }
        self.guess = guess;
        self.invalidate_records();
        self.size_tail();
        Ok(self)
    }

    /// Back to a fixed swing time `t` (s): the inverse of [`Self::with_free_swing_time`] (the guess
    /// drops its T; the interval becomes `t / K`). Errors on a time that is not finite and positive.
    pub fn with_fixed_swing_time(mut self, t: f64) -> Result<Self> {
        let nx = self.ctx.nx;
        let free = self.ctx.free.take();
        self.set_swing_time(t)?;
        if free.is_some() {
            for s in &mut self.dims.stages {
                s.nx = nx;
            }
            self.guess = self.strip_swing_time(&self.guess);
            self.size_tail();
        }
        Ok(self)
    }

    /// A point of the free-swing-time layout without its T (`x_k = [q, qd]`); a point without T
    /// is copied as it is.
    pub fn strip_swing_time(&self, z: &Primal) -> Primal {
        let nx = self.ctx.nx;
        Primal {
            x: z.x.iter().map(|x| x[..nx.min(x.len())].to_vec()).collect(),
            u: z.u.clone(),
        }
    }

    /// [`Self::strip_swing_time`] into `dst`, a point of the fixed-T layout (no allocation).
    /// Panics on a `dst` of other sizes.
    pub fn strip_swing_time_into(&self, z: &Primal, dst: &mut Primal) {
        let nx = self.ctx.nx;
        for (d, s) in dst.x.iter_mut().zip(&z.x) {
            d.copy_from_slice(&s[..nx]);
        }
        for (d, s) in dst.u.iter_mut().zip(&z.u) {
            d.copy_from_slice(s);
        }
    }

    /// The range of a free swing time ([`Self::with_free_swing_time`]), `None` when T is fixed.
    pub fn free_swing_time(&self) -> Option<[f64; 2]> {
        self.ctx.free
    }

    /// The swing time of a point `z` of this problem: its T (stage 0's) with a free swing time, the
    /// fixed T otherwise, s.
    pub fn swing_time_of(&self, z: &Primal) -> f64 {
        match self.ctx.free {
            Some(_) => z.x[0][self.ctx.nx],
            None => self.swing_time(),
        }
    }

    /// The box bounds of knots 1..K on q and qd (knot 0 is the start state).
    pub fn knot_bounds(&self) -> &Bounds {
        &self.bounds
    }

    /// Set the box bounds of knots 1..K in place (no allocation).
    pub fn set_knot_bounds(&mut self, bounds: &Bounds) {
        self.bounds.clone_from(bounds);
    }

    /// A box on the state at the last knot (2n entries `[lo, hi]`: q then qd; rad, rad/s),
    /// intersected with that knot's own bounds (a component whose intersection is empty keeps the
    /// knot's bound), or `None` for the knot's bounds alone. Errors on a wrong length or a range that
    /// is not `lo <= hi` (infinite ends allowed).
    pub fn set_end_box(&mut self, b: Option<&[[f64; 2]]>) -> Result<()> {
        if let Some(r) = b {
            if r.len() != self.ctx.nx {
                return Err(Error::Dimension {
                    what: "shooting: end box".into(),
                    expected: self.ctx.nx,
                    got: r.len(),
                });
            }
            if let Some(v) = r
                .iter()
                .find(|v| v[0].is_nan() || v[1].is_nan() || v[0] > v[1])
            {
                return Err(Error::invalid(
                    "<shooting>",
                    "end box",
                    format!("{v:?}"),
                    "must have lo <= hi",
                ));
            }
        }
        self.end_box = b.map(<[[f64; 2]]>::to_vec);
        Ok(())
    }

    /// The box set by [`SwingOcp::set_end_box`].
    pub fn end_box(&self) -> Option<&[[f64; 2]]> {
        self.end_box.as_deref()
    }

    /// Set the target bar position in place, m.
    pub fn set_target(&mut self, target: [f64; 2]) {
        self.target = target;
    }

    /// RK4 steps per interval.
    pub fn substeps(&self) -> usize {
        self.ctx.substeps
    }

    /// Number of clearance rows per stage (k >= 1).
    pub fn n_clearance(&self) -> usize {
        self.ctx.n_clear
    }

    /// The flow of stage `k < K` over the current interval, `x_{k+1} = Phi(x, u)` (the dynamics row
    /// of [`OcpProblem::evaluate`], values only), into `out`; `x` and `out` in the problem's layout
    /// (2n, or 2n + 1 with a free swing time: then over `x`'s own T, carried into `out`). Uses
    /// stage k's scratch (no allocation; the recorded forward pass of the Hessian stays valid).
    /// Panics on `k >= K` or wrong sizes.
    pub fn flow(&mut self, k: usize, x: &[f64], u: &[f64], out: &mut [f64]) {
        assert!(
            k < self.ctx.horizon,
            "flow of stage {k}: the last is {}",
            self.ctx.horizon - 1
        );
        let nxp = self.ctx.nx_problem();
        assert!(
            x.len() == nxp && out.len() == nxp,
            "flow: x and out need {nxp} values, got {} and {}",
            x.len(),
            out.len()
        );
        let h = self.ctx.stage_h(x);
        let nx = self.ctx.nx;
        if k < self.work.len() {
            let w = &mut self.work[k];
            w.forward(&self.ctx, x, u, false, h);
            out[..nx].copy_from_slice(&w.xs);
        } else if let Some(tail) = &self.tail {
            let mut t = tail.state();
            let j = k - t.first;
            let w = &mut t.work[j];
            w.forward(&self.ctx, x, u, false, h);
            out[..nx].copy_from_slice(&w.xs);
        }
        if self.ctx.free.is_some() {
            out[self.ctx.nx] = x[self.ctx.nx];
        }
    }

    /// Evaluate the stages: the first half on the calling thread while the helper thread runs
    /// `job` on the second (its inputs copied in, its results copied out), or all of them on the
    /// calling thread (no helper, or called from inside a rayon worker, where the cores are taken).
    /// The multipliers `lam`, `mu` (one entry per stage) are read by a Hessian job only.
    fn for_stages(
        &mut self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        lam: &[Vec<f64>],
        mu: &[Vec<f64>],
        job: TailJob,
        stages: &mut [StageEval],
    ) -> std::result::Result<(), EvalError> {
        let ctx = &self.ctx;
        let own = self.work.len();
        let here = |w: &mut StageWork<D>, k: usize, ev: &mut StageEval| {
            job.run(w, ctx, k, &zx[k], &zu[k], at(lam, k), at(mu, k), ev)
        };
        let threaded = self
            .tail
            .as_ref()
            .is_some_and(|t| t.has_thread() && rayon::current_thread_index().is_none());
        let Some(tail) = self.tail.as_mut().filter(|_| threaded) else {
            // every stage here: the first ones, then the helper's (if any) in its scratch
            for (k, (w, ev)) in self.work.iter_mut().zip(stages.iter_mut()).enumerate() {
                here(w, k, ev);
            }
            if let Some(tail) = &self.tail {
                for (j, w) in tail.state().work.iter_mut().enumerate() {
                    here(w, own + j, &mut stages[own + j]);
                }
            }
            return Ok(());
        };
        {
            let mut t = tail.state();
            let t = &mut *t;
            t.ctx.h = ctx.h;
            t.ctx.free = ctx.free;
            t.job = job;
            for (j, (dx, du)) in t.zx.iter_mut().zip(t.zu.iter_mut()).enumerate() {
                dx.copy_from_slice(&zx[own + j]);
                du.copy_from_slice(&zu[own + j]);
            }
            if let TailJob::Hessian(_) = job {
                // lam at the last stage is not read (and may have any size)
                let k_last = ctx.horizon;
                for (j, (dl, dm)) in t.lam.iter_mut().zip(t.mu.iter_mut()).enumerate() {
                    if own + j < k_last {
                        dl.copy_from_slice(&lam[own + j]);
                    }
                    dm.copy_from_slice(&mu[own + j]);
                }
            }
        }
        tail.post();
        for (k, (w, ev)) in self.work.iter_mut().zip(stages.iter_mut()).enumerate() {
            here(w, k, ev);
        }
        if let Err(msg) = tail.wait() {
            return Err(EvalError {
                stage: own,
                reason: format!(
                    "a stage evaluation on the helper thread (stages {own}..) failed: {msg}"
                ),
            });
        }
        let t = tail.state();
        let k_last = ctx.horizon;
        for (k, (src, dst)) in (own..).zip(t.out.iter().zip(&mut stages[own..])) {
            match job {
                TailJob::Evaluate(level) => {
                    // stage K's f and jac_f are not the problem's (they may have any size)
                    dst.cost = src.cost;
                    dst.c.copy_from_slice(&src.c);
                    if k < k_last {
                        dst.f.copy_from_slice(&src.f);
                    }
                    if level == EvalLevel::FirstOrder {
                        dst.grad.copy_from_slice(&src.grad);
                        dst.jac_c.copy_from_slice(&src.jac_c);
                        if k < k_last {
                            dst.jac_f.copy_from_slice(&src.jac_f);
                        }
                    }
                }
                TailJob::Hessian(_) => dst.hess.copy_from_slice(&src.hess),
            }
        }
        Ok(())
    }

    /// [`OcpProblem::evaluate`] on the knots `zx`, `zu` (K + 1 each) given as slices, so that a
    /// problem made of several swings ([`super::multi_swing::MultiSwingOcp`]) evaluates its phases
    /// in place, without copying them into a [`Primal`]. `stages` holds the K + 1 stages' buffers
    /// (stage K's `f` and `jac_f` are not touched, whatever their size).
    pub(crate) fn evaluate_parts(
        &mut self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> std::result::Result<(), EvalError> {
        self.check_sizes(zx, zu, stages.len())?;
        let t0 = Instant::now();
        self.for_stages(zx, zu, &[], &[], TailJob::Evaluate(level), stages)?;
        let nx = self.ctx.nx;
        let xl = &zx[self.ctx.horizon][..nx];
        if level == EvalLevel::FirstOrder {
            if self.ctx.free.is_some() {
                // the rows do not depend on T: its column stays zero
                self.term
                    .jacobian(&self.term_fn, xl, &mut self.term_val, &mut self.term_jac);
                terminal.jac_r.fill(0.0);
                for r in 0..4 {
                    terminal.jac_r[r * (nx + 1)..r * (nx + 1) + nx]
                        .copy_from_slice(&self.term_jac[r * nx..(r + 1) * nx]);
                }
            } else {
                self.term.jacobian(
                    &self.term_fn,
                    xl,
                    &mut self.term_val,
                    &mut terminal.jac_r[..4 * nx],
                );
            }
        } else {
            self.term.value(&self.term_fn, xl, &mut self.term_val);
        }
        terminal.r[0] = self.term_val[0] - self.target[0];
        terminal.r[1] = self.term_val[1] - self.target[1];
        terminal.r[2] = self.term_val[2];
        terminal.r[3] = self.term_val[3];
        let dt = t0.elapsed().as_secs_f64();
        if level == EvalLevel::FirstOrder {
            self.timings.first_order_s += dt;
            self.timings.first_order_calls += 1;
        } else {
            self.timings.values_s += dt;
        }
        Ok(())
    }

    /// [`OcpProblem::hessians`] on slices (see [`Self::evaluate_parts`]): `lam`, `mu` one entry per
    /// stage (`lam[K]` is not read), `nu` the 4 multipliers of the terminal rows, whose Hessian is
    /// added to stage K's.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn hessians_parts(
        &mut self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        sigma: f64,
        lam: &[Vec<f64>],
        mu: &[Vec<f64>],
        nu: &[f64],
        stages: &mut [StageEval],
    ) -> std::result::Result<(), EvalError> {
        self.check_sizes(zx, zu, stages.len())?;
        if lam.len() != stages.len() || mu.len() != stages.len() || nu.len() != 4 {
            return Err(EvalError {
                stage: 0,
                reason: "multipliers not shaped like the problem's dims".into(),
            });
        }
        let t0 = Instant::now();
        self.for_stages(zx, zu, lam, mu, TailJob::Hessian(sigma), stages)?;
        let k_last = self.ctx.horizon;
        let nx = self.ctx.nx;
        self.term
            .hessian_weighted(&self.term_fn, &zx[k_last][..nx], nu, &mut self.term_hess);
        let nxp = self.ctx.nx_problem();
        let hk = &mut stages[k_last].hess;
        for a in 0..nx {
            for (dst, src) in hk[a * nxp..a * nxp + nx]
                .iter_mut()
                .zip(&self.term_hess[a * nx..(a + 1) * nx])
            {
                *dst += src;
            }
        }
        self.timings.hessian_s += t0.elapsed().as_secs_f64();
        self.timings.hessian_calls += 1;
        Ok(())
    }

    fn check_sizes(
        &self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        n_stages: usize,
    ) -> std::result::Result<(), EvalError> {
        let n = self.ctx.horizon + 1;
        let ok = n_stages == n
            && zx.len() == n
            && zu.len() == n
            && zx
                .iter()
                .zip(zu)
                .zip(&self.dims.stages)
                .all(|((x, u), d)| x.len() == d.nx && u.len() == d.nu);
        if ok {
            Ok(())
        } else {
            Err(EvalError {
                stage: 0,
                reason: "primal point or buffers not shaped like the problem's dims".into(),
            })
        }
    }
}

impl<D: PointDynamics> OcpProblem for SwingOcp<D> {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }

    fn bounds(&self, k: usize, b: &mut StageBounds) {
        let (n, nx) = (self.ctx.n, self.ctx.nx);
        if let Some([t_lo, t_hi]) = self.ctx.free {
            b.x_lo[nx] = t_lo;
            b.x_hi[nx] = t_hi;
        }
        if k == 0 {
            b.x_lo[..nx].copy_from_slice(&self.x_start);
            b.x_hi[..nx].copy_from_slice(&self.x_start);
        } else {
            let bd = &self.bounds;
            b.x_lo[0] = bd.q1[0];
            b.x_hi[0] = bd.q1[1];
            for i in 1..n {
                b.x_lo[i] = -bd.q_rel_max;
                b.x_hi[i] = bd.q_rel_max;
            }
            let qd = bd.qd_bound(k == self.ctx.horizon);
            for i in 0..n {
                b.x_lo[n + i] = -qd;
                b.x_hi[n + i] = qd;
            }
            if let (Some(e), true) = (&self.end_box, k == self.ctx.horizon) {
                for (i, r) in e.iter().enumerate() {
                    let (lo, hi) = (b.x_lo[i].max(r[0]), b.x_hi[i].min(r[1]));
                    if lo <= hi {
                        b.x_lo[i] = lo;
                        b.x_hi[i] = hi;
                    }
                }
            }
        }
        if k < self.ctx.horizon {
            b.u_lo.copy_from_slice(&self.tau_lo);
            b.u_hi.copy_from_slice(&self.tau_hi);
        }
        b.c_lo.fill(0.0);
        b.c_hi.fill(f64::INFINITY);
        if k == 0 {
            // the sub-step rows of the first interval: no worse than the start pose, which is given
            for (i, lo) in b.c_lo.iter_mut().enumerate() {
                *lo = self.start_c[i % self.ctx.n_clear.max(1)].min(0.0);
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
        self.evaluate_parts(&z.x, &z.u, level, stages, terminal)
    }

    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        mult: &Multipliers,
        stages: &mut [StageEval],
    ) -> std::result::Result<(), EvalError> {
        if mult.lam.len() != stages.len() || mult.mu.len() != stages.len() {
            return Err(EvalError {
                stage: 0,
                reason: "multipliers not shaped like the problem's dims".into(),
            });
        }
        self.hessians_parts(&z.x, &z.u, sigma, &mult.lam, &mult.mu, &mult.nu, stages)
    }
}
