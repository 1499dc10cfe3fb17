//! Shared test problems: a generic linear-quadratic OCP (also written as one clarabel QP), dense
//! helpers and a random generator.
#![allow(dead_code)]

use brachia_ocp::*;
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// One stage of a linear-quadratic OCP: l = 1/2 z^T H z + q^T z, x+ = A x + B u + d, c = C z.
#[derive(Debug, Clone)]
pub struct LqStage {
    pub h: Vec<f64>,
    pub q: Vec<f64>,
    pub a: Vec<f64>,
    pub b: Vec<f64>,
    pub d: Vec<f64>,
    pub cm: Vec<f64>,
    pub bounds: StageBounds,
}

/// Linear-quadratic OCP with linear terminal rows r = G x_K + r0.
#[derive(Debug, Clone)]
pub struct LqProblem {
    pub dims: OcpDims,
    pub stages: Vec<LqStage>,
    pub g: Vec<f64>,
    pub r0: Vec<f64>,
    pub guess: Option<Primal>,
}

impl LqProblem {
    /// Zero data shaped like `dims` (no bounds).
    pub fn zeros(dims: OcpDims) -> Self {
        let kk = dims.horizon();
        let stages = (0..=kk)
            .map(|k| {
                let d = dims.stages[k];
                let nx1 = if k < kk { dims.stages[k + 1].nx } else { 0 };
                LqStage {
                    h: vec![0.0; d.nz() * d.nz()],
                    q: vec![0.0; d.nz()],
                    a: vec![0.0; nx1 * d.nx],
                    b: vec![0.0; nx1 * d.nu],
                    d: vec![0.0; nx1],
                    cm: vec![0.0; d.nc * d.nz()],
                    bounds: StageBounds::unbounded(d),
                }
            })
            .collect();
        let nr = dims.n_terminal;
        let nxk = dims.stages[kk].nx;
        LqProblem {
            g: vec![0.0; nr * nxk],
            r0: vec![0.0; nr],
            stages,
            dims,
            guess: None,
        }
    }

    pub fn nz_total(&self) -> usize {
        self.dims.stages.iter().map(|d| d.nz()).sum()
    }

    /// The flat z of a primal.
    pub fn flat(p: &Primal) -> Vec<f64> {
        let mut v = Vec::new();
        for k in 0..p.x.len() {
            v.extend_from_slice(&p.x[k]);
            v.extend_from_slice(&p.u[k]);
        }
        v
    }

    /// Objective at flat z.
    pub fn objective(&self, z: &[f64]) -> f64 {
        let mut o = 0;
        let mut j = 0.0;
        for (k, st) in self.stages.iter().enumerate() {
            let nz = self.dims.stages[k].nz();
            let zk = &z[o..o + nz];
            for a in 0..nz {
                j += st.q[a] * zk[a];
                for b in 0..nz {
                    j += 0.5 * zk[a] * st.h[a * nz + b] * zk[b];
                }
            }
            o += nz;
        }
        j
    }

