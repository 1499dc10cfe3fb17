//! The Newton step: a Riccati recursion over the condensed stage chain, plus a small dense Schur
//! complement for the equality rows (terminal rows and fixed states after stage 0).
//!
//! The equality-constrained QP solved here (all quantities are steps):
//! ```text
//! min  sum_k 1/2 dz_k^T H_k dz_k + g_k^T dz_k
//! s.t. dx_{k+1} = A_k dx_k + B_k du_k + b_k          (multiplier lam_k)
//!      a_j^T dx_{k_j} + rho_j = 0,  j = 0..m          (multiplier nu_j)
//! ```
//! `H_k = [Q S^T; S R]` in the order `z = [x, u]`. See docs/ocp.md for the derivation.

use crate::settings::MAX_EQUALITY_ROWS;
use brachia_linalg::{
    cholesky, cholesky_solve, eigen_solve, gemm_nn, gemm_nn_acc, gemm_tn_acc, gemv_n_acc,
    gemv_t_acc, sym_eigen, Scaling,
};

/// Offsets of every per-stage block in the flat workspace arrays.
#[derive(Debug, Clone)]
pub(crate) struct Layout {
    /// K (index of the last stage).
    pub kk: usize,
    pub nx: Vec<usize>,
    pub nu: Vec<usize>,
    pub nc: Vec<usize>,
    /// nx of the successor (0 at K).
    pub nx1: Vec<usize>,
    /// Offsets into arrays of `nz` per stage (K + 2 entries, the last is the total).
    pub oz: Vec<usize>,
    /// Offsets into arrays of `nx_{k+1}` per stage (dynamics rows, multipliers lam).
    pub ol: Vec<usize>,
    /// Offsets into arrays of `nc` per stage.
    pub oc: Vec<usize>,
    /// Offsets of the `nz x nz` stage Hessians.
    pub oh: Vec<usize>,
    /// Offsets of `A_k` (`nx_{k+1} x nx_k`).
    pub oa: Vec<usize>,
    /// Offsets of `B_k` (`nx_{k+1} x nu_k`).
    pub ob: Vec<usize>,
    /// Offsets of `P_k` (`nx_k x nx_k`).
    pub op: Vec<usize>,
    /// Offsets of the gains `K_k` (`nu_k x nx_k`).
    pub ok: Vec<usize>,
    /// Offsets of the Cholesky factors of `R^_k` (`nu_k x nu_k`).
    pub or: Vec<usize>,
    /// Largest nx, nu, nz over the stages.
    pub nx_max: usize,
    pub nu_max: usize,
}

fn offsets(sizes: impl Iterator<Item = usize>) -> Vec<usize> {
    let mut v = vec![0];
    let mut acc = 0;
    for s in sizes {
        acc += s;
        v.push(acc);
    }
    v
}

impl Layout {
    pub fn new(nx: Vec<usize>, nu: Vec<usize>, nc: Vec<usize>) -> Self {
        let n = nx.len();
        let kk = n - 1;
        let nx1: Vec<usize> = (0..n).map(|k| if k < kk { nx[k + 1] } else { 0 }).collect();
        let nz: Vec<usize> = (0..n).map(|k| nx[k] + nu[k]).collect();
        Layout {
            kk,
            oz: offsets(nz.iter().copied()),
            ol: offsets(nx1.iter().copied()),
            oc: offsets(nc.iter().copied()),
            oh: offsets(nz.iter().map(|z| z * z)),
            oa: offsets((0..n).map(|k| nx1[k] * nx[k])),
            ob: offsets((0..n).map(|k| nx1[k] * nu[k])),
            op: offsets(nx.iter().map(|x| x * x)),
            ok: offsets((0..n).map(|k| nu[k] * nx[k])),
            or: offsets(nu.iter().map(|u| u * u)),
            nx_max: nx.iter().copied().max().unwrap_or(0),
            nu_max: nu.iter().copied().max().unwrap_or(0),
            nx,
            nu,
            nc,
            nx1,
        }
    }
    pub fn nz(&self, k: usize) -> usize {
        self.nx[k] + self.nu[k]
    }
    pub fn n_z(&self) -> usize {
        self.oz[self.kk + 1]
    }
    pub fn n_l(&self) -> usize {
        self.ol[self.kk + 1]
    }
    pub fn n_c(&self) -> usize {
        self.oc[self.kk + 1]
    }
}

/// Where the factorisation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct NotPositive;

