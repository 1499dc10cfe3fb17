//! Plan the paper's V-B swing and track it to the end with the MPC on the model plant whose sensors
//! add seeded Gaussian noise (`run_closed_loop` over a `Noisy` plant); prints the summary.
//! `cargo run --release -p brachia --example plan_and_track`.
//!
//! Conventions: `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative), torques of
//! joints 2..n (N m), EE position in the grip frame (m), time in s.

use brachia::control::{Mpc, MpcSettings};
use brachia::planning::{plan, NlpSettings, PlannerSettings, SwingTask};
use brachia::sim::{run_closed_loop, ModelPlant, NoiseSettings, Noisy, RunSettings};
use brachia::Robot;

fn main() -> Result<(), brachia::Error> {
    let robot = Robot::paper();
    let task = SwingTask::paper();
    let p = plan(
        &robot,
        &task,
        &PlannerSettings::default(),
        &NlpSettings::default(),
    )?;
    if !p.converged() {
        eprintln!("plan did not converge: {:?}", p.status);
        std::process::exit(1);
    }
    let (energy, _) = p.trajectory.work();
    println!(
        "plan: T = {:.3} s, {} iterations, energy {energy:.3} J",
        p.swing_time_s, p.iterations
    );
    let reference = p.trajectory;
    let x0 = [reference.q(0), reference.qd(0)].concat();
    let noise = NoiseSettings {
        q_std: 1e-3,
        qd_std: 1e-2,
        seed: 0,
    };
    let mut plant = Noisy::new(ModelPlant::new(robot.clone(), &x0), noise)?;
    let mut mpc = Mpc::new(robot.clone(), reference.clone(), MpcSettings::default())?;
    let run = RunSettings {
        duration_s: reference.duration() + 0.2,
        ..RunSettings::default()
    };
    let log = run_closed_loop(&mut plant, &mut mpc, &reference, &robot, &run)?;
    let s = log.summary();
    println!(
        "track: final EE error {:.2} mm, largest {:.2} mm, energy {:.3} J",
        1e3 * s.ee_final_error_m,
        1e3 * s.ee_error_max_m,
        s.energy_j
    );
    println!(
        "{} rows of closed_loop.csv columns: {}",
        log.len(),
        log.to_csv().lines().next().unwrap_or_default()
    );
    Ok(())
}
