//! Plans that do not fail on obstacles: collision-free initial guesses (detour seeds, continuation on
//! the obstacle radii), and a diagnosis of what blocks the swing when no strategy converges.
//!
//! The default guess (a smooth step to an inverse-kinematics target pose, [`crate::planning::planner`]) ignores the
//! obstacles between the two poses; when it cuts through one, the interior point starts deep inside the
//! infeasible set and its restoration phase often fails. [`crate::planning::plan_with_guess`] then
//! runs an ordered chain of strategies, each recorded in the plan's solves by its role:
//! 1. the smooth step alone, where its guess clears the obstacles (or nothing else is tried: with
//!    `obstacle_guess = "direct"`, or an obstacle on the target bar);
//! 2. the swing without the obstacles (self-collision kept), which the seeds deform;
//! 3. a final pose for the seeds that clears the obstacles, when the obstacle-free swing's does not
//!    ([`super::goal`]);
//! 4. the race ([`super::race`]), in this order: the smooth step (where its guess cuts through an
//!    obstacle, one solve stopped at its first chance or [`SMOOTH_STEP_MIN_ITER`], whichever is
//!    more), the forward detour seeds of [`super::detour`] (the obstacle-free plan deformed around
//!    the obstacles by barrier tracking), the best-ranked configuration-space seed of
//!    [`super::homotopy`] (a collision-free joint path of another homotopy class) and the same with
//!    a longer swing, the backward detour seeds, then the other configuration-space seeds in their
//!    rank, each followed by the same with a longer swing; solved two at a time, each seed coarse to
//!    fine ([`super::candidate`]); the first plan in order that converges wins, except over a
//!    candidate past its first chance (its sub-step re-solve, its solve again from the seed, its
//!    solve at the task's mesh past one iteration per knot interval), which a later converged
//!    candidate beats ([`super::race`]);
//! 5. when the best C-space seed's solve failed: that seed planned with the torque limits scaled
//!    by [`TORQUE_RELAX`] and then at the real limits from that plan (continuation on the actuator
//!    limits: the seed, timed over the swing, may need more torque than the limits allow);
//! 6. the diagnosis's detour (`widened.rs`): the best C-space seed with the limits widened 8x, then at
//!    the real limits, or with a free swing time under `swing_time = "auto"`;
//! 7. every obstacle grown from a fraction `s` of its radius to the full radius, each step
//!    warm-started from the previous converged plan (`s` doubles its step after a success, halves it
//!    after a failure, down to [`MIN_SCALE_STEP`]). This rescues obstacles a link passes near; an
//!    obstacle the swing sweeps through is not rescued, at any radius (measured: docs/planner.md,
//!    "Obstacles on the path"), because a planar chain hanging from the grip lets a point it sweeps
//!    escape only past its free end: avoiding it changes the whole swing, not a neighbourhood of it
//!    (which is what the detour and C-space seeds do).
//!
//! The guesses of steps 4 to 7 are trajectories (a plan's knots or collocation points), so the
//! strategies work for every transcription and backend. Units: m, s.

use crate::error::Result;
use crate::model::{Circle, ClearanceFn, ClearancePair, Robot};
use crate::planning::nlp::{NlpSettings, SolveStatus};
use crate::planning::outcome::Plan;
use crate::planning::outcome::SolveRole;
use crate::planning::report::{Blockage, GuessReport, GuessStrategy, LinkClearance};
use crate::planning::settings::ObstacleGuess;
use crate::planning::settings::{PlannerSettings, ValidSettings};
use crate::planning::solve::common::{covering_obstacles, target_pose};
use crate::planning::solve::plan_single;
use crate::planning::solve_log::SolveLog;
use crate::planning::strategy::candidate::{
    longer_swing_settings, solve_seed_coarse_to_fine, solve_seed_longer_swing, Again,
    LONGER_SWING_FACTOR,
};
use crate::planning::strategy::cspace::CspaceReport;
use crate::planning::strategy::further::{
    FurtherSearch, RaceRoutes, FURTHER_GOALS, FURTHER_ROUTES,
};
use crate::planning::strategy::homotopy::{
    homotopy_routes_continued, GoalSearches, RankedRoutes, MAX_GOALS, ROUTES_PER_GOAL,
};
use crate::planning::strategy::torque_continuation::with_torque_scale;
use crate::planning::strategy::widened::{widened_detour, Probed};
use crate::planning::strategy::{goal, race};
use crate::planning::task::{SwingTask, ValidTask};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::sync::{Arc, OnceLock};

