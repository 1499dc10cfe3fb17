//! Cholesky factorisation `A = L L^T` of a small symmetric positive definite matrix and the
//! triangular solves with its factor.

use crate::Scalar;

/// Relative pivot threshold of [`cholesky`]: a pivot at or below `PIVOT_REL` times the column's
/// original diagonal entry means the matrix is singular to working precision.
const PIVOT_REL: f64 = 1e-13;

/// The matrix given to [`cholesky`] is not (numerically) positive definite: the pivot of `column`
/// (`a_jj - sum_k l_jk^2`, its real part for a dual number) is not finite or not above
/// `1e-13 |a_jj|`. The factor's columns before `column` are written; the rest of the matrix is
/// undefined.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("matrix not positive definite: pivot {pivot:e} at column {column}")]
pub struct NotPositiveDefinite {
    /// The column whose pivot failed (0-based).
    pub column: usize,
    /// That pivot (real part).
    pub pivot: f64,
}

/// How [`cholesky`] and [`cholesky_solve`] scale by a pivot `p`: `v / p` for every entry, or
/// `v * (1 / p)` with one division per pivot. The two round differently in the last bit, and a
/// plan's iterates depend on such bits: the OCP solver's Riccati factors divide and its solves
/// multiply by the reciprocal; the robot model's mass-matrix factor (forward dynamics, the model
/// plant, the re-rooting) and the Kalman filter's factor multiply and their solves divide; the
/// detour seeds divide in both.
///
/// It is an option rather than one rounding for all: one rule for every caller would change the
/// last bits of either the Riccati solves or the model's forward dynamics, and with them the
/// iterations and optima of every plan (which the solver and planner tests compare).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scaling {
    /// `v / p`.
    Divide,
    /// `v * (1 / p)`.
    Reciprocal,
}

impl Scaling {
    /// `v` scaled by the pivot `p`, whose reciprocal is `inv` (computed once by the caller; unused
    /// by [`Scaling::Divide`]).
    #[inline(always)]
    fn apply<T: Scalar>(self, v: T, p: T, inv: T) -> T {
        match self {
            Scaling::Divide => v / p,
            Scaling::Reciprocal => v * inv,
        }
    }
}

/// In-place Cholesky `A = L L^T` of the symmetric n x n row-major `a`: the lower triangle is read
/// and overwritten by `L`, the strict upper triangle is left alone. Column j is
/// `l_jj = sqrt(a_jj - sum_{k<j} l_jk^2)` and `l_ij = (a_ij - sum_{k<j} l_ik l_jk)` scaled by
/// `l_jj` as `scaling` says, each sum subtracted term by term in the order of k. Inlined, so that
/// a caller with a constant `n` gets a body with constant sizes.
///
/// # Errors
/// [`NotPositiveDefinite`] when a pivot is not finite or not above `1e-13` times its column's
/// original diagonal entry (an indefinite, singular or non-finite matrix).
#[inline(always)]
pub fn cholesky<T: Scalar>(
    a: &mut [T],
    n: usize,
    scaling: Scaling,
) -> Result<(), NotPositiveDefinite> {
    cholesky_with_pivot(a, n, scaling, PIVOT_REL)
}