    /// The same problem as a clarabel QP; returns (objective, flat z, status ok).
    pub fn solve_clarabel(&self) -> (f64, Vec<f64>, bool) {
        use clarabel::algebra::CscMatrix;
        use clarabel::solver::*;
        let n = self.nz_total();
        let kk = self.dims.horizon();
        let mut oz = vec![0];
        for d in &self.dims.stages {
            let l = *oz.last().unwrap();
            oz.push(l + d.nz());
        }
        let (mut pi, mut pj, mut pv) = (vec![], vec![], vec![]);
        let mut q = vec![0.0; n];
        for k in 0..=kk {
            let nz = self.dims.stages[k].nz();
            for a in 0..nz {
                q[oz[k] + a] = self.stages[k].q[a];
                for b in a..nz {
                    let v = self.stages[k].h[a * nz + b];
                    if v != 0.0 {
                        pi.push(oz[k] + a);
                        pj.push(oz[k] + b);
                        pv.push(v);
                    }
                }
            }
        }
        // rows: equalities first, then inequalities (A z <= b)
        let (mut ai, mut aj, mut av, mut bb) = (vec![], vec![], vec![], vec![]);
        let mut row = 0;
        for k in 0..kk {
            let d = self.dims.stages[k];
            let nx1 = self.dims.stages[k + 1].nx;
            let st = &self.stages[k];
            for r in 0..nx1 {
                for c in 0..d.nx {
                    ai.push(row);
                    aj.push(oz[k] + c);
                    av.push(st.a[r * d.nx + c]);
                }
                for c in 0..d.nu {
                    ai.push(row);
                    aj.push(oz[k] + d.nx + c);
                    av.push(st.b[r * d.nu + c]);
                }
                ai.push(row);
                aj.push(oz[k + 1] + r);
                av.push(-1.0);
                bb.push(-st.d[r]);
                row += 1;
            }
        }
        let nxk = self.dims.stages[kk].nx;
        for r in 0..self.dims.n_terminal {
            for c in 0..nxk {
                ai.push(row);
                aj.push(oz[kk] + c);
                av.push(self.g[r * nxk + c]);
            }
            bb.push(-self.r0[r]);
            row += 1;
        }
        // fixed variables
        for k in 0..=kk {
            let d = self.dims.stages[k];
            let b = &self.stages[k].bounds;
            for i in 0..d.nz() {
                let (lo, hi) = if i < d.nx {
                    (b.x_lo[i], b.x_hi[i])
                } else {
                    (b.u_lo[i - d.nx], b.u_hi[i - d.nx])
                };
                if lo == hi {
                    ai.push(row);
                    aj.push(oz[k] + i);
                    av.push(1.0);
                    bb.push(lo);
                    row += 1;
                }
            }
        }
        let n_eq = row;
        for k in 0..=kk {
            let d = self.dims.stages[k];
            let st = &self.stages[k];
            let b = &st.bounds;
            for i in 0..d.nz() {
                let (lo, hi) = if i < d.nx {
                    (b.x_lo[i], b.x_hi[i])
                } else {
                    (b.u_lo[i - d.nx], b.u_hi[i - d.nx])
                };
                if lo == hi {
                    continue;
                }
                if hi.is_finite() {
                    ai.push(row);
                    aj.push(oz[k] + i);
                    av.push(1.0);
                    bb.push(hi);
                    row += 1;
                }
                if lo.is_finite() {
                    ai.push(row);
                    aj.push(oz[k] + i);
                    av.push(-1.0);
                    bb.push(-lo);
                    row += 1;
                }
            }
            for j in 0..d.nc {
                for (sign, lim) in [(1.0, b.c_hi[j]), (-1.0, -b.c_lo[j])] {
                    if lim.is_finite() {
                        for c in 0..d.nz() {
                            ai.push(row);
                            aj.push(oz[k] + c);
                            av.push(sign * st.cm[j * d.nz() + c]);
                        }
                        bb.push(lim);
                        row += 1;
                    }
                }
            }
        }
        let p = CscMatrix::new_from_triplets(n, n, pi, pj, pv);
        let a = CscMatrix::new_from_triplets(row, n, ai, aj, av);
        let cones = [ZeroConeT(n_eq), NonnegativeConeT(row - n_eq)];
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .tol_gap_abs(1e-11)
            .tol_gap_rel(1e-11)
            .tol_feas(1e-11)
            .build()
            .unwrap();
        let mut solver = DefaultSolver::new(&p, &q, &a, &bb, &cones, settings).unwrap();
        solver.solve();
        let ok = matches!(
            solver.solution.status,
            SolverStatus::Solved | SolverStatus::AlmostSolved
        );
        (solver.solution.obj_val, solver.solution.x.clone(), ok)
    }
}

