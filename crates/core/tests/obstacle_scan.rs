//! Obstacles on the path of the tracking swing (docs/planner.md, "Obstacles on the path"): one 0.08 m
//! obstacle at a link's midpoint of the unobstructed swing (multiple shooting, 10 ms knots, `ocp`). The
//! full scan is the example `obstacle_scan` (minutes); this test runs the cheap part of it: the
//! placements, two plans (one whose smooth step clears the obstacle, one that needs the continuation)
//! and the diagnosis of what blocks a swing. Units: m, s.

use brachia::model::{ClearanceFn, Robot};
use brachia::planning::strategy::cspace::{cspace_path, cspace_seed, MAX_CELLS, MAX_DISCOVERED};
use brachia::planning::strategy::detour::{detour_seeds, SeedKind, EXTRA_CLEARANCE};
use brachia::planning::strategy::goal::{clear_final_pose, with_final_pose};
use brachia::planning::strategy::obstacles::{diagnose, path_placements, Placement};
use brachia::planning::{
    plan, solve_log, Backend, GuessStrategy, NlpSettings, Plan, PlannerSettings, SolveRole,
    SwingTask, Transcription,
};

fn tracking() -> SwingTask {
    SwingTask::paper()
}

/// The unobstructed tracking swing planned with `s` and the scan's placements on it (0.08 m obstacles,
/// 0.01 m from its ends, 8 times).
fn swing_and_placements(
    robot: &Robot,
    s: &PlannerSettings,
    nlp: &NlpSettings,
) -> (Plan, Vec<Placement>) {
    let base = plan(robot, &tracking(), s, nlp).unwrap();
    let places = path_placements(robot, &base.points, [0.8, 0.0], 0.08, 0.01, 8).unwrap();
    (base, places)
}

/// The tracking task with the one obstacle of `pl`.
fn with_obstacle(pl: &Placement) -> SwingTask {
    SwingTask {
        obstacles: vec![pl.obstacle],
        ..tracking()
    }
}

fn settings() -> (PlannerSettings, NlpSettings) {
    (
        PlannerSettings {
            transcription: Transcription::MultipleShooting,
            knot_dt: 0.01,
            shooting: brachia::planning::ShootingSettings {
                substeps: 1,
                ..Default::default()
            },
            ..Default::default()
        },
        NlpSettings {
            backend: Backend::Ocp,
            ..Default::default()
        },
    )
}

#[test]
fn placements_lie_on_the_swing_and_clear_its_ends_and_the_bar() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let base = plan(&robot, &tracking(), &s, &nlp).unwrap();
    assert!(base.converged() && base.guess.is_none());
    let places = path_placements(&robot, &base.points, [0.8, 0.0], 0.08, 0.01, 8).unwrap();
    assert!(places.len() >= 19, "{} placements", places.len());
    for pl in &places {
        let one = [pl.obstacle];
        let cf = ClearanceFn::new(robot.clone(), &one[..], 0.0)
            .unwrap()
            .with_self_collision(false);
        // on the path: the unobstructed swing overlaps it (its centre is on a link at t)
        let (k, _) = base.points.locate(pl.time_s);
        assert!(cf.min_clearance(base.points.q(k)) < -0.09, "{pl:?}");
        assert!(cf.min_clearance(&tracking().q0) > 0.01, "{pl:?}");
        let last = base.points.len() - 1;
        assert!(cf.min_clearance(base.points.q(last)) > 0.01, "{pl:?}");
    }
}

