//! Online estimation of the robot's base inertial parameters (docs/estimation.md).
//!
//! With `method = "ekf"` (the default) [`ParamEstimator`] runs the joint state and parameter filter
//! of [`super::joint_ekf`] on every sample. With `method = "windows"` it integrates Lagrange's
//! equations against a triangular weight `w` over windows of `window_s` (`w` rises from 0 to 1 over the first half and falls back to 0): with the momentum
//! regressor `Yp` and the Lagrangian-gradient regressor `Yl` of [`super::base_params`], and
//! `int w dp/dt = -int w' p` (w vanishes at both ends), every window gives n linear equations in the
//! 2n base parameters `theta = [ZZR_1..ZZR_n, MXR_1..MXR_n]`,
//!
//! ```text
//! (-int w' Yp dt - int w Yl dt) theta = int w [0, tau_2..tau_n] dt
//! ```
//!
//! (trapezoidal rule on the measured states; the torque held over each control period), without
//! differentiating the measured rates: the momenta enter as averages over half-windows, which
//! averages their sensor noise down. Row by row they update the estimate and its covariance (RLS
//! with forgetting factor `forgetting`; measurement noise `noise_nm_s` per row). A window whose
//! normalised innovation exceeds `outlier_sigma` in any row (an impact: a ball, a push, a contact
//! the model does not have) is rejected whole. The prior is the nominal robot with a standard
//! deviation of `prior_rel_std` of each nominal value. With `windows_in_flight` > 1 that many
//! windows overlap, started `window_s / windows_in_flight` apart (each row's residual variance is
//! counted that many times: overlapping windows share their sensor noise).
//!
//! Units: s, rad, rad/s, N m, N m s; `theta` in kg m^2 (ZZR) and kg m (MXR).

use super::base_params::{base_params, lagrangian_regressor, momentum_regressor, robot_from_base};
use super::joint_ekf::{EkfStep, JointEkf, JointEkfNoise};
use crate::error::{Error, Result};
use crate::model::Robot;
use brachia_linalg::{cholesky, cholesky_solve_vec, Scaling};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Most windows one estimator integrates at once (`windows_in_flight`).
pub const MAX_WINDOWS_IN_FLIGHT: usize = 32;
/// Shortest `window_s` and `model_update_period_s`, s.
const MIN_PERIOD_S: f64 = 1e-3;

/// Time constant of the joint filter's running mean of the normalised innovation squared, s
/// ([`ParamEstimatorSettings::use_max_nis_ratio`]).
pub use super::joint_ekf::NIS_WINDOW_S;

/// Most history samples one estimator keeps (allocated once; later updates are not recorded).
pub const MAX_HISTORY: usize = 1000;

/// How [`ParamEstimator`] estimates (docs/estimation.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EstimateMethod {
    /// An extended Kalman filter on the state and the base parameters together, every sample
    /// ([`super::joint_ekf::JointEkf`]).
    Ekf,
    /// Recursive least squares on windows of the integrated Lagrange equations.
    Windows,
}

