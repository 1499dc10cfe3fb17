//! Configuration-space routes of the fixed placement scan (`placement_scan.rs`) planned as longer
//! swings: what a route needs to plan when the automatic swing time `T` is too short for it (the
//! measurements behind the obstacle race's longer-swing candidates, docs/planner-measurements.md,
//! "The oracle").
//!
//! For each placement listed, the routes to the goal poses at the bar are searched as the oracle
//! searches them (`placement_oracle.rs`), each printed with its inverse-dynamics torque ratio when
//! timed over `T`, `1.25 T`, `1.5 T` and `2 T`; the routes chosen are planned in each variant: a
//! coarse solve (90 ms knots, at most 200 iterations), then the fine solve (30 ms knots, at most 1000
//! iterations) warm from the coarse plan when it converged or stopped at its limit, and from the
//! route itself when that gave no clear plan. Variants (the route timed over the swing time the
//! solves start at):
//! - `fixed2`, `fixed15`: the swing time fixed at `2 T`, `1.5 T`;
//! - `free2`: free in `[T, 2 T]` from `2 T` (the fine solve warm from the coarse plan starts at its
//!   swing time), as the planner's longer-swing candidates;
//! - `cf2`: the coarse solve as `free2`, the fine solves fixed at the coarse plan's swing time.
//!
//! Ignored (minutes per placement):
//! `BRACHIA_LONGER_SEEDS=23,40 cargo test --release -p brachia --test placement_longer_swing -- --ignored --nocapture`;
//! `BRACHIA_LONGER_GOALS` and `BRACHIA_LONGER_ROUTES` bound the goal poses and the routes per goal
//! (8 and 4 by default, the oracle's; 3 and 2 are the planner's race), `BRACHIA_LONGER_ONLY=1:1,4:3`
//! plans only those goal:route pairs, `BRACHIA_LONGER_VARIANTS=free2,fixed2` the variants listed
//! (`free2` by default). Units: m, s.

mod common;

use brachia::model::Robot;
use brachia::planning::strategy::cspace::{cspace_routes, time_path, CspaceReport};
use brachia::planning::strategy::goal::{
    clear_final_pose_until, distinct_goal_poses, with_final_pose,
};
use brachia::planning::{
    plan_with_guess, NlpSettings, Plan, PlannerSettings, SolveStatus, SwingTask,
};
use brachia::trajectory::Trajectory;
use common::placement::{
    free_swing, keeps_margin, min_clearance, nlp, settings_for, swing_placement,
};
use std::time::Instant;

/// Iteration limits of the coarse and the fine solve.
const COARSE_ITER: usize = 200;
const FINE_ITER: usize = 1000;

fn env_list<T: std::str::FromStr>(name: &str) -> Option<Vec<T>> {
    std::env::var(name)
        .ok()
        .map(|v| v.split(',').filter_map(|x| x.trim().parse().ok()).collect())
}

