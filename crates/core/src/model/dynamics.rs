//! Rigid-body dynamics `M(q) qdd + C(q, qd) qd + G(q) = B tau`, generic over the scalar type.
//!
//! State `x = [q, qd]` (2n), input `u = tau` = torques of joints 2..n (n - 1), `B = [0; I]`. Angles as in
//! [`super::kinematics`]. The mass matrix is built in absolute angles, where it has the closed form
//! `M_abs[j][k] = d_jk cos(th_j - th_k)`, and mapped to relative angles by `M = S^T M_abs S` with `S` the
//! lower-triangular matrix of ones (`th = S q`). Units: N m for torques, rad/s^2 for accelerations.

use super::Robot;
use crate::math::{c, Scalar};
use brachia_linalg::{cholesky, cholesky_solve_vec, Scaling};

/// Reusable buffers for the dynamics of one robot and one scalar type (allocated once; no allocation
/// per call).
#[derive(Debug, Clone)]
pub struct Scratch<T> {
    n: usize,
    s: Vec<T>,
    co: Vec<T>,
    thd: Vec<T>,
    mabs: Vec<T>,
    hab: Vec<T>,
    /// Mass matrix (relative angles), row-major n x n; after `forward_dynamics` its lower triangle holds
    /// the Cholesky factor (`brachia_linalg::cholesky`).
    m: Vec<T>,
    h: Vec<T>,
}

impl<T: Scalar> Scratch<T> {
    /// sin and cos of the absolute angles of the last [`Robot::forward_dynamics_into`] with this
    /// scratch (n each).
    pub(crate) fn trig(&self) -> (&[T], &[T]) {
        (&self.s, &self.co)
    }

    /// Buffers for an n-link robot.
    pub fn new(n: usize) -> Self {
        let z = T::zero();
        Scratch {
            n,
            s: vec![z; n],
            co: vec![z; n],
            thd: vec![z; n],
            mabs: vec![z; n * n],
            hab: vec![z; n],
            m: vec![z; n * n],
            h: vec![z; n],
        }
    }
}

impl Robot {
    /// Fill `ws.s`, `ws.co` (sin/cos of absolute angles) and `ws.m` (mass matrix in relative angles).
    fn fill_mass<T: Scalar>(&self, ws: &mut Scratch<T>, q: &[T]) {
        self.fill_mass_n(ws, q, self.n);
    }

    /// The sines and cosines of the absolute angles `th = S q` into `ws.s`, `ws.co` (the first part of
    /// [`Self::fill_mass_n`]; what the gravity forces need).
    #[inline(always)]
    fn fill_trig_n<T: Scalar>(&self, ws: &mut Scratch<T>, q: &[T], n: usize) {
        debug_assert_eq!(ws.n, n, "scratch built for another robot");
        let (q, sn, co) = (&q[..n], &mut ws.s[..n], &mut ws.co[..n]);
        let mut th = T::zero();
        for i in 0..n {
            th += q[i];
            let (sv, cv) = th.sin_cos();
            sn[i] = sv;
            co[i] = cv;
        }
    }

    /// [`Self::fill_mass`] with the link count `n` (= `self.n`) as an argument, so that callers that
    /// pass a constant get a body with constant sizes (unrolled, no bounds checks; same arithmetic).
    #[inline(always)]
    fn fill_mass_n<T: Scalar>(&self, ws: &mut Scratch<T>, q: &[T], n: usize) {
        self.fill_trig_n(ws, q, n);
        let (sn, co) = (&ws.s[..n], &ws.co[..n]);
        let (d, mabs, m) = (&self.d[..n * n], &mut ws.mabs[..n * n], &mut ws.m[..n * n]);
        if self.off_axis {
            self.fill_mass_abs_off_axis(sn, co, mabs, n);
        } else {
            for j in 0..n {
                mabs[j * n + j] = c(d[j * n + j]);
                for k in j + 1..n {
                    let v = (co[j] * co[k] + sn[j] * sn[k]) * d[j * n + k];
                    mabs[j * n + k] = v;
                    mabs[k * n + j] = v;
                }
            }
        }
        // M = S^T Mabs S: suffix sums over columns, then over rows.
        for i in 0..n {
            let mut acc = T::zero();
            for l in (0..n).rev() {
                acc += mabs[i * n + l];
                mabs[i * n + l] = acc;
            }
        }
        for l in 0..n {
            let mut acc = T::zero();
            for r in (0..n).rev() {
                acc += mabs[r * n + l];
                m[r * n + l] = acc;
            }
        }
    }

