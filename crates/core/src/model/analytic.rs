//! Closed-form first and second derivatives of the forward dynamics `qdd = f(z)`.
//!
//! Same function as [`super::DynamicsFn`]: `z = [q (n), qd (n), tau (n - 1)]` (rad, rad/s, N m) to
//! `qdd` (n, rad/s^2), angles as in the crate docs (`q[0]` absolute, `q[1..]` relative, `th = S q` with
//! `S` the lower-triangular matrix of ones). Outputs use exactly the layouts of
//! [`crate::ad::Diff::jacobian`] (row-major `n x (3n - 1)`, entry `[i][j] = d qdd_i / d z_j`) and
//! [`crate::ad::Diff::hessian_weighted`] (full symmetric row-major `(3n - 1) x (3n - 1)`), which stay the
//! test oracle. Derivative units follow from those of `z`: `d qdd / d q` in 1/s^2, `d qdd / d qd` in 1/s,
//! `d qdd / d tau` in 1/(kg m^2).
//!
//! ## Derivation (the formulas implemented; `docs/derivatives.md` has the long form)
//! Everything is written in absolute angles `th = S q`, rates `om = S qd`, accelerations `al = S a`
//! (`a = qdd`), where the generalised force of link j is a sum over links k with constant coefficients
//! `d_jk` and `g_j`:
//!
//! `r_j(th, om, al) = sum_k d_jk [cos(th_j - th_k) al_k + sin(th_j - th_k) om_k^2] + g_j cos th_j`,
//!
//! and the dynamics read `F(z, a) = S^T r(S q, S qd, S a) - B tau = 0` (`M = S^T M_abs S`,
//! `h = S^T r(th, om, 0)`). With `s_jk, c_jk` the sine and cosine of `th_j - th_k`:
//!
//! - First order: `M da/dz = -dF/dz`, with `dF/dq = S^T R_th S`, `dF/dqd = S^T R_om S`,
//!   `dF/dtau = -B`, and for `m != j`: `R_th[j][m] = P_jm = d_jm (s_jm al_m - c_jm om_m^2)`,
//!   `R_th[j][j] = -sum_{m != j} P_jm - g_j sin th_j`, `R_om[j][m] = 2 d_jm s_jm om_m`, `R_om[j][j] = 0`.
//!   Row sums of the `P` part vanish: `M` does not depend on `q[0]`, only gravity does.
//! - Second order, with the adjoint `y = M^-1 w` and `u = S y`: differentiating `F(z, a(z)) = 0` twice
//!   (`F` is linear in `a` and in `tau`) gives
//!   `w . d2a/dz2 = -(Q + P + P^T)`, where `Q = T^T (d2/d(th, om)^2 of u . r at fixed al) T`
//!   (`T = diag(S, S)` on the q, qd block, zero on tau) and `P = S^T L S (da/dz)` fills the q rows,
//!   `L[m][k] = d/dth_m (M_abs u)_k` (`L[m][k] = -u_m d_mk s_mk` for `m != k`, columns summing to zero).
//!   `u . r` is a sum over link pairs `j < k` of
//!   `psi = d_jk [c_jk (u_j al_k + u_k al_j) + s_jk (u_j om_k^2 - u_k om_j^2)]`, a function of
//!   `th_j - th_k` whose second derivative is `-psi`, plus `u_j g_j cos th_j`. The tau-tau and qd-tau blocks are zero; qd-qd is the suffix sum of a
//!   diagonal.
//!
//! The value `qdd` is computed with the arithmetic of [`Robot::forward_dynamics_into`] in the same order,
//! so it agrees with it bit for bit.

use super::Robot;
use brachia_linalg::{add_lincomb, add_lincomb2, cholesky, cholesky_solve_vec, Scaling};

