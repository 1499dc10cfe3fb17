//! Dense box-constrained quadratic programs by a primal active-set method.
//!
//! Problem: `min_u 1/2 u^T H u + g^T u  s.t.  lb <= u <= ub`, with `H` symmetric positive definite
//! (row-major n x n), `g`, `lb`, `ub`, `u` of length n. This is the QP of the condensed MPC (units are
//! whatever the caller's are; in the MPC u are torques in N m).
//!
//! Algorithm (primal active set, exact for strictly convex problems):
//! 1. Clamp the warm start into the box. Variables sitting on a bound form the working set W; the
//!    others are free (F). Variables with `lb == ub` are fixed for good.
//! 2. Solve the equality-constrained problem on F: `H_FF u_F = -(g_F + H_FW u_W)`.
//! 3. Move towards that point; if a bound blocks the step, take the longest feasible step, move the
//!    blocking variable into W and go to 2.
//! 4. Otherwise check the multipliers on W (gradient `H u + g`: must be `>= 0` at a lower bound and
//!    `<= 0` at an upper bound). Release the most violating one and go to 2, or stop: u is optimal.
//!
//! The Cholesky factor of `H_FF` is updated, not recomputed: releasing a variable appends a row
//! (forward substitution, O(|F|^2)), fixing one deletes a row and restores triangularity with Givens
//! rotations (O(|F|^2)). All memory is allocated in [`BoxQp::new`]; [`BoxQp::solve`] never allocates.

use brachia_linalg::{dot_lanes, dot_lanes_x4};
use serde::{Deserialize, Serialize};

/// Options of the box-QP solver.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct BoxQpSettings {
    /// Largest number of active-set changes (each costs O(n^2)). Default 500.
    pub max_iter: usize,
    /// Relative optimality tolerance on the multipliers of the active bounds: a bound is released only
    /// when its multiplier is below `-tol * scale`, with
    /// `scale = 1 + max|g_i| + max|H_ij| * max|u_i|`. Default 1e-13.
    pub tol: f64,
}

impl Default for BoxQpSettings {
    fn default() -> Self {
        BoxQpSettings {
            max_iter: 500,
            tol: 1e-13,
        }
    }
}

impl BoxQpSettings {
    /// Check the values.
    pub fn validate(&self) -> crate::Result<()> {
        if self.max_iter == 0 {
            return Err(crate::Error::invalid(
                "BoxQpSettings",
                "max_iter",
                self.max_iter,
                "must be >= 1",
            ));
        }
        if !(self.tol.is_finite() && self.tol >= 0.0) {
            return Err(crate::Error::invalid(
                "BoxQpSettings",
                "tol",
                self.tol,
                "must be finite and >= 0",
            ));
        }
        Ok(())
    }
}

/// Outcome of a box-QP solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum BoxQpStatus {
    /// The KKT conditions hold (to the tolerance): `u` is the minimiser.
    Solved,
    /// The iteration limit was reached; `u` is feasible and its objective is no worse than the clamped
    /// warm start's, but it may not be optimal.
    MaxIterations,
    /// `H` restricted to the free variables is not (numerically) positive definite; `u` is feasible but
    /// not optimal.
    NotPositiveDefinite,
    /// Sizes disagree (`h` not n x n, vectors of different lengths, n larger than the capacity);
    /// `u` is untouched.
    DimensionMismatch,
    /// A bound pair has `lb > ub` or some input is NaN; `u` is untouched.
    InvalidBounds,
}

/// Diagnostics of one solve.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxQpInfo {
    /// What happened.
    pub status: BoxQpStatus,
    /// Active-set changes (blocking steps plus releases) performed.
    pub iterations: usize,
    /// Variables on a bound at the end (including fixed ones).
    pub active: usize,
}

const FREE: u8 = 0;
const LOWER: u8 = 1;
const UPPER: u8 = 2;
const FIXED: u8 = 3;

