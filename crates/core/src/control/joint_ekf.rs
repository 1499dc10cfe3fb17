//! Joint estimation of the state and the base inertial parameters: an extended Kalman filter on
//! `z = [q (n), qd (n), theta (2n)]` (docs/estimation.md, "The joint filter").
//!
//! Model: `qdot = qd`, `qddot = f(q, qd, tau; theta)` (the robot's forward dynamics with the base
//! parameters `theta = [ZZR_1..ZZR_n, MXR_1..MXR_n]`, [`super::base_params`]), `thetadot = 0`; the
//! torque held over each control period is known. The mean is propagated by one RK4 step per period;
//! the covariance by `F = I + h G + h^2/2 G^2` with `G` the exact Jacobian of the continuous model:
//! `df/d[q, qd]` analytic ([`crate::model::DynamicsDerivatives`] of the robot with `theta`), and,
//! since the dynamics are linear in `theta` (`M(q; theta) qdd + h(q, qd; theta) = Y(q, qd, qdd)
//! theta`), `df/dtheta = -M(q; theta)^-1 Y(q, qd, f)`. Process noise on qd only (white-noise density
//! `process_qd_std`); measurement `y = [q, qd] + v` with standard deviations `meas_q_std`,
//! `meas_qd_std`.
//!
//! A measurement with a component beyond `outlier_sigma` of its predicted standard deviation (an
//! impact: a ball, a push) updates nothing: the state restarts at the measurement, its correlation
//! with the parameters is dropped and the parameters keep their estimate and covariance.
//!
//! Units: s, rad, rad/s, N m; `theta` in kg m^2 (ZZR) and kg m (MXR). Allocates in
//! [`JointEkf::new`] only.

use super::base_params::{regressor, set_base_params};
use crate::error::{Error, Result};
use crate::model::{DynamicsDerivatives, Robot, Scratch};
use brachia_linalg::{cholesky, cholesky_solve_vec, Scaling};

/// The parameters are kept within this factor of the prior (either way): a projection that keeps
/// the model's mass matrix positive definite while the first samples, with little excitation, move a
/// loose prior far.
pub const PARAM_BOX: f64 = 2.0;

/// Time constant of the filter's running mean of the normalised innovation squared, s
/// ([`JointEkf::nis_mean`]).
pub const NIS_WINDOW_S: f64 = 0.2;

/// Noise model of [`JointEkf`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct JointEkfNoise {
    /// Standard deviation of the measurement noise on q, rad.
    pub meas_q_std: f64,
    /// Standard deviation of the measurement noise on qd, rad/s.
    pub meas_qd_std: f64,
    /// Process noise density on qd, rad/(s sqrt(s)).
    pub process_qd_std: f64,
    /// Normalised innovation beyond which a measurement is rejected.
    pub outlier_sigma: f64,
}

/// What one [`JointEkf::observe`] did.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EkfStep {
    /// The first measurement (or the first after a break): the state starts at it.
    Started,
    /// Predicted and updated: the parameters moved.
    Updated,
    /// Rejected as an outlier: the state restarted at the measurement.
    Rejected,
}

/// The joint state and parameter filter; see the module docs.
#[derive(Debug, Clone)]
pub struct JointEkf {
    /// The nominal robot whose dynamics coefficients are set to the estimate before each use.
    model: Robot,
    dd: DynamicsDerivatives,
    ws: Scratch<f64>,
    noise: JointEkfNoise,
    /// `[q, qd, theta]`.
    z: Vec<f64>,
    /// Covariance, nz x nz row-major.
    p: Vec<f64>,
    /// The last good `z`, `p` (restored when a step produces non-finite values).
    z_good: Vec<f64>,
    p_good: Vec<f64>,
    t_prev: Option<f64>,
    /// Normalised innovation squared of the last measurement update (NaN when none or rejected).
    nis: f64,
    /// Running mean of `nis` over the last [`NIS_WINDOW_S`] (NaN: no update yet) and the time of
    /// its last sample.
    nis_mean: f64,
    nis_t: f64,
    /// The box the parameters are kept in: [prior / PARAM_BOX, prior * PARAM_BOX].
    lo: Vec<f64>,
    hi: Vec<f64>,
    // scratch
    zin: Vec<f64>,
    qdd: Vec<f64>,
    jac: Vec<f64>,
    y: Vec<f64>,
    m: Vec<f64>,
    g: Vec<f64>,
    f: Vec<f64>,
    tmp: Vec<f64>,
    s: Vec<f64>,
    kt: Vec<f64>,
    k1: Vec<f64>,
    k2: Vec<f64>,
    k3: Vec<f64>,
    k4: Vec<f64>,
    xs: Vec<f64>,
}