/// Reusable buffers (allocated in new; no allocation per call). Sized for robot.n.
///
/// Every method panics (a programmer's error) when called with a robot of another size or with slices
/// of the wrong lengths: `z` 3n - 1, `qdd` and `w` n, `jac` n (3n - 1), `hess` (3n - 1)^2.
#[derive(Debug, Clone)]
pub struct DynamicsDerivatives {
    n: usize,
    /// sin / cos of the absolute angles (n).
    sn: Vec<f64>,
    cs: Vec<f64>,
    /// sin / cos of the absolute angles at the angles `trig_q`, handed over by
    /// [`Self::provide_trig`] (valid when `trig_valid`): `prepare` at those angles takes them
    /// instead of calling `sin_cos` again.
    trig_q: Vec<f64>,
    trig_sn: Vec<f64>,
    trig_cs: Vec<f64>,
    trig_valid: bool,
    /// sin / cos of th_j - th_k, row-major n x n.
    sd: Vec<f64>,
    cd: Vec<f64>,
    /// Absolute rates om = S qd (n).
    om: Vec<f64>,
    /// M_abs and its sandwich (n x n scratch).
    tmp: Vec<f64>,
    /// M (relative angles), then its Cholesky factor in the lower triangle (n x n).
    l: Vec<f64>,
    /// Bias forces in absolute then relative angles (n).
    h: Vec<f64>,
    /// qdd (n) and absolute accelerations al = S qdd (n).
    a: Vec<f64>,
    al: Vec<f64>,
    /// dr/dth and dr/dom at fixed al (n x n), sandwiched in place by S^T . S.
    rth: Vec<f64>,
    rom: Vec<f64>,
    /// d qdd / dz (n x nz) and its absolute version S d qdd / dz (n x nz).
    jz: Vec<f64>,
    az: Vec<f64>,
    /// Adjoint y = M^-1 w and u = S y (n).
    y: Vec<f64>,
    u: Vec<f64>,
    /// Second derivatives of u . r at fixed al: th-th (n x n), th-om (n x n), om-om (diagonal, n).
    qtt: Vec<f64>,
    qto: Vec<f64>,
    qoo: Vec<f64>,
    /// L[m][k] = d/dth_m (M_abs u)_k (n x n).
    lta: Vec<f64>,
    /// P = S^T L S d qdd / dz (n x nz).
    p: Vec<f64>,
}

/// `x <- S^T x S` in place for row-major n x n `x`: entry `[i][l]` becomes `sum_{j >= i, m >= l} x[j][m]`.
/// (Inlined into callers with constant sizes.)
#[inline(always)]
fn sandwich_body(x: &mut [f64], n: usize) {
    let x = &mut x[..n * n];
    for i in 0..n {
        let row = &mut x[i * n..(i + 1) * n];
        for m in (0..n - 1).rev() {
            row[m] += row[m + 1];
        }
    }
    for i in (0..n - 1).rev() {
        for m in 0..n {
            x[i * n + m] += x[(i + 1) * n + m];
        }
    }
}

/// Solve `L L^T X = B` in place for row-major n x nc `x` (= B on entry), `L` the lower triangle of `l`
/// (inlined into callers with constant sizes).
#[inline(always)]
fn solve_multi_body(l: &[f64], n: usize, x: &mut [f64], nc: usize) {
    let (l, x) = (&l[..n * n], &mut x[..n * nc]);
    for i in 0..n {
        let (done, rest) = x.split_at_mut(i * nc);
        let xi = &mut rest[..nc];
        for k in 0..i {
            let lik = l[i * n + k];
            for (v, &xk) in xi.iter_mut().zip(&done[k * nc..(k + 1) * nc]) {
                *v -= lik * xk;
            }
        }
        let d = l[i * n + i];
        for v in xi.iter_mut() {
            *v /= d;
        }
    }
    for i in (0..n).rev() {
        let (head, tail) = x.split_at_mut((i + 1) * nc);
        let xi = &mut head[i * nc..];
        for k in i + 1..n {
            let lki = l[k * n + i];
            let xk = &tail[(k - i - 1) * nc..(k - i) * nc];
            for (v, &b) in xi.iter_mut().zip(xk) {
                *v -= lki * b;
            }
        }
        let d = l[i * n + i];
        for v in xi.iter_mut() {
            *v /= d;
        }
    }
}

