//! # brachia-rapier
//!
//! The physics-engine plant of brachia: the robot's link chain simulated by
//! [rapier2d-f64](https://rapier.rs) 0.36 with contacts against obstacles (fixed circles, free balls).
//! This is the only crate of the workspace that sees rapier.
//!
//! ## Conventions (the same as [`brachia`])
//! - Planar world, the grip point (joint 1) at the origin, x to the right, y up, gravity along -y.
//! - State `x = [q (n), qd (n)]`: `q[0]` absolute angle of link 1 from +x (counter-clockwise
//!   positive), `q[i >= 1]` angle of link i+1 relative to link i; rad and rad/s. Angles are continuous
//!   (never wrapped to (-pi, pi]).
//! - Input `tau` = torques of joints 2..n (n - 1 values, N m), clamped to the robot's limits and held
//!   for the control period.
//! - SI units throughout (m, kg, s, rad, N m, N s, J).
//!
//! ## Construction
//! Each link is a dynamic rigid body whose frame sits at its proximal joint with the x axis along the
//! link; its collider is a capsule from joint to joint with the robot's radius, with zero density,
//! and its mass properties (mass, centre of mass at `com` along the link, planar inertia) are set
//! exactly from the robot's parameters. The links are joined by reduced-coordinate (multibody)
//! revolute joints, the first one hinged at the origin to a fixed root body. See `docs/rapier.md` for
//! the traps of rapier this crate handles (default joint damping, initial coordinates, adjacent-link
//! contacts, torque mapping).

mod obstacle;
mod plant;
mod settings;

pub use obstacle::{Ball, Circle, ContactBody, ContactEvent, Obstacle};
pub use plant::{LinkMassProperties, RapierPlant, Regrip, REGRIP_TOLERANCE_M};
pub use settings::RapierSettings;
