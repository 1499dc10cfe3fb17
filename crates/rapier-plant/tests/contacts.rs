//! Obstacles and contacts of the rapier plant: a ball in the robot's path gets hit, a far one never.
//!
//! Conventions: x = [q, qd] (q[0] absolute from +x, the rest relative; rad, rad/s), positions in m with
//! the grip at the origin, y up; 1 ms control period; the paper's robot swinging passively from rest.

mod common;

use brachia::sim::{ModelPlant, Plant};
use brachia::Error;
use brachia_rapier::{Ball, Circle, ContactBody, Obstacle, RapierPlant, RapierSettings};
use common::*;

/// Time (s) at which the ball is placed on the model's end-effector path.
const T_HIT: f64 = 0.4;
const BALL_R: f64 = 0.05;

/// End-effector position of the RK4 model at `t` (independent of the rapier plant).
fn model_ee_at(t: f64) -> [f64; 2] {
    let robot = paper_robot();
    let mut mp = ModelPlant::new(robot.clone(), &start_state());
    let steps = (t / DT).round() as usize;
    for _ in 0..steps {
        mp.step(&[0.0; 3], DT);
    }
    let mut x = vec![0.0; 8];
    mp.state(&mut x);
    robot.ee_position(&x[..4])
}

fn ball_at(center: [f64; 2]) -> Obstacle {
    Obstacle::Ball(Ball {
        center,
        radius: BALL_R,
        mass: 0.4,
        restitution: 0.3,
        gravity: false,
    })
}

/// Passive run of `steps` control periods; returns the states after each step.
fn run(plant: &mut RapierPlant, steps: usize) -> Vec<Vec<f64>> {
    let mut out = Vec::with_capacity(steps);
    for _ in 0..steps {
        plant.step(&[0.0; 3], DT);
        let mut x = vec![0.0; 8];
        plant.state(&mut x);
        out.push(x);
    }
    out
}

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn ball_in_the_path_is_hit_and_knocked_away() {
    let robot = paper_robot();
    let settings = RapierSettings::default();
    let center = model_ee_at(T_HIT);
    let mut free = RapierPlant::new(&robot, &start_state(), &settings).unwrap();
    let mut hit = RapierPlant::new(&robot, &start_state(), &settings).unwrap();
    let id = hit.add_obstacle(&ball_at(center)).unwrap();
    assert_eq!(id, 0);
    let steps = 1000;
    let xs_free = run(&mut free, steps);
    let xs_hit = run(&mut hit, steps);

    // contact logged, by the last link (the EE runs into the ball), before the model's EE reaches the
    // ball's centre (the capsule and the ball touch earlier)
    let t1 = hit.first_contact_time().expect("the ball is hit");
    assert!(t1 > 0.05 && t1 <= T_HIT + 1e-9, "first contact at {t1} s");
    let first = hit.contacts()[0];
    assert_eq!(first.body, ContactBody::Obstacle(0));
    assert_eq!(first.link, 3, "first contact {first:?}");
    assert!(first.impulse > 0.0);
    assert!(hit.contacts().windows(2).all(|w| w[0].t <= w[1].t));

    // the ball moved away with momentum from the robot
    let p = hit.obstacle_position(0).unwrap();
    let moved = ((p[0] - center[0]).powi(2) + (p[1] - center[1]).powi(2)).sqrt();
    assert!(moved > 0.1, "ball moved only {moved} m");
    let v = hit.obstacle_velocity(0).unwrap();
    assert!(v[0].hypot(v[1]) > 0.1, "ball speed {v:?}");
    assert_eq!(hit.ball_positions(), vec![p]);
    // total impulse on the ball ~ its momentum (no gravity on the ball; friction impulses not logged,
    // so only a loose check that the logged normal impulses carry the momentum's order)
    let total: f64 = hit.contacts().iter().map(|c| c.impulse).sum();
    let momentum = 0.4 * v[0].hypot(v[1]);
    assert!(
        total > 0.5 * momentum && total < 3.0 * momentum,
        "impulse {total} vs momentum {momentum}"
    );

    // before contact the two runs are the same; after it the robot is perturbed
    let k1 = (t1 / DT).round() as usize - 1;
    let before = (0..k1.saturating_sub(1))
        .map(|k| max_diff(&xs_free[k], &xs_hit[k]))
        .fold(0.0, f64::max);
    assert!(before < 1e-12, "runs differ before contact by {before}");
    let after = max_diff(&xs_free[steps - 1], &xs_hit[steps - 1]);
    assert!(after > 1e-2, "robot not perturbed: {after}");

    // the obstacle track: one row before the first step and one after each step, ending where the
    // ball is now, starting where it was placed
    let rows: Vec<&[f64]> = hit.obstacle_track().collect();
    assert_eq!(rows.len(), steps + 1);
    assert_eq!(rows[0], &[0.0, center[0], center[1]][..]);
    assert_eq!(rows[steps][1..], p[..]);
    assert!((rows[steps][0] - steps as f64 * DT).abs() < 1e-9);
    let csv = hit.obstacle_track_csv();
    assert!(csv.starts_with("t,obstacle_0_x,obstacle_0_y\n"));
    assert_eq!(csv.lines().count(), steps + 2);
    assert!(free.obstacle_track().next().is_none());
}

