//! A link that passes through an obstacle between two checked points is not a converged plan.
//!
//! The clearance rows of multiple shooting hold at the points the solver checks; the swing's end moves
//! several centimetres between two knots 60 ms apart. Here an obstacle sits on the path of the
//! unobstructed tracking swing's end effector halfway between two knots, small enough that every knot
//! of that swing clears it; warm-started from that swing, the solve ends `Solved` at a point whose
//! knots all clear the obstacle while its resampled trajectory goes through it. Such a plan must not
//! be reported converged: its status says the solver converged, its `clearance_violation` names the
//! obstacle, the link, the time and the shortfall. Units: m, s.

use brachia::model::{Circle, ClearanceFn, Robot};
use brachia::planning::{
    check_clearance, plan, plan_with_guess, Backend, ClearanceSubject, NlpSettings, Plan,
    PlannerSettings, ShootingSettings, SwingTask, Transcription, CLEARANCE_TOLERANCE_M,
};

fn nlp() -> NlpSettings {
    NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    }
}

/// Multiple shooting at 60 ms knots with `substeps` RK4 steps per interval.
fn coarse(substeps: usize) -> PlannerSettings {
    PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.06,
        shooting: ShootingSettings {
            substeps,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// The unobstructed swing and an obstacle on its end effector's path between the two knots where it
/// moves fastest, clear of every knot by more than the margin.
fn swing_and_obstacle(s: &PlannerSettings) -> (Plan, Circle) {
    let robot = Robot::paper();
    let free = plan(&robot, &SwingTask::paper(), s, &nlp()).unwrap();
    assert!(free.converged(), "{:?}", free.failure_message());
    let pts = &free.points;
    let ee = |q: &[f64]| robot.ee_position(q);
    // the interval (away from the two ends) where the end effector moves farthest
    let k = (2..pts.len() - 3)
        .max_by(|&a, &b| {
            let d = |k: usize| {
                let (p, q) = (ee(pts.q(k)), ee(pts.q(k + 1)));
                (p[0] - q[0]).hypot(p[1] - q[1])
            };
            d(a).total_cmp(&d(b))
        })
        .unwrap();
    let tr = &free.trajectory;
    let (j, _) = tr.locate(0.5 * (pts.t[k] + pts.t[k + 1]));
    let centre = ee(tr.q(j));
    let mut c = Circle {
        center: centre,
        radius: 0.03,
    };
    // shrink it until every knot clears it by twice the margin
    let clear = |c: Circle| {
        let cf = ClearanceFn::new(robot.clone(), [c], 0.0)
            .unwrap()
            .with_self_collision(false);
        (0..pts.len())
            .map(|k| cf.min_clearance(pts.q(k)))
            .fold(f64::INFINITY, f64::min)
    };
    while clear(c) < 2.0 * s.obstacle_margin {
        c.radius *= 0.8;
        assert!(c.radius > 0.002, "no room between the knots");
    }
    (free, c)
}

#[test]
fn a_plan_that_tunnels_between_knots_is_not_converged() {
    let robot = Robot::paper();
    // one RK4 step per interval: the solver checks the knots only
    let s = coarse(1);
    let (free, obstacle) = swing_and_obstacle(&s);
    let task = SwingTask {
        obstacles: vec![obstacle],
        ..SwingTask::paper()
    };
    let p = plan_with_guess(&robot, &task, &s, &nlp(), Some(&free.trajectory)).unwrap();
    // the solver converged: its knots clear the obstacle by the margin
    assert!(p.status.is_converged(), "{:?}", p.status);
    assert!(p.violations.clearance <= 1e-6, "{:?}", p.violations);
    // but the 1 ms trajectory passes into it
    let dmin = p.min_obstacle_clearance_m.unwrap();
    assert!(dmin < s.obstacle_margin - CLEARANCE_TOLERANCE_M, "{dmin}");
    assert!(!p.converged());
    let v = p.clearance_violation.expect("a clearance violation");
    // the attempt the plan comes from records it (kept when a later solve's plan is returned)
    assert!(
        p.solves
            .iter()
            .any(|a| a.adopted && a.between_knots == Some(v)),
        "{:?}",
        p.solves
    );
    assert_eq!(
        v.subject,
        ClearanceSubject::Obstacle {
            obstacle: 0,
            link: 3
        }
    );
    assert!((v.clearance_m - dmin).abs() < 1e-12, "{v:?} vs {dmin}");
    assert!((v.shortfall_m() - (s.obstacle_margin - dmin)).abs() < 1e-12);
    assert!(v.time_s > 0.0 && v.time_s < p.swing_time_s, "{v:?}");
    // its time is that of the closest sample
    let (j, _) = p.trajectory.locate(v.time_s);
    let cf = ClearanceFn::new(robot.clone(), [obstacle], 0.0)
        .unwrap()
        .with_self_collision(false);
    let at = |j: usize| cf.min_clearance(p.trajectory.q(j));
    assert!(
        (at(j) - dmin).abs() < 1e-12 || (at(j + 1) - dmin).abs() < 1e-12,
        "{v:?}"
    );
    let msg = p.failure_message().expect("a failure message");
    for part in ["link 4", "obstacle 0", &format!("t = {:.3} s", v.time_s)] {
        assert!(msg.contains(part), "{part:?} not in {msg}");
    }
    // the same check from outside the planner
    assert_eq!(
        check_clearance(&robot, &task, &s, &p.trajectory).unwrap(),
        Some(v)
    );
    // ignoring the obstacle, nothing is required of it
    let ignored = PlannerSettings {
        avoid_obstacles: false,
        ..s.clone()
    };
    assert_eq!(
        check_clearance(&robot, &task, &ignored, &p.trajectory).unwrap(),
        None
    );
}

/// With the default 3 RK4 steps per interval the same placement, planned cold, is either planned
/// clear on the resampled trajectory or reported not converged: never a converged plan through it.
#[test]
fn a_converged_plan_keeps_the_clearance_on_its_resampled_trajectory() {
    let robot = Robot::paper();
    let s = coarse(3);
    let (_, obstacle) = swing_and_obstacle(&s);
    let task = SwingTask {
        obstacles: vec![obstacle],
        ..SwingTask::paper()
    };
    let p = plan(&robot, &task, &s, &nlp()).unwrap();
    let dmin = p.min_obstacle_clearance_m.unwrap();
    if p.converged() {
        assert!(dmin >= s.obstacle_margin - CLEARANCE_TOLERANCE_M, "{dmin}");
        assert!(p.clearance_violation.is_none() && p.failure_message().is_none());
    } else {
        assert!(p.failure_message().is_some());
    }
}
