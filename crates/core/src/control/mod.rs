//! Feedback controllers and their solvers: the box QP, the linear MPC of the paper's Section IV, and
//! baselines. Every controller implements [`crate::sim::Controller`].
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative),
//! input `u = tau` = torques of joints 2..n (N m), gravity along -y.

pub mod boxqp;

pub use boxqp::{BoxQp, BoxQpInfo, BoxQpSettings, BoxQpStatus};
pub mod baselines;
pub mod mpc;

pub use baselines::{OpenLoop, Pd, PdSettings};
pub use mpc::{Discretization, Linearization, Mpc, MpcSettings, Prediction, TorqueReference};