/// Reusable primal active-set solver for box QPs of up to `n_max` variables.
#[derive(Debug, Clone)]
pub struct BoxQp {
    n_max: usize,
    /// Options (may be changed between solves).
    pub settings: BoxQpSettings,
    /// Lower-triangular Cholesky factor of H_FF in the order of `free`, row stride `n_max`.
    l: Vec<f64>,
    /// Free variables in factor order.
    free: Vec<usize>,
    /// Variables on a bound (or fixed), in index order.
    bound: Vec<usize>,
    nf: usize,
    state: Vec<u8>,
    rhs: Vec<f64>,
    sol: Vec<f64>,
    work: Vec<f64>,
}

impl BoxQp {
    /// A solver for problems with at most `n_max` variables (all buffers allocated here).
    pub fn new(n_max: usize) -> Self {
        BoxQp {
            n_max,
            settings: BoxQpSettings::default(),
            l: vec![0.0; n_max * n_max],
            free: vec![0; n_max],
            bound: vec![0; n_max],
            nf: 0,
            state: vec![FREE; n_max],
            rhs: vec![0.0; n_max],
            sol: vec![0.0; n_max],
            work: vec![0.0; n_max],
        }
    }

    /// Capacity in variables.
    pub fn n_max(&self) -> usize {
        self.n_max
    }

    /// Solve `min 1/2 u^T H u + g^T u, lb <= u <= ub` with `h` row-major n x n (only its values are
    /// read; it must be symmetric), n = `g.len()`. `u_inout` holds the warm start on entry (any values;
    /// it is clamped into the box first) and the solution on exit. Never allocates, never panics.
    pub fn solve(
        &mut self,
        h: &[f64],
        g: &[f64],
        lb: &[f64],
        ub: &[f64],
        u_inout: &mut [f64],
    ) -> BoxQpInfo {
        let n = g.len();
        let mut info = BoxQpInfo {
            status: BoxQpStatus::Solved,
            iterations: 0,
            active: 0,
        };
        if n > self.n_max
            || h.len() != n * n
            || lb.len() != n
            || ub.len() != n
            || u_inout.len() != n
        {
            info.status = BoxQpStatus::DimensionMismatch;
            return info;
        }
        for i in 0..n {
            let ordered = matches!(
                lb[i].partial_cmp(&ub[i]),
                Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
            );
            if !ordered || g[i].is_nan() || h[i * n + i].is_nan() {
                info.status = BoxQpStatus::InvalidBounds;
                return info;
            }
        }
        let u = u_inout;

        // 1. Clamp and classify.
        let mut umax: f64 = 0.0;
        let mut gmax: f64 = 0.0;
        let mut hmax: f64 = 0.0;
        for i in 0..n {
            let v = if u[i].is_nan() { 0.0 } else { u[i] };
            u[i] = v.clamp(lb[i], ub[i]);
            self.state[i] = if lb[i] == ub[i] {
                FIXED
            } else if u[i] <= lb[i] {
                LOWER
            } else if u[i] >= ub[i] {
                UPPER
            } else {
                FREE
            };
            for b in [lb[i], ub[i]] {
                if b.is_finite() {
                    umax = umax.max(b.abs());
                }
            }
            umax = umax.max(u[i].abs());
            gmax = gmax.max(g[i].abs());
            // H is symmetric: the upper triangle holds its largest entry. NaNs are skipped (as by
            // `f64::max`).
            for &v in &h[i * n + i..(i + 1) * n] {
                let a = v.abs();
                if a > hmax {
                    hmax = a;
                }
            }
        }
        let tol = self.settings.tol * (1.0 + gmax + hmax * umax);

        // Factor H_FF from scratch.
        if !self.factor_free(h, n) {
            info.status = BoxQpStatus::NotPositiveDefinite;
            info.active = self.count_active(n);
            return info;
        }

        loop {
            if info.iterations >= self.settings.max_iter {
                info.status = BoxQpStatus::MaxIterations;
                break;
            }
            // 2. Equality-constrained minimiser on the free set.
            let nf = self.nf;
            // The bound variables in index order.
            let mut nb = 0;
            for j in 0..n {
                if self.state[j] != FREE {
                    self.bound[nb] = j;
                    nb += 1;
                }
            }
            for p in 0..nf {
                let i = self.free[p];
                let row = &h[i * n..(i + 1) * n];
                let mut r = -g[i];
                for &j in &self.bound[..nb] {
                    r -= row[j] * u[j];
                }
                self.rhs[p] = r;
            }
            self.solve_factor();

            // 3. Ratio test.
            let mut alpha = 1.0;
            let mut block: Option<(usize, u8)> = None;
            for p in 0..nf {
                let i = self.free[p];
                let d = self.sol[p] - u[i];
                if d < 0.0 && self.sol[p] < lb[i] {
                    let a = (lb[i] - u[i]) / d;
                    if a < alpha {
                        alpha = a;
                        block = Some((p, LOWER));
                    }
                } else if d > 0.0 && self.sol[p] > ub[i] {
                    let a = (ub[i] - u[i]) / d;
                    if a < alpha {
                        alpha = a;
                        block = Some((p, UPPER));
                    }
                }
            }
            let alpha = alpha.max(0.0);
            for p in 0..nf {
                let i = self.free[p];
                u[i] = (u[i] + alpha * (self.sol[p] - u[i])).clamp(lb[i], ub[i]);
            }
            if let Some((p, side)) = block {
                let i = self.free[p];
                u[i] = if side == LOWER { lb[i] } else { ub[i] };
                self.state[i] = side;
                self.remove(p);
                info.iterations += 1;
                continue;
            }
            for p in 0..nf {
                let i = self.free[p];
                u[i] = self.sol[p];
            }

            // 4. Multipliers of the working set.
            let mut worst = -tol;
            let mut release = None;
            for i in 0..n {
                let s = self.state[i];
                if s != LOWER && s != UPPER {
                    continue;
                }
                let row = &h[i * n..(i + 1) * n];
                let mut gr = g[i];
                for j in 0..n {
                    gr += row[j] * u[j];
                }
                let lam = if s == LOWER { gr } else { -gr };
                if lam < worst {
                    worst = lam;
                    release = Some(i);
                }
            }
            match release {
                None => {
                    info.status = BoxQpStatus::Solved;
                    break;
                }
                Some(i) => {
                    self.state[i] = FREE;
                    info.iterations += 1;
                    if !self.append(h, n, i) {
                        self.state[i] = if u[i] <= lb[i] { LOWER } else { UPPER };
                        info.status = BoxQpStatus::NotPositiveDefinite;
                        break;
                    }
                }
            }
        }
        info.active = self.count_active(n);
        info
    }

