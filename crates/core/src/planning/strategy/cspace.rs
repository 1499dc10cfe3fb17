//! Configuration-space seeds: a collision-free joint path from the start pose to the obstacle-free
//! swing's final pose, found by a search over a coarse grid of the robot's configuration space, timed
//! over the swing, with torques from inverse dynamics (docs/planner.md, "Obstacles on the path").
//!
//! The detour seeds of [`super::detour`] deform the obstacle-free swing and stay in its homotopy class;
//! an obstacle that class cannot avoid needs a path of another class, which a global search finds:
//! 1. **Grid.** Every joint's range (q1 in `bounds.q1`, the relative joints in `+-q_rel_max`) is cut
//!    into equal steps of at least [`GRID_STEP_RAD`], the step grown until the grid has at most
//!    [`MAX_CELLS`] cells (a byte each for a search's cell states, and a byte each for the cell
//!    verdicts its task's searches share: the only allocations that scale with the grid). A grid
//!    coarser than [`MAX_GRID_STEP_RAD`] (many links) is not searched.
//! 2. **Search.** Weighted A* ([`HEURISTIC_WEIGHT`]) over unit moves of one joint by one step, from the
//!    start pose's cell to the goal pose's cell, the heuristic the number of moves left (L1 in cells).
//!    A cell is free when every link clears every obstacle and every non-adjacent link (with
//!    `self_collision`) by the planner's margin plus [`CELL_EXTRA_CLEARANCE`]; a cell is checked
//!    when first reached (unless its verdict is known) and at most [`MAX_DISCOVERED`] cells are
//!    reached (the open list's bound). The search ends with a path, with the free cells reachable
//!    from the start exhausted (no grid path: evidence, not proof, that the task is blocked), or at
//!    the limit. Start and goal poses that do not clear the obstacles by the margin are not
//!    searched from. The open list keeps one small heap per priority (`open_list`), a cell's
//!    verdict is kept for the later searches on the same grid, to other goal poses included
//!    ([`super::homotopy`]), and a cell is checked from the cosines and sines of the grid's joint
//!    values, tabulated once, in squared distances, ending at the first pair too close: none of
//!    these changes which cells are reached or in what order (up to rounding at the boundary of a
//!    cell's check), only how fast.
//! 3. **Shortcut.** The grid path (start pose, cells, goal pose) is shortened greedily: from each kept
//!    waypoint to the farthest later one that the straight joint-space segment reaches with the
//!    segment clear by the margin plus [`SEGMENT_EXTRA_CLEARANCE`] (checked every
//!    [`SEGMENT_CHECK_RAD`] of the segment's 1-norm).
//! 4. **Timing.** The piecewise-linear path is travelled along its joint-space arc length `L` with the
//!    smooth step `s(t) = L (3 r^2 - 2 r^3)`, `r = t / T`: at rest at both ends, `qd = s'(t) e` and
//!    `qdd = s''(t) e` with `e` the unit direction of the current segment (corners ignored), torques the
//!    actuated entries of the inverse dynamics `M qdd + C qd + G` there (the passive entry is what the
//!    solver must close; the planner clamps the guess into the bounds).
//!
//! Nothing here prints or runs on a task without obstacles. Units: rad, m, s, N m.

use super::open_list::OpenList;
use crate::error::Result;
use crate::model::{Circle, ClearanceFn, Robot, Scratch, MAX_LINKS, P2};
use crate::planning::settings::PlannerSettings;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::cell::Cell;
use std::sync::atomic::{AtomicU8, Ordering};
use std::sync::Arc;

/// Finest grid step, rad (the grid of the 4-link paper robot: 32 x 59^3 = 6.6 M cells).
pub const GRID_STEP_RAD: f64 = 0.1;
/// Most grid cells (one byte each, 8 MiB, for a search's cell states, and as much again for the
/// cell verdicts the searches of one task share).
pub const MAX_CELLS: usize = 1 << 23;
/// Coarsest grid step searched, rad: a grid that needs a coarser step to fit [`MAX_CELLS`] (more
/// than six links; the six-link robot of params/ needs 0.41 rad) is not searched.
pub const MAX_GRID_STEP_RAD: f64 = 0.45;
/// Most cells the search reaches (blocked, or pushed on its open list) before it gives up.
pub const MAX_DISCOVERED: usize = 3_000_000;
/// Weight of the heuristic in the A* priority `g + w h` (> 1: fewer cells, longer grid paths that
/// the shortcut straightens).
pub const HEURISTIC_WEIGHT: u32 = 2;
/// Clearance a free cell keeps beyond the planner's margin, m (room for the motion between cells).
pub const CELL_EXTRA_CLEARANCE: f64 = 0.02;
/// Clearance a shortcut segment keeps beyond the planner's margin at its check points, m.
pub const SEGMENT_EXTRA_CLEARANCE: f64 = 0.01;
/// Spacing of the check points along a segment, rad of its 1-norm (a point of the chain moves at
/// most this times the robot's reach between two checks).
pub const SEGMENT_CHECK_RAD: f64 = 0.01;

