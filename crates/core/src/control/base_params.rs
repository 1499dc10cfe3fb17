//! The planar chain's dynamics as a linear function of its base inertial parameters
//! (docs/estimation.md derives them).
//!
//! In absolute angles `th_j = q_1 + ... + q_j` the kinetic and potential energies of the n-link chain
//! are
//!
//! ```text
//! T = 1/2 sum_j sum_k d_jk cos(th_j - th_k) thd_j thd_k,   V = g sum_j MXR_j sin(th_j),
//! d_jj = ZZR_j,   d_jk = d_kj = l_j MXR_k  (j < k),
//! ZZR_j = I_j + m_j c_j^2 + l_j^2 M_j,   MXR_j = m_j c_j + l_j M_j,   M_j = m_{j+1} + ... + m_n,
//! ```
//!
//! with `l_j` the link lengths, `m_j` the masses, `c_j` the centre-of-mass distances and `I_j` the
//! inertias about the centres of mass. The dynamics depend on the 4n physical values only through
//! the 2n **base parameters** `theta = [ZZR_1..ZZR_n, MXR_1..MXR_n]` (kg m^2, then kg m), and linearly:
//! the generalised momentum `p = M(q) qd = Yp(q, qd) theta` and the Lagrangian's gradient
//! `dL/dq = Yl(q, qd) theta`. Integrating Lagrange's equations over a window `[t0, t1]` gives a
//! linear relation without accelerations:
//!
//! ```text
//! (Yp(t1) - Yp(t0) - int Yl dt) theta = int [0, tau_2, ..., tau_n] dt,
//! ```
//!
//! the measurement equation of [`super::ParamEstimator`]. Every `theta` with all entries > 0 maps
//! back to a robot ([`robot_from_base`]); masses and inertias keep the nominal robot's proportions.
//!
//! Units: rad, rad/s, s, N m; matrices row-major, n rows (joints 1..n) by 2n columns.

use crate::error::{Error, Result};
use crate::model::{Robot, MAX_LINKS};

/// The base parameters of `robot`: `[ZZR_1..ZZR_n, MXR_1..MXR_n]` (kg m^2, kg m).
pub fn base_params(robot: &Robot, theta: &mut [f64]) {
    let n = robot.n();
    let (l, m, c, i) = (
        robot.lengths(),
        robot.masses(),
        robot.coms(),
        robot.inertias(),
    );
    let mut distal = 0.0;
    for j in (0..n).rev() {
        theta[j] = i[j] + m[j] * c[j] * c[j] + l[j] * l[j] * distal;
        theta[n + j] = m[j] * c[j] + l[j] * distal;
        distal += m[j];
    }
}

/// Absolute angles and rates of `q`, `qd` into the stack buffers `th`, `thd`.
fn absolute(q: &[f64], qd: &[f64], th: &mut [f64], thd: &mut [f64]) {
    let (mut a, mut ad) = (0.0, 0.0);
    for j in 0..q.len() {
        a += q[j];
        ad += qd[j];
        th[j] = a;
        thd[j] = ad;
    }
}

/// Turn absolute-angle rows into joint rows in place: row j becomes the sum of rows j..n (the
/// generalised force on q_j is the sum of those on th_j..th_n).
fn to_joint_rows(y: &mut [f64], n: usize) {
    let cols = 2 * n;
    for j in (0..n.saturating_sub(1)).rev() {
        for c in 0..cols {
            y[j * cols + c] += y[(j + 1) * cols + c];
        }
    }
}

/// The momentum regressor `Yp(q, qd)` (n x 2n, row-major): `Yp theta = M(q) qd`. Does not allocate.
pub fn momentum_regressor(robot: &Robot, q: &[f64], qd: &[f64], yp: &mut [f64]) {
    let n = robot.n();
    let cols = 2 * n;
    let l = robot.lengths();
    let (mut th, mut thd) = ([0.0; MAX_LINKS], [0.0; MAX_LINKS]);
    absolute(&q[..n], &qd[..n], &mut th, &mut thd);
    yp[..n * cols].fill(0.0);
    for i in 0..n {
        // ZZR_i: p_i += thd_i
        yp[i * cols + i] = thd[i];
        // MXR_k: p_j += l_j cos(th_j - th_k) thd_k (j < k), p_k += sum_j l_j cos(th_j - th_k) thd_j
        let k = i;
        for j in 0..k {
            let cjk = (th[j] - th[k]).cos();
            yp[j * cols + n + k] += l[j] * cjk * thd[k];
            yp[k * cols + n + k] += l[j] * cjk * thd[j];
        }
    }
    to_joint_rows(yp, n);
}

/// The Lagrangian-gradient regressor `Yl(q, qd)` (n x 2n, row-major): `Yl theta = dL/dq` with
/// `L = T - V`. Does not allocate.
pub fn lagrangian_regressor(robot: &Robot, q: &[f64], qd: &[f64], yl: &mut [f64]) {
    let n = robot.n();
    let cols = 2 * n;
    let l = robot.lengths();
    let g = robot.gravity;
    let (mut th, mut thd) = ([0.0; MAX_LINKS], [0.0; MAX_LINKS]);
    absolute(&q[..n], &qd[..n], &mut th, &mut thd);
    yl[..n * cols].fill(0.0);
    for k in 0..n {
        // dT/dth_a of the terms l_j MXR_k cos(th_j - th_k) thd_j thd_k, j < k
        for j in 0..k {
            let s = (th[j] - th[k]).sin() * l[j] * thd[j] * thd[k];
            yl[j * cols + n + k] -= s;
            yl[k * cols + n + k] += s;
        }
        // -dV/dth_k
        yl[k * cols + n + k] -= g * th[k].cos();
    }
    to_joint_rows(yl, n);
}