/// Settings of [`ParamEstimator`] (scenario section `[tracking] estimate_params = { ... }`).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ParamEstimatorSettings {
    /// How the parameters are estimated: `"ekf"` (the joint state and parameter filter) or
    /// `"windows"` (least squares on integration windows). Default [`EstimateMethod::Ekf`].
    pub method: EstimateMethod,
    /// The joint filter's measurement noise on q, rad (`method = "ekf"`). Default 0.0015.
    pub meas_q_std: f64,
    /// The joint filter's measurement noise on qd, rad/s (`method = "ekf"`). Default 0.015.
    pub meas_qd_std: f64,
    /// The joint filter's process noise density on qd, rad/(s sqrt(s)) (`method = "ekf"`): model
    /// error it allows per second; a larger value discards information. Default 0.002.
    pub process_qd_std: f64,
    /// Length of one integration window, s, in [0.001, 40]. Default 0.3.
    pub window_s: f64,
    /// RLS forgetting factor per window row, in (0, 1]. Default 1.
    pub forgetting: f64,
    /// Prior standard deviation of each base parameter, as a fraction of its nominal value
    /// (`method = "windows"` measures better with 1: docs/estimation.md). Default 0.3.
    pub prior_rel_std: f64,
    /// Standard deviation of one window equation's residual (sensor noise on the momenta), N m s.
    /// Default 0.02.
    pub noise_nm_s: f64,
    /// A window with a row whose innovation exceeds this many of its standard deviations is
    /// rejected. Default 5.
    pub outlier_sigma: f64,
    /// The controller's model is rebuilt from the estimate at most this often, s, in [0.001, 40].
    /// Default 0.05.
    pub model_update_period_s: f64,
    /// The estimate is handed to the controller only once it is determined: every base
    /// parameter's posterior standard deviation at most this fraction of its nominal value
    /// (docs/estimation.md, "When the estimate is used"). Default 0.02.
    pub use_max_rel_std: f64,
    /// ... and only once it differs from the nominal robot significantly: the nominal parameters
    /// outside the estimate's confidence region of this many standard normal deviations (a
    /// chi-square test with 2n degrees of freedom, one-sided level of a normal variable at this
    /// value; 0 turns the test off). Default 3.
    pub use_min_sigma: f64,
    /// ... and by at least this fraction of a nominal value in one base parameter (smaller
    /// differences are left to the feedback). Default 0.03.
    pub use_min_rel_change: f64,
    /// ... and, with the joint filter, only while its measurements are consistent with its noise
    /// model: the mean normalised innovation squared over the last [`NIS_WINDOW_S`] at most this
    /// multiple of its expected value 2n (an unmodelled force, torque noise, a geometry the base
    /// parameters cannot express or a sensor noise larger than `meas_q_std`, `meas_qd_std` raise
    /// it). Default 1.1.
    pub use_max_nis_ratio: f64,
    /// Windows integrated at once, started `window_s / windows_in_flight` apart (1: back to back),
    /// in 1..=[`MAX_WINDOWS_IN_FLIGHT`]; each row's residual variance is counted this many times
    /// (overlapping windows share their sensor noise). Default 1.
    pub windows_in_flight: usize,
}

impl Default for ParamEstimatorSettings {
    fn default() -> Self {
        ParamEstimatorSettings {
            method: EstimateMethod::Ekf,
            meas_q_std: 0.0015,
            meas_qd_std: 0.015,
            process_qd_std: 0.002,
            window_s: 0.3,
            forgetting: 1.0,
            prior_rel_std: 0.3,
            noise_nm_s: 0.02,
            outlier_sigma: 5.0,
            model_update_period_s: 0.05,
            windows_in_flight: 1,
            use_max_rel_std: 0.02,
            use_min_sigma: 3.0,
            use_min_rel_change: 0.03,
            use_max_nis_ratio: 1.1,
        }
    }
}

impl ParamEstimatorSettings {
    /// Check the values; `src` names the source in errors.
    pub fn validate(&self, src: &str) -> Result<()> {
        let pos = |field: &str, v: f64| -> Result<()> {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(src, field, v, "must be finite and > 0"))
            }
        };
        pos("window_s", self.window_s)?;
        pos("prior_rel_std", self.prior_rel_std)?;
        pos("noise_nm_s", self.noise_nm_s)?;
        pos("outlier_sigma", self.outlier_sigma)?;
        pos("model_update_period_s", self.model_update_period_s)?;
        pos("meas_q_std", self.meas_q_std)?;
        pos("meas_qd_std", self.meas_qd_std)?;
        pos("process_qd_std", self.process_qd_std)?;
        pos("use_max_rel_std", self.use_max_rel_std)?;
        pos("use_max_nis_ratio", self.use_max_nis_ratio)?;
        for (field, v) in [
            ("use_min_sigma", self.use_min_sigma),
            ("use_min_rel_change", self.use_min_rel_change),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(Error::invalid(src, field, v, "must be finite and >= 0"));
            }
        }
        if !(1..=MAX_WINDOWS_IN_FLIGHT).contains(&self.windows_in_flight) {
            return Err(Error::invalid(
                src,
                "windows_in_flight",
                self.windows_in_flight,
                format!("must be in 1..={MAX_WINDOWS_IN_FLIGHT}"),
            ));
        }
        // a window or a model update shorter than a millisecond (a control period at 1 kHz) would
        // run at every step whatever it says; one longer than the longest swing never ends
        for (field, v) in [
            ("window_s", self.window_s),
            ("model_update_period_s", self.model_update_period_s),
        ] {
            if !(MIN_PERIOD_S..=crate::limits::MAX_SWING_TIME_S).contains(&v) {
                return Err(Error::invalid(
                    src,
                    field,
                    v,
                    format!(
                        "must be in [{MIN_PERIOD_S}, {}] s: at least a control period at 1 kHz, at \
                         most the longest swing (brachia::limits::MAX_SWING_TIME_S)",
                        crate::limits::MAX_SWING_TIME_S
                    ),
                ));
            }
        }
        if !(self.forgetting > 0.0 && self.forgetting <= 1.0) {
            return Err(Error::invalid(
                src,
                "forgetting",
                self.forgetting,
                "must be in (0, 1]",
            ));
        }
        Ok(())
    }
}