/// What the configuration-space search found and, once tried, whether the plan from its seed
/// converged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CspaceReport {
    /// Grid step, rad (every joint's range cut into equal steps of about this).
    pub grid_step_rad: f64,
    /// Grid cells (the product of the per-joint counts; 0 when the grid was too coarse to search).
    pub grid_cells: usize,
    /// Cells the search reached (each found blocked or pushed on its open list).
    pub cells_discovered: usize,
    /// The start and goal poses clear the obstacles and the non-adjacent links by the planner's
    /// margin (otherwise nothing is searched).
    pub endpoints_clear: bool,
    /// A grid path was found.
    pub found: bool,
    /// No path and every free cell reachable from the start was reached: the obstacles block every
    /// grid path (margin and grid resolution as above).
    pub exhausted: bool,
    /// Unit moves of the grid path.
    pub grid_moves: usize,
    /// Waypoints after the shortcut (start and goal poses included).
    pub waypoints: usize,
    /// Joint-space arc length of the shortcut path, rad.
    pub path_length_rad: f64,
    /// Largest joint speed of the timed path, `1.5 L / T` times the largest direction entry, rad/s.
    pub max_speed_rad_s: f64,
    /// Smallest clearance along the shortcut path (surface distance minus the planner's margin,
    /// obstacles and self-collision, every check point), m.
    pub min_clearance_m: f64,
    /// Whether the plan from the seed converged, directly or after the actuator-limit continuation
    /// (`None`: not tried).
    pub converged: Option<bool>,
    /// Whether the plan from the seed with the torque limits widened by
    /// [`crate::planning::strategy::obstacles::TORQUE_RELAX`] converged (`None`: not tried, the seed's own solve converged).
    #[serde(default)]
    pub relaxed_converged: Option<bool>,
    /// Which route of the search this is (0: the first; later ones go round the tubes of the
    /// routes before them, [`cspace_routes`]).
    #[serde(default)]
    pub route: usize,
    /// Which goal pose the route ends at (0: the obstacle-free swing's final pose or the clear
    /// pose closest to it; later ones other clear poses at the bar, [`super::goal`]).
    #[serde(default)]
    pub goal: usize,
    /// The search ended early: the call's time limit was spent or it was cancelled.
    #[serde(default)]
    pub stopped: bool,
    /// Largest |inverse-dynamics torque| of the timed seed over its limit, over the actuated joints
    /// and the passive joint's residual (against the largest limit): how far the seed is from the
    /// limits, the rank of the seeds (lower first). 0 until timed.
    #[serde(default)]
    pub peak_torque_ratio: f64,
}

impl CspaceReport {
    /// The report of a search not (yet) run on a grid of `step`.
    pub(crate) fn not_searched(step: f64) -> Self {
        CspaceReport {
            grid_step_rad: step,
            grid_cells: 0,
            cells_discovered: 0,
            endpoints_clear: false,
            found: false,
            exhausted: false,
            grid_moves: 0,
            waypoints: 0,
            path_length_rad: 0.0,
            max_speed_rad_s: 0.0,
            min_clearance_m: f64::NEG_INFINITY,
            converged: None,
            relaxed_converged: None,
            route: 0,
            goal: 0,
            stopped: false,
            peak_torque_ratio: 0.0,
        }
    }
}

/// The grid over the joint ranges.
#[derive(Clone, PartialEq)]
struct Grid {
    lo: Vec<f64>,
    step: Vec<f64>,
    dims: Vec<usize>,
    cells: usize,
    nominal_step: f64,
}

impl Grid {
    /// The finest grid of at most [`MAX_CELLS`] cells with a step of at least [`GRID_STEP_RAD`];
    /// `None` when that step exceeds [`MAX_GRID_STEP_RAD`].
    fn new(lo: &[f64], hi: &[f64]) -> (f64, Option<Grid>) {
        let mut step = GRID_STEP_RAD;
        loop {
            let dims: Vec<usize> = lo
                .iter()
                .zip(hi)
                .map(|(l, h)| ((h - l) / step).ceil().max(1.0) as usize + 1)
                .collect();
            let cells = dims
                .iter()
                .try_fold(1usize, |a, d| a.checked_mul(*d))
                .unwrap_or(usize::MAX);
            if cells <= MAX_CELLS {
                let step_d = lo
                    .iter()
                    .zip(hi)
                    .zip(&dims)
                    .map(|((l, h), d)| (h - l) / (*d - 1) as f64)
                    .collect();
                return (
                    step,
                    Some(Grid {
                        lo: lo.to_vec(),
                        step: step_d,
                        dims,
                        cells,
                        nominal_step: step,
                    }),
                );
            }
            step *= 1.05;
            if step > MAX_GRID_STEP_RAD {
                return (step, None);
            }
        }
    }

    fn nearest(&self, q: &[f64], c: &mut [usize]) {
        for d in 0..c.len() {
            let v = ((q[d] - self.lo[d]) / self.step[d]).round().max(0.0) as usize;
            c[d] = v.min(self.dims[d] - 1);
        }
    }

    /// Per joint, how far apart in index two cells one step apart along it are.
    fn strides(&self) -> Vec<usize> {
        let mut s = vec![1; self.dims.len()];
        for d in (0..self.dims.len().saturating_sub(1)).rev() {
            s[d] = s[d + 1] * self.dims[d + 1];
        }
        s
    }

