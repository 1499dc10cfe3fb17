//! The one finite-difference checker every derivative in brachia is tested with.
//!
//! Finite differences are never the production path; they exist here to check the exact derivatives.
//! Central differences with step `h * max(1, |x_j|)`; an entry passes when
//! `|exact - fd| <= tol * max(1, |exact|, |fd|)`.

/// Outcome of a comparison.
#[derive(Debug, Clone, PartialEq)]
pub struct FdReport {
    /// Largest scaled error `|exact - fd| / max(1, |exact|, |fd|)`.
    pub max_scaled_err: f64,
    /// Row and column of the worst entry.
    pub worst: (usize, usize),
    /// Exact and finite-difference values there.
    pub values: (f64, f64),
}

/// Central-difference Jacobian of `f: R^n -> R^m`, row-major m x n.
pub fn fd_jacobian(mut f: impl FnMut(&[f64], &mut [f64]), x: &[f64], m: usize, h: f64) -> Vec<f64> {
    let n = x.len();
    let mut jac = vec![0.0; m * n];
    let (mut xp, mut fp, mut fm) = (x.to_vec(), vec![0.0; m], vec![0.0; m]);
    for j in 0..n {
        let step = h * x[j].abs().max(1.0);
        xp[j] = x[j] + step;
        f(&xp, &mut fp);
        xp[j] = x[j] - step;
        f(&xp, &mut fm);
        xp[j] = x[j];
        for i in 0..m {
            jac[i * n + j] = (fp[i] - fm[i]) / (2.0 * step);
        }
    }
    jac
}

/// Compare two row-major m x n matrices entry by entry.
pub fn compare(exact: &[f64], fd: &[f64], n_cols: usize) -> FdReport {
    assert_eq!(exact.len(), fd.len(), "matrices of different sizes");
    let mut rep = FdReport {
        max_scaled_err: 0.0,
        worst: (0, 0),
        values: (0.0, 0.0),
    };
    for (k, (&a, &b)) in exact.iter().zip(fd).enumerate() {
        let e = (a - b).abs() / 1f64.max(a.abs()).max(b.abs());
        if e > rep.max_scaled_err || e.is_nan() {
            rep = FdReport {
                max_scaled_err: e,
                worst: (k / n_cols, k % n_cols),
                values: (a, b),
            };
        }
    }
    rep
}

/// Check an exact Jacobian (row-major m x n) of `f` at `x` against central differences.
/// Panics with a readable message when an entry is off by more than `tol` (scaled).
pub fn assert_jacobian(
    what: &str,
    f: impl FnMut(&[f64], &mut [f64]),
    x: &[f64],
    exact: &[f64],
    tol: f64,
) -> FdReport {
    let n = x.len();
    let m = exact.len() / n.max(1);
    let fd = fd_jacobian(f, x, m, 1e-6);
    let rep = compare(exact, &fd, n);
    assert!(
        rep.max_scaled_err <= tol,
        "{what}: derivative mismatch at entry {:?}: exact {} vs finite difference {} (scaled error {:.3e} > {tol:.1e})",
        rep.worst,
        rep.values.0,
        rep.values.1,
        rep.max_scaled_err
    );
    rep
}

/// Check an exact Hessian (row-major n x n) of a scalar function against central differences of its
/// exact gradient `grad`.
pub fn assert_hessian(
    what: &str,
    grad: impl FnMut(&[f64], &mut [f64]),
    x: &[f64],
    exact: &[f64],
    tol: f64,
) -> FdReport {
    assert_jacobian(what, grad, x, exact, tol)
}
