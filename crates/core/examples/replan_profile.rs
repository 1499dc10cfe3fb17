//! A fixed re-planning workload for instruction counts (callgrind): `replan_profile N` builds the
//! persistent planner of the paper's tracking swing (`scenarios/tracking.toml`'s task; multiple
//! shooting, 30 ms knots, one RK4 step per interval, the `ocp` backend), plans it cold once, then
//! re-plans warm N times from the planned state at t = 0.6 s with a fixed disturbance (+0.05 rad on
//! every joint, -0.2 rad/s on every joint velocity), restoring the undisturbed plan before each. It
//! prints iterations and the end-effector miss. Differences of runs (N = 1 minus N = 0, and minus the
//! restore alone, `N` negative: `-1` restores once without re-planning) isolate one warm re-plan.
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/examples/replan_profile 1`.
//!
//! Conventions: rad, rad/s, m, s; q1 absolute from +x, the rest relative.

use brachia::planning::{
    Backend, NlpSettings, PlannerSettings, ShootingSettings, SwingPlanner, SwingTask, Transcription,
};
use brachia::Robot;

fn main() -> Result<(), brachia::Error> {
    let arg: i64 = std::env::args()
        .nth(1)
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    let robot = Robot::paper();
    let task = SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    };
    let s = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.03,
        shooting: ShootingSettings {
            substeps: 1,
            ..Default::default()
        },
        ..Default::default()
    };
    let nlp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp)?;
    let cold = planner.plan_outcome()?;
    println!(
        "cold: {} iterations, converged {}, miss {:.3e} m",
        cold.iterations,
        cold.converged(),
        cold.ee_error_m
    );
    let t_now = 0.6;
    let k = (t_now / cold.interval_s).round() as usize;
    let n = robot.n;
    let mut x: Vec<f64> = planner.knots().x[k].clone();
    for (i, v) in x.iter_mut().enumerate() {
        *v += if i < n { 0.05 } else { -0.2 };
    }
    let t_k = planner.knot_time(k);
    let cp = planner.checkpoint();
    if arg < 0 {
        planner.restore(&cp)?;
    }
    for _ in 0..arg.max(0) {
        planner.restore(&cp)?;
        let w = planner.replan(t_k, &x)?;
        println!(
            "warm: {} iterations, converged {}, miss {:.3e} m",
            w.iterations,
            w.converged(),
            w.ee_error_m
        );
    }
    Ok(())
}
