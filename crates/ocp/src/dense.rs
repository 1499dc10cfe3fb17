//! Small dense kernels on row-major slices (no allocation): Cholesky, triangular solves, products.
//!
//! Every matrix is row-major; `a[i * n + j]` is row i, column j of a matrix with n columns.

/// Relative pivot threshold of [`chol`]: a pivot below `PIVOT_REL * original diagonal` is a failure.
const PIVOT_REL: f64 = 1e-13;

/// In-place Cholesky `A = L L^T` of the symmetric n x n matrix `a` (lower triangle read, L written
/// there, strict upper triangle left alone). Returns false when `a` is not (numerically) positive
/// definite or holds non-finite values.
pub(crate) fn chol(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let orig = a[j * n + j];
        let mut d = orig;
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if !(d.is_finite() && d > PIVOT_REL * orig.abs() && d > 0.0) {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
    }
    true
}

/// Solves `L L^T X = B` in place for the n x m row-major `b` (m right-hand sides as columns), with L
/// from [`chol`].
pub(crate) fn chol_solve(l: &[f64], n: usize, b: &mut [f64], m: usize) {
    // forward: L Y = B
    for i in 0..n {
        for k in 0..i {
            let lik = l[i * n + k];
            if lik != 0.0 {
                for c in 0..m {
                    b[i * m + c] -= lik * b[k * m + c];
                }
            }
        }
        let d = 1.0 / l[i * n + i];
        for c in 0..m {
            b[i * m + c] *= d;
        }
    }
    // backward: L^T X = Y
    for i in (0..n).rev() {
        for k in i + 1..n {
            let lki = l[k * n + i];
            if lki != 0.0 {
                for c in 0..m {
                    b[i * m + c] -= lki * b[k * m + c];
                }
            }
        }
        let d = 1.0 / l[i * n + i];
        for c in 0..m {
            b[i * m + c] *= d;
        }
    }
}

/// `c (m x n) = a (m x r) * b (r x n)`.
pub(crate) fn gemm_nn(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    for i in 0..m {
        let ci = &mut c[i * n..(i + 1) * n];
        ci.fill(0.0);
        for k in 0..r {
            let aik = a[i * r + k];
            if aik != 0.0 {
                let bk = &b[k * n..(k + 1) * n];
                for j in 0..n {
                    ci[j] += aik * bk[j];
                }
            }
        }
    }
}

/// `c (m x n) += a^T b` with `a` r x m and `b` r x n.
pub(crate) fn gemm_tn_acc(a: &[f64], b: &[f64], c: &mut [f64], r: usize, m: usize, n: usize) {
    for k in 0..r {
        let ak = &a[k * m..(k + 1) * m];
        let bk = &b[k * n..(k + 1) * n];
        for i in 0..m {
            let aki = ak[i];
            if aki != 0.0 {
                let ci = &mut c[i * n..(i + 1) * n];
                for j in 0..n {
                    ci[j] += aki * bk[j];
                }
            }
        }
    }
}

/// `y (m) += a (m x n) x`.
pub(crate) fn gemv_n_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    for i in 0..m {
        let ai = &a[i * n..(i + 1) * n];
        let mut s = 0.0;
        for j in 0..n {
            s += ai[j] * x[j];
        }
        y[i] += s;
    }
}

/// `y (n) += a^T x` with `a` m x n.
pub(crate) fn gemv_t_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    for i in 0..m {
        let xi = x[i];
        if xi != 0.0 {
            let ai = &a[i * n..(i + 1) * n];
            for j in 0..n {
                y[j] += ai[j] * xi;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_a_small_system() {
        // A = M M^T + I
        let m = [1.0, 2.0, 0.5, -1.0, 0.3, 2.0, 0.0, 1.0, -0.7];
        let mut a = [0.0; 9];
        gemm_tn_acc(&m, &m, &mut a, 3, 3, 3); // M^T M
        for i in 0..3 {
            a[i * 3 + i] += 1.0;
        }
        let a0 = a;
        let x = [1.0, -2.0, 3.0];
        let mut b = [0.0; 3];
        gemv_n_acc(&a0, &x, &mut b, 3, 3);
        let mut l = a;
        assert!(chol(&mut l, 3));
        chol_solve(&l, 3, &mut b, 1);
        for i in 0..3 {
            assert!((b[i] - x[i]).abs() < 1e-12);
        }
        let mut indefinite = [1.0, 2.0, 2.0, 1.0];
        assert!(!chol(&mut indefinite, 2));
        let mut singular = [1.0, 1.0, 1.0, 1.0];
        assert!(!chol(&mut singular, 2));
    }

    #[test]
    fn products_agree_with_loops() {
        let a = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; // 2 x 3
        let b = [1.0, 0.0, -1.0, 2.0, 0.5, 1.0]; // 3 x 2
        let mut c = [0.0; 4];
        gemm_nn(&a, &b, &mut c, 2, 3, 2);
        assert_eq!(
            c,
            [
                1.0 + 2.0 * -1.0 + 1.5,
                4.0 + 3.0,
                4.0 - 5.0 + 3.0,
                10.0 + 6.0
            ]
        );
        let mut d = [0.0; 4]; // a a^T via tn with a^T: (3 x 2)^T (3 x 2)
        let at = [1.0, 4.0, 2.0, 5.0, 3.0, 6.0];
        gemm_tn_acc(&at, &at, &mut d, 3, 2, 2);
        assert_eq!(d, [14.0, 32.0, 32.0, 77.0]);
        let mut y = [0.0; 3];
        gemv_t_acc(&a, &[1.0, 1.0], &mut y, 2, 3);
        assert_eq!(y, [5.0, 7.0, 9.0]);
    }
}
