//! Construction of the rapier plant: exact mass properties, zero joint damping, initial state read
//! back, engine poses/velocities consistent with the model's kinematics, torque clamping, settings.
//!
//! Conventions: x = [q, qd] (q[0] absolute from +x, the rest relative; rad, rad/s), tau = torques of
//! joints 2..4 (N m), 1 ms control period, the paper's robot.

mod common;

use brachia::sim::{ModelPlant, Plant};
use brachia::Error;
use brachia_rapier::{RapierPlant, RapierSettings};
use common::*;
use std::f64::consts::PI;

/// Wrap an angle to (-pi, pi].
fn wrap(a: f64) -> f64 {
    let w = a.rem_euclid(2.0 * PI);
    if w > PI {
        w - 2.0 * PI
    } else {
        w
    }
}

fn moving_state() -> Vec<f64> {
    vec![-2.35, 0.4, -1.55, 0.7, 1.0, -2.0, 1.5, -1.0]
}

#[test]
fn mass_properties_are_exact_and_damping_is_zero() {
    let robot = paper_robot();
    let plant = RapierPlant::new(&robot, &start_state(), &RapierSettings::default()).unwrap();
    let mp = plant.link_mass_properties();
    assert_eq!(mp.len(), 4);
    for i in 0..4 {
        assert!(
            (mp[i].mass - robot.masses()[i]).abs() < 1e-12,
            "{:?}",
            mp[i]
        );
        assert!((mp[i].local_com[0] - robot.coms()[i]).abs() < 1e-12);
        assert!(mp[i].local_com[1].abs() < 1e-12);
        assert!(
            (mp[i].inertia - robot.inertias()[i]).abs() < 1e-12,
            "{:?}",
            mp[i]
        );
    }
    assert_eq!(plant.engine_joint_damping(), vec![0.0; 4]);
}

#[test]
fn initial_state_reads_back_and_matches_engine_bodies() {
    let robot = paper_robot();
    let x0 = moving_state();
    let plant = RapierPlant::new(&robot, &x0, &RapierSettings::default()).unwrap();
    let mut x = vec![0.0; 8];
    plant.state(&mut x);
    assert!(
        x.iter().zip(&x0).all(|(a, b)| (a - b).abs() < 1e-12),
        "{x:?} vs {x0:?}"
    );
    // body rotations and angular velocities are the absolute angles / rates
    let (mut th, mut w) = (0.0, 0.0);
    let angles = plant.body_angles();
    let rates = plant.body_angular_velocities();
    for i in 0..4 {
        th += x0[i];
        w += x0[4 + i];
        assert!((wrap(angles[i] - th)).abs() < 1e-12, "link {i}");
        assert!((rates[i] - w).abs() < 1e-12, "link {i}");
    }
    // the energy from the engine's bodies equals the model's energy (positions, COM velocities, mass
    // properties all agree)
    let e_model = robot.energy(&x0[..4], &x0[4..]);
    assert!(
        (plant.energy() - e_model).abs() < 1e-10,
        "{} vs {e_model}",
        plant.energy()
    );
}

#[test]
fn angles_are_continuous_over_full_turns() {
    // link 1 spinning fast enough to go over the top: q[0] must grow past pi without 2 pi jumps
    let robot = paper_robot();
    let x0 = vec![-1.0, 0.0, 0.0, 0.0, 12.0, 0.0, 0.0, 0.0];
    let mut rp = RapierPlant::new(&robot, &x0, &RapierSettings::default()).unwrap();
    let mut mp = ModelPlant::new(robot.clone(), &x0);
    let (mut x, mut xm, mut prev) = (vec![0.0; 8], vec![0.0; 8], x0.clone());
    for _ in 0..1500 {
        rp.step(&[0.0; 3], DT);
        mp.step(&[0.0; 3], DT);
        rp.state(&mut x);
        mp.state(&mut xm);
        for i in 0..4 {
            assert!((x[i] - prev[i]).abs() < 0.05, "jump in q[{i}]");
        }
        prev.copy_from_slice(&x);
    }
    assert!(
        x[0] > 2.0 * PI,
        "link 1 did not complete a turn: q0 = {}",
        x[0]
    );
    assert!((x[0] - xm[0]).abs() < 0.1, "{} vs model {}", x[0], xm[0]);
}

#[test]
fn torques_are_clamped_and_sanitised() {
    let robot = paper_robot();
    let mut plant = RapierPlant::new(&robot, &start_state(), &RapierSettings::default()).unwrap();
    plant.step(&[9.0, -7.0, f64::NAN], DT);
    assert_eq!(plant.applied_torques(), &[5.0, -5.0, 0.0]);
    plant.step(&[1.0], DT);
    assert_eq!(plant.applied_torques(), &[1.0, 0.0, 0.0]);
    let t = plant.time();
    plant.step(&[1.0; 3], -1.0);
    assert_eq!(plant.time(), t);
}

#[test]
fn invalid_inputs_are_typed_errors() {
    let robot = paper_robot();
    let err = RapierPlant::new(&robot, &[0.0; 5], &RapierSettings::default()).unwrap_err();
    assert!(
        matches!(
            err,
            Error::Dimension {
                expected: 8,
                got: 5,
                ..
            }
        ),
        "{err}"
    );
    let mut x0 = start_state();
    x0[5] = f64::INFINITY;
    assert!(RapierPlant::new(&robot, &x0, &RapierSettings::default()).is_err());
    for (s, field) in [
        (
            RapierSettings {
                substeps: 0,
                ..Default::default()
            },
            "substeps",
        ),
        (
            RapierSettings {
                link_friction: -1.0,
                ..Default::default()
            },
            "link_friction",
        ),
        (
            RapierSettings {
                link_restitution: 1.5,
                ..Default::default()
            },
            "link_restitution",
        ),
    ] {
        let err = s.validate("<t>").unwrap_err();
        assert!(err.to_string().contains(field), "{err}");
        assert!(RapierPlant::new(&robot, &start_state(), &s).is_err());
    }
    assert!(RapierSettings::default().validate("<t>").is_ok());
}

#[test]
fn settings_round_trip_through_json_with_defaults() {
    let s: RapierSettings = serde_json::from_str(r#"{"substeps": 4}"#).unwrap();
    assert_eq!(s.substeps, 4);
    assert_eq!(s.link_friction, RapierSettings::default().link_friction);
    let back: RapierSettings = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(back, s);
    assert!(serde_json::from_str::<RapierSettings>(r#"{"substep": 4}"#).is_err());
}
