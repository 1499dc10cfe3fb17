//! A fixed planning workload for instruction counts (callgrind): `plan_profile KNOT_MS N` plans the
//! paper's tracking swing (`scenarios/tracking.toml`'s task) cold N times by multiple shooting on the
//! `ocp` backend, knots every KNOT_MS ms, one RK4 step per interval, and prints iterations, objective
//! and replay miss. Differences of runs (N = 1 minus N = 0) drop the process start-up.
//! `valgrind --tool=callgrind target/release/plan_profile 30 1` (with `RAYON_NUM_THREADS=1`).
//! `BRACHIA_PLAN_CC=k` plans through a [`SwingPlanner`] instead (the same cold solve) whose cold
//! settings allow k centrality correctors per iteration (`OcpSettings::centrality_correctors`).
//!
//! Conventions: rad, rad/s, m, s; q1 absolute from +x, the rest relative.

use brachia::planning::{
    plan, Backend, NlpSettings, PlannerSettings, SwingPlanner, SwingTask, Transcription,
};
use brachia::Robot;

fn main() -> Result<(), brachia::Error> {
    let args: Vec<String> = std::env::args().collect();
    let knot_ms: f64 = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(30.0);
    let count: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let robot = Robot::paper();
    let task = SwingTask::paper();
    let mut s = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: knot_ms * 1e-3,
        ..Default::default()
    };
    s.shooting.substeps = 1;
    let nlp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    let cc: Option<usize> = std::env::var("BRACHIA_PLAN_CC")
        .ok()
        .and_then(|v| v.parse().ok());
    for _ in 0..count {
        let p = match cc {
            None => plan(&robot, &task, &s, &nlp)?,
            Some(k) => {
                let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp)?;
                planner.cold_settings_mut().centrality_correctors = k;
                planner.plan()?
            }
        };
        println!(
            "{} intervals, {} iterations, converged {}, objective {:.16e}, replay miss {:.6e} m",
            p.layout.intervals,
            p.iterations,
            p.converged(),
            p.objective,
            p.replay_ee_error_m
        );
    }
    Ok(())
}