impl OcpProblem for LqProblem {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }
    fn bounds(&self, k: usize, b: &mut StageBounds) {
        let s = &self.stages[k].bounds;
        b.x_lo.copy_from_slice(&s.x_lo);
        b.x_hi.copy_from_slice(&s.x_hi);
        b.u_lo.copy_from_slice(&s.u_lo);
        b.u_hi.copy_from_slice(&s.u_hi);
        b.c_lo.copy_from_slice(&s.c_lo);
        b.c_hi.copy_from_slice(&s.c_hi);
    }
    fn initial_guess(&self, z: &mut Primal) {
        if let Some(g) = &self.guess {
            for k in 0..g.x.len() {
                z.x[k].copy_from_slice(&g.x[k]);
                z.u[k].copy_from_slice(&g.u[k]);
            }
        }
    }
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        let kk = self.dims.horizon();
        for k in 0..=kk {
            let d = self.dims.stages[k];
            let (nx, nu, nz) = (d.nx, d.nu, d.nz());
            let st = &self.stages[k];
            let e = &mut stages[k];
            let zk = |i: usize| if i < nx { z.x[k][i] } else { z.u[k][i - nx] };
            let mut cost = 0.0;
            for a in 0..nz {
                let mut hz = 0.0;
                for b in 0..nz {
                    hz += st.h[a * nz + b] * zk(b);
                }
                cost += 0.5 * zk(a) * hz + st.q[a] * zk(a);
                if level == EvalLevel::FirstOrder {
                    e.grad[a] = hz + st.q[a];
                }
            }
            e.cost = cost;
            if k < kk {
                let nx1 = self.dims.stages[k + 1].nx;
                for r in 0..nx1 {
                    let mut v = st.d[r];
                    for c in 0..nx {
                        v += st.a[r * nx + c] * zk(c);
                        if level == EvalLevel::FirstOrder {
                            e.jac_f[r * nz + c] = st.a[r * nx + c];
                        }
                    }
                    for c in 0..nu {
                        v += st.b[r * nu + c] * zk(nx + c);
                        if level == EvalLevel::FirstOrder {
                            e.jac_f[r * nz + nx + c] = st.b[r * nu + c];
                        }
                    }
                    e.f[r] = v;
                }
            }
            for j in 0..d.nc {
                e.c[j] = (0..nz).map(|c| st.cm[j * nz + c] * zk(c)).sum();
            }
            if level == EvalLevel::FirstOrder {
                e.jac_c.copy_from_slice(&st.cm);
            }
        }
        let nxk = self.dims.stages[kk].nx;
        for r in 0..self.dims.n_terminal {
            terminal.r[r] = self.r0[r]
                + (0..nxk)
                    .map(|c| self.g[r * nxk + c] * z.x[kk][c])
                    .sum::<f64>();
            if level == EvalLevel::FirstOrder {
                terminal.jac_r[r * nxk..(r + 1) * nxk]
                    .copy_from_slice(&self.g[r * nxk..(r + 1) * nxk]);
            }
        }
        Ok(())
    }
    fn hessians(
        &mut self,
        _z: &Primal,
        sigma: f64,
        _m: &Multipliers,
        stages: &mut [StageEval],
    ) -> Result<(), EvalError> {
        for (k, e) in stages.iter_mut().enumerate() {
            for (h, v) in e.hess.iter_mut().zip(&self.stages[k].h) {
                *h = sigma * v;
            }
        }
        Ok(())
    }
}

/// The minimum-energy double integrator: x = [p, v], u = a, step h, x_0 = [0, 0] fixed,
/// x_K = [1, 0], cost sum_k 1/2 h u_k^2.
pub fn double_integrator(kk: usize, h: f64) -> LqProblem {
    let stages: Vec<StageDims> = (0..=kk)
        .map(|k| StageDims {
            nx: 2,
            nu: if k < kk { 1 } else { 0 },
            nc: 0,
        })
        .collect();
    let mut p = LqProblem::zeros(OcpDims {
        stages,
        n_terminal: 2,
    });
    for k in 0..kk {
        let s = &mut p.stages[k];
        s.a = vec![1.0, h, 0.0, 1.0];
        s.b = vec![0.5 * h * h, h];
        s.h[2 * 3 + 2] = h;
    }
    p.stages[0].bounds.x_lo = vec![0.0, 0.0];
    p.stages[0].bounds.x_hi = vec![0.0, 0.0];
    p.g = vec![1.0, 0.0, 0.0, 1.0];
    p.r0 = vec![-1.0, 0.0];
    p
}

/// Least-norm solution of `E y = t` under the weight `W = diag(w)`: `y = W^-1 E^T (E W^-1 E^T)^-1 t`
/// (dense, Gaussian elimination with partial pivoting).
pub fn weighted_least_norm(e: &[Vec<f64>], w: &[f64], t: &[f64]) -> Vec<f64> {
    let m = e.len();
    let n = w.len();
    let mut s = vec![vec![0.0; m]; m];
    for i in 0..m {
        for j in 0..m {
            s[i][j] = (0..n).map(|c| e[i][c] * e[j][c] / w[c]).sum();
        }
    }
    let lam = dense_solve(s, t.to_vec());
    (0..n)
        .map(|c| (0..m).map(|i| e[i][c] * lam[i]).sum::<f64>() / w[c])
        .collect()
}