/// Smallest step of the radius scale before the continuation gives up.
pub const MIN_SCALE_STEP: f64 = 1.0 / 16.0;
/// First step of the radius scale after the obstacle-free plan.
pub const FIRST_SCALE_STEP: f64 = 0.5;
/// Factor on the torque limits of the first solve of the actuator-limit continuation from the C-space
/// seed (measured on two placements of the scan: docs/planner-measurements.md).
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
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
) -> Result<(Plan, Probed)> {
    let started = std::time::Instant::now();
    let (mut p, probed) = strategies(robot, task, settings, nlp, started)?;
    // the time limit ended the strategies: they went past the first solve, none converged, and
    // nothing is left of the limit (a solve it stopped ends once it is spent)
    let spent = !p.converged() && nlp.remaining(started).is_none();
    if let Some(g) = p.guess.as_mut() {
        g.out_of_time = spent && g.strategy != GuessStrategy::SmoothStep;
    }
    Ok((p, probed))
}

/// Iteration limit of the smooth step's solve when its guess cuts through an obstacle and the race
/// did not run it (or ran it without a swing time). The settings' `max_iter` (default 500) bounds
/// it too.
pub const SMOOTH_STEP_RACE_MAX_ITER: usize = 600;

/// Fewest iterations of the smooth step's solve in the race: it stops at the larger of this and its
/// first chance ([`race::FIRST_CHANCE_ITER_PER_INTERVAL`] per knot interval: 75 for the paper's
/// swing on 30 ms knots, 223 on 10 ms knots). On the placement scans a smooth step in the race that
/// converged did so within 59 iterations on 30 ms knots, and none that ran 200 converged after
/// them; at 10 ms knots the smooth step of
/// `planner_shooting.rs::obstacle_is_avoided_by_multiple_shooting` converges in 177, to the optimum
/// the detour seeds miss (docs/planner-measurements.md).
pub const SMOOTH_STEP_MIN_ITER: usize = 100;

/// Where a candidate of the race came from.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    SmoothStep,
    Detour(usize),
    /// The C-space seed of this rank ([`super::homotopy`]).
    Cspace(usize),
    /// The C-space seed of this rank timed over a longer swing, the swing time free
    /// ([`super::candidate::solve_seed_longer_swing`]).
    CspaceLonger(usize),
    /// The further route of this rank as a longer swing ([`super::further`]).
    Further(usize),
}

/// The smooth step's plan of the task with what is left of the call begun at `started` (at least
/// 1 ms: a plan is returned), at most `cap` iterations.
fn smooth_step_now(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
    cap: usize,
) -> Result<Plan> {
    let run = nlp.remaining(started).unwrap_or_else(|| NlpSettings {
        max_wall_time_s: Some(1e-3),
        ..nlp.clone()
    });
    plan_single(robot, task, settings, &run.capped(cap), None)
}

/// The smooth step's plan from the solves of its race candidate, `ran` (each recorded in `log` in
/// order; the last is the plan), or, when it never started, solved now ([`smooth_step_now`]) and
/// recorded.
fn smooth_step_of(
    ran: Option<race::Plans>,
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
    log: &mut SolveLog,
) -> Result<Plan> {
    let mut last = None;
    for (role, mut p) in ran.unwrap_or_default() {
        log.record(&mut p, role);
        last = Some(p);
    }
    if let Some(p) = last {
        return Ok(p);
    }
    let cap = SMOOTH_STEP_RACE_MAX_ITER;
    let mut p = smooth_step_now(robot, task, settings, nlp, started, cap)?;
    log.record(&mut p, SolveRole::Task);
    Ok(p)
}

