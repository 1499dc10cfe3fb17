//! Test NLPs with known answers, shared by `tests/nlp_backends.rs` and `benches/nlp_backends.rs`.
//! Every derivative is written by hand and checked through `brachia::fdcheck` in the tests.

#![allow(dead_code)]

use brachia::planning::SparseNlp;

/// Hock-Schittkowski problem 71:
/// `min x0 x3 (x0 + x1 + x2) + x2` s.t. `x0 x1 x2 x3 >= 25`, `|x|^2 = 40`, `1 <= x <= 5`,
/// start (1, 5, 5, 1). Known optimum f* = 17.0140173 at (1, 4.7429994, 3.8211503, 1.3794082).
#[derive(Debug, Clone, Default)]
pub struct Hs071 {
    /// Emit every Hessian entry twice (each half the value), to test that duplicates are summed.
    pub split_hessian: bool,
    /// Multipliers offered for a warm start: (lambda, z_l, z_u).
    pub warm: Option<(Vec<f64>, Vec<f64>, Vec<f64>)>,
    /// Start point override.
    pub start: Option<[f64; 4]>,
}

impl Hs071 {
    /// Lower triangle of the Hessian of the Lagrangian, row-major order over (i, j <= i).
    fn hess_lower(x: &[f64], of: f64, l: &[f64]) -> [f64; 10] {
        [
            of * 2.0 * x[3] + l[1] * 2.0,                         // (0,0)
            of * x[3] + l[0] * x[2] * x[3],                       // (1,0)
            l[1] * 2.0,                                           // (1,1)
            of * x[3] + l[0] * x[1] * x[3],                       // (2,0)
            l[0] * x[0] * x[3],                                   // (2,1)
            l[1] * 2.0,                                           // (2,2)
            of * (2.0 * x[0] + x[1] + x[2]) + l[0] * x[1] * x[2], // (3,0)
            of * x[0] + l[0] * x[0] * x[2],                       // (3,1)
            of * x[0] + l[0] * x[0] * x[1],                       // (3,2)
            l[1] * 2.0,                                           // (3,3)
        ]
    }
}

impl SparseNlp for Hs071 {
    fn n_vars(&self) -> usize {
        4
    }
    fn n_cons(&self) -> usize {
        2
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        x_l.fill(1.0);
        x_u.fill(5.0);
        g_l.copy_from_slice(&[25.0, 40.0]);
        g_u.copy_from_slice(&[f64::INFINITY, 40.0]);
    }
    fn initial_guess(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.start.unwrap_or([1.0, 5.0, 5.0, 1.0]));
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2]
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = x[3] * (2.0 * x[0] + x[1] + x[2]);
        g[1] = x[0] * x[3];
        g[2] = x[0] * x[3] + 1.0;
        g[3] = x[0] * (x[0] + x[1] + x[2]);
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = x[0] * x[1] * x[2] * x[3];
        g[1] = x.iter().map(|v| v * v).sum();
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (vec![0, 0, 0, 0, 1, 1, 1, 1], vec![0, 1, 2, 3, 0, 1, 2, 3])
    }
    fn jacobian_values(&mut self, x: &[f64], v: &mut [f64]) {
        v.copy_from_slice(&[
            x[1] * x[2] * x[3],
            x[0] * x[2] * x[3],
            x[0] * x[1] * x[3],
            x[0] * x[1] * x[2],
            2.0 * x[0],
            2.0 * x[1],
            2.0 * x[2],
            2.0 * x[3],
        ]);
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        let (mut r, mut c) = (Vec::new(), Vec::new());
        for i in 0..4 {
            for j in 0..=i {
                r.push(i);
                c.push(j);
            }
        }
        if self.split_hessian {
            // The same pattern again, in reverse order.
            let (r2, c2): (Vec<usize>, Vec<usize>) =
                r.iter().zip(&c).rev().map(|(&a, &b)| (a, b)).unzip();
            r.extend(r2);
            c.extend(c2);
        }
        (r, c)
    }
    fn hessian_values(&mut self, x: &[f64], of: f64, l: &[f64], v: &mut [f64]) {
        let h = Self::hess_lower(x, of, l);
        if self.split_hessian {
            for k in 0..10 {
                v[k] = 0.5 * h[k];
                v[19 - k] = 0.5 * h[k];
            }
        } else {
            v.copy_from_slice(&h);
        }
    }
    fn initial_multipliers(&self, lambda: &mut [f64], z_l: &mut [f64], z_u: &mut [f64]) -> bool {
        match &self.warm {
            Some((l, zl, zu)) => {
                lambda.copy_from_slice(l);
                z_l.copy_from_slice(zl);
                z_u.copy_from_slice(zu);
                true
            }
            None => false,
        }
    }
}