#[test]
fn the_continuation_plans_around_an_obstacle_the_smooth_step_hits() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (_, places) = swing_and_placements(&robot, &s, &nlp);
    // #3 of the scan (link 4 at 0.50 s: the smooth step clears it) and #13 (link 1 at 1.49 s: it
    // does not)
    for (i, strategy) in [
        (2, GuessStrategy::SmoothStep),
        (12, GuessStrategy::Continuation),
    ] {
        let pl = places[i];
        let task = SwingTask {
            obstacles: vec![pl.obstacle],
            ..tracking()
        };
        let p = plan(&robot, &task, &s, &nlp).unwrap();
        assert!(p.converged(), "#{}: {:?}", i + 1, p.failure_message());
        let g = p.guess.as_ref().unwrap();
        // the smooth step is solved first; #13 needs a detour seed or the continuation only if that
        // solve fails
        if strategy == GuessStrategy::SmoothStep {
            assert_eq!(g.strategy, strategy, "#{}", i + 1);
        }
        if g.strategy == GuessStrategy::Detour {
            assert!(g.seeds.iter().any(|s| s.converged == Some(true)), "{g:?}");
        }
        assert_eq!(g.smooth_step_clear, strategy == GuessStrategy::SmoothStep);
        // the plan's counts are the totals over every solve
        assert_eq!((p.iterations, p.attempts), (g.iterations, g.solves));
        assert!(p.iterations > 0 && g.solve_time_s == p.solve_time_s);
        // and every solve is listed, the smooth step's first
        assert_eq!(solve_log::audit(&p), Vec::<String>::new());
        assert_eq!((p.solves[0].role, p.solves[0].solve), (SolveRole::Task, 0));
        if g.strategy == GuessStrategy::Continuation {
            assert!(g.solves >= 2 && g.scales[0] == 0.0 && *g.scales.last().unwrap() == 1.0);
        }
        assert!(p.violations.clearance <= 1e-8, "{:?}", p.violations);
        assert!(p.min_obstacle_clearance_m.unwrap() > -1e-3);
        assert!(p.blockage.is_none() && p.failure_message().is_none());
    }
}

#[test]
fn the_diagnosis_names_the_link_the_obstacle_blocks() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (base, places) = swing_and_placements(&robot, &s, &nlp);
    let pl = places[0];
    let task = with_obstacle(&pl);
    // the unobstructed swing as the attempt: its link sweeps through the centre at t
    let last = base.points.q(base.points.len() - 1).to_vec();
    let b = diagnose(&robot, &task, &s, &base.points, Some(&last))
        .unwrap()
        .unwrap();
    assert_eq!((b.link, b.obstacle), (pl.link, 0), "{b:?}");
    // the centre on the link: violated by the obstacle radius, the link radius and the margin
    assert!((b.violation_m - (0.08 + 0.02 + 0.01)).abs() < 0.01, "{b:?}");
    assert!((b.time_s - pl.time_s).abs() < 0.05, "{b:?} vs {pl:?}");
    assert_eq!(
        (b.start_overlaps, b.final_pose_overlaps, b.bar_overlaps),
        (false, Some(false), false)
    );
    let msg = b.to_string();
    assert!(
        msg.contains(&format!("obstacle 0 blocks link {}", pl.link + 1)),
        "{msg}"
    );
    // every link's closest approach to the obstacle, with its time, against a brute-force scan
    assert_eq!(b.clearances.len(), robot.n(), "{b:?}");
    let cf = ClearanceFn::new(robot.clone(), &task.obstacles[..], 0.0)
        .unwrap()
        .with_self_collision(false);
    let mut d = vec![0.0; robot.n()];
    for (link, c) in b.clearances.iter().enumerate() {
        assert_eq!((c.obstacle, c.link), (0, link));
        let (mut best, mut at) = (f64::INFINITY, 0.0);
        for k in 0..base.points.len() {
            cf.surface_distances(base.points.q(k), &mut d);
            if d[link] < best {
                (best, at) = (d[link], base.points.t[k]);
            }
        }
        assert_eq!((c.min_clearance_m, c.time_s), (best, at), "{c:?}");
        assert_eq!(c.violated, best < s.obstacle_margin);
    }
    let blocked = &b.clearances[pl.link];
    assert!(blocked.violated && blocked.time_s == b.time_s);
    assert!((b.violation_m - (s.obstacle_margin - blocked.min_clearance_m)).abs() < 1e-15);
    // the links above the grip's first link clear it: link 1 never comes near
    assert!(!b.clearances[0].violated, "{:?}", b.clearances[0]);
    assert!(!b.infeasible);
    // no obstacle, no diagnosis
    assert!(diagnose(&robot, &tracking(), &s, &base.points, None)
        .unwrap()
        .is_none());
}

