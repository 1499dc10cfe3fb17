//! Shared helpers of the rapier plant tests: the paper's robot and plant-vs-plant comparisons.
//!
//! Conventions: x = [q, qd] (q[0] absolute from +x, the rest relative; rad, rad/s), tau = torques of
//! joints 2..n (N m), 1 ms control period.

#![allow(dead_code)]

use brachia::sim::{ModelPlant, Plant};
use brachia::Robot;
use brachia_rapier::{RapierPlant, RapierSettings};

/// The paper's start pose (at rest).
pub const Q_START: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];

/// Control period, s.
pub const DT: f64 = 1e-3;

/// The paper's 4-link robot (Table I, as interpreted in the project preamble: planar inertias
/// [0.98, 0.10, 0.10, 0.98] kg m^2).
pub fn paper_robot() -> Robot {
    robot_with_inertia([0.98, 0.10, 0.10, 0.98])
}

/// The same chain with planar inertias a hundred times smaller (the dependency study's robot): much
/// faster relative motion of the links, a harder test of the integrator.
pub fn light_robot() -> Robot {
    robot_with_inertia([0.0098, 0.001, 0.001, 0.0098])
}

/// The paper's robot (`params/paper.toml`, [`Robot::paper`]) with the given planar inertias (kg m^2).
pub fn robot_with_inertia(inertia: [f64; 4]) -> Robot {
    let mut params = Robot::paper().params().clone();
    for (link, i) in params.links.iter_mut().zip(inertia) {
        link.inertia = i;
    }
    Robot::from_params(params, "<test>").expect("paper robot is valid")
}

/// Agreement of two plants over a run.
#[derive(Debug, Clone)]
pub struct Agreement {
    /// max over time of |q_rapier - q_model| per joint, rad.
    pub max_dq: Vec<f64>,
    /// max over time of |qd_rapier - qd_model| per joint, rad/s.
    pub max_dqd: Vec<f64>,
    /// max over time of |E_rapier(t) - E_rapier(0)|, J.
    pub rapier_drift: f64,
    /// max over time of |E_model(t) - E_model(0)|, J (the RK4 reference drifts by ~1e-7 J when passive).
    pub model_drift: f64,
    /// |E_rapier(0)|, J.
    pub e0: f64,
}

impl Agreement {
    /// Largest joint-angle difference, rad.
    pub fn max_q(&self) -> f64 {
        self.max_dq.iter().cloned().fold(0.0, f64::max)
    }
}

/// Run the rapier plant (`substeps`) and the RK4 model plant side by side from `x0` for `steps`
/// control periods under `tau(t)` (the rapier plant receives `rapier_sign * tau(t)`: -1 emulates a
/// flipped torque convention).
pub fn compare_signed(
    robot: &Robot,
    x0: &[f64],
    substeps: usize,
    steps: usize,
    rapier_sign: f64,
    tau: impl Fn(f64) -> Vec<f64>,
) -> Agreement {
    let settings = RapierSettings {
        substeps,
        ..RapierSettings::default()
    };
    let mut rp = RapierPlant::new(robot, x0, &settings).expect("plant builds");
    let mut mp = ModelPlant::new(robot.clone(), x0);
    let n = robot.n();
    let (mut xr, mut xm) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
    let (er0, em0) = (rp.energy(), mp.energy());
    let mut a = Agreement {
        max_dq: vec![0.0; n],
        max_dqd: vec![0.0; n],
        rapier_drift: 0.0,
        model_drift: 0.0,
        e0: er0.abs(),
    };
    for k in 0..steps {
        let u = tau(k as f64 * DT);
        let ur: Vec<f64> = u.iter().map(|v| rapier_sign * v).collect();
        rp.step(&ur, DT);
        mp.step(&u, DT);
        rp.state(&mut xr);
        mp.state(&mut xm);
        for i in 0..n {
            a.max_dq[i] = a.max_dq[i].max((xr[i] - xm[i]).abs());
            a.max_dqd[i] = a.max_dqd[i].max((xr[n + i] - xm[n + i]).abs());
        }
        a.rapier_drift = a.rapier_drift.max((rp.energy() - er0).abs());
        a.model_drift = a.model_drift.max((mp.energy() - em0).abs());
    }
    a
}

/// [`compare_signed`] with the same torques on both plants.
pub fn compare(
    robot: &Robot,
    x0: &[f64],
    substeps: usize,
    steps: usize,
    tau: impl Fn(f64) -> Vec<f64>,
) -> Agreement {
    compare_signed(robot, x0, substeps, steps, 1.0, tau)
}

/// The passive start state `[Q_START, 0]`.
pub fn start_state() -> Vec<f64> {
    let mut x = Q_START.to_vec();
    x.extend([0.0; 4]);
    x
}
