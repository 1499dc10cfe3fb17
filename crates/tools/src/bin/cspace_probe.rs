//! Why a placement of the obstacle scan fails from the C-space seed (docs/planner.md, "The placement
//! that still fails"): the scan's placements (one 0.08 m obstacle at a link's midpoint of the tracking
//! swing, multiple shooting on `ocp`, 10 ms knots), the C-space seed of each, and plans from that seed
//! alone with the torque limits given in turn (each plan warm-started from the last converged one: a
//! continuation on the actuator limits).
//! `cargo run --release -p brachia-tools --bin cspace_probe -- --only 4,7 [--tau 10,5] [--max-iter 500]
//! [--swing-time 3.0]` (placements 1-based; `--tau` in N m, default the robot's 5; `--swing-time` in s,
//! default "auto", the seed then timed on the obstacle-free swing of that duration). Units: m, s, N m.

use brachia::model::Robot;
use brachia::planning::strategy::cspace::cspace_seed;
use brachia::planning::strategy::obstacles::{diagnose, path_placements};
use brachia::planning::{
    plan, plan_with_guess, Backend, NlpSettings, PlannerSettings, ShootingSettings, SwingTask,
    SwingTime, Transcription,
};
use std::time::Instant;

fn arg<T: std::str::FromStr>(args: &[String], name: &str) -> Vec<T> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .map(|v| v.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_default()
}

fn main() -> Result<(), brachia::Error> {
    let args: Vec<String> = std::env::args().collect();
    let only: Vec<usize> = arg(&args, "--only");
    let mut taus: Vec<f64> = arg(&args, "--tau");
    let max_iter = arg::<usize>(&args, "--max-iter").first().copied();
    let swing_time = arg::<f64>(&args, "--swing-time").first().copied();
    let robot = Robot::paper();
    if taus.is_empty() {
        taus.push(robot.tau_max()[0]);
    }
    let task = SwingTask::paper();
    let scan = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.01,
        shooting: ShootingSettings {
            substeps: 1,
            ..Default::default()
        },
        ..Default::default()
    };
    let ms = PlannerSettings {
        swing_time: swing_time.map(SwingTime::Seconds).unwrap_or_default(),
        ..scan.clone()
    };
    let ocp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    let solve = NlpSettings {
        max_iter: max_iter.unwrap_or(ocp.max_iter),
        ..ocp.clone()
    };
    let base = plan(&robot, &task, &scan, &ocp)?;
    let places = path_placements(&robot, &base.points, task.target, 0.08, 0.01, 8)?;
    let free = plan(&robot, &task, &ms, &ocp)?;
    println!("T = {:.3} s", free.swing_time_s);
    for (i, pl) in places.iter().enumerate() {
        if !only.is_empty() && !only.contains(&(i + 1)) {
            continue;
        }
        let tk = SwingTask {
            obstacles: vec![pl.obstacle],
            ..task.clone()
        };
        let (rep, seed) = cspace_seed(&robot, &tk.obstacles, &ms, &free.points)?;
        println!("#{}: {rep:?}", i + 1);
        let Some(mut g) = seed else { continue };
        let peak = g.tau.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        println!("  seed: largest |tau| {peak:.2} N m");
        for &tau in &taus {
            let mut prm = robot.params().clone();
            prm.actuators.tau_max.iter_mut().for_each(|v| *v = tau);
            prm.actuators.tau_min.iter_mut().for_each(|v| *v = -tau);
            let limited = Robot::from_params(prm, "cspace_probe")?;
            let t0 = Instant::now();
            let p = plan_with_guess(&limited, &tk, &ms, &solve, Some(&g))?;
            let peak = p.points.tau.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            println!(
                "  limits {tau} N m: {:?}, {} iterations, {:.2} s wall, objective {:.4}, largest |tau| {peak:.2}, {:?}",
                p.status,
                p.iterations,
                t0.elapsed().as_secs_f64(),
                p.objective,
                p.violations
            );
            if let Some(b) = diagnose(&robot, &tk, &ms, &p.points, None)? {
                println!("  {b}");
            }
            if p.converged() {
                g = p.points;
            }
        }
    }
    Ok(())
}
