//! The hard search of the placement oracles (`placement_oracle.rs`, and the held-out scan's oracle
//! in `placement_heldout.rs`): every detour seed and C-space routes to more goal poses and more
//! routes per goal than the planner's race, at the task's swing time and at longer ones, coarse to
//! fine with more iterations and the continuation on the torque limits; the first plan that
//! converges with its 1 ms trajectory clear ends the search. Units: m, s.

use super::placement::{keeps_margin, min_clearance, nlp, settings_for, Placement};
use brachia::model::Robot;
use brachia::planning::strategy::cspace::{cspace_routes, time_path, CspaceReport};
use brachia::planning::strategy::detour::detour_seeds;
use brachia::planning::strategy::goal::{
    clear_final_pose_until, distinct_goal_poses, with_final_pose,
};
use brachia::planning::strategy::torque_continuation::with_torque_scale;
use brachia::planning::{plan_with_guess, NlpSettings, Plan, PlannerSettings, SwingTask};
use brachia::trajectory::Trajectory;
use std::time::Instant;

/// Goal poses the oracle searches routes to (the seeds' final pose included).
const ORACLE_GOALS: usize = 8;
/// Routes per goal pose.
const ORACLE_ROUTES: usize = 4;
/// Iteration limits of the coarse and the fine solve.
const COARSE_ITER: usize = 1000;
const FINE_ITER: usize = 3000;
/// Swing-time factors tried at a fixed swing time, after the task's own (1).
const FACTORS: [f64; 3] = [2.0, 1.5, 1.25];

/// One seed of the oracle: where it came from and its guess (on the unobstructed swing's time axis);
/// a C-space seed also keeps its route and time axis, to be timed over a longer swing.
struct Seed {
    label: String,
    guess: Trajectory,
    route: Option<(Vec<Vec<f64>>, Trajectory, CspaceReport)>,
}

impl Seed {
    /// The guess for a swing of `factor` times the unobstructed one: a C-space route timed over the
    /// longer swing (its torques those of the slower motion), a detour seed as it is.
    fn timed(&self, robot: &Robot, factor: f64) -> Trajectory {
        let Some((path, axis, rep)) = self.route.as_ref().filter(|_| factor != 1.0) else {
            return self.guess.clone();
        };
        time_path(robot, path, &axis.times_stretched(factor), &mut rep.clone())
    }
}

/// Every seed: the detour seeds, then the C-space routes ranked by their torque ratio.
fn seeds(robot: &Robot, s: &PlannerSettings, free: &Plan, task: &SwingTask) -> Vec<Seed> {
    let never = || false;
    let obstacles = &task.obstacles[..];
    let pts = &free.points;
    let last = pts.q(pts.len() - 1).to_vec();
    let target = task.target;
    let base = match clear_final_pose_until(robot, obstacles, s, &last, target, &never).unwrap() {
        Some(q) => with_final_pose(pts, &q),
        None => pts.clone(),
    };
    let mut out: Vec<Seed> = detour_seeds(robot, obstacles, s, &base)
        .unwrap()
        .into_iter()
        .map(|(r, g)| Seed {
            label: format!("detour {:?}", r.kind),
            guess: g,
            route: None,
        })
        .collect();
    let q_end = base.q(base.len() - 1);
    let goals =
        distinct_goal_poses(robot, obstacles, s, q_end, target, ORACLE_GOALS, &never).unwrap();
    let mut cs = vec![];
    let (mut searched, mut exhausted, mut unclear) = (0, 0, 0);
    for (gi, goal) in goals.iter().enumerate() {
        let axis = with_final_pose(&base, goal);
        let routes =
            cspace_routes(robot, obstacles, s, base.q(0), goal, ORACLE_ROUTES, &never).unwrap();
        for (mut rep, path) in routes {
            searched += 1;
            exhausted += usize::from(rep.exhausted && !rep.found);
            unclear += usize::from(!rep.endpoints_clear);
            if let Some(path) = path {
                let g = time_path(robot, &path, &axis, &mut rep);
                cs.push((
                    rep.peak_torque_ratio,
                    Seed {
                        label: format!(
                            "cspace goal {gi} route {} (torque ratio {:.2})",
                            rep.route, rep.peak_torque_ratio
                        ),
                        guess: g,
                        route: Some((path, axis.clone(), rep.clone())),
                    },
                ));
            }
        }
    }
    eprintln!(
        "  {} goal poses, {searched} C-space searches: {} routes, {exhausted} exhausted, \
         {unclear} with an end pose within the margin",
        goals.len(),
        cs.len()
    );
    cs.sort_by(|a, b| a.0.total_cmp(&b.0));
    out.extend(cs.into_iter().map(|(_, s)| s));
    out
}

