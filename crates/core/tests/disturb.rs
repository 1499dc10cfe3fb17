//! Each disturbance wrapper does what it says (docs/robustness.md): actuation delay shifts the torque
//! by exactly d steps, motor lag has the first-order step response, measurement delay shows the state
//! of d steps ago.
//!
//! Units: s, rad, rad/s, N m.

mod common;

use brachia::fdcheck;
use brachia::sim::{
    point_jacobian, ActuationDelay, Disturbances, JointFriction, MeasurementDelay, ModelPlant,
    MotorLag, Plant, Push, Pushes, TorqueLimit, TorqueNoise,
};
use common::*;

/// A plant that records every torque it is handed (3 actuated joints) and otherwise does nothing.
#[derive(Debug, Default)]
struct Recorder {
    got: Vec<Vec<f64>>,
    t: f64,
}

impl Plant for Recorder {
    fn n_links(&self) -> usize {
        4
    }
    fn time(&self) -> f64 {
        self.t
    }
    fn state(&self, x: &mut [f64]) {
        x.fill(0.0);
    }
    fn step(&mut self, tau: &[f64], dt: f64) {
        self.got.push(tau.to_vec());
        self.t += dt;
    }
    fn energy(&self) -> f64 {
        0.0
    }
    fn name(&self) -> &'static str {
        "recorder"
    }
}

#[test]
fn actuation_delay_shifts_the_torque_by_exactly_d_steps() {
    for d in [0, 1, 5] {
        let mut p = ActuationDelay::new(Recorder::default(), d).unwrap();
        for k in 0..20 {
            let c = k as f64;
            p.step(&[c, -c, 2.0 * c], 1e-3);
            assert_eq!(p.applied(), p.inner().got[k].as_slice());
        }
        for (k, got) in p.inner().got.iter().enumerate() {
            let want = if k < d { 0.0 } else { (k - d) as f64 };
            assert_eq!(got, &vec![want, -want, 2.0 * want], "d = {d}, step {k}");
        }
    }
    let steps = brachia::sim::delay_steps("test", 0.005, 1e-3).unwrap();
    assert_eq!(steps, 5);
    for bad in [-1e-3, f64::NAN, 2.0] {
        let e = brachia::sim::delay_steps("test", bad, 1e-3).unwrap_err();
        assert!(e.to_string().contains("delay_s"), "{e}");
    }
    assert!(ActuationDelay::new(Recorder::default(), 10_000_000).is_err());
}

#[test]
fn motor_lag_has_the_first_order_step_response() {
    let (tc, dt) = (0.01, 1e-3);
    let mut p = MotorLag::new(Recorder::default(), tc).unwrap();
    let mut impulse = 0.0;
    for k in 1..=100 {
        p.step(&[1.0, -2.0, 0.0], dt);
        let t = k as f64 * dt;
        let want = 1.0 - (-t / tc).exp();
        assert!((p.motor_torque()[0] - want).abs() < 1e-12, "step {k}");
        assert!((p.motor_torque()[1] + 2.0 * want).abs() < 1e-12);
        assert_eq!(p.motor_torque()[2], 0.0);
        // the applied torques carry the exact impulse: int_0^t (1 - e^{-s/T}) ds
        impulse += p.applied()[0] * dt;
        let exact = t - tc * (1.0 - (-t / tc).exp());
        assert!(
            (impulse - exact).abs() < 1e-12,
            "step {k}: {impulse} vs {exact}"
        );
    }
    // 63 % of the step after one time constant
    let mut p = MotorLag::new(Recorder::default(), tc).unwrap();
    for _ in 0..10 {
        p.step(&[1.0, 0.0, 0.0], dt);
    }
    assert!((p.motor_torque()[0] - (1.0 - (-1f64).exp())).abs() < 1e-12);
    // T = 0 passes the command through
    let mut p = MotorLag::new(Recorder::default(), 0.0).unwrap();
    p.step(&[0.3, 0.2, 0.1], dt);
    assert_eq!(p.inner().got[0], vec![0.3, 0.2, 0.1]);
    for bad in [-0.1, f64::INFINITY, 1e3] {
        let e = MotorLag::new(Recorder::default(), bad).unwrap_err();
        assert!(e.to_string().contains("time_constant_s"), "{e}");
    }
}

#[test]
fn measurement_delay_shows_the_state_of_d_steps_ago() {
    let robot = paper_robot(5.0);
    let d = 3;
    let x0 = start_state();
    let mut p = MeasurementDelay::new(ModelPlant::new(robot.clone(), &x0), d).unwrap();
    let mut history = vec![x0.clone()];
    let (mut x, mut xt) = (vec![0.0; 8], vec![0.0; 8]);
    for k in 0..30usize {
        p.state(&mut x);
        let want = &history[k.saturating_sub(d)];
        assert_eq!(&x, want, "step {k}");
        p.step(&[0.5, -0.3, 0.2], 1e-3);
        p.true_state(&mut xt);
        history.push(xt.clone());
    }
    assert_ne!(history[0], history[30]);
}

