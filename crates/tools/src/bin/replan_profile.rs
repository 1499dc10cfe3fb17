//! A fixed re-planning workload for instruction counts (callgrind): the warm re-plan set of
//! `benches/replan.rs` (the tracking swing, multiple shooting, 40 ms knots (`REPLAN_KNOT_DT`;
//! `BRACHIA_REPLAN_KNOT_DT` for another), one RK4 step, K = 56; from
//! the planned state at t = 0.6 s disturbed by uniform +-0.1 rad and +-0.5 rad/s per joint, 100
//! seeded draws, those inside the bounds). `replan_profile N` re-plans the first N draws warm (each
//! after restoring the undisturbed plan) and prints the iterations (mean, p99, max, the slowest
//! draws). `replan_profile N cold` re-plans them cold. Differences of runs (N minus 0) drop the
//! cold plan and the process start-up:
//! `RAYON_NUM_THREADS=1 valgrind --tool=callgrind target/release/replan_profile 100`.
//! Warm-start variants without a rebuild: `BRACHIA_REPLAN_MU` (mu_init), `BRACHIA_REPLAN_PUSH`
//! (warm_bound_push), `BRACHIA_REPLAN_DUALS` (stored, reset, centered; default stored bounds), `BRACHIA_REPLAN_ADAPTIVE=1`
//! (the adaptive barrier update), `BRACHIA_REPLAN_TOL` (tol), `BRACHIA_REPLAN_PRIMAL=shifted` (the
//! shifted start instead of the default feedback rollout, [`WarmPrimal`]), `BRACHIA_REPLAN_SHIFT_DUALS=0`
//! (the stored bound duals stage by stage, not moved with the shifted knots,
//! [`SwingPlanner::set_warm_shift_duals`]), `BRACHIA_REPLAN_CC=k` (at most k centrality correctors per
//! iteration, `OcpSettings::centrality_correctors`; 0 = off), `BRACHIA_REPLAN_SOC=k` (at most k
//! second-order corrections, `OcpSettings::max_soc`). It also prints the solve times' median, p99 and max
//! (the solver's own clock; noisy, the iterations are the figures to compare). Diagnosis: `BRACHIA_REPLAN_ONLY=i`
//! re-plans draw i only (after the same restore), `BRACHIA_REPLAN_LIST=1` prints every draw's
//! iterations, objective, status and end-effector miss (to compare optima draw by draw), and below it
//! the solver's factorisations, regularisations and time split ([`SwingPlanner::last_stats`]);
//! `BRACHIA_REPLAN_REPLAY=1` replays every re-plan's held torques open loop (untimed) and prints the
//! largest end-effector miss (the accuracy rule: <= 1 mm); `BRACHIA_REPLAN_GAP_MS=t` idles t ms
//! before each re-plan (untimed), as a closed loop does between re-plans.
//!
//! Conventions: rad, rad/s, m, s; q1 absolute from +x, the rest relative.

use brachia::planning::workload::{
    disturbed_starts, replan_settings, REPLAN_KNOT_DT, REPLAN_SEED, REPLAN_T_NOW,
};
use brachia::planning::{SwingPlanner, SwingTask, WarmPrimal};
use brachia::Robot;
use brachia_ocp::{MuStrategy, WarmDuals};

