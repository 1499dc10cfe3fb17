//! Swing times over the two-, three-, four- and six-link robots (params/): every robot from two start
//! poses (hanging straight; the rear hand on the previous bar, as after a swing), to the next bar, at
//! `swing_time = "auto"` and at fixed swing times on a grid. The default planner (multiple shooting,
//! 30 ms knots, the Riccati backend).
//!
//! The fast tests plan `"auto"` on every robot and start pose and check the account of a swing time
//! that does not plan. The whole scan (every robot, pose, bar spacing and swing time, with a held-out
//! set of spacings and grid points that no constant of the search was chosen on) is ignored by
//! default and prints the table of docs/planner.md ("Swing times that do not plan"):
//!
//! ```text
//! cargo test --release -p brachia --test swing_time_scan -- --ignored --nocapture
//! ```

use brachia::model::ik_from_seed;
use brachia::planning::{plan, NlpSettings, Plan, PlannerSettings, SwingTask, SwingTime};
use brachia::Robot;
use std::f64::consts::FRAC_PI_2;
use std::time::Instant;

/// A robot of the scan: its name, its parameters and the bar spacings it swings across (m; the
/// second one held out).
struct ScanRobot {
    name: &'static str,
    robot: Robot,
    spacings: [f64; 2],
}

fn params(file: &str) -> Robot {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../params")
        .join(file);
    Robot::from_toml_file(&p).unwrap()
}

fn robots() -> Vec<ScanRobot> {
    vec![
        ScanRobot {
            name: "two-link-hook",
            robot: params("two-link-hook.toml"),
            spacings: [0.34, 0.30],
        },
        ScanRobot {
            name: "three-link",
            robot: params("three-link.toml"),
            spacings: [0.8, 0.7],
        },
        ScanRobot {
            name: "paper (four-link)",
            robot: Robot::paper(),
            spacings: [0.8, 0.7],
        },
        ScanRobot {
            name: "six-link",
            robot: params("six-link.toml"),
            spacings: [0.7, 0.6],
        },
    ]
}

/// The start poses of the scan for bars `d` apart: hanging straight, and the rear hand on the
/// previous bar at (-d, 0) with the chain below the bars (inverse kinematics from a pose bent
/// back).
fn start_poses(robot: &Robot, d: f64) -> Vec<(&'static str, Vec<f64>)> {
    let n = robot.n();
    let mut straight = vec![0.0; n];
    straight[0] = -FRAC_PI_2;
    let mut seed = vec![-1.9 / (n - 1) as f64; n];
    seed[0] = -2.2;
    let rear = ik_from_seed(robot, &seed, [-d, 0.0]).expect("the previous bar is in reach");
    assert!(
        rear[0] > -std::f64::consts::PI && rear[0] < 0.0 && rear[1..].iter().all(|q| q.abs() < 2.9),
        "rear-hand pose {rear:?} outside the default bounds"
    );
    vec![("straight hang", straight), ("rear hand on bar", rear)]
}

fn task(q0: &[f64], d: f64) -> SwingTask {
    SwingTask {
        q0: q0.to_vec(),
        qd0: vec![],
        target: [d, 0.0],
        obstacles: vec![],
    }
}

fn plan_at(robot: &Robot, task: &SwingTask, t: SwingTime) -> (Plan, f64) {
    let s = PlannerSettings {
        swing_time: t,
        ..Default::default()
    };
    let c = Instant::now();
    let p = plan(robot, task, &s, &NlpSettings::default()).unwrap();
    (p, c.elapsed().as_secs_f64())
}

/// `swing_time = "auto"` plans on every robot of the scan from both start poses (the straight hang
/// is an equilibrium of the locked chain: the free-fall rule gives no time there, and the planner
/// searches around the locked chain's half period instead).
#[test]
fn auto_swing_time_plans_on_every_robot_and_start_pose() {
    for r in robots() {
        let d = r.spacings[0];
        for (pose, q0) in start_poses(&r.robot, d) {
            let (p, _) = plan_at(&r.robot, &task(&q0, d), SwingTime::default());
            assert!(
                p.converged(),
                "{} from {pose}: {:?}",
                r.name,
                p.failure_message()
            );
            if let Some(s) = &p.swing_time_search {
                // a plan found by the search says so, at the swing time it reports
                assert_eq!(s.planned_s, Some(p.swing_time_s), "{}: {s}", r.name);
            }
            if pose == "straight hang" {
                let s = p
                    .swing_time_search
                    .as_ref()
                    .expect("no rule time: a search");
                assert!(s.rule_failure.is_some() && s.reference_s.is_some(), "{s}");
                assert!(p.freefall_time_s.is_none());
            }
        }
    }
}