    fn count_active(&self, n: usize) -> usize {
        self.state[..n].iter().filter(|&&s| s != FREE).count()
    }

    /// Append variable `i` to the free set: new last row of the factor. False if the pivot is not
    /// positive (H_FF not positive definite).
    fn append(&mut self, h: &[f64], n: usize, i: usize) -> bool {
        let m = self.n_max;
        let nf = self.nf;
        // Solve L w = H_{F,i}.
        let hrow = &h[i * n..(i + 1) * n];
        for p in 0..nf {
            // H is symmetric: read row i (contiguous) instead of column i.
            let v = hrow[self.free[p]] - dot_lanes(&self.l[p * m..p * m + p], &self.work[..p]);
            self.work[p] = v / self.l[p * m + p];
        }
        let d = hrow[i] - dot_lanes(&self.work[..nf], &self.work[..nf]);
        // Relative pivot test: a pivot this small means H_FF is singular to working precision.
        if d.is_nan() || d <= 1e-14 * h[i * n + i].abs() || !d.is_finite() {
            return false;
        }
        for k in 0..nf {
            self.l[nf * m + k] = self.work[k];
        }
        self.l[nf * m + nf] = d.sqrt();
        self.free[nf] = i;
        self.nf += 1;
        true
    }

    /// Factor `H_FF` from scratch for the free variables in index order. Builds exactly the factor that
    /// [`Self::append`] would build one row at a time (same formulas, same rounding: every entry is
    /// `(H_ij - dot(L_i, L_j)) / L_jj` with the four-lane [`dot_lanes`]), but column by column, with
    /// the dot products of four rows against the column's row at once ([`dot_lanes_x4`]: each loaded
    /// entry of that row serves four products). False if a pivot is not positive (then `nf` counts
    /// the variables factored before it, as after a failed `append`).
    fn factor_free(&mut self, h: &[f64], n: usize) -> bool {
        let m = self.n_max;
        let mut nf = 0;
        for i in 0..n {
            if self.state[i] == FREE {
                self.free[nf] = i;
                nf += 1;
            }
        }
        self.nf = 0;
        // The lower triangle of H_FF into the factor's rows.
        for p in 0..nf {
            let hrow = &h[self.free[p] * n..(self.free[p] + 1) * n];
            let lrow = &mut self.l[p * m..p * m + p + 1];
            if nf == n {
                lrow.copy_from_slice(&hrow[..=p]);
            } else {
                for (v, &q) in lrow.iter_mut().zip(&self.free[..=p]) {
                    *v = hrow[q];
                }
            }
        }
        for j in 0..nf {
            let fj = self.free[j];
            let (top, rest) = self.l.split_at_mut((j + 1) * m);
            let lj = &mut top[j * m..(j + 1) * m];
            let d = lj[j] - dot_lanes(&lj[..j], &lj[..j]);
            if d.is_nan() || d <= 1e-14 * h[fj * n + fj].abs() || !d.is_finite() {
                return false;
            }
            let piv = d.sqrt();
            lj[j] = piv;
            let lj = &lj[..j];
            let below = nf - j - 1;
            let (quads, single) = rest[..below * m].split_at_mut(below / 4 * 4 * m);
            for quad in quads.chunks_exact_mut(4 * m) {
                let (r0, r) = quad.split_at_mut(m);
                let (r1, r) = r.split_at_mut(m);
                let (r2, r3) = r.split_at_mut(m);
                let acc = dot_lanes_x4([&r0[..j], &r1[..j], &r2[..j], &r3[..j]], lj);
                for (row, s) in [r0, r1, r2, r3].into_iter().zip(acc) {
                    row[j] = (row[j] - s) / piv;
                }
            }
            for row in single.chunks_exact_mut(m) {
                row[j] = (row[j] - dot_lanes(&row[..j], lj)) / piv;
            }
            self.nf = j + 1;
        }
        true
    }

