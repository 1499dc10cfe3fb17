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

/// The widths of small stages (1..=12 and 17: the rows of a stage's blocks for up to 6 links) get
/// a kernel with the constant width `N` ([`crate::dispatch_width`]), so that a row of the result
/// lives in registers and its loops unroll; any other width runs `$fallback`. The kernels do the
/// same arithmetic in the same order as the fallback, so the result does not depend on the width's
/// path.
macro_rules! with_width {
    ($w:expr, $kernel:ident $args:tt, $fallback:expr) => {
        $crate::dispatch_width!(
            $w,
            [1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 17],
            $kernel $args,
            $fallback
        )
    };
}

/// Solves `L L^T X = B` in place for the n x m row-major `b` (m right-hand sides as columns), with L
/// from [`chol`].
pub(crate) fn chol_solve(l: &[f64], n: usize, b: &mut [f64], m: usize) {
    if n == 0 || m == 0 {
        return;
    }
    let l = &l[..n * n];
    let b = &mut b[..n * m];
    with_width!(m, chol_solve_w(l, n, b), chol_solve_any(l, n, b, m))
}

/// [`chol_solve`] for `M` right-hand sides: a row of `B` in registers.
#[inline(always)]
fn chol_solve_w<const M: usize>(l: &[f64], n: usize, b: &mut [f64]) {
    let (b, _) = b.as_chunks_mut::<M>();
    let b = &mut b[..n];
    // forward: L Y = B
    for i in 0..n {
        let (done, rest) = b.split_at_mut(i);
        let mut x = rest[0];
        for (lik, bk) in l[i * n..i * n + i].iter().zip(done.iter()) {
            for j in 0..M {
                x[j] -= lik * bk[j];
            }
        }
        let d = 1.0 / l[i * n + i];
        for v in x.iter_mut() {
            *v *= d;
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
        let d = 1.0 / l[i * n + i];
        for v in x.iter_mut() {
            *v *= d;
        }
        head[i] = x;
    }
}

/// [`chol_solve`] for any m (the reference of the fixed-width kernels).
fn chol_solve_any(l: &[f64], n: usize, b: &mut [f64], m: usize) {
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

/// `c (m x n) = a (m x r) * b (r x n)`.
pub(crate) fn gemm_nn(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    if n == 0 {
        return;
    }
    c[..m * n].fill(0.0);
    gemm_nn_acc(a, b, c, m, r, n);
}

/// `c (m x n) += a (m x r) * b (r x n)`: every entry `c_ij + a_i0 b_0j + a_i1 b_1j + ...` summed in
/// the order of k.
pub(crate) fn gemm_nn_acc(a: &[f64], b: &[f64], c: &mut [f64], m: usize, r: usize, n: usize) {
    if n == 0 || r == 0 {
        return;
    }
    let (a, b, c) = (&a[..m * r], &b[..r * n], &mut c[..m * n]);
    with_width!(n, gemm_nn_w(a, b, c, r), gemm_nn_any(a, b, c, r, n))
}

/// [`gemm_nn_acc`] for any width (the reference of the fixed-width kernels).
fn gemm_nn_any(a: &[f64], b: &[f64], c: &mut [f64], r: usize, n: usize) {
    for (ci, ai) in c.chunks_exact_mut(n).zip(a.chunks_exact(r)) {
        for (aik, bk) in ai.iter().zip(b.chunks_exact(n)) {
            for (p, q) in ci.iter_mut().zip(bk) {
                *p += aik * q;
            }
        }
    }
}

/// [`gemm_nn_acc`] for `N` columns: rows of `c` in registers, two at a time for `N <= 8` (each
/// row of `b` loaded once for both).
#[inline(always)]
fn gemm_nn_w<const N: usize>(a: &[f64], b: &[f64], c: &mut [f64], r: usize) {
    let (b, _) = b.as_chunks::<N>();
    let (c, _) = c.as_chunks_mut::<N>();
    let pairs = if N <= 8 { c.len() / 2 } else { 0 };
    let (c2, c1) = c.split_at_mut(2 * pairs);
    let (a2, a1) = a.split_at(2 * pairs * r);
    for (cp, ap) in c2.chunks_exact_mut(2).zip(a2.chunks_exact(2 * r)) {
        let (mut x0, mut x1) = (cp[0], cp[1]);
        let (a0, a1) = ap.split_at(r);
        for ((s0, s1), bk) in a0.iter().zip(a1).zip(b) {
            for j in 0..N {
                x0[j] += s0 * bk[j];
                x1[j] += s1 * bk[j];
            }
        }
        (cp[0], cp[1]) = (x0, x1);
    }
    for (ci, ai) in c1.iter_mut().zip(a1.chunks_exact(r)) {
        let mut acc = *ci;
        for (aik, bk) in ai.iter().zip(b) {
            for j in 0..N {
                acc[j] += aik * bk[j];
            }
        }
        *ci = acc;
    }
}

/// `c (m x n) += a^T b` with `a` r x m and `b` r x n: every entry `c_ij + a_0i b_0j + a_1i b_1j + ...`
/// summed in the order of k.
pub(crate) fn gemm_tn_acc(a: &[f64], b: &[f64], c: &mut [f64], r: usize, m: usize, n: usize) {
    if n == 0 || m == 0 {
        return;
    }
    let (a, b, c) = (&a[..r * m], &b[..r * n], &mut c[..m * n]);
    with_width!(n, gemm_tn_w(a, b, c, m), gemm_tn_any(a, b, c, m, n))
}

/// [`gemm_tn_acc`] for any width (the reference of the fixed-width kernels).
fn gemm_tn_any(a: &[f64], b: &[f64], c: &mut [f64], m: usize, n: usize) {
    for (ak, bk) in a.chunks_exact(m).zip(b.chunks_exact(n)) {
        for (aki, ci) in ak.iter().zip(c.chunks_exact_mut(n)) {
            for (p, q) in ci.iter_mut().zip(bk) {
                *p += aki * q;
            }
        }
    }
}

/// [`gemm_tn_acc`] for `N` columns: rows of `c` in registers, two at a time for `N <= 8` (each
/// row of `b` loaded once for both).
#[inline(always)]
fn gemm_tn_w<const N: usize>(a: &[f64], b: &[f64], c: &mut [f64], m: usize) {
    let (b, _) = b.as_chunks::<N>();
    let (c, _) = c.as_chunks_mut::<N>();
    let pairs = if N <= 8 { m / 2 } else { 0 };
    let (c2, c1) = c.split_at_mut(2 * pairs);
    for (p, cp) in c2.chunks_exact_mut(2).enumerate() {
        let i = 2 * p;
        let (mut x0, mut x1) = (cp[0], cp[1]);
        for (ak, bk) in a.chunks_exact(m).zip(b) {
            let (s0, s1) = (ak[i], ak[i + 1]);
            for j in 0..N {
                x0[j] += s0 * bk[j];
                x1[j] += s1 * bk[j];
            }
        }
        (cp[0], cp[1]) = (x0, x1);
    }
    for (i, ci) in c1.iter_mut().enumerate() {
        let i = 2 * pairs + i;
        let mut acc = *ci;
        for (ak, bk) in a.chunks_exact(m).zip(b) {
            let aki = ak[i];
            for j in 0..N {
                acc[j] += aki * bk[j];
            }
        }
        *ci = acc;
    }
}

/// `y (m) += a (m x n) x`: `y_i + (a_i0 x_0 + a_i1 x_1 + ...)`, the dot product summed from 0 in the
/// order of j.
pub(crate) fn gemv_n_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    if n == 0 {
        return;
    }
    let (a, x, y) = (&a[..m * n], &x[..n], &mut y[..m]);
    with_width!(n, gemv_n_w(a, x, y), gemv_n_any(a, x, y, n))
}

/// [`gemv_n_acc`] for any width (the reference of the fixed-width kernels).
fn gemv_n_any(a: &[f64], x: &[f64], y: &mut [f64], n: usize) {
    for (yi, ai) in y.iter_mut().zip(a.chunks_exact(n)) {
        let mut s = 0.0;
        for (p, q) in ai.iter().zip(x) {
            s += p * q;
        }
        *yi += s;
    }
}

/// [`gemv_n_acc`] for `N` columns.
#[inline(always)]
fn gemv_n_w<const N: usize>(a: &[f64], x: &[f64], y: &mut [f64]) {
    let (a, _) = a.as_chunks::<N>();
    let x: &[f64; N] = x.try_into().expect("x has N entries");
    for (yi, ai) in y.iter_mut().zip(a) {
        let mut s = 0.0;
        for j in 0..N {
            s += ai[j] * x[j];
        }
        *yi += s;
    }
}

/// `y (n) += a^T x` with `a` m x n: every entry `y_j + x_0 a_0j + x_1 a_1j + ...` summed in the order
/// of i.
pub(crate) fn gemv_t_acc(a: &[f64], x: &[f64], y: &mut [f64], m: usize, n: usize) {
    if n == 0 {
        return;
    }
    let (a, x, y) = (&a[..m * n], &x[..m], &mut y[..n]);
    with_width!(n, gemv_t_w(a, x, y), gemv_t_any(a, x, y, n))
}

/// [`gemv_t_acc`] for any width (the reference of the fixed-width kernels).
fn gemv_t_any(a: &[f64], x: &[f64], y: &mut [f64], n: usize) {
    for (xi, ai) in x.iter().zip(a.chunks_exact(n)) {
        for (p, q) in y.iter_mut().zip(ai) {
            *p += xi * q;
        }
    }
}

/// [`gemv_t_acc`] for `N` columns: `y` in registers.
#[inline(always)]
fn gemv_t_w<const N: usize>(a: &[f64], x: &[f64], y: &mut [f64]) {
    let (a, _) = a.as_chunks::<N>();
    let y: &mut [f64; N] = y.try_into().expect("y has N entries");
    let mut acc = *y;
    for (xi, ai) in x.iter().zip(a) {
        for j in 0..N {
            acc[j] += xi * ai[j];
        }
    }
    *y = acc;
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
    use crate::testing::values;

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
    fn fixed_width_kernels_match_the_reference_bit_for_bit() {
        // every width with a kernel and its neighbours; odd and even row counts (the paired rows)
        for n in (1..=13).chain([16, 17, 18]) {
            for (m, r) in [(1, 1), (2, 3), (3, 8), (7, 5), (8, 8), (11, 4)] {
                let seed = (n * 100 + m * 10 + r) as u64;
                let (a, b, c0) = (
                    values(m * r, seed),
                    values(r * n, seed + 1),
                    values(m * n, seed + 2),
                );
                let (mut c, mut c_ref) = (c0.clone(), c0.clone());
                gemm_nn_acc(&a, &b, &mut c, m, r, n);
                gemm_nn_any(&a, &b, &mut c_ref, r, n);
                assert_eq!(c, c_ref, "gemm_nn_acc m {m} r {r} n {n}");
                let at = values(r * m, seed + 3);
                let (mut c, mut c_ref) = (c0.clone(), c0.clone());
                gemm_tn_acc(&at, &b, &mut c, r, m, n);
                gemm_tn_any(&at, &b, &mut c_ref, m, n);
                assert_eq!(c, c_ref, "gemm_tn_acc m {m} r {r} n {n}");
                let (x, y0) = (values(n, seed + 4), values(m, seed + 5));
                let an = values(m * n, seed + 6);
                let (mut y, mut y_ref) = (y0.clone(), y0.clone());
                gemv_n_acc(&an, &x, &mut y, m, n);
                gemv_n_any(&an, &x, &mut y_ref, n);
                assert_eq!(y, y_ref, "gemv_n_acc m {m} n {n}");
                let (xt, yt0) = (values(m, seed + 7), values(n, seed + 8));
                let (mut y, mut y_ref) = (yt0.clone(), yt0.clone());
                gemv_t_acc(&an, &xt, &mut y, m, n);
                gemv_t_any(&an, &xt, &mut y_ref, n);
                assert_eq!(y, y_ref, "gemv_t_acc m {m} n {n}");
            }
            // n x n factor, n right-hand-side columns
            let k = 5;
            let mm = values(k * k, n as u64);
            let mut spd = vec![0.0; k * k];
            gemm_tn_any(&mm, &mm, &mut spd, k, k);
            for i in 0..k {
                spd[i * k + i] += 1.0;
            }
            assert!(chol(&mut spd, k));
            let b0 = values(k * n, n as u64 + 1);
            let (mut x, mut x_ref) = (b0.clone(), b0.clone());
            chol_solve(&spd, k, &mut x, n);
            chol_solve_any(&spd, k, &mut x_ref, n);
            assert_eq!(x, x_ref, "chol_solve n {n}");
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
