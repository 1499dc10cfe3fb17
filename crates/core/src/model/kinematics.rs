//! Forward kinematics of the planar chain, generic over the scalar type.
//!
//! Angles: `q[0]` is the absolute angle of link 1 from the +x axis (counter-clockwise positive);
//! `q[i]` (i >= 1) is the angle of link i+1 relative to link i. The absolute angle of link i is
//! `th_i = q_0 + ... + q_i`. Joint 1 sits at the grip point, the origin of the body frame; joint i+1 is
//! the distal end of link i; the end effector (EE) is the point [`Robot::end_effector`] of link n's
//! frame (by default its distal end). Lengths in m.

use super::Robot;
use crate::math::{c, Scalar};

/// A 2-D point or vector `[x, y]`.
pub type P2<T> = [T; 2];

impl Robot {
    /// Absolute link angles `th` from relative joint angles `q`.
    pub fn absolute_angles<T: Scalar>(&self, q: &[T], th: &mut [T]) {
        let mut acc = T::zero();
        for i in 0..self.n {
            acc += q[i];
            th[i] = acc;
        }
    }

    /// Joint positions: `out[0]` is the grip (origin), `out[i]` the distal end of link i (`out[n]` is
    /// the EE for the ideal chain; see [`Self::ee_position`] in general).
    /// `out` must hold n + 1 points.
    pub fn joint_positions<T: Scalar>(&self, q: &[T], out: &mut [P2<T>]) {
        let mut th = T::zero();
        let mut p = [T::zero(), T::zero()];
        out[0] = p;
        for i in 0..self.n {
            th += q[i];
            let (s, co) = th.sin_cos();
            p = [p[0] + co * self.len[i], p[1] + s * self.len[i]];
            out[i + 1] = p;
        }
    }

    /// The point `[x, y]` of link i's frame that the chain continues from: the distal joint
    /// `[length, 0]`, or the end effector for the last link.
    #[inline(always)]
    fn arm(&self, i: usize) -> [f64; 2] {
        if i + 1 == self.n {
            self.ee
        } else {
            [self.len[i], 0.0]
        }
    }

    /// End-effector position.
    pub fn ee_position<T: Scalar>(&self, q: &[T]) -> P2<T> {
        if !self.ee_default {
            return self.ee_position_general(q);
        }
        let mut th = T::zero();
        let mut p = [T::zero(), T::zero()];
        for i in 0..self.n {
            th += q[i];
            let (s, co) = th.sin_cos();
            p = [p[0] + co * self.len[i], p[1] + s * self.len[i]];
        }
        p
    }

    /// [`Self::ee_position`] with the end effector anywhere in the last link's frame.
    fn ee_position_general<T: Scalar>(&self, q: &[T]) -> P2<T> {
        let mut th = T::zero();
        let mut p = [T::zero(), T::zero()];
        for i in 0..self.n {
            th += q[i];
            let (s, co) = th.sin_cos();
            let [ax, ay] = self.arm(i);
            p = [p[0] + co * ax - s * ay, p[1] + s * ax + co * ay];
        }
        p
    }

    /// End-effector velocity `J(q) qd`.
    pub fn ee_velocity<T: Scalar>(&self, q: &[T], qd: &[T]) -> P2<T> {
        let (mut th, mut thd) = (T::zero(), T::zero());
        let mut v = [T::zero(), T::zero()];
        for i in 0..self.n {
            th += q[i];
            thd += qd[i];
            let (s, co) = th.sin_cos();
            if self.ee_default {
                v = [v[0] - s * thd * self.len[i], v[1] + co * thd * self.len[i]];
            } else {
                let [ax, ay] = self.arm(i);
                // d/dt R(th) a = thd R(th) [-ay, ax]
                let (rx, ry) = (co * ax - s * ay, s * ax + co * ay);
                v = [v[0] - ry * thd, v[1] + rx * thd];
            }
        }
        v
    }

