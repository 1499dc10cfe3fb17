//! One shooting stage: its RK4 steps with the sensitivities of every evaluation, the cost, the
//! clearance rows and the reverse sweep of the dynamics Hessian (see the module docs of
//! [`super`]). Everything is allocated once per stage.

use super::dynamics::PointDynamics;
use super::kernels::{add_sandwich_upper, fx_transpose_times};
use crate::model::{ClearanceDerivatives, ClearanceRecord, Robot};
use crate::planning::transcription::clearance_fn::DistanceClearanceFn;
use brachia_linalg::add_lincomb;
use brachia_ocp::{EvalLevel, StageEval};
use std::sync::Arc;

/// The classical RK4 tableau: the nodes `c_j` (evaluation j's input is `x + c_j s k_{j-1}` for a
/// step s) and the weights times 6, `b_j` (`x+ = x + s/6 sum_j b_j k_j`).
pub(super) const RK4_C: [f64; 4] = [0.0, 0.5, 0.5, 1.0];
pub(super) const RK4_B6: [f64; 4] = [1.0, 2.0, 2.0, 1.0];

/// Data shared by the stages (the helper thread keeps a copy, whose `h` and `free` are refreshed
/// before each of its jobs).
#[derive(Clone)]
pub(super) struct Ctx {
    pub(super) n: usize,
    pub(super) nx: usize,
    pub(super) nz: usize,
    pub(super) horizon: usize,
    pub(super) h: f64,
    pub(super) substeps: usize,
    pub(super) q1: Vec<f64>,
    pub(super) r1: Vec<f64>,
    pub(super) clearance: Option<DistanceClearanceFn>,
    pub(super) n_clear: usize,
    /// Clearance rows also at the interior RK4 sub-step states of every interval.
    pub(super) sub_clear: bool,
    /// A free swing time `[T_min, T_max]` (s): then every state carries T as its last component
    /// (`x_k = [q, qd, T]`, constant along the stages) and stage k's interval is `T_k / K`
    /// ([`SwingOcp::with_free_swing_time`]); `None`: T fixed, the interval is `h`.
    pub(super) free: Option<[f64; 2]>,
}

impl Ctx {
    /// Trapezoid weight of the state term at stage k for the interval `h`.
    pub(super) fn state_weight(&self, k: usize, h: f64) -> f64 {
        if k == 0 || k == self.horizon {
            0.5 * h
        } else {
            h
        }
    }

    /// The interval of a stage whose (problem-layout) state is `x`: `T_k / K` with a free swing
    /// time, `h` otherwise.
    pub(super) fn stage_h(&self, x: &[f64]) -> f64 {
        match self.free {
            Some(_) => x[self.nx] / self.horizon as f64,
            None => self.h,
        }
    }

    /// Sub-step states of an interval that carry clearance rows (`substeps - 1`, or 0).
    pub(super) fn sub_states(&self) -> usize {
        if self.sub_clear && self.n_clear > 0 {
            self.substeps - 1
        } else {
            0
        }
    }

    /// Clearance rows of stage k: the knot's (k >= 1), then each interior sub-step state's (k < K).
    pub(super) fn stage_rows(&self, k: usize) -> usize {
        let knot = usize::from(k >= 1);
        let sub = if k < self.horizon {
            self.sub_states()
        } else {
            0
        };
        self.n_clear * (knot + sub)
    }

    /// Size of a stage's state in the problem's layout (`2n`, or `2n + 1` with a free swing time).
    pub(super) fn nx_problem(&self) -> usize {
        self.nx + usize::from(self.free.is_some())
    }
}

/// Column of internal stage variable `c` (`[q, qd, u]`) in the problem's layout, where a free swing
/// time sits between the state and the input (`[q, qd, T, u]`).
pub(super) fn col(c: usize, nx: usize, free: bool) -> usize {
    if free && c >= nx {
        c + 1
    } else {
        c
    }
}

/// The arguments of [`StageWork::forward_n`], run through [`pulp::Arch::dispatch`]: the body is
/// compiled for the widest vector instructions the CPU has. The same numbers on every CPU: its
/// loops are element-wise (no reordered sums) and Rust never fuses a multiply and an add.
struct Forward<'a, D> {
    w: &'a mut StageWork<D>,
    ctx: &'a Ctx,
    x: &'a [f64],
    u: &'a [f64],
    jac: bool,
    h: f64,
}

impl<D: PointDynamics> pulp::WithSimd for Forward<'_, D> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let Forward {
            w,
            ctx,
            x,
            u,
            jac,
            h,
        } = self;
        // the paper's 4 links with constant sizes (unrolled loops), any other count through the
        // same body: the same arithmetic either way
        with_link_count!(ctx.n, |n| w.forward_n(ctx, x, u, jac, n, h));
    }
}

/// The arguments of [`StageWork::hessian_internal`], run through [`pulp::Arch::dispatch`] as
/// [`Forward`] (the same numbers on every CPU).
struct Reverse<'a, D> {
    w: &'a mut StageWork<D>,
    ctx: &'a Ctx,
    k: usize,
    x: &'a [f64],
    u: &'a [f64],
    sigma: f64,
    lam: &'a [f64],
    mu: &'a [f64],
    h: f64,
    hess: &'a mut [f64],
}

impl<D: PointDynamics> pulp::WithSimd for Reverse<'_, D> {
    type Output = f64;

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> f64 {
        let Reverse {
            w,
            ctx,
            k,
            x,
            u,
            sigma,
            lam,
            mu,
            h,
            hess,
        } = self;
        w.hessian_internal_body(ctx, k, x, u, sigma, lam, mu, h, hess)
    }
}