/// Riccati factors and solve workspace.
#[derive(Debug, Clone)]
pub(crate) struct Riccati {
    /// Condensed stage Hessians (input; left untouched by the factorisation).
    pub h: Vec<f64>,
    /// Dynamics Jacobians (input).
    pub a: Vec<f64>,
    pub b: Vec<f64>,
    /// Value-function Hessians P_k.
    p: Vec<f64>,
    /// Soft dynamics (restoration): per dynamics row a weight D >= 0 in
    /// `dx_{k+1} = A dx + B du + b - D lam` (empty use when `soft` is false).
    pub soft: bool,
    /// The weights D (n_l).
    pub dsoft: Vec<f64>,
    /// `P~_{k+1} = P - P S (I + S P S)^-1 S P`, S = D^1/2, stored at the offsets of P_{k+1}.
    ptil: Vec<f64>,
    /// Cholesky factors of `I + S P_{k+1} S`, at the offsets of P_{k+1}.
    lm: Vec<f64>,
    /// Soft-dynamics gradients p~_{k+1} (n_l) of the last solve.
    pvt: Vec<f64>,
    /// Feedback gains K_k = -R^^-1 S^.
    pub kgain: Vec<f64>,
    /// Cholesky factors of R^_k.
    lr: Vec<f64>,
    /// Scratch copy of P_0, and the eigendecomposition `S P_0 S = V diag(d) V^T` of P_0 scaled by
    /// the positive diagonal `S = diag(p0_s)` (P_0 may be indefinite when equality rows make the
    /// problem convex; see [`Riccati::factor_schur`]). S is the identity unless P_0 looks singular
    /// only for the spread of its diagonal (see [`Riccati::factor`]).
    lp0: Vec<f64>,
    p0_v: Vec<f64>,
    p0_d: Vec<f64>,
    p0_s: Vec<f64>,
    p0_tmp: Vec<f64>,
    /// Value-function gradients p_k of the last solve.
    pv: Vec<f64>,
    /// Feed-forward terms of the last solve.
    kff: Vec<f64>,
    // temporaries
    pa: Vec<f64>,
    pb: Vec<f64>,
    qh: Vec<f64>,
    sh: Vec<f64>,
    rh: Vec<f64>,
    t: Vec<f64>,
    // Schur complement over the equality rows
    /// Stage of each equality row.
    pub eq_stage: Vec<usize>,
    /// Row vectors a_j (MAX_EQUALITY_ROWS x nx_max; only nx_{k_j} entries used).
    pub eq_a: Vec<f64>,
    /// Residuals rho_j.
    pub eq_rho: Vec<f64>,
    /// Per-row regularisation of the Schur complement (restoration weights; 0 otherwise).
    pub eq_reg: Vec<f64>,
    /// Number of equality rows in use.
    pub m: usize,
    schur: Vec<f64>,
    schur_fac: Vec<f64>,
    schur_v: Vec<f64>,
    schur_d: Vec<f64>,
    schur_tmp: Vec<f64>,
    /// Responses of the chain QP to the unit gradients `a_j` (zero defects), all m at once:
    /// `dz^(j)` as an `n_z x m` and `lam^(j)` as an `n_l x m` row-major array (sized on the first
    /// factorisation with m rows; see [`Riccati::factor_schur`]).
    resp_dz: Vec<f64>,
    resp_lam: Vec<f64>,
    /// Gradient with the equality rows' contributions (n_z).
    gw: Vec<f64>,
    /// Multi-right-hand-side value-function gradients (n_z x m), feed-forward terms (n_z x m) and
    /// soft-dynamics gradients (n_l x m) of the response solve.
    mpv: Vec<f64>,
    mkff: Vec<f64>,
    mpvt: Vec<f64>,
    /// Scratch of the response solve (nx_max x m each, nu_max x m).
    mt: Vec<f64>,
    mw: Vec<f64>,
    mrh: Vec<f64>,
    p0_col: Vec<f64>,
}