fn main() -> Result<(), brachia::Error> {
    let args: Vec<String> = std::env::args().collect();
    let count: usize = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(100);
    let warm = args.get(2).map(String::as_str) != Some("cold");
    let robot = Robot::paper();
    let task = SwingTask::paper();
    let (s, nlp) = replan_settings(
        std::env::var("BRACHIA_REPLAN_KNOT_DT")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(REPLAN_KNOT_DT),
    );
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp)?;
    let env = |k: &str| std::env::var(k).ok();
    let w = planner.warm_settings_mut();
    if let Some(v) = env("BRACHIA_REPLAN_MU").and_then(|v| v.parse().ok()) {
        w.mu_init = v;
    }
    if let Some(v) = env("BRACHIA_REPLAN_PUSH").and_then(|v| v.parse().ok()) {
        w.warm_bound_push = v;
    }
    if let Some(v) = env("BRACHIA_REPLAN_TOL").and_then(|v| v.parse().ok()) {
        w.tol = v;
    }
    match env("BRACHIA_REPLAN_DUALS").as_deref() {
        Some("reset") => w.warm_duals = WarmDuals::Reset,
        Some("centered") => w.warm_duals = WarmDuals::Centered,
        Some("stored") => w.warm_duals = WarmDuals::Stored,
        _ => {}
    }
    if let Some(v) = env("BRACHIA_REPLAN_CC").and_then(|v| v.parse().ok()) {
        w.centrality_correctors = v;
    }
    if let Some(v) = env("BRACHIA_REPLAN_SOC").and_then(|v| v.parse().ok()) {
        w.max_soc = v;
    }
    if env("BRACHIA_REPLAN_ADAPTIVE").as_deref() == Some("1") {
        w.mu_strategy = MuStrategy::Adaptive;
    }
    if env("BRACHIA_REPLAN_PRIMAL").as_deref() == Some("shifted") {
        planner.set_warm_primal(WarmPrimal::Shifted);
    }
    if env("BRACHIA_REPLAN_SHIFT_DUALS").as_deref() == Some("0") {
        planner.set_warm_shift_duals(false);
    }
    let p = planner.plan()?;
    assert!(p.converged(), "{:?}", p.status);
    println!(
        "cold plan: {} knots, replay miss {:.3e} m",
        p.points.t.len(),
        p.replay_ee_error_m
    );
    let j = p
        .trajectory
        .t
        .iter()
        .position(|t| (t - REPLAN_T_NOW).abs() < 1e-9)
        .expect("a sample at t = 0.6 s");
    let x_nom = [p.trajectory.q(j), p.trajectory.qd(j)].concat();
    let states = disturbed_starts(&x_nom, &s.bounds, 100, REPLAN_SEED);
    let cp = planner.checkpoint();
    let mut its = vec![];
    let mut times = vec![];
    let mut conv = 0;
    let mut obj_sum = 0.0;
    let only: Option<usize> = env("BRACHIA_REPLAN_ONLY").and_then(|v| v.parse().ok());
    let list = env("BRACHIA_REPLAN_LIST").as_deref() == Some("1");
    let replay = env("BRACHIA_REPLAN_REPLAY").as_deref() == Some("1");
    let gap_ms: Option<f64> = env("BRACHIA_REPLAN_GAP_MS").and_then(|v| v.parse().ok());
    let mut replay_max = 0.0f64;
    for (i, x) in states.iter().enumerate().take(count) {
        if only.is_some_and(|o| o != i) {
            continue;
        }
        planner.restore(&cp)?;
        if let Some(ms) = gap_ms {
            std::thread::sleep(std::time::Duration::from_secs_f64(ms * 1e-3));
        }
        let o = if warm {
            planner.replan(REPLAN_T_NOW, x)?
        } else {
            planner.replan_cold(REPLAN_T_NOW, x)?
        };
        conv += usize::from(o.converged() && o.ee_error_m < 1e-6);
        obj_sum += o.objective;
        its.push(o.iterations);
        times.push(o.solve_time_s);
        if replay {
            // the re-plan's own held torques replayed open loop from x (untimed)
            replay_max = replay_max.max(planner.current_plan()?.replay_ee_error_m);
        }
        if list {
            println!(
                "draw {i} iterations {} objective {:.15e} status {:?} ee_error {:.3e}",
                o.iterations, o.objective, o.status, o.ee_error_m
            );
            if let Some(st) = planner.last_stats() {
                let t = &st.time;
                println!(
                    "  factorizations {} regularizations {} time ms: total {:.2} eval {:.2} hess {:.2} linalg {:.2} ls {:.2}",
                    st.factorizations,
                    st.regularizations,
                    t.total_s * 1e3,
                    t.evaluation_s * 1e3,
                    t.hessian_s * 1e3,
                    t.linear_algebra_s * 1e3,
                    t.line_search_s * 1e3
                );
            }
        }
    }
    if its.is_empty() {
        return Ok(());
    }
    let m = its.len();
    let mut sorted: Vec<(usize, usize)> = its.iter().copied().zip(0..).collect();
    sorted.sort_by(|a, b| b.cmp(a));
    let mut v = its.clone();
    v.sort_unstable();
    let i99 = ((0.99 * m as f64).ceil() as usize).clamp(1, m) - 1;
    let p99 = v[i99];
    println!(
        "{} re-plans ({}): {conv} converged, iterations mean {:.2}, median {}, p99 {p99}, max {}, \
         objective sum {obj_sum:.9}; slowest draws {:?}",
        m,
        if warm { "warm" } else { "cold" },
        its.iter().sum::<usize>() as f64 / m as f64,
        v[m / 2],
        v[m - 1],
        &sorted[..3.min(m)]
    );
    if replay {
        println!("largest replay miss of the re-plans: {replay_max:.3e} m");
    }
    times.sort_by(f64::total_cmp);
    println!(
        "solve times: median {:.2} ms, p99 {:.2} ms, max {:.2} ms, sum {:.1} ms",
        times[m / 2] * 1e3,
        times[i99] * 1e3,
        times[m - 1] * 1e3,
        times.iter().sum::<f64>() * 1e3
    );
    Ok(())
}
