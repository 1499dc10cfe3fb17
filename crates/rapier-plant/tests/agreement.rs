//! Agreement of the rapier plant with the RK4 model plant (`brachia::sim::ModelPlant`, 1 RK4 step per
//! ms, energy drift ~1e-7 J over 1 s: the reference).
//!
//! rapier integrates with a first-order scheme, so the plant-model mismatch halves with each doubling
//! of the sub-steps. The bounds are ~1.6x the values measured when this file was written (table in docs/rapier.md), scaled
//! by 1 / substeps.
//!
//! Conventions: x = [q, qd] (q[0] absolute from +x, the rest relative; rad, rad/s), tau = torques of
//! joints 2..4 (N m), 1 ms control period, 1000 steps = 1 s.

mod common;

use brachia::Robot;
use common::*;

/// Smooth torques on joints 2..4, N m (within the +-5 N m limits).
fn sinusoids(t: f64) -> Vec<f64> {
    use std::f64::consts::TAU;
    vec![
        1.5 * (TAU * 1.0 * t).sin(),
        -(TAU * 1.5 * t + 0.5).sin(),
        0.5 * (TAU * 2.0 * t + 1.0).sin(),
    ]
}

fn passive(_: f64) -> Vec<f64> {
    vec![0.0; 3]
}

const SUBSTEPS: [usize; 3] = [1, 2, 4];

/// Bounds of one robot at 1 sub-step (divided by the sub-steps for 2 and 4).
struct Bounds {
    /// passive swing, max |dq| over 1 s, rad
    passive_q: f64,
    /// passive swing, max |E(t) - E(0)| / |E(0)| over 1 s
    passive_drift: f64,
    /// sinusoidal torques, max |dq| over 1 s, rad
    torque_q: f64,
    /// nonzero initial velocities, max |dq| over 100 ms, rad
    qd0_q: f64,
    /// nonzero initial velocities, max |dqd| over 100 ms, rad/s
    qd0_qd: f64,
}

/// The paper's robot (large link inertias, slow relative motion).
const PAPER: Bounds = Bounds {
    passive_q: 2.0e-3,
    passive_drift: 1.8e-3,
    torque_q: 3.0e-3,
    qd0_q: 2.0e-4,
    qd0_qd: 4.5e-4,
};

/// The light-inertia robot of the dependency study.
const LIGHT: Bounds = Bounds {
    passive_q: 3.5e-2,
    passive_drift: 5.0e-3,
    torque_q: 0.15,
    qd0_q: 9.0e-4,
    qd0_qd: 5.0e-3,
};

fn moving_start() -> Vec<f64> {
    let mut x0 = Q_START.to_vec();
    x0.extend([1.0, -2.0, 1.5, -1.0]);
    x0
}

/// Assert `errs[k] < bound / substeps` and that each doubling of the sub-steps cuts the error to
/// below 0.6x.
fn check_convergence(what: &str, errs: &[f64], bound: f64) {
    for (k, &s) in SUBSTEPS.iter().enumerate() {
        assert!(
            errs[k] < bound / s as f64,
            "{what}, {s} substeps: {:.3e} >= bound {:.3e} (all: {errs:?})",
            errs[k],
            bound / s as f64
        );
    }
    for k in 1..errs.len() {
        assert!(
            errs[k] < 0.6 * errs[k - 1],
            "{what}: error does not decrease with substeps: {errs:?}"
        );
    }
}

fn passive_swing(robot: &Robot, b: &Bounds) {
    let runs: Vec<Agreement> = SUBSTEPS
        .iter()
        .map(|&s| compare(robot, &start_state(), s, 1000, passive))
        .collect();
    let q: Vec<f64> = runs.iter().map(|a| a.max_q()).collect();
    let drift: Vec<f64> = runs.iter().map(|a| a.rapier_drift / a.e0).collect();
    check_convergence("passive max |dq|", &q, b.passive_q);
    check_convergence("passive relative energy drift", &drift, b.passive_drift);
    // the reference itself conserves energy far better than the bounds
    assert!(
        runs.iter().all(|a| a.model_drift < 1e-6),
        "RK4 reference drifts"
    );
}

fn torque_profile(robot: &Robot, b: &Bounds) {
    let mut errs = Vec::new();
    for &s in &SUBSTEPS {
        let good = compare(robot, &start_state(), s, 1000, sinusoids);
        let flipped = compare_signed(robot, &start_state(), s, 1000, -1.0, sinusoids);
        // a plant with the opposite torque convention is far off: the check is sensitive to the sign
        assert!(
            flipped.max_q() > 0.25 && flipped.max_q() > 20.0 * good.max_q(),
            "{s} substeps: flipped sign {:.3e} rad vs correct {:.3e} rad",
            flipped.max_q(),
            good.max_q()
        );
        errs.push(good.max_q());
    }
    check_convergence("torque profile max |dq|", &errs, b.torque_q);
}

fn initial_velocities(robot: &Robot, b: &Bounds) {
    let runs: Vec<Agreement> = SUBSTEPS
        .iter()
        .map(|&s| compare(robot, &moving_start(), s, 100, passive))
        .collect();
    let q: Vec<f64> = runs.iter().map(|a| a.max_q()).collect();
    let qd: Vec<f64> = runs
        .iter()
        .map(|a| a.max_dqd.iter().cloned().fold(0.0, f64::max))
        .collect();
    check_convergence("initial velocities max |dq|", &q, b.qd0_q);
    check_convergence("initial velocities max |dqd|", &qd, b.qd0_qd);
}

#[test]
fn passive_swing_matches_model_paper_robot() {
    passive_swing(&paper_robot(), &PAPER);
}

#[test]
fn passive_swing_matches_model_light_robot() {
    passive_swing(&light_robot(), &LIGHT);
}

#[test]
fn torque_profile_matches_model_and_sign_matters_paper_robot() {
    torque_profile(&paper_robot(), &PAPER);
}

#[test]
fn torque_profile_matches_model_and_sign_matters_light_robot() {
    torque_profile(&light_robot(), &LIGHT);
}

#[test]
fn initial_velocities_match_model_paper_robot() {
    initial_velocities(&paper_robot(), &PAPER);
}

#[test]
fn initial_velocities_match_model_light_robot() {
    initial_velocities(&light_robot(), &LIGHT);
}

#[test]
fn zero_initial_velocity_would_be_detected() {
    // the initial-velocity comparison is sensitive: a plant started at rest (as if qd0 were dropped)
    // differs from the moving model by far more than the bound within 100 ms
    let robot = paper_robot();
    let mut rest = moving_start();
    rest[4..].fill(0.0);
    let mut rp =
        brachia_rapier::RapierPlant::new(&robot, &rest, &Default::default()).expect("plant");
    let mut mp = brachia::sim::ModelPlant::new(robot.clone(), &moving_start());
    use brachia::sim::Plant;
    let (mut xr, mut xm) = (vec![0.0; 8], vec![0.0; 8]);
    for _ in 0..100 {
        rp.step(&[0.0; 3], DT);
        mp.step(&[0.0; 3], DT);
    }
    rp.state(&mut xr);
    mp.state(&mut xm);
    let d = (0..4).map(|i| (xr[i] - xm[i]).abs()).fold(0.0, f64::max);
    assert!(d > 100.0 * PAPER.qd0_q, "{d}");
}
