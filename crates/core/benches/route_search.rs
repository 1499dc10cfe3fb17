//! The configuration-space route search of the obstacle race (`strategy/cspace.rs`,
//! `strategy/homotopy.rs`): up to 3 goal poses at the bar, up to 2 routes each, on the paper robot's
//! grid (32 x 59^3 cells), for two obstacles on the paper swing's path that its detours do not pass.
//!
//! Two ways to run the same grid searches: as the race runs them (`homotopy_routes`: the searches
//! to the goal poses share their grid's cell verdicts, so a cell is checked once for all of them),
//! and each goal pose's search on its own (`cspace_routes` per goal pose: every search checks its
//! cells itself), the baseline. A manual pass prints the medians of both and their ratio, and
//! that both found the same routes. A first manual pass times the search's cell check against the
//! exact clearance of the cell's pose on the same random grid cells.
//! `cargo bench -p brachia --bench route_search`.

use brachia::model::{Circle, ClearanceFn, Robot};
use brachia::planning::strategy::cspace::{
    cspace_routes, time_path, CELL_EXTRA_CLEARANCE, GRID_STEP_RAD,
};
use brachia::planning::strategy::goal::{
    clear_final_pose_until, distinct_goal_poses, with_final_pose,
};
use brachia::planning::strategy::homotopy::{homotopy_routes, MAX_GOALS, ROUTES_PER_GOAL};
use brachia::planning::{plan, NlpSettings, PlannerSettings, SwingTask};
use brachia::trajectory::Trajectory;
use criterion::{criterion_group, criterion_main, Criterion};
use shared::median;
use std::time::{Duration, Instant};

mod shared;

/// One placement: the obstacle-free swing's knots (ending at a clear pose at the bar) and the
/// obstacle on it.
struct Case {
    name: &'static str,
    free: Trajectory,
    obstacles: Vec<Circle>,
}

/// The two placements: on the paper swing, a circle at the point a fraction `along` of link `link`
/// (0-based) passes at `t_s`.
fn cases(robot: &Robot, s: &PlannerSettings) -> Vec<Case> {
    let task = SwingTask::paper();
    let p = plan(robot, &task, s, &NlpSettings::default()).expect("the paper swing plans");
    assert!(p.converged(), "the paper swing converges");
    let knots = p.points.clone();
    let last = knots.q(knots.len() - 1).to_vec();
    let on_link = |link: usize, along: f64, t_s: f64, radius: f64| {
        let k = ((t_s / p.swing_time_s) * (knots.len() - 1) as f64).round() as usize;
        let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
        robot.link_segments(knots.q(k), &mut segs);
        let (a, b) = segs[link];
        Circle {
            center: [a[0] + along * (b[0] - a[0]), a[1] + along * (b[1] - a[1])],
            radius,
        }
    };
    let placements = [
        (
            "link 3 midpoint at 1.42 s, r 0.12 m",
            on_link(2, 0.5, 1.42, 0.12),
        ),
        (
            "link 1 tip at 1.02 s, r 0.114 m",
            on_link(0, 1.0, 1.02, 0.114),
        ),
    ];
    placements
        .into_iter()
        .map(|(name, c)| {
            let obstacles = vec![c];
            let never = || false;
            let end = clear_final_pose_until(robot, &obstacles, s, &last, task.target, &never)
                .expect("the goal search runs");
            let free = match end {
                Some(q) => with_final_pose(&knots, &q),
                None => knots.clone(),
            };
            Case {
                name,
                free,
                obstacles,
            }
        })
        .collect()
}

/// The routes (waypoints) of the race's search, sharing the cell verdicts.
fn shared_search(robot: &Robot, s: &PlannerSettings, c: &Case) -> Vec<Vec<Vec<f64>>> {
    let target = SwingTask::paper().target;
    let r = homotopy_routes(robot, &c.obstacles, s, &c.free, target, &|| false).expect("searches");
    let mut by_search: Vec<_> = r.seeds.into_iter().map(|sd| (sd.report, sd.path)).collect();
    by_search.sort_by_key(|(i, _)| *i);
    by_search.into_iter().map(|(_, p)| p).collect()
}

/// The same searches, each goal pose's on its own, each route timed over the swing as the race's
/// are.
fn own_searches(robot: &Robot, s: &PlannerSettings, c: &Case) -> Vec<Vec<Vec<f64>>> {
    let target = SwingTask::paper().target;
    let never = || false;
    let (start, end) = (c.free.q(0), c.free.q(c.free.len() - 1));
    let goals = distinct_goal_poses(robot, &c.obstacles, s, end, target, MAX_GOALS, &never)
        .expect("goal poses");
    let mut paths = vec![];
    for g in &goals {
        let axis = with_final_pose(&c.free, g);
        let routes = cspace_routes(robot, &c.obstacles, s, start, g, ROUTES_PER_GOAL, &never);
        for (mut rep, path) in routes.expect("searches") {
            if let Some(path) = path {
                time_path(robot, &path, &axis, &mut rep);
                paths.push(path);
            }
        }
    }
    paths
}