impl JointEkf {
    /// A filter for `nominal` (centres of mass on the links' axes) with the prior `theta0` and its
    /// standard deviations `theta_std` (2n each). Errors on an off-axis robot or a noise value
    /// that is not finite and > 0.
    pub fn new(
        nominal: &Robot,
        theta0: &[f64],
        theta_std: &[f64],
        noise: JointEkfNoise,
    ) -> Result<Self> {
        if nominal.off_axis {
            return Err(Error::invalid(
                "estimate_params",
                "method",
                "ekf",
                "the joint filter needs every centre of mass on its link's axis (com_across = 0)",
            ));
        }
        for (field, v) in [
            ("meas_q_std", noise.meas_q_std),
            ("meas_qd_std", noise.meas_qd_std),
            ("process_qd_std", noise.process_qd_std),
            ("outlier_sigma", noise.outlier_sigma),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(Error::invalid(
                    "estimate_params",
                    field,
                    v,
                    "must be finite and > 0",
                ));
            }
        }
        let n = nominal.n;
        let (nx, nz) = (2 * n, 4 * n);
        let mut ekf = JointEkf {
            model: nominal.clone(),
            dd: DynamicsDerivatives::new(nominal),
            ws: Scratch::new(n),
            noise,
            z: vec![0.0; nz],
            p: vec![0.0; nz * nz],
            z_good: vec![0.0; nz],
            p_good: vec![0.0; nz * nz],
            t_prev: None,
            nis: f64::NAN,
            nis_mean: f64::NAN,
            nis_t: 0.0,
            lo: vec![0.0; 2 * n],
            hi: vec![0.0; 2 * n],
            zin: vec![0.0; 3 * n - 1],
            qdd: vec![0.0; n],
            jac: vec![0.0; n * (3 * n - 1)],
            y: vec![0.0; n * nx],
            m: vec![0.0; n * n],
            g: vec![0.0; n * nz],
            f: vec![0.0; nz * nz],
            tmp: vec![0.0; nz * nz],
            s: vec![0.0; nx * nx],
            kt: vec![0.0; nx * nz],
            k1: vec![0.0; nx],
            k2: vec![0.0; nx],
            k3: vec![0.0; nx],
            k4: vec![0.0; nx],
            xs: vec![0.0; nx],
        };
        ekf.reset(theta0, theta_std);
        Ok(ekf)
    }

    /// Start over from the prior `theta0`, `theta_std` (no innovation recorded); the next
    /// measurement starts the state.
    pub fn reset(&mut self, theta0: &[f64], theta_std: &[f64]) {
        let n = self.model.n;
        let nz = 4 * n;
        self.z[2 * n..].copy_from_slice(theta0);
        for i in 0..2 * n {
            let (a, b) = (theta0[i] / PARAM_BOX, theta0[i] * PARAM_BOX);
            (self.lo[i], self.hi[i]) = (a.min(b), a.max(b));
        }
        self.p.fill(0.0);
        for i in 0..2 * n {
            let s = theta_std[i];
            self.p[(2 * n + i) * nz + 2 * n + i] = s * s;
        }
        self.t_prev = None;
        self.nis_mean = f64::NAN;
    }

    /// The parameter estimate `[ZZR_1..ZZR_n, MXR_1..MXR_n]`.
    pub fn theta(&self) -> &[f64] {
        &self.z[2 * self.model.n..]
    }

    /// The state estimate `[q, qd]`.
    pub fn state(&self) -> &[f64] {
        &self.z[..2 * self.model.n]
    }

    /// Standard deviation of parameter `i`.
    pub fn theta_std(&self, i: usize) -> f64 {
        let n = self.model.n;
        let (nz, k) = (4 * n, 2 * n + i);
        self.p[k * nz + k].max(0.0).sqrt()
    }

    /// The parameters' covariance (2n x 2n row-major) into `out`.
    pub fn param_cov_into(&self, out: &mut [f64]) {
        let n = self.model.n;
        let (nx, nz, np) = (2 * n, 4 * n, 2 * n);
        for i in 0..np {
            out[i * np..(i + 1) * np]
                .copy_from_slice(&self.p[(nx + i) * nz + nx..(nx + i) * nz + nz]);
        }
    }

    /// The normalised innovation squared `e^T S^-1 e` of the last measurement update (2n degrees
    /// of freedom when the filter is consistent); NaN when the last measurement started the state
    /// or was rejected.
    pub fn last_nis(&self) -> f64 {
        self.nis
    }

    /// The running mean of [`Self::last_nis`] over the last [`NIS_WINDOW_S`] of updates (each
    /// update moves it toward its value by the fraction of the window elapsed since the last one);
    /// NaN before the first update.
    pub fn nis_mean(&self) -> f64 {
        self.nis_mean
    }

    /// Forget the state (the next measurement starts it again); the parameters keep their estimate
    /// and covariance.
    pub fn break_state(&mut self) {
        self.t_prev = None;
    }

    /// The continuous model at `z` with the torque `tau` (n - 1): `qdd` (n) and, when `jacobian`,
    /// `g` (n x 4n: `d qdd / d [q, qd, theta]`). Sets the model's coefficients to `z`'s `theta`.
    fn dynamics(&mut self, jacobian: bool, tau: &[f64]) {
        let n = self.model.n;
        let (nx, nz, nin) = (2 * n, 4 * n, 3 * n - 1);
        set_base_params(&mut self.model, &self.z[nx..]);
        self.zin[..nx].copy_from_slice(&self.z[..nx]);
        self.zin[nx..].copy_from_slice(&tau[..n - 1]);
        if !jacobian {
            self.dd.qdd(&self.model, &self.zin, &mut self.qdd);
            return;
        }
        self.dd
            .jacobian(&self.model, &self.zin, &mut self.qdd, &mut self.jac);
        // d qdd / d theta = -M^-1 Y(q, qd, qdd)
        let (q, qd) = (&self.z[..n], &self.z[n..nx]);
        regressor(&self.model, q, qd, &self.qdd, &mut self.y);
        self.model.mass_matrix_into(&mut self.ws, q, &mut self.m);
        let ok = cholesky(&mut self.m, n, Scaling::Reciprocal).is_ok();
        for i in 0..n {
            self.g[i * nz..i * nz + nx].copy_from_slice(&self.jac[i * nin..i * nin + nx]);
        }
        let mut col = [0.0; crate::model::MAX_LINKS];
        for c in 0..nx {
            for i in 0..n {
                col[i] = self.y[i * nx + c];
            }
            if ok {
                cholesky_solve_vec(&self.m, n, &mut col[..n], Scaling::Divide);
            } else {
                col[..n].fill(f64::NAN);
            }
            for i in 0..n {
                self.g[i * nz + nx + c] = -col[i];
            }
        }
    }

    /// `qdd` at `[q, qd] = x` with the current `theta` into `out`.
    fn accel_at(&mut self, x: &[f64], tau: &[f64], out: &mut [f64]) {
        let n = self.model.n;
        let nx = 2 * n;
        self.zin[..nx].copy_from_slice(&x[..nx]);
        self.zin[nx..].copy_from_slice(&tau[..n - 1]);
        self.dd.qdd(&self.model, &self.zin, &mut self.qdd);
        out[..n].copy_from_slice(&x[n..nx]);
        out[n..nx].copy_from_slice(&self.qdd);
    }

    /// One RK4 step of `[q, qd]` over `h` with the torque `tau` (the model's coefficients set).
    fn propagate_mean(&mut self, h: f64, tau: &[f64]) {
        let nx = 2 * self.model.n;
        let x0: [f64; 2 * crate::model::MAX_LINKS] = {
            let mut a = [0.0; 2 * crate::model::MAX_LINKS];
            a[..nx].copy_from_slice(&self.z[..nx]);
            a
        };
        let mut k = std::mem::take(&mut self.k1);
        self.accel_at(&x0[..nx], tau, &mut k);
        self.k1 = k;
        for i in 0..nx {
            self.xs[i] = x0[i] + 0.5 * h * self.k1[i];
        }
        let (xs, mut k) = (std::mem::take(&mut self.xs), std::mem::take(&mut self.k2));
        self.accel_at(&xs, tau, &mut k);
        self.k2 = k;
        let mut xs = xs;
        for i in 0..nx {
            xs[i] = x0[i] + 0.5 * h * self.k2[i];
        }
        let mut k = std::mem::take(&mut self.k3);
        self.accel_at(&xs, tau, &mut k);
        self.k3 = k;
        for i in 0..nx {
            xs[i] = x0[i] + h * self.k3[i];
        }
        let mut k = std::mem::take(&mut self.k4);
        self.accel_at(&xs, tau, &mut k);
        self.k4 = k;
        self.xs = xs;
        for i in 0..nx {
            self.z[i] =
                x0[i] + h / 6.0 * (self.k1[i] + 2.0 * self.k2[i] + 2.0 * self.k3[i] + self.k4[i]);
        }
    }

    /// `P <- F P F^T + Q` with `F = I + h G + h^2/2 G^2` (G from [`Self::dynamics`]).
    fn propagate_cov(&mut self, h: f64) {
        let n = self.model.n;
        let (nx, nz) = (2 * n, 4 * n);
        // F: rows of q: [I + h^2/2 Jq, h I + h^2/2 Jqd, h^2/2 Jth]; rows of qd: [h Jq + h^2/2 Jqd Jq,
        // I + h Jqd + h^2/2 (Jq + Jqd Jqd), h Jth + h^2/2 Jqd Jth]; rows of theta: I.
        let h2 = 0.5 * h * h;
        self.f.fill(0.0);
        for i in 0..nz {
            self.f[i * nz + i] = 1.0;
        }
        for i in 0..n {
            for c in 0..nz {
                let gi = self.g[i * nz + c];
                self.f[i * nz + c] += h2 * gi;
                // Jqd G (row i): sum_k Jqd[i][k] G[k][c]
                let mut jg = 0.0;
                for k in 0..n {
                    jg += self.g[i * nz + n + k] * self.g[k * nz + c];
                }
                self.f[(n + i) * nz + c] += h * gi + h2 * jg;
            }
            self.f[i * nz + n + i] += h;
            // G^2 rows of qd also take Jq (from qdot = qd)
            for k in 0..n {
                self.f[(n + i) * nz + n + k] += h2 * self.g[i * nz + k];
            }
        }
        // tmp = F P
        for i in 0..nz {
            for c in 0..nz {
                let mut v = 0.0;
                for k in 0..nz {
                    v += self.f[i * nz + k] * self.p[k * nz + c];
                }
                self.tmp[i * nz + c] = v;
            }
        }
        // P = tmp F^T
        for i in 0..nz {
            for c in i..nz {
                let mut v = 0.0;
                for k in 0..nz {
                    v += self.tmp[i * nz + k] * self.f[c * nz + k];
                }
                self.p[i * nz + c] = v;
                self.p[c * nz + i] = v;
            }
        }
        let sqd = self.noise.process_qd_std;
        for i in n..nx {
            self.p[i * nz + i] += sqd * sqd * h;
        }
    }

    /// Measurement variance of state component `i`.
    fn r(&self, i: usize) -> f64 {
        let s = if i < self.model.n {
            self.noise.meas_q_std
        } else {
            self.noise.meas_qd_std
        };
        s * s
    }

    /// Restart the state at the measurement `x`: its covariance the measurement's, no correlation
    /// with the parameters.
    fn restart_state(&mut self, x: &[f64]) {
        let nx = 2 * self.model.n;
        let nz = 2 * nx;
        self.z[..nx].copy_from_slice(&x[..nx]);
        for i in 0..nx {
            for c in 0..nz {
                self.p[i * nz + c] = 0.0;
                self.p[c * nz + i] = 0.0;
            }
            self.p[i * nz + i] = self.r(i);
        }
    }

    /// Measurement update with `x`; false when rejected as an outlier (nothing updated).
    fn update(&mut self, x: &[f64]) -> bool {
        let nx = 2 * self.model.n;
        let nz = 2 * nx;
        for i in 0..nx {
            for c in 0..nx {
                self.s[i * nx + c] = self.p[i * nz + c];
            }
            self.s[i * nx + i] += self.r(i);
        }
        let mut e = [0.0; 2 * crate::model::MAX_LINKS];
        self.nis = f64::NAN;
        for i in 0..nx {
            e[i] = x[i] - self.z[i];
            if e[i].abs() > self.noise.outlier_sigma * self.s[i * nx + i].sqrt() {
                return false;
            }
        }
        if cholesky(&mut self.s, nx, Scaling::Reciprocal).is_err() {
            return false;
        }
        let mut col = [0.0; 2 * crate::model::MAX_LINKS];
        col[..nx].copy_from_slice(&e[..nx]);
        cholesky_solve_vec(&self.s, nx, &mut col[..nx], Scaling::Divide);
        self.nis = (0..nx).map(|i| e[i] * col[i]).sum();
        // kt = S^-1 P[x, :] (nx x nz): K = kt^T
        for c in 0..nz {
            for i in 0..nx {
                col[i] = self.p[i * nz + c];
            }
            cholesky_solve_vec(&self.s, nx, &mut col[..nx], Scaling::Divide);
            for i in 0..nx {
                self.kt[i * nz + c] = col[i];
            }
        }
        for c in 0..nz {
            let mut v = 0.0;
            for i in 0..nx {
                v += self.kt[i * nz + c] * e[i];
            }
            self.z[c] += v;
        }
        for i in 0..nx {
            self.z[nx + i] = self.z[nx + i].clamp(self.lo[i], self.hi[i]);
        }
        // P -= K P[x, :] (symmetric)
        for i in 0..nz {
            for c in i..nz {
                let mut v = 0.0;
                for k in 0..nx {
                    v += self.kt[k * nz + i] * self.p[k * nz + c];
                }
                self.tmp[i * nz + c] = v;
            }
        }
        for i in 0..nz {
            for c in i..nz {
                let v = self.p[i * nz + c] - self.tmp[i * nz + c];
                self.p[i * nz + c] = v;
                self.p[c * nz + i] = v;
            }
        }
        true
    }

    /// Take the measured state `x` (2n) at `t`, with `tau` (n - 1) the torque held since the previous
    /// call: predict over the elapsed time, then update. A step that yields non-finite values is
    /// undone and the state restarts at the measurement.
    pub fn observe(&mut self, t: f64, x: &[f64], tau: &[f64]) -> EkfStep {
        let nx = 2 * self.model.n;
        let Some(t_prev) = self.t_prev.filter(|&tp| t > tp) else {
            self.restart_state(x);
            self.t_prev = Some(t);
            self.nis = f64::NAN;
            return EkfStep::Started;
        };
        self.t_prev = Some(t);
        self.z_good.copy_from_slice(&self.z);
        self.p_good.copy_from_slice(&self.p);
        let h = t - t_prev;
        self.dynamics(true, tau);
        self.propagate_cov(h);
        self.propagate_mean(h, tau);
        let updated = self.update(x);
        if !(self.z.iter().all(|v| v.is_finite()) && self.p.iter().all(|v| v.is_finite())) {
            self.z.copy_from_slice(&self.z_good);
            self.p.copy_from_slice(&self.p_good);
            self.restart_state(x);
            return EkfStep::Rejected;
        }
        if updated {
            if self.nis.is_finite() {
                self.nis_mean = if self.nis_mean.is_finite() {
                    let a = ((t - self.nis_t) / NIS_WINDOW_S).clamp(0.0, 1.0);
                    self.nis_mean + a * (self.nis - self.nis_mean)
                } else {
                    self.nis
                };
                self.nis_t = t;
            }
            EkfStep::Updated
        } else {
            // the parameters and their covariance as before the step; the state at the measurement
            self.z[nx..].copy_from_slice(&self.z_good[nx..]);
            let nz = 2 * nx;
            for i in nx..nz {
                for c in nx..nz {
                    self.p[i * nz + c] = self.p_good[i * nz + c];
                }
            }
            self.restart_state(x);
            EkfStep::Rejected
        }
    }

    /// The continuous model's `qdd` at `[q, qd, theta] = z` (4n) with the torque `tau` and, in
    /// `jac` (n x 4n row-major), its exact Jacobian (derivative checks). Replaces the estimate with
    /// `z`.
    pub fn model_jacobian(&mut self, z: &[f64], tau: &[f64], qdd: &mut [f64], jac: &mut [f64]) {
        let n = self.model.n;
        self.z.copy_from_slice(z);
        self.dynamics(true, tau);
        qdd[..n].copy_from_slice(&self.qdd);
        jac[..self.g.len()].copy_from_slice(&self.g);
    }

    /// The continuous model's `qdd` at `z` (4n) with the torque `tau` (derivative checks). Replaces
    /// the estimate with `z`.
    pub fn model_qdd(&mut self, z: &[f64], tau: &[f64], qdd: &mut [f64]) {
        let n = self.model.n;
        self.z.copy_from_slice(z);
        self.dynamics(false, tau);
        qdd[..n].copy_from_slice(&self.qdd);
    }
}

