//! Integrators over the model's `xdot = f(x, u)`.
//!
//! State `x = [q, qd]` (2n), input `u = tau` (n - 1) held constant over a step (zero-order hold).
//! Time in s.

use crate::model::{Robot, Scratch};

/// Classic fourth-order Runge-Kutta for the robot, with reusable buffers (no allocation per step).
#[derive(Debug, Clone)]
pub struct Rk4 {
    ws: Scratch<f64>,
    k: [Vec<f64>; 4],
    tmp: Vec<f64>,
}

impl Rk4 {
    /// Buffers for an n-link robot.
    pub fn new(robot: &Robot) -> Self {
        let nx = robot.nx();
        Rk4 {
            ws: Scratch::new(robot.n),
            k: std::array::from_fn(|_| vec![0.0; nx]),
            tmp: vec![0.0; nx],
        }
    }

    /// `xdot = f(x, u)` into `out`.
    pub fn deriv(&mut self, robot: &Robot, x: &[f64], u: &[f64], out: &mut [f64]) {
        deriv(robot, &mut self.ws, x, u, out);
    }

    /// One RK4 step of length `dt` in place.
    pub fn step(&mut self, robot: &Robot, x: &mut [f64], u: &[f64], dt: f64) {
        let ws = &mut self.ws;
        rk4_step(x, dt, &mut self.k, &mut self.tmp, |_, x, out| {
            deriv(robot, ws, x, u, out)
        });
    }

    /// Advance by `dt` in `substeps` equal RK4 steps.
    pub fn advance(&mut self, robot: &Robot, x: &mut [f64], u: &[f64], dt: f64, substeps: usize) {
        let h = dt / substeps.max(1) as f64;
        for _ in 0..substeps.max(1) {
            self.step(robot, x, u, h);
        }
    }
}

/// Where in a step [`rk4_step`] samples the right-hand side: a time-varying input (a torque profile)
/// is evaluated at the step's start, its middle (stages 2 and 3) or its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StepPoint {
    /// `t`.
    Start,
    /// `t + dt / 2`.
    Middle,
    /// `t + dt`.
    End,
}

/// One classic fourth-order Runge-Kutta step of length `dt` of `xdot = f(point, x)` in place, with
/// caller-owned stage buffers (`k[i]` and `tmp` at least `x.len()` long; no allocation). `f` writes
/// `xdot` into its last argument. The one RK4 of the crate: [`Rk4`] (the robot's model), the open-loop
/// replay of a torque profile and the locked-chain free fall use it.
pub fn rk4_step(
    x: &mut [f64],
    dt: f64,
    k: &mut [Vec<f64>; 4],
    tmp: &mut [f64],
    mut f: impl FnMut(StepPoint, &[f64], &mut [f64]),
) {
    let nx = x.len();
    let [k1, k2, k3, k4] = k;
    f(StepPoint::Start, x, k1);
    for i in 0..nx {
        tmp[i] = x[i] + 0.5 * dt * k1[i];
    }
    f(StepPoint::Middle, &tmp[..nx], k2);
    for i in 0..nx {
        tmp[i] = x[i] + 0.5 * dt * k2[i];
    }
    f(StepPoint::Middle, &tmp[..nx], k3);
    for i in 0..nx {
        tmp[i] = x[i] + dt * k3[i];
    }
    f(StepPoint::End, &tmp[..nx], k4);
    for i in 0..nx {
        x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
}

/// `xdot = [qd, qdd(q, qd, u)]`.
pub fn deriv(robot: &Robot, ws: &mut Scratch<f64>, x: &[f64], u: &[f64], out: &mut [f64]) {
    let n = robot.n;
    out[..n].copy_from_slice(&x[n..]);
    let (q, qd) = x.split_at(n);
    robot.forward_dynamics_into(ws, q, qd, u, &mut out[n..]);
}