/// `s` with `BRACHIA_ORACLE_SUBSTEPS` RK4 steps per shooting interval when that is set (the
/// clearance rows at the sub-steps then closer together), else as it is.
fn with_substeps(mut s: PlannerSettings) -> PlannerSettings {
    if let Some(k) = std::env::var("BRACHIA_ORACLE_SUBSTEPS")
        .ok()
        .and_then(|v| v.parse().ok())
    {
        s.shooting.substeps = k;
    }
    s
}

/// What one attempt gave: a clear plan (with its iterations and swing time) or why not.
struct Attempt {
    clear: Option<(usize, f64, f64)>,
    line: String,
}

/// Plan `task` from `g`: coarse (90 ms knots), then fine warm from the coarse plan (from `g` when
/// the coarse solve failed), and from `g` itself when the coarse solve failed and the fine one from
/// it too; when no fine solve converged, the continuation on the torque limits: the fine task with
/// every limit scaled by 2, then by 8, from `g`, and the first that converges warm-starts the task
/// at the real limits. Each solve within the time `left`.
fn attempt(
    robot: &Robot,
    task: &SwingTask,
    t_s: f64,
    range: Option<[f64; 2]>,
    g: &Trajectory,
    left: &dyn Fn() -> Option<f64>,
    continuation: bool,
) -> Attempt {
    let run = |cap: usize| -> Option<NlpSettings> {
        left().map(|l| NlpSettings {
            max_iter: cap,
            ..nlp(l)
        })
    };
    let mut iters = 0;
    let mut notes = vec![];
    let coarse_s = settings_for(t_s, range, 0.09);
    let fine_s = with_substeps(settings_for(t_s, range, PlannerSettings::default().knot_dt));
    let mut solve = |r: &Robot, s: &PlannerSettings, cap: usize, from: &Trajectory, tag: &str| {
        let n = run(cap)?;
        match plan_with_guess(r, task, s, &n, Some(from)) {
            Ok(p) => {
                iters += p.iterations;
                let d = min_clearance(robot, &task.obstacles, &p.trajectory);
                notes.push(format!("{tag} {:?} {d:.4}", p.status));
                let clear = p.converged() && keeps_margin(&PlannerSettings::default(), d);
                Some((p, clear, d))
            }
            Err(e) => {
                notes.push(format!("{tag} refused: {e}"));
                None
            }
        }
    };
    let mut done = None;
    let coarse = solve(robot, &coarse_s, COARSE_ITER, g, "coarse");
    let warm = coarse
        .as_ref()
        .filter(|(p, _, _)| p.status.is_converged())
        .map(|(p, _, _)| (p.points.clone(), p.swing_time_s));
    // a free swing time's fine solve warm from the coarse plan starts at the coarse plan's
    let mut froms = vec![];
    if let Some((w, tw)) = &warm {
        let from_coarse = match range {
            Some(_) => with_substeps(settings_for(*tw, range, fine_s.knot_dt)),
            None => fine_s.clone(),
        };
        froms.push((w.clone(), from_coarse, "fine from coarse"));
    }
    froms.push((g.clone(), fine_s.clone(), "fine from seed"));
    for (from, st, tag) in &froms {
        if let Some((p, true, d)) = solve(robot, st, FINE_ITER, from, tag) {
            done = Some((p.swing_time_s, d));
            break;
        }
    }
    if done.is_none() && continuation {
        for k in [2.0, 8.0] {
            let wide = with_torque_scale(robot, k).unwrap();
            let Some((w, _, _)) = solve(&wide, &fine_s, FINE_ITER, g, &format!("tau x{k}")) else {
                break;
            };
            if !w.status.is_converged() {
                continue;
            }
            if let Some((p, true, d)) = solve(robot, &fine_s, FINE_ITER, &w.points, "real limits") {
                done = Some((p.swing_time_s, d));
            }
            break;
        }
    }
    Attempt {
        clear: done.map(|(ts, d)| (iters, ts, d)),
        line: notes.join(", "),
    }
}

