//! The adaptive MPC fed the online mass estimate, tracking a swing on a model plant under sensor
//! noise: the runs of the estimation tests.
//!
//! Units: rad, rad/s, s.

use brachia::control::{Adaptive, Mpc, MpcSettings, ParamEstimatorSettings};
use brachia::model::Robot;
use brachia::sim::{run_closed_loop, ModelPlant, NoiseSettings, Noisy, RunSettings};
use brachia::trajectory::Trajectory;
use std::sync::Arc;

/// The paper's robot with per-link mass and inertia factors.
pub fn scaled(mass: &[f64], inertia: &[f64]) -> Robot {
    let mut p = Robot::paper().params().clone();
    for (j, l) in p.links.iter_mut().enumerate() {
        l.mass *= mass[j];
        l.inertia *= inertia[j];
    }
    Robot::from_params(p, "scaled").unwrap()
}

/// The adaptive MPC (the paper's robot as its nominal model, estimator settings `es`) tracking
/// `reference` on the model plant of `plant` for `duration_s`, with sensor noise `noise_scale` x
/// (sigma_q = 0.0015 rad, sigma_qd = 0.015 rad/s) seeded `seed`: the controller after the run.
pub fn adaptive_run(
    reference: &Arc<Trajectory>,
    plant: &Robot,
    es: ParamEstimatorSettings,
    noise_scale: f64,
    seed: u64,
    duration_s: f64,
) -> Adaptive<Mpc> {
    let nominal = Arc::new(Robot::paper());
    let mpc = Mpc::new(
        Arc::clone(&nominal),
        Arc::clone(reference),
        MpcSettings::default(),
    )
    .unwrap();
    let mut c = Adaptive::new(mpc, Arc::clone(&nominal), es).unwrap();
    let x0 = [reference.q(0), reference.qd(0)].concat();
    let mut mp = ModelPlant::new(plant.clone(), &x0);
    let noise = NoiseSettings {
        q_std: 0.0015 * noise_scale,
        qd_std: 0.015 * noise_scale,
        seed,
    };
    let mut p = Noisy::new(Box::new(&mut mp), noise).unwrap();
    let rs = RunSettings {
        duration_s,
        control_dt: 1e-3,
        cancel: None,
    };
    run_closed_loop(&mut p, &mut c, reference, &nominal, &rs).unwrap();
    c
}