#[test]
fn an_obstacle_on_the_swing_s_final_pose_gets_the_seeds_another_pose_that_grasps_the_bar() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (base, _) = swing_and_placements(&robot, &s, &nlp);
    let last = base.points.q(base.points.len() - 1).to_vec();
    // an obstacle on the middle of link 2 of the final pose: that pose overlaps it
    let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
    robot.link_segments(&last, &mut segs);
    let (a, b) = segs[1];
    let o = brachia::model::Circle {
        center: [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])],
        radius: 0.05,
    };
    let need = s.obstacle_margin + EXTRA_CLEARANCE;
    let cf = ClearanceFn::new(robot.clone(), vec![o], 0.0)
        .unwrap()
        .with_self_collision(true);
    assert!(cf.min_clearance(&last) < 0.0);
    let q = clear_final_pose(&robot, &[o], &s, &last, [0.8, 0.0])
        .unwrap()
        .expect("a clear pose");
    // it grasps the bar, clears the obstacle and the other links, and stays in the bounds
    let ee = robot.ee_position(&q);
    assert!((ee[0] - 0.8).hypot(ee[1]) < 1e-6, "{ee:?}");
    assert!(cf.min_clearance(&q) >= need, "{}", cf.min_clearance(&q));
    let bq = &s.bounds;
    assert!(q[0] >= bq.q1[0] && q[0] <= bq.q1[1], "{q:?}");
    assert!(q[1..].iter().all(|v| v.abs() <= bq.q_rel_max), "{q:?}");
    // a final pose that already clears the obstacles is kept
    let far = brachia::model::Circle {
        center: [0.0, 2.0],
        radius: 0.05,
    };
    assert!(clear_final_pose(&robot, &[far], &s, &last, [0.8, 0.0])
        .unwrap()
        .is_none());
    // the seeds' obstacle-free swing ends there, the rest of it unchanged
    let moved = with_final_pose(&base.points, &q);
    let k = moved.len() - 1;
    assert_eq!(moved.q(k), q.as_slice());
    assert_eq!(moved.q(k - 1), base.points.q(k - 1));
}

#[test]
fn detour_seeds_go_around_obstacles_the_unobstructed_swing_sweeps() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (base, places) = swing_and_placements(&robot, &s, &nlp);
    let len = base.points.len();
    let b = &s.bounds;
    // #1, #2, #4, #8: links 2 and 3 sweep through the obstacle's centre
    for i in [0, 1, 3, 7] {
        let obstacles = [places[i].obstacle];
        let seeds = detour_seeds(&robot, &obstacles, &s, &base.points).unwrap();
        assert!(seeds.len() >= 2, "#{}: {} seeds", i + 1, seeds.len());
        let cf = ClearanceFn::new(robot.clone(), &obstacles[..], 0.0).unwrap();
        // the measured order: forward-fold, forward, backward-fold, backward
        let kinds: Vec<SeedKind> = seeds.iter().map(|(r, _)| r.kind).collect();
        let rank = |k: &SeedKind| {
            [
                SeedKind::ForwardFold,
                SeedKind::Forward,
                SeedKind::BackwardFold,
                SeedKind::Backward,
            ]
            .iter()
            .position(|x| x == k)
        };
        assert!(
            kinds.windows(2).all(|w| rank(&w[0]) < rank(&w[1])),
            "{kinds:?}"
        );
        for (r, g) in &seeds {
            assert_eq!(g.t, base.points.t);
            // every knot clear of the obstacle and of the other links by margin + extra clearance
            let worst = (0..len)
                .map(|k| cf.min_clearance(g.q(k)))
                .fold(f64::INFINITY, f64::min);
            assert!(
                worst >= s.obstacle_margin + EXTRA_CLEARANCE - 1e-9,
                "#{} {:?}: {worst}",
                i + 1,
                r.kind
            );
            assert!((r.min_clearance_m - (worst - s.obstacle_margin)).abs() < 1e-12);
            for k in 0..len {
                let q = g.q(k);
                assert!(q[0] >= b.q1[0] - 1e-3 && q[0] <= b.q1[1] + 1e-3);
                assert!(q[1..].iter().all(|v| v.abs() <= b.q_rel_max + 1e-3));
            }
            // a seed starts where its tracking started (the start pose, or the final pose), moved
            // only by the barrier's push off the bounds and obstacles
            let (k, want) = match r.kind {
                SeedKind::Forward | SeedKind::ForwardFold => (0, base.points.q(0)),
                SeedKind::Backward | SeedKind::BackwardFold => (len - 1, base.points.q(len - 1)),
            };
            let off = g
                .q(k)
                .iter()
                .zip(want)
                .fold(0.0f64, |m, (a, w)| m.max((a - w).abs()));
            assert!(off < 5e-3, "#{} {:?}: {off}", i + 1, r.kind);
            assert!(r.converged.is_none());
        }
        // not the unobstructed swing: that one cuts through the obstacle
        let through = (0..len)
            .map(|k| cf.min_clearance(base.points.q(k)))
            .fold(f64::INFINITY, f64::min);
        assert!(through < -0.09, "#{}: {through}", i + 1);
        // two seeds that differ: the chain goes around the obstacle in more than one way
        let (a, c) = (&seeds[0].1, &seeds[1].1);
        let diff =
            a.q.iter()
                .zip(&c.q)
                .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(diff > 0.1, "#{}: {diff}", i + 1);
    }
    // no obstacles, no seeds
    assert!(detour_seeds(&robot, &[], &s, &base.points)
        .unwrap()
        .is_empty());
}