/// A swing time that does not plan on the two-link hook robot (rear hand on the previous bar, bars
/// 0.34 m apart, T = 1.0 s) ends not converged, with the search's account: the cold plans tried and
/// the nearest swing times that plan on either side, each a converged plan of the search.
#[test]
fn a_swing_time_that_does_not_plan_names_the_nearest_that_do() {
    let r = &robots()[0];
    let q0 = start_poses(&r.robot, 0.34).remove(1).1;
    let (p, _) = plan_at(&r.robot, &task(&q0, 0.34), SwingTime::Seconds(1.0));
    assert!(!p.converged());
    assert_eq!(p.swing_time_s, 1.0);
    let s = p.swing_time_search.as_ref().expect("the search ran");
    assert_eq!(s.requested_s, Some(1.0));
    assert_eq!(s.planned_s, None);
    let (lo, hi) = s.nearest_planned();
    let hi = hi.expect("a longer swing plans");
    assert!(hi > 1.0 && hi < 1.5, "{s}");
    assert!(lo.is_none_or(|lo| lo < 1.0), "{s}");
    let msg = p.failure_message().unwrap();
    assert!(
        msg.contains("T = 1.000 s did not plan") && msg.contains("nearest swing times that plan"),
        "{msg}"
    );
    // the swing time named above does plan, cold or warm: it was a converged plan of the search
    assert!(s.tried.iter().any(|x| x.converged && x.swing_time_s == hi));
    // the continuation from above stops there, its swing pressing against the elbow's bound and
    // the rate bound as well as the torque limit
    let stop = s.stops.iter().find(|x| x.swing_time_s == hi).expect("{s}");
    assert!(
        stop.torque_use > 0.99 && stop.joints_at_bound == [2],
        "{stop:?}"
    );
    assert!(stop.at_joint_or_rate_bound(), "{stop:?}");
    assert!(
        msg.contains("the continuations in T stop at")
            && msg.contains("joint 2 at its 2.9 rad bound"),
        "{msg}"
    );
}

