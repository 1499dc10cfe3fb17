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
pub mod adaptive;
pub mod base_params;
pub mod baselines;
pub mod estimator;
pub mod joint_ekf;
pub mod mpc;
pub mod param_estimator;
pub mod replan_gate;
pub mod replanning;
mod tracking;
pub mod tvlqr;

pub use adaptive::Adaptive;
pub use param_estimator::{
    EstimateMethod, EstimateReport, EstimateSample, ParamEstimator, ParamEstimatorSettings,
};

pub use baselines::{OpenLoop, Pd, PdSettings};
pub use estimator::{Estimated, EstimatorSettings};
pub use mpc::{Discretization, Linearization, Mpc, MpcSettings, Prediction, TorqueReference};
pub use replanning::{MissPrediction, ReplanEvent, ReplanSettings, Replanning};
pub use tvlqr::{Tvlqr, TvlqrSettings};

/// A diagonal weight vector of a controller's settings: `len` values for the n-link robot (`what`
/// says which), each finite, >= 0 and <= 1e12. Errors name `src` and the field `name`.
pub(crate) fn check_weights(
    src: &str,
    n: usize,
    name: &str,
    v: &[f64],
    len: usize,
    what: &str,
) -> Result<()> {
    if v.len() != len {
        return Err(Error::invalid(
            src,
            name,
            format!("{v:?}"),
            format!("needs {len} values for the {n}-link robot: {what}"),
        ));
    }
    if let Some(x) = v
        .iter()
        .find(|x| !(x.is_finite() && **x >= 0.0 && **x <= 1e12))
    {
        return Err(Error::invalid(
            src,
            name,
            x,
            "weights must be finite, >= 0 and <= 1e12",
        ));
    }
    Ok(())
}

/// The tracking weights the MPC and the TVLQR share, resolved (defaults filled): `[q_diag (2n: q then
/// qd), w_diag (2: EE x, y), r_diag (n - 1)]`, each as [`check_weights`], and every `r_diag` entry > 0
/// (`why_r_positive` says what that keeps). Errors name `src` and the field as written in a scenario.
pub(crate) fn check_tracking_weights(
    src: &str,
    n: usize,
    [q_diag, w_diag, r_diag]: [&[f64]; 3],
    why_r_positive: &str,
) -> Result<()> {
    check_weights(
        src,
        n,
        "q_diag",
        q_diag,
        2 * n,
        "2n values (q then qd), or none for the default",
    )?;
    check_weights(src, n, "w_diag", w_diag, 2, "2 values (EE x, y)")?;
    check_weights(
        src,
        n,
        "r_diag",
        r_diag,
        n.saturating_sub(1),
        "n - 1 values, or none for the default",
    )?;
    if let Some(x) = r_diag.iter().find(|x| **x <= 0.0) {
        return Err(Error::invalid(
            src,
            "r_diag",
            x,
            format!("must be > 0 ({why_r_positive})"),
        ));
    }
    Ok(())
}

/// Swap the reference a controller of `robot` tracks: `reference` checked against the robot first
/// ([`Trajectory::check_reference`]), then moved into `slot` (an `Arc` swap, no allocation). The one
/// body of every `set_reference`.
pub(crate) fn swap_reference(
    robot: &crate::model::Robot,
    slot: &mut Arc<Trajectory>,
    reference: impl Into<Arc<Trajectory>>,
) -> Result<()> {
    let reference = reference.into();
    reference.check_reference(robot)?;
    *slot = reference;
    Ok(())
}

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
    /// Use `robot` (same link count and geometry, other masses and inertias: an online estimate)
    /// as the model from the next call on. The default refuses: a controller without a model has
    /// nothing to update.
    fn set_model(&mut self, robot: Arc<crate::model::Robot>) -> Result<()> {
        drop(robot);
        Err(Error::invalid(
            "controller",
            "model",
            self.name(),
            "this controller has no model to update",
        ))
    }
    /// A copy of this controller in its current state (reference, warm start, model), to predict
    /// what it will do (the re-planner's adoption test); `None` (the default) when it cannot be
    /// copied.
    fn clone_box(&self) -> Option<Box<dyn Controller>> {
        None
    }
}

/// [`Controller`] for a pointer `$ptr` to a controller `C` (a borrow, a box): every method
/// forwarded to the controller it points to (none falls back to a default), written once for every
/// pointer.
macro_rules! controller_through {
    ($(#[$m:meta])* $ptr:ty) => {
        $(#[$m])*
        impl<C: Controller + ?Sized> Controller for $ptr {
            fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
                (**self).control(t, x, tau)
            }
            fn name(&self) -> &'static str {
                (**self).name()
            }
            fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
                (**self).set_reference(reference)
            }
            fn set_model(&mut self, robot: Arc<crate::model::Robot>) -> Result<()> {
                (**self).set_model(robot)
            }
            fn clone_box(&self) -> Option<Box<dyn Controller>> {
                (**self).clone_box()
            }
        }
    };
}

controller_through!(
    /// A mutable borrow of a controller is a controller (so a loop can drive one the caller keeps).
    &mut C
);
controller_through!(
    /// A boxed controller is a controller (so a loop can hold one chosen at run time).
    Box<C>
);

#[cfg(test)]
mod tests {
    use super::*;

    /// A controller that answers every method itself (none of the trait's defaults).
    #[derive(Clone)]
    struct Own(f64);

    impl Controller for Own {
        fn control(&mut self, _t: f64, _x: &[f64], tau: &mut [f64]) -> ControlInfo {
            tau.fill(self.0);
            ControlInfo { iterations: 7 }
        }
        fn name(&self) -> &'static str {
            "own"
        }
        fn set_reference(&mut self, _reference: Arc<Trajectory>) -> Result<()> {
            self.0 = 1.0;
            Ok(())
        }
        fn set_model(&mut self, _robot: Arc<crate::model::Robot>) -> Result<()> {
            self.0 = 2.0;
            Ok(())
        }
        fn clone_box(&self) -> Option<Box<dyn Controller>> {
            Some(Box::new(self.clone()))
        }
    }

    /// Every method, called through `c`, reaches `Own`'s.
    fn all_reach_the_controller(mut c: impl Controller) {
        let mut tau = [0.0; 3];
        assert_eq!(c.control(0.0, &[], &mut tau).iterations, 7);
        assert_eq!(c.name(), "own");
        c.set_reference(Arc::new(Trajectory::new(4))).unwrap();
        c.control(0.0, &[], &mut tau);
        assert_eq!(tau, [1.0; 3]);
        c.set_model(Arc::new(crate::model::Robot::paper())).unwrap();
        c.control(0.0, &[], &mut tau);
        assert_eq!(tau, [2.0; 3]);
        assert_eq!(c.clone_box().map(|b| b.name()), Some("own"));
    }

    #[test]
    fn a_borrowed_or_boxed_controller_forwards_every_method() {
        let mut own = Own(0.0);
        all_reach_the_controller(&mut own);
        assert_eq!(own.0, 2.0);
        all_reach_the_controller(Box::new(Own(0.0)));
        all_reach_the_controller(Box::new(Own(0.0)) as Box<dyn Controller>);
    }
}
