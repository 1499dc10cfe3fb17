//! Shared parts of the reach-bound tests: the hook robot and its reduced model, the bound's grid.
#![allow(dead_code)]

use brachia::Robot;
use brachia_tools::reach_box::ReachSettings;
use brachia_tools::reduced_two_link::ReducedTwoLink;
use std::f64::consts::PI;

/// The two-link hook robot and its reduced model.
pub fn hook() -> (Robot, ReducedTwoLink) {
    let robot = brachia_tools::hook_robot().unwrap();
    let model = ReducedTwoLink::new(&robot).unwrap();
    (robot, model)
}

/// The tests' grid of the reach bound (coarser than the proofs'), steps of `dt` s.
pub fn reach_settings(dt: f64) -> ReachSettings {
    ReachSettings {
        dt,
        n_q2: 58,
        dz: 0.02,
        dh: 0.01,
        q2_max: 2.9,
        u_max: 15.0,
        q1_range: [-PI, 0.0],
        t_max: 1.3,
        bar: [0.34, 0.0],
        lambda: 0.549,
        target_split: 4,
    }
}