    /// Fill `ws.h` = C(q, qd) qd + G(q) in relative angles (needs `fill_mass` first for sin/cos).
    fn fill_bias<T: Scalar>(
        &self,
        ws: &mut Scratch<T>,
        qd: &[T],
        with_velocity: bool,
        with_gravity: bool,
    ) {
        self.fill_bias_n(ws, qd, with_velocity, with_gravity, self.n);
    }

    /// [`Self::fill_bias`] with the link count as an argument (see [`Self::fill_mass_n`]).
    #[inline(always)]
    fn fill_bias_n<T: Scalar>(
        &self,
        ws: &mut Scratch<T>,
        qd: &[T],
        with_velocity: bool,
        with_gravity: bool,
        n: usize,
    ) {
        let (qd, sn, co, thd) = (&qd[..n], &ws.s[..n], &ws.co[..n], &mut ws.thd[..n]);
        let (hab, h) = (&mut ws.hab[..n], &mut ws.h[..n]);
        let (d, gcoef) = (&self.d[..n * n], &self.gcoef[..n]);
        let mut acc = T::zero();
        for i in 0..n {
            acc += qd[i];
            thd[i] = acc;
        }
        if self.off_axis {
            self.fill_bias_abs_off_axis(sn, co, thd, hab, with_velocity, with_gravity, n);
        } else {
            for j in 0..n {
                let mut v = T::zero();
                if with_velocity {
                    for k in 0..n {
                        if k != j {
                            // sin(th_j - th_k)
                            let sjk = sn[j] * co[k] - co[j] * sn[k];
                            v += sjk * thd[k] * thd[k] * d[j * n + k];
                        }
                    }
                }
                if with_gravity {
                    v += co[j] * gcoef[j];
                }
                hab[j] = v;
            }
        }
        let mut acc = T::zero();
        for l in (0..n).rev() {
            acc += hab[l];
            h[l] = acc;
        }
    }

    /// `M_abs` of a robot with centres of mass off the links' axes:
    /// `M_abs[j][k] = rho_jk cos(th_j - th_k - beta_jk)` (the arithmetic of
    /// [`super::DynamicsDerivatives`], in the same order).
    #[inline(always)]
    fn fill_mass_abs_off_axis<T: Scalar>(&self, sn: &[T], co: &[T], mabs: &mut [T], n: usize) {
        let (rho, cb, sb) = (&self.rho[..n * n], &self.cb[..n * n], &self.sb[..n * n]);
        for j in 0..n {
            mabs[j * n + j] = c(rho[j * n + j]);
            for k in j + 1..n {
                let c0 = co[j] * co[k] + sn[j] * sn[k];
                let s0 = sn[j] * co[k] - co[j] * sn[k];
                let cr = c0 * cb[j * n + k] + s0 * sb[j * n + k];
                let v = cr * rho[j * n + k];
                mabs[j * n + k] = v;
                mabs[k * n + j] = v;
            }
        }
    }

    /// The bias forces in absolute angles of a robot with centres of mass off the links' axes:
    /// `sum_k rho_jk sin(th_j - th_k - beta_jk) thd_k^2 + gcoef_j cos th_j - gsin_j sin th_j`.
    #[inline(always)]
    fn fill_bias_abs_off_axis<T: Scalar>(
        &self,
        sn: &[T],
        co: &[T],
        thd: &[T],
        hab: &mut [T],
        with_velocity: bool,
        with_gravity: bool,
        n: usize,
    ) {
        let (rho, cb, sb) = (&self.rho[..n * n], &self.cb[..n * n], &self.sb[..n * n]);
        let (gcoef, gsin) = (&self.gcoef[..n], &self.gsin[..n]);
        for j in 0..n {
            let mut v = T::zero();
            if with_velocity {
                for k in 0..n {
                    if k != j {
                        let c0 = co[j] * co[k] + sn[j] * sn[k];
                        let s0 = sn[j] * co[k] - co[j] * sn[k];
                        let sr = s0 * cb[j * n + k] - c0 * sb[j * n + k];
                        v += sr * thd[k] * thd[k] * rho[j * n + k];
                    }
                }
            }
            if with_gravity {
                v += co[j] * gcoef[j];
                v -= sn[j] * gsin[j];
            }
            hab[j] = v;
        }
    }

    /// Mass matrix M(q), row-major n x n.
    pub fn mass_matrix_into<T: Scalar>(&self, ws: &mut Scratch<T>, q: &[T], m: &mut [T]) {
        self.fill_mass(ws, q);
        m[..self.n * self.n].copy_from_slice(&ws.m);
    }

