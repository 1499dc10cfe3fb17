//! The model plant: the robot's own dynamics integrated by RK4 with sub-steps.
//!
//! State `[q, qd]` (rad, rad/s), torques of joints 2..n in N m, clamped to the robot's limits.

use super::{Plant, StepClock};
use crate::integrate::Rk4;
use crate::model::Robot;
use std::sync::Arc;

/// RK4 simulation of the model; `substeps` RK4 steps per call to [`Plant::step`].
#[derive(Debug, Clone)]
pub struct ModelPlant {
    robot: Arc<Robot>,
    rk4: Rk4,
    x: Vec<f64>,
    clock: StepClock,
    tau: Vec<f64>,
    /// RK4 steps per `step` call (default 1; at 1 ms one step conserves energy to ~1e-9 relative).
    pub substeps: usize,
}

impl ModelPlant {
    /// A plant starting at `x0 = [q, qd]` at t = 0. `robot` may be an owned `Robot` or a shared
    /// `Arc<Robot>`.
    ///
    /// # Panics
    /// When `x0` does not hold 2n values (a programmer's error).
    pub fn new(robot: impl Into<Arc<Robot>>, x0: &[f64]) -> Self {
        let robot: Arc<Robot> = robot.into();
        assert_eq!(x0.len(), robot.nx(), "x0 must hold [q, qd]");
        ModelPlant {
            rk4: Rk4::new(&robot),
            x: x0.to_vec(),
            clock: StepClock::new(0.0),
            tau: vec![0.0; robot.nu()],
            robot,
            substeps: 1,
        }
    }

    /// The robot simulated.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }
}

impl Plant for ModelPlant {
    fn n_links(&self) -> usize {
        self.robot.n
    }
    fn time(&self) -> f64 {
        self.clock.time()
    }
    fn state(&self, x: &mut [f64]) {
        x.copy_from_slice(&self.x);
    }
    fn step(&mut self, tau: &[f64], dt: f64) {
        for j in 0..self.tau.len() {
            self.tau[j] = tau[j].clamp(self.robot.tau_min[j], self.robot.tau_max[j]);
        }
        self.rk4
            .advance(&self.robot, &mut self.x, &self.tau, dt, self.substeps);
        self.clock.advance(dt);
    }
    fn energy(&self) -> f64 {
        let n = self.robot.n;
        self.robot.energy(&self.x[..n], &self.x[n..])
    }
    fn name(&self) -> &'static str {
        "model"
    }
    /// An impulse changes the velocity at once: `M(q) dqd = J_p(q)^T impulse`, with `J_p` the
    /// Jacobian of the pushed point ([`super::point_jacobian`]); the angles do not jump.
    fn push(&mut self, link: usize, point_m: f64, impulse: [f64; 2]) -> crate::Result<()> {
        let n = self.robot.n;
        if link >= n || !point_m.is_finite() || !impulse.iter().all(|v| v.is_finite()) {
            return Err(crate::Error::invalid(
                "ModelPlant",
                "push",
                format!("link {link}, point {point_m} m, impulse {impulse:?}"),
                format!("needs a link 0..{n} and finite values"),
            ));
        }
        let mut jac = vec![0.0; 2 * n];
        super::point_jacobian(&self.robot, &self.x[..n], link, point_m, &mut jac);
        let mut m = self.robot.mass_matrix(&self.x[..n]);
        let mut dqd: Vec<f64> = (0..n)
            .map(|i| jac[i] * impulse[0] + jac[n + i] * impulse[1])
            .collect();
        if brachia_linalg::cholesky_solve_in_place(
            &mut m,
            n,
            &mut dqd,
            brachia_linalg::Scaling::Reciprocal,
            brachia_linalg::Scaling::Divide,
        )
        .is_err()
        {
            return Err(crate::Error::invalid(
                "ModelPlant",
                "push",
                format!("{impulse:?}"),
                "the mass matrix at the plant's state is not positive definite",
            ));
        }
        for i in 0..n {
            self.x[n + i] += dqd[i];
        }
        Ok(())
    }
}