impl Riccati {
    pub fn new(lay: &Layout) -> Self {
        let kk = lay.kk;
        let nxm = lay.nx_max;
        let num = lay.nu_max;
        let nx1m = lay.nx1.iter().copied().max().unwrap_or(0);
        let me = MAX_EQUALITY_ROWS;
        Riccati {
            h: vec![0.0; lay.oh[kk + 1]],
            a: vec![0.0; lay.oa[kk + 1]],
            b: vec![0.0; lay.ob[kk + 1]],
            p: vec![0.0; lay.op[kk + 1]],
            soft: false,
            dsoft: vec![0.0; lay.n_l()],
            ptil: vec![0.0; lay.op[kk + 1]],
            lm: vec![0.0; lay.op[kk + 1]],
            pvt: vec![0.0; lay.n_l()],
            kgain: vec![0.0; lay.ok[kk + 1]],
            lr: vec![0.0; lay.or[kk + 1]],
            lp0: vec![0.0; lay.nx[0] * lay.nx[0]],
            p0_v: vec![0.0; lay.nx[0] * lay.nx[0]],
            p0_d: vec![0.0; lay.nx[0]],
            p0_s: vec![1.0; lay.nx[0]],
            p0_tmp: vec![0.0; lay.nx[0]],
            pv: vec![0.0; lay.oz[kk + 1]],
            kff: vec![0.0; lay.oz[kk + 1]],
            pa: vec![0.0; nx1m * nxm],
            pb: vec![0.0; nx1m * num],
            qh: vec![0.0; nxm * nxm],
            sh: vec![0.0; num * nxm],
            rh: vec![0.0; num * num.max(1)],
            t: vec![0.0; nx1m.max(nxm)],
            eq_stage: vec![0; me],
            eq_a: vec![0.0; me * nxm],
            eq_rho: vec![0.0; me],
            eq_reg: vec![0.0; me],
            m: 0,
            schur: vec![0.0; me * me],
            schur_fac: vec![0.0; me * me],
            schur_v: vec![0.0; me * me],
            schur_d: vec![0.0; me],
            schur_tmp: vec![0.0; me],
            resp_dz: Vec::new(),
            gw: vec![0.0; lay.n_z()],
            resp_lam: Vec::new(),
            mpv: Vec::new(),
            mkff: Vec::new(),
            mpvt: Vec::new(),
            mt: Vec::new(),
            mw: Vec::new(),
            mrh: Vec::new(),
            p0_col: vec![0.0; lay.nx[0]],
        }
    }