#[test]
fn far_ball_is_never_hit() {
    let robot = paper_robot();
    let settings = RapierSettings::default();
    let mut free = RapierPlant::new(&robot, &start_state(), &settings).unwrap();
    let mut far = RapierPlant::new(&robot, &start_state(), &settings).unwrap();
    let center = [3.0, 2.0];
    far.add_obstacle(&ball_at(center)).unwrap();
    let xs_free = run(&mut free, 1000);
    let xs_far = run(&mut far, 1000);
    assert!(far.contacts().is_empty());
    assert_eq!(far.first_contact_time(), None);
    assert_eq!(far.obstacle_position(0), Some(center));
    let d = (0..1000)
        .map(|k| max_diff(&xs_free[k], &xs_far[k]))
        .fold(0.0, f64::max);
    assert!(d < 1e-12, "far ball changed the swing by {d}");
}

#[test]
fn fixed_circle_stops_the_swing_and_stays_put() {
    let robot = paper_robot();
    let settings = RapierSettings::default();
    let center = model_ee_at(T_HIT);
    let mut plant = RapierPlant::new(&robot, &start_state(), &settings).unwrap();
    plant
        .add_obstacle(&Obstacle::Circle(Circle {
            center,
            radius: BALL_R,
        }))
        .unwrap();
    run(&mut plant, 600);
    assert!(plant.first_contact_time().is_some());
    assert_eq!(plant.obstacle_position(0), Some(center));
    // the EE never passes through the circle: its distance to the centre stays >= radius (minus a
    // small penetration tolerance)
    let mut x = vec![0.0; 8];
    let mut p2 = RapierPlant::new(&robot, &start_state(), &settings).unwrap();
    p2.add_obstacle(&Obstacle::Circle(Circle {
        center,
        radius: BALL_R,
    }))
    .unwrap();
    for _ in 0..600 {
        p2.step(&[0.0; 3], DT);
        p2.state(&mut x);
        let ee = robot.ee_position(&x[..4]);
        let d = (ee[0] - center[0]).hypot(ee[1] - center[1]);
        assert!(d > BALL_R - 0.01, "EE inside the circle: {d}");
    }
}

#[test]
fn obstacle_overlapping_the_robot_is_rejected() {
    let robot = paper_robot();
    let mut plant = RapierPlant::new(&robot, &start_state(), &RapierSettings::default()).unwrap();
    let ee = robot.ee_position(&Q_START);
    let err = plant.add_obstacle(&ball_at(ee)).unwrap_err();
    assert!(matches!(err, Error::InfeasibleTask(_)), "{err}");
    let bad = Obstacle::Ball(Ball {
        center: [2.0, 2.0],
        radius: 0.1,
        mass: -1.0,
        restitution: 0.3,
        gravity: true,
    });
    let err = plant.add_obstacle(&bad).unwrap_err();
    assert!(err.to_string().contains("obstacles[0].mass"), "{err}");
    assert_eq!(plant.obstacles().count(), 0);
}

