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
    if n == 0 || m == 0 {
        return;
    }
    let l = &l[..n * n];
    let b = &mut b[..n * m];
    // forward: L Y = B
    for i in 0..n {
        let (done, rest) = b.split_at_mut(i * m);
        let bi = &mut rest[..m];
        let li = &l[i * n..i * n + i];
        for (lik, bk) in li.iter().zip(done.chunks_exact(m)) {
            for (x, y) in bi.iter_mut().zip(bk) {
                *x -= lik * y;
            }
        }
        let d = 1.0 / l[i * n + i];
        for x in bi.iter_mut() {
            *x *= d;
        }
    }
    // backward: L^T X = Y
    for i in (0..n).rev() {
        let (head, tail) = b.split_at_mut((i + 1) * m);
        let bi = &mut head[i * m..];
        for (k, bk) in tail.chunks_exact(m).enumerate() {
            let lki = l[(i + 1 + k) * n + i];
            for (x, y) in bi.iter_mut().zip(bk) {
                *x -= lki * y;
            }
        }
        let d = 1.0 / l[i * n + i];
        for x in bi.iter_mut() {
            *x *= d;
        }
    }
}

/// `y += a x` for slices of equal length. The common stage sizes get fixed-length copies (no loop,
/// no bounds checks, fully vectorised); other lengths the plain loop.
#[inline(always)]
fn axpy(a: f64, x: &[f64], y: &mut [f64]) {
    fn fixed<const N: usize>(a: f64, x: &[f64], y: &mut [f64]) -> bool {
        match (<&[f64; N]>::try_from(x), <&mut [f64; N]>::try_from(y)) {
            (Ok(x), Ok(y)) => {
                for i in 0..N {
                    y[i] += a * x[i];
                }
                true
            }
            _ => false,
        }
    }
    let done = match x.len() {
        8 => fixed::<8>(a, x, y),
        4 => fixed::<4>(a, x, y),
        3 => fixed::<3>(a, x, y),
        2 => fixed::<2>(a, x, y),
        _ => false,
    };
    if !done {
        for (p, q) in y.iter_mut().zip(x) {
            *p += a * q;
        }
    }
}

/// `sum x_i y_i` (fixed-length copies for the common stage sizes, as in [`axpy`]).
#[inline(always)]
fn dot(x: &[f64], y: &[f64]) -> f64 {
    fn fixed<const N: usize>(x: &[f64], y: &[f64]) -> Option<f64> {
        match (<&[f64; N]>::try_from(x), <&[f64; N]>::try_from(y)) {
            (Ok(x), Ok(y)) => {
                let mut s = 0.0;
                for i in 0..N {
                    s += x[i] * y[i];
                }
                Some(s)
            }
            _ => None,
        }
    }
    let r = match x.len() {
        8 => fixed::<8>(x, y),
        4 => fixed::<4>(x, y),
        3 => fixed::<3>(x, y),
        _ => None,
    };
    r.unwrap_or_else(|| x.iter().zip(y).map(|(p, q)| p * q).sum())
}

/// `c (m x n) = a (m x r) * b (r x n)`.
pub(crate) fn gemm_nn(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    if n == 0 {
        return;
    }
    c[..m * n].fill(0.0);
    gemm_nn_acc(a, b, c, m, r, n);
}

/// `c (m x n) += a (m x r) * b (r x n)`.
pub(crate) fn gemm_nn_acc(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    if n == 0 || r == 0 {
        return;
    }
    let b = &b[..r * n];
    for (ci, ai) in c[..m * n].chunks_exact_mut(n).zip(a.chunks_exact(r)) {
        for (aik, bk) in ai.iter().zip(b.chunks_exact(n)) {
            axpy(*aik, bk, ci);
        }
    }
}

/// `c (m x n) += a^T b` with `a` r x m and `b` r x n.
pub(crate) fn gemm_tn_acc(a: &[f64], b: &[f64], c: &mut [f64], r: usize, m: usize, n: usize) {
    if n == 0 || m == 0 {
        return;
    }
    let c = &mut c[..m * n];
    for (ak, bk) in a[..r * m].chunks_exact(m).zip(b.chunks_exact(n)) {
        for (aki, ci) in ak.iter().zip(c.chunks_exact_mut(n)) {
            axpy(*aki, bk, ci);
        }
    }
}

/// `y (m) += a (m x n) x`.
pub(crate) fn gemv_n_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    if n == 0 {
        return;
    }
    let x = &x[..n];
    for (yi, ai) in y[..m].iter_mut().zip(a.chunks_exact(n)) {
        *yi += dot(ai, x);
    }
}

/// `y (n) += a^T x` with `a` m x n.
pub(crate) fn gemv_t_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    if n == 0 {
        return;
    }
    let y = &mut y[..n];
    for (xi, ai) in x[..m].iter().zip(a.chunks_exact(n)) {
        axpy(*xi, ai, y);
    }
}