    /// Backward factorisation of the chain with `delta_w` added to the diagonal entries flagged in
    /// `regularize` (one flag per entry of z). Fails when a reduced input Hessian `R^_k` is not
    /// positive definite or `P_0` is singular; returns the number of negative eigenvalues of `P_0`.
    pub fn factor(
        &mut self,
        lay: &Layout,
        delta_w: f64,
        regularize: &[bool],
    ) -> Result<usize, NotPositive> {
        for k in (0..=lay.kk).rev() {
            let (nx, nu, nz, nx1) = (lay.nx[k], lay.nu[k], lay.nz(k), lay.nx1[k]);
            let h = &self.h[lay.oh[k]..lay.oh[k + 1]];
            let reg = &regularize[lay.oz[k]..lay.oz[k + 1]];
            let qh = &mut self.qh[..nx * nx];
            let sh = &mut self.sh[..nu * nx];
            let rh = &mut self.rh[..nu * nu];
            for i in 0..nx {
                qh[i * nx..(i + 1) * nx].copy_from_slice(&h[i * nz..i * nz + nx]);
                if reg[i] {
                    qh[i * nx + i] += delta_w;
                }
            }
            for i in 0..nu {
                let row = &h[(nx + i) * nz..(nx + i + 1) * nz];
                sh[i * nx..(i + 1) * nx].copy_from_slice(&row[..nx]);
                rh[i * nu..(i + 1) * nu].copy_from_slice(&row[nx..]);
                if reg[nx + i] {
                    rh[i * nu + i] += delta_w;
                }
            }
            if k < lay.kk && self.soft {
                let (o, n) = (lay.op[k + 1], nx1);
                let p1 = &self.p[o..o + n * n];
                let d = &self.dsoft[lay.ol[k]..lay.ol[k + 1]];
                let lm = &mut self.lm[o..o + n * n];
                for i in 0..n {
                    for j in 0..n {
                        lm[i * n + j] = d[i].sqrt() * p1[i * n + j] * d[j].sqrt()
                            + if i == j { 1.0 } else { 0.0 };
                    }
                }
                if cholesky(lm, n, Scaling::Divide).is_err() {
                    return Err(NotPositive);
                }
                // X = M^-1 S P in ptil, then P~ = P - (S P)^T X
                let pt = &mut self.ptil[o..o + n * n];
                for i in 0..n {
                    for j in 0..n {
                        pt[i * n + j] = d[i].sqrt() * p1[i * n + j];
                    }
                }
                cholesky_solve(lm, n, pt, n, Scaling::Reciprocal);
                let pa = &mut self.pa[..n * n];
                pa.copy_from_slice(p1);
                for l in 0..n {
                    let sl = d[l].sqrt();
                    for i in 0..n {
                        let spli = sl * p1[l * n + i];
                        for j in 0..n {
                            pa[i * n + j] -= spli * pt[l * n + j];
                        }
                    }
                }
                for i in 0..n {
                    for j in 0..=i {
                        let v = 0.5 * (pa[i * n + j] + pa[j * n + i]);
                        pt[i * n + j] = v;
                        pt[j * n + i] = v;
                    }
                }
            }
            if k < lay.kk {
                let p1 = if self.soft {
                    &self.ptil[lay.op[k + 1]..lay.op[k + 2]]
                } else {
                    &self.p[lay.op[k + 1]..lay.op[k + 2]]
                };
                let a = &self.a[lay.oa[k]..lay.oa[k + 1]];
                let b = &self.b[lay.ob[k]..lay.ob[k + 1]];
                let pa = &mut self.pa[..nx1 * nx];
                let pb = &mut self.pb[..nx1 * nu];
                gemm_nn(p1, a, pa, nx1, nx1, nx);
                gemm_tn_acc(a, pa, qh, nx1, nx, nx);
                if nu > 0 {
                    gemm_tn_acc(b, pa, sh, nx1, nu, nx);
                    gemm_nn(p1, b, pb, nx1, nx1, nu);
                    gemm_tn_acc(b, pb, rh, nx1, nu, nu);
                }
            }
            if nu > 0 {
                if cholesky(rh, nu, Scaling::Divide).is_err() {
                    return Err(NotPositive);
                }
                self.lr[lay.or[k]..lay.or[k + 1]].copy_from_slice(rh);
                let kg = &mut self.kgain[lay.ok[k]..lay.ok[k + 1]];
                kg.copy_from_slice(sh);
                cholesky_solve(rh, nu, kg, nx, Scaling::Reciprocal);
                for v in kg.iter_mut() {
                    *v = -*v;
                }
                // P = Q^ + S^^T K
                gemm_tn_acc(sh, kg, qh, nu, nx, nx);
            }
            let p = &mut self.p[lay.op[k]..lay.op[k + 1]];
            for i in 0..nx {
                for j in 0..=i {
                    let v = 0.5 * (qh[i * nx + j] + qh[j * nx + i]);
                    p[i * nx + j] = v;
                    p[j * nx + i] = v;
                }
            }
        }
        let n0 = lay.nx[0];
        self.p0_s[..n0].fill(1.0);
        self.lp0.copy_from_slice(&self.p[..n0 * n0]);
        let unscaled = count_inertia(&mut self.lp0, n0, &mut self.p0_d, &mut self.p0_v);
        if unscaled.is_ok() {
            return unscaled;
        }
        // The test above is relative to the largest eigenvalue: a P_0 whose diagonal spans more
        // than 1e13 (a free initial state that stays the same along the chain, like a free swing
        // time, sums its barrier term at a bound over every stage, beside the unit entries of the
        // fixed states) fails it whatever delta_w, which only grows the free entries. The inertia
        // is that of `S P_0 S` for any positive diagonal S (Sylvester), so the test is repeated
        // on P_0 with a unit diagonal where its entries are nonzero.
        for i in 0..n0 {
            let d = self.p[i * n0 + i].abs();
            self.p0_s[i] = if d.is_finite() && d > 0.0 {
                1.0 / d.sqrt()
            } else {
                1.0
            };
        }
        for i in 0..n0 {
            for j in 0..n0 {
                self.lp0[i * n0 + j] = self.p0_s[i] * self.p[i * n0 + j] * self.p0_s[j];
            }
        }
        count_inertia(&mut self.lp0, n0, &mut self.p0_d, &mut self.p0_v)
    }

    /// Solves `P_0 x = b` in place with the scaled eigendecomposition of [`Riccati::factor`]:
    /// `x = S (S P_0 S)^-1 S b`.
    fn p0_solve(&mut self, n0: usize, b: &mut [f64]) {
        for (x, s) in b[..n0].iter_mut().zip(&self.p0_s) {
            *x *= s;
        }
        eigen_solve(&self.p0_v, &self.p0_d, n0, b, &mut self.p0_tmp);
        for (x, s) in b[..n0].iter_mut().zip(&self.p0_s) {
            *x *= s;
        }
    }

