//! Plans that do not fail on obstacles: collision-free initial guesses (detour seeds, continuation on
//! the obstacle radii), and a diagnosis of what blocks the swing when no strategy converges.
//!
//! The default guess (a smooth step to an inverse-kinematics target pose, [`crate::planning::planner`]) ignores the
//! obstacles between the two poses; when it cuts through one, the interior point starts deep inside the
//! infeasible set and its restoration phase often fails. [`crate::planning::plan_with_guess`] then
//! 1. plans the swing without the obstacles (self-collision kept) from the default guess;
//! 2. tries the detour seeds of [`super::detour`] (the obstacle-free plan deformed around the
//!    obstacles by barrier tracking, in a fixed measured order), each solved at full radius from its guess,
//!    stopping at the first that converges;
//! 3. tries the configuration-space seed of [`super::cspace`] (a collision-free joint path of another
//!    homotopy class, found by a grid search), and when its solve fails, plans it with the torque
//!    limits scaled by [`TORQUE_RELAX`] and then at the real limits from that plan (continuation on the
//!    actuator limits: the seed, timed over the swing, may need more torque than the limits allow);
//! 4. grows every obstacle from a fraction `s` of its radius to the full radius, each step warm-started
//!    from the previous converged plan (`s` doubles its step after a success, halves it after a
//!    failure, down to [`MIN_SCALE_STEP`]). This rescues obstacles a link passes near; an obstacle the
//!    swing sweeps through is not rescued, at any radius (measured: docs/planner.md, "Obstacles on the
//!    path"), because a planar chain hanging from the grip lets a point it sweeps escape only past its
//!    free end: avoiding it changes the whole swing, not a neighbourhood of it (which is what the
//!    detour and C-space seeds of steps 2 and 3 do).
//!
//! The guesses of steps 2 to 4 are trajectories (a plan's knots or collocation points), so the
//! strategies work for every transcription and backend. Units: m, s.

use crate::error::Result;
use crate::model::{Circle, ClearanceFn, ClearancePair, Robot};
use crate::planning::nlp::{NlpSettings, SolveStatus};
use crate::planning::outcome::Plan;
use crate::planning::outcome::SolveRole;
use crate::planning::report::{Blockage, GuessReport, GuessStrategy, LinkClearance};
use crate::planning::settings::ObstacleGuess;
use crate::planning::settings::PlannerSettings;
use crate::planning::solve::common::target_pose;
use crate::planning::solve::plan_single;
use crate::planning::solve_log::SolveLog;
use crate::planning::strategy::torque_continuation::with_torque_scale;
use crate::planning::task::SwingTask;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Smallest step of the radius scale before the continuation gives up.
pub const MIN_SCALE_STEP: f64 = 1.0 / 16.0;
/// First step of the radius scale after the obstacle-free plan.
pub const FIRST_SCALE_STEP: f64 = 0.5;
/// Factor on the torque limits of the first solve of the actuator-limit continuation from the C-space
/// seed (measured on the scan's #4 and #7: docs/planner.md, "The two placements that still fail").
pub const TORQUE_RELAX: f64 = 2.0;
/// Iteration limit of one intermediate continuation solve, and of the final attempt after the
/// continuation gave up (the step at full radius keeps the settings' `max_iter`): a step that does not
/// converge within it is retried with a smaller step.
pub const STEP_MAX_ITER: usize = 60;

/// Index of the first obstacle whose surface is within the last link's radius plus the margin of
/// the target bar: the last link ends at the bar, so no grasping pose clears it (the task is
/// infeasible).
pub fn obstacle_on_bar(robot: &Robot, task: &SwingTask, margin: f64) -> Option<usize> {
    let r_last = robot.radius[robot.n - 1];
    task.obstacles.iter().position(|o| {
        (task.target[0] - o.center[0]).hypot(task.target[1] - o.center[1]) - o.radius
            < r_last + margin
    })
}

/// `task` with every obstacle's radius scaled by `s`.
fn scaled(task: &SwingTask, s: f64) -> SwingTask {
    SwingTask {
        obstacles: task
            .obstacles
            .iter()
            .map(|o| Circle {
                center: o.center,
                radius: s * o.radius,
            })
            .collect(),
        ..task.clone()
    }
}

/// Whether the smooth step from `q0` to the target pose (sampled at 100 points) clears every
/// obstacle by the margin. Errors as [`target_pose`].
fn smooth_step_is_clear(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
) -> Result<bool> {
    let cf = ClearanceFn::new(
        robot.clone(),
        task.obstacles.as_slice(),
        settings.obstacle_margin,
    )?
    .with_self_collision(false);
    let q_t = target_pose(robot, task, settings, Some(&cf))?;
    let mut q = vec![0.0; robot.n];
    let clear = (0..=100).all(|j| {
        let r = j as f64 / 100.0;
        let s = r * r * (3.0 - 2.0 * r);
        for i in 0..robot.n {
            q[i] = task.q0[i] + s * (q_t[i] - task.q0[i]);
        }
        cf.min_clearance(&q) >= settings.obstacle_margin
    });
    Ok(clear)
}