    /// Delete position `p` of the free set from the factor (row deletion + Givens re-triangulation).
    fn remove(&mut self, p: usize) {
        let m = self.n_max;
        let nf = self.nf;
        for r in p..nf - 1 {
            self.free[r] = self.free[r + 1];
            for k in 0..=r + 1 {
                self.l[r * m + k] = self.l[(r + 1) * m + k];
            }
        }
        // Rows p..nf-2 now have one entry above the diagonal (column r + 1): rotate it away.
        for k in p..nf - 1 {
            let a = self.l[k * m + k];
            let b = self.l[k * m + k + 1];
            let r = a.hypot(b);
            if r == 0.0 {
                continue;
            }
            let (c, s) = (a / r, b / r);
            for i in k..nf - 1 {
                let x = self.l[i * m + k];
                let y = self.l[i * m + k + 1];
                self.l[i * m + k] = c * x + s * y;
                self.l[i * m + k + 1] = -s * x + c * y;
            }
            self.l[k * m + k + 1] = 0.0;
            if self.l[k * m + k] < 0.0 {
                for i in k..nf - 1 {
                    self.l[i * m + k] = -self.l[i * m + k];
                }
            }
        }
        self.nf -= 1;
    }

    /// `sol = (L L^T)^-1 rhs` over the free set.
    fn solve_factor(&mut self) {
        let m = self.n_max;
        let nf = self.nf;
        for p in 0..nf {
            let v = self.rhs[p] - dot_lanes(&self.l[p * m..p * m + p], &self.sol[..p]);
            self.sol[p] = v / self.l[p * m + p];
        }
        for p in (0..nf).rev() {
            let mut v = self.sol[p];
            for k in p + 1..nf {
                v -= self.l[k * m + p] * self.sol[k];
            }
            self.sol[p] = v / self.l[p * m + p];
        }
    }
}