#[test]
fn a_detour_seed_plans_around_an_obstacle_the_swing_sweeps() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (_, places) = swing_and_placements(&robot, &s, &nlp);
    // #19 of the scan: link 4 at 1.73 s; the smooth step's solve fails, the continuation never
    // converged here (docs/planner.md), the forward-fold detour seed does
    let pl = places[18];
    let task = with_obstacle(&pl);
    let p = plan(&robot, &task, &s, &nlp).unwrap();
    assert!(p.converged(), "{:?}", p.failure_message());
    let g = p.guess.as_ref().unwrap();
    assert_eq!(g.strategy, GuessStrategy::Detour, "{g:?}");
    assert!(!g.smooth_step_clear && g.scales.is_empty());
    let won: Vec<_> = g
        .seeds
        .iter()
        .filter(|r| r.converged == Some(true))
        .collect();
    assert_eq!(won.len(), 1, "{g:?}");
    // the seeds run two at a time in their order: one after the winner can have started only
    // once one before it had failed, and the race ended with the winner (the others cut short:
    // not concluded)
    let at = g
        .seeds
        .iter()
        .position(|r| r.converged == Some(true))
        .unwrap();
    let failed_before = g.seeds[..at]
        .iter()
        .filter(|r| r.converged == Some(false))
        .count();
    assert!(g.seeds[at + 1..].iter().all(|r| r.converged.is_none()));
    let started_after = (at + 1..g.seeds.len())
        .filter(|k| {
            p.solves
                .iter()
                .any(|a| a.role == SolveRole::DetourSeed { index: *k })
        })
        .count();
    assert!(started_after <= failed_before, "{g:?}");
    assert_eq!((p.iterations, p.attempts), (g.iterations, g.solves));
    // the adopted attempt is the winning seed's (or its solve again from the seed), after the smooth
    // step, the obstacle-free plan and the failed seeds
    assert_eq!(solve_log::audit(&p), Vec::<String>::new());
    let adopted = p.solves.iter().find(|a| a.adopted).unwrap();
    assert!(
        adopted.role == SolveRole::DetourSeed { index: at } || adopted.role == SolveRole::FromSeed,
        "{:?}",
        adopted.role
    );
    assert!(p.solves.iter().any(|a| a.role == SolveRole::ObstacleFree));
    assert!(p.violations.clearance <= 1e-8, "{:?}", p.violations);
    assert!(p.min_obstacle_clearance_m.unwrap() > -1e-3);
    assert!(p.blockage.is_none());
}

#[test]
fn an_obstacle_on_the_bar_is_refused_before_any_solve() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    // the obstacle's surface is 0.01 m below the bar (the target is not inside it): the last link,
    // which ends at the bar, needs its radius 0.02 m plus the margin 0.01 m
    let o = brachia::model::Circle {
        center: [0.8, -0.09],
        radius: 0.08,
    };
    let task = SwingTask {
        obstacles: vec![o],
        ..tracking()
    };
    assert_eq!(
        brachia::planning::strategy::obstacles::obstacle_on_bar(&robot, &task, s.obstacle_margin),
        Some(0)
    );
    let e = plan(&robot, &task, &s, &nlp).unwrap_err().to_string();
    assert!(
        e.contains("obstacles[0]") && e.contains("no pose that grasps the bar clears it"),
        "{e}"
    );
    // the same task without the obstacle on the bar is not refused as infeasible
    let ok = SwingTask {
        obstacles: vec![brachia::model::Circle {
            center: [0.8, -0.2],
            radius: 0.08,
        }],
        ..tracking()
    };
    assert_eq!(
        brachia::planning::strategy::obstacles::obstacle_on_bar(&robot, &ok, s.obstacle_margin),
        None
    );
    brachia::planning::validate_task(&robot, &ok, &s, "task", "").unwrap();
}

