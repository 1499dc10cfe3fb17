//! The robot model: parameters, kinematics, dynamics and their exact derivatives.

mod analytic;
mod clearance_derivatives;
mod collision;
mod derivatives;
mod dynamics;
mod kinematics;
mod params;
mod reroot;

pub use analytic::DynamicsDerivatives;
pub use clearance_derivatives::{ClearanceDerivatives, ClearanceForm, ClearanceRecord};
pub use collision::{Circle, ClearanceFn, ClearancePair, LinkSet};
pub use derivatives::{DynamicsFn, LinearModel, Linearizer};
pub use dynamics::Scratch;
pub use kinematics::{ik_from_seed, mirrored_pose, wrap_angle, P2};
pub use params::{ActuatorParams, LinkParams, Robot, RobotParams, MAX_LINKS, PAPER_TOML};
pub use reroot::{reroot_jacobian, reroot_state, reroot_tau, switch_grip, GripSwitch};
