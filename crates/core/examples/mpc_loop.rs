//! An MPC loop one control period at a time, with a re-plan half-way: plan the paper's V-B swing
//! (multiple shooting by default), track it on the model plant with `ClosedLoop::step`, and after 0.5 s
//! swap in a plan re-made from the measured state with `ClosedLoop::set_reference`. Prints the
//! tracking errors. `cargo run --release -p brachia --example mpc_loop`.
//!
//! Conventions: `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative), torques of
//! joints 2..n (N m), EE position in the grip frame (m), time in s.

use brachia::control::{Mpc, MpcSettings};
use brachia::planning::{plan, NlpSettings, PlannerSettings, SwingTask};
use brachia::sim::{ClosedLoop, ModelPlant, Plant, RunSettings};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use std::sync::Arc;

fn main() -> Result<(), brachia::Error> {
    let robot = Arc::new(Robot::paper());
    let task = SwingTask::paper();
    let settings = PlannerSettings::default();
    let p = plan(&robot, &task, &settings, &NlpSettings::default())?;
    if !p.converged() {
        eprintln!("plan did not converge: {:?}", p.status);
        std::process::exit(1);
    }
    let reference = Arc::new(p.trajectory);
    let x0 = [reference.q(0), reference.qd(0)].concat();
    let plant = ModelPlant::new(Arc::clone(&robot), &x0);
    let mpc = Mpc::new(
        Arc::clone(&robot),
        Arc::clone(&reference),
        MpcSettings::default(),
    )?;
    let run = RunSettings {
        duration_s: reference.duration() + 0.2,
        ..RunSettings::default()
    };
    let mut cl = ClosedLoop::new(plant, mpc, Arc::clone(&robot), Arc::clone(&reference), &run)?;
    let mut replanned = false;
    while let Some(step) = cl.step() {
        if !replanned && step.t >= 0.5 {
            replanned = true;
            // Re-plan the rest of the swing from the measured state; time in the new plan starts at
            // the current time, so shift it.
            let mut x = vec![0.0; robot.nx()];
            cl.plant().state(&mut x);
            let rest = SwingTask {
                q0: x[..robot.n()].to_vec(),
                qd0: x[robot.n()..].to_vec(),
                ..task.clone()
            };
            let t_now = cl.plant().time();
            match plan(&robot, &rest, &settings, &NlpSettings::default()) {
                Ok(p2) if p2.converged() => {
                    let mut shifted = Trajectory::new(robot.n());
                    let tr = &p2.trajectory;
                    for k in 0..tr.len() {
                        shifted.push(t_now + tr.t[k], tr.q(k), tr.qd(k), tr.tau(k));
                    }
                    cl.set_reference(shifted)?;
                    println!("re-planned at t = {t_now:.3} s: {} samples", tr.len());
                }
                Ok(p2) => println!(
                    "re-plan at t = {t_now:.3} s did not converge: {:?}",
                    p2.status
                ),
                Err(e) => println!("re-plan at t = {t_now:.3} s refused: {e}"),
            }
        }
    }
    let s = cl.finish().summary();
    println!(
        "final EE error {:.2} mm, largest {:.2} mm, joint RMS error {:.4} rad, MPC step p50 {:.0} us",
        1e3 * s.ee_final_error_m,
        1e3 * s.ee_error_max_m,
        s.joint_rms_error_rad,
        s.control_step_us_p50
    );
    Ok(())
}