/// One point of the estimate's history.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EstimateSample {
    /// End of the window, s.
    pub t_s: f64,
    /// The estimate `[ZZR_1..ZZR_n, MXR_1..MXR_n]` (kg m^2, kg m).
    pub theta: Vec<f64>,
    /// Its standard deviations (square roots of the covariance's diagonal), same units.
    pub std: Vec<f64>,
}

/// The estimator's state for reports.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct EstimateReport {
    /// The base parameters' names, `ZZR_1..ZZR_n, MXR_1..MXR_n`.
    pub names: Vec<String>,
    /// The nominal (planner's) robot's base parameters.
    pub nominal: Vec<f64>,
    /// The final estimate.
    pub theta: Vec<f64>,
    /// Its standard deviations.
    pub std: Vec<f64>,
    /// Windows used (`method = "ekf"`: measurements used).
    pub windows: usize,
    /// Windows rejected as outliers (`method = "ekf"`: measurements rejected).
    pub rejected: usize,
    /// The estimate after every used window (at most [`MAX_HISTORY`]).
    pub history: Vec<EstimateSample>,
    /// When the controller was first given the estimate, s (`None`: never; the estimate was not
    /// determined or not significantly different from the nominal robot).
    #[serde(default)]
    pub used_from_s: Option<f64>,
}

/// One integration window: its start and its matrix and right-hand side so far.
#[derive(Debug, Clone)]
struct Window {
    t0: Option<f64>,
    acc: Vec<f64>,
    tau_int: Vec<f64>,
}

/// Recursive least squares on the base parameters; see the module docs.
#[derive(Debug, Clone)]
pub struct ParamEstimator {
    nominal: Arc<Robot>,
    settings: ParamEstimatorSettings,
    theta: Vec<f64>,
    theta_nom: Vec<f64>,
    /// Covariance, 2n x 2n row-major.
    p: Vec<f64>,
    /// The windows in flight.
    wins: Vec<Window>,
    /// Time of the first sample of the current run of samples (`None`: none yet, or broken).
    t_start: Option<f64>,
    /// The last sample: time, regressors.
    t_prev: f64,
    yl_prev: Vec<f64>,
    yp_prev: Vec<f64>,
    /// Scratch.
    yp: Vec<f64>,
    yl: Vec<f64>,
    a: Vec<f64>,
    pa: Vec<f64>,
    innov: Vec<f64>,
    windows: usize,
    rejected: usize,
    history: Vec<EstimateSample>,
    /// The joint filter (`method = "ekf"`), and when its estimate was last recorded.
    ekf: Option<Box<JointEkf>>,
    last_record: f64,
    /// Scratch of [`Self::nominal_chi2`]: the parameters' covariance and the difference.
    cov: Vec<f64>,
    dev: Vec<f64>,
    /// When a controller was first given the estimate ([`Self::mark_used`]).
    used_from: Option<f64>,
}

