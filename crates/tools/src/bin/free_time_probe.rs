//! Free swing time on the tracking swing: where the plan ends from several starts (docs/planner.md,
//! "Free swing time"). `cargo run --release -p brachia-tools --bin free_time_probe [t_min t_max]`.

use brachia::planning::{
    plan, plan_with_guess, Backend, NlpSettings, PlannerSettings, SwingPlanner, SwingTask,
    SwingTime, Transcription,
};
use brachia::Robot;

fn main() -> brachia::Result<()> {
    let args: Vec<f64> = std::env::args()
        .skip(1)
        .filter_map(|a| a.parse().ok())
        .collect();
    let (lo, hi) = match args[..] {
        [a, b] => (a, b),
        _ => (1.2, 4.0),
    };
    let robot = Robot::paper();
    let task = SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    };
    let nlp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    let base = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.03,
        ..Default::default()
    };
    let free = |start: SwingTime| PlannerSettings {
        swing_time: start,
        free_swing_time: Some([lo, hi]),
        ..base.clone()
    };
    let show = |what: &str, p: &brachia::planning::Plan| {
        println!(
            "{what}: {:?}, T {:.4} s, K {}, objective {:.6}, E {:.3} J, {} iterations, {:.1} ms, replay {:.2e} m",
            p.status,
            p.swing_time_s,
            p.layout.intervals,
            p.objective,
            p.energy_j,
            p.iterations,
            p.solve_time_s * 1e3,
            p.replay_ee_error_m
        )
    };
    let third = (hi - lo) / 3.0;
    for start in [
        SwingTime::default(),
        SwingTime::Seconds(lo + 0.5 * third),
        SwingTime::Seconds(lo + 1.5 * third),
        SwingTime::Seconds(3.0),
        SwingTime::Seconds(lo + 2.5 * third),
        SwingTime::Seconds(3.5),
    ] {
        let p = plan(&robot, &task, &free(start), &nlp)?;
        show(&format!("free from {start:?}, default guess"), &p);
    }
    // fixed T on a grid, cold from the default guess
    let mut t = lo;
    while t <= hi + 1e-9 {
        let s = PlannerSettings {
            swing_time: SwingTime::Seconds(t),
            ..base.clone()
        };
        let p = plan(&robot, &task, &s, &nlp)?;
        show(&format!("fixed {t:.2}"), &p);
        t += 0.2;
    }
    // free, started from the fixed plan at the task's T (2 T_freefall)
    let p0 = plan(&robot, &task, &base, &nlp)?;
    show("fixed auto", &p0);
    let p = plan_with_guess(
        &robot,
        &task,
        &free(SwingTime::default()),
        &nlp,
        Some(&p0.points),
    )?;
    show("free from the fixed auto plan", &p);
    // the persistent planner: the free solve, then the fixed-T problem at T* from it
    let s = free(SwingTime::default());
    let p = plan(&robot, &task, &s, &nlp)?;
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp)?;
    let out = planner.plan_outcome()?;
    println!(
        "SwingPlanner: {:?}, T {:.4} s, objective {:.6}, {} iterations ({} of them the free solve), {:.1} ms",
        out.status,
        planner.swing_time(),
        out.objective,
        out.iterations,
        p.iterations,
        out.solve_time_s * 1e3
    );
    Ok(())
}
