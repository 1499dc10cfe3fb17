//! Probe of a parameter-study cell's torque need: plan the cell (default r2 = 0.1 at T - 0.5 s, the one
//! cell that fails) with 20 N m limits, then warm-started through tighter limits down to the paper's
//! 5 N m, printing each solve's status, iterations, energy (eq. 18, J) and largest |tau| (N m). Where
//! the continuation stops is the smallest limit this family of swings reaches (docs/parameter-study.md).
//!
//! ```text
//! cargo run --release -p brachia-experiments --example torque_continuation_probe -- [R2] [OFFSET_S]
//! ```
//! Units: s, N m, J. The study's default settings (multiple shooting, 30 ms knots, `ocp`).
use brachia::model::Robot;
use brachia::planning::{freefall_time, plan_with_guess, PlannerSettings, SwingTime};
use brachia_experiments::parameter_study::{scaled_params, start_pose, ParameterStudySettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let s = ParameterStudySettings::default();
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .map(|a| a.parse().unwrap())
        .collect();
    let (r2, off) = (
        args.first().copied().unwrap_or(0.1),
        args.get(1).copied().unwrap_or(-0.5),
    );
    let base = Robot::paper().params().clone();
    let p = scaled_params(&base, r2, s.arm_length_m)?;
    let robot = Robot::from_params(p.clone(), "probe")?;
    let q0 = start_pose(&robot, s.start)?;
    let ff = freefall_time(&robot, &q0, 0.5 * (s.start[0] + s.target[0]))?;
    let t = 2.0 * ff + off;
    let task = brachia::planning::SwingTask {
        q0: q0.clone(),
        qd0: vec![],
        target: s.target,
        obstacles: vec![],
    };
    let planner = PlannerSettings {
        swing_time: SwingTime::Seconds(t),
        ..s.planner.clone()
    };
    let mut guess = None;
    for lim in [
        20.0, 15.0, 12.0, 10.0, 9.0, 8.0, 7.0, 6.5, 6.0, 5.5, 5.25, 5.0,
    ] {
        let mut pp = p.clone();
        pp.actuators.tau_min = vec![-lim; robot.n() - 1];
        pp.actuators.tau_max = vec![lim; robot.n() - 1];
        let r = Robot::from_params(pp, "probe")?;
        let plan = plan_with_guess(&r, &task, &planner, &s.solver, guess.as_ref())?;
        let tmax = (0..plan.trajectory.t.len())
            .flat_map(|k| plan.trajectory.tau(k).to_vec())
            .fold(0.0f64, |a, b| a.max(b.abs()));
        println!(
            "T {t:.3} limit {lim:5.2}: {:?} {} it, E {:.3}, max |tau| {tmax:.3}",
            plan.status, plan.iterations, plan.energy_j
        );
        if plan.converged() {
            guess = Some(plan.trajectory.clone());
        } else {
            break;
        }
    }
    Ok(())
}