/// Largest violation of the KKT conditions of the box QP at `u` (for tests and diagnostics):
/// the maximum over i of `|u_i - clamp(u_i - (H u + g)_i, lb_i, ub_i)|` (the projected-gradient
/// residual, zero exactly at the minimiser) together with the largest bound violation.
pub fn kkt_residual(h: &[f64], g: &[f64], lb: &[f64], ub: &[f64], u: &[f64]) -> f64 {
    let n = g.len();
    let mut r: f64 = 0.0;
    for i in 0..n {
        let gr: f64 = g[i] + (0..n).map(|j| h[i * n + j] * u[j]).sum::<f64>();
        let proj = (u[i] - gr).clamp(lb[i], ub[i]);
        r = r.max((u[i] - proj).abs());
        r = r.max(lb[i] - u[i]).max(u[i] - ub[i]);
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Random SPD matrix `Q diag(eig) Q^T` with log-uniform eigenvalues in [1, cond].
    fn random_spd(rng: &mut ChaCha8Rng, n: usize, cond: f64) -> Vec<f64> {
        let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
        for v in a.iter_mut() {
            *v = rng.gen_range(-1.0..1.0);
        }
        let q = a.qr().q();
        let eig: Vec<f64> = (0..n)
            .map(|k| {
                if n == 1 {
                    1.0
                } else {
                    cond.powf(k as f64 / (n - 1) as f64)
                }
            })
            .collect();
        let d = nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_vec(eig));
        let h = &q * d * q.transpose();
        let mut out = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                out[i * n + j] = 0.5 * (h[(i, j)] + h[(j, i)]);
            }
        }
        out
    }

    fn objective(h: &[f64], g: &[f64], u: &[f64]) -> f64 {
        let n = g.len();
        let mut v = 0.0;
        for i in 0..n {
            v += g[i] * u[i];
            for j in 0..n {
                v += 0.5 * u[i] * h[i * n + j] * u[j];
            }
        }
        v
    }

    #[test]
    fn unconstrained_optimum_inside_the_box() {
        // H = [[4, 1], [1, 3]], g = [-1, -2]: u* = H^-1 [1, 2] = [1/11, 7/11].
        let h = [4.0, 1.0, 1.0, 3.0];
        let g = [-1.0, -2.0];
        let mut qp = BoxQp::new(4);
        let mut u = [0.0, 0.0];
        let info = qp.solve(&h, &g, &[-10.0; 2], &[10.0; 2], &mut u);
        assert_eq!(info.status, BoxQpStatus::Solved);
        assert_eq!(info.active, 0);
        assert!((u[0] - 1.0 / 11.0).abs() < 1e-15 && (u[1] - 7.0 / 11.0).abs() < 1e-15);
    }

    #[test]
    fn all_bounds_active() {
        // The unconstrained optimum u* = -H^-1 g = [10, -10] lies outside [-1, 1]^2 far enough that both
        // bounds bind: u = [1, -1], with multipliers of the right signs.
        let h = [2.0, 0.0, 0.0, 2.0];
        let g = [-20.0, 20.0];
        let mut qp = BoxQp::new(2);
        let mut u = [0.3, 0.2];
        let info = qp.solve(&h, &g, &[-1.0; 2], &[1.0; 2], &mut u);
        assert_eq!(info.status, BoxQpStatus::Solved);
        assert_eq!(info.active, 2);
        assert_eq!(u, [1.0, -1.0]);
    }

    #[test]
    fn equal_bounds_fix_the_variable() {
        // u1 fixed at 0.5; u0 minimises 2 u0^2 + u0 u1 - u0 => u0 = (1 - 0.5) / 4.
        let h = [4.0, 1.0, 1.0, 3.0];
        let g = [-1.0, 0.0];
        let mut qp = BoxQp::new(2);
        let mut u = [0.0, -3.0];
        let info = qp.solve(&h, &g, &[-5.0, 0.5], &[5.0, 0.5], &mut u);
        assert_eq!(info.status, BoxQpStatus::Solved);
        assert_eq!(u[1], 0.5);
        assert!((u[0] - 0.125).abs() < 1e-15);
        assert!(kkt_residual(&h, &g, &[-5.0, 0.5], &[5.0, 0.5], &u) < 1e-14);
    }

    #[test]
    fn bad_inputs_give_a_status() {
        let mut qp = BoxQp::new(2);
        let mut u = [0.0; 3];
        let info = qp.solve(&[1.0; 9], &[0.0; 3], &[0.0; 3], &[1.0; 3], &mut u);
        assert_eq!(info.status, BoxQpStatus::DimensionMismatch);
        let mut u = [0.0; 2];
        let info = qp.solve(
            &[1.0, 0.0, 0.0, 1.0],
            &[0.0; 2],
            &[1.0, 0.0],
            &[0.0, 1.0],
            &mut u,
        );
        assert_eq!(info.status, BoxQpStatus::InvalidBounds);
        // Indefinite H: diag(1, -1).
        let info = qp.solve(
            &[1.0, 0.0, 0.0, -1.0],
            &[0.0; 2],
            &[-1.0; 2],
            &[1.0; 2],
            &mut [0.0, 0.0],
        );
        assert_eq!(info.status, BoxQpStatus::NotPositiveDefinite);
    }

    /// Solve with clarabel (interior point, tight tolerances): variables u, constraints u <= ub and
    /// -u <= -lb as a nonnegative cone on the slack.
    fn clarabel_solve(h: &[f64], g: &[f64], lb: &[f64], ub: &[f64]) -> Vec<f64> {
        use clarabel::algebra::CscMatrix;
        use clarabel::solver::*;
        let n = g.len();
        // Upper triangle of H in CSC.
        let mut colptr = vec![0usize];
        let mut rowval = Vec::new();
        let mut nzval = Vec::new();
        for j in 0..n {
            for i in 0..=j {
                rowval.push(i);
                nzval.push(h[i * n + j]);
            }
            colptr.push(rowval.len());
        }
        let p = CscMatrix::new(n, n, colptr, rowval, nzval);
        let mut colptr = vec![0usize];
        let mut rowval = Vec::new();
        let mut nzval = Vec::new();
        for j in 0..n {
            rowval.push(j);
            nzval.push(1.0);
            rowval.push(n + j);
            nzval.push(-1.0);
            colptr.push(rowval.len());
        }
        let a = CscMatrix::new(2 * n, n, colptr, rowval, nzval);
        let mut b = ub.to_vec();
        b.extend(lb.iter().map(|v| -v));
        let cones = [NonnegativeConeT(2 * n)];
        let settings = DefaultSettingsBuilder::default()
            .verbose(false)
            .presolve_enable(false)
            .tol_gap_abs(1e-13)
            .tol_gap_rel(1e-13)
            .tol_feas(1e-13)
            .tol_ktratio(1e-10)
            .max_iter(200)
            .build()
            .unwrap();
        let mut solver = DefaultSolver::new(&p, g, &a, &b, &cones, settings).unwrap();
        solver.solve();
        solver.solution.x.clone()
    }

    /// 1000 random box QPs (sizes 1..=60, condition numbers up to 1e5, random boxes with some equal
    /// bounds and random warm starts) against clarabel, with the KKT residual of every solution.
    #[test]
    fn agrees_with_clarabel_on_random_problems() {
        let mut rng = ChaCha8Rng::seed_from_u64(20240611);
        let mut qp = BoxQp::new(60);
        let (mut worst_du, mut worst_kkt, mut worst_obj) = (0.0f64, 0.0f64, 0.0f64);
        let mut n_active_total = 0;
        let mut n_oracle_limited = 0;
        for case in 0..1000 {
            let n = rng.gen_range(1..=60);
            let cond = 10f64.powf(rng.gen_range(0.0..5.0));
            let h = random_spd(&mut rng, n, cond);
            let g: Vec<f64> = (0..n).map(|_| rng.gen_range(-10.0..10.0)).collect();
            let mut lb = vec![0.0; n];
            let mut ub = vec![0.0; n];
            for i in 0..n {
                let a: f64 = rng.gen_range(-2.0..1.0);
                let w: f64 = if rng.gen_bool(0.03) {
                    0.0
                } else {
                    rng.gen_range(0.01..3.0)
                };
                lb[i] = a;
                ub[i] = a + w;
            }
            let mut u: Vec<f64> = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
            let info = qp.solve(&h, &g, &lb, &ub, &mut u);
            assert_eq!(info.status, BoxQpStatus::Solved, "case {case}: {info:?}");
            n_active_total += info.active;
            let kkt = kkt_residual(&h, &g, &lb, &ub, &u);
            worst_kkt = worst_kkt.max(kkt);
            // The active-set solution is exact up to round-off: projected-gradient residual relative to
            // the gradient scale.
            assert!(kkt < 1e-9, "case {case}: KKT residual {kkt:e}");
            let uc = clarabel_solve(&h, &g, &lb, &ub);
            let du = u
                .iter()
                .zip(&uc)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            let (f, fc) = (objective(&h, &g, &u), objective(&h, &g, &uc));
            worst_du = worst_du.max(du);
            worst_obj = worst_obj.max(f - fc);
            // Never worse than the oracle beyond round-off.
            assert!(
                f <= fc + 1e-10 * (1.0 + fc.abs()),
                "case {case}: {f} vs {fc}"
            );
            if du >= 1e-8 {
                // Clarabel (an interior-point method) stops at its own accuracy: with condition numbers
                // near 1e5 its KKT residual can exceed 1e-8 even at tightened tolerances. Then the
                // active-set answer must be the more accurate one on both counts.
                let kc = kkt_residual(&h, &g, &lb, &ub, &uc);
                assert!(
                    kc > 10.0 * kkt && f <= fc + 1e-12 * (1.0 + fc.abs()),
                    "case {case} n={n} cond={cond:.1e}: |du| = {du:e}, KKT ours {kkt:e} clarabel {kc:e}"
                );
                n_oracle_limited += 1;
            }
        }
        eprintln!("cases limited by clarabel's accuracy: {n_oracle_limited}");
        assert!(
            n_oracle_limited < 50,
            "too many disagreements: {n_oracle_limited}"
        );
        assert!(
            n_active_total > 1000,
            "too few active bounds to test anything"
        );
        eprintln!(
            "boxqp vs clarabel: max|du| {worst_du:e}, max KKT {worst_kkt:e}, obj gap {worst_obj:e}"
        );
    }

    /// Warm starts from the solution itself, and from the solution of a perturbed problem, end at the
    /// same answer as a cold start.
    #[test]
    fn warm_start_reaches_the_same_solution() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut qp = BoxQp::new(40);
        for _ in 0..50 {
            let n = 40;
            let h = random_spd(&mut rng, n, 1e4);
            let g: Vec<f64> = (0..n).map(|_| rng.gen_range(-50.0..50.0)).collect();
            let (lb, ub) = (vec![-1.0; n], vec![1.0; n]);
            let mut cold = vec![0.0; n];
            let ic = qp.solve(&h, &g, &lb, &ub, &mut cold);
            let mut warm = cold.clone();
            let iw = qp.solve(&h, &g, &lb, &ub, &mut warm);
            assert_eq!(iw.status, BoxQpStatus::Solved);
            assert_eq!(iw.iterations, 0, "a solution as warm start needs no change");
            let g2: Vec<f64> = g.iter().map(|v| v + rng.gen_range(-1.0..1.0)).collect();
            let mut cold2 = vec![0.0; n];
            qp.solve(&h, &g2, &lb, &ub, &mut cold2);
            let mut warm2 = cold.clone();
            let iw2 = qp.solve(&h, &g2, &lb, &ub, &mut warm2);
            assert_eq!(iw2.status, BoxQpStatus::Solved);
            let d = cold2
                .iter()
                .zip(&warm2)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(d < 1e-9, "warm and cold differ by {d:e}");
            assert!(ic.iterations > 0);
        }
    }

    /// The MPC's own QPs, recorded from a closed-loop run on the model plant with torque limits tight
    /// enough (1 N m) that bounds are active, against clarabel.
    #[test]
    fn agrees_with_clarabel_on_qps_recorded_from_a_closed_loop_run() {
        use crate::control::{Mpc, MpcSettings};
        use crate::sim::{Controller, ModelPlant, Plant};
        use crate::trajectory::Trajectory;
        let mut params = crate::Robot::paper().params.clone();
        params.actuators.tau_min = vec![-1.0; 3];
        params.actuators.tau_max = vec![1.0; 3];
        let robot = crate::Robot::from_params(params, "test").unwrap();
        // a feasible 1 ms reference: the model under smooth torques
        let x0 = [-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut plant = ModelPlant::new(robot.clone(), &x0);
        let mut reference = Trajectory::new(4);
        let mut x = [0.0; 8];
        for k in 0..=800 {
            let t = k as f64 * 1e-3;
            let tau = [
                0.8 * (3.0 * t).sin(),
                -0.6 * (2.0 * t).sin(),
                0.5 * (4.0 * t).cos(),
            ];
            plant.state(&mut x);
            reference.push(t, &x[..4], &x[4..], &tau);
            plant.step(&tau, 1e-3);
        }
        // Track it from a perturbed start and record every 25th QP: without the input-rate penalty
        // against clarabel; with the default rate penalty (a worse-conditioned H) by the KKT residual,
        // the optimality certificate of a strictly convex QP (the gap to clarabel is printed).
        for rate in [0.0, 0.1] {
            let settings = MpcSettings {
                rate_diag: vec![rate; 3],
                ..MpcSettings::default()
            };
            let mut mpc = Mpc::new(robot.clone(), reference.clone(), settings).unwrap();
            let mut plant =
                ModelPlant::new(robot.clone(), &[-2.25, 0.1, -1.6, 0.05, 0.0, 0.0, 0.0, 0.0]);
            let (mut tau, mut checked, mut active) = ([0.0; 3], 0, 0);
            let mut du_max: f64 = 0.0;
            for k in 0..800 {
                plant.state(&mut x);
                mpc.control(k as f64 * 1e-3, &x, &mut tau);
                if k % 25 == 0 {
                    let (h, g, lb, ub) = mpc.qp_data();
                    let u = mpc.solution();
                    let uc = clarabel_solve(h, g, lb, ub);
                    let du = u
                        .iter()
                        .zip(&uc)
                        .map(|(a, b)| (a - b).abs())
                        .fold(0.0, f64::max);
                    du_max = du_max.max(du);
                    if rate == 0.0 {
                        assert!(du < 1e-7, "step {k}: |u - u_clarabel| = {du:e}");
                    }
                    assert!(kkt_residual(h, g, lb, ub, u) < 1e-8);
                    active += u
                        .iter()
                        .zip(lb.iter().zip(ub))
                        .filter(|(v, (l, h))| **v <= **l || **v >= **h)
                        .count();
                    checked += 1;
                }
                plant.step(&tau, 1e-3);
            }
            eprintln!("rate {rate}: largest |u - u_clarabel| {du_max:e}");
            assert_eq!(checked, 32);
            assert!(active > 0, "the recorded QPs should include active bounds");
        }
    }
}