    /// Solves the chain QP without the equality rows, for gradient `g` (n_z) and defects `bdef`
    /// (n_l), after [`Riccati::factor`]. Writes the step `dz` and the dynamics multipliers `lam`.
    pub fn solve_chain(
        &mut self,
        lay: &Layout,
        g: &[f64],
        bdef: &[f64],
        dz: &mut [f64],
        lam: &mut [f64],
    ) {
        let kk = lay.kk;
        for k in (0..=kk).rev() {
            let (nx, nu, nx1) = (lay.nx[k], lay.nu[k], lay.nx1[k]);
            let gk = &g[lay.oz[k]..lay.oz[k + 1]];
            let (pv_lo, pv_hi) = self.pv.split_at_mut(lay.oz[k + 1]);
            let pk = &mut pv_lo[lay.oz[k]..lay.oz[k] + nx];
            pk.copy_from_slice(&gk[..nx]);
            let rh = &mut self.rh[..nu];
            rh.copy_from_slice(&gk[nx..]);
            if k < kk && self.soft {
                // p~ = p - P S M^-1 S p
                let d = &self.dsoft[lay.ol[k]..lay.ol[k + 1]];
                let w = &mut self.t[..nx1];
                for i in 0..nx1 {
                    w[i] = d[i].sqrt() * pv_hi[i];
                }
                let o = lay.op[k + 1];
                cholesky_solve(&self.lm[o..o + nx1 * nx1], nx1, w, 1, Scaling::Reciprocal);
                for i in 0..nx1 {
                    w[i] *= d[i].sqrt();
                }
                let pt = &mut self.pvt[lay.ol[k]..lay.ol[k + 1]];
                pt.copy_from_slice(&pv_hi[..nx1]);
                for i in 0..nx1 {
                    let mut acc = 0.0;
                    for j in 0..nx1 {
                        acc += self.p[o + i * nx1 + j] * w[j];
                    }
                    pt[i] -= acc;
                }
            }
            if k < kk {
                let t = &mut self.t[..nx1];
                let p1 = if self.soft {
                    t.copy_from_slice(&self.pvt[lay.ol[k]..lay.ol[k + 1]]);
                    &self.ptil[lay.op[k + 1]..lay.op[k + 2]]
                } else {
                    t.copy_from_slice(&pv_hi[..nx1]); // p_{k+1} sits at oz[k+1]
                    &self.p[lay.op[k + 1]..lay.op[k + 2]]
                };
                gemv_n_acc(p1, &bdef[lay.ol[k]..lay.ol[k + 1]], t, nx1, nx1);
                gemv_t_acc(&self.a[lay.oa[k]..lay.oa[k + 1]], t, pk, nx1, nx);
                if nu > 0 {
                    gemv_t_acc(&self.b[lay.ob[k]..lay.ob[k + 1]], t, rh, nx1, nu);
                }
            }
            if nu > 0 {
                let kf = &mut self.kff[lay.oz[k]..lay.oz[k] + nu];
                kf.copy_from_slice(rh);
                cholesky_solve(
                    &self.lr[lay.or[k]..lay.or[k + 1]],
                    nu,
                    kf,
                    1,
                    Scaling::Reciprocal,
                );
                for v in kf.iter_mut() {
                    *v = -*v;
                }
                // p_k = q^ + K^T r^
                gemv_t_acc(&self.kgain[lay.ok[k]..lay.ok[k + 1]], rh, pk, nu, nx);
            }
        }
        // forward
        let n0 = lay.nx[0];
        {
            let dx0 = &mut dz[..n0];
            for i in 0..n0 {
                dx0[i] = -self.pv[i];
            }
            self.p0_solve(n0, dx0);
        }
        for k in 0..=kk {
            let (nx, nu, nx1) = (lay.nx[k], lay.nu[k], lay.nx1[k]);
            let (dz_lo, dz_hi) = dz.split_at_mut(lay.oz[k + 1]);
            let dzk = &mut dz_lo[lay.oz[k]..];
            let (dx, du) = dzk.split_at_mut(nx);
            if nu > 0 {
                du.copy_from_slice(&self.kff[lay.oz[k]..lay.oz[k] + nu]);
                gemv_n_acc(&self.kgain[lay.ok[k]..lay.ok[k + 1]], dx, du, nu, nx);
            }
            if k < kk {
                let dx1 = &mut dz_hi[..nx1];
                dx1.copy_from_slice(&bdef[lay.ol[k]..lay.ol[k + 1]]);
                gemv_n_acc(&self.a[lay.oa[k]..lay.oa[k + 1]], dx, dx1, nx1, nx);
                if nu > 0 {
                    gemv_n_acc(&self.b[lay.ob[k]..lay.ob[k + 1]], du, dx1, nx1, nu);
                }
                let lk = &mut lam[lay.ol[k]..lay.ol[k + 1]];
                if self.soft {
                    // lam = P~ y + p~, x+ = y - D lam
                    lk.copy_from_slice(&self.pvt[lay.ol[k]..lay.ol[k + 1]]);
                    gemv_n_acc(&self.ptil[lay.op[k + 1]..lay.op[k + 2]], dx1, lk, nx1, nx1);
                    let d = &self.dsoft[lay.ol[k]..lay.ol[k + 1]];
                    for i in 0..nx1 {
                        dx1[i] -= d[i] * lk[i];
                    }
                } else {
                    lk.copy_from_slice(&self.pv[lay.oz[k + 1]..lay.oz[k + 1] + nx1]);
                    gemv_n_acc(&self.p[lay.op[k + 1]..lay.op[k + 2]], dx1, lk, nx1, nx1);
                }
            }
        }
    }

