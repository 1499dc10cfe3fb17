//! Profile MPC control steps under callgrind (instruction counts do not depend on the machine load).
//! The states are those of the `mpc_step` bench: the paper robot (+-5 N m) on the 1.5 s model
//! reference (RK4 model plant under smooth torques) from a perturbed start, closed loop with the
//! default MPC. The recorded states are then fed to a fresh MPC of the chosen variant inside
//! [`measured`], the only function to count:
//!
//! ```text
//! cargo build --release -p brachia-tools --bin mpc_profile
//! valgrind --tool=callgrind --toggle-collect='*mpc_profile*measured*' \
//!     target/release/mpc_profile [default|norate|euler|ltv] [calls]
//! callgrind_annotate --inclusive=yes callgrind.out.<pid>
//! ```
//!
//! Instructions per step = the total of `measured` / calls. Prints a checksum of the torques.
//! Conventions: `x = [q (n), qd (n)]` (rad, rad/s), torques of joints 2..n (N m), time in s.

#[path = "../../../core/tests/common/mod.rs"]
mod common;

use brachia::control::{Discretization, Linearization, Mpc, MpcSettings};
use brachia::sim::{Controller, ModelPlant, Plant};
use common::*;

/// The closed-loop states of the bench (t, x).
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

/// `calls` control steps over the recorded states (cycled); returns the sum of |tau|.
#[inline(never)]
fn measured(mpc: &mut Mpc, xs: &[(f64, Vec<f64>)], calls: usize) -> f64 {
    let mut tau = [0.0; 3];
    let mut sum = 0.0;
    for k in 0..calls {
        let (t, x) = &xs[k % xs.len()];
        if k > 0 && k % xs.len() == 0 {
            mpc.reset();
        }
        mpc.control(*t, x, &mut tau);
        sum += tau.iter().map(|v| v.abs()).sum::<f64>();
    }
    sum
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let variant = args.get(1).map(String::as_str).unwrap_or("default");
    let calls: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1500);
    let settings = match variant {
        "default" => MpcSettings::default(),
        "norate" => MpcSettings {
            rate_diag: vec![0.0; 3],
            ..MpcSettings::default()
        },
        "euler" => MpcSettings {
            discretization: Discretization::Euler,
            ..MpcSettings::default()
        },
        "ltv" => MpcSettings {
            linearization: Linearization::AlongReference,
            ..MpcSettings::default()
        },
        other => {
            eprintln!("unknown variant {other:?}: default, norate, euler or ltv");
            std::process::exit(2);
        }
    };
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let xs = states(&robot, &tr);
    let mut mpc = Mpc::new(robot, tr, settings).unwrap();
    let sum = measured(&mut mpc, &xs, calls);
    println!("{variant}: {calls} calls, sum |tau| = {sum:.12e}");
}
