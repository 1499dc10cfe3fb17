//! Direct collocation of the swing (paper eqs. 3-10) as a sparse NLP with exact derivatives.
//!
//! Variables: one block `z_p = [q (n), qd (n), tau (n-1)]` per collocation point p (rad, rad/s, N m). For
//! Euler and trapezoidal transcriptions the points are the N + 1 knots; for Hermite-Simpson (separated
//! form) they are the knots and the interval midpoints interleaved (point 2k = knot k, 2k+1 = midpoint).
//!
//! Every defect equation of every transcription is stored the same way: a [`Row`] of constant linear
//! terms on variables plus weighted terms on `qdd` at some points. So one routine evaluates constraints, one
//! the Jacobian (linear coefficients plus weighted rows of `d qdd / d z_p`), and one the Hessian of the
//! Lagrangian (per point, the Hessian of `omega_p . qdd(z_p)` where `omega_p` collects multiplier times
//! coefficient). Boundary constraints: final EE position and velocity (eqs. 8-9). Optional path
//! constraints (obstacle and self-collision clearances, eqs. 11-13) on q at every point but the first.
//! Sparsity patterns are built once; values are scattered through precomputed slots (no hashing per call).

use crate::ad::{Diff, LocalFn};
use crate::math::Scalar;
use crate::model::Robot;
use crate::planning::nlp::SparseNlp;
use crate::planning::settings::Transcription;
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Instant;

/// The swing's terminal constraint as a [`LocalFn`]: `[q, qd] (2n) -> [ee_x, ee_y, ee_vx, ee_vy]`
/// (paper eqs. 8-9: final EE position on the bar, final EE velocity `J qd` zero). Owns a shared
/// handle to its robot.
#[derive(Debug, Clone)]
pub struct EeTerminalFn {
    /// The robot.
    pub robot: Arc<Robot>,
}

impl EeTerminalFn {
    /// The terminal map of `robot` (a `Robot` or a shared `Arc<Robot>`).
    pub fn new(robot: impl Into<Arc<Robot>>) -> Self {
        EeTerminalFn {
            robot: robot.into(),
        }
    }
}

impl LocalFn for EeTerminalFn {
    type Scratch<T: Scalar> = ();
    fn n_in(&self) -> usize {
        2 * self.robot.n
    }
    fn n_out(&self) -> usize {
        4
    }
    fn scratch<T: Scalar>(&self) {}
    fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
        let n = self.robot.n;
        let (q, qd) = z.split_at(n);
        let p = self.robot.ee_position(q);
        let v = self.robot.ee_velocity(q, qd);
        out.copy_from_slice(&[p[0], p[1], v[0], v[1]]);
    }
    fn hessian_entry_is_zero(&self, i: usize, j: usize) -> bool {
        let n = self.robot.n;
        i >= n && j >= n // position is independent of qd, velocity linear in it
    }
}

/// No path constraints.
#[derive(Debug, Clone, Copy)]
pub struct NoPath;

impl LocalFn for NoPath {
    type Scratch<T: Scalar> = ();
    fn n_in(&self) -> usize {
        0
    }
    fn n_out(&self) -> usize {
        0
    }
    fn scratch<T: Scalar>(&self) {}
    fn eval<T: Scalar>(&self, _: &mut (), _: &[T], _: &mut [T]) {}
}

/// Where the variables of the transcription live.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layout {
    /// Degrees of freedom (links) n.
    pub n: usize,
    /// Inputs per point (n - 1 for the robot).
    pub nu: usize,
    /// Variables per point, 2n + nu.
    pub nz: usize,
    /// Intervals N.
    pub intervals: usize,
    /// Collocation points (N + 1, or 2N + 1 for Hermite-Simpson).
    pub points: usize,
    /// Interval length h = T / N, s.
    pub h: f64,
    /// The rule.
    pub transcription: Transcription,
}

