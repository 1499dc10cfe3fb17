//! Any [`OcpProblem`] as a [`SparseNlp`], so that the general-purpose backends (pounce, ripopt) solve
//! exactly the problem the stage-structured solver solves.
//!
//! ## Layout
//! - **Variables**: stage by stage, `[z_0, z_1, .., z_K]` with `z_k = [x_k, u_k]`; simple bounds as the
//!   problem gives them (a fixed `x_0` becomes `lo == hi`).
//! - **Constraints**, stage by stage: the stage inequalities `c_lo <= c_k(z_k) <= c_hi` (nc_k rows),
//!   then (k < K) the dynamics `f_k(z_k) - x_{k+1} = 0` (nx_{k+1} rows); after the last stage the
//!   terminal equalities `r(x_K) = 0`.
//! - **Jacobian**: the dense stage blocks `d c_k / d z_k`, `d f_k / d z_k` and `-I` on `x_{k+1}`, and
//!   `d r / d x_K`.
//! - **Hessian**: the lower triangle of every stage block, from [`OcpProblem::hessians`]; the NLP's
//!   `L = obj_factor f + lambda^T g` maps onto the OCP's `sigma = obj_factor`, `lam_k`, `mu_k`, `nu` =
//!   the entries of `lambda` on the dynamics, inequality and terminal rows (the `-x_{k+1}` terms are
//!   linear and contribute nothing).
//!
//! Values are cached per `x` (one problem evaluation serves objective, gradient, constraints and
//! Jacobian). An [`brachia_ocp::EvalError`] turns the requested values into NaN, which the NLP seam
//! reports to the backend as an evaluation failure.

use super::problem::SparseNlp;
use brachia_ocp::{
    EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageBounds, StageEval, TerminalEval,
};
use std::time::Instant;

/// Wall time spent in the adapter's callbacks, s.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct AdapterTimings {
    /// Problem evaluations (values and first derivatives).
    pub evaluation_s: f64,
    /// Hessian evaluations (including the scatter into the sparse lower triangle).
    pub hessian_s: f64,
}

/// An [`OcpProblem`] presented as a [`SparseNlp`] (see the module docs).
pub struct OcpNlp<P: OcpProblem> {
    problem: P,
    dims: OcpDims,
    /// First variable of every stage.
    var0: Vec<usize>,
    /// First row of every stage's inequalities and dynamics; first terminal row.
    crow: Vec<usize>,
    frow: Vec<usize>,
    rrow: usize,
    n_vars: usize,
    n_cons: usize,
    bounds: Vec<StageBounds>,
    primal: Primal,
    mult: Multipliers,
    stages: Vec<StageEval>,
    terminal: TerminalEval,
    cache_x: Vec<f64>,
    /// 0: nothing cached, 1: values, 2: values and first derivatives.
    cache_level: u8,
    cache_ok: bool,
    /// Time spent in the callbacks.
    pub timings: AdapterTimings,
}

impl<P: OcpProblem> OcpNlp<P> {
    /// Wrap `problem` (its dimensions and bounds are read once, here).
    pub fn new(problem: P) -> Self {
        let dims = problem.dims().clone();
        let k_last = dims.horizon();
        let (mut var0, mut crow, mut frow) = (vec![], vec![], vec![]);
        let (mut nv, mut nr) = (0, 0);
        for (k, d) in dims.stages.iter().enumerate() {
            var0.push(nv);
            nv += d.nz();
            crow.push(nr);
            nr += d.nc;
            frow.push(nr);
            if k < k_last {
                nr += dims.stages[k + 1].nx;
            }
        }
        let rrow = nr;
        nr += dims.n_terminal;
        let bounds = (0..dims.stages.len())
            .map(|k| {
                let mut b = StageBounds::unbounded(dims.stages[k]);
                problem.bounds(k, &mut b);
                b
            })
            .collect();
        let stages = dims.stage_evals();
        let terminal = dims.terminal_eval();
        OcpNlp {
            primal: Primal::zeros(&dims),
            mult: Multipliers::zeros(&dims),
            stages,
            terminal,
            problem,
            var0,
            crow,
            frow,
            rrow,
            n_vars: nv,
            n_cons: nr,
            bounds,
            dims,
            cache_x: vec![],
            cache_level: 0,
            cache_ok: false,
            timings: AdapterTimings::default(),
        }
    }