/// Dense solve by Gaussian elimination with partial pivoting.
pub fn dense_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let n = b.len();
    for c in 0..n {
        let piv = (c..n)
            .max_by(|&i, &j| a[i][c].abs().total_cmp(&a[j][c].abs()))
            .unwrap();
        a.swap(c, piv);
        b.swap(c, piv);
        for r in c + 1..n {
            let f = a[r][c] / a[c][c];
            for cc in c..n {
                a[r][cc] -= f * a[c][cc];
            }
            b[r] -= f * b[c];
        }
    }
    let mut x = vec![0.0; n];
    for r in (0..n).rev() {
        let s: f64 = (r + 1..n).map(|c| a[r][c] * x[c]).sum();
        x[r] = (b[r] - s) / a[r][r];
    }
    x
}

/// A random strictly convex, feasible linear-quadratic OCP: random sizes, dynamics, PD Hessians,
/// bounds and stage rows around a simulated trajectory (some active at the optimum), x_0 fixed
/// (partly free with `free_x0`), terminal rows through the simulated end state.
pub fn random_qp(
    rng: &mut ChaCha8Rng,
    kk: usize,
    nx: usize,
    nu: usize,
    nc: usize,
    nr: usize,
    free_x0: bool,
) -> LqProblem {
    random_qp_with(rng, kk, nx, nu, nc, nr, free_x0, 1.0, 0.3)
}

/// [`random_qp`] with dynamics `A = a_diag I + U(-a_spread, a_spread)` (stable for long horizons
/// with e.g. 0.9 and 0.05).
pub fn random_qp_with(
    rng: &mut ChaCha8Rng,
    kk: usize,
    nx: usize,
    nu: usize,
    nc: usize,
    nr: usize,
    free_x0: bool,
    a_diag: f64,
    a_spread: f64,
) -> LqProblem {
    let stages: Vec<StageDims> = (0..=kk)
        .map(|k| StageDims {
            nx,
            nu: if k < kk || rng.gen_bool(0.5) { nu } else { 0 },
            nc,
        })
        .collect();
    let mut p = LqProblem::zeros(OcpDims {
        stages: stages.clone(),
        n_terminal: nr,
    });
    let mut x: Vec<f64> = (0..nx).map(|_| rng.gen_range(-1.0..1.0)).collect();
    for k in 0..=kk {
        let d = stages[k];
        let nz = d.nz();
        let u: Vec<f64> = (0..d.nu).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let zbar: Vec<f64> = x.iter().chain(u.iter()).copied().collect();
        let st = &mut p.stages[k];
        // H = M^T M + 0.1 I
        let mm: Vec<f64> = (0..nz * nz).map(|_| rng.gen_range(-1.0..1.0)).collect();
        for a in 0..nz {
            for b in 0..nz {
                st.h[a * nz + b] = (0..nz)
                    .map(|r| mm[r * nz + a] * mm[r * nz + b])
                    .sum::<f64>()
                    + if a == b { 0.1 } else { 0.0 };
            }
            st.q[a] = rng.gen_range(-2.0..2.0);
        }
        for i in 0..nz {
            let (lo, hi) = if i < nx {
                (&mut st.bounds.x_lo[i], &mut st.bounds.x_hi[i])
            } else {
                (&mut st.bounds.u_lo[i - nx], &mut st.bounds.u_hi[i - nx])
            };
            if k == 0 && i < nx && !(free_x0 && i == 0) {
                *lo = zbar[i];
                *hi = zbar[i];
                continue;
            }
            if rng.gen_bool(0.5) {
                *lo = zbar[i] - rng.gen_range(0.0..0.5);
            }
            if rng.gen_bool(0.5) {
                *hi = zbar[i] + rng.gen_range(0.0..0.5);
            }
        }
        for j in 0..nc {
            let row: Vec<f64> = (0..nz).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let cv: f64 = row.iter().zip(&zbar).map(|(a, b)| a * b).sum();
            st.cm[j * nz..(j + 1) * nz].copy_from_slice(&row);
            if rng.gen_bool(0.7) {
                st.bounds.c_hi[j] = cv + rng.gen_range(0.0..0.3);
            }
            if rng.gen_bool(0.5) {
                st.bounds.c_lo[j] = cv - rng.gen_range(0.0..0.3);
            }
        }
        if k < kk {
            let nx1 = stages[k + 1].nx;
            let mut xn = vec![0.0; nx1];
            for r in 0..nx1 {
                for c in 0..nx {
                    st.a[r * nx + c] =
                        if r == c { a_diag } else { 0.0 } + rng.gen_range(-a_spread..a_spread);
                }
                for c in 0..d.nu {
                    st.b[r * d.nu + c] = rng.gen_range(-1.0..1.0);
                }
                st.d[r] = rng.gen_range(-0.1..0.1);
                xn[r] = st.d[r]
                    + (0..nx).map(|c| st.a[r * nx + c] * x[c]).sum::<f64>()
                    + (0..d.nu).map(|c| st.b[r * d.nu + c] * u[c]).sum::<f64>();
            }
            x = xn;
        } else {
            for r in 0..nr {
                for c in 0..nx {
                    p.g[r * nx + c] = rng.gen_range(-1.0..1.0);
                }
                p.r0[r] = -(0..nx).map(|c| p.g[r * nx + c] * x[c]).sum::<f64>();
            }
        }
    }
    p
}

