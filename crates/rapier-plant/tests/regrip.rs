//! Grip switching on the rapier plant: at capture the chain is rebuilt in the same world,
//! rooted by a new joint at the hand that caught the bar, with the re-rooted chain's parameters and
//! state from the grasp-switch map of the core crate (`brachia::model::switch_grip`). The switch keeps
//! every joint's world position (to `REGRIP_TOLERANCE_M`, in fact ~1e-15 m), stops the hand when it
//! arrives moving (the capture impulse), leaves balls where they are, and the new chain then swings
//! like the re-rooted model.
//!
//! Conventions: x = [q, qd] (rad, rad/s), world frame x right, y up, m; 1 ms control period.

mod common;

use brachia::model::switch_grip;
use brachia::sim::{ModelPlant, Plant};
use brachia_rapier::{Ball, Obstacle, RapierPlant, RapierSettings, REGRIP_TOLERANCE_M};
use common::{paper_robot, DT, Q_START};

/// A swinging chain (EE moving) hanging from `grip`, regripped at its EE; returns the plant and the
/// state and grip it was regripped with.
fn swing_then_regrip(steps: usize) -> (RapierPlant, brachia_rapier::Regrip, Vec<f64>, [f64; 2]) {
    let robot = paper_robot();
    let grip = [0.3, 0.1];
    let x0 = [Q_START.to_vec(), vec![0.0; 4]].concat();
    let mut p = RapierPlant::new_at(&robot, grip, &x0, &RapierSettings::default()).unwrap();
    for _ in 0..steps {
        p.step(&[0.5, -0.3, 0.2], DT);
    }
    let mut x = vec![0.0; 8];
    p.state(&mut x);
    let s = switch_grip(&robot, p.grip(), &x).unwrap();
    let rr = robot.rerooted().unwrap();
    let r = p.regrip(&rr, s.grip, &s.x).unwrap();
    (p, r, s.x, s.grip)
}

#[test]
fn the_switch_keeps_every_joint_in_place_and_stops_the_hand() {
    let (p, r, x, grip) = swing_then_regrip(300);
    let n = 4;
    assert_eq!(r.joints_before.len(), n + 1);
    // world pose kept: every joint within the tolerance (the rebuild from the re-rooted state)
    assert!(
        r.position_residual_m <= REGRIP_TOLERANCE_M,
        "residual {:.3e} m",
        r.position_residual_m
    );
    assert!(
        r.grip_offset_m < 1e-9,
        "the root joint is where the hand was"
    );
    // the hand was moving: the capture impulse stopped it, the old grip was already at rest
    assert!(r.ee_speed_before_m_s > 0.1, "{}", r.ee_speed_before_m_s);
    let v_hand = r.velocities_after[n];
    assert!(
        v_hand[0].hypot(v_hand[1]) < 1e-9,
        "new grip at rest: {v_hand:?}"
    );
    assert!(r.velocity_change_m_s > 0.1);
    assert!(r.velocity_change_m_s < 3.0 * r.ee_speed_before_m_s);
    // the plant reads back the re-rooted state, its grip and a fresh clock
    let mut xr = vec![0.0; 2 * n];
    p.state(&mut xr);
    for i in 0..2 * n {
        assert!(
            (xr[i] - x[i]).abs() < 1e-12,
            "x[{i}]: {} vs {}",
            xr[i],
            x[i]
        );
    }
    assert_eq!(p.grip(), grip);
    assert_eq!(p.time(), 0.0);
    assert!((p.total_time() - 0.3).abs() < 1e-12);
    // the engine's joints agree with the re-rooted robot's kinematics at the new grip
    let (pw, _) = p.world_joints();
    let mut pk = vec![[0.0; 2]; n + 1];
    p.robot().joint_positions(&x[..n], &mut pk);
    for j in 0..=n {
        let d = (pw[j][0] - grip[0] - pk[j][0]).hypot(pw[j][1] - grip[1] - pk[j][1]);
        assert!(d < 1e-12, "joint {j}: {d}");
    }
}

#[test]
fn after_the_switch_the_chain_swings_like_the_rerooted_model() {
    let (mut p, _, x, _) = swing_then_regrip(200);
    let rr = paper_robot().rerooted().unwrap();
    let mut m = ModelPlant::new(rr, &x);
    let mut xp = vec![0.0; 8];
    let mut xm = vec![0.0; 8];
    let mut err: f64 = 0.0;
    for _ in 0..500 {
        p.step(&[0.2, 0.1, -0.2], DT);
        m.step(&[0.2, 0.1, -0.2], DT);
        p.state(&mut xp);
        m.state(&mut xm);
        err = err.max((0..4).map(|i| (xp[i] - xm[i]).abs()).fold(0.0, f64::max));
    }
    // the agreement of a fresh plant with the model (docs/rapier.md: ~1e-3 rad per s at 1 sub-step)
    assert!(err < 2e-3, "max |dq| over 0.5 s after the switch: {err}");
    assert!(err > 0.0);
}

#[test]
fn balls_keep_their_world_state_across_the_switch() {
    let robot = paper_robot();
    let x0 = [Q_START.to_vec(), vec![0.0; 4]].concat();
    let mut p = RapierPlant::new_at(&robot, [1.0, 0.5], &x0, &RapierSettings::default()).unwrap();
    let ball = Obstacle::Ball(Ball {
        center: [3.0, 2.5],
        radius: 0.05,
        mass: 0.4,
        restitution: 0.3,
        gravity: true,
    });
    p.add_obstacle(&ball).unwrap();
    for _ in 0..100 {
        p.step(&[0.0; 3], DT);
    }
    let (b0, v0) = (
        p.obstacle_position(0).unwrap(),
        p.obstacle_velocity(0).unwrap(),
    );
    let mut x = vec![0.0; 8];
    p.state(&mut x);
    let s = switch_grip(&robot, p.grip(), &x).unwrap();
    p.regrip(&robot.rerooted().unwrap(), s.grip, &s.x).unwrap();
    assert_eq!(p.obstacle_position(0).unwrap(), b0);
    assert_eq!(p.obstacle_velocity(0).unwrap(), v0);
    // it keeps falling as -g t^2 / 2 (no contact), its track stamped with the total time
    for _ in 0..100 {
        p.step(&[0.0; 3], DT);
    }
    let y = p.obstacle_position(0).unwrap()[1];
    assert!((y - (2.5 - 0.5 * 9.81 * 0.2 * 0.2)).abs() < 5e-3, "{y}");
    let last = p.obstacle_track().last().unwrap().to_vec();
    assert!((last[0] - 0.2).abs() < 1e-12);
}

#[test]
fn a_state_that_is_not_the_rerooted_pose_is_refused() {
    let robot = paper_robot();
    let x0 = [Q_START.to_vec(), vec![0.0; 4]].concat();
    let mut p = RapierPlant::new(&robot, &x0, &RapierSettings::default()).unwrap();
    let mut x = vec![0.0; 8];
    p.state(&mut x);
    let mut s = switch_grip(&robot, p.grip(), &x).unwrap();
    s.x[1] += 0.1;
    let e = p
        .regrip(&robot.rerooted().unwrap(), s.grip, &s.x)
        .unwrap_err();
    assert!(e.to_string().contains("not the old pose re-rooted"), "{e}");
    let e = p.regrip(&robot, s.grip, &s.x[..6]).unwrap_err();
    assert!(e.to_string().contains("regrip"), "{e}");
}