/// One of the three steps of [`DynamicsDerivatives`], run through [`pulp::Arch::dispatch`]: the
/// bodies are compiled for the widest vector instructions the CPU has. The same numbers on every
/// CPU: the loops are element-wise (no reordered sums) and Rust never fuses a multiply and an add.
struct Kernel<'a> {
    d: &'a mut DynamicsDerivatives,
    robot: &'a Robot,
    job: Job<'a>,
}

/// What a [`Kernel`] computes: `prepare` at `z`, the Jacobian, or the Hessian weighted by `w`.
enum Job<'a> {
    Prepare(&'a [f64]),
    Jacobian,
    Hessian(&'a [f64], &'a mut [f64]),
}

impl pulp::WithSimd for Kernel<'_> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let Kernel { d, robot, job } = self;
        // the paper's 4 links with constant sizes (unrolled, no bounds checks), any other count
        // through the same body: the same arithmetic either way
        match job {
            Job::Prepare(z) => with_link_count!(d.n, |n| d.prepare_n(robot, z, n)),
            Job::Jacobian => with_link_count!(d.n, |n| d.fill_jacobian_n(robot, n)),
            Job::Hessian(w, hess) => with_link_count!(d.n, |n| d.fill_hessian_n(robot, w, hess, n)),
        }
    }
}

impl DynamicsDerivatives {
    /// Buffers for `robot`.
    pub fn new(robot: &Robot) -> Self {
        let n = robot.n;
        let nz = 3 * n - 1;
        let v = |len: usize| vec![0.0; len];
        DynamicsDerivatives {
            n,
            sn: v(n),
            cs: v(n),
            trig_q: v(n),
            trig_sn: v(n),
            trig_cs: v(n),
            trig_valid: false,
            sd: v(n * n),
            cd: v(n * n),
            om: v(n),
            tmp: v(n * n),
            l: v(n * n),
            h: v(n),
            a: v(n),
            al: v(n),
            rth: v(n * n),
            rom: v(n * n),
            jz: v(n * nz),
            az: v(n * nz),
            y: v(n),
            u: v(n),
            qtt: v(n * n),
            qto: v(n * n),
            qoo: v(n),
            lta: v(n * n),
            p: v(n * nz),
        }
    }

    /// Trigonometry, M and its factor, h, qdd and al at `z`.
    fn prepare(&mut self, robot: &Robot, z: &[f64]) {
        crate::simd_arch().dispatch(Kernel {
            d: self,
            robot,
            job: Job::Prepare(z),
        });
    }

