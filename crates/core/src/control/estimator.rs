//! A Kalman filter on the model linearised along the plan, wrapped around any [`Controller`]: the
//! controller sees the filtered state instead of the raw measurement, predicted over a known
//! measurement and actuation delay.
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative),
//! input `u = tau` = torques of joints 2..n (N m), time in s, one call per control period `dt`.
//!
//! Model (the plan as prior, the applied torque as input): over one control period from time s,
//! `x_{+} = x^d(s + dt) + Ad(s) (x - x^d(s)) + Bd(s) (u - u^d(s)) + w`, with `A, B` the exact
//! Jacobians at the plan point `(x^d(s), u^d(s))` ([`crate::model::Linearizer`]) and
//! `Ad = I + dt A + dt^2/2 A^2`, `Bd = dt B + dt^2/2 A B` (second-order hold, error O(dt^3)).
//! Process noise `w ~ N(0, diag(sq^2, sqd^2) dt)` (white-noise densities `process_q_std`,
//! `process_qd_std`); measurement `y = x + v`, `v ~ N(0, diag(rq^2, rqd^2))`. The update is the
//! time-varying Kalman filter with the Joseph form of the covariance.
//!
//! Delays (whole control periods, rounded): a measurement taken at t describes the state at
//! `t - measurement_delay_s`; a torque sent at t acts from `t + actuation_delay_s`. The filter runs at
//! the measured time with the torques that acted then (from the history of torques sent), then the
//! estimate is predicted with the same model to `t + actuation_delay_s` using the torques already sent,
//! and the wrapped controller is asked for the torque at that time. Before the first call the plant is
//! assumed to have received the plan's torques.

use super::{ControlInfo, Controller};
use crate::error::{Error, Result};
use crate::model::{LinearModel, Linearizer, Robot, MAX_LINKS};
use crate::trajectory::Trajectory;
use brachia_linalg::{cholesky, cholesky_solve_vec, Scaling};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Largest total delay (measurement + actuation) the estimator predicts over, s.
pub const MAX_DELAY_S: f64 = 0.5;

/// Noise model and delays of [`Estimated`] (defaults in `docs/mpc.md`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct EstimatorSettings {
    /// Standard deviation of the measurement noise on q, rad (> 0). Default 0.005.
    pub meas_q_std: f64,
    /// Standard deviation of the measurement noise on qd, rad/s (> 0). Default 0.05.
    pub meas_qd_std: f64,
    /// Process noise density on q, rad/sqrt(s) (> 0): model error the filter allows per second.
    /// Default 0.002.
    pub process_q_std: f64,
    /// Process noise density on qd, rad/(s sqrt(s)) (> 0). Default 0.2.
    pub process_qd_std: f64,
    /// Initial standard deviation on q, rad (> 0). Default 0.05.
    pub initial_q_std: f64,
    /// Initial standard deviation on qd, rad/s (> 0). Default 0.5.
    pub initial_qd_std: f64,
    /// Known measurement delay, s (>= 0; rounded to whole control periods). Default 0.
    pub measurement_delay_s: f64,
    /// Known actuation delay, s (>= 0; rounded to whole control periods). Default 0.
    pub actuation_delay_s: f64,
}

impl Default for EstimatorSettings {
    fn default() -> Self {
        EstimatorSettings {
            meas_q_std: 0.005,
            meas_qd_std: 0.05,
            process_q_std: 0.002,
            process_qd_std: 0.2,
            initial_q_std: 0.05,
            initial_qd_std: 0.5,
            measurement_delay_s: 0.0,
            actuation_delay_s: 0.0,
        }
    }
}