/// Angular momentum of the robot about the grip, kg m^2/s:
/// `sum_i m_i (r_ci x v_ci) + I_i omega_i`, with COM velocities from the point Jacobian.
fn angular_momentum(robot: &brachia::Robot, x: &[f64]) -> f64 {
    let n = robot.n();
    let (q, qd) = (&x[..n], &x[n..]);
    let mut com = vec![[0.0; 2]; n];
    robot.com_positions(q, &mut com);
    let mut jac = vec![0.0; 2 * n];
    let mut l = 0.0;
    let mut w = 0.0;
    for i in 0..n {
        point_jacobian(robot, q, i, robot.coms()[i], &mut jac);
        let v: [f64; 2] = [
            (0..n).map(|k| jac[k] * qd[k]).sum(),
            (0..n).map(|k| jac[n + k] * qd[k]).sum(),
        ];
        w += qd[i];
        l += robot.masses()[i] * (com[i][0] * v[1] - com[i][1] * v[0]) + robot.inertias()[i] * w;
    }
    l
}

#[test]
fn the_point_jacobian_matches_finite_differences() {
    let robot = paper_robot(5.0);
    let q = [-2.0, 0.4, -1.1, 0.7];
    for (link, s) in [(0, 0.1), (2, 0.3), (3, robot.lengths()[3])] {
        let mut jac = vec![0.0; 8];
        point_jacobian(&robot, &q, link, s, &mut jac);
        let f = |q: &[f64], out: &mut [f64]| {
            let mut j = vec![[0.0; 2]; 5];
            robot.joint_positions(q, &mut j);
            let mut th = [0.0; 4];
            robot.absolute_angles(q, &mut th);
            out[0] = j[link][0] + s * th[link].cos();
            out[1] = j[link][1] + s * th[link].sin();
        };
        let fd = fdcheck::fd_jacobian(f, &q, 2, 1e-6);
        let rep = fdcheck::compare(&jac, &fd, 4);
        assert!(rep.max_scaled_err < 1e-7, "link {link}: {rep:?}");
    }
    // at the EE it is the EE Jacobian
    let mut jac = vec![0.0; 8];
    let mut ee = vec![0.0; 8];
    point_jacobian(&robot, &q, 3, robot.lengths()[3], &mut jac);
    robot.ee_jacobian(&q, &mut ee);
    for (a, b) in jac.iter().zip(&ee) {
        assert!((a - b).abs() < 1e-12);
    }
}

#[test]
fn a_push_changes_the_angular_momentum_about_the_grip_by_r_cross_j() {
    let robot = paper_robot(5.0);
    let x0 = [-2.0, 0.4, -1.1, 0.7, 0.3, -0.5, 1.0, 0.2];
    let (link, s, j) = (2, 0.2, [0.15, -0.4]);
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    plant.push(link, s, j).unwrap();
    let mut x1 = vec![0.0; 8];
    plant.state(&mut x1);
    assert_eq!(&x1[..4], &x0[..4], "a push does not move the angles");
    let mut jp = vec![[0.0; 2]; 5];
    robot.joint_positions(&x0[..4], &mut jp);
    let th: f64 = x0[..3].iter().sum();
    let r = [jp[link][0] + s * th.cos(), jp[link][1] + s * th.sin()];
    let want = r[0] * j[1] - r[1] * j[0];
    let got = angular_momentum(&robot, &x1) - angular_momentum(&robot, &x0);
    assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    assert!(want.abs() > 0.05);
    // scheduled: applied at the first step whose period holds its time, once
    let push = Push {
        t_s: 0.0105,
        link: 3,
        point_m: 0.2,
        impulse_n_s: j,
    };
    let mut a = Pushes::new(ModelPlant::new(robot.clone(), &x0), &[push]).unwrap();
    let mut b = ModelPlant::new(robot.clone(), &x0);
    let (mut xa, mut xb) = (vec![0.0; 8], vec![0.0; 8]);
    for k in 0..20 {
        a.step(&[0.0; 3], 1e-3);
        b.step(&[0.0; 3], 1e-3);
        a.state(&mut xa);
        b.state(&mut xb);
        assert_eq!(xa == xb, k < 10, "step {k}");
    }
    assert_eq!(a.applied(), 1);
    for bad in [
        Push { link: 0, ..push },
        Push { link: 5, ..push },
        Push { t_s: -1.0, ..push },
        Push {
            impulse_n_s: [f64::NAN, 0.0],
            ..push
        },
    ] {
        assert!(Pushes::new(ModelPlant::new(robot.clone(), &x0), &[bad]).is_err());
    }
}