    #[inline(always)]
    fn prepare_n(&mut self, robot: &Robot, z: &[f64], n: usize) {
        assert_eq!(robot.n, n, "DynamicsDerivatives built for a {n}-link robot");
        assert_eq!(
            z.len(),
            3 * n - 1,
            "z must hold [q, qd, tau] (3n - 1 values)"
        );
        let (q, qd, tau) = (&z[..n], &z[n..2 * n], &z[2 * n..3 * n - 1]);
        // centres of mass off the links' axes: d c + e s = rho cos(x - beta), so the pair terms are
        // those of the ideal chain with rho for d and the angles x - beta for x
        let off = robot.off_axis;
        let d = if off {
            &robot.rho[..n * n]
        } else {
            &robot.d[..n * n]
        };
        let (cb, sb) = (&robot.cb[..n * n], &robot.sb[..n * n]);
        let (g, gs) = (&robot.gcoef[..n], &robot.gsin[..n]);
        let (sn, cs, om) = (&mut self.sn[..n], &mut self.cs[..n], &mut self.om[..n]);
        let (sd, cd, tmp) = (
            &mut self.sd[..n * n],
            &mut self.cd[..n * n],
            &mut self.tmp[..n * n],
        );
        let (l, h, a, al) = (
            &mut self.l[..n * n],
            &mut self.h[..n],
            &mut self.a[..n],
            &mut self.al[..n],
        );
        // the sines and cosines handed over at these very angles are the same numbers (the same sums,
        // the same `sin_cos`)
        let reuse = self.trig_valid && self.trig_q[..n] == *q;
        let (tsn, tcs) = (&self.trig_sn[..n], &self.trig_cs[..n]);
        let (mut th, mut omv) = (0.0, 0.0);
        for i in 0..n {
            th += q[i];
            let (s, c) = if reuse {
                (tsn[i], tcs[i])
            } else {
                th.sin_cos()
            };
            sn[i] = s;
            cs[i] = c;
            omv += qd[i];
            om[i] = omv;
        }
        for j in 0..n {
            sd[j * n + j] = 0.0;
            cd[j * n + j] = 1.0;
            tmp[j * n + j] = d[j * n + j];
            for k in j + 1..n {
                let mut c = cs[j] * cs[k] + sn[j] * sn[k];
                let mut s = sn[j] * cs[k] - cs[j] * sn[k];
                if off {
                    let (cbv, sbv) = (cb[j * n + k], sb[j * n + k]);
                    (c, s) = (c * cbv + s * sbv, s * cbv - c * sbv);
                }
                cd[j * n + k] = c;
                cd[k * n + j] = c;
                sd[j * n + k] = s;
                sd[k * n + j] = -s;
                let m = c * d[j * n + k];
                tmp[j * n + k] = m;
                tmp[k * n + j] = m;
            }
        }
        sandwich_body(tmp, n);
        l.copy_from_slice(tmp);
        for j in 0..n {
            let mut v = 0.0;
            for k in 0..n {
                if k != j {
                    v += sd[j * n + k] * om[k] * om[k] * d[j * n + k];
                }
            }
            v += cs[j] * g[j];
            if off {
                v -= sn[j] * gs[j];
            }
            h[j] = v;
        }
        for j in (0..n - 1).rev() {
            h[j] += h[j + 1];
        }
        a[0] = -h[0];
        for i in 1..n {
            a[i] = tau[i - 1] - h[i];
        }
        // M is positive definite for any valid robot; a failed factorisation (non-finite state)
        // gives NaN accelerations
        if cholesky(l, n, Scaling::Reciprocal).is_ok() {
            cholesky_solve_vec(l, n, a, Scaling::Divide);
        } else {
            a.fill(f64::NAN);
        }
        let mut acc = 0.0;
        for i in 0..n {
            acc += a[i];
            al[i] = acc;
        }
    }

    /// `jz = d qdd / dz` (after `prepare`).
    fn fill_jacobian(&mut self, robot: &Robot) {
        crate::simd_arch().dispatch(Kernel {
            d: self,
            robot,
            job: Job::Jacobian,
        });
    }

    #[inline(always)]
    fn fill_jacobian_n(&mut self, robot: &Robot, n: usize) {
        let nz = 3 * n - 1;
        let off = robot.off_axis;
        let d = if off {
            &robot.rho[..n * n]
        } else {
            &robot.d[..n * n]
        };
        let (g, gs, cs) = (&robot.gcoef[..n], &robot.gsin[..n], &self.cs[..n]);
        let (sd, cd, sn) = (&self.sd[..n * n], &self.cd[..n * n], &self.sn[..n]);
        let (al, om) = (&self.al[..n], &self.om[..n]);
        let (rth, rom) = (&mut self.rth[..n * n], &mut self.rom[..n * n]);
        for j in 0..n {
            let mut diag = 0.0;
            for m in 0..n {
                if m == j {
                    continue;
                }
                let jm = j * n + m;
                let p = d[jm] * (sd[jm] * al[m] - cd[jm] * om[m] * om[m]);
                rth[jm] = p;
                diag += p;
                rom[jm] = 2.0 * d[jm] * sd[jm] * om[m];
            }
            rth[j * n + j] = -diag - g[j] * sn[j];
            if off {
                rth[j * n + j] -= gs[j] * cs[j];
            }
            rom[j * n + j] = 0.0;
        }
        sandwich_body(rth, n);
        sandwich_body(rom, n);
        let jz = &mut self.jz[..n * nz];
        for i in 0..n {
            let row = &mut jz[i * nz..(i + 1) * nz];
            for c in 0..n {
                row[c] = -rth[i * n + c];
                row[n + c] = -rom[i * n + c];
            }
            for c in 0..n - 1 {
                row[2 * n + c] = if c + 1 == i { 1.0 } else { 0.0 };
            }
        }
        solve_multi_body(&self.l, n, jz, nz);
    }