/// Minimum-effort rest-to-rest transfer of a double integrator, trapezoidal collocation.
///
/// Continuous problem: `p'' = u`, `p(0) = 0, v(0) = 0, p(1) = 1, v(1) = 0`, `min int_0^1 u^2 dt`;
/// closed form `u(t) = 6 - 12 t`, `p(t) = 3 t^2 - 2 t^3`, cost 12.
///
/// Variables, knot-major: `z = [p_0, v_0, u_0, p_1, v_1, u_1, ..., p_N, v_N, u_N]` (n = 3 (N+1)).
/// Constraints, 2 per interval k: `p_{k+1} - p_k - h/2 (v_k + v_{k+1}) = 0` and
/// `v_{k+1} - v_k - h/2 (u_k + u_{k+1}) = 0` (m = 2N). Boundary values are fixed by variable bounds.
/// Cost: trapezoidal quadrature `sum_k h/2 (u_k^2 + u_{k+1}^2)`.
#[derive(Debug, Clone)]
pub struct DoubleIntegrator {
    /// Number of intervals N.
    pub n_int: usize,
}

impl DoubleIntegrator {
    /// Step h = 1 / N.
    pub fn h(&self) -> f64 {
        1.0 / self.n_int as f64
    }
    /// Quadrature weight of knot k.
    fn w(&self, k: usize) -> f64 {
        if k == 0 || k == self.n_int {
            0.5 * self.h()
        } else {
            self.h()
        }
    }
    /// Index of u_k in z.
    pub fn iu(k: usize) -> usize {
        3 * k + 2
    }
}

impl SparseNlp for DoubleIntegrator {
    fn n_vars(&self) -> usize {
        3 * (self.n_int + 1)
    }
    fn n_cons(&self) -> usize {
        2 * self.n_int
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        let last = 3 * self.n_int;
        for (i, v) in [(0, 0.0), (1, 0.0), (last, 1.0), (last + 1, 0.0)] {
            x_l[i] = v;
            x_u[i] = v;
        }
        g_l.fill(0.0);
        g_u.fill(0.0);
    }
    fn initial_guess(&self, x: &mut [f64]) {
        // Straight-line position, zero velocity and effort.
        for k in 0..=self.n_int {
            x[3 * k] = k as f64 * self.h();
        }
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        (0..=self.n_int)
            .map(|k| self.w(k) * x[Self::iu(k)].powi(2))
            .sum()
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
        g.fill(0.0);
        for k in 0..=self.n_int {
            g[Self::iu(k)] = 2.0 * self.w(k) * x[Self::iu(k)];
        }
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        let hh = 0.5 * self.h();
        for k in 0..self.n_int {
            let (a, b) = (3 * k, 3 * (k + 1));
            g[2 * k] = x[b] - x[a] - hh * (x[a + 1] + x[b + 1]);
            g[2 * k + 1] = x[b + 1] - x[a + 1] - hh * (x[a + 2] + x[b + 2]);
        }
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        let (mut r, mut c) = (Vec::new(), Vec::new());
        for k in 0..self.n_int {
            let (a, b) = (3 * k, 3 * (k + 1));
            for (row, cols) in [
                (2 * k, [a, a + 1, b, b + 1]),
                (2 * k + 1, [a + 1, a + 2, b + 1, b + 2]),
            ] {
                for col in cols {
                    r.push(row);
                    c.push(col);
                }
            }
        }
        (r, c)
    }
    fn jacobian_values(&mut self, _x: &[f64], v: &mut [f64]) {
        let hh = 0.5 * self.h();
        for k in 0..self.n_int {
            v[8 * k..8 * k + 8].copy_from_slice(&[-1.0, -hh, 1.0, -hh, -1.0, -hh, 1.0, -hh]);
        }
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        let idx: Vec<usize> = (0..=self.n_int).map(Self::iu).collect();
        (idx.clone(), idx)
    }
    fn hessian_values(&mut self, _x: &[f64], of: f64, _l: &[f64], v: &mut [f64]) {
        for k in 0..=self.n_int {
            v[k] = of * 2.0 * self.w(k);
        }
    }
}

/// Rosenbrock's function on the unit disk (nonconvex objective, active nonlinear constraint):
/// `min (1 - x)^2 + 100 (y - x^2)^2` s.t. `x^2 + y^2 <= 1`, start (-1.2, 1).
/// Literature optimum (e.g. MATLAB's fmincon example): (0.7864, 0.6177), f = 0.04567.
#[derive(Debug, Clone, Default)]
pub struct RosenbrockDisk;