impl EstimatorSettings {
    /// Check the values. Errors name the field as written in a scenario's `[tracking.estimator]`.
    pub fn validate(&self) -> Result<()> {
        let src = "EstimatorSettings";
        for (name, v) in [
            ("meas_q_std", self.meas_q_std),
            ("meas_qd_std", self.meas_qd_std),
            ("process_q_std", self.process_q_std),
            ("process_qd_std", self.process_qd_std),
            ("initial_q_std", self.initial_q_std),
            ("initial_qd_std", self.initial_qd_std),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 1e3) {
                return Err(Error::invalid(
                    src,
                    name,
                    v,
                    "must be finite, > 0 and <= 1e3",
                ));
            }
        }
        for (name, v) in [
            ("measurement_delay_s", self.measurement_delay_s),
            ("actuation_delay_s", self.actuation_delay_s),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(src, name, v, "must be finite and >= 0"));
            }
        }
        let total = self.measurement_delay_s + self.actuation_delay_s;
        if total > MAX_DELAY_S {
            // name the delay that takes the larger share of the sum
            let (name, v) = if self.measurement_delay_s > self.actuation_delay_s {
                ("measurement_delay_s", self.measurement_delay_s)
            } else {
                ("actuation_delay_s", self.actuation_delay_s)
            };
            return Err(Error::invalid(
                src,
                name,
                v,
                format!(
                    "measurement_delay_s + actuation_delay_s = {total} s; at most {MAX_DELAY_S} s \
                     (brachia::control::estimator::MAX_DELAY_S)"
                ),
            ));
        }
        Ok(())
    }
}

/// A controller fed by a Kalman filter along the plan (see the module docs). Owns the wrapped
/// controller, shared handles to the robot and the plan, and buffers allocated once in
/// [`Estimated::new`]: a control call does not allocate.
#[derive(Debug, Clone)]
pub struct Estimated<C> {
    inner: C,
    robot: Arc<Robot>,
    reference: Arc<Trajectory>,
    settings: EstimatorSettings,
    dt: f64,
    /// Delays in control periods.
    dm: usize,
    da: usize,
    lin: Linearizer,
    lm: LinearModel,
    ad: Vec<f64>,
    bd: Vec<f64>,
    a2: Vec<f64>,
    /// Filtered state at the measured time.
    xhat: Vec<f64>,
    /// Prediction to the actuation time (what the inner controller sees).
    xpred: Vec<f64>,
    p: Vec<f64>,
    tmp: Vec<f64>,
    kt: Vec<f64>,
    s: Vec<f64>,
    xd: Vec<f64>,
    xd1: Vec<f64>,
    xbuf: Vec<f64>,
    /// Torques sent: ring of `len` entries, entry `i % len` for the call of step index i.
    hist: Vec<f64>,
    hist_len: usize,
    /// Step index of the last call (None before the first call) and its time.
    last_step: Option<i64>,
    t0: f64,
    /// Step index at which `xhat` is valid.
    xhat_step: i64,
}

impl<C: Controller> Estimated<C> {
    /// Wrap `inner`, filtering measurements along `reference` for `robot`; calls come every
    /// `control_dt` seconds.
    pub fn new(
        inner: C,
        robot: impl Into<Arc<Robot>>,
        reference: impl Into<Arc<Trajectory>>,
        settings: EstimatorSettings,
        control_dt: f64,
    ) -> Result<Self> {
        let (robot, reference): (Arc<Robot>, Arc<Trajectory>) = (robot.into(), reference.into());
        reference.check_reference(&robot)?;
        settings.validate()?;
        if !(control_dt.is_finite() && control_dt > 0.0 && control_dt <= 1.0) {
            return Err(Error::invalid(
                "Estimated",
                "control_dt",
                control_dt,
                "must be finite and in (0, 1] s",
            ));
        }
        let steps = |d: f64| (d / control_dt).round();
        let (dm, da) = (
            steps(settings.measurement_delay_s),
            steps(settings.actuation_delay_s),
        );
        // Bounded: total delay <= MAX_DELAY_S was checked; the period may be tiny, so cap the count.
        if dm + da > 100_000.0 {
            return Err(Error::invalid(
                "Estimated",
                "control_dt",
                control_dt,
                "the delays span more than 100000 control periods",
            ));
        }
        let (dm, da) = (dm as usize, da as usize);
        let n = robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let hist_len = dm + da + 2;
        Ok(Estimated {
            inner,
            lin: Linearizer::new(Arc::clone(&robot)),
            lm: LinearModel::zeros(n),
            robot,
            reference,
            settings,
            dt: control_dt,
            dm,
            da,
            ad: vec![0.0; nx * nx],
            bd: vec![0.0; nx * nu],
            a2: vec![0.0; nx * nx],
            xhat: vec![0.0; nx],
            xpred: vec![0.0; nx],
            p: vec![0.0; nx * nx],
            tmp: vec![0.0; nx * nx],
            kt: vec![0.0; nx * nx],
            s: vec![0.0; nx * nx],
            xd: vec![0.0; nx],
            xd1: vec![0.0; nx],
            xbuf: vec![0.0; nx],
            hist: vec![0.0; hist_len * nu],
            hist_len,
            last_step: None,
            t0: 0.0,
            xhat_step: 0,
        })
    }