    /// Weighted Hessian into `hess` (after `fill_jacobian`).
    fn fill_hessian(&mut self, robot: &Robot, w: &[f64], hess: &mut [f64]) {
        crate::simd_arch().dispatch(Kernel {
            d: self,
            robot,
            job: Job::Hessian(w, hess),
        });
    }

    #[inline(always)]
    fn fill_hessian_n(&mut self, robot: &Robot, w: &[f64], hess: &mut [f64], n: usize) {
        let nz = 3 * n - 1;
        assert_eq!(w.len(), n, "one weight per output qdd_i");
        assert_eq!(hess.len(), nz * nz, "hess is (3n - 1) x (3n - 1)");
        let off = robot.off_axis;
        let d = if off {
            &robot.rho[..n * n]
        } else {
            &robot.d[..n * n]
        };
        let (g, gs) = (&robot.gcoef[..n], &robot.gsin[..n]);
        let (y, u) = (&mut self.y[..n], &mut self.u[..n]);
        let l = &self.l[..n * n];
        y.copy_from_slice(w);
        cholesky_solve_vec(l, n, y, Scaling::Divide);
        let mut acc = 0.0;
        for i in 0..n {
            acc += y[i];
            u[i] = acc;
        }
        // az = S jz: prefix sums over rows.
        let (jz, az) = (&self.jz[..n * nz], &mut self.az[..n * nz]);
        az[..nz].copy_from_slice(&jz[..nz]);
        for i in 1..n {
            for c in 0..nz {
                az[i * nz + c] = az[(i - 1) * nz + c] + jz[i * nz + c];
            }
        }
        // Second derivatives of u . r at fixed al, one link pair at a time.
        let (qtt, qto, qoo) = (
            &mut self.qtt[..n * n],
            &mut self.qto[..n * n],
            &mut self.qoo[..n],
        );
        qtt.fill(0.0);
        qto.fill(0.0);
        qoo.fill(0.0);
        let (u, al, om) = (&*u, &self.al[..n], &self.om[..n]);
        let (cd, sd, cs) = (&self.cd[..n * n], &self.sd[..n * n], &self.cs[..n]);
        for j in 0..n {
            for k in j + 1..n {
                let jk = j * n + k;
                let (c, s, djk) = (cd[jk], sd[jk], d[jk]);
                let big_a = u[j] * al[k] + u[k] * al[j];
                let big_w = u[j] * om[k] * om[k] - u[k] * om[j] * om[j];
                let psi2 = -djk * (c * big_a + s * big_w);
                qtt[j * n + j] += psi2;
                qtt[k * n + k] += psi2;
                qtt[jk] -= psi2;
                qtt[k * n + j] -= psi2;
                let e1 = 2.0 * djk * c * u[j] * om[k];
                let e2 = 2.0 * djk * c * u[k] * om[j];
                qto[jk] += e1;
                qto[k * n + k] -= e1;
                qto[j * n + j] -= e2;
                qto[k * n + j] += e2;
                qoo[k] += 2.0 * djk * s * u[j];
                qoo[j] -= 2.0 * djk * s * u[k];
            }
            qtt[j * n + j] -= u[j] * g[j] * cs[j];
            if off {
                qtt[j * n + j] += u[j] * gs[j] * self.sn[j];
            }
        }
        // L[m][k] = d/dth_m (M_abs u)_k.
        let lta = &mut self.lta[..n * n];
        for k in 0..n {
            let mut diag = 0.0;
            for m in 0..n {
                if m != k {
                    let v = -u[m] * d[m * n + k] * sd[m * n + k];
                    lta[m * n + k] = v;
                    diag -= v;
                }
            }
            lta[k * n + k] = diag;
        }
        // P = S^T L az.
        let p = &mut self.p[..n * nz];
        p.fill(0.0);
        for m in (0..n).step_by(2) {
            if m + 1 < n {
                let (p0, p1) = p[m * nz..(m + 2) * nz].split_at_mut(nz);
                add_lincomb2(p0, p1, &lta[m * n..], &lta[(m + 1) * n..], 1, az, nz, n);
            } else {
                add_lincomb(&mut p[m * nz..(m + 1) * nz], &lta[m * n..], 1, az, nz, n);
            }
        }
        for m in (0..n - 1).rev() {
            for c in 0..nz {
                p[m * nz + c] += p[(m + 1) * nz + c];
            }
        }
        sandwich_body(qtt, n);
        sandwich_body(qto, n);
        for m in (0..n - 1).rev() {
            qoo[m] += qoo[m + 1];
        }
        // Assemble -(Q + P + P^T) with exact symmetry.
        let p = &*p;
        let hess = &mut hess[..nz * nz];
        let mut put = |i: usize, j: usize, v: f64| {
            hess[i * nz + j] = v;
            hess[j * nz + i] = v;
        };
        for i in 0..n {
            for l in 0..=i {
                put(i, l, -(qtt[i * n + l] + p[i * nz + l] + p[l * nz + i]));
            }
            for l in 0..n {
                put(i, n + l, -(qto[i * n + l] + p[i * nz + n + l]));
            }
            for l in 0..n - 1 {
                put(i, 2 * n + l, -p[i * nz + 2 * n + l]);
            }
        }
        for i in 0..n {
            for l in 0..=i {
                put(n + i, n + l, -qoo[i]);
            }
            for l in 0..n - 1 {
                put(n + i, 2 * n + l, 0.0);
            }
        }
        for i in 0..n - 1 {
            for l in 0..=i {
                put(2 * n + i, 2 * n + l, 0.0);
            }
        }
    }