    /// The wrapped problem.
    pub fn problem(&self) -> &P {
        &self.problem
    }

    /// The wrapped problem, mutably.
    pub fn problem_mut(&mut self) -> &mut P {
        &mut self.problem
    }

    /// Unwrap.
    pub fn into_problem(self) -> P {
        self.problem
    }

    /// The stage point of a stacked NLP vector `x` (n_vars), into `z`.
    pub fn unstack(&self, x: &[f64], z: &mut Primal) {
        for (k, d) in self.dims.stages.iter().enumerate() {
            let o = self.var0[k];
            z.x[k].copy_from_slice(&x[o..o + d.nx]);
            z.u[k].copy_from_slice(&x[o + d.nx..o + d.nz()]);
        }
    }

    /// A stage point stacked into an NLP vector `x` (n_vars).
    pub fn stack(&self, z: &Primal, x: &mut [f64]) {
        for (k, d) in self.dims.stages.iter().enumerate() {
            let o = self.var0[k];
            x[o..o + d.nx].copy_from_slice(&z.x[k]);
            x[o + d.nx..o + d.nz()].copy_from_slice(&z.u[k]);
        }
    }

    /// The OCP multipliers in an NLP multiplier vector `lambda` (n_cons), into `m`.
    pub fn unstack_multipliers(&self, lambda: &[f64], m: &mut Multipliers) {
        for (k, d) in self.dims.stages.iter().enumerate() {
            m.mu[k].copy_from_slice(&lambda[self.crow[k]..self.crow[k] + d.nc]);
            let nf = m.lam[k].len();
            m.lam[k].copy_from_slice(&lambda[self.frow[k]..self.frow[k] + nf]);
        }
        m.nu.copy_from_slice(&lambda[self.rrow..self.rrow + self.dims.n_terminal]);
    }

    fn ensure(&mut self, x: &[f64], level: u8) {
        if self.cache_level >= level && self.cache_x.as_slice() == x {
            return;
        }
        let t0 = Instant::now();
        let mut z = std::mem::take(&mut self.primal);
        self.unstack(x, &mut z);
        let lv = if level >= 2 {
            EvalLevel::FirstOrder
        } else {
            EvalLevel::Values
        };
        self.cache_ok = self
            .problem
            .evaluate(&z, lv, &mut self.stages, &mut self.terminal)
            .is_ok();
        self.primal = z;
        self.cache_x.clear();
        self.cache_x.extend_from_slice(x);
        self.cache_level = level;
        self.timings.evaluation_s += t0.elapsed().as_secs_f64();
    }
}

impl<P: OcpProblem> SparseNlp for OcpNlp<P> {
    fn n_vars(&self) -> usize {
        self.n_vars
    }