    /// The wrapped controller.
    pub fn inner(&self) -> &C {
        &self.inner
    }

    /// The wrapped controller, mutable.
    pub fn inner_mut(&mut self) -> &mut C {
        &mut self.inner
    }

    /// The settings in use.
    pub fn settings(&self) -> &EstimatorSettings {
        &self.settings
    }

    /// The filtered state at the last measured time (`t - measurement_delay_s`).
    pub fn estimate(&self) -> &[f64] {
        &self.xhat
    }

    /// The state the wrapped controller saw at the last call (the estimate predicted to
    /// `t + actuation_delay_s`).
    pub fn prediction(&self) -> &[f64] {
        &self.xpred
    }

    /// The covariance of [`Estimated::estimate`] (2n x 2n row-major).
    pub fn covariance(&self) -> &[f64] {
        &self.p
    }

    /// Restart the filter at the next call (the inner controller is not reset).
    pub fn reset(&mut self) {
        self.last_step = None;
    }

    fn time_of(&self, step: i64) -> f64 {
        self.t0 + step as f64 * self.dt
    }

    /// The torque that acted over the period starting at step `j` (sent at step `j - da`), clamped.
    fn applied(&self, j: i64, out: &mut [f64]) {
        let nu = self.robot.nu();
        let sent = j - self.da as i64;
        let have = match self.last_step {
            Some(last) => sent >= 0 && sent <= last && last - sent < self.hist_len as i64,
            None => false,
        };
        if have {
            let r = (sent as usize) % self.hist_len;
            out[..nu].copy_from_slice(&self.hist[r * nu..(r + 1) * nu]);
        } else {
            self.reference.tau_at(self.time_of(j), &mut out[..nu]);
            for (k, o) in out[..nu].iter_mut().enumerate() {
                *o = o.clamp(self.robot.tau_min[k], self.robot.tau_max[k]);
            }
        }
    }

    /// Linearise at the plan point of step `j` and discretise over one period into `ad`, `bd`;
    /// `xd`, `xd1` get the plan states at steps j and j + 1, and `ud` the planned torque at j.
    fn model_at(&mut self, j: i64, ud: &mut [f64]) {
        let n = self.robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let (s, dt) = (self.time_of(j), self.dt);
        self.reference.state_at(s, &mut self.xd);
        self.reference.state_at(s + dt, &mut self.xd1);
        self.reference.tau_at(s, &mut ud[..nu]);
        self.lin.linearize_into(&self.xd, &ud[..nu], &mut self.lm);
        let a = &self.lm.a;
        let b = &self.lm.b;
        // a2 = A^2
        for i in 0..nx {
            for c in 0..nx {
                let mut v = 0.0;
                for k in 0..nx {
                    v += a[i * nx + k] * a[k * nx + c];
                }
                self.a2[i * nx + c] = v;
            }
        }
        let h = 0.5 * dt * dt;
        for i in 0..nx {
            for c in 0..nx {
                let id = if i == c { 1.0 } else { 0.0 };
                self.ad[i * nx + c] = id + dt * a[i * nx + c] + h * self.a2[i * nx + c];
            }
            for c in 0..nu {
                let mut ab = 0.0;
                for k in 0..nx {
                    ab += a[i * nx + k] * b[k * nu + c];
                }
                self.bd[i * nu + c] = dt * b[i * nu + c] + h * ab;
            }
        }
    }