/// A scalar with its gradient and Hessian w.r.t. the three stage variables z = [theta, omega, tau]
/// (hand-written second-order forward mode for the pendulum's RK4 step).
#[derive(Debug, Clone, Copy)]
pub struct Jet {
    pub v: f64,
    pub g: [f64; 3],
    pub h: [[f64; 3]; 3],
}

impl Jet {
    pub fn var(v: f64, i: usize) -> Jet {
        let mut g = [0.0; 3];
        g[i] = 1.0;
        Jet {
            v,
            g,
            h: [[0.0; 3]; 3],
        }
    }
    pub fn add(self, o: Jet) -> Jet {
        let mut r = self;
        r.v += o.v;
        for i in 0..3 {
            r.g[i] += o.g[i];
            for j in 0..3 {
                r.h[i][j] += o.h[i][j];
            }
        }
        r
    }
    pub fn scale(self, c: f64) -> Jet {
        let mut r = self;
        r.v *= c;
        for i in 0..3 {
            r.g[i] *= c;
            for j in 0..3 {
                r.h[i][j] *= c;
            }
        }
        r
    }
    pub fn sin(self) -> Jet {
        let (s, c) = self.v.sin_cos();
        let mut r = Jet {
            v: s,
            g: [0.0; 3],
            h: [[0.0; 3]; 3],
        };
        for i in 0..3 {
            r.g[i] = c * self.g[i];
            for j in 0..3 {
                r.h[i][j] = c * self.h[i][j] - s * self.g[i] * self.g[j];
            }
        }
        r
    }
}

/// Pendulum swing-up: theta = 0 hanging down, theta' = omega,
/// omega' = -g/l sin(theta) - b omega + tau / (m l^2); RK4 steps of h with tau held; x_0 = [0, 0]
/// fixed, x_K = [pi, 0]; cost sum_k 1/2 h (tau^2 + w omega^2); |tau| <= tau_max; stage rows
/// omega^2 <= omega_max^2.
#[derive(Debug, Clone)]
pub struct Pendulum {
    pub dims: OcpDims,
    pub h: f64,
    pub tau_max: f64,
    pub omega_max: f64,
    pub x0: [f64; 2],
    pub w: f64,
}

pub const G_L: f64 = 9.81;
pub const DAMP: f64 = 0.1;

impl Pendulum {
    pub fn new(kk: usize, h: f64, tau_max: f64) -> Self {
        let stages = (0..=kk)
            .map(|k| StageDims {
                nx: 2,
                nu: if k < kk { 1 } else { 0 },
                nc: 1,
            })
            .collect();
        Pendulum {
            dims: OcpDims {
                stages,
                n_terminal: 2,
            },
            h,
            tau_max,
            omega_max: 7.0,
            x0: [0.0, 0.0],
            w: 0.01,
        }
    }

