//! Probe of a parameter-study cell's torque need (docs/parameter-study.md), two continuations:
//!
//! - `torque [R2] [OFFSET_S]` (default 0.1 -0.5, the one cell that fails): plan the cell with 20 N m
//!   limits, then warm-started through tighter limits down to the paper's 5 N m. Where it stops is the
//!   smallest limit this family of swings reaches.
//! - `time [R2] [STEP_S] [LIMIT_NM]` (default 0.1 0.005 5): plan the row's swing at T - 0.3 s within the
//!   limit, then warm-started through shorter swing times in steps of STEP_S until a solve fails. Where
//!   it stops is the shortest swing this family reaches within the limit.
//!
//! - `r2 [R2] [FROM] [OFFSET_S] [STEPS]` (default 0.1 0.2 -0.5 10): plan the cell of r2 = FROM at
//!   OFFSET_S within 5 N m, then warm-started through r2 in STEPS steps to R2 at the same offset (each
//!   robot's own start pose and T). Where it stops is how far this family reaches in r2.
//!
//! Each solve prints its status, iterations, energy (eq. 18, J) and largest |tau| (N m).
//!
//! ```text
//! cargo run --release -p brachia-tools --bin torque_continuation_probe -- torque 0.1 -0.5
//! cargo run --release -p brachia-tools --bin torque_continuation_probe -- time 0.1 0.005 5
//! ```
//! Units: s, N m, J. The study's default settings (multiple shooting, 30 ms knots, `ocp`).
use brachia::model::{Robot, RobotParams};
use brachia::planning::{
    freefall_time, plan_with_guess, Plan, PlannerSettings, SwingTask, SwingTime,
};
use brachia::trajectory::Trajectory;
use brachia_experiments::parameter_study::{scaled_params, start_pose, ParameterStudySettings};

/// The study's robot for `r2` with symmetric torque limits `lim` (N m).
fn limited(
    base: &RobotParams,
    r2: f64,
    lim: f64,
    s: &ParameterStudySettings,
) -> Result<Robot, Box<dyn std::error::Error>> {
    let mut p = scaled_params(base, r2, s.arm_length_m)?;
    p.actuators.tau_min = vec![-lim; p.links.len() - 1];
    p.actuators.tau_max = vec![lim; p.links.len() - 1];
    Ok(Robot::from_params(p, "probe")?)
}

/// Plan `robot`'s study swing of `t` seconds warm from `guess`, print one line, return the plan.
fn solve(
    robot: &Robot,
    task: &SwingTask,
    t: f64,
    s: &ParameterStudySettings,
    guess: Option<&Trajectory>,
    label: &str,
) -> Result<Plan, Box<dyn std::error::Error>> {
    let planner = PlannerSettings {
        swing_time: SwingTime::Seconds(t),
        ..s.planner.clone()
    };
    let plan = plan_with_guess(robot, task, &planner, &s.solver, guess)?;
    let tmax = (0..plan.trajectory.t.len())
        .flat_map(|k| plan.trajectory.tau(k).to_vec())
        .fold(0.0f64, |a, b| a.max(b.abs()));
    println!(
        "{label} T {t:.3}: {:?} {} it, E {:.3}, max |tau| {tmax:.3}",
        plan.status, plan.iterations, plan.energy_j
    );
    Ok(plan)
}

/// A random smooth guess of `samples` points over `[0, t]`: every joint moves from `q0` by a smooth
/// step to `q0 + d` plus `a1 sin(pi r) + a2 sin(2 pi r)` (r = time fraction), zero torque; `d`, `a1`,
/// `a2` uniform in +-`amp` rad per joint.
fn random_guess(q0: &[f64], t: f64, amp: f64, rng: &mut impl rand::Rng) -> Trajectory {
    use std::f64::consts::PI;
    let n = q0.len();
    let mut draw = || -> Vec<f64> { (0..n).map(|_| rng.gen_range(-amp..=amp)).collect() };
    let (d, a1, a2) = (draw(), draw(), draw());
    let samples = 101;
    let mut tr = Trajectory::new(n);
    let (mut q, mut qd) = (vec![0.0; n], vec![0.0; n]);
    for k in 0..samples {
        let r = k as f64 / (samples - 1) as f64;
        let (st, sdt) = (r * r * (3.0 - 2.0 * r), 6.0 * r * (1.0 - r) / t);
        for i in 0..n {
            let (w1, w2) = (PI * r, 2.0 * PI * r);
            q[i] = q0[i] + st * d[i] + a1[i] * w1.sin() + a2[i] * w2.sin();
            qd[i] = sdt * d[i] + (a1[i] * PI * w1.cos() + a2[i] * 2.0 * PI * w2.cos()) / t;
        }
        tr.push(r * t, &q, &qd, &vec![0.0; n - 1]);
    }
    tr
}