/// Per-stage scratch, allocated once.
pub(super) struct StageWork<D> {
    /// One per RK4 evaluation of the stage, so that the Hessian reuses each evaluation's
    /// factorisation and first derivatives from the forward pass.
    pub(super) dynamics: Vec<D>,
    pub(super) clear: Option<ClearanceDerivatives>,
    /// The clearance rows at the knot of the last first-order evaluation, for the Hessian there.
    pub(super) crec: Option<ClearanceRecord>,
    /// The stage point `[x_k, u_k]` of the recorded forward pass, and whether it is valid.
    pub(super) rec_z: Vec<f64>,
    pub(super) rec_valid: bool,
    /// Inputs of the RK4 evaluations, `ne x nz`.
    pub(super) y: Vec<f64>,
    /// `d qdd / d y` at each evaluation, `ne x (n x nz)`.
    pub(super) jq: Vec<f64>,
    /// `S_i = d y_i / d z_k`, `ne x (nz x nz)`.
    pub(super) sens: Vec<f64>,
    /// Current sub-step state and its sensitivity `nx x nz`.
    pub(super) xs: Vec<f64>,
    pub(super) xsens: Vec<f64>,
    /// RK4 stage derivatives `4 x nx` and their sensitivities `4 x (nx x nz)`.
    pub(super) kv: Vec<f64>,
    pub(super) kz: Vec<f64>,
    /// Input of a value-only evaluation.
    pub(super) yv: Vec<f64>,
    pub(super) qdd: Vec<f64>,
    /// Reverse sweep: state adjoint, one transposed-Jacobian product per evaluation, weights.
    pub(super) abar: Vec<f64>,
    pub(super) g: Vec<f64>,
    pub(super) w: Vec<f64>,
    pub(super) hbuf: Vec<f64>,
    pub(super) tmp: Vec<f64>,
    /// Clearance Jacobian (`nc x n`) and weighted Hessian (`n x n`).
    pub(super) cjac: Vec<f64>,
    pub(super) chess: Vec<f64>,
    /// The state after each RK4 sub-step of the last forward pass, `substeps x nx`.
    pub(super) xsub: Vec<f64>,
    /// The clearance rows' records at the interior sub-step states, one each.
    pub(super) crec_sub: Vec<ClearanceRecord>,
    /// Scratch of the sub-step rows: values (`nc`), `J^T mu` (`n`), products (`n x nz`, `n`).
    pub(super) cval: Vec<f64>,
    pub(super) cadj: Vec<f64>,
    pub(super) ctmp: Vec<f64>,
    pub(super) cvec: Vec<f64>,
    /// The interval of the recorded forward pass, s.
    pub(super) rec_h: f64,
    /// Free swing time only: each evaluation's acceleration `ne x n`, the derivatives w.r.t. the
    /// interval h of each evaluation's state input `ne x nx` and stage derivative `ne x nx`, and of
    /// Phi (`nx`); the h column of the Hessian (`nz`), a scratch row (`nz`) and the stage's Hessian
    /// in the internal layout (`nz x nz`).
    pub(super) qdds: Vec<f64>,
    pub(super) ty: Vec<f64>,
    pub(super) tk: Vec<f64>,
    pub(super) tphi: Vec<f64>,
    pub(super) colh: Vec<f64>,
    pub(super) vrow: Vec<f64>,
    pub(super) hint: Vec<f64>,
}

impl<D: PointDynamics> StageWork<D> {
    pub(super) fn new(robot: &Arc<Robot>, ctx: &Ctx) -> Self {
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
    pub(super) fn forward(&mut self, ctx: &Ctx, x: &[f64], u: &[f64], jac: bool, h: f64) {
        crate::simd_arch().dispatch(Forward {
            w: self,
            ctx,
            x,
            u,
            jac,
            h,
        });
        if jac && ctx.free.is_some() {
            self.tangent(ctx, h);
        }
    }

    /// The derivatives w.r.t. the interval h at the recorded forward pass (x and u fixed): of each
    /// RK4 evaluation's state input (`ty`) and stage derivative (`tk`), and of Phi (`tphi`). The
    /// step h enters RK4 only through the coefficients of `y_j = x_s + c_j (h/m) k_{j-1}` and
    /// `x_{s+1} = x_s + (h/6m) sum b_j k_j`, so `ty_j = tx_s + c_j (h/m) tk_{j-1} + (c_j/m) k_{j-1}`
    /// and `tk_j = F_y(y_j) [ty_j; 0]`.
    pub(super) fn tangent(&mut self, ctx: &Ctx, h: f64) {
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
    pub(super) fn forward_n(
        &mut self,
        ctx: &Ctx,
        x: &[f64],
        u: &[f64],
        jac: bool,
        n: usize,
        h: f64,
    ) {
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
    #[inline]
    pub(super) fn evaluate(
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
    pub(super) fn substep_rows(&mut self, ctx: &Ctx, k: usize, first: bool, ev: &mut StageEval) {
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
    pub(super) fn substep_hessian(
        &mut self,
        ctx: &Ctx,
        s: usize,
        mu_s: &[f64],
        hess: &mut [f64],
    ) -> f64 {
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
    #[inline]
    pub(super) fn hessian(
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
    pub(super) fn hessian_internal(
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
        crate::simd_arch().dispatch(Reverse {
            w: self,
            ctx,
            k,
            x,
            u,
            sigma,
            lam,
            mu,
            h,
            hess,
        })
    }

    /// [`Self::hessian_internal`]'s body (run through [`Reverse`]).
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    fn hessian_internal_body(
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
    pub(super) fn h_terms(&mut self, ctx: &Ctx, i: usize, j: usize, h: f64) -> f64 {
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