    /// Centre-of-mass positions of the links (`out` holds n points).
    pub fn com_positions<T: Scalar>(&self, q: &[T], out: &mut [P2<T>]) {
        let mut th = T::zero();
        let mut p = [T::zero(), T::zero()];
        for i in 0..self.n {
            th += q[i];
            let (s, co) = th.sin_cos();
            out[i] = if self.off_axis {
                let (cx, cy) = (self.com[i], self.com_across[i]);
                [p[0] + co * cx - s * cy, p[1] + s * cx + co * cy]
            } else {
                [p[0] + co * self.com[i], p[1] + s * self.com[i]]
            };
            p = [p[0] + co * self.len[i], p[1] + s * self.len[i]];
        }
    }

    /// EE Jacobian `J = d ee / d q`, 2 x n, written row-major into `jac` (length 2n).
    pub fn ee_jacobian(&self, q: &[f64], jac: &mut [f64]) {
        let n = self.n;
        let mut th = [0.0; super::MAX_LINKS];
        self.absolute_angles(q, &mut th[..n]);
        let (mut sx, mut sy) = (0.0, 0.0);
        for l in (0..n).rev() {
            let (s, co) = th[l].sin_cos();
            if self.ee_default {
                sx -= self.len[l] * s;
                sy += self.len[l] * co;
            } else {
                let [ax, ay] = self.arm(l);
                sx -= s * ax + co * ay;
                sy += co * ax - s * ay;
            }
            jac[l] = sx;
            jac[n + l] = sy;
        }
    }

    /// `Jdot(q, qd) qd`: the EE acceleration when qdd = 0.
    pub fn ee_jdot_qd<T: Scalar>(&self, q: &[T], qd: &[T]) -> P2<T> {
        let (mut th, mut thd) = (T::zero(), T::zero());
        let mut a = [T::zero(), T::zero()];
        for i in 0..self.n {
            th += q[i];
            thd += qd[i];
            let (s, co) = th.sin_cos();
            if self.ee_default {
                let w2 = thd * thd * self.len[i];
                a = [a[0] - co * w2, a[1] - s * w2];
            } else {
                let [ax, ay] = self.arm(i);
                let w2 = thd * thd;
                a = [
                    a[0] - (co * ax - s * ay) * w2,
                    a[1] - (s * ax + co * ay) * w2,
                ];
            }
        }
        a
    }

    /// Links as segments `(start, end)`: link i runs from joint i to joint i+1 (`out` holds n segments).
    pub fn link_segments<T: Scalar>(&self, q: &[T], out: &mut [(P2<T>, P2<T>)]) {
        let mut th = T::zero();
        let mut p = [T::zero(), T::zero()];
        for i in 0..self.n {
            th += q[i];
            let (s, co) = th.sin_cos();
            let e = [p[0] + co * self.len[i], p[1] + s * self.len[i]];
            out[i] = (p, e);
            p = e;
        }
    }

    /// [`Self::link_segments`] from each joint's `[cos q_i, sin q_i]` (`rot`, n entries), the links'
    /// directions composed by rotation instead of a sine and cosine per link: equal to it up to
    /// rounding, for callers that evaluate many poses on a grid of joint angles, whose cosines and
    /// sines are tabulated once.
    pub fn link_segments_rotated(&self, rot: &[[f64; 2]], out: &mut [(P2<f64>, P2<f64>)]) {
        let (mut co, mut s) = (1.0, 0.0);
        let mut p = [0.0, 0.0];
        for i in 0..self.n {
            let [ci, si] = rot[i];
            (co, s) = (co * ci - s * si, s * ci + co * si);
            let e = [p[0] + co * self.len[i], p[1] + s * self.len[i]];
            out[i] = (p, e);
            p = e;
        }
    }