    fn eq_dot(&self, lay: &Layout, j: usize, dz: &[f64]) -> f64 {
        let k = self.eq_stage[j];
        let nx = lay.nx[k];
        let a = &self.eq_a[j * lay.nx_max..j * lay.nx_max + nx];
        let x = &dz[lay.oz[k]..lay.oz[k] + nx];
        a.iter().zip(x).map(|(a, x)| a * x).sum()
    }

    /// [`Riccati::factor`] and [`Riccati::factor_schur`] with IPOPT's inertia test: true when the
    /// KKT matrix has the inertia of a local minimiser (R^_k positive definite, and as many negative
    /// eigenvalues in the Schur matrix W as in P_0).
    pub fn factor_with_inertia(&mut self, lay: &Layout, delta_w: f64, regularize: &[bool]) -> bool {
        match self.factor(lay, delta_w, regularize) {
            Err(_) => false,
            Ok(q) if self.m == 0 => q == 0,
            Ok(q) => self.factor_schur(lay) == Ok(q),
        }
    }

    /// The Schur complement of the `m` equality rows after [`Riccati::factor`]: the responses
    /// `M_ij = a_i^T dx^(j)` (m chain solves) and the eigendecomposition of
    /// `W = delta_c I + diag(eq_reg) - M`. `delta_c` starts at 0 and grows from `1e-10 max|M_ii|`
    /// by 100 while W is singular (dependent rows). Returns the number of negative eigenvalues of W,
    /// which equals that of `P_0` exactly when the whole KKT matrix has the inertia of a local
    /// minimiser (Haynsworth: In(KKT) = In(S) + In(-C S^-1 C^T)).
    pub fn factor_schur(&mut self, lay: &Layout) -> Result<usize, NotPositive> {
        let m = self.m;
        if m == 0 {
            return Ok(0);
        }
        self.solve_responses(lay);
        let nxm = lay.nx_max;
        for i in 0..m {
            let k = self.eq_stage[i];
            let nx = lay.nx[k];
            let ai = &self.eq_a[i * nxm..i * nxm + nx];
            let rows = &self.resp_dz[lay.oz[k] * m..(lay.oz[k] + nx) * m];
            let si = &mut self.schur[i * m..(i + 1) * m];
            si.fill(0.0);
            for (a, r) in ai.iter().zip(rows.chunks_exact(m)) {
                for (x, y) in si.iter_mut().zip(r) {
                    *x += a * y;
                }
            }
        }
        let scale = (0..m)
            .map(|i| self.schur[i * m + i].abs())
            .fold(0.0_f64, f64::max)
            .max(1e-300);
        let mut delta_c = 0.0;
        for _attempt in 0..12 {
            for i in 0..m {
                for j in 0..m {
                    let v = -0.5 * (self.schur[i * m + j] + self.schur[j * m + i]);
                    self.schur_fac[i * m + j] = v + if i == j {
                        delta_c + self.eq_reg[i]
                    } else {
                        0.0
                    };
                }
            }
            if let Ok(neg) = count_inertia(
                &mut self.schur_fac[..m * m],
                m,
                &mut self.schur_d[..m],
                &mut self.schur_v[..m * m],
            ) {
                return Ok(neg);
            }
            delta_c = if delta_c == 0.0 {
                1e-10 * scale
            } else {
                delta_c * 100.0
            };
        }
        Err(NotPositive)
    }

