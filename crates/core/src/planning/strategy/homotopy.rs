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

use super::cspace::{time_path, CellVerdicts, CspaceReport, RouteSearch, GRID_STEP_RAD};
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
    /// Whether the searches of a call are kept in it, with their cell verdicts (otherwise each goal
    /// pose's grid is freed once its routes are found, and the verdicts when the call ends).
    keep: bool,
    searches: Vec<RouteSearch>,
    /// The cell verdicts the set's searches share (replaced when a search of another robot,
    /// obstacles or settings is given them).
    verdicts: CellVerdicts,
}

impl GoalSearches {
    /// An empty set that keeps the searches of the call it is given to.
    pub fn kept() -> Self {
        GoalSearches {
            keep: true,
            ..Self::default()
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
            None => RouteSearch::sharing(
                robot,
                obstacles,
                settings,
                q_start,
                goal,
                Some(&mut kept.verdicts),
            )?,
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
    // a set that keeps nothing keeps no verdicts either
    if !kept.keep {
        kept.verdicts = CellVerdicts::default();
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::ik_from_seed;
    use crate::planning::strategy::goal::distinct_goal_poses;
    use std::cell::Cell;

    /// The three-link robot of params/, a straight-line swing in its angles from a folded start
    /// pose to a pose grasping the bar at 0.8 m, and a circle on its middle link halfway.
    fn three_link_swing() -> (Robot, Vec<Circle>, Trajectory, [f64; 2]) {
        let robot = Robot::from_repo_params("three-link.toml");
        let target = [0.8, 0.0];
        let q0 = [-2.2, 0.0, -1.0];
        let q1 = ik_from_seed(&robot, &[-1.2, 0.4, 0.4], target).expect("the bar is in reach");
        let mut free = Trajectory::new(3);
        let knots = 21;
        for k in 0..knots {
            let s = k as f64 / (knots - 1) as f64;
            let q: Vec<f64> = q0.iter().zip(&q1).map(|(a, b)| a + s * (b - a)).collect();
            free.push(s, &q, &[0.0; 3], &[0.0; 2]);
        }
        let mut segs = [([0.0; 2], [0.0; 2]); 3];
        robot.link_segments(free.q(knots / 2), &mut segs);
        let (a, b) = segs[1];
        let obstacles = vec![Circle {
            center: [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0],
            radius: 0.05,
        }];
        (robot, obstacles, free, target)
    }

    /// A search the stop rule cut short in the first call is kept but not continued: the second
    /// call, never stopped, finds the same routes with the same reports as a new search, and
    /// counts the same grid searches.
    #[test]
    fn a_route_search_the_stop_rule_cut_short_is_searched_again() {
        let (robot, obs, free, target) = three_link_swing();
        let s = PlannerSettings::default();
        let limits = (MAX_GOALS, ROUTES_PER_GOAL);
        let never = || false;
        let fresh = homotopy_routes_up_to(&robot, &obs, &s, &free, target, limits, &never).unwrap();
        assert!(fresh
            .reports
            .iter()
            .all(|r| r.endpoints_clear && r.grid_cells > 0));
        assert!(!fresh.seeds.is_empty() && fresh.grid_searches > 0);
        // the questions the goal search asks, then a stop at the first question after them: in
        // the first goal pose's route search
        let asked = Cell::new(0usize);
        let counting = || {
            asked.set(asked.get() + 1);
            false
        };
        let last = free.q(free.len() - 1);
        distinct_goal_poses(&robot, &obs, &s, last, target, MAX_GOALS, &counting).unwrap();
        let before = asked.get();
        asked.set(0);
        let stop = || {
            asked.set(asked.get() + 1);
            asked.get() > before
        };
        let mut kept = GoalSearches::kept();
        let cut =
            homotopy_routes_continued(&robot, &obs, &s, &free, target, limits, &mut kept, &stop)
                .unwrap();
        assert!(
            asked.get() > before,
            "the stop rule was not asked past the goal search"
        );
        assert_eq!(kept.searches.len(), 1);
        assert!(kept.searches[0].stopped() && kept.searches[0].searches() >= 1);
        assert!(cut.reports.iter().all(|r| r.goal == 0));
        assert!(cut.grid_searches < fresh.grid_searches);
        let mut kept = kept.not_kept();
        let again =
            homotopy_routes_continued(&robot, &obs, &s, &free, target, limits, &mut kept, &never)
                .unwrap();
        assert_eq!(again.reports, fresh.reports);
        assert_eq!(again.grid_searches, fresh.grid_searches);
        assert_eq!(again.seeds.len(), fresh.seeds.len());
        for (a, f) in again.seeds.iter().zip(&fresh.seeds) {
            assert_eq!((a.report, &a.path, &a.guess), (f.report, &f.path, &f.guess));
        }
    }

    /// The searches to the goal poses share their grid's cell verdicts: each goal pose's routes,
    /// their waypoints and their search reports (cells reached, moves, clearance) are those of a
    /// search of its own that checks every cell itself.
    #[test]
    fn searches_sharing_cell_verdicts_find_the_routes_of_searches_of_their_own() {
        use crate::planning::strategy::cspace::cspace_routes;
        let (robot, obs, free, target) = three_link_swing();
        let s = PlannerSettings::default();
        let never = || false;
        let limits = (MAX_GOALS, ROUTES_PER_GOAL);
        let shared =
            homotopy_routes_up_to(&robot, &obs, &s, &free, target, limits, &never).unwrap();
        let last = free.q(free.len() - 1);
        let goals = distinct_goal_poses(&robot, &obs, &s, last, target, MAX_GOALS, &never).unwrap();
        assert!(goals.len() >= 2, "{} goal poses", goals.len());
        let mut own = vec![];
        for (gi, goal) in goals.iter().enumerate() {
            let routes = cspace_routes(&robot, &obs, &s, free.q(0), goal, ROUTES_PER_GOAL, &never);
            for (mut rep, path) in routes.unwrap() {
                rep.goal = gi;
                own.push((rep, path));
            }
        }
        assert_eq!(own.len(), shared.reports.len());
        let searched = |r: &CspaceReport| {
            let mut r = r.clone();
            (r.max_speed_rad_s, r.peak_torque_ratio) = (0.0, 0.0);
            r
        };
        for (i, (rep, path)) in own.iter().enumerate() {
            assert_eq!(searched(&shared.reports[i]), *rep, "search {i}");
            let seed = shared.seeds.iter().find(|sd| sd.report == i);
            assert_eq!(seed.map(|sd| &sd.path), path.as_ref(), "search {i}");
        }
        assert!(shared.reports.iter().filter(|r| r.found).count() >= 3);
    }

    /// Cell verdicts given to a search against other obstacles are not used: its routes and reports
    /// are those of a search of its own (a larger circle blocks cells the first search found free).
    #[test]
    fn cell_verdicts_of_other_obstacles_are_not_used() {
        let (robot, obs, free, _) = three_link_swing();
        let s = PlannerSettings::default();
        let never = || false;
        let (start, goal) = (free.q(0), free.q(free.len() - 1));
        let larger = vec![Circle {
            radius: 0.09,
            ..obs[0]
        }];
        let mut verdicts = CellVerdicts::default();
        let routes = |o: &[Circle], v: Option<&mut CellVerdicts>| {
            let mut r = RouteSearch::sharing(&robot, o, &s, start, goal, v).unwrap();
            r.more(ROUTES_PER_GOAL, &never)
        };
        let first = routes(&obs, Some(&mut verdicts));
        let after = routes(&larger, Some(&mut verdicts));
        let own = routes(&larger, None);
        assert!(first.iter().any(|(_, p)| p.is_some()));
        assert_ne!(first, own);
        assert_eq!(after, own);
    }
}
