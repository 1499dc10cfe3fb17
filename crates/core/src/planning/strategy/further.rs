//! Further configuration-space routes as longer swings, the race's last candidates: when every
//! earlier candidate has started and none has won, the routes the race did not have (to up to
//! [`FURTHER_GOALS`] goal poses at the bar, up to [`FURTHER_ROUTES`] routes each,
//! [`super::homotopy::homotopy_routes_up_to`]), each solved as a longer swing
//! ([`super::candidate::solve_seed_longer_swing`]: the route timed over [`LONGER_SWING_FACTOR`] times
//! the automatic swing time, the swing time free up to there), lowest inverse-dynamics torque ratio
//! over that longest swing first.
//!
//! A placement whose route goes round the obstacle to a goal pose past the race's
//! [`super::homotopy::MAX_GOALS`], or by a route past its [`super::homotopy::ROUTES_PER_GOAL`], can
//! plan here. They come last in the race's order, so they run only once every earlier candidate
//! has started without winning (measured on the placement scan: docs/planner-measurements.md).
//! Units: s.

use crate::error::Result;
use crate::model::{Circle, Robot};
use crate::planning::nlp::NlpSettings;
use crate::planning::settings::ValidSettings;
use crate::planning::strategy::candidate::{solve_seed_longer_swing, LONGER_SWING_FACTOR};
use crate::planning::strategy::cspace::{time_path, CspaceReport};
use crate::planning::strategy::homotopy::{
    homotopy_routes_continued, same_pose, GoalSearches, RankedRoutes, RankedSeed,
};
use crate::planning::strategy::race::Plans;
use crate::planning::task::ValidTask;
use crate::trajectory::Trajectory;
use std::sync::{Mutex, OnceLock};
use std::time::Instant;

/// Most goal poses of the further search (the seeds' final pose included).
pub const FURTHER_GOALS: usize = 8;
/// Most routes per goal pose of the further search.
pub const FURTHER_ROUTES: usize = 4;

/// A route the race already had: its goal pose (the route's last waypoint) and its index among the
/// routes to that pose.
pub(crate) type Tried = (Vec<f64>, usize);

/// The goal pose and route index of a ranked seed.
pub(crate) fn tried(sd: &RankedSeed, reports: &[CspaceReport]) -> Option<Tried> {
    let goal = sd.path.last()?.clone();
    Some((goal, reports.get(sd.report)?.route))
}

/// The race's own routes and its route searches, which the further search continues (each goal
/// pose's search past its routes, [`homotopy_routes_continued`]) instead of running them again.
#[derive(Default)]
pub(crate) struct RaceRoutes {
    /// The race's ranked routes.
    pub routes: RankedRoutes,
    /// The race's route searches, taken by the further search.
    pub searches: Mutex<GoalSearches>,
}

impl RaceRoutes {
    /// The routes the race had: the goal pose and route index of each of its seeds.
    fn tried(&self) -> Vec<Tried> {
        let r = &self.routes;
        r.seeds
            .iter()
            .filter_map(|sd| tried(sd, &r.reports))
            .collect()
    }

    /// The race's route searches, taken out (none when taken before).
    fn take_searches(&self) -> GoalSearches {
        let taken = match self.searches.lock() {
            Ok(mut g) => std::mem::take(&mut *g),
            Err(p) => std::mem::take(&mut *p.into_inner()),
        };
        taken.not_kept()
    }
}

/// The further search, run once by the first candidate that needs it (the others wait for it),
/// within that candidate's time limit and cancel token: the routes the race did not have, lowest
/// inverse-dynamics torque ratio over the longest swing first.
pub(crate) struct FurtherSearch<'a> {
    robot: &'a Robot,
    obstacles: &'a [Circle],
    settings: &'a ValidSettings,
    /// The obstacle-free swing's knots ending at the seeds' final pose.
    free: &'a Trajectory,
    target: [f64; 2],
    found: OnceLock<RankedRoutes>,
}