    /// Propagate `x` (in `xbuf`) over the period starting at step j with the model of `model_at(j)`
    /// and the applied torque `u`.
    fn propagate(&mut self, u: &[f64], ud: &[f64]) {
        let nx = self.xd.len();
        let nu = u.len();
        for i in 0..nx {
            let mut v = self.xd1[i];
            for c in 0..nx {
                v += self.ad[i * nx + c] * (self.xbuf[c] - self.xd[c]);
            }
            for c in 0..nu {
                v += self.bd[i * nu + c] * (u[c] - ud[c]);
            }
            self.tmp[i] = v;
        }
        self.xbuf.copy_from_slice(&self.tmp[..nx]);
    }

    /// `P <- Ad P Ad^T + Qd`.
    fn predict_cov(&mut self) {
        let nx = self.xd.len();
        let n = nx / 2;
        // tmp = Ad P
        for i in 0..nx {
            for c in 0..nx {
                let mut v = 0.0;
                for k in 0..nx {
                    v += self.ad[i * nx + k] * self.p[k * nx + c];
                }
                self.tmp[i * nx + c] = v;
            }
        }
        // P = tmp Ad^T
        for i in 0..nx {
            for c in i..nx {
                let mut v = 0.0;
                for k in 0..nx {
                    v += self.tmp[i * nx + k] * self.ad[c * nx + k];
                }
                self.p[i * nx + c] = v;
                self.p[c * nx + i] = v;
            }
        }
        let (sq, sqd) = (self.settings.process_q_std, self.settings.process_qd_std);
        for i in 0..n {
            self.p[i * nx + i] += sq * sq * self.dt;
            self.p[(n + i) * nx + n + i] += sqd * sqd * self.dt;
        }
    }

    /// Measurement update with `y` (full state) into `xhat`, `P`.
    fn update(&mut self, y: &[f64]) {
        let nx = self.xd.len();
        let n = nx / 2;
        let (rq, rqd) = (self.settings.meas_q_std, self.settings.meas_qd_std);
        let rdiag = |i: usize| if i < n { rq * rq } else { rqd * rqd };
        // S = P + R, factor; K^T = S^-1 P (columns of P solved).
        self.s.copy_from_slice(&self.p);
        for i in 0..nx {
            self.s[i * nx + i] += rdiag(i);
        }
        if cholesky(&mut self.s, nx, Scaling::Reciprocal).is_err() {
            // S is not positive definite only when P holds non-finite values: keep the prediction
            return;
        }
        for c in 0..nx {
            let mut col = [0.0; 2 * MAX_LINKS];
            for i in 0..nx {
                col[i] = self.p[i * nx + c];
            }
            cholesky_solve_vec(&self.s, nx, &mut col[..nx], Scaling::Divide);
            // K^T column c = row c of K.
            for i in 0..nx {
                self.kt[c * nx + i] = col[i];
            }
        }
        // kt now holds K (row c = K[c, :]).
        let mut innov = [0.0; 2 * MAX_LINKS];
        for i in 0..nx {
            innov[i] = y[i] - self.xhat[i];
        }
        for i in 0..nx {
            let mut v = 0.0;
            for k in 0..nx {
                v += self.kt[i * nx + k] * innov[k];
            }
            self.xhat[i] += v;
        }
        // Joseph form: P = (I - K) P (I - K)^T + K R K^T. tmp = I - K.
        for i in 0..nx {
            for c in 0..nx {
                let id = if i == c { 1.0 } else { 0.0 };
                self.tmp[i * nx + c] = id - self.kt[i * nx + c];
            }
        }
        // s = (I - K) P
        for i in 0..nx {
            for c in 0..nx {
                let mut v = 0.0;
                for k in 0..nx {
                    v += self.tmp[i * nx + k] * self.p[k * nx + c];
                }
                self.s[i * nx + c] = v;
            }
        }
        for i in 0..nx {
            for c in i..nx {
                let mut v = 0.0;
                for k in 0..nx {
                    v += self.s[i * nx + k] * self.tmp[c * nx + k]
                        + self.kt[i * nx + k] * rdiag(k) * self.kt[c * nx + k];
                }
                self.p[i * nx + c] = v;
                self.p[c * nx + i] = v;
            }
        }
    }