/// Whether a candidate's plans ended because the race was decided elsewhere (its last solve was
/// cancelled): it neither converged nor failed.
fn interrupted(plans: &race::Plans) -> bool {
    plans
        .last()
        .is_some_and(|(_, p)| p.status == SolveStatus::Cancelled)
}

/// The iteration limit of the smooth step's solve in the race, for a swing of `t_s` on knots
/// `knot_dt` apart, s: the larger of [`SMOOTH_STEP_MIN_ITER`] and its first chance
/// ([`race::first_chance_iter`]), or [`SMOOTH_STEP_RACE_MAX_ITER`] without a swing time.
fn smooth_step_cap(knot_dt: f64, t_s: f64) -> usize {
    race::first_chance_iter(knot_dt, t_s)
        .map_or(SMOOTH_STEP_RACE_MAX_ITER, |n| n.max(SMOOTH_STEP_MIN_ITER))
}

/// The smooth step as a candidate of the race (a swing of `t_s`, the automatic swing time; 0 when
/// unknown): one solve, stopped at [`smooth_step_cap`] iterations, at most the settings'
/// `max_iter`.
fn smooth_step_candidate<'a>(
    robot: &'a Robot,
    task: &'a ValidTask,
    settings: &'a ValidSettings,
    t_s: f64,
) -> race::Candidate<'a> {
    Box::new(move |run: &NlpSettings| {
        let cap = smooth_step_cap(settings.knot_dt, t_s);
        let first = race::with_first_chance(run, settings.knot_dt, t_s).capped(cap);
        let p = plan_single(robot, task, settings, &first, None)?;
        Ok(vec![(SolveRole::Task, p)])
    })
}

