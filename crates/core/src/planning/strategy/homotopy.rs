//! Seeds of several homotopy classes for the obstacle race: configuration-space paths to several
//! goal poses, several routes to each, ranked by a cheap measure before any of them is solved.
//!
//! The detour seeds ([`super::detour`]) stay in the obstacle-free swing's homotopy class, and one
//! configuration-space path ([`super::cspace`]) is one more class. Which class plans depends on the
//! obstacle's place against each link's sweep (a link passes it before or after in its angle sweep,
//! the chain folds above or below it) and on the pose the chain ends in at the bar. So the seeds
//! here are:
//! 1. **Goals.** The pose the obstacle-free swing's knots end at (the seeds' final pose), then up
//!    to [`MAX_GOALS`] - 1 other poses that grasp the bar and clear the obstacles, one per family of
//!    signs of the relative joints (elbow up or down at each joint;
//!    [`super::goal::distinct_goal_poses`]), nearest first.
//! 2. **Routes.** For each goal, up to [`ROUTES_PER_GOAL`] grid routes from the start pose
//!    ([`super::cspace::cspace_routes`]): each next route goes round a tube about the routes before it,
//!    so it passes the obstacles another way; routes that stay within
//!    [`super::cspace::SAME_ROUTE_RAD`] of an earlier one are dropped. A wider search later
//!    ([`homotopy_routes_continued`]) continues each goal pose's search where this one ended.
//! 3. **Rank.** Each route timed over the swing ([`super::cspace::time_path`]) with its
//!    inverse-dynamics torques; the seeds are solved in the order of their largest torque against
//!    the limits (`CspaceReport::peak_torque_ratio`, the passive joint's residual included), lowest
//!    first: a path the actuators can nearly follow is the likeliest to plan.
//!
//! A stop rule (the call's time limit and cancel token) is asked throughout: once it says stop, the
//! seeds found so far are returned. Units: rad, s.

use super::cspace::{time_path, CspaceReport, RouteSearch, GRID_STEP_RAD};
use super::goal::{distinct_goal_poses, with_final_pose};
use crate::error::Result;
use crate::model::{Circle, Robot};
use crate::planning::settings::PlannerSettings;
use crate::trajectory::Trajectory;

/// One ranked configuration-space seed: the index of its search's report, the route's waypoints,
/// the time axis it is timed over (the obstacle-free swing's knots ending at its goal pose) and the
/// seed itself, the route timed over that axis ([`time_path`]).
#[derive(Debug, Clone)]
pub struct RankedSeed {
    /// Index of the route's search in [`RankedRoutes::reports`].
    pub report: usize,
    /// The route's waypoints, rad (start and goal pose included).
    pub path: Vec<Vec<f64>>,
    /// The time axis the route is timed over, s.
    pub axis: Trajectory,
    /// The route timed over `axis`.
    pub guess: Trajectory,
}

impl RankedSeed {
    /// The route timed over its axis stretched by `factor` (a swing `factor` times as long, its
    /// inverse-dynamics torques those of the slower motion).
    pub fn retimed(&self, robot: &Robot, factor: f64) -> Trajectory {
        let axis = self.axis.times_stretched(factor);
        let mut rep = CspaceReport::not_searched(GRID_STEP_RAD);
        time_path(robot, &self.path, &axis, &mut rep)
    }
}

/// Every search's report (in the order run) and the seeds found, best first.
#[derive(Debug, Clone, Default)]
pub struct RankedRoutes {
    /// Every search's report, in the order run.
    pub reports: Vec<CspaceReport>,
    /// The seeds found, lowest torque ratio first.
    pub seeds: Vec<RankedSeed>,
    /// Grid searches run ([`super::cspace::RouteSearch::searches`]; a continued search counts
    /// only those of this call).
    pub grid_searches: usize,
}

/// Most goal poses searched to (the seeds' final pose included).
pub const MAX_GOALS: usize = 3;
/// Most routes searched per goal.
pub const ROUTES_PER_GOAL: usize = 2;

