//! Exact derivatives of the forward dynamics, and the linearisation used by the MPC.
//!
//! [`DynamicsFn`] presents `qdd(z)` with `z = [q, qd, tau]` (2n + n - 1 inputs, n outputs) to the
//! automatic-differentiation engine in [`crate::ad`]. Second derivatives that are zero by structure
//! (qdd is linear in tau, and qd and tau never multiply) are declared so and skipped. Production code
//! uses the closed forms of [`super::DynamicsDerivatives`]; `DynamicsFn` with [`crate::ad::Diff`] is
//! their test oracle.
//!
//! [`Linearizer`] builds the MPC's continuous-time linear model from the analytic Jacobian.

use super::{DynamicsDerivatives, Robot, Scratch};
use crate::ad::LocalFn;
use crate::math::Scalar;
use std::sync::Arc;

/// Forward dynamics as a [`LocalFn`]: `z = [q (n), qd (n), tau (n-1)] -> qdd (n)`. Owns a shared
/// handle to its robot, so the transcriptions and the shooting problem that hold one own their data.
#[derive(Debug, Clone)]
pub struct DynamicsFn {
    /// The robot.
    pub robot: Arc<Robot>,
}

impl DynamicsFn {
    /// The forward dynamics of `robot` (a `Robot` or a shared `Arc<Robot>`).
    pub fn new(robot: impl Into<Arc<Robot>>) -> Self {
        DynamicsFn {
            robot: robot.into(),
        }
    }
}

impl LocalFn for DynamicsFn {
    type Scratch<T: Scalar> = Scratch<T>;

    fn n_in(&self) -> usize {
        3 * self.robot.n - 1
    }
    fn n_out(&self) -> usize {
        self.robot.n
    }
    fn scratch<T: Scalar>(&self) -> Scratch<T> {
        Scratch::new(self.robot.n)
    }
    fn eval<T: Scalar>(&self, ws: &mut Scratch<T>, z: &[T], out: &mut [T]) {
        let n = self.robot.n;
        self.robot
            .forward_dynamics_into(ws, &z[..n], &z[n..2 * n], &z[2 * n..], out);
    }
    fn hessian_entry_is_zero(&self, i: usize, j: usize) -> bool {
        let n = self.robot.n;
        let (hi, lo) = if i >= j { (i, j) } else { (j, i) };
        // tau-tau: qdd is linear in tau; qd-tau: M does not depend on qd.
        hi >= 2 * n && lo >= n
    }
}

/// A continuous-time linearisation `xdot ~= A x + B u + F` about `(x*, u*)` (paper eq. 14), with the EE
/// output `y ~= C x + f` (eq. 16). Matrices are row-major: A is 2n x 2n, B is 2n x (n-1), C is 2 x 2n.
#[derive(Debug, Clone, PartialEq)]
pub struct LinearModel {
    /// State Jacobian, 2n x 2n.
    pub a: Vec<f64>,
    /// Input Jacobian, 2n x (n-1).
    pub b: Vec<f64>,
    /// Affine term `f(x*, u*) - A x* - B u*` (2n).
    pub f: Vec<f64>,
    /// EE output Jacobian, 2 x 2n (zero velocity columns).
    pub c: Vec<f64>,
    /// Output affine term `ee(q*) - C x*` (2).
    pub fy: Vec<f64>,
}

/// Reusable evaluator of [`LinearModel`]s for one robot (analytic Jacobian of qdd): allocates at
/// construction only. Owns a shared handle to its robot (`Arc<Robot>`), so it can be kept across
/// calls and moved between threads.
#[derive(Debug, Clone)]
pub struct Linearizer {
    robot: Arc<Robot>,
    dd: DynamicsDerivatives,
    z: Vec<f64>,
    qdd: Vec<f64>,
    jac: Vec<f64>,
    jee: Vec<f64>,
}

impl Linearizer {
    /// Buffers for `robot` (a `Robot` or an `Arc<Robot>` shared with other users).
    pub fn new(robot: impl Into<Arc<Robot>>) -> Self {
        let robot: Arc<Robot> = robot.into();
        let n = robot.n;
        Linearizer {
            dd: DynamicsDerivatives::new(&robot),
            z: vec![0.0; 3 * n - 1],
            qdd: vec![0.0; n],
            jac: vec![0.0; n * (3 * n - 1)],
            jee: vec![0.0; 2 * n],
            robot,
        }
    }

    /// The robot linearised.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// Exact Jacobian of qdd with respect to `[q, qd, tau]`, row-major n x (3n-1), and qdd itself.
    pub fn qdd_jacobian(&mut self, q: &[f64], qd: &[f64], tau: &[f64]) -> (&[f64], &[f64]) {
        let n = self.robot.n;
        self.z[..n].copy_from_slice(q);
        self.z[n..2 * n].copy_from_slice(qd);
        self.z[2 * n..].copy_from_slice(tau);
        self.dd
            .jacobian(&self.robot, &self.z, &mut self.qdd, &mut self.jac);
        (&self.qdd, &self.jac)
    }

    /// Linearise `xdot = f(x, u)` and `y = ee(q)` about `(x, u)`, writing into `out` (no allocation
    /// when `out` already has the right sizes).
    pub fn linearize_into(&mut self, x: &[f64], u: &[f64], out: &mut LinearModel) {
        let n = self.robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let nz = 3 * n - 1;
        self.qdd_jacobian(&x[..n], &x[n..], u);
        out.a.resize(nx * nx, 0.0);
        out.b.resize(nx * nu, 0.0);
        out.f.resize(nx, 0.0);
        out.c.resize(2 * nx, 0.0);
        out.fy.resize(2, 0.0);
        out.a.fill(0.0);
        for i in 0..n {
            out.a[i * nx + n + i] = 1.0;
            for j in 0..nx {
                out.a[(n + i) * nx + j] = self.jac[i * nz + j];
            }
            for j in 0..nu {
                out.b[i * nu + j] = 0.0;
                out.b[(n + i) * nu + j] = self.jac[i * nz + nx + j];
            }
        }
        for i in 0..nx {
            let fx = if i < n { x[n + i] } else { self.qdd[i - n] };
            let ax: f64 = (0..nx).map(|j| out.a[i * nx + j] * x[j]).sum();
            let bu: f64 = (0..nu).map(|j| out.b[i * nu + j] * u[j]).sum();
            out.f[i] = fx - ax - bu;
        }
        self.robot.ee_jacobian(&x[..n], &mut self.jee);
        let ee = self.robot.ee_position(&x[..n]);
        out.c.fill(0.0);
        for r in 0..2 {
            let mut cx = 0.0;
            for j in 0..n {
                out.c[r * nx + j] = self.jee[r * n + j];
                cx += self.jee[r * n + j] * x[j];
            }
            out.fy[r] = ee[r] - cx;
        }
    }
}

impl LinearModel {
    /// An empty model to be filled by [`Linearizer::linearize_into`].
    pub fn zeros(n: usize) -> Self {
        let (nx, nu) = (2 * n, n - 1);
        LinearModel {
            a: vec![0.0; nx * nx],
            b: vec![0.0; nx * nu],
            f: vec![0.0; nx],
            c: vec![0.0; 2 * nx],
            fy: vec![0.0; 2],
        }
    }
}