    fn index(&self, c: &[usize]) -> usize {
        c.iter().zip(&self.dims).fold(0, |a, (ci, d)| a * d + ci)
    }

    fn coords(&self, mut idx: usize, c: &mut [usize]) {
        for d in (0..c.len()).rev() {
            c[d] = idx % self.dims[d];
            idx /= self.dims[d];
        }
    }

    fn value(&self, c: &[usize], q: &mut [f64]) {
        for d in 0..c.len() {
            q[d] = self.lo[d] + c[d] as f64 * self.step[d];
        }
    }

    /// Per joint, `[cos, sin]` of each of its grid values ([`Self::value`]).
    fn rotations(&self) -> Vec<Vec<[f64; 2]>> {
        (0..self.dims.len())
            .map(|d| {
                (0..self.dims[d])
                    .map(|i| {
                        let (s, c) = (self.lo[d] + i as f64 * self.step[d]).sin_cos();
                        [c, s]
                    })
                    .collect()
            })
            .collect()
    }
}

/// The scratch of a cell's check: its joints' `[cos, sin]` and its links' segments.
struct CellScratch {
    rot: Vec<[f64; 2]>,
    segs: [(P2<f64>, P2<f64>); MAX_LINKS],
}

impl CellScratch {
    fn new(n: usize) -> Self {
        CellScratch {
            rot: vec![[1.0, 0.0]; n],
            segs: [([0.0; 2], [0.0; 2]); MAX_LINKS],
        }
    }
}

/// Cell states: not reached, reached and blocked, known free, in an earlier route's tube, the start,
/// or reached by move `dir` (its state is `FIRST_MOVE + dir`, `dir = 2 d + up`).
const UNSEEN: u8 = 0;
const BLOCKED: u8 = 1;
/// Checked free by an earlier search of the same grid, not reached by this one.
const FREE: u8 = 2;
/// Blocked for this search: round an earlier route.
const TUBE: u8 = 3;
const START: u8 = 4;
const FIRST_MOVE: u8 = 5;

/// What a grid's cell verdicts hold for: the robot, the obstacles, the margin and self-collision
/// rule, and the grid.
#[derive(PartialEq)]
struct VerdictKey {
    robot: Robot,
    obstacles: Vec<Circle>,
    margin: f64,
    self_collision: bool,
    grid: Grid,
}

/// The collision verdict of every cell of one grid against one set of obstacles and self-collision
/// rule: not checked yet, free or blocked (by [`CELL_EXTRA_CLEARANCE`]). Route searches on the same
/// grid to different goal poses share them, so a cell is checked once for all of them. Empty until
/// a search is given them; a search of another robot, obstacles, margin or grid replaces them.
#[derive(Default)]
pub(crate) struct CellVerdicts(Option<(VerdictKey, Arc<[AtomicU8]>)>);

const NOT_CHECKED: u8 = 0;
const CHECKED_FREE: u8 = 1;
const CHECKED_BLOCKED: u8 = 2;

impl CellVerdicts {
    /// The verdicts for `key`'s grid of `cells` cells: these when they hold for it, otherwise new
    /// ones in their place.
    fn for_key(&mut self, key: VerdictKey, cells: usize) -> Arc<[AtomicU8]> {
        match &self.0 {
            Some((k, v)) if *k == key => v.clone(),
            _ => {
                let v: Arc<[AtomicU8]> = (0..cells).map(|_| AtomicU8::new(NOT_CHECKED)).collect();
                self.0 = Some((key, v.clone()));
                v
            }
        }
    }
}

/// Collision checks against the planner's margin plus an extra clearance.
struct Checker {
    cf: ClearanceFn,
    margin: f64,
}

impl Checker {
    /// Clearance of pose `q` beyond the planner's margin, m.
    fn clearance(&self, q: &[f64]) -> f64 {
        self.cf.min_clearance(q) - self.margin
    }

    /// Whether the cell `c` of a grid whose joint values have the `[cos, sin]` of `rotations`
    /// ([`Grid::rotations`]) is blocked: its pose's [`Self::clearance`] below
    /// [`CELL_EXTRA_CLEARANCE`] (up to rounding; no sine or cosine evaluated, squared distances
    /// compared, ended at the first pair too close).
    fn cell_blocked(&self, rotations: &[Vec<[f64; 2]>], c: &[usize], w: &mut CellScratch) -> bool {
        for (d, &i) in c.iter().enumerate() {
            w.rot[d] = rotations[d][i];
        }
        let n = c.len();
        self.cf
            .robot
            .link_segments_rotated(&w.rot, &mut w.segs[..n]);
        !self
            .cf
            .keeps(&w.segs[..n], self.margin + CELL_EXTRA_CLEARANCE)
    }

    /// Smallest clearance beyond the margin over the check points of the segment `a -> b`.
    fn segment(&self, a: &[f64], b: &[f64], q: &mut [f64], stop_below: f64) -> f64 {
        let len: f64 = a.iter().zip(b).map(|(x, y)| (y - x).abs()).sum();
        let m = (len / SEGMENT_CHECK_RAD).ceil().max(1.0) as usize;
        let mut worst = f64::INFINITY;
        for j in 0..=m {
            let r = j as f64 / m as f64;
            for i in 0..q.len() {
                q[i] = a[i] + r * (b[i] - a[i]);
            }
            worst = worst.min(self.clearance(q));
            if worst < stop_below {
                break;
            }
        }
        worst
    }
}