impl ParamEstimator {
    /// An estimator whose prior is `nominal`. Errors on invalid settings.
    pub fn new(nominal: impl Into<Arc<Robot>>, settings: ParamEstimatorSettings) -> Result<Self> {
        settings.validate("estimate_params")?;
        let nominal: Arc<Robot> = nominal.into();
        let n = nominal.n();
        let np = 2 * n;
        let mut theta = vec![0.0; np];
        base_params(&nominal, &mut theta);
        let mut p = vec![0.0; np * np];
        let prior_std: Vec<f64> = theta
            .iter()
            .map(|v| settings.prior_rel_std * v.abs().max(1e-6))
            .collect();
        for i in 0..np {
            p[i * np + i] = prior_std[i] * prior_std[i];
        }
        let ekf = match settings.method {
            EstimateMethod::Windows => None,
            EstimateMethod::Ekf => Some(Box::new(JointEkf::new(
                &nominal,
                &theta,
                &prior_std,
                JointEkfNoise {
                    meas_q_std: settings.meas_q_std,
                    meas_qd_std: settings.meas_qd_std,
                    process_qd_std: settings.process_qd_std,
                    outlier_sigma: settings.outlier_sigma,
                },
            )?)),
        };
        Ok(ParamEstimator {
            ekf,
            last_record: f64::NEG_INFINITY,
            nominal,
            settings,
            theta_nom: theta.clone(),
            theta,
            p,
            wins: vec![
                Window {
                    t0: None,
                    acc: vec![0.0; n * np],
                    tau_int: vec![0.0; n],
                };
                settings.windows_in_flight
            ],
            t_start: None,
            t_prev: 0.0,
            yl_prev: vec![0.0; n * np],
            yp_prev: vec![0.0; n * np],
            yp: vec![0.0; n * np],
            yl: vec![0.0; n * np],
            a: vec![0.0; np],
            pa: vec![0.0; np],
            innov: vec![0.0; n],
            windows: 0,
            rejected: 0,
            history: Vec::with_capacity(MAX_HISTORY),
            cov: vec![0.0; np * np],
            dev: vec![0.0; np],
            used_from: None,
        })
    }

    /// The current estimate `[ZZR_1..ZZR_n, MXR_1..MXR_n]`.
    pub fn theta(&self) -> &[f64] {
        &self.theta
    }

    /// The nominal robot's base parameters.
    pub fn nominal_theta(&self) -> &[f64] {
        &self.theta_nom
    }

    /// Standard deviation of estimate entry `i`.
    pub fn std(&self, i: usize) -> f64 {
        if let Some(ekf) = &self.ekf {
            return ekf.theta_std(i);
        }
        let np = self.theta.len();
        self.p[i * np + i].max(0.0).sqrt()
    }

    /// The largest posterior standard deviation of a base parameter relative to its nominal value.
    pub fn max_rel_std(&self) -> f64 {
        (0..self.theta.len())
            .map(|i| self.std(i) / self.theta_nom[i].abs().max(1e-12))
            .fold(0.0, f64::max)
    }

    /// The largest difference of a base parameter from its nominal value, relative to it.
    pub fn max_rel_change(&self) -> f64 {
        self.theta
            .iter()
            .zip(&self.theta_nom)
            .map(|(a, b)| ((a - b) / b.abs().max(1e-12)).abs())
            .fold(0.0, f64::max)
    }

    /// The squared Mahalanobis distance of the nominal parameters from the estimate under its
    /// covariance, `(theta - theta_nom)^T P^-1 (theta - theta_nom)` (chi-square with 2n degrees of
    /// freedom when the nominal robot is the truth); NaN when the covariance is not positive
    /// definite (no distance can be read from it: every comparison with a quantile fails, so the
    /// estimate is not taken as different from the nominal robot). Does not allocate.
    pub fn nominal_chi2(&mut self) -> f64 {
        let np = self.theta.len();
        match &self.ekf {
            Some(ekf) => ekf.param_cov_into(&mut self.cov),
            None => self.cov.copy_from_slice(&self.p),
        }
        for i in 0..np {
            self.dev[i] = self.theta[i] - self.theta_nom[i];
        }
        if cholesky(&mut self.cov, np, Scaling::Reciprocal).is_err() {
            return f64::NAN;
        }
        let mut sol = [0.0; 2 * crate::model::MAX_LINKS];
        sol[..np].copy_from_slice(&self.dev);
        cholesky_solve_vec(&self.cov, np, &mut sol[..np], Scaling::Divide);
        dot(&sol[..np], &self.dev)
    }