/// The strategies of [`plan_around_obstacles`], for a call that began at `started`, as an ordered
/// chain (the module docs): the smooth step alone where it clears the obstacles; the obstacle-free
/// swing; the race of the smooth step (where it does not clear them), the detour seeds and the
/// C-space seed; the actuator-limit continuation from the C-space seed; the radius continuation.
fn strategies(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
) -> Result<(Plan, Probed)> {
    let clear = smooth_step_is_clear(robot, task, settings)?;
    let mut rep = empty_report(clear);
    let mut log = SolveLog::default();
    let direct = settings.obstacle_guess == ObstacleGuess::Direct;
    let on_bar = obstacle_on_bar(robot, task, settings.obstacle_margin).is_some();
    // 1. the smooth step alone where its guess clears the obstacles (where it converged before, the
    // plan is the same) or where nothing else can help (an obstacle on the bar: the attempt is
    // diagnosed)
    let mut smooth = None;
    if clear || direct || on_bar {
        let mut p = plan_single(robot, task, settings, nlp, None)?;
        log.record(&mut p, SolveRole::Task);
        if p.converged() || direct || on_bar {
            return Ok((
                finish(robot, task, settings, p, rep, log, None),
                Probed::default(),
            ));
        }
        smooth = Some(p);
    }
    // 2. the obstacle-free swing, which the seeds deform (an obstacle-free task can still be
    // refused, e.g. a target out of reach: that is the error)
    rep.strategy = GuessStrategy::Continuation;
    let no_obstacles = task.without_obstacles();
    let mut free = match nlp.remaining(started) {
        Some(run) => Some(plan_single(robot, &no_obstacles, settings, &run, None)?),
        None => None,
    };
    let free_final = free
        .as_ref()
        .map(|f| f.points.q(f.points.len() - 1).to_vec());
    let ff = free_final.as_deref();
    let Some(free_points) = free
        .as_ref()
        .filter(|f| f.converged())
        .map(|f| f.points.clone())
    else {
        let best = match smooth {
            Some(p) => p,
            None => {
                let mut p = smooth_step_now(robot, task, settings, nlp, started, usize::MAX)?;
                log.record(&mut p, SolveRole::Task);
                p
            }
        };
        if let Some(f) = free.as_mut() {
            log.record(f, SolveRole::ObstacleFree);
        }
        let p = finish(robot, task, settings, best, rep, log, ff);
        return Ok((p, Probed::default()));
    };
    // 3. a clear final pose for the seeds; 4. the race: the smooth step (unless solved above), the detour seeds, the C-space seed
    // the seeds end at a pose that clears the obstacles (the obstacle-free swing's, or another
    // that grasps the bar)
    let last = free_points.q(free_points.len() - 1).to_vec();
    let spent = || nlp.remaining(started).is_none();
    // the seeds go round the obstacles that matter: one of two identical circles, none inside
    // another (a detour's barrier would count a duplicated obstacle twice)
    let obstacles = covering_obstacles(&task.obstacles);
    let obstacles = obstacles.as_slice();
    let seed_free =
        match goal::clear_final_pose_until(robot, obstacles, settings, &last, task.target, &spent)?
        {
            Some(q) => goal::with_final_pose(&free_points, &q),
            None => free_points.clone(),
        };
    let seeds =
        crate::planning::strategy::detour::detour_seeds(robot, obstacles, settings, &seed_free)?;
    rep.seeds = seeds.iter().map(|(r, _)| r.clone()).collect();
    // the homotopy search, run once by the first candidate that needs it (the others wait for it),
    // within that candidate's time limit and cancel token
    let cspace: OnceLock<RaceRoutes> = OnceLock::new();
    let further = FurtherSearch::new(robot, obstacles, settings, &seed_free, task.target);
    let t_auto = free.as_ref().map_or(0.0, |f| f.swing_time_s);
    let mut kinds = vec![];
    let mut cands: Vec<race::Candidate<'_>> = vec![];
    if smooth.is_none() {
        kinds.push(Kind::SmoothStep);
        cands.push(smooth_step_candidate(robot, task, settings, t_auto));
    }
    let seed_free = &seed_free;
    let longer = matches!(longer_swing_settings(settings, t_auto, t_auto), Some(Ok(_)));
    // the race's routes, its route searches kept for the further routes (when they run)
    let race_routes = &cspace;
    let search = move |run: &NlpSettings| -> &RaceRoutes {
        race_routes.get_or_init(|| {
            let t0 = std::time::Instant::now();
            let stop = || run.remaining(t0).is_none();
            let mut kept = if longer {
                GoalSearches::kept()
            } else {
                GoalSearches::default()
            };
            let limits = (MAX_GOALS, ROUTES_PER_GOAL);
            let (target, k) = (task.target, &mut kept);
            let routes = homotopy_routes_continued(
                robot, obstacles, settings, seed_free, target, limits, k, &stop,
            )
            .unwrap_or_default();
            let searches = std::sync::Mutex::new(kept);
            RaceRoutes { routes, searches }
        })
    };
    // the route of rank j and the time left of `run` once the search has run (its time counts)
    let route = move |run: &NlpSettings, j: usize| {
        let t0 = std::time::Instant::now();
        let h = &search(run).routes;
        Some((h.seeds.get(j)?, run.remaining(t0)?))
    };
    let order = race_order(seeds.len(), |i| seeds[i].0.kind.backward(), longer);
    let further = &further;
    for kind in order {
        kinds.push(kind);
        match kind {
            Kind::Detour(i) => {
                let g = &seeds[i].1;
                cands.push(Box::new(move |run: &NlpSettings| {
                    let role = SolveRole::DetourSeed { index: i };
                    solve_seed_coarse_to_fine(robot, task, settings, run, g, role, Again::FromSeed)
                }));
            }
            Kind::Cspace(j) => cands.push(Box::new(move |run: &NlpSettings| {
                let Some((sd, run)) = route(run, j) else {
                    return Ok(vec![]);
                };
                let g = &sd.guess;
                let role = SolveRole::CspaceSeed;
                solve_seed_coarse_to_fine(robot, task, settings, &run, g, role, Again::No)
            })),
            Kind::CspaceLonger(j) => cands.push(Box::new(move |run: &NlpSettings| {
                let Some((sd, run)) = route(run, j) else {
                    return Ok(vec![]);
                };
                // the route timed over the longest swing, where its torques are lowest
                let g = sd.retimed(robot, LONGER_SWING_FACTOR);
                solve_seed_longer_swing(robot, task, settings, &run, &g, t_auto)
            })),
            Kind::Further(j) => cands.push(Box::new(move |run: &NlpSettings| {
                // the race's routes first (searched now when no candidate needed them yet)
                further.solve(j, task, run, t_auto, search(run))
            })),
            Kind::SmoothStep => {}
        }
    }
    let outcome = race::race(&cands, nlp, started)?;
    drop(cands);
    let RankedRoutes {
        reports: mut routes,
        seeds: ranked,
        ..
    } = cspace.into_inner().unwrap_or_default().routes;
    // the report of the seed of rank j
    let of_rank = |j: usize| ranked.get(j).map(|sd| sd.report);
    let top = of_rank(0);
    // the solves in the report: the smooth step's first, then the obstacle-free plan, then the
    // candidates in their order
    let mut won_plan = None;
    let mut cspace_failed = false;
    let mut plans = outcome.plans;
    if kinds[0] == Kind::SmoothStep {
        let ran = plans[0].take();
        let p = smooth_step_of(ran, robot, task, settings, nlp, started, &mut log)?;
        if outcome.winner == Some(0) {
            rep.strategy = GuessStrategy::SmoothStep;
            won_plan = Some(p.clone());
        }
        smooth = Some(p);
    }
    if let Some(f) = free.as_mut() {
        log.record(f, SolveRole::ObstacleFree);
    }
    let mut further_concluded = vec![];
    for (c, kind) in kinds.iter().enumerate() {
        let Some(v) = plans[c].take() else {
            continue;
        };
        let concluded = (!interrupted(&v)).then(|| race::won(&v));
        match *kind {
            Kind::SmoothStep => continue,
            Kind::Detour(i) => rep.seeds[i].converged = concluded,
            Kind::Cspace(j) => {
                if let Some(i) = of_rank(j) {
                    routes[i].converged = concluded;
                }
                if j == 0 {
                    cspace_failed = concluded == Some(false);
                }
            }
            Kind::CspaceLonger(j) => {
                if let (Some(i), Some(true)) = (of_rank(j), concluded) {
                    routes[i].converged = Some(true);
                }
            }
            Kind::Further(j) => further_concluded.push((j, concluded)),
        }
        let n = v.len();
        for (k, (role, mut p)) in v.into_iter().enumerate() {
            log.record(&mut p, role);
            if outcome.winner == Some(c) && k + 1 == n {
                rep.strategy = match kind {
                    Kind::Cspace(_) | Kind::CspaceLonger(_) | Kind::Further(_) => {
                        GuessStrategy::Cspace
                    }
                    _ => GuessStrategy::Detour,
                };
                won_plan = Some(p);
            }
        }
    }
    let best = match smooth {
        Some(p) => p,
        None => smooth_step_now(
            robot,
            task,
            settings,
            nlp,
            started,
            SMOOTH_STEP_RACE_MAX_ITER,
        )?,
    };
    routes.extend(further.reports(&further_concluded));
    let cguess = ranked.into_iter().next().map(|sd| sd.guess);
    if let Some(p) = won_plan {
        put_cspace(&mut rep, routes, top);
        let p = finish(robot, task, settings, p, rep, log, ff);
        return Ok((p, Probed::default()));
    }
    let fallback = Fallback {
        cguess,
        cspace_failed,
        top,
        routes,
        best,
        free_points,
    };
    after_race(robot, task, settings, nlp, started, fallback, rep, log, ff)
}