/// How often (in cells reached) the search asks its stop rule whether to end.
pub const STOP_CHECK_CELLS: usize = 2048;

/// A collision-free piecewise-linear joint path from `q_start` to `q_goal` (see the module docs): its
/// waypoints (start and goal included), or `None` with the report saying why.
pub fn cspace_path(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    q_start: &[f64],
    q_goal: &[f64],
) -> Result<(CspaceReport, Option<Vec<Vec<f64>>>)> {
    let mut routes = cspace_routes(robot, obstacles, settings, q_start, q_goal, 1, &|| false)?;
    Ok(routes.remove(0))
}

/// Up to `k` distinct collision-free joint paths from `q_start` to `q_goal`, best first: the first
/// as [`cspace_path`]; each next one searched on the same grid with a tube of
/// [`ROUTE_TUBE_CELLS`] cells round every route before it blocked (except within
/// [`ROUTE_TUBE_CELLS`] + 1 cells of the two ends), so it takes another way round; a route whose
/// waypoints stay within [`SAME_ROUTE_RAD`] of an earlier route's is dropped. Cells checked once
/// are not checked again. `stop` is asked every [`STOP_CHECK_CELLS`] cells reached: once it says
/// stop, the search running ends without a path (its report says `stopped`) and no other starts.
/// One report per search run that found no route or a distinct one (at least one report); the
/// waypoints of those that found a distinct route (a route too near an earlier one is dropped).
/// The same as [`RouteSearch::more`] on a new [`RouteSearch`].
pub fn cspace_routes(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    q_start: &[f64],
    q_goal: &[f64],
    k: usize,
    stop: &dyn Fn() -> bool,
) -> Result<Vec<Route>> {
    Ok(RouteSearch::new(robot, obstacles, settings, q_start, q_goal)?.more(k, stop))
}

/// The route searches of [`cspace_routes`] from one start pose to one goal pose, kept between
/// calls: a later call for more routes ([`RouteSearch::more`]) continues from the grid the earlier
/// routes left (their tubes blocked, the cells checked), so the routes it yields are those a single
/// call for all of them would have yielded past the earlier ones, without searching the earlier
/// ones again.
pub struct RouteSearch {
    /// The report every search starts from (grid, endpoints).
    rep: CspaceReport,
    /// The grid and its cells' states; `None` when nothing is searched (a grid too coarse, or an
    /// end pose that does not clear the obstacles).
    search: Option<Search>,
    q_start: Vec<f64>,
    q_goal: Vec<f64>,
    /// The distinct routes found so far.
    found: Vec<Vec<Vec<f64>>>,
    /// Index of the next route to search.
    next: usize,
    /// A search found no route: no later one is searched.
    failed: bool,
    /// The cells of the last route found, whose tube is blocked before the next search.
    tube: Option<Vec<usize>>,
    /// The stop rule said stop during a call: the grid's state is not that of a search run to
    /// its end.
    stopped: bool,
    /// Grid searches run.
    searches: usize,
}

impl RouteSearch {
    /// The searches from `q_start` to `q_goal` against `obstacles`, none run yet (the grid is
    /// allocated when the end poses clear the obstacles).
    pub fn new(
        robot: &Robot,
        obstacles: &[Circle],
        settings: &PlannerSettings,
        q_start: &[f64],
        q_goal: &[f64],
    ) -> Result<Self> {
        Self::sharing(robot, obstacles, settings, q_start, q_goal, None)
    }

    /// [`RouteSearch::new`], its grid's cell verdicts shared through `verdicts` (when given) with
    /// the other searches given them for the same robot, obstacles and settings.
    pub(crate) fn sharing(
        robot: &Robot,
        obstacles: &[Circle],
        settings: &PlannerSettings,
        q_start: &[f64],
        q_goal: &[f64],
        verdicts: Option<&mut CellVerdicts>,
    ) -> Result<Self> {
        let n = robot.n;
        let b = &settings.bounds;
        let mut lo = vec![-b.q_rel_max; n];
        let mut hi = vec![b.q_rel_max; n];
        (lo[0], hi[0]) = (b.q1[0], b.q1[1]);
        let (step, grid) = Grid::new(&lo, &hi);
        let mut rep = CspaceReport::not_searched(step);
        let check = Checker {
            cf: ClearanceFn::new(robot.clone(), obstacles.to_vec(), 0.0)?
                .with_self_collision(settings.self_collision),
            margin: settings.obstacle_margin,
        };
        // (reported also for a grid too coarse to search: `grid_cells` 0 says why nothing was
        // searched)
        rep.endpoints_clear = check.clearance(q_start) >= 0.0 && check.clearance(q_goal) >= 0.0;
        let search = match grid {
            Some(grid) => {
                rep.grid_cells = grid.cells;
                rep.grid_step_rad = grid.nominal_step;
                rep.endpoints_clear.then(|| {
                    let verdicts = verdicts.map(|v| {
                        let key = VerdictKey {
                            robot: robot.clone(),
                            obstacles: obstacles.to_vec(),
                            margin: settings.obstacle_margin,
                            self_collision: settings.self_collision,
                            grid: grid.clone(),
                        };
                        v.for_key(key, grid.cells)
                    });
                    Search {
                        state: vec![UNSEEN; grid.cells],
                        verdicts,
                        rotations: grid.rotations(),
                        grid,
                        check,
                    }
                })
            }
            None => None,
        };
        Ok(RouteSearch {
            rep,
            search,
            q_start: q_start.to_vec(),
            q_goal: q_goal.to_vec(),
            found: vec![],
            next: 0,
            failed: false,
            tube: None,
            stopped: false,
            searches: 0,
        })
    }