/// The whole scan: every robot, start pose and bar spacing, `"auto"` and the swing-time grid (the
/// hook robot's 0.80 ..= 1.30 s and held-out points between them, the
/// other robots' multiples of the locked chain's half period). Prints a markdown table.
#[test]
#[ignore = "the whole swing-time scan, several minutes; see the module docs"]
fn swing_time_scan_table() {
    println!(
        "| robot | start | bars m | T s | outcome | planned T s | objective | peak abs(tau) N m | time s |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let (mut auto_ok, mut auto_all, mut grid_ok, mut grid_all) = (0, 0, 0, 0);
    for r in robots() {
        for (si, &d) in r.spacings.iter().enumerate() {
            for (pose, q0) in start_poses(&r.robot, d) {
                let tk = task(&q0, d);
                let mut grid: Vec<(SwingTime, bool)> = vec![(SwingTime::default(), false)];
                if r.name == "two-link-hook" {
                    grid.extend(
                        (0..=10).map(|i| (SwingTime::Seconds(0.80 + 0.05 * i as f64), false)),
                    );
                    grid.extend(
                        [0.825, 0.975, 1.125, 1.275].map(|t| (SwingTime::Seconds(t), true)),
                    );
                } else {
                    let mut straight = vec![0.0; q0.len()];
                    straight[0] = -FRAC_PI_2;
                    let r0 = brachia::planning::reference_swing_time(&r.robot, &straight).unwrap();
                    grid.extend([1.5, 2.0, 2.5, 3.0].map(|k| (SwingTime::Seconds(k * r0), false)));
                    grid.extend([1.75, 2.75].map(|k| (SwingTime::Seconds(k * r0), true)));
                }
                for (t, held) in grid {
                    let (p, secs) = plan_at(&r.robot, &tk, t);
                    let label = match t {
                        SwingTime::Seconds(t) => format!("{t:.3}"),
                        SwingTime::Auto(_) => "auto".into(),
                    };
                    let held_out = held || si == 1;
                    let outcome = if p.converged() {
                        match &p.swing_time_search {
                            Some(_) => "planned (search)".to_string(),
                            None => "planned".to_string(),
                        }
                    } else {
                        let near = p.swing_time_search.as_ref().map(|s| s.nearest_planned());
                        match near {
                            Some((lo, hi)) => format!(
                                "{:?}; nearest planned {} / {}",
                                p.status,
                                lo.map_or("-".into(), |v| format!("{v:.3}")),
                                hi.map_or("-".into(), |v| format!("{v:.3}"))
                            ),
                            None => format!("{:?}", p.status),
                        }
                    };
                    if matches!(t, SwingTime::Auto(_)) {
                        auto_all += 1;
                        auto_ok += usize::from(p.converged());
                    } else {
                        grid_all += 1;
                        grid_ok += usize::from(p.converged());
                    }
                    // objective and peak torque of a converged plan only
                    let (obj, peak) = if p.converged() {
                        let peak = p.points.tau.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                        (format!("{:.4}", p.objective), format!("{peak:.3}"))
                    } else {
                        ("-".to_string(), "-".to_string())
                    };
                    println!(
                        "| {} | {pose} | {d}{} | {label}{} | {outcome} | {} | {obj} | {peak} | {secs:.2} |",
                        r.name,
                        if si == 1 { " (held out)" } else { "" },
                        if held_out && si == 0 {
                            " (held out)"
                        } else {
                            ""
                        },
                        if p.converged() {
                            format!("{:.3}", p.swing_time_s)
                        } else {
                            "-".into()
                        },
                    );
                }
            }
        }
    }
    println!("auto planned {auto_ok} of {auto_all}; grid planned {grid_ok} of {grid_all}");
    assert_eq!(
        auto_ok, auto_all,
        "auto must plan on every robot and start pose"
    );
}

/// The reference of the search without a rule time is the locked chain's half period of small
/// oscillation: a 0.01 rad swing of the locked chain about its straight hang, integrated with RK4
/// from the chain's own mass matrix and gravity, turns back after that time (within 0.1 %).
#[test]
fn the_reference_swing_time_is_the_locked_chains_half_period() {
    for r in robots() {
        let n = r.robot.n();
        let mut q = vec![0.0; n];
        q[0] = -FRAC_PI_2;
        let half = brachia::planning::reference_swing_time(&r.robot, &q).unwrap();
        let m11 = r.robot.mass_matrix(&q)[0];
        let mut ws = brachia::model::Scratch::new(n);
        let mut g = vec![0.0; n];
        let mut acc = |th: f64| {
            let mut qq = q.clone();
            qq[0] = th;
            r.robot.gravity_into(&mut ws, &qq, &mut g);
            -g[0] / m11
        };
        let (dt, mut t, mut th, mut w) = (1e-5, 0.0, -FRAC_PI_2 + 0.01, 0.0);
        loop {
            let (k1t, k1w) = (w, acc(th));
            let (k2t, k2w) = (w + 0.5 * dt * k1w, acc(th + 0.5 * dt * k1t));
            let (k3t, k3w) = (w + 0.5 * dt * k2w, acc(th + 0.5 * dt * k2t));
            let (k4t, k4w) = (w + dt * k3w, acc(th + dt * k3t));
            let w1 = w + dt / 6.0 * (k1w + 2.0 * k2w + 2.0 * k3w + k4w);
            th += dt / 6.0 * (k1t + 2.0 * k2t + 2.0 * k3t + k4t);
            t += dt;
            if t > 0.01 && w1 >= 0.0 && w < 0.0 {
                break;
            }
            w = w1;
        }
        assert!((t - half).abs() < 1e-3 * half, "{}: {t} vs {half}", r.name);
    }
}

/// A free swing time inside the hook robot's band that does not plan (rear hand on the previous
/// bar, `free_swing_time = [0.9, 1.2]`): the free solve fails, the fixed swing times inside the range
/// are tried cold (5, from the middle out), none plans, and the plan says so.
#[test]
fn a_free_swing_time_that_does_not_plan_lists_the_swing_times_tried_in_its_range() {
    let r = &robots()[0];
    let q0 = start_poses(&r.robot, 0.34).remove(1).1;
    let s = PlannerSettings {
        free_swing_time: Some([0.9, 1.2]),
        ..Default::default()
    };
    let p = plan(&r.robot, &task(&q0, 0.34), &s, &NlpSettings::default()).unwrap();
    assert!(!p.converged(), "{:?}", p.status);
    let search = p.swing_time_search.as_ref().expect("the search ran");
    assert_eq!(search.tried.len(), 5, "{search}");
    for x in &search.tried {
        assert!(
            !x.converged && !x.warm && (0.9..=1.2).contains(&x.swing_time_s),
            "{x:?}"
        );
    }
    let msg = p.failure_message().unwrap();
    assert!(msg.contains("the free swing time did not plan"), "{msg}");
}