impl<'a> FurtherSearch<'a> {
    /// A search against `obstacles` (those that cover the others) from the knots `free` to the bar
    /// at `target`; nothing is searched before [`FurtherSearch::routes`].
    pub(crate) fn new(
        robot: &'a Robot,
        obstacles: &'a [Circle],
        settings: &'a ValidSettings,
        free: &'a Trajectory,
        target: [f64; 2],
    ) -> Self {
        FurtherSearch {
            robot,
            obstacles,
            settings,
            free,
            target,
            found: OnceLock::new(),
        }
    }

    /// The further routes (searched on the first call, within `run`, continuing the race's route
    /// searches), without the race's own, each seed's guess its route timed over the longest swing,
    /// lowest torque ratio there first.
    pub(crate) fn routes(&self, run: &NlpSettings, race: &RaceRoutes) -> &RankedRoutes {
        self.found.get_or_init(|| {
            let t0 = Instant::now();
            let stop = || run.remaining(t0).is_none();
            let limits = (FURTHER_GOALS, FURTHER_ROUTES);
            let (robot, target) = (self.robot, self.target);
            let mut kept = race.take_searches();
            let mut r = homotopy_routes_continued(
                robot,
                self.obstacles,
                self.settings,
                self.free,
                target,
                limits,
                &mut kept,
                &stop,
            )
            .unwrap_or_default();
            drop(kept);
            // a race search the stop rule ended early was searched again from its start: its
            // routes the race had are dropped here
            let done = race.tried();
            let reports = &r.reports;
            r.seeds.retain(|sd| {
                tried(sd, reports).is_some_and(|t| !done.iter().any(|d| same_route(d, &t)))
            });
            // each route's guess timed over the longest swing, where it starts; lowest torque ratio
            // there first
            let retimed = |mut sd: RankedSeed| {
                let mut rep = reports[sd.report].clone();
                let axis = sd.axis.times_stretched(LONGER_SWING_FACTOR);
                sd.guess = time_path(robot, &sd.path, &axis, &mut rep);
                (rep.peak_torque_ratio, sd)
            };
            let mut keyed: Vec<(f64, RankedSeed)> = r.seeds.drain(..).map(retimed).collect();
            keyed.sort_by(|a, b| a.0.total_cmp(&b.0));
            r.seeds = keyed.into_iter().map(|(_, sd)| sd).collect();
            r
        })
    }

    /// Candidate `j` of the further routes: its route solved as a longer swing (nothing when there is
    /// no such route or no time is left).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn solve(
        &self,
        j: usize,
        task: &ValidTask,
        run: &NlpSettings,
        t_auto: f64,
        race: &RaceRoutes,
    ) -> Result<Plans> {
        let t0 = Instant::now();
        let h = self.routes(run, race);
        let (Some(sd), Some(run)) = (h.seeds.get(j), run.remaining(t0)) else {
            return Ok(vec![]);
        };
        // the guess is the route timed over the longest swing ([`Self::routes`])
        solve_seed_longer_swing(self.robot, task, self.settings, &run, &sd.guess, t_auto)
    }

    /// The reports of the further routes (their `goal` counts the further search's goal poses),
    /// each route of a rank in `concluded` marked with how its candidate concluded (converged clear,
    /// failed, or `None` when interrupted); none when the search did not run.
    pub(crate) fn reports(&self, concluded: &[(usize, Option<bool>)]) -> Vec<CspaceReport> {
        let Some(RankedRoutes { reports, seeds, .. }) = self.found.get() else {
            return vec![];
        };
        seeds
            .iter()
            .enumerate()
            .map(|(j, sd)| {
                let mut r = reports[sd.report].clone();
                if let Some(&(_, c)) = concluded.iter().find(|(k, _)| *k == j) {
                    r.converged = c;
                }
                r
            })
            .collect()
    }
}

/// Whether two routes are the same route: the same index to the same goal pose.
fn same_route(a: &Tried, b: &Tried) -> bool {
    a.1 == b.1 && same_pose(&a.0, &b.0)
}