impl Layout {
    /// Layout for `intervals` intervals over `t_final` seconds.
    pub fn new(
        n: usize,
        nu: usize,
        intervals: usize,
        t_final: f64,
        transcription: Transcription,
    ) -> Self {
        let points = match transcription {
            Transcription::HermiteSimpson => 2 * intervals + 1,
            _ => intervals + 1,
        };
        Layout {
            n,
            nu,
            nz: 2 * n + nu,
            intervals,
            points,
            h: t_final / intervals as f64,
            transcription,
        }
    }
    /// Index of variable `k` (0..nz: q, qd, tau) of point `p`.
    pub fn var(&self, p: usize, k: usize) -> usize {
        p * self.nz + k
    }
    /// Time of point `p`, s.
    pub fn time(&self, p: usize) -> f64 {
        match self.transcription {
            Transcription::HermiteSimpson => p as f64 * self.h * 0.5,
            _ => p as f64 * self.h,
        }
    }
    /// Point of knot `k`.
    pub fn knot(&self, k: usize) -> usize {
        match self.transcription {
            Transcription::HermiteSimpson => 2 * k,
            _ => k,
        }
    }
    /// Number of variables.
    pub fn n_vars(&self) -> usize {
        self.points * self.nz
    }
    /// Quadrature weight of point `p` for integrals over the swing (trapezoid or Simpson), s.
    pub fn quadrature_weight(&self, p: usize) -> f64 {
        let h = self.h;
        match self.transcription {
            Transcription::HermiteSimpson => {
                if p % 2 == 1 {
                    4.0 * h / 6.0
                } else if p == 0 || p == self.points - 1 {
                    h / 6.0
                } else {
                    2.0 * h / 6.0
                }
            }
            _ => {
                if p == 0 || p == self.points - 1 {
                    h / 2.0
                } else {
                    h
                }
            }
        }
    }
}

/// A defect equation: `sum lin.coef * x[lin.var] + sum dynt.coef * qdd_{p}[i] = 0`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Row {
    /// Constant linear terms `(variable, coefficient)`.
    pub lin: Vec<(usize, f64)>,
    /// Terms on accelerations `(point, component, coefficient)`.
    pub dynt: Vec<(usize, usize, f64)>,
}

/// The defect rows of a transcription.
///
/// # Panics
/// For [`Transcription::MultipleShooting`], which is not a collocation rule (its problem is
/// [`crate::planning::SwingOcp`]); a programmer's error.
pub fn defect_rows(l: &Layout) -> Vec<Row> {
    let (n, h) = (l.n, l.h);
    let q = |p: usize, i: usize| l.var(p, i);
    let qd = |p: usize, i: usize| l.var(p, n + i);
    let mut rows = Vec::new();
    for k in 0..l.intervals {
        let (a, b) = (l.knot(k), l.knot(k + 1));
        match l.transcription {
            Transcription::MultipleShooting => {
                panic!("multiple shooting is not a collocation rule: build a SwingOcp")
            }
            Transcription::Euler => {
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![(q(b, i), 1.0), (q(a, i), -1.0), (qd(a, i), -h)],
                        dynt: vec![(a, i, -0.5 * h * h)],
                    });
                }
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![(qd(b, i), 1.0), (qd(a, i), -1.0)],
                        dynt: vec![(a, i, -h)],
                    });
                }
            }
            Transcription::Trapezoidal => {
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![
                            (q(b, i), 1.0),
                            (q(a, i), -1.0),
                            (qd(a, i), -0.5 * h),
                            (qd(b, i), -0.5 * h),
                        ],
                        dynt: vec![],
                    });
                }
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![(qd(b, i), 1.0), (qd(a, i), -1.0)],
                        dynt: vec![(a, i, -0.5 * h), (b, i, -0.5 * h)],
                    });
                }
            }
            Transcription::HermiteSimpson => {
                let c = a + 1;
                // Hermite interpolation of the midpoint
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![
                            (q(c, i), 1.0),
                            (q(a, i), -0.5),
                            (q(b, i), -0.5),
                            (qd(a, i), -h / 8.0),
                            (qd(b, i), h / 8.0),
                        ],
                        dynt: vec![],
                    });
                }
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![(qd(c, i), 1.0), (qd(a, i), -0.5), (qd(b, i), -0.5)],
                        dynt: vec![(a, i, -h / 8.0), (b, i, h / 8.0)],
                    });
                }
                // Simpson quadrature
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![
                            (q(b, i), 1.0),
                            (q(a, i), -1.0),
                            (qd(a, i), -h / 6.0),
                            (qd(c, i), -4.0 * h / 6.0),
                            (qd(b, i), -h / 6.0),
                        ],
                        dynt: vec![],
                    });
                }
                for i in 0..n {
                    rows.push(Row {
                        lin: vec![(qd(b, i), 1.0), (qd(a, i), -1.0)],
                        dynt: vec![(a, i, -h / 6.0), (c, i, -4.0 * h / 6.0), (b, i, -h / 6.0)],
                    });
                }
            }
        }
    }
    rows
}