    /// Coriolis and centrifugal forces C(q, qd) qd (n).
    pub fn coriolis_into<T: Scalar>(&self, ws: &mut Scratch<T>, q: &[T], qd: &[T], out: &mut [T]) {
        self.fill_mass(ws, q);
        self.fill_bias(ws, qd, true, false);
        out[..self.n].copy_from_slice(&ws.h);
    }

    /// Gravity forces G(q) = dV/dq (n). Computes the sines and cosines of the angles, not the mass
    /// matrix.
    pub fn gravity_into<T: Scalar>(&self, ws: &mut Scratch<T>, q: &[T], out: &mut [T]) {
        with_link_count!(self.n, |n| {
            self.fill_trig_n(ws, q, n);
            self.fill_bias_n(ws, q, false, true, n);
        });
        out[..self.n].copy_from_slice(&ws.h);
    }

    /// Forward dynamics: `qdd = M^-1 (B tau - C qd - G)`.
    pub fn forward_dynamics_into<T: Scalar>(
        &self,
        ws: &mut Scratch<T>,
        q: &[T],
        qd: &[T],
        tau: &[T],
        qdd: &mut [T],
    ) {
        // the paper's 4 links with constant sizes, any other count through the same body
        with_link_count!(self.n, |n| self.forward_dynamics_n(ws, q, qd, tau, qdd, n));
    }

    /// [`Self::forward_dynamics_into`] with the link count as an argument (see [`Self::fill_mass_n`]).
    #[inline(always)]
    fn forward_dynamics_n<T: Scalar>(
        &self,
        ws: &mut Scratch<T>,
        q: &[T],
        qd: &[T],
        tau: &[T],
        qdd: &mut [T],
        n: usize,
    ) {
        self.fill_mass_n(ws, q, n);
        self.fill_bias_n(ws, qd, true, true, n);
        let (qdd, h, tau) = (&mut qdd[..n], &ws.h[..n], &tau[..n - 1]);
        qdd[0] = -h[0];
        for i in 1..n {
            qdd[i] = tau[i - 1] - h[i];
        }
        // M is positive definite for any valid robot; a failed factorisation (non-finite state)
        // gives NaN accelerations
        if cholesky(&mut ws.m, n, Scaling::Reciprocal).is_ok() {
            cholesky_solve_vec(&ws.m, n, qdd, Scaling::Divide);
        } else {
            qdd.fill(c(f64::NAN));
        }
    }

    /// Inverse dynamics: the generalised forces `M qdd + C qd + G` (n). For a motion the robot can make,
    /// entry 0 (the passive grip joint) is zero and entries 1.. are the torques tau.
    pub fn inverse_dynamics_into<T: Scalar>(
        &self,
        ws: &mut Scratch<T>,
        q: &[T],
        qd: &[T],
        qdd: &[T],
        out: &mut [T],
    ) {
        let n = self.n;
        self.fill_mass(ws, q);
        self.fill_bias(ws, qd, true, true);
        for i in 0..n {
            let mut v = ws.h[i];
            for j in 0..n {
                v += ws.m[i * n + j] * qdd[j];
            }
            out[i] = v;
        }
    }

    /// Kinetic energy `1/2 qd^T M(q) qd`, J.
    pub fn kinetic_energy<T: Scalar>(&self, ws: &mut Scratch<T>, q: &[T], qd: &[T]) -> T {
        let n = self.n;
        self.fill_mass(ws, q);
        let mut e = T::zero();
        for i in 0..n {
            for j in 0..n {
                e += ws.m[i * n + j] * qd[i] * qd[j];
            }
        }
        e * 0.5
    }

    /// Total mechanical energy (kinetic + potential), J.
    pub fn energy(&self, q: &[f64], qd: &[f64]) -> f64 {
        let mut ws = Scratch::new(self.n);
        self.kinetic_energy(&mut ws, q, qd) + self.potential_energy(q)
    }

    /// Forward dynamics in plain f64 (allocates a scratch; use
    /// [`Robot::forward_dynamics_into`] in loops).
    pub fn forward_dynamics(&self, q: &[f64], qd: &[f64], tau: &[f64]) -> Vec<f64> {
        let mut ws = Scratch::new(self.n);
        let mut qdd = vec![0.0; self.n];
        self.forward_dynamics_into(&mut ws, q, qd, tau, &mut qdd);
        qdd
    }

    /// Mass matrix in plain f64, row-major (allocates).
    pub fn mass_matrix(&self, q: &[f64]) -> Vec<f64> {
        let mut ws = Scratch::new(self.n);
        let mut m = vec![0.0; self.n * self.n];
        self.mass_matrix_into(&mut ws, q, &mut m);
        m
    }
}