/// The race's candidates after the smooth step, in their order: the forward detour seeds (they start
/// at the start pose, and win most), the best-ranked C-space seed (and with a longer swing), the
/// backward detour seeds (`backward(i)` of the `n_seeds`), the other C-space seeds in their rank,
/// each followed by the same with a longer swing when `longer`; then, when `longer`, the further
/// routes as longer swings ([`super::further`]).
fn race_order(n_seeds: usize, backward: impl Fn(usize) -> bool, longer: bool) -> Vec<Kind> {
    let (back, forward): (Vec<usize>, Vec<usize>) = (0..n_seeds).partition(|&i| backward(i));
    let mut order: Vec<Kind> = forward.into_iter().map(Kind::Detour).collect();
    let with_longer =
        |j: usize| std::iter::once(Kind::Cspace(j)).chain(longer.then_some(Kind::CspaceLonger(j)));
    order.extend(with_longer(0));
    order.extend(back.into_iter().map(Kind::Detour));
    order.extend((1..MAX_GOALS * ROUTES_PER_GOAL).flat_map(with_longer));
    if longer {
        order.extend((0..FURTHER_GOALS * FURTHER_ROUTES).map(Kind::Further));
    }
    order
}

/// What the race leaves to the fallbacks after it: the best-ranked C-space seed (`cguess`, its
/// report index `top`), whether its solve failed, every route's report, the plan to diagnose when
/// nothing converges (`best`) and the obstacle-free swing's knots.
struct Fallback {
    cguess: Option<Trajectory>,
    cspace_failed: bool,
    top: Option<usize>,
    routes: Vec<CspaceReport>,
    best: Plan,
    free_points: Trajectory,
}