/// The blocks of a [`CollocationNlp`]'s constraint vector, in row order.
#[derive(Debug, Clone, Copy)]
pub struct RowBlocks<'g> {
    /// Dynamics defects (zero at a solution).
    pub defects: &'g [f64],
    /// The terminal rows of [`EeTerminalFn`]: EE position (x, y), m, then EE velocity (x, y), m/s.
    pub terminal: &'g [f64],
    /// Path constraints (clearances, >= 0), `n_path` per point after the first.
    pub path: &'g [f64],
}

/// A trajectory-optimisation problem as a sparse NLP: second-order dynamics `qdd = D(q, qd, u)` imposed
/// by the layout's transcription, a terminal constraint `T(q_N, qd_N) = target` and path constraints
/// `P(q_p) >= 0`. Built by [`crate::planning::plan`] for the swing (D = the robot's forward dynamics,
/// T = [`EeTerminalFn`], P = capsule clearances); public so that other systems (tests with known answers,
/// future grip-switching phases) use the very same transcription.
pub struct CollocationNlp<D: LocalFn, T: LocalFn, P: LocalFn = NoPath> {
    /// Variable layout.
    pub layout: Layout,
    rows: Vec<Row>,
    target: Vec<f64>,
    cost_w: Vec<f64>,
    x_l: Vec<f64>,
    x_u: Vec<f64>,
    x0: Vec<f64>,
    dynf: D,
    ddiff: Diff<D>,
    term: T,
    tdiff: Diff<T>,
    path: Option<(P, Diff<P>)>,
    n_path: usize,
    // caches keyed by x
    cache_x: Vec<f64>,
    cache_level: u8,
    qdd: Vec<f64>,
    qdd_jac: Vec<f64>,
    omega: Vec<f64>,
    hbuf: Vec<f64>,
    vbuf: Vec<f64>,
    jbuf: Vec<f64>,
    jac_pattern: Pattern,
    hess_pattern: Pattern,
    /// Wall time spent in the callbacks, for profiling.
    pub timings: CallbackTimings,
}

/// Wall time spent in each kind of callback of a [`CollocationNlp`], s.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CallbackTimings {
    /// Objective and gradient.
    pub objective_s: f64,
    /// Constraint values (including the qdd evaluations they trigger).
    pub constraints_s: f64,
    /// Constraint Jacobian (including the AD Jacobians of qdd).
    pub jacobian_s: f64,
    /// Hessian of the Lagrangian (AD Hessians and assembly).
    pub hessian_s: f64,
    /// Number of Hessian evaluations.
    pub hessian_calls: usize,
}

impl CallbackTimings {
    /// Total callback time, s.
    pub fn total_s(&self) -> f64 {
        self.objective_s + self.constraints_s + self.jacobian_s + self.hessian_s
    }

    /// Add `other` to `self`, kind by kind.
    pub fn add(&mut self, other: &CallbackTimings) {
        self.objective_s += other.objective_s;
        self.constraints_s += other.constraints_s;
        self.jacobian_s += other.jacobian_s;
        self.hessian_s += other.hessian_s;
        self.hessian_calls += other.hessian_calls;
    }
}

/// A fixed sparsity pattern and the slot of every emitted entry.
#[derive(Debug, Clone, Default)]
struct Pattern {
    rows: Vec<usize>,
    cols: Vec<usize>,
    slots: Vec<usize>,
}

impl Pattern {
    fn from_entries(entries: &[(usize, usize)]) -> Self {
        let mut map: HashMap<(usize, usize), usize> = HashMap::with_capacity(entries.len());
        let mut p = Pattern::default();
        for &(r, c) in entries {
            let next = p.rows.len();
            let s = *map.entry((r, c)).or_insert(next);
            if s == next {
                p.rows.push(r);
                p.cols.push(c);
            }
            p.slots.push(s);
        }
        p
    }
}