impl SparseNlp for RosenbrockDisk {
    fn n_vars(&self) -> usize {
        2
    }
    fn n_cons(&self) -> usize {
        1
    }
    fn bounds(&self, _x_l: &mut [f64], _x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        g_l[0] = f64::NEG_INFINITY;
        g_u[0] = 1.0;
    }
    fn initial_guess(&self, x: &mut [f64]) {
        x.copy_from_slice(&[-1.2, 1.0]);
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2)
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
        let r = x[1] - x[0] * x[0];
        g[0] = -2.0 * (1.0 - x[0]) - 400.0 * x[0] * r;
        g[1] = 200.0 * r;
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = x[0] * x[0] + x[1] * x[1];
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (vec![0, 0], vec![0, 1])
    }
    fn jacobian_values(&mut self, x: &[f64], v: &mut [f64]) {
        v[0] = 2.0 * x[0];
        v[1] = 2.0 * x[1];
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (vec![0, 1, 1], vec![0, 0, 1])
    }
    fn hessian_values(&mut self, x: &[f64], of: f64, l: &[f64], v: &mut [f64]) {
        v[0] = of * (2.0 - 400.0 * x[1] + 1200.0 * x[0] * x[0]) + 2.0 * l[0];
        v[1] = of * (-400.0 * x[0]);
        v[2] = of * 200.0 + 2.0 * l[0];
    }
}

/// `min x^2` s.t. `x >= 1` and `x <= 0` (both as constraints on g = [x, x]): infeasible.
#[derive(Debug, Clone, Default)]
pub struct Infeasible;

impl SparseNlp for Infeasible {
    fn n_vars(&self) -> usize {
        1
    }
    fn n_cons(&self) -> usize {
        2
    }
    fn bounds(&self, _x_l: &mut [f64], _x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        g_l.copy_from_slice(&[1.0, f64::NEG_INFINITY]);
        g_u.copy_from_slice(&[f64::INFINITY, 0.0]);
    }
    fn initial_guess(&self, x: &mut [f64]) {
        x[0] = 3.0;
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        x[0] * x[0]
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = 2.0 * x[0];
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = x[0];
        g[1] = x[0];
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (vec![0, 1], vec![0, 0])
    }
    fn jacobian_values(&mut self, _x: &[f64], v: &mut [f64]) {
        v[0] = 1.0;
        v[1] = 1.0;
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (vec![0], vec![0])
    }
    fn hessian_values(&mut self, _x: &[f64], of: f64, _l: &[f64], v: &mut [f64]) {
        v[0] = 2.0 * of;
    }
}

/// `min x - ln x` (unbounded variable; f = NaN for x <= 0), start x = 10: the first Newton step
/// lands at x = -80, so the backend must recover from a NaN objective in its line search.
/// Optimum x = 1, f = 1. With `nan_at_start` the start itself is x = -1 (NaN from the outset);
/// with `panic_in_hessian` the Hessian callback panics.
#[derive(Debug, Clone, Default)]
pub struct LogBarrier {
    /// Start at x = -1 where f is NaN.
    pub nan_at_start: bool,
    /// Panic inside `hessian_values`.
    pub panic_in_hessian: bool,
}

impl SparseNlp for LogBarrier {
    fn n_vars(&self) -> usize {
        1
    }
    fn n_cons(&self) -> usize {
        0
    }
    fn bounds(&self, _x_l: &mut [f64], _x_u: &mut [f64], _g_l: &mut [f64], _g_u: &mut [f64]) {}
    fn initial_guess(&self, x: &mut [f64]) {
        x[0] = if self.nan_at_start { -1.0 } else { 10.0 };
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        // f64::ln returns NaN for negative arguments (and -inf at 0: non-finite too).
        x[0] - x[0].ln()
    }
    fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
        g[0] = if x[0] > 0.0 {
            1.0 - 1.0 / x[0]
        } else {
            f64::NAN
        };
    }
    fn constraints(&mut self, _x: &[f64], _g: &mut [f64]) {}
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (vec![], vec![])
    }
    fn jacobian_values(&mut self, _x: &[f64], _v: &mut [f64]) {}
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (vec![0], vec![0])
    }
    fn hessian_values(&mut self, x: &[f64], of: f64, _l: &[f64], v: &mut [f64]) {
        assert!(
            !self.panic_in_hessian,
            "deliberate panic in the Hessian callback"
        );
        v[0] = of / (x[0] * x[0]);
    }
}