    /// The joint filter's running mean of the normalised innovation squared over the last
    /// [`NIS_WINDOW_S`], divided by its expected value 2n (about 1 when the filter's noise model
    /// fits the measurements); NaN before the first update or with `method = "windows"`.
    pub fn nis_ratio(&self) -> f64 {
        // the measurement's dimension: the joint filter measures the state [q, qd]
        match &self.ekf {
            Some(ekf) => ekf.nis_mean() / ekf.state().len() as f64,
            None => f64::NAN,
        }
    }

    /// Whether the estimate is ready to be used (docs/estimation.md, "When the estimate is used"):
    /// determined (every relative standard deviation at most `use_max_rel_std`), consistent (with
    /// the joint filter: [`Self::nis_ratio`] at most `use_max_nis_ratio`) and, unless it was
    /// handed over already ([`Self::mark_used`]), significantly different from the nominal robot
    /// (the chi-square test at `use_min_sigma` and a change of at least `use_min_rel_change`).
    pub fn ready_to_use(&mut self) -> bool {
        let s = self.settings;
        if self.max_rel_std() > s.use_max_rel_std {
            return false;
        }
        let nis = self.nis_ratio();
        // NaN (no update yet) fails too
        if self.ekf.is_some() && (nis.is_nan() || nis > s.use_max_nis_ratio) {
            return false;
        }
        if self.used_from.is_some() {
            return true;
        }
        self.max_rel_change() >= s.use_min_rel_change
            && (s.use_min_sigma == 0.0
                || self.nominal_chi2() >= chi2_quantile(self.theta.len(), s.use_min_sigma))
    }

    /// Record that a controller was given the estimate at `t`, s (the first time is kept): from
    /// then on [`Self::ready_to_use`] no longer asks the estimate to differ from the nominal robot.
    pub fn mark_used(&mut self, t: f64) {
        self.used_from.get_or_insert(t);
    }

    /// When a controller was first given the estimate, s (`None`: not yet, or not since
    /// [`Self::reset`]).
    pub fn used_from(&self) -> Option<f64> {
        self.used_from
    }

    /// The joint filter (`method = "ekf"`), for its diagnostics.
    pub fn joint_filter(&self) -> Option<&JointEkf> {
        self.ekf.as_deref()
    }

    /// Windows used so far.
    pub fn windows(&self) -> usize {
        self.windows
    }

    /// A robot with the current estimate ([`robot_from_base`]); errors when the estimate has none.
    pub fn robot(&self) -> Result<Robot> {
        robot_from_base(&self.nominal, &self.theta)
    }

    /// Start over from the prior.
    pub fn reset(&mut self) {
        let np = self.theta.len();
        self.theta.copy_from_slice(&self.theta_nom);
        self.p.fill(0.0);
        for i in 0..np {
            let s = self.settings.prior_rel_std * self.theta_nom[i].abs().max(1e-6);
            self.p[i * np + i] = s * s;
        }
        self.break_windows();
        self.windows = 0;
        self.rejected = 0;
        self.history.clear();
        self.last_record = f64::NEG_INFINITY;
        self.used_from = None;
        if let Some(ekf) = &mut self.ekf {
            let std: Vec<f64> = (0..np).map(|i| self.p[i * np + i].sqrt()).collect();
            ekf.reset(&self.theta_nom, &std);
        }
    }

