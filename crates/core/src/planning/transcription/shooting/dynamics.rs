//! Exact derivatives of the forward dynamics at one point, as the shooting stages take them: in closed
//! form ([`AnalyticDynamics`], the default) or by automatic differentiation ([`AdDynamics`], the test
//! oracle).

use crate::ad::Diff;
use crate::model::{DynamicsDerivatives, DynamicsFn, Robot, Scratch};
use std::sync::Arc;

/// Exact derivatives of the forward dynamics `qdd(y)`, `y = [q (n), qd (n), tau (n - 1)]`, at one point:
/// the seam through which the shooting problem gets them (automatic differentiation now, the closed
/// form later; the AD path then stays as the test oracle). Layouts as [`crate::ad::Diff`]:
/// Jacobian row-major `n x (3n - 1)`, Hessian full symmetric row-major `(3n - 1) x (3n - 1)`.
pub trait PointDynamics: Send + Sized + 'static {
    /// Buffers for `robot` (allocated once; the robot shared, not copied).
    fn new(robot: &Arc<Robot>) -> Self;
    /// `qdd = f(y)`.
    fn value(&mut self, y: &[f64], qdd: &mut [f64]);
    /// `qdd = f(y)` and its Jacobian.
    fn jacobian(&mut self, y: &[f64], qdd: &mut [f64], jac: &mut [f64]);
    /// Hessian of `w . qdd(y)` (w: n weights).
    fn hessian_weighted(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]);
    /// [`Self::hessian_weighted`] where `y` may be the input of this object's last
    /// [`Self::jacobian`] call (`value` calls in between allowed), whose work an implementation may
    /// reuse; it must check that `y` is that input. The default recomputes.
    fn hessian_weighted_reuse(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        self.hessian_weighted(y, w, hess);
    }
}

/// [`PointDynamics`] by forward-mode automatic differentiation ([`DynamicsFn`] through [`Diff`]).
pub struct AdDynamics {
    f: DynamicsFn,
    diff: Diff<DynamicsFn>,
}

impl PointDynamics for AdDynamics {
    fn new(robot: &Arc<Robot>) -> Self {
        let f = DynamicsFn::new(Arc::clone(robot));
        AdDynamics {
            diff: Diff::new(&f),
            f,
        }
    }
    fn value(&mut self, y: &[f64], qdd: &mut [f64]) {
        self.diff.value(&self.f, y, qdd);
    }
    fn jacobian(&mut self, y: &[f64], qdd: &mut [f64], jac: &mut [f64]) {
        self.diff.jacobian(&self.f, y, qdd, jac);
    }
    fn hessian_weighted(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        self.diff.hessian_weighted(&self.f, y, w, hess);
    }
}

/// [`PointDynamics`] in closed form ([`DynamicsDerivatives`]); values by
/// [`Robot::forward_dynamics_into`], the same arithmetic as [`crate::integrate::Rk4`]. The default.
pub struct AnalyticDynamics {
    robot: Arc<Robot>,
    ws: Scratch<f64>,
    d: DynamicsDerivatives,
    /// Input of the last `jacobian` call (`d` still holds its factorisation), if any.
    jac_y: Vec<f64>,
    jac_valid: bool,
}

impl PointDynamics for AnalyticDynamics {
    fn new(robot: &Arc<Robot>) -> Self {
        AnalyticDynamics {
            ws: Scratch::new(robot.n),
            d: DynamicsDerivatives::new(robot),
            jac_y: vec![0.0; 3 * robot.n - 1],
            jac_valid: false,
            robot: Arc::clone(robot),
        }
    }
    #[inline]
    fn value(&mut self, y: &[f64], qdd: &mut [f64]) {
        let n = self.robot.n;
        self.robot
            .forward_dynamics_into(&mut self.ws, &y[..n], &y[n..2 * n], &y[2 * n..], qdd);
        // a first-order evaluation at the same point (the accepted trial point) reuses them
        let (sn, cs) = self.ws.trig();
        self.d.provide_trig(&y[..n], sn, cs);
    }
    #[inline]
    fn jacobian(&mut self, y: &[f64], qdd: &mut [f64], jac: &mut [f64]) {
        self.d.jacobian(&self.robot, y, qdd, jac);
        self.jac_y.copy_from_slice(y);
        self.jac_valid = true;
    }
    #[inline]
    fn hessian_weighted(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        self.d.hessian_weighted(&self.robot, y, w, hess);
        self.jac_y.copy_from_slice(y);
        self.jac_valid = true;
    }
    #[inline]
    fn hessian_weighted_reuse(&mut self, y: &[f64], w: &[f64], hess: &mut [f64]) {
        if self.jac_valid && self.jac_y == y {
            self.d.hessian_weighted_after_jacobian(&self.robot, w, hess);
        } else {
            self.hessian_weighted(y, w, hess);
        }
    }
}