    /// The routes past those of the earlier calls, up to `k` routes in all counted from the first
    /// call's first ([`cspace_routes`]): one report per search run that found no route or a
    /// distinct one (the first call at least one), with the waypoints of a distinct route.
    pub fn more(&mut self, k: usize, stop: &dyn Fn() -> bool) -> Vec<Route> {
        let said_stop = Cell::new(false);
        let stop = || {
            let s = stop();
            said_stop.set(said_stop.get() || s);
            s
        };
        let mut out: Vec<Route> = vec![];
        let Some(search) = self.search.as_mut() else {
            if self.next == 0 {
                self.next = 1;
                out.push((self.rep.clone(), None));
            }
            return out;
        };
        for route in self.next..k.max(1) {
            if route > 0 {
                if self.failed {
                    break;
                }
                if let Some(cells) = self.tube.take() {
                    search.block_tube(&cells, &stop);
                }
                if stop() {
                    break;
                }
            }
            self.next = route + 1;
            self.searches += 1;
            let mut r = self.rep.clone();
            r.route = route;
            let Some(cells) = search.route(&self.q_start, &self.q_goal, &mut r, &stop) else {
                self.failed = true;
                out.push((r, None));
                continue;
            };
            let path = search.shortcut(&self.q_start, &self.q_goal, &cells, &mut r);
            self.tube = Some(cells);
            if self.found.iter().all(|f| !same_route(f, &path)) {
                self.found.push(path.clone());
                out.push((r, Some(path)));
            }
        }
        self.stopped |= said_stop.get();
        // a search that failed gives no more routes, and one the stop rule ended is not continued:
        // their grids are freed
        if self.failed || self.stopped {
            self.search = None;
        }
        out
    }

    /// The goal pose searched to, rad.
    pub fn goal(&self) -> &[f64] {
        &self.q_goal
    }

    /// The start pose searched from, rad.
    pub fn start(&self) -> &[f64] {
        &self.q_start
    }

    /// Whether the stop rule said stop during a call (a later call would not continue a search run
    /// to its end).
    pub fn stopped(&self) -> bool {
        self.stopped
    }

    /// Grid searches run over all calls.
    pub fn searches(&self) -> usize {
        self.searches
    }
}

/// One search of [`cspace_routes`]: its report and, when it found a distinct route, the route's
/// waypoints.
pub type Route = (CspaceReport, Option<Vec<Vec<f64>>>);

/// Cells round a route blocked for the routes after it (L-infinity radius in cells).
pub const ROUTE_TUBE_CELLS: usize = 3;
/// Most cells of the box round one route cell that the tube visits: on a grid of many dimensions
/// the tube's half-width shrinks below [`ROUTE_TUBE_CELLS`] until its box holds at most this many
/// (`(2 r + 1)^n`), down to the route's own cells, so blocking it stays cheap for any link count.
pub const MAX_TUBE_BOX_CELLS: usize = 20_000;
/// Two routes whose waypoints, resampled at 32 points along their arc length, all agree to this
/// (rad, largest joint difference) are one route.
pub const SAME_ROUTE_RAD: f64 = 0.3;

/// Whether two paths are the same route ([`SAME_ROUTE_RAD`]).
fn same_route(a: &[Vec<f64>], b: &[Vec<f64>]) -> bool {
    let (pa, pb) = (along(a, 32), along(b, 32));
    pa.iter().zip(&pb).all(|(x, y)| {
        x.iter()
            .zip(y)
            .all(|(u, v)| (u - v).abs() <= SAME_ROUTE_RAD)
    })
}

/// `m + 1` points evenly spaced along the arc length of the piecewise-linear path `p`.
fn along(p: &[Vec<f64>], m: usize) -> Vec<Vec<f64>> {
    let mut acc = vec![0.0];
    for w in p.windows(2) {
        acc.push(acc.last().copied().unwrap_or(0.0) + dist(&w[0], &w[1]));
    }
    let total = acc.last().copied().unwrap_or(0.0);
    (0..=m)
        .map(|j| {
            let s = total * j as f64 / m as f64;
            let seg = (acc.partition_point(|&a| a <= s).max(1) - 1).min(p.len().saturating_sub(2));
            if p.len() < 2 {
                return p[0].clone();
            }
            let l = acc[seg + 1] - acc[seg];
            let f = if l > 0.0 {
                ((s - acc[seg]) / l).clamp(0.0, 1.0)
            } else {
                0.0
            };
            p[seg]
                .iter()
                .zip(&p[seg + 1])
                .map(|(a, b)| a + f * (b - a))
                .collect()
        })
        .collect()
}

