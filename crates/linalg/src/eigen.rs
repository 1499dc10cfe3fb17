//! Symmetric eigendecomposition of a small matrix by cyclic Jacobi rotations, and the solve with it
//! (for symmetric matrices that may be indefinite).

/// Symmetric eigendecomposition `A = V diag(d) V^T` by cyclic Jacobi rotations: `a` (n x n,
/// symmetric, destroyed), eigenvalues into `d`, eigenvectors as the columns of `v`. Returns false if
/// the sweeps did not converge or met non-finite values.
pub fn sym_eigen(a: &mut [f64], n: usize, d: &mut [f64], v: &mut [f64]) -> bool {
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
pub fn eigen_solve(v: &[f64], d: &[f64], n: usize, b: &mut [f64], tmp: &mut [f64]) {
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
    use crate::gemv_n_acc;

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
}
