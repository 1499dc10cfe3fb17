//! A whole MPC control step (linearise + discretise + condense + QP) on the states of a closed-loop
//! run from a perturbed start (4 links, default settings: horizon 20, dt_mpc 20 ms, ZOH, rate
//! penalty 0.1). Criterion reports the mean per call over the sequence; a manual pass prints the
//! median and p99 of single calls. Also: the MPC without the rate penalty (the baseline of the same
//! run), the MPC behind the Kalman filter (`Estimated<Mpc>`), and the TVLQR.

#[path = "../tests/common/mod.rs"]
mod common;

mod shared;
#[path = "step_timing/mod.rs"]
mod step_timing;

use brachia::control::{
    Discretization, Estimated, EstimatorSettings, Linearization, Mpc, MpcSettings, Tvlqr,
    TvlqrSettings,
};
use common::*;
use criterion::{criterion_group, criterion_main, Criterion};
use step_timing::{states, time_controllers, Restart};

impl Restart for Estimated<Mpc> {
    fn restart(&mut self) {
        self.reset();
        self.inner_mut().reset();
    }
}
impl Restart for Tvlqr {
    fn restart(&mut self) {}
}

fn bench(c: &mut Criterion) {
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let xs = states(&robot, &tr);
    let variants = [
        ("mpc_step default (zoh, measured)", MpcSettings::default()),
        (
            "mpc_step no rate penalty",
            MpcSettings {
                rate_diag: vec![0.0; 3],
                ..MpcSettings::default()
            },
        ),
        (
            "mpc_step euler",
            MpcSettings {
                discretization: Discretization::Euler,
                ..MpcSettings::default()
            },
        ),
        (
            "mpc_step ltv along reference",
            MpcSettings {
                linearization: Linearization::AlongReference,
                ..MpcSettings::default()
            },
        ),
    ];
    let mut controllers: Vec<(&str, Box<dyn Restart>)> = Vec::new();
    for (name, settings) in variants {
        controllers.push((
            name,
            Box::new(Mpc::new(robot.clone(), tr.clone(), settings).unwrap()),
        ));
    }
    let mpc = Mpc::new(robot.clone(), tr.clone(), MpcSettings::default()).unwrap();
    let kf = Estimated::new(
        mpc,
        robot.clone(),
        tr.clone(),
        EstimatorSettings::default(),
        1e-3,
    );
    controllers.push(("mpc_step with kalman filter", Box::new(kf.unwrap())));
    let lqr = Tvlqr::new(robot.clone(), tr.clone(), TvlqrSettings::default()).unwrap();
    controllers.push(("tvlqr step", Box::new(lqr)));
    time_controllers(c, controllers, &xs, robot.nu());
}

criterion_group!(benches, bench);
criterion_main!(benches);