impl<D: LocalFn, T: LocalFn, P: LocalFn> CollocationNlp<D, T, P> {
    /// Build the NLP. `dynamics` maps `[q, qd, u]` to `qdd`; `terminal` maps `[q, qd]` of the last point
    /// to values that must equal `target`; `x_l`, `x_u` are the variable bounds (fixed start and final
    /// input included), `x0` the initial guess, `q1`/`r1` the cost weights on qd and u (cost: the
    /// transcription's quadrature of `||qd||^2_Q1 + ||u||^2_R1`), `path` the optional constraint on q.
    ///
    /// # Panics
    /// When the layout's transcription is [`Transcription::MultipleShooting`] (see [`defect_rows`]).
    pub fn new(
        dynamics: D,
        terminal: T,
        layout: Layout,
        target: Vec<f64>,
        (x_l, x_u): (Vec<f64>, Vec<f64>),
        x0: Vec<f64>,
        (q1, r1): (&[f64], &[f64]),
        path: Option<P>,
    ) -> Self {
        let (n, nz) = (layout.n, layout.nz);
        assert_eq!(dynamics.n_in(), nz, "dynamics inputs must be [q, qd, u]");
        assert_eq!(dynamics.n_out(), n, "dynamics outputs must be qdd");
        assert_eq!(terminal.n_in(), 2 * n, "terminal inputs must be [q, qd]");
        assert_eq!(
            terminal.n_out(),
            target.len(),
            "one target per terminal output"
        );
        let nt = target.len();
        let mut cost_w = vec![0.0; layout.n_vars()];
        for p in 0..layout.points {
            let w = layout.quadrature_weight(p);
            for i in 0..n {
                cost_w[layout.var(p, n + i)] = w * q1[i];
            }
            for j in 0..layout.nu {
                cost_w[layout.var(p, 2 * n + j)] = w * r1[j];
            }
        }
        let n_path = path.as_ref().map_or(0, |p| p.n_out());
        let path = path.map(|p| {
            let d = Diff::new(&p);
            (p, d)
        });
        let mut s = CollocationNlp {
            rows: defect_rows(&layout),
            layout,
            target,
            cost_w,
            x_l,
            x_u,
            x0,
            ddiff: Diff::new(&dynamics),
            dynf: dynamics,
            tdiff: Diff::new(&terminal),
            term: terminal,
            path,
            n_path,
            cache_x: vec![],
            cache_level: 0,
            qdd: vec![0.0; layout.points * n],
            qdd_jac: vec![0.0; layout.points * n * nz],
            omega: vec![0.0; layout.points * n],
            hbuf: vec![0.0; 4 * nz * nz],
            vbuf: vec![0.0; n_path.max(nt).max(1)],
            jbuf: vec![0.0; 2 * n * n_path.max(nt).max(1)],
            jac_pattern: Pattern::default(),
            hess_pattern: Pattern::default(),
            timings: CallbackTimings::default(),
        };
        let x0 = s.x0.clone();
        let mut entries = Vec::new();
        s.jac_walk(&x0, &mut |r, c, _| entries.push((r, c)));
        s.jac_pattern = Pattern::from_entries(&entries);
        entries.clear();
        let lam = vec![1.0; s.n_cons()];
        s.hess_walk(&x0, 1.0, &lam, &mut |r, c, _| entries.push((r, c)));
        s.hess_pattern = Pattern::from_entries(&entries);
        s.timings = CallbackTimings::default();
        s
    }

    /// Number of defect rows.
    pub fn n_defects(&self) -> usize {
        self.rows.len()
    }

    /// Number of path-constraint rows per point.
    pub fn n_path(&self) -> usize {
        self.n_path
    }

    /// Number of terminal rows (they follow the defects).
    pub fn n_terminal(&self) -> usize {
        self.target.len()
    }

    /// First row of the path constraints.
    pub fn path_row0(&self) -> usize {
        self.rows.len() + self.target.len()
    }