    /// Take the measured state `x` (2n) at `t`, with `tau` (n - 1) the torque held since the previous
    /// call. Returns true when the estimate was updated (a window closed; with the joint filter,
    /// every measurement not rejected). A state with NaNs breaks the window (the next call starts a
    /// new one). Does not allocate (past [`MAX_HISTORY`] updates the history stops growing; with the
    /// joint filter the history records the estimate at most every `model_update_period_s`).
    pub fn observe(&mut self, t: f64, x: &[f64], tau: &[f64]) -> bool {
        let n = self.nominal.n();
        let (q, qd) = (&x[..n], &x[n..2 * n]);
        if !x.iter().all(|v| v.is_finite()) || !tau.iter().all(|v| v.is_finite()) {
            self.break_windows();
            if let Some(ekf) = &mut self.ekf {
                ekf.break_state();
            }
            return false;
        }
        if self.ekf.is_some() {
            return self.observe_ekf(t, x, tau);
        }
        lagrangian_regressor(&self.nominal, q, qd, &mut self.yl);
        momentum_regressor(&self.nominal, q, qd, &mut self.yp);
        let Some(t_start) = self.t_start else {
            self.t_start = Some(t);
            self.wins[0].start(t);
            self.keep_sample(t);
            return false;
        };
        let (h, w_len) = (t - self.t_prev, self.settings.window_s);
        let mut updated = false;
        for k in 0..self.wins.len() {
            let Some(t0) = self.wins[k].t0 else {
                continue;
            };
            // the weight and its slope at the interval's midpoint
            let tm = (0.5 * (self.t_prev + t) - t0) / w_len;
            let w = (1.0 - (2.0 * tm - 1.0).abs()).max(0.0);
            let dw = if tm < 0.5 { 2.0 / w_len } else { -2.0 / w_len };
            let win = &mut self.wins[k];
            for i in 0..win.acc.len() {
                win.acc[i] -= 0.5
                    * h
                    * (dw * (self.yp_prev[i] + self.yp[i]) + w * (self.yl_prev[i] + self.yl[i]));
            }
            for j in 1..n {
                win.tau_int[j] += w * h * tau[j - 1];
            }
            if t - t0 >= w_len - 1e-9 {
                updated |= self.update(t, k);
                self.wins[k].start(t);
            }
        }
        // windows not started yet start at their offsets
        let stagger = w_len / self.wins.len() as f64;
        for (k, win) in self.wins.iter_mut().enumerate() {
            if win.t0.is_none() && t - t_start >= k as f64 * stagger - 1e-9 {
                win.start(t);
            }
        }
        self.keep_sample(t);
        updated
    }

    /// [`Self::observe`] with the joint filter.
    fn observe_ekf(&mut self, t: f64, x: &[f64], tau: &[f64]) -> bool {
        let Some(ekf) = self.ekf.as_mut() else {
            return false;
        };
        match ekf.observe(t, x, tau) {
            EkfStep::Started => false,
            EkfStep::Rejected => {
                self.rejected += 1;
                false
            }
            EkfStep::Updated => {
                self.theta.copy_from_slice(ekf.theta());
                self.windows += 1;
                let period = self.settings.model_update_period_s;
                if t - self.last_record >= period - 1e-9 && self.history.len() < MAX_HISTORY {
                    self.last_record = t;
                    self.history.push(EstimateSample {
                        t_s: t,
                        theta: self.theta.clone(),
                        std: (0..self.theta.len()).map(|i| ekf.theta_std(i)).collect(),
                    });
                }
                true
            }
        }
    }

    /// Keep the sample at `t` (`yl`, `yp` hold its regressors) as the last one.
    fn keep_sample(&mut self, t: f64) {
        self.yl_prev.copy_from_slice(&self.yl);
        self.yp_prev.copy_from_slice(&self.yp);
        self.t_prev = t;
    }

    /// Drop every window in flight (the next sample starts them again).
    fn break_windows(&mut self) {
        self.t_start = None;
        for w in &mut self.wins {
            w.t0 = None;
        }
    }