/// The worst obstacle row of `points` against the task's obstacles (margin as in `settings`), with
/// every obstacle's closest approach to every link.
pub fn diagnose(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    points: &Trajectory,
    free_final_pose: Option<&[f64]>,
) -> Result<Option<Blockage>> {
    if task.obstacles.is_empty() || points.is_empty() {
        return Ok(None);
    }
    let margin = settings.obstacle_margin;
    let shared = Arc::new(robot.clone());
    let cf = ClearanceFn::new(Arc::clone(&shared), task.obstacles.as_slice(), 0.0)?
        .with_self_collision(false);
    let pairs = cf.pairs();
    let mut d = vec![0.0; pairs.len()];
    // per row (link-major, obstacle inner): the smallest distance and its time
    let mut closest = vec![(f64::INFINITY, 0.0); pairs.len()];
    for k in 0..points.len() {
        cf.surface_distances(points.q(k), &mut d);
        for (c, v) in closest.iter_mut().zip(&d) {
            if *v < c.0 {
                *c = (*v, points.t[k]);
            }
        }
    }
    let mut clearances: Vec<LinkClearance> = pairs
        .iter()
        .zip(&closest)
        .filter_map(|(p, &(m, t))| match *p {
            ClearancePair::LinkObstacle { link, obstacle } => Some(LinkClearance {
                obstacle,
                link,
                min_clearance_m: m,
                time_s: t,
                violated: m < margin,
            }),
            ClearancePair::JointLink { .. } | ClearancePair::LinkLink { .. } => None,
        })
        .collect();
    clearances.sort_by_key(|c| (c.obstacle, c.link));
    // the worst row; ties go to the first in row order
    let Some(w) = clearances
        .iter()
        .fold(None::<&LinkClearance>, |b, c| match b {
            Some(b) if b.min_clearance_m <= c.min_clearance_m => Some(b),
            _ => Some(c),
        })
    else {
        return Ok(None);
    };
    let (link, obstacle, time_s, dmin) = (w.link, w.obstacle, w.time_s, w.min_clearance_m);
    let one = [task.obstacles[obstacle]];
    let cf1 = ClearanceFn::new(shared, one, 0.0)?.with_self_collision(false);
    let o = &task.obstacles[obstacle];
    let r_last = robot.radius[robot.n - 1];
    let bar = (task.target[0] - o.center[0]).hypot(task.target[1] - o.center[1]) - o.radius;
    Ok(Some(Blockage {
        link,
        obstacle,
        time_s,
        violation_m: margin - dmin,
        start_overlaps: cf1.min_clearance(&task.q0) < margin,
        final_pose_overlaps: free_final_pose.map(|q| cf1.min_clearance(q) < margin),
        bar_overlaps: bar < r_last + margin,
        infeasible: obstacle_on_bar(robot, task, margin).is_some(),
        clearances,
    }))
}

/// Plan with a collision-free initial guess (see the module docs); called by
/// [`crate::planning::plan_with_guess`] without a guess when obstacles are avoided. The returned plan lists
/// every solve in `solves` (and counts them in `iterations`, `attempts` and `solve_time_s`), carries
/// a [`GuessReport`], and, when it did not converge, a [`Blockage`]. `nlp.max_wall_time_s` bounds
/// the whole call: each solve gets what is left, and none starts once it is spent (the smooth
/// step's attempt is then returned).
pub(crate) fn plan_around_obstacles(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
) -> Result<Plan> {
    let started = std::time::Instant::now();
    let mut p = strategies(robot, task, settings, nlp, started)?;
    // the time limit ended the strategies: they went past the first solve, none converged, and
    // nothing is left of the limit (a solve it stopped ends once it is spent)
    let spent = !p.converged() && nlp.remaining(started).is_none();
    if let Some(g) = p.guess.as_mut() {
        g.out_of_time = spent && g.strategy != GuessStrategy::SmoothStep;
    }
    Ok(p)
}