#[test]
fn the_cspace_seed_is_collision_free_at_its_knots_and_ends_at_the_swing_s_poses() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (base, places) = swing_and_placements(&robot, &s, &nlp);
    let len = base.points.len();
    // #4 of the scan: link 2 at 0.74 s, no detour seed converged there (docs/planner.md)
    let obstacles = [places[3].obstacle];
    let (rep, seed) = cspace_seed(&robot, &obstacles, &s, &base.points).unwrap();
    let g = seed.unwrap_or_else(|| panic!("no seed: {rep:?}"));
    assert!(
        rep.found && !rep.exhausted && rep.converged.is_none(),
        "{rep:?}"
    );
    assert!(rep.grid_cells <= MAX_CELLS && rep.cells_discovered <= MAX_DISCOVERED);
    assert!(
        rep.waypoints >= 3 && rep.waypoints <= rep.grid_moves + 3,
        "{rep:?}"
    );
    assert_eq!(g.t, base.points.t);
    // every knot clear of the obstacle and of the non-adjacent links by the planner's margin
    let cf = ClearanceFn::new(robot.clone(), obstacles.to_vec(), 0.0)
        .unwrap()
        .with_self_collision(true);
    let worst = (0..len)
        .map(|k| cf.min_clearance(g.q(k)))
        .fold(f64::INFINITY, f64::min);
    assert!(worst >= s.obstacle_margin, "{worst}");
    assert!(rep.min_clearance_m >= 0.0 && worst - s.obstacle_margin >= rep.min_clearance_m - 1e-12);
    // the unobstructed swing cuts through the obstacle, the seed does not
    let through = (0..len)
        .map(|k| cf.min_clearance(base.points.q(k)))
        .fold(f64::INFINITY, f64::min);
    assert!(through < -0.09, "{through}");
    // at rest at the start pose and at the obstacle-free swing's final pose (at the bar)
    for (k, want) in [(0, base.points.q(0)), (len - 1, base.points.q(len - 1))] {
        assert_eq!(g.q(k), want);
        assert!(g.qd(k).iter().all(|v| v.abs() < 1e-12), "{:?}", g.qd(k));
    }
    // inside the joint bounds, and no joint faster than the report says
    let b = &s.bounds;
    for k in 0..len {
        let q = g.q(k);
        assert!(q[0] >= b.q1[0] && q[0] <= b.q1[1], "{q:?}");
        assert!(q[1..].iter().all(|v| v.abs() <= b.q_rel_max), "{q:?}");
        assert!(g
            .qd(k)
            .iter()
            .all(|v| v.abs() <= rep.max_speed_rad_s + 1e-9));
    }
    // no obstacle, no search
    let (none, g) = cspace_seed(&robot, &[], &s, &base.points).unwrap();
    assert!(g.is_none() && !none.found && none.cells_discovered == 0);
}