    /// Solves the full QP (chain and the `m` equality rows) after [`Riccati::factor`] and
    /// [`Riccati::factor_schur`]: two chain solves and the small solve with W. Writes `dz`, `lam`
    /// and the equality multipliers `nu` (m).
    pub fn solve(
        &mut self,
        lay: &Layout,
        g: &[f64],
        bdef: &[f64],
        dz: &mut [f64],
        lam: &mut [f64],
        nu: &mut [f64],
    ) {
        let m = self.m;
        if m == 0 {
            self.solve_chain(lay, g, bdef, dz, lam);
            return;
        }
        // base solve, then (delta_c I + D - M) nu = a^T dx^0 + rho
        self.solve_chain(lay, g, bdef, dz, lam);
        for i in 0..m {
            nu[i] = self.eq_dot(lay, i, dz) + self.eq_rho[i];
        }
        eigen_solve(
            &self.schur_v[..m * m],
            &self.schur_d[..m],
            m,
            &mut nu[..m],
            &mut self.schur_tmp[..m],
        );
        // final solve with the gradient g + sum_j nu_j a_j (not the base plus nu times the
        // responses: near an active bound P_k has entries ~1/mu, and the cancellation in
        // lam = P dx + p is only consistent within one solve)
        let nxm = lay.nx_max;
        self.gw.copy_from_slice(g);
        for j in 0..m {
            let k = self.eq_stage[j];
            for i in 0..lay.nx[k] {
                self.gw[lay.oz[k] + i] += nu[j] * self.eq_a[j * nxm + i];
            }
        }
        let gw = std::mem::take(&mut self.gw);
        self.solve_chain(lay, &gw, bdef, dz, lam);
        self.gw = gw;
    }

