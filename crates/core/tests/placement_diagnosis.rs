//! The diagnosis of an obstacle placement that does not plan (`Plan::diagnosis`): it names the
//! obstacle and the link it blocks, and what the best detour found would need; a placement that plans
//! gets none. Units: m, s, N m.

use brachia::model::Circle;
use brachia::planning::{plan, NlpSettings, ObstacleGuess, PlannerSettings, SwingTask, Verdict};
use brachia::Robot;

/// An obstacle above the bars, away from every pose of the paper's swing (which hangs below them).
fn aside() -> Circle {
    Circle {
        center: [-0.6, 0.3],
        radius: 0.05,
    }
}

/// An obstacle whose surface is 0.01 m below the target bar holds the grasp: the last link, which ends
/// at the bar, cannot reach it past the obstacle, whatever the torque or the swing time. The task
/// check refuses it before any solve, naming that obstacle (the second of two).
#[test]
fn an_obstacle_holding_the_target_bar_is_refused_before_any_solve() {
    let robot = Robot::paper();
    let task = SwingTask {
        obstacles: vec![
            aside(),
            Circle {
                center: [0.8, -0.09],
                radius: 0.08,
            },
        ],
        ..SwingTask::paper()
    };
    let e = plan(
        &robot,
        &task,
        &PlannerSettings::default(),
        &NlpSettings::default(),
    )
    .unwrap_err()
    .to_string();
    assert!(
        e.contains("obstacles[1]") && e.contains("no pose that grasps the bar clears it"),
        "{e}"
    );
}

/// An obstacle 0.005 m from link 1 of the start pose (inside the 0.01 m margin, not overlapping it):
/// no motion clears it. The diagnosis names that obstacle (the second of two) and link 1, and probes
/// nothing.
#[test]
fn an_obstacle_within_the_margin_of_the_start_pose_is_unreachable() {
    let robot = Robot::paper();
    let q0 = &SwingTask::paper().q0;
    let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
    robot.link_segments(q0, &mut segs);
    let (a, b) = segs[0];
    // off link 1's midpoint, square to the link, on its lower side
    let (len, radius) = (robot.lengths()[0], 0.05);
    let normal = [(b[1] - a[1]) / len, -(b[0] - a[0]) / len];
    let off = robot.radii()[0] + 0.005 + radius;
    let at_start = Circle {
        center: [
            0.5 * (a[0] + b[0]) + off * normal[0],
            0.5 * (a[1] + b[1]) + off * normal[1],
        ],
        radius,
    };
    let task = SwingTask {
        obstacles: vec![aside(), at_start],
        ..SwingTask::paper()
    };
    let nlp = NlpSettings {
        max_iter: 40,
        max_wall_time_s: Some(5.0),
        ..Default::default()
    };
    let p = plan(&robot, &task, &PlannerSettings::default(), &nlp).unwrap();
    assert!(!p.converged());
    let d = p.diagnosis.as_ref().expect("a diagnosis");
    assert_eq!(d.verdict, Verdict::Unreachable, "{d:?}");
    assert_eq!((d.obstacle, d.link), (1, 0), "{d:?}");
    assert!(d.torque_probe.is_none() && d.swing_time_probe.is_none() && d.solves == 0);
    let msg = p.failure_message().unwrap();
    assert!(
        msg.contains("obstacle 1 blocks link 1 where it must pass")
            && msg.contains("no torque or swing time clears it"),
        "{msg}"
    );
}

/// An obstacle on the unobstructed swing's path (link 3, a quarter along it, at 0.86 T), which the
/// planner plans around with the clearance row active: no diagnosis.
#[test]
fn a_placement_that_plans_gets_no_diagnosis() {
    let robot = Robot::paper();
    let (s, nlp) = (PlannerSettings::default(), NlpSettings::default());
    let free = plan(&robot, &SwingTask::paper(), &s, &nlp).unwrap();
    let (k, _) = free.trajectory.locate(0.86 * free.swing_time_s);
    let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
    robot.link_segments(free.trajectory.q(k), &mut segs);
    let (a, b) = segs[2];
    let on_path = Circle {
        center: [a[0] + 0.25 * (b[0] - a[0]), a[1] + 0.25 * (b[1] - a[1])],
        radius: 0.086,
    };
    let task = SwingTask {
        obstacles: vec![aside(), on_path],
        ..SwingTask::paper()
    };
    let p = plan(&robot, &task, &s, &nlp).unwrap();
    assert!(p.converged(), "{:?}", p.failure_message());
    // the obstacle on the path shaped the plan: the clearance is at the margin
    let c = p.min_obstacle_clearance_m.unwrap();
    assert!(c < s.obstacle_margin + 2e-3, "{c}");
    assert!(p.diagnosis.is_none() && p.blockage.is_none());
}

/// An obstacle of 0.08 m at link 2's midpoint at 0.3 T of the unobstructed swing: the swing sweeps
/// it, and the smooth step's solve (the direct guess: one solve) fails. The time limit is wide, so
/// that the probe's solves end on their iteration limit, not on the clock. The torque probe plans a
/// detour with the limits widened 8x; the diagnosis names that obstacle (the second of two), a link
/// that sweeps it, and the peak torque the detour needs against the 5 N m limits.
#[test]
fn a_swept_obstacle_is_diagnosed_with_the_torque_its_detour_needs() {
    let robot = Robot::paper();
    let nlp = NlpSettings {
        max_wall_time_s: Some(600.0),
        ..Default::default()
    };
    let free = plan(
        &robot,
        &SwingTask::paper(),
        &PlannerSettings::default(),
        &nlp,
    )
    .unwrap();
    let (k, _) = free.trajectory.locate(0.3 * free.swing_time_s);
    let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
    robot.link_segments(free.trajectory.q(k), &mut segs);
    let (a, b) = segs[1];
    let swept = Circle {
        center: [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])],
        radius: 0.08,
    };
    let task = SwingTask {
        obstacles: vec![aside(), swept],
        ..SwingTask::paper()
    };
    let s = PlannerSettings {
        obstacle_guess: ObstacleGuess::Direct,
        ..Default::default()
    };
    let p = plan(&robot, &task, &s, &nlp).unwrap();
    assert!(!p.converged());
    let d = p.diagnosis.as_ref().expect("a diagnosis");
    assert_eq!(d.obstacle, 1, "{d:?}");
    // link 2 sweeps its centre; link 3, behind it, sweeps it too
    assert!(d.link == 1 || d.link == 2, "{d:?}");
    let tp = d.torque_probe.as_ref().expect("a torque probe");
    assert!(tp.converged, "{d:?}");
    assert!(
        matches!(d.verdict, Verdict::NeedsTorque | Verdict::NeedsSwingTime),
        "{d:?}"
    );
    let (j, r) = tp.worst_joint().unwrap();
    assert!(r > 1.0 && tp.peak_torque_nm[j] > tp.limit_nm[j], "{tp:?}");
    assert_eq!(tp.limit_nm, vec![5.0; 3]);
    let msg = p.failure_message().unwrap();
    assert!(
        msg.contains("obstacle 1 blocks link") && msg.contains("x its limit 5 N m"),
        "{msg}"
    );
}