/// The strategies of [`plan_around_obstacles`], for a call that began at `started`.
fn strategies(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
) -> Result<Plan> {
    let clear = smooth_step_is_clear(robot, task, settings)?;
    let mut rep = GuessReport {
        strategy: GuessStrategy::SmoothStep,
        smooth_step_clear: clear,
        solves: 0,
        iterations: 0,
        solve_time_s: 0.0,
        scales: vec![],
        seeds: vec![],
        cspace: None,
        out_of_time: false,
    };
    // the smooth step first, always: where it converged before, the plan is the same
    let mut log = SolveLog::default();
    let mut best = plan_single(robot, task, settings, nlp, None)?;
    log.record(&mut best, SolveRole::Task);
    // an obstacle on the bar: no guess can help, the first solve's attempt is diagnosed
    if best.converged()
        || settings.obstacle_guess == ObstacleGuess::Direct
        || obstacle_on_bar(robot, task, settings.obstacle_margin).is_some()
    {
        return Ok(finish(robot, task, settings, best, rep, log, None));
    }
    // `nlp` with what is left of the call's time limit and at most `cap` iterations; `None` once
    // the time is spent
    let within = |cap: usize| nlp.remaining(started).map(|n| n.capped(cap));
    rep.strategy = GuessStrategy::Continuation;
    let no_obstacles = SwingTask {
        obstacles: vec![],
        ..task.clone()
    };
    let Some(run) = within(usize::MAX) else {
        return Ok(finish(robot, task, settings, best, rep, log, None));
    };
    // an obstacle-free task can still be refused (e.g. a target out of reach): that is the error
    let mut free = plan_single(robot, &no_obstacles, settings, &run, None)?;
    log.record(&mut free, SolveRole::ObstacleFree);
    let free_final = free.points.q(free.points.len() - 1).to_vec();
    let ff = Some(free_final.as_slice());
    if !free.converged() {
        return Ok(finish(robot, task, settings, best, rep, log, ff));
    }
    // detour seeds in order, each solved at full radius until one converges
    rep.strategy = GuessStrategy::Detour;
    if within(usize::MAX).is_none() {
        return Ok(finish(robot, task, settings, best, rep, log, ff));
    }
    let seeds = crate::planning::strategy::detour::detour_seeds(
        robot,
        &task.obstacles,
        settings,
        &free.points,
    )?;
    rep.seeds = seeds.iter().map(|(r, _)| r.clone()).collect();
    for (i, (_, g)) in seeds.iter().enumerate() {
        let role = SolveRole::DetourSeed { index: i };
        let Some(p) = solve_seed(robot, task, settings, &within, g, role, &mut log)? else {
            return Ok(finish(robot, task, settings, best, rep, log, ff));
        };
        rep.seeds[i].converged = Some(p.converged());
        if p.converged() {
            return Ok(finish(robot, task, settings, p, rep, log, ff));
        }
        // a failed seed's plan is not the one returned: the smooth step's attempt (`best`) shows the
        // obstacle cutting through the swing, which is what the diagnosis names
    }
    // the configuration-space seed: a path of another homotopy class than the obstacle-free swing's
    rep.strategy = GuessStrategy::Cspace;
    if within(usize::MAX).is_none() {
        return Ok(finish(robot, task, settings, best, rep, log, ff));
    }
    let (mut crep, seed) = crate::planning::strategy::cspace::cspace_seed(
        robot,
        &task.obstacles,
        settings,
        &free.points,
    )?;
    if let Some(g) = seed {
        let role = SolveRole::CspaceSeed;
        let Some(p) = solve_seed(robot, task, settings, &within, &g, role, &mut log)? else {
            rep.cspace = Some(crep);
            return Ok(finish(robot, task, settings, best, rep, log, ff));
        };
        crep.converged = Some(p.converged());
        if p.converged() {
            rep.cspace = Some(crep);
            return Ok(finish(robot, task, settings, p, rep, log, ff));
        }
        // continuation on the actuator limits: the seed's path, timed over T, needs more torque than
        // the limits allow; planned with the limits widened, then at the real ones from that plan
        let wide = with_torque_scale(robot, TORQUE_RELAX)?;
        let mut relaxed = None;
        if let Some(run) = within(usize::MAX) {
            let mut p = plan_single(&wide, task, settings, &run, Some(&g))?;
            log.record(
                &mut p,
                SolveRole::TorqueScale {
                    scale: TORQUE_RELAX,
                },
            );
            crep.relaxed_converged = Some(p.converged());
            relaxed = Some(p);
        }
        if let (Some(w), Some(run)) = (relaxed.filter(|p| p.converged()), within(usize::MAX)) {
            let mut p = plan_single(robot, task, settings, &run, Some(&w.points))?;
            log.record(&mut p, SolveRole::TorqueScale { scale: 1.0 });
            crep.converged = Some(p.converged());
            if p.converged() {
                rep.cspace = Some(crep);
                return Ok(finish(robot, task, settings, p, rep, log, ff));
            }
        }
    }
    rep.cspace = Some(crep);
    rep.strategy = GuessStrategy::Continuation;
    rep.scales.push(0.0);
    let mut guess = free.points;
    let (mut done, mut step) = (0.0f64, FIRST_SCALE_STEP);
    while step >= MIN_SCALE_STEP {
        let s = (done + step).min(1.0);
        let last = s >= 1.0;
        let Some(run) = within(if last { usize::MAX } else { STEP_MAX_ITER }) else {
            break;
        };
        let mut p = plan_single(robot, &scaled(task, s), settings, &run, Some(&guess))?;
        log.record(&mut p, SolveRole::ObstacleScale { scale: s });
        if p.converged() {
            rep.scales.push(s);
            if last {
                return Ok(finish(robot, task, settings, p, rep, log, ff));
            }
            guess = p.points;
            done = s;
            step *= 2.0;
        } else {
            step *= 0.5;
        }
    }
    // nothing converged: the smooth step's attempt, diagnosed
    Ok(finish(robot, task, settings, best, rep, log, ff))
}

