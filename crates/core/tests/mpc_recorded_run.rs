//! The MPC computes the same torques as the recorded run: `data/mpc_recorded_run.csv` holds the
//! torques (N m) applied by seven MPC variants at every 10th of 1000 control calls (1 kHz), recorded
//! with the MPC step written plainly, before it was made faster. Every rewrite of the step
//! (linearisation, discretisation, condensing, QP) must reproduce them to [`TOL`] (1e-8 N m: the
//! rounding of reordered sums, which moved the worst-conditioned variant, `model_prediction`, by
//! 3.4e-9 N m in the constant-size step; a change of the mathematics moves torques by
//! orders of magnitude more, and `tests/mpc_condensing.rs` checks the condensed QP itself).
//!
//! The measured states do not depend on the MPC: the model plant (RK4, 1 ms) runs open loop under the
//! planned torques from a perturbed start (so the states drift from the plan by up to a few cm at the
//! EE and the MPC corrects), with a deterministic ripple on q and qd. The variants cover both
//! linearisations, both discretisations, both torque references, both predictions, the rate penalty
//! on and off, and tight torque limits (+-1.5 N m) on which bounds are active.
//!
//! To re-record (only when the MPC's mathematics changes on purpose, never to make this test pass):
//! `cargo nextest run --release -p brachia --test mpc_recorded_run --run-ignored only`.

mod common;

use brachia::control::{
    Discretization, Linearization, Mpc, MpcSettings, Prediction, TorqueReference,
};
use brachia::sim::{Controller, ModelPlant, Plant};
use common::*;

const PATH: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/tests/data/mpc_recorded_run.csv"
);
const CALLS: usize = 1000;
const EVERY: usize = 10;
/// Largest accepted difference from the recorded torques, N m (see the file's header).
const TOL: f64 = 1e-8;

/// (name, torque limit N m, settings) of the recorded variants.
fn variants() -> Vec<(&'static str, f64, MpcSettings)> {
    let d = MpcSettings::default;
    vec![
        ("default", 5.0, d()),
        (
            "no_rate",
            5.0,
            MpcSettings {
                rate_diag: vec![0.0; 3],
                ..d()
            },
        ),
        (
            "euler",
            5.0,
            MpcSettings {
                discretization: Discretization::Euler,
                ..d()
            },
        ),
        (
            "ltv",
            5.0,
            MpcSettings {
                linearization: Linearization::AlongReference,
                ..d()
            },
        ),
        (
            "zero_torque_ref",
            5.0,
            MpcSettings {
                torque_reference: TorqueReference::Zero,
                ..d()
            },
        ),
        (
            "model_prediction",
            5.0,
            MpcSettings {
                prediction: Prediction::Model,
                ..d()
            },
        ),
        ("tight_limits", 1.5, d()),
    ]
}

/// The applied torques at every `EVERY`-th call of variant `settings` on the open-loop states.
fn run(tau_limit: f64, settings: MpcSettings) -> (Vec<[f64; 3]>, usize) {
    let robot = paper_robot(tau_limit);
    let tr = model_reference(&robot, &start_state(), 1.2);
    let mut x0 = start_state();
    x0[1] += 0.1;
    x0[2] -= 0.1;
    x0[5] += 0.3;
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), settings).unwrap();
    let (mut x, mut tau, mut tau_plan) = (vec![0.0; 8], [0.0; 3], [0.0; 3]);
    let mut out = Vec::new();
    let mut active = 0;
    for k in 0..CALLS {
        let t = plant.time();
        plant.state(&mut x);
        for (i, v) in x.iter_mut().enumerate() {
            let amp = if i < 4 { 2e-3 } else { 2e-2 };
            *v += amp * (0.37 * k as f64 + 1.3 * i as f64).sin();
        }
        mpc.control(t, &x, &mut tau);
        active += mpc.last_qp_info().unwrap().active;
        if k % EVERY == 0 {
            out.push(tau);
        }
        tr.tau_at(t, &mut tau_plan);
        plant.step(&tau_plan, 1e-3);
    }
    (out, active)
}

#[test]
fn mpc_reproduces_the_recorded_torques() {
    let text = std::fs::read_to_string(PATH).expect("recorded run present");
    let mut rows = text.lines().skip(1).map(|l| {
        let f: Vec<&str> = l.split(',').collect();
        let v = |i: usize| f[i].parse::<f64>().unwrap();
        (
            f[0].to_string(),
            f[1].parse::<usize>().unwrap(),
            [v(2), v(3), v(4)],
        )
    });
    let mut tight_active = 0;
    for (name, limit, settings) in variants() {
        let (got, active) = run(limit, settings);
        if name == "tight_limits" {
            tight_active = active;
        }
        let mut worst: f64 = 0.0;
        for (k, tau) in got.iter().enumerate() {
            let (rname, call, rec) = rows.next().expect("a recorded row per call");
            assert_eq!((rname.as_str(), call), (name, k * EVERY));
            for j in 0..3 {
                worst = worst.max((tau[j] - rec[j]).abs());
            }
        }
        eprintln!("{name}: largest difference from the recorded torques {worst:e} N m");
        assert!(
            worst <= TOL,
            "{name}: torques differ from the recorded run by {worst:e} N m"
        );
    }
    assert!(rows.next().is_none(), "extra rows in the recording");
    // The tight-limit run exercises the active set (else it would not test the QP's updates).
    assert!(tight_active > CALLS, "only {tight_active} active bounds");
}

#[test]
#[ignore = "writes the recording; run only when the MPC's mathematics changes on purpose"]
fn record_mpc_run() {
    let mut s = String::from("variant,call,tau2_nm,tau3_nm,tau4_nm\n");
    for (name, limit, settings) in variants() {
        let (got, _) = run(limit, settings);
        for (k, tau) in got.iter().enumerate() {
            s += &format!(
                "{name},{},{:.17e},{:.17e},{:.17e}\n",
                k * EVERY,
                tau[0],
                tau[1],
                tau[2]
            );
        }
    }
    std::fs::write(PATH, s).unwrap();
}