/// The ranked configuration-space seeds of the obstacle-free swing's knots `free` (its last knot the
/// seeds' final pose, which clears the obstacles; the bar at `target`) against `obstacles` (see the
/// module docs): every search's report (in the order run) and the seeds found, best first, each
/// with its route and time axis, so that it can be timed over another swing time
/// ([`RankedSeed::retimed`]).
pub fn homotopy_routes(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    free: &Trajectory,
    target: [f64; 2],
    stop: &dyn Fn() -> bool,
) -> Result<RankedRoutes> {
    let limits = (MAX_GOALS, ROUTES_PER_GOAL);
    homotopy_routes_up_to(robot, obstacles, settings, free, target, limits, stop)
}

/// [`homotopy_routes`] to up to `goals` goal poses, up to `routes` routes each (`(goals, routes)`).
pub fn homotopy_routes_up_to(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    free: &Trajectory,
    target: [f64; 2],
    limits: (usize, usize),
    stop: &dyn Fn() -> bool,
) -> Result<RankedRoutes> {
    let mut none = GoalSearches::default();
    homotopy_routes_continued(
        robot, obstacles, settings, free, target, limits, &mut none, stop,
    )
}

/// The route searches of a homotopy search, one per goal pose, kept so that a wider search
/// ([`homotopy_routes_continued`]) continues them instead of searching their routes again.
#[derive(Default)]
pub struct GoalSearches {
    /// Whether the searches of a call are kept in it (otherwise each goal pose's grid is freed once
    /// its routes are found).
    keep: bool,
    searches: Vec<RouteSearch>,
}

impl GoalSearches {
    /// An empty set that keeps the searches of the call it is given to.
    pub fn kept() -> Self {
        GoalSearches {
            keep: true,
            searches: vec![],
        }
    }

    /// The same searches, not keeping those of the next call.
    pub fn not_kept(self) -> Self {
        GoalSearches {
            keep: false,
            ..self
        }
    }

    /// The search from `start` to `goal` ([`same_pose`]) run to its end, taken out of the set.
    fn take(&mut self, start: &[f64], goal: &[f64]) -> Option<RouteSearch> {
        let i = self.searches.iter().position(|s| {
            !s.stopped() && same_pose(s.start(), start) && same_pose(s.goal(), goal)
        })?;
        Some(self.searches.swap_remove(i))
    }
}

/// Whether two poses are the same pose: the same number of angles, each within 1e-9 rad.
pub(crate) fn same_pose(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-9)
}

/// [`homotopy_routes_up_to`], continuing the searches in `kept` to the goal poses they searched to
/// (those the stop rule did not end early): their routes past those already found, the same as a
/// new search's routes past its first ones, without searching those again. When `kept` keeps, this
/// call's searches are left in it.
#[allow(clippy::too_many_arguments)]
pub fn homotopy_routes_continued(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    free: &Trajectory,
    target: [f64; 2],
    (goals, routes): (usize, usize),
    kept: &mut GoalSearches,
    stop: &dyn Fn() -> bool,
) -> Result<RankedRoutes> {
    let len = free.len();
    if len < 2 || obstacles.is_empty() {
        return Ok(RankedRoutes::default());
    }
    let (q_start, q_end) = (free.q(0), free.q(len - 1));
    let goals = distinct_goal_poses(robot, obstacles, settings, q_end, target, goals, stop)?;
    let mut reports = vec![];
    let mut seeds: Vec<RankedSeed> = vec![];
    let mut grid_searches = 0;
    let mut searched = vec![];
    for (gi, goal) in goals.iter().enumerate() {
        if gi > 0 && stop() {
            break;
        }
        let axis = with_final_pose(free, goal);
        let mut search = match kept.take(q_start, goal) {
            Some(s) => s,
            None => RouteSearch::new(robot, obstacles, settings, q_start, goal)?,
        };
        let before = search.searches();
        let found = search.more(routes, stop);
        grid_searches += search.searches() - before;
        if kept.keep {
            searched.push(search);
        }
        for (mut rep, path) in found {
            rep.goal = gi;
            if let Some(path) = path {
                let guess = time_path(robot, &path, &axis, &mut rep);
                seeds.push(RankedSeed {
                    report: reports.len(),
                    path,
                    axis: axis.clone(),
                    guess,
                });
            }
            reports.push(rep);
        }
    }
    kept.searches.extend(searched);
    // lowest torque ratio first; ties keep the search order
    seeds.sort_by(|a, b| {
        reports[a.report]
            .peak_torque_ratio
            .total_cmp(&reports[b.report].peak_torque_ratio)
    });
    Ok(RankedRoutes {
        reports,
        seeds,
        grid_searches,
    })
}