/// [`cholesky`] with the relative pivot threshold `min_pivot_rel` (`>= 0`) in place of `1e-13`: a
/// pivot must be finite and above `min_pivot_rel |a_jj|` (with 0, any positive pivot passes).
///
/// # Errors
/// [`NotPositiveDefinite`] naming the first column whose pivot fails that rule.
#[inline(always)]
pub fn cholesky_with_pivot<T: Scalar>(
    a: &mut [T],
    n: usize,
    scaling: Scaling,
    min_pivot_rel: f64,
) -> Result<(), NotPositiveDefinite> {
    let a = &mut a[..n * n];
    for j in 0..n {
        let orig = a[j * n + j].re();
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        let pivot = d.re();
        // false for a NaN pivot or diagonal entry; `pivot > 0` follows from
        // `min_pivot_rel |orig| >= 0`
        if !(pivot > min_pivot_rel * orig.abs() && pivot < f64::INFINITY) {
            return Err(NotPositiveDefinite { column: j, pivot });
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        let inv = match scaling {
            Scaling::Divide => d,
            Scaling::Reciprocal => d.recip(),
        };
        for i in j + 1..n {
            let mut v = a[i * n + j];
            for k in 0..j {
                v -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = scaling.apply(v, d, inv);
        }
    }
    Ok(())
}

/// Calls `solve_w::<M, _>` with the number of right-hand sides `$m` as the constant `M` for 1..=12
/// and 17 (the rows of a stage's blocks for robots of up to 6 links), else `$fallback`; the kernels
/// do the arithmetic of the any-width loops.
macro_rules! with_rhs_width {
    ($m:expr, ($($arg:expr),*), $fallback:expr) => {
        match $m {
            1 => solve_w::<1, _>($($arg),*),
            2 => solve_w::<2, _>($($arg),*),
            3 => solve_w::<3, _>($($arg),*),
            4 => solve_w::<4, _>($($arg),*),
            5 => solve_w::<5, _>($($arg),*),
            6 => solve_w::<6, _>($($arg),*),
            7 => solve_w::<7, _>($($arg),*),
            8 => solve_w::<8, _>($($arg),*),
            9 => solve_w::<9, _>($($arg),*),
            10 => solve_w::<10, _>($($arg),*),
            11 => solve_w::<11, _>($($arg),*),
            12 => solve_w::<12, _>($($arg),*),
            17 => solve_w::<17, _>($($arg),*),
            _ => $fallback,
        }
    };
}

/// Solves `L L^T X = B` in place for the n x m row-major `b` (m right-hand sides as its columns; a
/// vector is m = 1), with `L` the lower triangle of `l` (n x n) from [`cholesky`]. Forward
/// `L Y = B`, then backward `L^T X = Y`; each row is `b_i - sum_k l_ik y_k` (the sum subtracted
/// term by term in the order of k) scaled by `l_ii` as `scaling` says.
#[inline]
pub fn cholesky_solve<T: Scalar>(l: &[T], n: usize, b: &mut [T], m: usize, scaling: Scaling) {
    if n == 0 || m == 0 {
        return;
    }
    let l = &l[..n * n];
    let b = &mut b[..n * m];
    with_rhs_width!(m, (l, n, b, scaling), solve_any(l, n, b, m, scaling))
}

/// Factor `a` ([`cholesky`]) and solve `A x = b` for one right-hand side `b` (n) in place
/// ([`cholesky_solve_vec`]), with `factor` and `solve` the scalings of each.
///
/// # Errors
/// [`NotPositiveDefinite`] from the factorisation (then `b` is untouched).
#[inline(always)]
pub fn cholesky_solve_in_place<T: Scalar>(
    a: &mut [T],
    n: usize,
    b: &mut [T],
    factor: Scaling,
    solve: Scaling,
) -> Result<(), NotPositiveDefinite> {
    cholesky(a, n, factor)?;
    cholesky_solve_vec(a, n, b, solve);
    Ok(())
}

/// [`cholesky_solve`] for one right-hand side `b` (n), the same arithmetic in plain loops, inlined:
/// a caller with a constant `n` (the robot model's forward dynamics) gets a body with constant
/// sizes.
#[inline(always)]
pub fn cholesky_solve_vec<T: Scalar>(l: &[T], n: usize, b: &mut [T], scaling: Scaling) {
    let (l, b) = (&l[..n * n], &mut b[..n]);
    for i in 0..n {
        let mut v = b[i];
        for k in 0..i {
            v -= l[i * n + k] * b[k];
        }
        let (p, inv) = pivot(l[i * n + i], scaling);
        b[i] = scaling.apply(v, p, inv);
    }
    for i in (0..n).rev() {
        let mut v = b[i];
        for k in i + 1..n {
            v -= l[k * n + i] * b[k];
        }
        let (p, inv) = pivot(l[i * n + i], scaling);
        b[i] = scaling.apply(v, p, inv);
    }
}

/// The pivot `p` and the factor [`Scaling::apply`] takes with it (its reciprocal, computed once per
/// row, for [`Scaling::Reciprocal`]).
#[inline(always)]
fn pivot<T: Scalar>(p: T, scaling: Scaling) -> (T, T) {
    match scaling {
        Scaling::Divide => (p, p),
        Scaling::Reciprocal => (p, p.recip()),
    }
}

/// [`cholesky_solve`] for `M` right-hand sides: a row of `B` in registers.
#[inline(always)]
fn solve_w<const M: usize, T: Scalar>(l: &[T], n: usize, b: &mut [T], scaling: Scaling) {
    let (b, _) = b.as_chunks_mut::<M>();
    let b = &mut b[..n];
    // forward: L Y = B
    for i in 0..n {
        let (done, rest) = b.split_at_mut(i);
        let mut x = rest[0];
        for (&lik, bk) in l[i * n..i * n + i].iter().zip(done.iter()) {
            for j in 0..M {
                x[j] -= lik * bk[j];
            }
        }
        let (p, inv) = pivot(l[i * n + i], scaling);
        for v in x.iter_mut() {
            *v = scaling.apply(*v, p, inv);
        }
        rest[0] = x;
    }
    // backward: L^T X = Y
    for i in (0..n).rev() {
        let (head, tail) = b.split_at_mut(i + 1);
        let mut x = head[i];
        for (k, bk) in tail.iter().enumerate() {
            let lki = l[(i + 1 + k) * n + i];
            for j in 0..M {
                x[j] -= lki * bk[j];
            }
        }
        let (p, inv) = pivot(l[i * n + i], scaling);
        for v in x.iter_mut() {
            *v = scaling.apply(*v, p, inv);
        }
        head[i] = x;
    }
}

/// [`cholesky_solve`] for any m (the reference of the fixed-width kernels).
fn solve_any<T: Scalar>(l: &[T], n: usize, b: &mut [T], m: usize, scaling: Scaling) {
    // forward: L Y = B
    for i in 0..n {
        let (done, rest) = b.split_at_mut(i * m);
        let bi = &mut rest[..m];
        let li = &l[i * n..i * n + i];
        for (&lik, bk) in li.iter().zip(done.chunks_exact(m)) {
            for (x, &y) in bi.iter_mut().zip(bk) {
                *x -= lik * y;
            }
        }
        let (p, inv) = pivot(l[i * n + i], scaling);
        for x in bi.iter_mut() {
            *x = scaling.apply(*x, p, inv);
        }
    }
    // backward: L^T X = Y
    for i in (0..n).rev() {
        let (head, tail) = b.split_at_mut((i + 1) * m);
        let bi = &mut head[i * m..];
        for (k, bk) in tail.chunks_exact(m).enumerate() {
            let lki = l[(i + 1 + k) * n + i];
            for (x, &y) in bi.iter_mut().zip(bk) {
                *x -= lki * y;
            }
        }
        let (p, inv) = pivot(l[i * n + i], scaling);
        for x in bi.iter_mut() {
            *x = scaling.apply(*x, p, inv);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::values;

    #[test]
    fn fixed_width_solves_match_the_reference_bit_for_bit() {
        for m in (1..=13).chain([16, 17, 18]) {
            for n in [1, 2, 5, 9] {
                let mm = values(n * n, (m * 31 + n) as u64);
                let mut spd = vec![0.0; n * n];
                for i in 0..n {
                    for j in 0..n {
                        spd[i * n + j] = (0..n).map(|k| mm[k * n + i] * mm[k * n + j]).sum();
                    }
                    spd[i * n + i] += 1.0;
                }
                cholesky(&mut spd, n, Scaling::Divide).expect("SPD");
                let b0 = values(n * m, (m * 31 + n + 7) as u64);
                for scaling in [Scaling::Divide, Scaling::Reciprocal] {
                    let (mut x, mut x_ref) = (b0.clone(), b0.clone());
                    cholesky_solve(&spd, n, &mut x, m, scaling);
                    solve_any(&spd, n, &mut x_ref, m, scaling);
                    assert_eq!(x, x_ref, "n {n} m {m} {scaling:?}");
                    if m == 1 {
                        let mut v = b0.clone();
                        cholesky_solve_vec(&spd, n, &mut v, scaling);
                        assert_eq!(v, x_ref, "n {n} {scaling:?}");
                    }
                }
            }
        }
    }
}