/// Symmetric eigendecomposition `A = V diag(d) V^T` by cyclic Jacobi rotations: `a` (n x n,
/// symmetric, destroyed), eigenvalues into `d`, eigenvectors as the columns of `v`. Returns false if
/// the sweeps did not converge or met non-finite values.
pub(crate) fn sym_eigen(a: &mut [f64], n: usize, d: &mut [f64], v: &mut [f64]) -> bool {
    v[..n * n].fill(0.0);
    for i in 0..n {
        v[i * n + i] = 1.0;
    }
    let mut converged = false;
    for _sweep in 0..60 {
        let (mut off, mut diag) = (0.0, 0.0);
        for i in 0..n {
            diag += a[i * n + i] * a[i * n + i];
            for j in i + 1..n {
                off += a[i * n + j] * a[i * n + j];
            }
        }
        if !(off.is_finite() && diag.is_finite()) {
            return false;
        }
        if off <= 1e-30 * diag || off == 0.0 {
            converged = true;
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                let apq = a[p * n + q];
                if apq == 0.0 {
                    continue;
                }
                let theta = (a[q * n + q] - a[p * n + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..n {
                    let (akp, akq) = (a[k * n + p], a[k * n + q]);
                    a[k * n + p] = c * akp - s * akq;
                    a[k * n + q] = s * akp + c * akq;
                }
                for k in 0..n {
                    let (apk, aqk) = (a[p * n + k], a[q * n + k]);
                    a[p * n + k] = c * apk - s * aqk;
                    a[q * n + k] = s * apk + c * aqk;
                }
                for k in 0..n {
                    let (vkp, vkq) = (v[k * n + p], v[k * n + q]);
                    v[k * n + p] = c * vkp - s * vkq;
                    v[k * n + q] = s * vkp + c * vkq;
                }
            }
        }
    }
    for i in 0..n {
        d[i] = a[i * n + i];
    }
    converged
}

/// Solves `V diag(d) V^T x = b` in place (b of length n), with `tmp` (n) as scratch.
pub(crate) fn eigen_solve(v: &[f64], d: &[f64], n: usize, b: &mut [f64], tmp: &mut [f64]) {
    for j in 0..n {
        let mut s = 0.0;
        for i in 0..n {
            s += v[i * n + j] * b[i];
        }
        tmp[j] = s / d[j];
    }
    for i in 0..n {
        let mut s = 0.0;
        for j in 0..n {
            s += v[i * n + j] * tmp[j];
        }
        b[i] = s;
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
    fn jacobi_eigendecomposition_reconstructs_and_solves() {
        let n = 4;
        let a0 = [
            2.0, -1.0, 0.5, 0.0, -1.0, -3.0, 1.0, 0.2, 0.5, 1.0, 0.1, -0.7, 0.0, 0.2, -0.7, 4.0,
        ];
        let mut a = a0;
        let (mut d, mut v) = ([0.0; 4], [0.0; 16]);
        assert!(sym_eigen(&mut a, n, &mut d, &mut v));
        for i in 0..n {
            for j in 0..n {
                let r: f64 = (0..n).map(|k| v[i * n + k] * d[k] * v[j * n + k]).sum();
                assert!((r - a0[i * n + j]).abs() < 1e-12);
            }
        }
        // R diag(3, -2) R^T with a rotation R: eigenvalues 3 and -2
        let (c, sn) = (0.6_f64, 0.8_f64);
        let mut r2 = [
            3.0 * c * c - 2.0 * sn * sn,
            (3.0 + 2.0) * c * sn,
            (3.0 + 2.0) * c * sn,
            3.0 * sn * sn - 2.0 * c * c,
        ];
        let (mut d2, mut v2) = ([0.0; 2], [0.0; 4]);
        assert!(sym_eigen(&mut r2, 2, &mut d2, &mut v2));
        let (lo, hi) = (d2[0].min(d2[1]), d2[0].max(d2[1]));
        assert!(
            (lo + 2.0).abs() < 1e-12 && (hi - 3.0).abs() < 1e-12,
            "{d2:?}"
        );
        let x = [1.0, 2.0, -1.0, 0.5];
        let mut b = [0.0; 4];
        gemv_n_acc(&a0, &x, &mut b, n, n);
        let mut tmp = [0.0; 4];
        eigen_solve(&v, &d, n, &mut b, &mut tmp);
        for i in 0..n {
            assert!((b[i] - x[i]).abs() < 1e-12);
        }
    }

    #[test]
    fn products_agree_with_loops() {
        let a = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0]; // 2 x 3
        let b = [1.0, 0.0, -1.0, 2.0, 0.5, 1.0]; // 3 x 2
        let mut c = [0.0; 4];
        gemm_nn(&a, &b, &mut c, 2, 3, 2);
        assert_eq!(c, [1.0 - 2.0 + 1.5, 4.0 + 3.0, 4.0 - 5.0 + 3.0, 10.0 + 6.0]);
        let mut d = [0.0; 4]; // a a^T via tn with a^T: (3 x 2)^T (3 x 2)
        let at = [1.0, 4.0, 2.0, 5.0, 3.0, 6.0];
        gemm_tn_acc(&at, &at, &mut d, 3, 2, 2);
        assert_eq!(d, [14.0, 32.0, 32.0, 77.0]);
        let mut y = [0.0; 3];
        gemv_t_acc(&a, &[1.0, 1.0], &mut y, 2, 3);
        assert_eq!(y, [5.0, 7.0, 9.0]);
    }
}
