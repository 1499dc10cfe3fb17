//! Measurement probes of brachia's planner, solver and MPC; the library part holds what more than one
//! probe or test uses.
pub mod reach_box;
pub mod reach_interval;
pub mod reach_model;
pub mod reach_sweep;
pub mod reduced_two_link;
pub mod swing_dp;

use brachia::model::RobotParams;
use brachia::Robot;

/// The two-link hook robot of `params/two-link-hook.toml` (the probes' and tests' robot of the
/// reduced two-link model).
pub fn hook_robot() -> brachia::Result<Robot> {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../params/two-link-hook.toml");
    Robot::from_params(RobotParams::from_toml_file(&path)?, "two-link-hook")
}