/// One grid with its cells' states, searched for one route after another.
struct Search {
    grid: Grid,
    /// Per joint, `[cos, sin]` of its grid values ([`Grid::rotations`]).
    rotations: Vec<Vec<[f64; 2]>>,
    check: Checker,
    state: Vec<u8>,
    /// The cells' collision verdicts, shared with the searches to other goal poses on this grid
    /// (`None`: a search on its own, whose cell states keep what it checked).
    verdicts: Option<Arc<[AtomicU8]>>,
}

/// Whether cell `k` (coordinates `c`) is blocked: its shared verdict, or its pose checked against
/// the margin plus [`CELL_EXTRA_CLEARANCE`] ([`Checker::cell_blocked`]) and the verdict kept.
fn cell_blocked(
    verdicts: Option<&[AtomicU8]>,
    check: &Checker,
    rotations: &[Vec<[f64; 2]>],
    k: usize,
    c: &[usize],
    w: &mut CellScratch,
) -> bool {
    let mut checked = || check.cell_blocked(rotations, c, w);
    let Some(verdicts) = verdicts else {
        return checked();
    };
    match verdicts[k].load(Ordering::Relaxed) {
        CHECKED_FREE => false,
        CHECKED_BLOCKED => true,
        _ => {
            let blocked = checked();
            let v = if blocked {
                CHECKED_BLOCKED
            } else {
                CHECKED_FREE
            };
            verdicts[k].store(v, Ordering::Relaxed);
            blocked
        }
    }
}