#[test]
fn ball_with_gravity_falls_freely() {
    let robot = paper_robot();
    let mut plant = RapierPlant::new(&robot, &start_state(), &RapierSettings::default()).unwrap();
    plant
        .add_obstacle(&Obstacle::Ball(Ball {
            center: [3.0, 0.0],
            radius: 0.1,
            mass: 0.2,
            restitution: 0.0,
            gravity: true,
        }))
        .unwrap();
    run(&mut plant, 500);
    let p = plant.obstacle_position(0).unwrap();
    let t = plant.time();
    // free fall y = -g t^2 / 2 (first-order integrator: within a few mm after 0.5 s)
    let expected = -0.5 * 9.81 * t * t;
    assert!((p[1] - expected).abs() < 5e-3, "y = {} vs {expected}", p[1]);
    assert!((p[0] - 3.0).abs() < 1e-12);
}

#[test]
fn obstacles_round_trip_through_json() {
    let obs = vec![
        ball_at([1.0, -0.5]),
        Obstacle::Circle(Circle {
            center: [0.5, -1.0],
            radius: 0.1,
        }),
    ];
    let text = serde_json::to_string(&obs).unwrap();
    assert!(text.contains("\"kind\":\"ball\""), "{text}");
    let back: Vec<Obstacle> = serde_json::from_str(&text).unwrap();
    assert_eq!(back, obs);
}

#[test]
fn a_ball_added_after_stepping_is_tracked_from_then_with_nan_before() {
    // a ladder throws a ball in when its swing starts: the obstacle track keeps one column pair per
    // obstacle, the rows before the ball existed have NaN in its columns
    let robot = paper_robot();
    let mut plant = RapierPlant::new(&robot, &start_state(), &RapierSettings::default()).unwrap();
    plant.add_obstacle(&ball_at([3.0, 0.0])).unwrap();
    run(&mut plant, 5);
    let before: Vec<Vec<f64>> = plant.obstacle_track().map(<[f64]>::to_vec).collect();
    assert_eq!(before.len(), 6);
    assert!(before.iter().all(|r| r.len() == 3));
    let id = plant.add_obstacle(&ball_at([-3.0, 0.0])).unwrap();
    assert_eq!(id, 1);
    run(&mut plant, 3);
    let rows: Vec<Vec<f64>> = plant.obstacle_track().map(<[f64]>::to_vec).collect();
    assert_eq!(rows.len(), 9);
    for (k, r) in rows.iter().enumerate() {
        assert_eq!(r.len(), 5, "row {k}");
        if k < 6 {
            // the first ball's history is kept, the new ball's columns are NaN
            assert_eq!(r[..3], before[k][..], "row {k}");
            assert!(r[3].is_nan() && r[4].is_nan(), "row {k}: {r:?}");
        } else {
            assert_eq!(r[3..], [-3.0, 0.0], "row {k}: the floating ball at rest");
        }
    }
    let csv = plant.obstacle_track_csv();
    assert!(csv.starts_with("t,obstacle_0_x,obstacle_0_y,obstacle_1_x,obstacle_1_y\n"));
    assert_eq!(csv.lines().count(), 10);
}

#[test]
fn a_ball_on_the_planned_path_sits_at_the_planned_hand() {
    use brachia::trajectory::Trajectory;
    let robot = paper_robot();
    // a two-knot "plan": the start pose at t = 0 and a bent pose at t = 1
    let mut plan = Trajectory::new(4);
    let q1 = [-2.0, 0.3, -1.2, 0.2];
    plan.push(0.0, &Q_START, &[0.0; 4], &[0.0; 3]);
    plan.push(1.0, &q1, &[0.0; 4], &[0.0; 3]);
    let (b, t) = Ball::on_path(&plan, &robot, 1.5, 0.2, 0.05, 0.5);
    assert_eq!(t, 1.0);
    assert_eq!(b.center, robot.ee_position(&q1));
    assert_eq!(
        (b.mass, b.radius, b.restitution, b.gravity),
        (0.2, 0.05, 0.5, false)
    );
    let (b0, t0) = Ball::on_path(&plan, &robot, 0.5, 0.2, 0.05, 0.5);
    assert_eq!(t0, 0.0);
    assert_eq!(b0.center, robot.ee_position(&Q_START));
    // centred on the hand: it overlaps the chain in that pose by the ball and hand radii
    let c = b0.clearance(&robot, &Q_START);
    assert!((c + 0.05 + robot.radii()[3]).abs() < 1e-12, "{c}");
    assert!(b0.clearance(&robot, &q1) > c);
}