#[test]
fn the_cspace_search_reports_a_blocked_configuration_space_as_exhausted() {
    let robot = Robot::paper();
    let (s, _) = settings();
    // two small obstacles on either side of link 1 of the start pose (0.1 m off its axis at its
    // midpoint): link 1 cannot turn more than about 0.1 rad either way, so no path reaches a pose at
    // the bar, while both end poses are clear
    let th = -2.35f64;
    let (u, v) = ([th.cos(), th.sin()], [-th.sin(), th.cos()]);
    let mid = 0.5 * robot.lengths()[0];
    let fence: Vec<brachia::model::Circle> = [-1.0, 1.0]
        .iter()
        .map(|side| brachia::model::Circle {
            center: [
                mid * u[0] + side * 0.1 * v[0],
                mid * u[1] + side * 0.1 * v[1],
            ],
            radius: 0.03,
        })
        .collect();
    let start = tracking().q0;
    // the pose reaching (0.8, 0) found by IK from the mirrored start pose
    let goal =
        brachia::model::ik_from_seed(&robot, &brachia::model::mirrored_pose(&start), [0.8, 0.0])
            .unwrap();
    let (rep, path) = cspace_path(&robot, &fence, &s, &start, &goal).unwrap();
    assert!(rep.endpoints_clear, "{rep:?}");
    assert!(path.is_none() && !rep.found && rep.exhausted, "{rep:?}");
    assert!(rep.cells_discovered > 1 && rep.cells_discovered < MAX_DISCOVERED);
    // without the wall the same search finds a path that ends at the goal pose
    let (rep, path) = cspace_path(&robot, &[], &s, &start, &goal).unwrap();
    let path = path.unwrap();
    assert!(rep.found && path.first().unwrap() == &start && path.last().unwrap() == &goal);
}

#[test]
fn the_cspace_seed_plans_a_placement_no_detour_seed_converged_on() {
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (base, places) = swing_and_placements(&robot, &s, &nlp);
    // #18 of the scan: link 3 at 1.73 s; every detour seed and the continuation ended
    // LocallyInfeasible (docs/planner.md), the planner tries the C-space seed after them. Planned here
    // from that seed directly (the planner's whole sequence takes minutes at 10 ms knots)
    let pl = places[17];
    let task = with_obstacle(&pl);
    let (rep, seed) = cspace_seed(&robot, &task.obstacles, &s, &base.points).unwrap();
    let seed = seed.unwrap_or_else(|| panic!("no seed: {rep:?}"));
    let p = brachia::planning::plan_with_guess(&robot, &task, &s, &nlp, Some(&seed)).unwrap();
    assert!(p.converged(), "{:?} {:?}", p.status, p.violations);
    assert!(p.violations.clearance <= 1e-8, "{:?}", p.violations);
    assert!(p.min_obstacle_clearance_m.unwrap() > -1e-3);
    // it reaches the bar at rest, and the obstacle is passed, not ignored: the plan's links come
    // no closer to it than the margin at the knots
    let cf = ClearanceFn::new(robot.clone(), task.obstacles.clone(), 0.0)
        .unwrap()
        .with_self_collision(false);
    let worst = (0..p.points.len())
        .map(|k| cf.min_clearance(p.points.q(k)))
        .fold(f64::INFINITY, f64::min);
    assert!(worst >= s.obstacle_margin - 1e-6, "{worst}");
    let ee = p.ee_final;
    assert!((ee[0] - 0.8).hypot(ee[1]) < 1e-6, "{ee:?}");
}

/// #18 of the scan (link 3 at 1.73 s on the 10 ms swing), a failure of every detour seed, on the
/// planner's default mesh (30 ms knots: the whole strategy chain in a few seconds): the robot, the
/// task and the settings.
fn every_detour_seed_fails() -> (Robot, SwingTask, PlannerSettings, NlpSettings) {
    let robot = Robot::paper();
    let (mut s, nlp) = settings();
    let (_, places) = swing_and_placements(&robot, &s, &nlp);
    // 30 ms knots with 3 RK4 steps each (the default mesh): a solve whose 1 ms trajectory dips
    // into the margin between the knots is refined with the sub-step rows
    s.knot_dt = 0.03;
    s.shooting.substeps = 3;
    let task = with_obstacle(&places[17]);
    (robot, task, s, nlp)
}

