//! The MPC control step with the online mass estimate (`Adaptive<Mpc>`; default settings: the joint
//! state and parameter filter's prediction and update every step and a model rebuild every 50 ms;
//! `method = "windows"`: the regressors and window sums every step, an RLS update and a model
//! rebuild every window) against the plain MPC step on the same states of a closed-loop run from a
//! perturbed start (4 links).
//! A manual pass prints the median and p99 of single calls of both in the same run (docs/estimation.md
//! "Cost").
//!
//! `cargo bench -p brachia --bench mpc_estimate_step`

#[path = "../tests/common/mod.rs"]
mod common;

mod shared;
#[path = "step_timing/mod.rs"]
mod step_timing;

use brachia::control::{Adaptive, EstimateMethod, Mpc, MpcSettings, ParamEstimatorSettings};
use common::*;
use criterion::{criterion_group, criterion_main, Criterion};
use step_timing::{states, time_controllers, Restart};

impl Restart for Adaptive<Mpc> {
    fn restart(&mut self) {
        self.reset();
        self.inner_mut().reset();
    }
}

fn bench(c: &mut Criterion) {
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let xs = states(&robot, &tr);
    let mpc = || Mpc::new(robot.clone(), tr.clone(), MpcSettings::default()).unwrap();
    let adaptive = Adaptive::new(mpc(), robot.clone(), ParamEstimatorSettings::default()).unwrap();
    let windows = ParamEstimatorSettings {
        method: EstimateMethod::Windows,
        ..Default::default()
    };
    let windowed = Adaptive::new(mpc(), robot.clone(), windows).unwrap();
    let controllers: Vec<(&str, Box<dyn Restart>)> = vec![
        ("mpc_step default", Box::new(mpc())),
        ("mpc_step with mass estimate", Box::new(adaptive)),
        ("mpc_step with windowed mass estimate", Box::new(windowed)),
    ];
    time_controllers(c, controllers, &xs, robot.nu());
}

criterion_group!(benches, bench);
criterion_main!(benches);