    fn filter_and_predict(&mut self, t: f64, y: &[f64]) {
        let n = self.robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let step = match self.last_step {
            None => {
                self.t0 = t;
                0
            }
            Some(_) => ((t - self.t0) / self.dt).round() as i64,
        };
        let meas_step = step - self.dm as i64;
        let mut u = [0.0; MAX_LINKS];
        let mut ud = [0.0; MAX_LINKS];
        if self.last_step.is_none() {
            self.xhat.copy_from_slice(y);
            self.p.fill(0.0);
            let (q0, qd0) = (self.settings.initial_q_std, self.settings.initial_qd_std);
            for i in 0..n {
                self.p[i * nx + i] = q0 * q0;
                self.p[(n + i) * nx + n + i] = qd0 * qd0;
            }
            self.xhat_step = meas_step;
            self.update(y);
        } else {
            // Predict to the measured step (normally one period), then update.
            let to = meas_step.max(self.xhat_step);
            // A gap longer than the history would need torques no longer kept: bound the loop.
            let from = self.xhat_step.max(to - self.hist_len as i64);
            self.xbuf.copy_from_slice(&self.xhat);
            for j in from..to {
                self.model_at(j, &mut ud[..nu]);
                self.applied(j, &mut u[..nu]);
                self.propagate(&u[..nu], &ud[..nu]);
                self.predict_cov();
            }
            self.xhat.copy_from_slice(&self.xbuf);
            self.xhat_step = to;
            self.update(y);
        }
        // Predict to the actuation time with the torques already sent.
        self.xbuf.copy_from_slice(&self.xhat);
        let target = step + self.da as i64;
        for j in self.xhat_step..target {
            self.model_at(j, &mut ud[..nu]);
            self.applied(j, &mut u[..nu]);
            self.propagate(&u[..nu], &ud[..nu]);
        }
        self.xpred.copy_from_slice(&self.xbuf);
    }
}

impl<C: Controller> Controller for Estimated<C> {
    /// Filter the measurement, predict over the delays and call the wrapped controller at
    /// `t + actuation_delay_s` with the predicted state. A measurement of the wrong length or with
    /// NaNs is passed to the wrapped controller unchanged (its own fallback applies) and does not
    /// update the filter.
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let n = self.robot.n;
        let nu = n - 1;
        if x.len() != 2 * n || tau.len() != nu || x.iter().any(|v| !v.is_finite()) {
            return self.inner.control(t, x, tau);
        }
        self.filter_and_predict(t, x);
        let step = match self.last_step {
            None => 0,
            Some(_) => ((t - self.t0) / self.dt).round() as i64,
        };
        let ta = self.time_of(step + self.da as i64);
        let xp = std::mem::take(&mut self.xpred);
        let info = self.inner.control(ta, &xp, tau);
        self.xpred = xp;
        for (j, o) in tau.iter_mut().enumerate() {
            *o = o.clamp(self.robot.tau_min[j], self.robot.tau_max[j]);
        }
        let r = (step.max(0) as usize) % self.hist_len;
        self.hist[r * nu..(r + 1) * nu].copy_from_slice(tau);
        self.last_step = Some(step);
        info
    }

    /// The wrapped controller's name with `-kf` (`mpc-kf`, `tvlqr-kf`, `pd-kf`).
    fn name(&self) -> &'static str {
        match self.inner.name() {
            "mpc" => "mpc-kf",
            "tvlqr" => "tvlqr-kf",
            "pd" => "pd-kf",
            "open-loop" => "open-loop",
            _ => "estimated",
        }
    }

    /// Swap the plan of the filter and of the wrapped controller (the filter state is kept).
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        reference.check_reference(&self.robot)?;
        self.inner.set_reference(Arc::clone(&reference))?;
        self.reference = reference;
        Ok(())
    }
}