/// Steps 5-7 of [`strategies`] when the race found no plan: the actuator-limit continuation from
/// the best C-space seed, the diagnosis's widened detour, the radius continuation.
#[allow(clippy::too_many_arguments)]
fn after_race(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
    fallback: Fallback,
    mut rep: GuessReport,
    mut log: SolveLog,
    ff: Option<&[f64]>,
) -> Result<(Plan, Probed)> {
    let Fallback {
        cguess,
        cspace_failed,
        top,
        mut routes,
        best,
        free_points,
    } = fallback;
    // 5. continuation on the actuator limits from the best C-space seed: its path, timed over T,
    // may need more torque than the limits allow; planned with the limits widened, then at the
    // real ones from that plan
    let mut crep = top.map(|i| routes[i].clone());
    if let (Some(g), true) = (cguess.as_ref(), cspace_failed) {
        if let Some(p) =
            cspace_torque_continuation(robot, task, settings, nlp, started, g, &mut crep, &mut log)?
        {
            rep.strategy = GuessStrategy::Cspace;
            if let (Some(i), Some(c)) = (top, crep) {
                routes[i] = c;
            }
            put_cspace(&mut rep, routes, top);
            let p = finish(robot, task, settings, p, rep, log, ff);
            return Ok((p, Probed::default()));
        }
    }
    if let (Some(i), Some(c)) = (top, crep) {
        routes[i] = c;
    }
    // 6. the diagnosis's detour: the seed with the limits widened as the torque probe does, then
    // at the real limits or with a longer swing
    let mut probed = Probed::default();
    if let Some(g) = cguess.as_ref() {
        let (p, pr) = widened_detour(robot, task, settings, nlp, started, g, &mut log)?;
        probed = pr;
        if let Some(p) = p {
            rep.strategy = GuessStrategy::Cspace;
            if let Some(i) = top {
                routes[i].converged = Some(true);
            }
            put_cspace(&mut rep, routes, top);
            let p = finish(robot, task, settings, p, rep, log, ff);
            return Ok((p, probed));
        }
    }
    put_cspace(&mut rep, routes, top);
    // 7. continuation on the obstacle radii
    rep.strategy = GuessStrategy::Continuation;
    let p = match radius_continuation(
        robot,
        task,
        settings,
        nlp,
        started,
        free_points,
        &mut rep,
        &mut log,
    )? {
        Some(p) => finish(robot, task, settings, p, rep, log, ff),
        // nothing converged: the smooth step's attempt, diagnosed
        None => finish(robot, task, settings, best, rep, log, ff),
    };
    Ok((p, probed))
}