impl Search {
    /// The weighted A* of the module docs from `q_start`'s cell to `q_goal`'s: the cells of the
    /// route, start to goal, or `None` (the report says why).
    fn route(
        &mut self,
        q_start: &[f64],
        q_goal: &[f64],
        rep: &mut CspaceReport,
        stop: &dyn Fn() -> bool,
    ) -> Option<Vec<usize>> {
        let n = q_start.len();
        let grid = &self.grid;
        // cells reached by an earlier search are known free; its path marks are cleared
        for s in self.state.iter_mut() {
            if *s >= START {
                *s = FREE;
            }
        }
        let (mut c, mut nb, mut goal) = (vec![0; n], vec![0; n], vec![0; n]);
        let mut w = CellScratch::new(n);
        grid.nearest(q_goal, &mut goal);
        grid.nearest(q_start, &mut c);
        let (start_idx, goal_idx) = (grid.index(&c), grid.index(&goal));
        let h = |c: &[usize]| -> u32 {
            c.iter()
                .zip(&goal)
                .map(|(a, g)| a.abs_diff(*g) as u32)
                .sum()
        };
        let (state, verdicts, check) = (&mut self.state, self.verdicts.as_deref(), &self.check);
        let rotations = &self.rotations;
        state[start_idx] = START;
        // (priority, deeper first, cell): the start and goal cells are taken as they are (the exact
        // poses are checked by the shortcut)
        let mut open = OpenList::default();
        open.push(HEURISTIC_WEIGHT * h(&c), 0, start_idx as u32);
        rep.cells_discovered = 1;
        let mut found = start_idx == goal_idx;
        let strides = grid.strides();
        'search: while let Some((g, idx)) = open.pop() {
            grid.coords(idx as usize, &mut c);
            nb.copy_from_slice(&c);
            let h_c = h(&c);
            for d in 0..n {
                for up in [false, true] {
                    if (up && c[d] + 1 >= grid.dims[d]) || (!up && c[d] == 0) {
                        continue;
                    }
                    // the neighbour one step along joint d: its coordinates (put back below), its
                    // index and its heuristic, one move nearer the goal or one farther
                    let (k, h_nb);
                    if up {
                        nb[d] = c[d] + 1;
                        k = idx as usize + strides[d];
                        h_nb = if c[d] < goal[d] { h_c - 1 } else { h_c + 1 };
                    } else {
                        nb[d] = c[d] - 1;
                        k = idx as usize - strides[d];
                        h_nb = if c[d] > goal[d] { h_c - 1 } else { h_c + 1 };
                    }
                    let s = state[k];
                    if s != UNSEEN && s != FREE {
                        continue;
                    }
                    if rep.cells_discovered >= MAX_DISCOVERED {
                        break 'search;
                    }
                    if rep.cells_discovered.is_multiple_of(STOP_CHECK_CELLS) && stop() {
                        rep.stopped = true;
                        break 'search;
                    }
                    rep.cells_discovered += 1;
                    let dir = (2 * d + usize::from(up)) as u8;
                    if k == goal_idx {
                        state[k] = FIRST_MOVE + dir;
                        found = true;
                        break 'search;
                    }
                    if s == UNSEEN && cell_blocked(verdicts, check, rotations, k, &nb, &mut w) {
                        state[k] = BLOCKED;
                        continue;
                    }
                    state[k] = FIRST_MOVE + dir;
                    let g1 = g + 1;
                    open.push(g1 + HEURISTIC_WEIGHT * h_nb, g1, k as u32);
                }
                nb[d] = c[d];
            }
        }
        if !found {
            rep.exhausted =
                !rep.stopped && open.is_empty() && rep.cells_discovered < MAX_DISCOVERED;
            return None;
        }
        rep.found = true;
        // the grid path, goal back to start
        let mut cells = vec![goal_idx];
        let mut k = goal_idx;
        while state[k] != START {
            let dir = (state[k] - FIRST_MOVE) as usize;
            grid.coords(k, &mut c);
            let d = dir / 2;
            if dir % 2 == 1 {
                c[d] -= 1;
            } else {
                c[d] += 1;
            }
            k = grid.index(&c);
            cells.push(k);
        }
        cells.reverse();
        rep.grid_moves = cells.len() - 1;
        Some(cells)
    }

    /// The route `cells` from `q_start` to `q_goal` shortened (the module docs, step 3), with the
    /// report's waypoints, clearance and length.
    fn shortcut(
        &self,
        q_start: &[f64],
        q_goal: &[f64],
        cells: &[usize],
        rep: &mut CspaceReport,
    ) -> Vec<Vec<f64>> {
        let n = q_start.len();
        let (grid, check) = (&self.grid, &self.check);
        let (mut c, mut q) = (vec![0; n], vec![0.0; n]);
        let mut pts: Vec<Vec<f64>> = Vec::with_capacity(cells.len() + 2);
        pts.push(q_start.to_vec());
        for &k in cells {
            grid.coords(k, &mut c);
            grid.value(&c, &mut q);
            pts.push(q.clone());
        }
        pts.push(q_goal.to_vec());
        // greedy shortcut: from each kept point to the farthest later one a clear segment reaches
        let mut out = vec![pts[0].clone()];
        let mut i = 0;
        let last = pts.len() - 1;
        while i < last {
            let mut j = i + 1;
            while j < last
                && check.segment(&pts[i], &pts[j + 1], &mut q, SEGMENT_EXTRA_CLEARANCE)
                    >= SEGMENT_EXTRA_CLEARANCE
            {
                j += 1;
            }
            out.push(pts[j].clone());
            i = j;
        }
        rep.waypoints = out.len();
        rep.min_clearance_m = out
            .windows(2)
            .map(|w| check.segment(&w[0], &w[1], &mut q, f64::NEG_INFINITY))
            .fold(f64::INFINITY, f64::min);
        rep.path_length_rad = out.windows(2).map(|w| dist(&w[0], &w[1])).sum();
        out
    }

    /// Block the cells within [`ROUTE_TUBE_CELLS`] (L-infinity; less on a grid of many dimensions,
    /// [`MAX_TUBE_BOX_CELLS`]) of the route `cells` for the searches after it, except near its two
    /// ends. Stops when the search is told to.
    fn block_tube(&mut self, cells: &[usize], stop: &dyn Fn() -> bool) {
        let (Some(&first), Some(&last)) = (cells.first(), cells.last()) else {
            return;
        };
        let grid = &self.grid;
        let n = grid.dims.len();
        let mut r = ROUTE_TUBE_CELLS as isize;
        while r > 0
            && ((2 * r + 1) as usize)
                .checked_pow(n as u32)
                .is_none_or(|c| c > MAX_TUBE_BOX_CELLS)
        {
            r -= 1;
        }
        let (mut a, mut z, mut c, mut nb) = (vec![0; n], vec![0; n], vec![0; n], vec![0; n]);
        grid.coords(first, &mut a);
        grid.coords(last, &mut z);
        let near_end = |x: &[usize]| {
            [&a, &z].iter().any(|e| {
                x.iter()
                    .zip(e.iter())
                    .all(|(u, v)| u.abs_diff(*v) <= ROUTE_TUBE_CELLS + 1)
            })
        };
        let side = (2 * r + 1) as usize;
        let count = side.pow(n as u32);
        for &k in cells {
            if stop() {
                return;
            }
            grid.coords(k, &mut c);
            for m in 0..count {
                let mut rem = m;
                let mut inside = true;
                for d in 0..n {
                    let off = (rem % side) as isize - r;
                    rem /= side;
                    let v = c[d] as isize + off;
                    if v < 0 || v >= grid.dims[d] as isize {
                        inside = false;
                        break;
                    }
                    nb[d] = v as usize;
                }
                if !inside || near_end(&nb) {
                    continue;
                }
                let i = grid.index(&nb);
                if self.state[i] != BLOCKED {
                    self.state[i] = TUBE;
                }
            }
        }
    }
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (y - x).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The configuration-space seed of the obstacle-free plan `free` (its knots: the start pose at the
/// first, the final pose at the bar at the last) against `obstacles`: the path of [`cspace_path`]
/// between those poses timed over `free`'s time axis (see the module docs), or `None` with the report
/// saying why.
pub fn cspace_seed(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    free: &Trajectory,
) -> Result<(CspaceReport, Option<Trajectory>)> {
    let len = free.len();
    if len < 2 || obstacles.is_empty() {
        return Ok((CspaceReport::not_searched(GRID_STEP_RAD), None));
    }
    let (mut rep, path) = cspace_path(robot, obstacles, settings, free.q(0), free.q(len - 1))?;
    let Some(path) = path else {
        return Ok((rep, None));
    };
    let g = time_path(robot, &path, free, &mut rep);
    Ok((rep, Some(g)))
}

/// The piecewise-linear joint path `path` timed over `free`'s time axis (the module docs, step 4),
/// with the report's largest speed and torque ratio.
pub fn time_path(
    robot: &Robot,
    path: &[Vec<f64>],
    free: &Trajectory,
    rep: &mut CspaceReport,
) -> Trajectory {
    let n = robot.n;
    let len = free.len();
    // cumulative arc length at the waypoints
    let mut acc = vec![0.0];
    for w in path.windows(2) {
        acc.push(acc.last().copied().unwrap_or(0.0) + dist(&w[0], &w[1]));
    }
    let total = acc.last().copied().unwrap_or(0.0);
    let (t0, dur) = (free.t[0], free.duration());
    let mut ws = Scratch::new(n);
    let (mut q, mut qd, mut qdd, mut f) = (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let mut e = vec![0.0; n];
    let mut g = Trajectory::new(n);
    let mut max_dir = 0.0f64;
    let a = &robot.params().actuators;
    let limit: Vec<f64> = (0..n - 1)
        .map(|j| a.tau_min[j].abs().max(a.tau_max[j].abs()).max(1e-9))
        .collect();
    let biggest = limit.iter().fold(1e-9f64, |m, v| m.max(*v));
    let mut ratio = 0.0f64;
    for k in 0..len {
        let r = ((free.t[k] - t0) / dur).clamp(0.0, 1.0);
        let s = total * r * r * (3.0 - 2.0 * r);
        let sd = total * 6.0 * r * (1.0 - r) / dur;
        let sdd = total * 6.0 * (1.0 - 2.0 * r) / (dur * dur);
        // the segment holding arc length s (zero-length segments skipped)
        let seg = (acc.partition_point(|&a| a <= s).max(1) - 1).min(path.len() - 2);
        let l = acc[seg + 1] - acc[seg];
        let frac = if l > 0.0 { (s - acc[seg]) / l } else { 0.0 };
        for i in 0..n {
            let (a, b) = (path[seg][i], path[seg + 1][i]);
            q[i] = a + frac.clamp(0.0, 1.0) * (b - a);
            e[i] = if l > 0.0 { (b - a) / l } else { 0.0 };
            qd[i] = sd * e[i];
            qdd[i] = sdd * e[i];
            max_dir = max_dir.max(e[i].abs());
        }
        robot.inverse_dynamics_into(&mut ws, &q, &qd, &qdd, &mut f);
        ratio = ratio.max(f[0].abs() / biggest);
        for (fj, lj) in f[1..].iter().zip(&limit) {
            ratio = ratio.max(fj.abs() / lj);
        }
        g.push(free.t[k], &q, &qd, &f[1..]);
    }
    rep.max_speed_rad_s = 1.5 * total / dur * max_dir;
    rep.peak_torque_ratio = ratio;
    g
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// A cell's check from the grid's tabulated rotations says what the exact clearance of the
    /// cell's pose says, on random cells of the paper robot's grid about an obstacle on its swing,
    /// away from the boundary.
    #[test]
    fn a_cell_check_agrees_with_the_exact_clearance_of_the_cell_pose() {
        let robot = Robot::paper();
        let obstacles = [Circle {
            center: [0.3, -0.55],
            radius: 0.12,
        }];
        let settings = PlannerSettings::default();
        let (start, goal) = ([-2.35, 0.0, -1.55, 0.0], [-1.0, 0.5, 0.5, 0.3]);
        let rs = RouteSearch::new(&robot, &obstacles, &settings, &start, &goal).unwrap();
        let search = rs
            .search
            .as_ref()
            .expect("the paper robot's grid is searched");
        let (grid, check) = (&search.grid, &search.check);
        let n = robot.n;
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let (mut c, mut q, mut w) = (vec![0; n], vec![0.0; n], CellScratch::new(n));
        let (mut blocked, mut free) = (0, 0);
        for _ in 0..20_000 {
            for d in 0..n {
                c[d] = rng.gen_range(0..grid.dims[d]);
            }
            grid.value(&c, &mut q);
            let exact = check.clearance(&q);
            if (exact - CELL_EXTRA_CLEARANCE).abs() < 1e-9 {
                continue;
            }
            let is_blocked = check.cell_blocked(&search.rotations, &c, &mut w);
            assert_eq!(is_blocked, exact < CELL_EXTRA_CLEARANCE, "{c:?}: {exact}");
            if is_blocked {
                blocked += 1;
            } else {
                free += 1;
            }
        }
        assert!(
            blocked > 1000 && free > 1000,
            "{blocked} blocked, {free} free"
        );
        // one step along a joint is one stride apart in index
        let strides = grid.strides();
        for d in 0..n {
            c.iter_mut().for_each(|x| *x = 1);
            let k = grid.index(&c);
            c[d] += 1;
            assert_eq!(grid.index(&c), k + strides[d]);
        }
    }
}