    /// Potential energy `V(q) = sum_i m_i g y_ci`, J (zero at the height of the grip).
    pub fn potential_energy<T: Scalar>(&self, q: &[T]) -> T {
        let mut th = T::zero();
        let mut v = T::zero();
        for i in 0..self.n {
            th += q[i];
            // gcoef[i] = g (m_i com_i + L_i * distal mass), gsin[i] = g m_i com_across_i
            if self.off_axis {
                let (s, co) = th.sin_cos();
                v += s * c::<T>(self.gcoef[i]) + co * c::<T>(self.gsin[i]);
            } else {
                v += th.sin() * c::<T>(self.gcoef[i]);
            }
        }
        v
    }
}

/// The angle `a` wrapped into (-pi, pi].
pub fn wrap_angle(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let mut v = a % tau;
    if v <= -std::f64::consts::PI {
        v += tau;
    } else if v > std::f64::consts::PI {
        v -= tau;
    }
    v
}

/// The start pose mirrored about the vertical through the grip (absolute angles th -> pi - th).
pub fn mirrored_pose(q0: &[f64]) -> Vec<f64> {
    let n = q0.len();
    let mut th = 0.0;
    let abs: Vec<f64> = q0
        .iter()
        .map(|qi| {
            th += qi;
            std::f64::consts::PI - th
        })
        .collect();
    (0..n)
        .map(|i| wrap_angle(if i == 0 { abs[0] } else { abs[i] - abs[i - 1] }))
        .collect()
}

/// Inverse kinematics by damped least squares with a null-space pull towards `seed`; `None` when it
/// does not reach `target` to 1e-9 m.
pub fn ik_from_seed(robot: &Robot, seed: &[f64], target: [f64; 2]) -> Option<Vec<f64>> {
    let n = robot.n();
    let mut q = seed.to_vec();
    let mut jac = vec![0.0; 2 * n];
    // 300 iterations with a null-space pull towards the seed, then pure Gauss-Newton to polish (the pull
    // leaves a second-order residual).
    for it in 0..400 {
        let pull = if it < 300 { 0.1 } else { 0.0 };
        let ee = robot.ee_position(&q);
        let e = [target[0] - ee[0], target[1] - ee[1]];
        robot.ee_jacobian(&q, &mut jac);
        // A = J J^T + lambda^2 I (2 x 2)
        let lam2 = 1e-6;
        let a00: f64 = (0..n).map(|j| jac[j] * jac[j]).sum::<f64>() + lam2;
        let a01: f64 = (0..n).map(|j| jac[j] * jac[n + j]).sum();
        let a11: f64 = (0..n).map(|j| jac[n + j] * jac[n + j]).sum::<f64>() + lam2;
        let det = a00 * a11 - a01 * a01;
        let solve2 = |b: [f64; 2]| {
            [
                (a11 * b[0] - a01 * b[1]) / det,
                (a00 * b[1] - a01 * b[0]) / det,
            ]
        };
        let y = solve2(e);
        // null-space step towards the seed: (I - J^T A^-1 J) (seed - q)
        let d: Vec<f64> = (0..n).map(|j| seed[j] - q[j]).collect();
        let jd = [
            (0..n).map(|j| jac[j] * d[j]).sum::<f64>(),
            (0..n).map(|j| jac[n + j] * d[j]).sum::<f64>(),
        ];
        let yd = solve2(jd);
        for j in 0..n {
            let task = jac[j] * y[0] + jac[n + j] * y[1];
            let null = d[j] - (jac[j] * yd[0] + jac[n + j] * yd[1]);
            q[j] += task + pull * null;
        }
        if it >= 300 && (e[0] * e[0] + e[1] * e[1]).sqrt() < 1e-12 {
            break;
        }
    }
    let ee = robot.ee_position(&q);
    let err = ((ee[0] - target[0]).powi(2) + (ee[1] - target[1]).powi(2)).sqrt();
    (err < 1e-9 && q.iter().all(|v| v.is_finite())).then_some(q)
}