    fn n_cons(&self) -> usize {
        self.n_cons
    }

    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        for (k, d) in self.dims.stages.iter().enumerate() {
            let (o, b) = (self.var0[k], &self.bounds[k]);
            x_l[o..o + d.nx].copy_from_slice(&b.x_lo);
            x_u[o..o + d.nx].copy_from_slice(&b.x_hi);
            x_l[o + d.nx..o + d.nz()].copy_from_slice(&b.u_lo);
            x_u[o + d.nx..o + d.nz()].copy_from_slice(&b.u_hi);
            let c = self.crow[k];
            g_l[c..c + d.nc].copy_from_slice(&b.c_lo);
            g_u[c..c + d.nc].copy_from_slice(&b.c_hi);
        }
        for k in 0..self.dims.horizon() {
            let (f, nf) = (self.frow[k], self.dims.stages[k + 1].nx);
            g_l[f..f + nf].fill(0.0);
            g_u[f..f + nf].fill(0.0);
        }
        let (r, nr) = (self.rrow, self.dims.n_terminal);
        g_l[r..r + nr].fill(0.0);
        g_u[r..r + nr].fill(0.0);
    }

    fn initial_guess(&self, x: &mut [f64]) {
        let mut z = Primal::zeros(&self.dims);
        self.problem.initial_guess(&mut z);
        self.stack(&z, x);
    }

    fn objective(&mut self, x: &[f64]) -> f64 {
        self.ensure(x, 1);
        if !self.cache_ok {
            return f64::NAN;
        }
        self.stages.iter().map(|s| s.cost).sum()
    }

    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) {
        self.ensure(x, 2);
        if !self.cache_ok {
            grad.fill(f64::NAN);
            return;
        }
        for (k, s) in self.stages.iter().enumerate() {
            let o = self.var0[k];
            grad[o..o + s.grad.len()].copy_from_slice(&s.grad);
        }
    }

    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        self.ensure(x, 1);
        if !self.cache_ok {
            g.fill(f64::NAN);
            return;
        }
        for (k, s) in self.stages.iter().enumerate() {
            let c = self.crow[k];
            g[c..c + s.c.len()].copy_from_slice(&s.c);
            let (f, o) = (self.frow[k], self.var0.get(k + 1).copied().unwrap_or(0));
            for (i, v) in s.f.iter().enumerate() {
                g[f + i] = v - x[o + i];
            }
        }
        let r = self.rrow;
        g[r..r + self.terminal.r.len()].copy_from_slice(&self.terminal.r);
    }

    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        let (mut rows, mut cols) = (vec![], vec![]);
        let k_last = self.dims.horizon();
        for (k, d) in self.dims.stages.iter().enumerate() {
            let o = self.var0[k];
            for r in 0..d.nc {
                for j in 0..d.nz() {
                    rows.push(self.crow[k] + r);
                    cols.push(o + j);
                }
            }
            if k < k_last {
                let nf = self.dims.stages[k + 1].nx;
                for r in 0..nf {
                    for j in 0..d.nz() {
                        rows.push(self.frow[k] + r);
                        cols.push(o + j);
                    }
                    rows.push(self.frow[k] + r);
                    cols.push(self.var0[k + 1] + r);
                }
            }
        }
        let (o, nx) = (self.var0[k_last], self.dims.stages[k_last].nx);
        for r in 0..self.dims.n_terminal {
            for j in 0..nx {
                rows.push(self.rrow + r);
                cols.push(o + j);
            }
        }
        (rows, cols)
    }

    fn jacobian_values(&mut self, x: &[f64], vals: &mut [f64]) {
        self.ensure(x, 2);
        if !self.cache_ok {
            vals.fill(f64::NAN);
            return;
        }
        let mut p = 0;
        let k_last = self.dims.horizon();
        for (k, s) in self.stages.iter().enumerate() {
            let nz = s.grad.len();
            vals[p..p + s.jac_c.len()].copy_from_slice(&s.jac_c);
            p += s.jac_c.len();
            if k < k_last {
                for r in 0..s.f.len() {
                    vals[p..p + nz].copy_from_slice(&s.jac_f[r * nz..(r + 1) * nz]);
                    vals[p + nz] = -1.0;
                    p += nz + 1;
                }
            }
        }
        let jr = &self.terminal.jac_r;
        vals[p..p + jr.len()].copy_from_slice(jr);
    }

    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        let (mut rows, mut cols) = (vec![], vec![]);
        for (k, d) in self.dims.stages.iter().enumerate() {
            let o = self.var0[k];
            for a in 0..d.nz() {
                for b in 0..=a {
                    rows.push(o + a);
                    cols.push(o + b);
                }
            }
        }
        (rows, cols)
    }

    fn hessian_values(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]) {
        let t0 = Instant::now();
        let (mut z, mut m) = (
            std::mem::take(&mut self.primal),
            std::mem::take(&mut self.mult),
        );
        self.unstack(x, &mut z);
        self.unstack_multipliers(lambda, &mut m);
        let ok = self
            .problem
            .hessians(&z, obj_factor, &m, &mut self.stages)
            .is_ok();
        self.primal = z;
        self.mult = m;
        if ok {
            let mut p = 0;
            for s in &self.stages {
                let nz = s.grad.len();
                for a in 0..nz {
                    vals[p..p + a + 1].copy_from_slice(&s.hess[a * nz..a * nz + a + 1]);
                    p += a + 1;
                }
            }
        } else {
            vals.fill(f64::NAN);
        }
        self.timings.hessian_s += t0.elapsed().as_secs_f64();
    }
}
