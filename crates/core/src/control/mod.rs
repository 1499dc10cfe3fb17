//! Feedback controllers and their solvers: the box QP, the linear MPC of the paper's Section IV, a
//! time-varying LQR along the plan, baselines, a Kalman-filter wrapper ([`Estimated`]) that feeds any
//! of them a filtered, delay-compensated state, online re-planning around a tracking controller
//! ([`Replanning`]), and the [`Controller`] trait they all implement.
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative),
//! input `u = tau` = torques of joints 2..n (N m), gravity along -y.

pub mod boxqp;

use crate::error::{Error, Result};
use crate::trajectory::Trajectory;
use std::sync::Arc;

pub use boxqp::{BoxQp, BoxQpInfo, BoxQpSettings, BoxQpStatus};
pub mod baselines;
pub mod estimator;
pub mod mpc;
pub mod replanning;
pub mod tvlqr;

pub use baselines::{OpenLoop, Pd, PdSettings};
pub use estimator::{Estimated, EstimatorSettings};
pub use mpc::{Discretization, Linearization, Mpc, MpcSettings, Prediction, TorqueReference};
pub use replanning::{ReplanEvent, ReplanSettings, Replanning};
pub use tvlqr::{Tvlqr, TvlqrSettings};

/// Diagnostics of one control step.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ControlInfo {
    /// Iterations of the inner solver (0 for controllers without one).
    pub iterations: usize,
}

/// A feedback law evaluated once per control period.
pub trait Controller {
    /// Torques for joints 2..n (n - 1 values, N m) at time `t` (s) for measured state `x` (2n).
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo;
    /// A short name for reports (`mpc`, `pd`, `open-loop`).
    fn name(&self) -> &'static str;
    /// Track another plan from the next call on (re-planning). The default refuses: a controller
    /// without a reference has nothing to swap.
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        drop(reference);
        Err(Error::invalid(
            "controller",
            "reference",
            self.name(),
            "this controller tracks no reference",
        ))
    }
}

/// A mutable borrow of a controller is a controller (so a loop can drive one the caller keeps).
impl<C: Controller + ?Sized> Controller for &mut C {
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        (**self).control(t, x, tau)
    }
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        (**self).set_reference(reference)
    }
}

/// A boxed controller is a controller (so a loop can hold one chosen at run time).
impl<C: Controller + ?Sized> Controller for Box<C> {
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        (**self).control(t, x, tau)
    }
    fn name(&self) -> &'static str {
        (**self).name()
    }
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        (**self).set_reference(reference)
    }
}
