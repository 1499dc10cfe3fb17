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

/// Every derivative an optimal-control problem ([`brachia_ocp::OcpProblem`]) hands the solver, checked
/// at `z` against central differences of its own values: per stage k the Jacobian of `[f_k; c_k]`
/// (tolerance 1e-6) and the cost gradient (1e-7) in `z_k = [x_k; u_k]`, the terminal rows' Jacobian in
/// `x_K` (1e-7), and every stage Lagrangian Hessian of `sigma l_k + lam_k^T f_k + mu_k^T c_k`
/// (`+ nu^T r` at the last stage) with the multipliers `m`: symmetric, and against differences of that
/// Lagrangian's exact gradient (1e-5). `probe` is a second instance of the same problem, used for the
/// perturbed evaluations. Panics naming `what` and the stage at the first mismatch, or when an
/// evaluation fails.
pub fn assert_ocp_derivatives(
    what: &str,
    ocp: &mut dyn brachia_ocp::OcpProblem,
    probe: &mut dyn brachia_ocp::OcpProblem,
    z: &brachia_ocp::Primal,
    sigma: f64,
    m: &brachia_ocp::Multipliers,
) {
    use brachia_ocp::EvalLevel;
    let k_last = ocp.dims().horizon();
    let b = ocp_eval(ocp, z, EvalLevel::FirstOrder);
    for (k, ev) in b.stages.iter().enumerate() {
        let zk = stage_vec(z, k);
        assert_eq!(ev.grad.len(), zk.len(), "{what} stage {k}: gradient length");
        let (nf, nc) = (ev.f.len(), ev.c.len());
        let mut zp = z.clone();
        if nf + nc > 0 {
            let exact = [ev.jac_f.as_slice(), ev.jac_c.as_slice()].concat();
            assert_jacobian(
                &format!("{what} stage {k}: [f; c] Jacobian"),
                |v, out| {
                    set_stage(&mut zp, k, v);
                    let e = ocp_eval(probe, &zp, EvalLevel::Values);
                    out[..nf].copy_from_slice(&e.stages[k].f);
                    out[nf..].copy_from_slice(&e.stages[k].c);
                },
                &zk,
                &exact,
                1e-6,
            );
        }
        let mut zp = z.clone();
        assert_jacobian(
            &format!("{what} stage {k}: cost gradient"),
            |v, out| {
                set_stage(&mut zp, k, v);
                out[0] = ocp_eval(probe, &zp, EvalLevel::Values).stages[k].cost;
            },
            &zk,
            &ev.grad,
            1e-7,
        );
    }
    let mut zp = z.clone();
    assert_jacobian(
        &format!("{what}: terminal Jacobian"),
        |v, out| {
            zp.x[k_last].copy_from_slice(v);
            out.copy_from_slice(&ocp_eval(probe, &zp, EvalLevel::Values).term.r);
        },
        &z.x[k_last],
        &b.term.jac_r,
        1e-7,
    );

    let mut hb = ocp_buffers(ocp.dims());
    if let Err(e) = ocp.hessians(z, sigma, m, &mut hb.stages) {
        panic!("{what}: Hessians failed at stage {}: {}", e.stage, e.reason);
    }
    for (k, st) in hb.stages.iter().enumerate() {
        let zk = stage_vec(z, k);
        let nz = zk.len();
        let hess = &st.hess;
        for a in 0..nz {
            for c in 0..a {
                assert_eq!(
                    hess[a * nz + c],
                    hess[c * nz + a],
                    "{what} stage {k}: Hessian not symmetric at ({a}, {c})"
                );
            }
        }
        let mut zp = z.clone();
        assert_hessian(
            &format!("{what} stage {k}: Lagrangian Hessian"),
            |v, out| {
                set_stage(&mut zp, k, v);
                let e = ocp_eval(probe, &zp, EvalLevel::FirstOrder);
                stage_lagrangian_gradient(&e, k, sigma, m, k == k_last, out);
            },
            &zk,
            hess,
            1e-5,
        );
    }
}

/// Evaluation buffers of an optimal-control problem.
struct OcpBuffers {
    stages: Vec<brachia_ocp::StageEval>,
    term: brachia_ocp::TerminalEval,
}

fn ocp_buffers(d: &brachia_ocp::OcpDims) -> OcpBuffers {
    OcpBuffers {
        stages: d.stage_evals(),
        term: d.terminal_eval(),
    }
}

fn ocp_eval(
    ocp: &mut dyn brachia_ocp::OcpProblem,
    z: &brachia_ocp::Primal,
    level: brachia_ocp::EvalLevel,
) -> OcpBuffers {
    let mut b = ocp_buffers(ocp.dims());
    if let Err(e) = ocp.evaluate(z, level, &mut b.stages, &mut b.term) {
        panic!("evaluation failed at stage {}: {}", e.stage, e.reason);
    }
    b
}

fn set_stage(z: &mut brachia_ocp::Primal, k: usize, v: &[f64]) {
    let nx = z.x[k].len();
    z.x[k].copy_from_slice(&v[..nx]);
    z.u[k].copy_from_slice(&v[nx..]);
}

fn stage_vec(z: &brachia_ocp::Primal, k: usize) -> Vec<f64> {
    [z.x[k].as_slice(), z.u[k].as_slice()].concat()
}

/// Gradient in `z_k` of `sigma l_k + lam_k^T f_k + mu_k^T c_k` (`+ nu^T r` at the last stage).
fn stage_lagrangian_gradient(
    b: &OcpBuffers,
    k: usize,
    sigma: f64,
    m: &brachia_ocp::Multipliers,
    last: bool,
    out: &mut [f64],
) {
    let ev = &b.stages[k];
    let nz = ev.grad.len();
    for (j, o) in out.iter_mut().enumerate().take(nz) {
        let mut v = sigma * ev.grad[j];
        for (r, l) in m.lam[k].iter().enumerate() {
            v += l * ev.jac_f[r * nz + j];
        }
        for (r, l) in m.mu[k].iter().enumerate() {
            v += l * ev.jac_c[r * nz + j];
        }
        if last {
            for (r, l) in m.nu.iter().enumerate() {
                v += l * b.term.jac_r[r * nz + j];
            }
        }
        *o = v;
    }
}