/// `seeds [R2] [OFFSET_S] [N] [AMP_RAD] [LIMITS...]`: N random smooth guesses (seeds 0..N, in
/// parallel), each planned through the torque limits given (default 20 12 9 7 6 5 N m), each warm from
/// the previous limit's plan; prints per seed the last limit solved and its energy and largest |tau|.
fn seeds(
    base: &RobotParams,
    r2: f64,
    task: &SwingTask,
    t: f64,
    s: &ParameterStudySettings,
    nums: &[f64],
) -> Result<(), Box<dyn std::error::Error>> {
    use rand::SeedableRng;
    use rayon::prelude::*;
    let n_seeds = nums.get(2).copied().unwrap_or(32.0).clamp(1.0, 10_000.0) as u64;
    let amp = nums.get(3).copied().unwrap_or(1.0);
    let limits: Vec<f64> = if nums.len() > 4 {
        nums[4..].to_vec()
    } else {
        vec![20.0, 12.0, 9.0, 7.0, 6.0, 5.0]
    };
    let robots = limits
        .iter()
        .map(|&l| limited(base, r2, l, s))
        .collect::<Result<Vec<_>, _>>()?;
    let rows: Vec<String> = (0..n_seeds)
        .into_par_iter()
        .map(|seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut guess = random_guess(&task.q0, t, amp, &mut rng);
            let mut line = format!("seed {seed:4}:");
            for (robot, lim) in robots.iter().zip(&limits) {
                let planner = PlannerSettings {
                    swing_time: SwingTime::Seconds(t),
                    ..s.planner.clone()
                };
                let plan = match plan_with_guess(robot, task, &planner, &s.solver, Some(&guess)) {
                    Ok(p) => p,
                    Err(e) => return format!("{line} error {e}"),
                };
                let tmax = (0..plan.trajectory.t.len())
                    .flat_map(|k| plan.trajectory.tau(k).to_vec())
                    .fold(0.0f64, |a, b| a.max(b.abs()));
                if !plan.converged() {
                    line += &format!(" | {lim} {:?} {} it", plan.status, plan.iterations);
                    break;
                }
                line += &format!(" | {lim} E {:.3} tau {tmax:.2}", plan.energy_j);
                guess = plan.trajectory;
            }
            line
        })
        .collect();
    for r in rows {
        println!("{r}");
    }
    Ok(())
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let s = ParameterStudySettings::default();
    let mut args = std::env::args().skip(1);
    let mode = args.next().unwrap_or_else(|| "torque".into());
    let nums = args
        .map(|a| a.parse::<f64>())
        .collect::<Result<Vec<_>, _>>()?;
    let arg = |i: usize, default: f64| nums.get(i).copied().unwrap_or(default);
    let r2 = arg(0, 0.1);
    let base = Robot::paper().params().clone();
    let free = Robot::from_params(scaled_params(&base, r2, s.arm_length_m)?, "probe")?;
    let q0 = start_pose(&free, s.start)?;
    let ff = freefall_time(&free, &q0, 0.5 * (s.start[0] + s.target[0]))?;
    let task = SwingTask {
        q0,
        qd0: vec![],
        target: s.target,
        obstacles: vec![],
    };
    let mut guess: Option<Trajectory> = None;
    match mode.as_str() {
        "torque" => {
            let t = 2.0 * ff + arg(1, -0.5);
            for lim in [
                20.0, 15.0, 12.0, 10.0, 9.0, 8.0, 7.0, 6.5, 6.0, 5.5, 5.25, 5.0,
            ] {
                let robot = limited(&base, r2, lim, &s)?;
                let plan = solve(
                    &robot,
                    &task,
                    t,
                    &s,
                    guess.as_ref(),
                    &format!("limit {lim:5.2}"),
                )?;
                if !plan.converged() {
                    break;
                }
                guess = Some(plan.trajectory);
            }
        }
        "time" => {
            let (step, lim) = (arg(1, 0.005), arg(2, 5.0));
            if step.is_nan() || step <= 0.0 {
                return Err("STEP_S must be positive".into());
            }
            let robot = limited(&base, r2, lim, &s)?;
            let mut off = -0.3;
            while off > -1.0 {
                let plan = solve(
                    &robot,
                    &task,
                    2.0 * ff + off,
                    &s,
                    guess.as_ref(),
                    &format!("offset {off:.3}"),
                )?;
                if !plan.converged() {
                    break;
                }
                guess = Some(plan.trajectory);
                off -= step;
            }
        }
        "r2" => {
            // from the cell of r2 = FROM at OFFSET (its own T), warm-started through r2 in STEPS
            // steps down (or up) to R2 at the same offset, each robot with 5 N m limits
            let (from, off, steps) = (arg(1, 0.2), arg(2, -0.5), arg(3, 10.0));
            if !(1.0..=100.0).contains(&steps) {
                return Err("STEPS must be 1 to 100".into());
            }
            let steps = steps as usize;
            for i in 0..=steps {
                let ri = from + (r2 - from) * i as f64 / steps as f64;
                let robot = limited(&base, ri, 5.0, &s)?;
                let q0 = start_pose(&robot, s.start)?;
                let ff = freefall_time(&robot, &q0, 0.5 * (s.start[0] + s.target[0]))?;
                let task_i = SwingTask { q0, ..task.clone() };
                let plan = solve(
                    &robot,
                    &task_i,
                    2.0 * ff + off,
                    &s,
                    guess.as_ref(),
                    &format!("r2 {ri:.3}"),
                )?;
                if !plan.converged() {
                    break;
                }
                guess = Some(plan.trajectory);
            }
        }
        "seeds" => seeds(&base, r2, &task, 2.0 * ff + arg(1, -0.5), &s, &nums)?,
        other => return Err(format!("unknown mode {other:?}: torque, time, r2 or seeds").into()),
    }
    Ok(())
}