fn env_usize(name: &str, default: usize) -> usize {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// One variant's swing times: the factor the route is timed over and the solves start at, and the
/// free range (none: fixed), with whether the fine solves are fixed at the coarse plan's swing time.
fn variant(name: &str, t: f64) -> Option<(f64, Option<[f64; 2]>, bool)> {
    match name {
        "fixed2" => Some((2.0, None, false)),
        "fixed15" => Some((1.5, None, false)),
        "free2" => Some((2.0, Some([t, 2.0 * t]), false)),
        "cf2" => Some((2.0, Some([t, 2.0 * t]), true)),
        _ => None,
    }
}

/// Plan `task` from the route `g` (timed over `f T`) in the variant's swing times; one line.
fn attempt(
    robot: &Robot,
    task: &SwingTask,
    t: f64,
    (f, range, fixed_fine): (f64, Option<[f64; 2]>, bool),
    g: &Trajectory,
) -> String {
    let s = PlannerSettings::default();
    let t0 = Instant::now();
    let solve = |st: &PlannerSettings, cap: usize, from: &Trajectory| -> Plan {
        let n = NlpSettings {
            max_iter: cap,
            ..nlp(600.0)
        };
        plan_with_guess(robot, task, st, &n, Some(from)).unwrap()
    };
    let c = solve(&settings_for(f * t, range, 0.09), COARSE_ITER, g);
    let mut total = c.iterations;
    let mut line = vec![format!(
        "coarse {:?} {} it T {:.3} {:.1} s",
        c.status,
        c.iterations,
        c.swing_time_s,
        t0.elapsed().as_secs_f64()
    )];
    let mut froms = vec![];
    if c.status.is_converged() || c.status == SolveStatus::MaxIterations {
        froms.push((c.points.clone(), c.swing_time_s, "fine from coarse"));
    }
    froms.push((g.clone(), f * t, "fine from route"));
    for (from, ts, tag) in froms {
        let t1 = Instant::now();
        let (ts, fr) = match (range, fixed_fine) {
            (Some(_), true) => (c.swing_time_s, None),
            (Some(_), false) => (ts, range),
            (None, _) => (f * t, None),
        };
        let p = solve(&settings_for(ts, fr, 0.03), FINE_ITER, &from);
        total += p.iterations;
        let d = min_clearance(robot, &task.obstacles, &p.trajectory);
        // a converged plan is never reported through the obstacle (the planner's own check)
        assert!(
            !p.converged() || keeps_margin(&s, d),
            "{tag}: converged at clearance {d:.4} m"
        );
        let clear = p.converged();
        line.push(format!(
            "{tag} {:?} {} it T {:.3} clearance {d:.4} m {:.1} s{}",
            p.status,
            p.iterations,
            p.swing_time_s,
            t1.elapsed().as_secs_f64(),
            if clear { " CLEAR" } else { "" }
        ));
        if clear {
            break;
        }
    }
    format!(
        "{} | {total} iterations, {:.1} s, load {}",
        line.join("; "),
        t0.elapsed().as_secs_f64(),
        std::fs::read_to_string("/proc/loadavg")
            .unwrap_or_default()
            .trim()
    )
}

#[test]
#[ignore = "minutes per placement: C-space routes planned as longer swings"]
fn configuration_space_routes_planned_as_longer_swings() {
    let robot = Robot::paper();
    let free = free_swing(&robot, &SwingTask::paper(), "paper", 30.0);
    let t = free.swing_time_s;
    let seeds: Vec<u64> = env_list("BRACHIA_LONGER_SEEDS").unwrap_or_else(|| vec![23]);
    let only: Option<Vec<String>> = env_list("BRACHIA_LONGER_ONLY");
    let variants: Vec<String> =
        env_list("BRACHIA_LONGER_VARIANTS").unwrap_or_else(|| vec!["free2".to_string()]);
    let k_goals = env_usize("BRACHIA_LONGER_GOALS", 8);
    let k_routes = env_usize("BRACHIA_LONGER_ROUTES", 4);
    let s = PlannerSettings::default();
    let never = || false;
    for seed in seeds {
        let Some(pl) = swing_placement(&robot, &free, seed) else {
            eprintln!("seed {seed}: overlaps the start pose");
            continue;
        };
        let task = SwingTask {
            obstacles: pl.obstacles.clone(),
            ..SwingTask::paper()
        };
        let pts = &free.points;
        let last = pts.q(pts.len() - 1).to_vec();
        let base =
            match clear_final_pose_until(&robot, &pl.obstacles, &s, &last, task.target, &never)
                .unwrap()
            {
                Some(q) => with_final_pose(pts, &q),
                None => pts.clone(),
            };
        let q_end = base.q(base.len() - 1);
        let goals = distinct_goal_poses(
            &robot,
            &pl.obstacles,
            &s,
            q_end,
            task.target,
            k_goals,
            &never,
        )
        .unwrap();
        eprintln!(
            "seed {seed}: {}, T {t:.3} s, {} goal poses",
            pl.what,
            goals.len()
        );
        for (gi, goal) in goals.iter().enumerate() {
            let axis = with_final_pose(&base, goal);
            let routes =
                cspace_routes(&robot, &pl.obstacles, &s, base.q(0), goal, k_routes, &never)
                    .unwrap();
            for (rep, path) in routes {
                let Some(path) = path else { continue };
                let timed = |f: f64| -> (Trajectory, f64) {
                    let mut r: CspaceReport = rep.clone();
                    let g = time_path(&robot, &path, &axis.times_stretched(f), &mut r);
                    (g, r.peak_torque_ratio)
                };
                let ratios: Vec<String> = [1.0, 1.25, 1.5, 2.0]
                    .iter()
                    .map(|&f| format!("{:.2}", timed(f).1))
                    .collect();
                eprintln!(
                    "  goal {gi} route {}: torque ratio at T, 1.25 T, 1.5 T, 2 T: {}",
                    rep.route,
                    ratios.join(" ")
                );
                let pair = format!("{gi}:{}", rep.route);
                if only.as_ref().is_some_and(|o| !o.contains(&pair)) {
                    continue;
                }
                for v in &variants {
                    let Some(var) = variant(v, t) else {
                        eprintln!("    {v}: not a variant (fixed2, fixed15, free2, cf2)");
                        continue;
                    };
                    let (g, _) = timed(var.0);
                    eprintln!("    {v}: {}", attempt(&robot, &task, t, var, &g));
                }
            }
        }
    }
}