    fn rhs(th: Jet, om: Jet, tau: Jet) -> [Jet; 2] {
        [om, th.sin().scale(-G_L).add(om.scale(-DAMP)).add(tau)]
    }

    /// One RK4 step with derivatives w.r.t. [theta, omega, tau].
    pub fn step(&self, x: [f64; 2], tau: f64) -> [Jet; 2] {
        let h = self.h;
        let th = Jet::var(x[0], 0);
        let om = Jet::var(x[1], 1);
        let u = Jet::var(tau, 2);
        let k1 = Self::rhs(th, om, u);
        let k2 = Self::rhs(
            th.add(k1[0].scale(h / 2.0)),
            om.add(k1[1].scale(h / 2.0)),
            u,
        );
        let k3 = Self::rhs(
            th.add(k2[0].scale(h / 2.0)),
            om.add(k2[1].scale(h / 2.0)),
            u,
        );
        let k4 = Self::rhs(th.add(k3[0].scale(h)), om.add(k3[1].scale(h)), u);
        let comb = |y: Jet, i: usize| {
            y.add(
                k1[i]
                    .add(k2[i].scale(2.0))
                    .add(k3[i].scale(2.0))
                    .add(k4[i])
                    .scale(h / 6.0),
            )
        };
        [comb(th, 0), comb(om, 1)]
    }
}

impl OcpProblem for Pendulum {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }
    fn bounds(&self, k: usize, b: &mut StageBounds) {
        if k == 0 {
            b.x_lo.copy_from_slice(&self.x0);
            b.x_hi.copy_from_slice(&self.x0);
        }
        if k < self.dims.horizon() {
            b.u_lo[0] = -self.tau_max;
            b.u_hi[0] = self.tau_max;
        }
        b.c_hi[0] = self.omega_max * self.omega_max;
    }
    fn initial_guess(&self, z: &mut Primal) {
        let kk = self.dims.horizon();
        for k in 0..=kk {
            let s = k as f64 / kk as f64;
            z.x[k][0] = std::f64::consts::PI * s;
            z.x[k][1] = std::f64::consts::PI / (kk as f64 * self.h);
        }
    }
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        let kk = self.dims.horizon();
        let h = self.h;
        for k in 0..=kk {
            let e = &mut stages[k];
            let (th, om) = (z.x[k][0], z.x[k][1]);
            let tau = if k < kk { z.u[k][0] } else { 0.0 };
            e.cost = if k < kk {
                0.5 * h * (tau * tau + self.w * om * om)
            } else {
                0.0
            };
            e.c[0] = om * om;
            if level == EvalLevel::FirstOrder {
                e.jac_c.fill(0.0);
                e.jac_c[1] = 2.0 * om;
                e.grad.fill(0.0);
                if k < kk {
                    e.grad[1] = h * self.w * om;
                    e.grad[2] = h * tau;
                }
            }
            if k < kk {
                let f = self.step([th, om], tau);
                for r in 0..2 {
                    e.f[r] = f[r].v;
                    if level == EvalLevel::FirstOrder {
                        e.jac_f[r * 3..r * 3 + 3].copy_from_slice(&f[r].g);
                    }
                }
            }
        }
        terminal.r[0] = z.x[kk][0] - std::f64::consts::PI;
        terminal.r[1] = z.x[kk][1];
        if level == EvalLevel::FirstOrder {
            terminal.jac_r.copy_from_slice(&[1.0, 0.0, 0.0, 1.0]);
        }
        Ok(())
    }
    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        m: &Multipliers,
        stages: &mut [StageEval],
    ) -> Result<(), EvalError> {
        let kk = self.dims.horizon();
        let h = self.h;
        for k in 0..=kk {
            let e = &mut stages[k];
            let nz = if k < kk { 3 } else { 2 };
            e.hess.fill(0.0);
            if k < kk {
                e.hess[3 + 1] = sigma * h * self.w; // (omega, omega)
                e.hess[2 * 3 + 2] = sigma * h;
                let f = self.step([z.x[k][0], z.x[k][1]], z.u[k][0]);
                for r in 0..2 {
                    for i in 0..3 {
                        for j in 0..3 {
                            e.hess[i * 3 + j] += m.lam[k][r] * f[r].h[i][j];
                        }
                    }
                }
            }
            e.hess[nz + 1] += 2.0 * m.mu[k][0]; // (omega, omega)
        }
        Ok(())
    }
}

