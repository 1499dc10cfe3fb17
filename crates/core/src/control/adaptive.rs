//! A controller whose model learns the robot it drives (docs/estimation.md).
//!
//! [`Adaptive`] wraps any controller with a model ([`Controller::set_model`]: the MPC, or
//! [`super::Replanning`] around it, which passes the model on to its tracking controller and uses
//! it for its capture predictions) and a [`ParamEstimator`]. Every control step the estimator takes
//! the measured state and the torque held since the previous step; at most every
//! `model_update_period_s`, after a window that updated the estimate, the wrapped controller gets a
//! robot with the estimated base parameters ([`super::base_params::robot_from_base`]; building it
//! allocates), once the estimate is ready ([`ParamEstimator::ready_to_use`]: determined, and
//! significantly different from the nominal robot; until then the wrapped controller keeps the
//! nominal robot). An estimate with no physical robot (a mass or inertia not > 0) is not passed on.

use super::param_estimator::{EstimateReport, ParamEstimator, ParamEstimatorSettings};
use super::{ControlInfo, Controller};
use crate::error::Result;
use crate::model::{Robot, MAX_LINKS};
use crate::trajectory::Trajectory;
use std::sync::Arc;

/// A controller fed an online estimate of the robot's masses and inertias; see the module docs.
pub struct Adaptive<C> {
    inner: C,
    estimator: ParamEstimator,
    settings: ParamEstimatorSettings,
    tau_last: [f64; MAX_LINKS],
    have_tau: bool,
    last_update: f64,
    model_updates: usize,
}

impl<C: Controller> Adaptive<C> {
    /// Wrap `inner`, whose model is `nominal` (the estimator's prior). Errors on invalid settings.
    pub fn new(
        inner: C,
        nominal: impl Into<Arc<Robot>>,
        settings: ParamEstimatorSettings,
    ) -> Result<Self> {
        Ok(Adaptive {
            inner,
            estimator: ParamEstimator::new(nominal, settings)?,
            settings,
            tau_last: [0.0; MAX_LINKS],
            have_tau: false,
            last_update: f64::NEG_INFINITY,
            model_updates: 0,
        })
    }

    /// The estimator.
    pub fn estimator(&self) -> &ParamEstimator {
        &self.estimator
    }

    /// The wrapped controller.
    pub fn inner(&self) -> &C {
        &self.inner
    }

    /// The wrapped controller, mutably.
    pub fn inner_mut(&mut self) -> &mut C {
        &mut self.inner
    }

    /// Start over: the estimator back at its prior, no torque held (the wrapped controller keeps
    /// the model it was last given).
    pub fn reset(&mut self) {
        self.estimator.reset();
        self.have_tau = false;
        self.last_update = f64::NEG_INFINITY;
    }

    /// How many times the wrapped controller's model was updated.
    pub fn model_updates(&self) -> usize {
        self.model_updates
    }

    /// When the wrapped controller was first given the estimate, s (`None`: not yet).
    pub fn used_from(&self) -> Option<f64> {
        self.estimator.used_from()
    }

    /// The estimate, its uncertainty and its history.
    pub fn report(&self) -> EstimateReport {
        self.estimator.report()
    }
}

impl<C: Controller> Controller for Adaptive<C> {
    /// Feed the estimator, pass an updated model on, then the wrapped controller's torque.
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let nu = tau.len().min(MAX_LINKS);
        let held = if self.have_tau {
            &self.tau_last[..nu]
        } else {
            &[][..]
        };
        let updated = if self.have_tau && x.len() == 2 * (nu + 1) {
            self.estimator.observe(t, x, held)
        } else {
            false
        };
        if updated
            && t - self.last_update >= self.settings.model_update_period_s - 1e-9
            && self.estimator.ready_to_use()
        {
            if let Ok(r) = self.estimator.robot() {
                if self.inner.set_model(Arc::new(r)).is_ok() {
                    self.last_update = t;
                    self.model_updates += 1;
                    self.estimator.mark_used(t);
                }
            }
        }
        let info = self.inner.control(t, x, tau);
        self.tau_last[..nu].copy_from_slice(&tau[..nu]);
        self.have_tau = true;
        info
    }

    fn name(&self) -> &'static str {
        "adaptive"
    }

    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        self.inner.set_reference(reference)
    }

    fn set_model(&mut self, robot: Arc<Robot>) -> Result<()> {
        self.inner.set_model(robot)
    }
}