/// Random cells of a grid of `GRID_STEP_RAD` in every joint's range (q1 in the bounds, the others
/// within `q_rel_max`): each cell's joint indices and angles, and the grid's `[cos, sin]` per joint
/// and index.
struct GridPoses {
    poses: Vec<Vec<f64>>,
    cells: Vec<Vec<usize>>,
    table: Vec<Vec<[f64; 2]>>,
}

fn grid_poses(robot: &Robot, s: &PlannerSettings, count: usize) -> GridPoses {
    let b = &s.bounds;
    let n = robot.n();
    let lo: Vec<f64> = (0..n)
        .map(|d| if d == 0 { b.q1[0] } else { -b.q_rel_max })
        .collect();
    let hi: Vec<f64> = (0..n)
        .map(|d| if d == 0 { b.q1[1] } else { b.q_rel_max })
        .collect();
    let dims: Vec<usize> = (0..n)
        .map(|d| ((hi[d] - lo[d]) / GRID_STEP_RAD).ceil() as usize + 1)
        .collect();
    let value = |d: usize, i: usize| lo[d] + i as f64 * (hi[d] - lo[d]) / (dims[d] - 1) as f64;
    let table = (0..n)
        .map(|d| {
            (0..dims[d])
                .map(|i| {
                    let (sn, c) = value(d, i).sin_cos();
                    [c, sn]
                })
                .collect()
        })
        .collect();
    // a fixed linear congruential sequence: the same cells in every run
    let mut x: u64 = 12345;
    let mut next = |m: usize| {
        x = x
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (x >> 33) as usize % m
    };
    let cells: Vec<Vec<usize>> = (0..count)
        .map(|_| (0..n).map(|d| next(dims[d])).collect())
        .collect();
    let poses = cells
        .iter()
        .map(|c| c.iter().enumerate().map(|(d, &i)| value(d, i)).collect())
        .collect();
    GridPoses {
        poses,
        cells,
        table,
    }
}

/// The cell check of the search (tabulated rotations, squared distances, ended at the first pair
/// too close) against the exact clearance of each cell's pose, the baseline, on the same cells of
/// the first case: the medians of 5 passes over 200,000 cells and their ratio, and that both
/// blocked the same cells.
fn cell_check_pass(robot: &Robot, s: &PlannerSettings, c: &Case) {
    let cf = ClearanceFn::new(robot.clone(), c.obstacles.as_slice(), 0.0)
        .expect("a valid obstacle")
        .with_self_collision(s.self_collision);
    let need = s.obstacle_margin + CELL_EXTRA_CLEARANCE;
    let GridPoses {
        poses,
        cells,
        table,
    } = grid_poses(robot, s, 200_000);
    let n = robot.n();
    let (mut fast_t, mut exact_t) = (vec![], vec![]);
    let (mut fast_blocked, mut exact_blocked) = (0, 0);
    let mut segs = vec![([0.0; 2], [0.0; 2]); n];
    let mut rot = vec![[1.0, 0.0]; n];
    for _ in 0..5 {
        let t = Instant::now();
        fast_blocked = cells
            .iter()
            .filter(|cell| {
                for (d, &i) in cell.iter().enumerate() {
                    rot[d] = table[d][i];
                }
                robot.link_segments_rotated(&rot, &mut segs);
                !cf.keeps(&segs, need)
            })
            .count();
        fast_t.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        exact_blocked = poses.iter().filter(|q| cf.min_clearance(q) < need).count();
        exact_t.push(t.elapsed().as_secs_f64());
    }
    let (mf, me) = (median(&fast_t), median(&exact_t));
    println!(
        "  cell check, {}: {:.3} us a cell against the exact clearance's {:.3} us (median of 5 passes over {} cells), ratio {:.2}; blocked {fast_blocked} / {exact_blocked}",
        c.name,
        mf / cells.len() as f64 * 1e6,
        me / cells.len() as f64 * 1e6,
        cells.len(),
        mf / me
    );
}

fn bench(cr: &mut Criterion) {
    let robot = Robot::paper();
    let s = PlannerSettings::default();
    let cases = cases(&robot, &s);
    cell_check_pass(&robot, &s, &cases[0]);
    println!("route search, {MAX_GOALS} goal poses x {ROUTES_PER_GOAL} routes, paper robot");
    for c in &cases {
        let (mut shared_t, mut own_t) = (vec![], vec![]);
        let mut same = true;
        for _ in 0..5 {
            let t = Instant::now();
            let a = shared_search(&robot, &s, c);
            shared_t.push(t.elapsed().as_secs_f64());
            let t = Instant::now();
            let b = own_searches(&robot, &s, c);
            own_t.push(t.elapsed().as_secs_f64());
            same &= a == b;
        }
        let (ms, mo) = (median(&shared_t), median(&own_t));
        println!(
            "  {}: shared verdicts {:.3} s, each search its own {:.3} s (median of 5), ratio {:.2}; same routes: {same}",
            c.name,
            ms,
            mo,
            ms / mo
        );
    }
    let mut g = cr.benchmark_group("route search");
    g.sample_size(10).measurement_time(Duration::from_secs(25));
    for c in &cases {
        g.bench_function(format!("shared verdicts, {}", c.name), |b| {
            b.iter(|| shared_search(&robot, &s, c))
        });
        g.bench_function(format!("each search its own, {}", c.name), |b| {
            b.iter(|| own_searches(&robot, &s, c))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
