//! Shared fixtures of the control tests: the paper's robot (Table I) and a feasible reference made by
//! simulating the model plant under small smooth torques.
#![allow(dead_code)]

pub mod estimate;
pub mod oracle;
pub mod placement;
pub mod replan_model;

use brachia::model::{ActuatorParams, LinkParams, Robot, RobotParams};
use brachia::sim::{ModelPlant, Plant};
use brachia::trajectory::Trajectory;
use brachia_ocp::{Multipliers, OcpDims};
use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// The paper's start pose, at rest.
pub const Q_START: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];

/// The paper's 4-link robot with torque limits `+-tau_limit`.
pub fn paper_robot(tau_limit: f64) -> Robot {
    let mass = [0.35, 0.56, 0.56, 0.35];
    let com = [0.2059, 0.1832, 0.1718, 0.1491];
    let inertia = [0.98, 0.10, 0.10, 0.98];
    let links = (0..4)
        .map(|i| LinkParams {
            length: 0.355,
            mass: mass[i],
            com: com[i],
            inertia: inertia[i],
            radius: 0.02,
            ..Default::default()
        })
        .collect();
    chain_robot("paper", links, tau_limit)
}

/// A robot of the given links, gravity 9.81 m/s^2, torque limits `+-tau_limit` N m on joints 2..n.
pub fn chain_robot(name: &str, links: Vec<LinkParams>, tau_limit: f64) -> Robot {
    let n = links.len();
    let params = RobotParams {
        name: name.into(),
        gravity: 9.81,
        links,
        actuators: ActuatorParams {
            tau_min: vec![-tau_limit; n - 1],
            tau_max: vec![tau_limit; n - 1],
        },
        end_effector: None,
    };
    Robot::from_params(params, "<test>").expect("valid test robot")
}

/// Smooth torque profile used to make references, N m.
pub fn torque_profile(t: f64, tau: &mut [f64]) {
    let pi2 = 2.0 * std::f64::consts::PI;
    tau[0] = 1.2 * (pi2 * 0.8 * t).sin();
    tau[1] = -0.9 * (pi2 * 1.1 * t + 0.4).sin() + 0.3;
    tau[2] = 0.6 * (pi2 * 1.5 * t + 1.0).sin();
}

/// Simulate the model plant from `x0` for `duration` s at 1 ms under [`torque_profile`]: a reference
/// the robot can follow exactly (sample k holds the state at t_k and the torque held over
/// [t_k, t_k + 1 ms)).
pub fn model_reference(robot: &Robot, x0: &[f64], duration: f64) -> Trajectory {
    let mut plant = ModelPlant::new(robot.clone(), x0);
    let mut tr = Trajectory::new(robot.n());
    let steps = (duration / 1e-3).round() as usize;
    let mut x = vec![0.0; robot.nx()];
    let mut tau = vec![0.0; robot.nu()];
    for _ in 0..=steps {
        let t = plant.time();
        plant.state(&mut x);
        torque_profile(t, &mut tau);
        tr.push(t, &x[..robot.n()], &x[robot.n()..], &tau);
        plant.step(&tau, 1e-3);
    }
    tr
}

/// Paper start state `[q, 0]`.
pub fn start_state() -> Vec<f64> {
    let mut x = Q_START.to_vec();
    x.extend([0.0; 4]);
    x
}

/// Multipliers of `dims` (transitions, stage rows, terminal rows) drawn uniformly from (-1, 1), for
/// the Lagrangian-Hessian checks of [`brachia::fdcheck::assert_ocp_derivatives`].
pub fn random_multipliers(rng: &mut ChaCha8Rng, dims: &OcpDims) -> Multipliers {
    let mut m = Multipliers::zeros(dims);
    for v in m
        .lam
        .iter_mut()
        .chain(m.mu.iter_mut())
        .flat_map(|v| v.iter_mut())
        .chain(m.nu.iter_mut())
    {
        *v = rng.gen_range(-1.0..1.0);
    }
    m
}

/// The paper's swing (`Robot::paper()`, `SwingTask::paper()`) planned by multiple shooting on the
/// 30 ms mesh with the OCP backend; asserts that it converged.
pub fn paper_swing() -> std::sync::Arc<Trajectory> {
    let (_, plan) = replan_model::planned(&std::sync::Arc::new(Robot::paper()));
    std::sync::Arc::new(plan.trajectory)
}