    /// Hand over `sn`, `cs`: the sines and cosines of the absolute angles at the relative angles `q`
    /// (n), computed as [`Robot::forward_dynamics_into`] does (`th += q[i]` from 0, then
    /// `th.sin_cos()`), so that the next evaluation at the same angles does not compute them again
    /// (bit for bit the same numbers). Kept until the next call.
    pub(crate) fn provide_trig(&mut self, q: &[f64], sn: &[f64], cs: &[f64]) {
        let n = self.n;
        self.trig_q.copy_from_slice(&q[..n]);
        self.trig_sn.copy_from_slice(&sn[..n]);
        self.trig_cs.copy_from_slice(&cs[..n]);
        self.trig_valid = true;
    }

    /// qdd = f(z), z = [q, qd, tau] (3n - 1).
    pub fn qdd(&mut self, robot: &Robot, z: &[f64], qdd: &mut [f64]) {
        self.prepare(robot, z);
        qdd[..self.n].copy_from_slice(&self.a);
    }

    /// qdd and its Jacobian, row-major n x (3n - 1): exactly the layout of `Diff::<DynamicsFn>::jacobian`.
    pub fn jacobian(&mut self, robot: &Robot, z: &[f64], qdd: &mut [f64], jac: &mut [f64]) {
        self.prepare(robot, z);
        self.fill_jacobian(robot);
        qdd[..self.n].copy_from_slice(&self.a);
        jac[..self.jz.len()].copy_from_slice(&self.jz);
    }

    /// Full symmetric (3n-1) x (3n-1) row-major Hessian of sum_i w_i qdd_i(z): exactly `Diff::<DynamicsFn>::hessian_weighted`.
    pub fn hessian_weighted(&mut self, robot: &Robot, z: &[f64], w: &[f64], hess: &mut [f64]) {
        self.prepare(robot, z);
        self.fill_jacobian(robot);
        self.fill_hessian(robot, w, hess);
    }

    /// The weighted Hessian at the `z` of this object's last [`Self::jacobian`] call (its
    /// factorisation and first derivatives are still in the buffers): [`Self::hessian_weighted`]
    /// without redoing them. Calling it after anything but `jacobian` at that `z` gives wrong results;
    /// callers that cannot guarantee it use `hessian_weighted`.
    pub fn hessian_weighted_after_jacobian(&mut self, robot: &Robot, w: &[f64], hess: &mut [f64]) {
        self.fill_hessian(robot, w, hess);
    }