    /// The responses `dz^(j)`, `lam^(j)` of the chain QP to the unit gradients `a_j` (at the
    /// state of stage `k_j`) with zero defects, for all m equality rows at once: the backward and
    /// forward passes of [`Riccati::solve_chain`] with m right-hand sides (matrix products instead
    /// of m matrix-vector passes). Sizes the response arrays on first use.
    fn solve_responses(&mut self, lay: &Layout) {
        let m = self.m;
        let kk = lay.kk;
        let (nz, nl) = (lay.n_z(), lay.n_l());
        let nx1m = lay.nx1.iter().copied().max().unwrap_or(0).max(lay.nx_max);
        if self.resp_dz.len() < nz * m {
            for v in [&mut self.resp_dz, &mut self.mpv, &mut self.mkff] {
                v.resize(nz * m, 0.0);
            }
            for v in [&mut self.resp_lam, &mut self.mpvt] {
                v.resize(nl * m, 0.0);
            }
            self.mt.resize(nx1m * m, 0.0);
            self.mw.resize(nx1m * m, 0.0);
            self.mrh.resize(lay.nu_max.max(1) * m, 0.0);
        }
        let nxm = lay.nx_max;
        for k in (0..=kk).rev() {
            let (nx, nu, nx1) = (lay.nx[k], lay.nu[k], lay.nx1[k]);
            let o = lay.oz[k] * m;
            let (pv_lo, pv_hi) = self.mpv.split_at_mut(lay.oz[k + 1] * m);
            let pk = &mut pv_lo[o..o + nx * m];
            pk.fill(0.0);
            for j in 0..m {
                if self.eq_stage[j] == k {
                    for i in 0..nx {
                        pk[i * m + j] = self.eq_a[j * nxm + i];
                    }
                }
            }
            let rh = &mut self.mrh[..nu * m];
            rh.fill(0.0);
            if k < kk {
                let t = &mut self.mt[..nx1 * m];
                let o1 = lay.op[k + 1];
                if self.soft {
                    // p~ = p - P S M^-1 S p
                    let d = &self.dsoft[lay.ol[k]..lay.ol[k + 1]];
                    let w = &mut self.mw[..nx1 * m];
                    for ((wi, pi), di) in w.chunks_exact_mut(m).zip(pv_hi.chunks_exact(m)).zip(d) {
                        let sd = di.sqrt();
                        for (x, y) in wi.iter_mut().zip(pi) {
                            *x = sd * y;
                        }
                    }
                    cholesky_solve(&self.lm[o1..o1 + nx1 * nx1], nx1, w, m, Scaling::Reciprocal);
                    for (wi, di) in w.chunks_exact_mut(m).zip(d) {
                        let sd = -di.sqrt();
                        for x in wi.iter_mut() {
                            *x *= sd;
                        }
                    }
                    let pt = &mut self.mpvt[lay.ol[k] * m..lay.ol[k + 1] * m];
                    pt.copy_from_slice(&pv_hi[..nx1 * m]);
                    gemm_nn_acc(&self.p[o1..o1 + nx1 * nx1], w, pt, nx1, nx1, m);
                    t.copy_from_slice(pt);
                } else {
                    t.copy_from_slice(&pv_hi[..nx1 * m]);
                }
                gemm_tn_acc(&self.a[lay.oa[k]..lay.oa[k + 1]], t, pk, nx1, nx, m);
                if nu > 0 {
                    gemm_tn_acc(&self.b[lay.ob[k]..lay.ob[k + 1]], t, rh, nx1, nu, m);
                }
            }
            if nu > 0 {
                let kf = &mut self.mkff[o..o + nu * m];
                kf.copy_from_slice(rh);
                cholesky_solve(
                    &self.lr[lay.or[k]..lay.or[k + 1]],
                    nu,
                    kf,
                    m,
                    Scaling::Reciprocal,
                );
                for v in kf.iter_mut() {
                    *v = -*v;
                }
                gemm_tn_acc(&self.kgain[lay.ok[k]..lay.ok[k + 1]], rh, pk, nu, nx, m);
            }
        }
        // forward: dx_0 = -P_0^-1 p_0 column by column
        let n0 = lay.nx[0];
        for c in 0..m {
            for i in 0..n0 {
                self.p0_col[i] = -self.mpv[i * m + c];
            }
            let mut col = std::mem::take(&mut self.p0_col);
            self.p0_solve(n0, &mut col);
            self.p0_col = col;
            for i in 0..n0 {
                self.resp_dz[i * m + c] = self.p0_col[i];
            }
        }
        for k in 0..=kk {
            let (nx, nu, nx1) = (lay.nx[k], lay.nu[k], lay.nx1[k]);
            let (dz_lo, dz_hi) = self.resp_dz.split_at_mut(lay.oz[k + 1] * m);
            let dzk = &mut dz_lo[lay.oz[k] * m..];
            let (dx, du) = dzk.split_at_mut(nx * m);
            if nu > 0 {
                du.copy_from_slice(&self.mkff[lay.oz[k] * m..lay.oz[k] * m + nu * m]);
                gemm_nn_acc(&self.kgain[lay.ok[k]..lay.ok[k + 1]], dx, du, nu, nx, m);
            }
            if k < kk {
                let dx1 = &mut dz_hi[..nx1 * m];
                dx1.fill(0.0);
                gemm_nn_acc(&self.a[lay.oa[k]..lay.oa[k + 1]], dx, dx1, nx1, nx, m);
                if nu > 0 {
                    gemm_nn_acc(&self.b[lay.ob[k]..lay.ob[k + 1]], du, dx1, nx1, nu, m);
                }
                // the multipliers lam^(j) are only needed for the soft dynamics' x_{k+1}
                if self.soft {
                    let lk = &mut self.resp_lam[lay.ol[k] * m..lay.ol[k + 1] * m];
                    lk.copy_from_slice(&self.mpvt[lay.ol[k] * m..lay.ol[k + 1] * m]);
                    let o1 = lay.op[k + 1];
                    gemm_nn_acc(&self.ptil[o1..o1 + nx1 * nx1], dx1, lk, nx1, nx1, m);
                    let d = &self.dsoft[lay.ol[k]..lay.ol[k + 1]];
                    for ((xi, li), di) in dx1.chunks_exact_mut(m).zip(lk.chunks_exact(m)).zip(d) {
                        for (x, l) in xi.iter_mut().zip(li) {
                            *x -= di * l;
                        }
                    }
                }
            }
        }
    }
}

/// Eigendecomposition of the symmetric n x n matrix `a` (destroyed) into `d`, `v`; the number of
/// negative eigenvalues, or an error if it is (numerically) singular or not finite.
fn count_inertia(
    a: &mut [f64],
    n: usize,
    d: &mut [f64],
    v: &mut [f64],
) -> Result<usize, NotPositive> {
    if !sym_eigen(a, n, d, v) {
        return Err(NotPositive);
    }
    let dmax = d[..n].iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    if n > 0 && !(dmax > 0.0 && d[..n].iter().all(|x| x.abs() > 1e-13 * dmax)) {
        return Err(NotPositive);
    }
    Ok(d[..n].iter().filter(|x| **x < 0.0).count())
}
