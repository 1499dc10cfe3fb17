//! # brachia
//!
//! Energy-optimal swings for underactuated brachiation robots: the planar n-link model, an offline
//! direct-collocation planner, a linear MPC tracker and the plants they run against.
//!
//! ## Conventions (stated once here; repeated in file headers and CSV headers)
//! - **Frame**: planar, body frame at the grip point (origin), x to the right, y up; gravity along -y.
//! - **Angles** (rad): `q[0]` = absolute angle of link 1 from +x, counter-clockwise positive (the passive
//!   grip joint); `q[i]`, i >= 1, = angle of link i+1 relative to link i (actuated). Absolute angle of
//!   link i: `th_i = q_0 + ... + q_i`.
//! - **State** `x = [q (n), qd (n)]`; **input** `u = tau` = torques of joints 2..n (n - 1), so
//!   `B = [0; I]`. The end effector (EE) is the distal tip of link n.
//! - **Units**: SI throughout (m, kg, s, rad, N m, J).
//!
//! ## Layout
//! - [`model`]: parameters ([`model::Robot`]), kinematics, dynamics `M qdd + C qd + G = B tau`, exact
//!   derivatives through [`ad`].
//! - [`integrate`]: integrators over the same `f(x, u)` (RK4 with sub-steps).
//! - [`trajectory`]: time series of states and torques, Hermite resampling, CSV.
//! - [`sim`]: the `Plant` and `Controller` traits, the model plant.
//! - [`fdcheck`]: the single finite-difference helper every derivative test uses.

pub mod ad;
pub mod control;
pub mod error;
pub mod fdcheck;
pub mod geometry;
pub mod integrate;
pub mod limits;
pub mod math;
pub mod model;
pub mod planning;
pub mod serde_exact;

pub use error::{Error, Result};
pub use model::Robot;
pub mod sim;
pub mod trajectory;