/// Plan from the seed `g` (a solve for `role`, recorded in `log`) with the settings `within` gives
/// (`None`: the time is spent, nothing solved); a solve that ran out of iterations, not of ideas,
/// resumes once from where it stopped.
fn solve_seed(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    within: &dyn Fn(usize) -> Option<NlpSettings>,
    g: &Trajectory,
    role: SolveRole,
    log: &mut SolveLog,
) -> Result<Option<Plan>> {
    let Some(run) = within(usize::MAX) else {
        return Ok(None);
    };
    let mut p = plan_single(robot, task, settings, &run, Some(g))?;
    log.record(&mut p, role);
    if p.status == SolveStatus::MaxIterations {
        if let Some(run) = within(usize::MAX) {
            let mut resumed = plan_single(robot, task, settings, &run, Some(&p.points))?;
            log.record(&mut resumed, SolveRole::Resumed);
            p = resumed;
        }
    }
    Ok(Some(p))
}

/// Attach every solve (`log`), the totals, the report and (if not converged) the diagnosis to `p`.
#[allow(clippy::too_many_arguments)]
fn finish(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    mut p: Plan,
    mut rep: GuessReport,
    log: SolveLog,
    free_final: Option<&[f64]>,
) -> Plan {
    let all = log.totals(|_| true);
    (rep.solves, rep.iterations, rep.solve_time_s) = (all.attempts, all.iterations, all.time_s);
    log.finish(&mut p);
    if !p.converged() {
        p.blockage = diagnose(robot, task, settings, &p.points, free_final)
            .ok()
            .flatten();
    }
    p.guess = Some(rep);
    p
}

/// One obstacle placement of a scan: a circle at the midpoint of `link` at time `time_s` of a swing.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Placement {
    /// Time on the swing, s.
    pub time_s: f64,
    /// 0-based link index.
    pub link: usize,
    /// The obstacle.
    pub obstacle: Circle,
}

/// Obstacles of `radius` (m) at the midpoint of every link at `times` evenly spaced times
/// `t_j = T j / (times + 1)`, `j = 1..=times`, of the swing `points` (the knot at or before `t_j`),
/// skipping those whose surface is within `margin` (m) of the start pose or of the swing's final
/// pose, or within the last link's radius plus `margin` of `target` (the bar). Time-major, then link.
pub fn path_placements(
    robot: &Robot,
    points: &Trajectory,
    target: [f64; 2],
    radius: f64,
    margin: f64,
    times: usize,
) -> Result<Vec<Placement>> {
    let n = robot.n;
    let mut segs = vec![([0.0; 2], [0.0; 2]); n];
    let (q_start, q_end) = (points.q(0), points.q(points.len() - 1));
    let t_final = points.t[points.len() - 1];
    let shared = Arc::new(robot.clone());
    let mut out = vec![];
    for j in 1..=times {
        let t = points.t[0] + (t_final - points.t[0]) * j as f64 / (times + 1) as f64;
        let (k, _) = points.locate(t);
        robot.link_segments(points.q(k), &mut segs);
        for (link, (a, b)) in segs.iter().enumerate() {
            let obstacle = Circle {
                center: [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])],
                radius,
            };
            let cf =
                ClearanceFn::new(Arc::clone(&shared), [obstacle], 0.0)?.with_self_collision(false);
            let bar =
                (target[0] - obstacle.center[0]).hypot(target[1] - obstacle.center[1]) - radius;
            if cf.min_clearance(q_start) > margin
                && cf.min_clearance(q_end) > margin
                && bar > robot.radius[n - 1] + margin
            {
                out.push(Placement {
                    time_s: t,
                    link,
                    obstacle,
                });
            }
        }
    }
    Ok(out)
}
