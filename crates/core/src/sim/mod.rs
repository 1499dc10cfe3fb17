//! Plants (what a controller runs against), controllers, and the closed-loop runner.
//!
//! A [`Plant`] reports the measured state in the paper's convention (`x = [q, qd]`, q1 absolute, the
//! rest relative; rad, rad/s) and advances under joint torques (N m, joints 2..n) held for one control
//! period. A [`Controller`] maps time and measured state to torques. The runner, not the controllers,
//! keeps the logs.

mod model_plant;
mod runner;

pub use model_plant::ModelPlant;
pub use runner::{run_closed_loop, ClosedLoopLog, RunSettings, RunSummary};

/// Something a controller can drive: a simulator of the model, a physics engine, a wrapper adding noise.
pub trait Plant {
    /// Number of links n.
    fn n_links(&self) -> usize;
    /// Simulated time, s.
    fn time(&self) -> f64;
    /// Measured state `[q (n), qd (n)]`, written into `x` (2n).
    fn state(&self, x: &mut [f64]);
    /// Apply `tau` (n - 1 values, N m; the plant clamps them to its torque limits) for `dt` seconds.
    fn step(&mut self, tau: &[f64], dt: f64);
    /// Total mechanical energy of the robot, J (for drift checks).
    fn energy(&self) -> f64;
    /// A short name for reports (`model`, `rapier`).
    fn name(&self) -> &'static str;
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
}