#[cfg(test)]
mod tests {
    use super::{EkfStep, JointEkf, JointEkfNoise, NIS_WINDOW_S};
    use crate::control::base_params::base_params;
    use crate::integrate::Rk4;
    use crate::model::Robot;

    /// The running mean of the normalised innovation squared: NaN until the first update, that
    /// update's value, then each update moves it toward its own value by the fraction of
    /// `NIS_WINDOW_S` elapsed since the last one; a measurement that starts the state or is rejected
    /// leaves it, and a reset forgets it.
    #[test]
    fn the_nis_mean_follows_the_updates_over_its_window() {
        let robot = Robot::paper();
        let n = robot.n;
        let mut theta = vec![0.0; 2 * n];
        base_params(&robot, &mut theta);
        let std: Vec<f64> = theta.iter().map(|v| 0.1 * v.abs()).collect();
        let noise = JointEkfNoise {
            meas_q_std: 0.0015,
            meas_qd_std: 0.015,
            process_qd_std: 0.05,
            outlier_sigma: 5.0,
        };
        let mut ekf = JointEkf::new(&robot, &theta, &std, noise).unwrap();
        assert!(ekf.nis_mean().is_nan());
        // the robot swinging freely from the paper's start pose, measured every 2 ms with a
        // deterministic wobble of about the modelled noise, and one measurement 1 rad off
        let mut rk4 = Rk4::new(&robot);
        let mut x = vec![-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0];
        let (tau, h) = ([0.0; 3], 2e-3);
        let (mut expect, mut t_last, mut updates, mut others) = (f64::NAN, 0.0, 0, 0);
        for k in 0..150 {
            let t = h * k as f64;
            let mut meas = x.clone();
            for (i, m) in meas.iter_mut().enumerate() {
                let s = if i < n { 0.0015 } else { 0.015 };
                *m += s * (1.7 * k as f64 + i as f64).sin();
            }
            if k == 100 {
                meas[0] += 1.0;
            }
            let before = ekf.nis_mean();
            match ekf.observe(t, &meas, &tau) {
                EkfStep::Updated => {
                    let nis = ekf.last_nis();
                    expect = if expect.is_finite() {
                        let a = ((t - t_last) / NIS_WINDOW_S).clamp(0.0, 1.0);
                        expect + a * (nis - expect)
                    } else {
                        nis
                    };
                    t_last = t;
                    updates += 1;
                    assert_eq!(ekf.nis_mean().to_bits(), expect.to_bits(), "step {k}");
                }
                _ => {
                    others += 1;
                    assert_eq!(ekf.nis_mean().to_bits(), before.to_bits(), "step {k}");
                }
            }
            rk4.step(&robot, &mut x, &tau, h);
        }
        // the first measurement starts the state, the one 1 rad off is rejected
        assert!(
            updates > 100 && others >= 2,
            "{updates} updates, {others} others"
        );
        ekf.reset(&theta, &std);
        assert!(ekf.nis_mean().is_nan());
    }
}