/// Search one placement of the obstacle-free `task` (whose unobstructed swing is `free`) for up to
/// `budget_s`; the first clear plan's account, or `None`.
pub fn search(
    robot: &Robot,
    task: &SwingTask,
    free: &Plan,
    pl: &Placement,
    budget_s: f64,
) -> Option<String> {
    let t0 = Instant::now();
    let left = || {
        let l = budget_s - t0.elapsed().as_secs_f64();
        (l > 0.5).then_some(l)
    };
    let s = PlannerSettings::default();
    let task = SwingTask {
        obstacles: pl.obstacles.clone(),
        ..task.clone()
    };
    let all = seeds(robot, &s, free, &task);
    let t = free.swing_time_s;
    eprintln!(
        "  seed {}: {} seeds ({:.1} s to build), T = {t:.3} s",
        pl.seed,
        all.len(),
        t0.elapsed().as_secs_f64()
    );
    // every seed at the task's swing time, then the C-space seeds (other homotopy classes: the
    // detour seeds' class needs the same torque at any swing time) with a swing time free in
    // [T, 2 T] started at 2 T, then at fixed longer ones; each route timed over the swing time it
    // starts at
    let mut times: Vec<(String, f64, Option<[f64; 2]>)> = vec![(format!("T {t:.3}"), t, None)];
    times.push((
        format!("free [{t:.3}, {:.3}] from {:.3}", 2.0 * t, 2.0 * t),
        2.0 * t,
        Some([t, 2.0 * t]),
    ));
    for f in FACTORS {
        times.push((format!("T {:.3} ({f} T)", f * t), f * t, None));
    }
    let cs: Vec<usize> = (0..all.len())
        .filter(|&i| all[i].label.starts_with("cspace"))
        .collect();
    // `BRACHIA_ORACLE_CSPACE_ONLY=1`: the C-space seeds only (the detour seeds searched before)
    let first: Vec<usize> = match std::env::var_os("BRACHIA_ORACLE_CSPACE_ONLY") {
        Some(_) => cs.clone(),
        None => (0..all.len()).collect(),
    };
    let mut order: Vec<(usize, usize)> = first.into_iter().map(|i| (i, 0)).collect();
    for j in 1..times.len() {
        order.extend(cs.iter().map(|&i| (i, j)));
    }
    // `BRACHIA_ORACLE_LONGER_ONLY=1`: the C-space seeds at the longer swing times only, without the
    // torque continuation (a second pass after the first spent its budget at T)
    let longer_only = std::env::var_os("BRACHIA_ORACLE_LONGER_ONLY").is_some();
    if longer_only {
        order.retain(|&(i, j)| j > 0 && cs.contains(&i));
    }
    for (i, j) in order {
        let (sd, (what, ts, range)) = (&all[i], &times[j]);
        if left().is_none() {
            eprintln!("  seed {}: budget spent", pl.seed);
            return None;
        }
        let g = sd.timed(robot, ts / t);
        let a = attempt(robot, &task, *ts, *range, &g, &left, !longer_only);
        eprintln!("    {} | {what} | {}", sd.label, a.line);
        if let Some((it, ts, d)) = a.clear {
            return Some(format!(
                "{} at {what} (swing {ts:.3} s), {it} iterations, clearance {d:.4} m, after {:.1} s",
                sd.label,
                t0.elapsed().as_secs_f64()
            ));
        }
    }
    None
}