#[test]
fn the_planner_falls_back_to_the_cspace_seed_when_every_detour_seed_fails() {
    let (robot, task, s, nlp) = every_detour_seed_fails();
    let p = plan(&robot, &task, &s, &nlp).unwrap();
    assert!(p.converged(), "{:?}", p.failure_message());
    let g = p.guess.as_ref().unwrap();
    assert_eq!(g.strategy, GuessStrategy::Cspace, "{g:?}");
    // no detour seed converged (each failed, or was cut short when the C-space seed won)
    assert!(!g.seeds.is_empty(), "{g:?}");
    assert!(g.seeds.iter().all(|r| r.converged != Some(true)), "{g:?}");
    let c = g.cspace.as_ref().unwrap();
    assert!(c.found && c.converged == Some(true), "{c:?}");
    assert!(g.scales.is_empty(), "{g:?}");
    // the smooth step, the obstacle-free plan, each detour seed, the C-space seed (and resumes)
    assert!(g.solves >= 3 + g.seeds.len(), "{g:?}");
    assert_eq!((p.iterations, p.attempts), (g.iterations, g.solves));
    assert_eq!(solve_log::audit(&p), Vec::<String>::new());
    assert!(p.violations.clearance <= 1e-8, "{:?}", p.violations);
    assert!(p.min_obstacle_clearance_m.unwrap() > -1e-3);
    assert!(p.blockage.is_none());
    // the seed's own solve converged: the actuator-limit continuation was not needed
    assert_eq!(c.relaxed_converged, None, "{c:?}");
}

#[test]
fn the_obstacle_strategies_share_the_time_limit() {
    // the placement of the C-space fallback above: the smooth step, the obstacle-free plan and every
    // detour seed fail or run before the seed that converges
    let (robot, task, s, nlp) = every_detour_seed_fails();
    let full = plan(&robot, &task, &s, &nlp).unwrap();
    assert!(full.converged());
    let g = full.guess.as_ref().unwrap();
    assert!(!g.out_of_time, "{g:?}");
    // a limit of 0.4 of what the chain's first solve (the smooth step) took, a small part of the
    // chain: the strategies stop early and say why. With the whole first solve's time, a quieter
    // machine during the limited call leaves time for later strategies, which may then plan.
    let first: f64 = full
        .solves
        .iter()
        .filter(|a| a.solve == 0)
        .map(|a| a.time_s)
        .sum();
    let limit = 0.4 * first;
    let short = NlpSettings {
        max_wall_time_s: Some(limit),
        ..nlp.clone()
    };
    let p = plan(&robot, &task, &s, &short).unwrap();
    eprintln!(
        "full {} s, {} solves; limited {} s, {} solves",
        full.solve_time_s, full.attempts, p.solve_time_s, p.attempts
    );
    assert!(!p.converged(), "{:?}", p.guess);
    let g = p.guess.as_ref().unwrap();
    assert!(g.out_of_time, "{g:?}");
    let why = p.failure_message().unwrap();
    assert!(why.contains("max_wall_time_s"), "{why}");
    assert!(
        p.attempts < full.attempts,
        "{} {}",
        p.attempts,
        full.attempts
    );
    assert_eq!(solve_log::audit(&p), Vec::<String>::new());
    // a backend checks the limit between iterations: the solves together overrun it by at most an
    // iteration each (a few ms on this 30 ms mesh), far less than the chain's own time
    assert!(
        p.solve_time_s < limit + 0.5 * (full.solve_time_s - limit),
        "{} {limit}",
        p.solve_time_s
    );
}

#[test]
fn the_homotopy_seeds_are_distinct_clear_routes_to_poses_at_the_bar_ranked_by_torque() {
    use brachia::planning::strategy::cspace::SAME_ROUTE_RAD;
    use brachia::planning::strategy::homotopy::{homotopy_routes, MAX_GOALS, ROUTES_PER_GOAL};
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (base, places) = swing_and_placements(&robot, &s, &nlp);
    // #4 of the scan: link 2 swept at 0.74 s
    let obstacles = [places[3].obstacle];
    let ranked =
        homotopy_routes(&robot, &obstacles, &s, &base.points, [0.8, 0.0], &|| false).unwrap();
    let reports = ranked.reports;
    let seeds: Vec<(usize, _)> = ranked
        .seeds
        .into_iter()
        .map(|r| (r.report, r.guess))
        .collect();
    assert!(seeds.len() >= 2, "{reports:?}");
    assert!(reports.len() <= MAX_GOALS * ROUTES_PER_GOAL, "{reports:?}");
    let cf = ClearanceFn::new(robot.clone(), obstacles.to_vec(), 0.0)
        .unwrap()
        .with_self_collision(true);
    let len = base.points.len();
    for (i, g) in &seeds {
        let r = &reports[*i];
        assert!(r.found && !r.stopped && r.peak_torque_ratio > 0.0, "{r:?}");
        // clear at every knot, from the start pose to a pose that grasps the bar
        let worst = (0..len)
            .map(|k| cf.min_clearance(g.q(k)))
            .fold(f64::INFINITY, f64::min);
        assert!(worst >= s.obstacle_margin, "{worst}");
        assert_eq!(g.q(0), base.points.q(0));
        let ee = robot.ee_position(g.q(len - 1));
        assert!((ee[0] - 0.8).hypot(ee[1]) < 1e-6, "{ee:?}");
    }
    // ranked by the torque ratio, lowest first
    for w in seeds.windows(2) {
        assert!(reports[w[0].0].peak_torque_ratio <= reports[w[1].0].peak_torque_ratio);
    }
    // no two seeds follow the same route: they differ somewhere by more than SAME_ROUTE_RAD
    for (a, (_, ga)) in seeds.iter().enumerate() {
        for (_, gb) in &seeds[a + 1..] {
            let apart =
                ga.q.iter()
                    .zip(&gb.q)
                    .any(|(x, y)| (x - y).abs() > SAME_ROUTE_RAD);
            assert!(apart, "two seeds on one route");
        }
    }
}