    /// The constraint vector `g` (length `n_cons`) split into its named blocks.
    pub fn row_blocks<'g>(&self, g: &'g [f64]) -> RowBlocks<'g> {
        let (r0, p0) = (self.rows.len(), self.path_row0());
        RowBlocks {
            defects: &g[..r0],
            terminal: &g[r0..p0],
            path: &g[p0..],
        }
    }

    /// qdd at every point for `x` (row-major points x n).
    pub fn accelerations(&mut self, x: &[f64]) -> &[f64] {
        self.ensure(x, 1);
        &self.qdd
    }

    fn ensure(&mut self, x: &[f64], level: u8) {
        if self.cache_level >= level && self.cache_x.as_slice() == x {
            return;
        }
        let (n, nz) = (self.layout.n, self.layout.nz);
        for p in 0..self.layout.points {
            let z = &x[p * nz..(p + 1) * nz];
            let out = &mut self.qdd[p * n..(p + 1) * n];
            if level >= 2 {
                let jac = &mut self.qdd_jac[p * n * nz..(p + 1) * n * nz];
                self.ddiff.jacobian(&self.dynf, z, out, jac);
            } else {
                self.ddiff.value(&self.dynf, z, out);
            }
        }
        self.cache_x.clear();
        self.cache_x.extend_from_slice(x);
        self.cache_level = level;
    }

    fn last_point(&self) -> usize {
        self.layout.points - 1
    }

    fn jac_walk(&mut self, x: &[f64], emit: &mut dyn FnMut(usize, usize, f64)) {
        self.ensure(x, 2);
        let (n, nz) = (self.layout.n, self.layout.nz);
        for (r, row) in self.rows.iter().enumerate() {
            for &(v, c) in &row.lin {
                emit(r, v, c);
            }
            for &(p, i, c) in &row.dynt {
                let jrow = &self.qdd_jac[(p * n + i) * nz..(p * n + i + 1) * nz];
                for (j, &d) in jrow.iter().enumerate() {
                    emit(r, p * nz + j, c * d);
                }
            }
        }
        let r0 = self.rows.len();
        let pl = self.last_point();
        let zl = &x[pl * nz..pl * nz + 2 * n];
        let nt = self.target.len();
        self.tdiff.jacobian(
            &self.term,
            zl,
            &mut self.vbuf[..nt],
            &mut self.jbuf[..nt * 2 * n],
        );
        for r in 0..nt {
            for j in 0..2 * n {
                emit(r0 + r, pl * nz + j, self.jbuf[r * 2 * n + j]);
            }
        }
        if let Some((pf, pd)) = &mut self.path {
            let np = self.n_path;
            let r0 = r0 + nt;
            for p in 1..self.layout.points {
                let q = &x[p * nz..p * nz + n];
                pd.jacobian(pf, q, &mut self.vbuf[..np], &mut self.jbuf[..np * n]);
                for r in 0..np {
                    for j in 0..n {
                        emit(r0 + (p - 1) * np + r, p * nz + j, self.jbuf[r * n + j]);
                    }
                }
            }
        }
    }

    fn hess_walk(
        &mut self,
        x: &[f64],
        obj_factor: f64,
        lambda: &[f64],
        emit: &mut dyn FnMut(usize, usize, f64),
    ) {
        let (n, nz) = (self.layout.n, self.layout.nz);
        for (i, &w) in self.cost_w.iter().enumerate() {
            if w != 0.0 {
                emit(i, i, 2.0 * w * obj_factor);
            }
        }
        self.omega.fill(0.0);
        for (r, row) in self.rows.iter().enumerate() {
            for &(p, i, c) in &row.dynt {
                self.omega[p * n + i] += lambda[r] * c;
            }
        }
        let h = &mut self.hbuf[..nz * nz];
        for p in 0..self.layout.points {
            let z = &x[p * nz..(p + 1) * nz];
            self.ddiff
                .hessian_weighted(&self.dynf, z, &self.omega[p * n..(p + 1) * n], h);
            for a in 0..nz {
                for b in 0..=a {
                    if !self.dynf.hessian_entry_is_zero(a, b) {
                        emit(p * nz + a, p * nz + b, h[a * nz + b]);
                    }
                }
            }
        }
        let r0 = self.rows.len();
        let pl = self.last_point();
        let zl = &x[pl * nz..pl * nz + 2 * n];
        let nt = self.target.len();
        let h = &mut self.hbuf[..4 * n * n];
        self.tdiff
            .hessian_weighted(&self.term, zl, &lambda[r0..r0 + nt], h);
        for a in 0..2 * n {
            for b in 0..=a {
                if !self.term.hessian_entry_is_zero(a, b) {
                    emit(pl * nz + a, pl * nz + b, h[a * 2 * n + b]);
                }
            }
        }
        if let Some((pf, pd)) = &mut self.path {
            let np = self.n_path;
            let r0 = r0 + nt;
            let h = &mut self.hbuf[..n * n];
            for p in 1..self.layout.points {
                let q = &x[p * nz..p * nz + n];
                let lam = &lambda[r0 + (p - 1) * np..r0 + p * np];
                pd.hessian_weighted(pf, q, lam, h);
                for a in 0..n {
                    for b in 0..=a {
                        emit(p * nz + a, p * nz + b, h[a * n + b]);
                    }
                }
            }
        }
    }
}