    /// Both at once when a caller needs Jacobian and weighted Hessian at the same z (shares the factorisation).
    pub fn jacobian_and_hessian(
        &mut self,
        robot: &Robot,
        z: &[f64],
        w: &[f64],
        qdd: &mut [f64],
        jac: &mut [f64],
        hess: &mut [f64],
    ) {
        self.prepare(robot, z);
        self.fill_jacobian(robot);
        self.fill_hessian(robot, w, hess);
        qdd[..self.n].copy_from_slice(&self.a);
        jac[..self.jz.len()].copy_from_slice(&self.jz);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::collision::tests::odd_robot;
    use crate::model::Scratch;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn bits(v: &[f64]) -> Vec<u64> {
        v.iter().map(|x| x.to_bits()).collect()
    }

    #[test]
    fn vector_instructions_give_the_scalar_bits() {
        // the derivatives as dispatched (the CPU's widest vector instructions) and through the
        // scalar path: the same bits
        let mut rng = ChaCha8Rng::seed_from_u64(29);
        for robot in [Robot::paper(), odd_robot()] {
            let n = robot.n;
            let nz = 3 * n - 1;
            let mut fast = DynamicsDerivatives::new(&robot);
            let mut plain = DynamicsDerivatives::new(&robot);
            let (mut a0, mut j0, mut h0) = (vec![0.0; n], vec![0.0; n * nz], vec![0.0; nz * nz]);
            let mut h1 = vec![0.0; nz * nz];
            for it in 0..20 {
                let z: Vec<f64> = (0..nz).map(|_| rng.gen_range(-3.0..3.0)).collect();
                let w: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
                fast.jacobian_and_hessian(&robot, &z, &w, &mut a0, &mut j0, &mut h0);
                for job in [Job::Prepare(&z), Job::Jacobian, Job::Hessian(&w, &mut h1)] {
                    pulp::Arch::Scalar.dispatch(Kernel {
                        d: &mut plain,
                        robot: &robot,
                        job,
                    });
                }
                assert_eq!(bits(&a0), bits(&plain.a), "qdd, pose {it}");
                assert_eq!(bits(&j0), bits(&plain.jz), "Jacobian, pose {it}");
                assert_eq!(bits(&h0), bits(&h1), "Hessian, pose {it}");
            }
        }
    }

    #[test]
    fn handed_over_trig_gives_the_same_bits() {
        // the sines and cosines of a value evaluation handed over to the derivatives: the same
        // Jacobian and Hessian bit for bit at those angles, and recomputed at other angles
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        for robot in [Robot::paper(), odd_robot()] {
            let n = robot.n;
            let nz = 3 * n - 1;
            let mut ws = Scratch::new(n);
            let (mut fresh, mut handed) = (
                DynamicsDerivatives::new(&robot),
                DynamicsDerivatives::new(&robot),
            );
            let (mut a0, mut a1, mut qv) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
            let (mut j0, mut j1) = (vec![0.0; n * nz], vec![0.0; n * nz]);
            let (mut h0, mut h1) = (vec![0.0; nz * nz], vec![0.0; nz * nz]);
            for it in 0..30 {
                let z: Vec<f64> = (0..nz).map(|_| rng.gen_range(-3.0..3.0)).collect();
                let w: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
                // every other pose the value evaluation is at other angles: nothing to reuse
                let mut zv = z.clone();
                if it % 2 == 1 {
                    zv[0] += 0.25;
                }
                robot.forward_dynamics_into(
                    &mut ws,
                    &zv[..n],
                    &zv[n..2 * n],
                    &zv[2 * n..],
                    &mut qv,
                );
                let (sn, cs) = ws.trig();
                handed.provide_trig(&zv[..n], sn, cs);
                fresh.jacobian(&robot, &z, &mut a0, &mut j0);
                handed.jacobian(&robot, &z, &mut a1, &mut j1);
                assert_eq!(bits(&a0), bits(&a1), "qdd, pose {it}");
                assert_eq!(bits(&j0), bits(&j1), "Jacobian, pose {it}");
                fresh.hessian_weighted(&robot, &z, &w, &mut h0);
                handed.hessian_weighted(&robot, &z, &w, &mut h1);
                assert_eq!(bits(&h0), bits(&h1), "Hessian, pose {it}");
            }
        }
    }
}