/// Central finite-difference check of a vector function's Jacobian: `f(z) -> values`, analytic
/// `jac` (rows x n); returns the largest absolute error.
pub fn fd_jacobian_error(f: impl Fn(&[f64]) -> Vec<f64>, z: &[f64], jac: &[f64]) -> f64 {
    let n = z.len();
    let eps = 1e-6;
    let mut err = 0.0_f64;
    for c in 0..n {
        let mut zp = z.to_vec();
        let mut zm = z.to_vec();
        zp[c] += eps;
        zm[c] -= eps;
        let (fp, fm) = (f(&zp), f(&zm));
        for r in 0..fp.len() {
            let d = (fp[r] - fm[r]) / (2.0 * eps);
            err = err.max((d - jac[r * n + c]).abs());
        }
    }
    err
}

/// The double integrator with a free final time: x = [p, v, T] (T a constant state, free in x_0),
/// steps h = T / K, p+ = p + h v + h^2/2 u, v+ = v + h u, T+ = T; cost sum_k 1/2 h u_k^2 + w T
/// (at stage 0); x_0 = [0, 0, free], x_K = [1, 0, .]; T in [0.1, 10].
#[derive(Debug, Clone)]
pub struct FreeTime {
    pub dims: OcpDims,
    pub w: f64,
    pub t_guess: f64,
}

impl FreeTime {
    pub fn new(kk: usize, w: f64) -> Self {
        let stages = (0..=kk)
            .map(|k| StageDims {
                nx: 3,
                nu: if k < kk { 1 } else { 0 },
                nc: 0,
            })
            .collect();
        FreeTime {
            dims: OcpDims {
                stages,
                n_terminal: 2,
            },
            w,
            t_guess: 1.0,
        }
    }
}

impl OcpProblem for FreeTime {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }
    fn bounds(&self, k: usize, b: &mut StageBounds) {
        if k == 0 {
            b.x_lo[0] = 0.0;
            b.x_hi[0] = 0.0;
            b.x_lo[1] = 0.0;
            b.x_hi[1] = 0.0;
        }
        b.x_lo[2] = 0.1;
        b.x_hi[2] = 10.0;
    }
    fn initial_guess(&self, z: &mut Primal) {
        for x in z.x.iter_mut() {
            x[2] = self.t_guess;
        }
    }
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        st: &mut [StageEval],
        t: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        let kk = self.dims.horizon();
        let n = kk as f64;
        for k in 0..=kk {
            let (p, v, tt) = (z.x[k][0], z.x[k][1], z.x[k][2]);
            let h = tt / n;
            let e = &mut st[k];
            let u = if k < kk { z.u[k][0] } else { 0.0 };
            e.cost =
                if k < kk { 0.5 * h * u * u } else { 0.0 } + if k == 0 { self.w * tt } else { 0.0 };
            if level == EvalLevel::FirstOrder {
                e.grad.fill(0.0);
                if k < kk {
                    e.grad[2] = 0.5 * u * u / n;
                    e.grad[3] = h * u;
                }
                if k == 0 {
                    e.grad[2] += self.w;
                }
            }
            if k < kk {
                e.f[0] = p + h * v + 0.5 * h * h * u;
                e.f[1] = v + h * u;
                e.f[2] = tt;
                if level == EvalLevel::FirstOrder {
                    // columns [p, v, T, u]
                    e.jac_f.copy_from_slice(&[
                        1.0,
                        h,
                        (v + h * u) / n,
                        0.5 * h * h,
                        0.0,
                        1.0,
                        u / n,
                        h,
                        0.0,
                        0.0,
                        1.0,
                        0.0,
                    ]);
                }
            }
        }
        t.r[0] = z.x[kk][0] - 1.0;
        t.r[1] = z.x[kk][1];
        if level == EvalLevel::FirstOrder {
            t.jac_r.copy_from_slice(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
        }
        Ok(())
    }
    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        m: &Multipliers,
        st: &mut [StageEval],
    ) -> Result<(), EvalError> {
        let kk = self.dims.horizon();
        let n = kk as f64;
        for k in 0..=kk {
            let e = &mut st[k];
            e.hess.fill(0.0);
            if k == kk {
                continue;
            }
            let (tt, u) = (z.x[k][2], z.u[k][0]);
            let h = tt / n;
            let (l0, l1) = (m.lam[k][0], m.lam[k][1]);
            // z = [p, v, T, u]; index (i, j) = i * 4 + j
            let mut set = |i: usize, j: usize, v: f64| {
                e.hess[i * 4 + j] += v;
                if i != j {
                    e.hess[j * 4 + i] += v;
                }
            };
            // cost 1/2 h u^2 = 1/2 T/n u^2
            set(2, 3, sigma * u / n);
            set(3, 3, sigma * h);
            // f0 = p + T/n v + 1/2 (T/n)^2 u
            set(1, 2, l0 / n);
            set(2, 2, l0 * u / (n * n));
            set(2, 3, l0 * h / n);
            // f1 = v + T/n u
            set(2, 3, l1 / n);
            let _ = tt;
        }
        Ok(())
    }
}

