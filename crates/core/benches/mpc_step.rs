//! A whole MPC control step (linearise + discretise + condense + QP) on the states of a closed-loop
//! run from a perturbed start (4 links, default settings: horizon 20, dt_mpc 20 ms, ZOH, rate
//! penalty 0.1). Criterion reports the mean per call over the sequence; a manual pass prints the
//! median and p99 of single calls. Also: the MPC without the rate penalty (the baseline of the same
//! run), the MPC behind the Kalman filter (`Estimated<Mpc>`), and the TVLQR.

#[path = "../tests/common/mod.rs"]
mod common;

use brachia::control::{
    Discretization, Estimated, EstimatorSettings, Linearization, Mpc, MpcSettings, Tvlqr,
    TvlqrSettings,
};
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
    for (name, mut mpc) in controllers {
        let mut tau = vec![0.0; 3];
        // Manual percentiles over 3 passes of the run.
        let mut us = Vec::with_capacity(3 * xs.len());
        for _ in 0..3 {
            mpc.restart();
            for (t, x) in &xs {
                let s = Instant::now();
                mpc.control(*t, x, &mut tau);
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
        mpc.restart();
        c.bench_function(name, |b| {
            b.iter(|| {
                k = (k + 1) % xs.len();
                if k == 0 {
                    mpc.restart();
                }
                black_box(mpc.control(xs[k].0, &xs[k].1, &mut tau))
            })
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