impl<D: LocalFn, T: LocalFn, P: LocalFn> SparseNlp for CollocationNlp<D, T, P> {
    fn n_vars(&self) -> usize {
        self.layout.n_vars()
    }
    fn n_cons(&self) -> usize {
        self.rows.len() + self.target.len() + (self.layout.points - 1) * self.n_path
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        x_l.copy_from_slice(&self.x_l);
        x_u.copy_from_slice(&self.x_u);
        let r0 = self.rows.len();
        let nt = self.target.len();
        g_l[..r0].fill(0.0);
        g_u[..r0].fill(0.0);
        g_l[r0..r0 + nt].copy_from_slice(&self.target);
        g_u[r0..r0 + nt].copy_from_slice(&self.target);
        g_l[r0 + nt..].fill(0.0);
        g_u[r0 + nt..].fill(f64::INFINITY);
    }
    fn initial_guess(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x0);
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        let t = Instant::now();
        let f = x.iter().zip(&self.cost_w).map(|(v, w)| w * v * v).sum();
        self.timings.objective_s += t.elapsed().as_secs_f64();
        f
    }
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) {
        let t = Instant::now();
        for ((g, v), w) in grad.iter_mut().zip(x).zip(&self.cost_w) {
            *g = 2.0 * w * v;
        }
        self.timings.objective_s += t.elapsed().as_secs_f64();
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        let t0 = Instant::now();
        self.ensure(x, 1);
        let (n, nz) = (self.layout.n, self.layout.nz);
        for (r, row) in self.rows.iter().enumerate() {
            let mut v = 0.0;
            for &(var, c) in &row.lin {
                v += c * x[var];
            }
            for &(p, i, c) in &row.dynt {
                v += c * self.qdd[p * n + i];
            }
            g[r] = v;
        }
        let r0 = self.rows.len();
        let pl = self.last_point();
        let zl = &x[pl * nz..pl * nz + 2 * n];
        let nt = self.target.len();
        self.tdiff.value(&self.term, zl, &mut g[r0..r0 + nt]);
        if let Some((pf, pd)) = &mut self.path {
            let np = self.n_path;
            for p in 1..self.layout.points {
                let q = &x[p * nz..p * nz + n];
                let r = r0 + nt + (p - 1) * np;
                pd.value(pf, q, &mut g[r..r + np]);
            }
        }
        self.timings.constraints_s += t0.elapsed().as_secs_f64();
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (self.jac_pattern.rows.clone(), self.jac_pattern.cols.clone())
    }
    fn jacobian_values(&mut self, x: &[f64], vals: &mut [f64]) {
        let t0 = Instant::now();
        vals.fill(0.0);
        let slots = std::mem::take(&mut self.jac_pattern.slots);
        let mut k = 0;
        self.jac_walk(x, &mut |_, _, v| {
            vals[slots[k]] += v;
            k += 1;
        });
        self.jac_pattern.slots = slots;
        self.timings.jacobian_s += t0.elapsed().as_secs_f64();
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (
            self.hess_pattern.rows.clone(),
            self.hess_pattern.cols.clone(),
        )
    }
    fn hessian_values(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]) {
        let t0 = Instant::now();
        vals.fill(0.0);
        let slots = std::mem::take(&mut self.hess_pattern.slots);
        let mut k = 0;
        self.hess_walk(x, obj_factor, lambda, &mut |_, _, v| {
            vals[slots[k]] += v;
            k += 1;
        });
        self.hess_pattern.slots = slots;
        self.timings.hessian_s += t0.elapsed().as_secs_f64();
        self.timings.hessian_calls += 1;
    }
}
