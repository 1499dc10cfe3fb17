//! The timing loop the control-step benches share: the states of a closed-loop run of the MPC from a
//! perturbed start, and for each controller a manual pass (median, p99 and max of single calls over
//! three passes of the run) followed by criterion's mean over the same sequence.

use crate::common::*;
use crate::shared::quantile;
use brachia::control::{Mpc, MpcSettings};
use brachia::sim::{Controller, ModelPlant, Plant};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use criterion::{black_box, Criterion};
use std::time::Instant;

/// The (time, state) pairs of 1.5 s of the default MPC tracking `tr` on the model plant from the
/// start state with joints 2 and 3 perturbed by +-0.1 rad.
pub fn states(robot: &Robot, tr: &Trajectory) -> Vec<(f64, Vec<f64>)> {
    let mut x0 = start_state();
    x0[1] += 0.1;
    x0[2] -= 0.1;
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), MpcSettings::default()).unwrap();
    let (mut x, mut tau) = (vec![0.0; robot.nx()], vec![0.0; robot.nu()]);
    let mut out = Vec::new();
    for _ in 0..1500 {
        plant.state(&mut x);
        out.push((plant.time(), x.clone()));
        mpc.control(plant.time(), &x, &mut tau);
        plant.step(&tau, 1e-3);
    }
    out
}

/// A controller that can start cold again (for repeated passes over the same states).
pub trait Restart: Controller {
    fn restart(&mut self);
}

impl Restart for Mpc {
    fn restart(&mut self) {
        self.reset();
    }
}

/// Time every controller on `xs` (`nu` torques): the manual percentiles printed to stderr, then a
/// criterion benchmark under the controller's name.
pub fn time_controllers(
    c: &mut Criterion,
    controllers: Vec<(&str, Box<dyn Restart>)>,
    xs: &[(f64, Vec<f64>)],
    nu: usize,
) {
    for (name, mut ctrl) in controllers {
        let mut tau = vec![0.0; nu];
        let mut us = Vec::with_capacity(3 * xs.len());
        for _ in 0..3 {
            ctrl.restart();
            for (t, x) in xs {
                let s = Instant::now();
                ctrl.control(*t, x, &mut tau);
                us.push(s.elapsed().as_secs_f64() * 1e6);
            }
        }
        eprintln!(
            "{name}: single calls median {:.1} us, p99 {:.1} us, max {:.1} us",
            quantile(&us, 0.5),
            quantile(&us, 0.99),
            quantile(&us, 1.0)
        );
        let mut k = 0;
        ctrl.restart();
        c.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) % xs.len();
                if k == 0 {
                    ctrl.restart();
                }
                black_box(ctrl.control(xs[k].0, &xs[k].1, &mut tau))
            })
        });
    }
}