#[test]
fn a_configuration_space_search_told_to_stop_ends_within_one_check() {
    use brachia::planning::strategy::cspace::{cspace_routes, STOP_CHECK_CELLS};
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let (base, places) = swing_and_placements(&robot, &s, &nlp);
    let obstacles = [places[3].obstacle];
    let (q0, q1) = (base.points.q(0), base.points.q(base.points.len() - 1));
    let runs = cspace_routes(&robot, &obstacles, &s, q0, q1, 3, &|| true).unwrap();
    // one search, ended at its first check: no path, not exhausted, no other route searched
    assert_eq!(runs.len(), 1);
    let (r, path) = &runs[0];
    assert!(
        path.is_none() && r.stopped && !r.found && !r.exhausted,
        "{r:?}"
    );
    assert!(r.cells_discovered <= STOP_CHECK_CELLS, "{r:?}");
    // the same search left alone finds a route
    let runs = cspace_routes(&robot, &obstacles, &s, q0, q1, 1, &|| false).unwrap();
    assert!(runs[0].1.is_some() && !runs[0].0.stopped, "{:?}", runs[0].0);
}

#[test]
fn the_clear_final_poses_are_one_per_elbow_family_nearest_first() {
    use brachia::planning::strategy::goal::clear_final_poses;
    let robot = Robot::paper();
    let (s, nlp) = settings();
    let base = plan(&robot, &tracking(), &s, &nlp).unwrap();
    let last = base.points.q(base.points.len() - 1).to_vec();
    let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
    robot.link_segments(&last, &mut segs);
    let (a, b) = segs[1];
    let o = brachia::model::Circle {
        center: [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])],
        radius: 0.05,
    };
    let poses = clear_final_poses(&robot, &[o], &s, &last, [0.8, 0.0], 4, &|| false).unwrap();
    assert!(poses.len() >= 2, "{poses:?}");
    let first = clear_final_pose(&robot, &[o], &s, &last, [0.8, 0.0])
        .unwrap()
        .unwrap();
    assert_eq!(poses[0], first);
    let need = s.obstacle_margin + EXTRA_CLEARANCE;
    let cf = ClearanceFn::new(robot.clone(), vec![o], 0.0)
        .unwrap()
        .with_self_collision(true);
    let family = |q: &[f64]| q[1..].iter().map(|v| *v >= 0.0).collect::<Vec<_>>();
    let dist = |q: &[f64]| -> f64 { q.iter().zip(&last).map(|(x, y)| (x - y).powi(2)).sum() };
    for (i, q) in poses.iter().enumerate() {
        let ee = robot.ee_position(q);
        assert!((ee[0] - 0.8).hypot(ee[1]) < 1e-6, "{ee:?}");
        assert!(cf.min_clearance(q) >= need);
        for p in &poses[i + 1..] {
            assert_ne!(family(q), family(p));
            assert!(dist(q) <= dist(p));
        }
    }
    // asked to stop at once: nothing searched
    assert!(
        clear_final_poses(&robot, &[o], &s, &last, [0.8, 0.0], 4, &|| true)
            .unwrap()
            .is_empty()
    );
}