/// The report of a chain that has solved nothing yet, with whether the smooth step's guess clears
/// the obstacles.
fn empty_report(smooth_step_clear: bool) -> GuessReport {
    GuessReport {
        strategy: GuessStrategy::SmoothStep,
        smooth_step_clear,
        solves: 0,
        iterations: 0,
        solve_time_s: 0.0,
        scales: vec![],
        seeds: vec![],
        cspace: None,
        cspace_routes: vec![],
        out_of_time: false,
    }
}

/// The C-space searches' reports into `rep`: all of them, and the best-ranked seed's (`top`; the
/// first search's when no seed was found) as `cspace`.
fn put_cspace(rep: &mut GuessReport, routes: Vec<CspaceReport>, top: Option<usize>) {
    rep.cspace = top
        .or((!routes.is_empty()).then_some(0))
        .map(|i| routes[i].clone());
    rep.cspace_routes = routes;
}

/// The continuation on the actuator limits from the C-space seed `g` (the module docs, step 4):
/// planned with the limits widened by [`TORQUE_RELAX`] (a guess: its knots' optimum, without the
/// sub-step refinement), then at the real limits from that plan; the plan when it converged.
#[allow(clippy::too_many_arguments)]
fn cspace_torque_continuation(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
    g: &Trajectory,
    crep: &mut Option<CspaceReport>,
    log: &mut SolveLog,
) -> Result<Option<Plan>> {
    let within = |cap: usize| nlp.remaining(started).map(|n| n.capped(cap));
    let wide = with_torque_scale(robot, TORQUE_RELAX)?;
    let mut relaxed = None;
    let knots_only = settings.without_substep_clearance();
    if let Some(run) = within(usize::MAX) {
        let mut p = plan_single(&wide, task, &knots_only, &run, Some(g))?;
        log.record(
            &mut p,
            SolveRole::TorqueScale {
                scale: TORQUE_RELAX,
            },
        );
        if let Some(r) = crep.as_mut() {
            r.relaxed_converged = Some(p.status.is_converged());
        }
        relaxed = Some(p);
    }
    let relaxed = relaxed.filter(|p| p.status.is_converged());
    if let (Some(w), Some(run)) = (relaxed, within(usize::MAX)) {
        let mut p = plan_single(robot, task, settings, &run, Some(&w.points))?;
        log.record(&mut p, SolveRole::TorqueScale { scale: 1.0 });
        let ok = p.converged();
        if let Some(r) = crep.as_mut() {
            r.converged = Some(ok);
        }
        if ok {
            return Ok(Some(p));
        }
    }
    Ok(None)
}