/// The acceleration regressor `Y(q, qd, qdd)` (n x 2n, row-major): `Y theta` is the inverse
/// dynamics `M qdd + C qd + G` ([`Robot::inverse_dynamics_into`]). Checks and tests use it; the
/// estimator never differentiates measured rates. Does not allocate.
pub fn regressor(robot: &Robot, q: &[f64], qd: &[f64], qdd: &[f64], y: &mut [f64]) {
    let n = robot.n();
    let cols = 2 * n;
    let l = robot.lengths();
    let g = robot.gravity;
    let (mut th, mut thd) = ([0.0; MAX_LINKS], [0.0; MAX_LINKS]);
    let (mut thdd, mut unused) = ([0.0; MAX_LINKS], [0.0; MAX_LINKS]);
    absolute(&q[..n], &qd[..n], &mut th, &mut thd);
    absolute(&q[..n], &qdd[..n], &mut unused, &mut thdd);
    y[..n * cols].fill(0.0);
    for k in 0..n {
        y[k * cols + k] = thdd[k];
        for j in 0..k {
            let (s, c) = (th[j] - th[k]).sin_cos();
            // d/dt of the momentum terms minus dT/dth, in absolute angles
            y[j * cols + n + k] += l[j] * (c * thdd[k] + s * thd[k] * thd[k]);
            y[k * cols + n + k] += l[j] * (c * thdd[j] - s * thd[j] * thd[j]);
        }
        y[k * cols + n + k] += g * th[k].cos();
    }
    to_joint_rows(y, n);
}

/// A robot whose base parameters are `theta` (2n, as [`base_params`]), built from `nominal`: the
/// lengths, centre-of-mass distances, radii, gravity and torque limits are the nominal robot's;
/// from link n down to link 1 the mass is chosen so that `MXR_j` holds with the nominal
/// centre-of-mass distance, and the inertia so that `ZZR_j` holds. Errors when `theta` has no such
/// robot (a mass or an inertia not > 0), naming the entry.
pub fn robot_from_base(nominal: &Robot, theta: &[f64]) -> Result<Robot> {
    let n = nominal.n();
    let mut p = nominal.params().clone();
    let l = nominal.lengths();
    let mut distal = 0.0;
    for j in (0..n).rev() {
        let c = nominal.coms()[j];
        let mx = theta[n + j] - l[j] * distal;
        let m = if c > 0.0 { mx / c } else { nominal.masses()[j] };
        let inertia = theta[j] - l[j] * l[j] * distal - m * c * c;
        if !(m.is_finite() && m > 0.0) {
            return Err(Error::invalid(
                "estimated robot",
                format!("MXR_{}", j + 1),
                theta[n + j],
                format!("leaves link {} a mass of {m} kg (must be > 0)", j + 1),
            ));
        }
        if !(inertia.is_finite() && inertia > 0.0) {
            return Err(Error::invalid(
                "estimated robot",
                format!("ZZR_{}", j + 1),
                theta[j],
                format!(
                    "leaves link {} an inertia of {inertia} kg m^2 (must be > 0)",
                    j + 1
                ),
            ));
        }
        p.links[j].mass = m;
        p.links[j].inertia = inertia;
        distal += m;
    }
    Robot::from_params(p, "estimated robot")
}

/// Check that `robot` may stand in for `current` as a controller's model: the same link count,
/// lengths, centre-of-mass distances, gravity and torque limits (only masses and inertias differ).
pub fn check_model(current: &Robot, robot: &Robot) -> Result<()> {
    let same = |a: &[f64], b: &[f64]| a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x == y);
    if current.n() != robot.n()
        || !same(current.lengths(), robot.lengths())
        || !same(current.coms(), robot.coms())
        || current.gravity != robot.gravity
        || !same(&current.tau_min, &robot.tau_min)
        || !same(&current.tau_max, &robot.tau_max)
    {
        return Err(Error::invalid(
            "controller",
            "model",
            robot.params().name.clone(),
            "a model update may change masses and inertias only (same links, lengths, \
             centres of mass, gravity and torque limits)",
        ));
    }
    Ok(())
}

/// Set the mass-matrix and gravity coefficients of `robot` (centres of mass on the links' axes) to
/// those of the base parameters `theta` (2n), in place and without allocating:
/// `d_jj = ZZR_j`, `d_jk = d_kj = l_j MXR_k` (j < k), `gcoef_j = g MXR_j`. The dynamics
/// ([`Robot::forward_dynamics_into`], [`crate::model::DynamicsDerivatives`]) then are those of
/// `theta`; the robot's masses and inertias (which the dynamics do not read) are left as they were,
/// so the robot serves only as the joint filter's model and is never handed out.
pub(crate) fn set_base_params(robot: &mut Robot, theta: &[f64]) {
    debug_assert!(
        !robot.off_axis,
        "base parameters need centres of mass on the axes"
    );
    let n = robot.n;
    for j in 0..n {
        robot.d[j * n + j] = theta[j];
        robot.rho[j * n + j] = theta[j];
        for k in j + 1..n {
            let v = robot.len[j] * theta[n + k];
            robot.d[j * n + k] = v;
            robot.d[k * n + j] = v;
            robot.rho[j * n + k] = v;
            robot.rho[k * n + j] = v;
        }
        robot.gcoef[j] = robot.gravity * theta[n + j];
    }
}