/// [`FreeTime`] with T fixed at `t` and removed from the state: x = [p, v], the same dynamics and
/// stage costs (`w T` is then a constant and left out).
#[derive(Debug, Clone)]
pub struct FixedTime {
    pub dims: OcpDims,
    pub t: f64,
}

impl FixedTime {
    pub fn new(kk: usize, t: f64) -> Self {
        let stages = (0..=kk)
            .map(|k| StageDims {
                nx: 2,
                nu: if k < kk { 1 } else { 0 },
                nc: 0,
            })
            .collect();
        FixedTime {
            dims: OcpDims {
                stages,
                n_terminal: 2,
            },
            t,
        }
    }
}

impl OcpProblem for FixedTime {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }
    fn bounds(&self, k: usize, b: &mut StageBounds) {
        if k == 0 {
            b.x_lo.fill(0.0);
            b.x_hi.fill(0.0);
        }
    }
    fn initial_guess(&self, _z: &mut Primal) {}
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        st: &mut [StageEval],
        t: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        let kk = self.dims.horizon();
        let h = self.t / kk as f64;
        for k in 0..=kk {
            let (p, v) = (z.x[k][0], z.x[k][1]);
            let e = &mut st[k];
            let u = if k < kk { z.u[k][0] } else { 0.0 };
            e.cost = if k < kk { 0.5 * h * u * u } else { 0.0 };
            if level == EvalLevel::FirstOrder {
                e.grad.fill(0.0);
                if k < kk {
                    e.grad[2] = h * u;
                }
            }
            if k < kk {
                e.f[0] = p + h * v + 0.5 * h * h * u;
                e.f[1] = v + h * u;
                if level == EvalLevel::FirstOrder {
                    e.jac_f.copy_from_slice(&[1.0, h, 0.5 * h * h, 0.0, 1.0, h]);
                }
            }
        }
        t.r[0] = z.x[kk][0] - 1.0;
        t.r[1] = z.x[kk][1];
        if level == EvalLevel::FirstOrder {
            t.jac_r.copy_from_slice(&[1.0, 0.0, 0.0, 1.0]);
        }
        Ok(())
    }
    fn hessians(
        &mut self,
        _z: &Primal,
        sigma: f64,
        _m: &Multipliers,
        st: &mut [StageEval],
    ) -> Result<(), EvalError> {
        let kk = self.dims.horizon();
        let h = self.t / kk as f64;
        for (k, e) in st.iter_mut().enumerate() {
            e.hess.fill(0.0);
            if k < kk {
                e.hess[2 * 3 + 2] = sigma * h;
            }
        }
        Ok(())
    }
}

/// Energy of the discrete minimum-energy rest-to-rest transfer over 1 m in time `t` with `kk` steps.
pub fn min_energy_for_time(kk: usize, t: f64) -> f64 {
    let h = t / kk as f64;
    let mut e = vec![vec![0.0; kk]; 2];
    for k in 0..kk {
        let steps = (kk - 1 - k) as f64;
        e[0][k] = 0.5 * h * h + steps * h * h;
        e[1][k] = h;
    }
    let u = weighted_least_norm(&e, &vec![h; kk], &[1.0, 0.0]);
    u.iter().map(|u| 0.5 * h * u * u).sum()
}