/// Grow every obstacle from the obstacle-free plan `guess` to its full radius (the module docs,
/// step 4); the plan at full radius when it converged.
#[allow(clippy::too_many_arguments)]
fn radius_continuation(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: std::time::Instant,
    mut guess: Trajectory,
    rep: &mut GuessReport,
    log: &mut SolveLog,
) -> Result<Option<Plan>> {
    let within = |cap: usize| nlp.remaining(started).map(|n| n.capped(cap));
    rep.scales.push(0.0);
    let (mut done, mut step) = (0.0f64, FIRST_SCALE_STEP);
    while step >= MIN_SCALE_STEP {
        let s = (done + step).min(1.0);
        let last = s >= 1.0;
        let Some(run) = within(if last { usize::MAX } else { STEP_MAX_ITER }) else {
            break;
        };
        let mut p = plan_single(
            robot,
            &task.with_obstacles_scaled(s),
            settings,
            &run,
            Some(&guess),
        )?;
        log.record(&mut p, SolveRole::ObstacleScale { scale: s });
        if p.converged() {
            rep.scales.push(s);
            if last {
                return Ok(Some(p));
            }
            guess = p.points;
            done = s;
            step *= 2.0;
        } else {
            step *= 0.5;
        }
    }
    Ok(None)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// The position of `k` in `order`.
    fn at(order: &[Kind], k: Kind) -> usize {
        order
            .iter()
            .position(|&x| x == k)
            .unwrap_or_else(|| panic!("{k:?} not in {order:?}"))
    }

    /// The race's order: the forward detour seeds, the best-ranked C-space seed as it is and then
    /// as a longer swing, the backward detour seeds, the other C-space seeds the same way in their
    /// rank, the further routes last. Where a seed as it is converges first, its plan at the
    /// automatic swing time wins over the longer swing's.
    #[test]
    fn each_cspace_seed_runs_as_it_is_just_before_it_runs_as_a_longer_swing() {
        // detour seeds 0 and 2 forward, 1 backward
        let order = race_order(3, |i| i == 1, true);
        let head = [
            Kind::Detour(0),
            Kind::Detour(2),
            Kind::Cspace(0),
            Kind::CspaceLonger(0),
            Kind::Detour(1),
        ];
        assert_eq!(order[..head.len()], head, "{order:?}");
        for j in 0..MAX_GOALS * ROUTES_PER_GOAL {
            let plain = at(&order, Kind::Cspace(j));
            assert_eq!(at(&order, Kind::CspaceLonger(j)), plain + 1, "{order:?}");
        }
        let further = FURTHER_GOALS * FURTHER_ROUTES;
        let tail = &order[order.len() - further..];
        assert!(
            tail.iter().all(|k| matches!(k, Kind::Further(_))),
            "{order:?}"
        );
        // without the longer swing: the seeds as they are, no further routes
        let plain = race_order(3, |i| i == 1, false);
        assert_eq!(plain.len(), 3 + MAX_GOALS * ROUTES_PER_GOAL, "{plain:?}");
        assert!(plain
            .iter()
            .all(|k| matches!(k, Kind::Detour(_) | Kind::Cspace(_))));
    }

    /// The smooth step in the race is one solve, stopped at the larger of
    /// [`SMOOTH_STEP_MIN_ITER`] and its first chance; on the paper's swing with an obstacle of
    /// radius 0.086 m at the tip of link 2 at 1.13 s of the unobstructed swing, which its guess
    /// cuts through, that solve stops there without converging.
    #[test]
    fn the_smooth_step_in_the_race_is_one_solve_stopped_at_its_cap() {
        assert_eq!(smooth_step_cap(0.03, 2.23), SMOOTH_STEP_MIN_ITER);
        assert_eq!(smooth_step_cap(0.01, 2.23), 223);
        assert_eq!(smooth_step_cap(0.03, 0.0), SMOOTH_STEP_RACE_MAX_ITER);
        let (robot, s, _, free) = crate::planning::strategy::test_swing::paper_swing();
        let nlp = NlpSettings::default();
        let mut x = vec![0.0; 2 * robot.n];
        free.points.state_at(1.13, &mut x);
        let mut joints = vec![[0.0; 2]; robot.n + 1];
        robot.joint_positions(&x[..robot.n], &mut joints);
        let obstacle = Circle {
            center: joints[2],
            radius: 0.086,
        };
        let blocked = SwingTask {
            obstacles: vec![obstacle],
            ..SwingTask::paper()
        };
        let task = ValidTask::new(&robot, blocked, &s, "task", "").unwrap();
        assert!(!smooth_step_is_clear(&robot, &task, &s).unwrap());
        let t_s = free.swing_time_s;
        let cap = smooth_step_cap(s.knot_dt, t_s);
        let plans = smooth_step_candidate(&robot, &task, &s, t_s)(&nlp).unwrap();
        assert_eq!(plans.len(), 1, "{plans:?}");
        let p = &plans[0].1;
        assert!(!p.converged(), "{:?}", p.solves);
        assert!(
            p.solves.iter().all(|a| a.iterations <= cap),
            "{:?}",
            p.solves
        );
        let at_cap = |a: &crate::planning::outcome::SolveAttempt| {
            a.iterations == cap && a.status == SolveStatus::MaxIterations
        };
        assert!(p.solves.iter().any(at_cap), "{:?}", p.solves);
    }
}
