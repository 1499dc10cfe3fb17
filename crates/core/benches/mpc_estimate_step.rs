//! The MPC control step with the online mass estimate (`Adaptive<Mpc>`: the estimator's regressors
//! and window sums every step, an RLS update and a model rebuild every window) against the plain MPC
//! step on the same states of a closed-loop run from a perturbed start (4 links, default settings).
//! A manual pass prints the median and p99 of single calls of both in the same run (docs/estimation.md
//! "Cost").
//!
//! `cargo bench -p brachia --bench mpc_estimate_step`

#[path = "../tests/common/mod.rs"]
mod common;

use brachia::control::{Adaptive, Mpc, MpcSettings, ParamEstimatorSettings};
use brachia::sim::{Controller, ModelPlant, Plant};
use common::*;
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use std::time::Instant;

fn states(robot: &brachia::Robot, tr: &brachia::trajectory::Trajectory) -> Vec<(f64, Vec<f64>)> {
    let mut x0 = start_state();
    x0[1] += 0.1;
    x0[2] -= 0.1;
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), MpcSettings::default()).unwrap();
    let (mut x, mut tau) = (vec![0.0; 8], vec![0.0; 3]);
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
trait Restart: Controller {
    fn restart(&mut self);
}
impl Restart for Mpc {
    fn restart(&mut self) {
        self.reset();
    }
}
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
    let controllers: Vec<(&str, Box<dyn Restart>)> = vec![
        ("mpc_step default", Box::new(mpc())),
        ("mpc_step with mass estimate", Box::new(adaptive)),
    ];
    for (name, mut ctrl) in controllers {
        let mut tau = vec![0.0; 3];
        let mut us = Vec::with_capacity(3 * xs.len());
        for _ in 0..3 {
            ctrl.restart();
            for (t, x) in &xs {
                let s = Instant::now();
                ctrl.control(*t, x, &mut tau);
                us.push(s.elapsed().as_secs_f64() * 1e6);
            }
        }
        us.sort_by(f64::total_cmp);
        let p = |q: f64| us[((q * (us.len() - 1) as f64).round()) as usize];
        eprintln!(
            "{name}: single calls median {:.1} us, p99 {:.1} us, max {:.1} us",
            p(0.5),
            p(0.99),
            us[us.len() - 1]
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

criterion_group!(benches, bench);
criterion_main!(benches);