#[test]
fn friction_dissipates_energy_on_a_passive_swing() {
    let robot = paper_robot(5.0);
    let x0 = [-1.2, 0.6, -0.8, 0.5, 0.0, 0.0, 0.0, 0.0];
    let mut free = ModelPlant::new(robot.clone(), &x0);
    let e0 = free.energy();
    for (coulomb, viscous) in [(0.0, 0.05), (0.05, 0.0)] {
        let mut p =
            JointFriction::new(ModelPlant::new(robot.clone(), &x0), coulomb, viscous).unwrap();
        let mut prev = p.energy();
        for _ in 0..1000 {
            p.step(&[0.0; 3], 1e-3);
            let e = p.energy();
            assert!(e <= prev + 1e-9, "friction added energy: {e} > {prev}");
            prev = e;
        }
        assert!(prev < e0 - 1e-3, "({coulomb}, {viscous}): {prev} vs {e0}");
    }
    for _ in 0..1000 {
        free.step(&[0.0; 3], 1e-3);
    }
    assert!(
        (free.energy() - e0).abs() < 1e-6,
        "the free swing conserves energy"
    );
    assert!(JointFriction::new(free, -0.1, 0.0).is_err());
}

#[test]
fn torque_noise_and_limit_change_the_torque_as_documented() {
    let mut p = TorqueNoise::new(Recorder::default(), 0.3, 7).unwrap();
    let mut q = TorqueNoise::new(Recorder::default(), 0.3, 7).unwrap();
    let (mut sum, mut sq, m) = (0.0, 0.0, 20_000);
    for _ in 0..m {
        p.step(&[1.0, 1.0, 1.0], 1e-3);
        q.step(&[1.0, 1.0, 1.0], 1e-3);
        assert_eq!(p.applied(), q.applied(), "same seed, same noise");
        let e = p.applied()[1] - 1.0;
        sum += e;
        sq += e * e;
    }
    let (mean, sd) = (sum / m as f64, (sq / m as f64).sqrt());
    assert!(mean.abs() < 0.01 && (sd - 0.3).abs() < 0.01, "{mean} {sd}");
    let mut l = TorqueLimit::new(Recorder::default(), 2.0).unwrap();
    l.step(&[3.0, -2.5, 1.0], 1e-3);
    assert_eq!(l.applied(), &[2.0, -2.0, 1.0]);
    assert!(TorqueLimit::new(Recorder::default(), 0.0).is_err());
}

#[test]
fn disturbances_validate_every_value_and_build_the_stack() {
    let robot = paper_robot(5.0);
    let ok = Disturbances {
        mass_scale: vec![1.1, 0.9, 1.0, 1.0],
        actuation_delay_s: 0.005,
        motor_time_constant_s: 0.01,
        start_offset: vec![0.01, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        ..Disturbances::default()
    };
    ok.validate(4, 1e-3, "t").unwrap();
    assert!(!ok.is_none() && Disturbances::default().is_none());
    let p = ok.plant_params(robot.params());
    assert!((p.links[0].mass - 1.1 * robot.masses()[0]).abs() < 1e-15);
    assert_eq!(ok.start_state(&start_state())[0], start_state()[0] + 0.01);
    let bad = [
        (
            Disturbances {
                mass_scale: vec![1.0; 3],
                ..Default::default()
            },
            "mass_scale",
        ),
        (
            Disturbances {
                com_scale: vec![1.0, 1.0, 0.0, 1.0],
                ..Default::default()
            },
            "com_scale[2]",
        ),
        (
            Disturbances {
                coulomb_nm: f64::NAN,
                ..Default::default()
            },
            "coulomb_nm",
        ),
        (
            Disturbances {
                actuation_delay_s: 5.0,
                ..Default::default()
            },
            "actuation_delay_s",
        ),
        (
            Disturbances {
                measurement_delay_s: -0.1,
                ..Default::default()
            },
            "measurement_delay_s",
        ),
        (
            Disturbances {
                torque_limit_nm: Some(0.0),
                ..Default::default()
            },
            "torque_limit_nm",
        ),
        (
            Disturbances {
                start_offset: vec![0.0; 3],
                ..Default::default()
            },
            "start_offset",
        ),
        (
            Disturbances {
                start_offset: vec![2.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
                ..Default::default()
            },
            "start_offset[0]",
        ),
        (
            Disturbances {
                motor_time_constant_s: 1e9,
                ..Default::default()
            },
            "motor_time_constant_s",
        ),
    ];
    for (d, field) in bad {
        let e = d.validate(4, 1e-3, "t").unwrap_err().to_string();
        assert!(e.contains(field), "{field}: {e}");
    }
    // the stack: delay then lag, as the wrappers alone
    let x0 = start_state();
    let mut stacked = ok
        .wrap(Box::new(ModelPlant::new(robot.clone(), &x0)), 1e-3)
        .unwrap();
    let mut by_hand = ActuationDelay::new(
        MotorLag::new(ModelPlant::new(robot.clone(), &x0), 0.01).unwrap(),
        5,
    )
    .unwrap();
    let (mut a, mut b) = (vec![0.0; 8], vec![0.0; 8]);
    for k in 0..50 {
        let tau = [0.5 * (k as f64 * 0.1).sin(), 0.2, -0.3];
        stacked.step(&tau, 1e-3);
        by_hand.step(&tau, 1e-3);
    }
    stacked.state(&mut a);
    by_hand.state(&mut b);
    assert_eq!(a, b);
}