    /// The rows of window `k` (its matrix and right-hand side) ending at `t`.
    fn update(&mut self, t: f64, k: usize) -> bool {
        let n = self.nominal.n();
        let np = 2 * n;
        let r = self.settings.noise_nm_s * self.settings.noise_nm_s * self.wins.len() as f64;
        // outlier test against the estimate before the window
        for j in 0..n {
            let row = &self.wins[k].acc[j * np..(j + 1) * np];
            let e = self.wins[k].tau_int[j] - dot(row, &self.theta);
            let mut s = r;
            for a in 0..np {
                s += row[a] * dot(&self.p[a * np..(a + 1) * np], row);
            }
            self.innov[j] = e / s.sqrt();
        }
        let lim = self.settings.outlier_sigma;
        if self.innov.iter().any(|z| z.is_nan() || z.abs() > lim) {
            self.rejected += 1;
            return false;
        }
        for j in 0..n {
            self.a
                .copy_from_slice(&self.wins[k].acc[j * np..(j + 1) * np]);
            for i in 0..np {
                self.pa[i] = dot(&self.p[i * np..(i + 1) * np], &self.a);
            }
            let s = r + dot(&self.a, &self.pa);
            let e = self.wins[k].tau_int[j] - dot(&self.a, &self.theta);
            for i in 0..np {
                self.theta[i] += self.pa[i] * e / s;
            }
            let lam = self.settings.forgetting;
            for i in 0..np {
                for k in 0..np {
                    self.p[i * np + k] = (self.p[i * np + k] - self.pa[i] * self.pa[k] / s) / lam;
                }
            }
        }
        self.windows += 1;
        if self.history.len() < MAX_HISTORY {
            self.history.push(EstimateSample {
                t_s: t,
                theta: self.theta.clone(),
                std: (0..np).map(|i| self.std(i)).collect(),
            });
        }
        true
    }

    /// The estimate, its uncertainty and its history for a report.
    pub fn report(&self) -> EstimateReport {
        let n = self.nominal.n();
        let np = 2 * n;
        EstimateReport {
            names: (1..=n)
                .map(|j| format!("ZZR_{j}"))
                .chain((1..=n).map(|j| format!("MXR_{j}")))
                .collect(),
            nominal: self.theta_nom.clone(),
            theta: self.theta.clone(),
            std: (0..np).map(|i| self.std(i)).collect(),
            windows: self.windows,
            rejected: self.rejected,
            history: self.history.clone(),
            used_from_s: self.used_from,
        }
    }
}

impl Window {
    /// Start the window at `t`, empty.
    fn start(&mut self, t: f64) {
        self.acc.fill(0.0);
        self.tau_int.fill(0.0);
        self.t0 = Some(t);
    }
}

/// The chi-square quantile with `k` degrees of freedom at the one-sided normal level `z` (the
/// Wilson-Hilferty approximation: `k (1 - 2/(9k) + z sqrt(2/(9k)))^3`, within 1 % for k >= 4 at
/// the levels used here).
pub fn chi2_quantile(k: usize, z: f64) -> f64 {
    let k = k as f64;
    let a = 2.0 / (9.0 * k);
    k * (1.0 - a + z * a.sqrt()).max(0.0).powi(3)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[cfg(test)]
mod tests {
    use super::{EstimateMethod, ParamEstimator, ParamEstimatorSettings};
    use crate::model::Robot;

    /// An estimate far from the nominal robot whose covariance is singular (all zeros: every
    /// standard deviation 0, so it counts as determined) gives no chi-square distance and is not
    /// handed over; with a positive definite covariance of the same size it is.
    #[test]
    fn a_singular_covariance_does_not_pass_the_test_against_the_nominal_robot() {
        let settings = ParamEstimatorSettings {
            method: EstimateMethod::Windows,
            ..Default::default()
        };
        let mut est = ParamEstimator::new(Robot::paper(), settings).unwrap();
        let np = est.theta.len();
        for i in 0..np {
            est.theta[i] = 1.5 * est.theta_nom[i];
        }
        est.p.fill(0.0);
        assert!(est.nominal_chi2().is_nan());
        assert!(!est.ready_to_use());
        // the same estimate with a tiny, positive definite covariance is far from nominal
        for i in 0..np {
            est.p[i * np + i] = (1e-6 * est.theta_nom[i]).powi(2);
        }
        assert!(est.nominal_chi2() > 1e6, "{}", est.nominal_chi2());
        assert!(est.ready_to_use());
    }
}
