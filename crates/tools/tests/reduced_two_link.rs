//! The reduced two-link model (elbow angle as input, momentum about the grip as state) against the full
//! model: with the elbow driven along a smooth path by the torque the full model needs for it, the full
//! model's grip angle and momentum follow the reduced model's.
use brachia::model::{ik_from_seed, Scratch};
use brachia::Robot;
use brachia_tools::reduced_two_link::{ReducedModelError, ReducedTwoLink};

fn hook() -> Robot {
    brachia_tools::hook_robot().unwrap()
}

/// The elbow's path: angle, rate and acceleration at `t` s.
fn elbow(q20: f64, t: f64) -> (f64, f64, f64) {
    let (a, w) = (1.2, 5.0);
    (
        q20 + a * (w * t).sin() + 0.8 * t * t,
        a * w * (w * t).cos() + 1.6 * t,
        -a * w * w * (w * t).sin() + 1.6,
    )
}

/// Full-model accelerations with the computed torque that gives the elbow the path's acceleration
/// (from the model's inverse dynamics), and that torque.
fn computed_torque(
    robot: &Robot,
    ws: &mut Scratch<f64>,
    z: [f64; 4],
    q2dd: f64,
) -> ([f64; 2], f64) {
    let (q, qd) = ([z[0], z[1]], [z[2], z[3]]);
    let m = robot.mass_matrix(&q);
    let mut f = [0.0; 2];
    robot.inverse_dynamics_into(ws, &q, &qd, &[0.0, q2dd], &mut f);
    // the passive grip: row 0 of M qdd + C qd + G vanishes
    let q1dd = -f[0] / m[0];
    robot.inverse_dynamics_into(ws, &q, &qd, &[q1dd, q2dd], &mut f);
    let tau = f[1];
    let qdd = robot.forward_dynamics(&q, &qd, &[tau]);
    ([qdd[0], qdd[1]], tau)
}

#[test]
fn reduced_dynamics_follow_the_full_model_under_computed_torque() {
    let robot = hook();
    let red = ReducedTwoLink::new(&robot).unwrap();
    let q0 = ik_from_seed(&robot, &[-2.2, -1.9], [-0.34, 0.0]).unwrap();
    let mut ws = Scratch::new(2);
    let (q2, q2d, _) = elbow(q0[1], 0.0);
    // the full state starts at rest in the grip, the elbow already moving
    let mut z = [q0[0], q2, 0.0, q2d];
    let mut x = [q0[0], red.momentum([z[0], z[1]], [z[2], z[3]]), q2];
    let (h, steps) = (1e-3, 1000);
    let mut peak_tau = 0.0f64;
    let mut worst = [0.0f64; 3];
    let mut swing = 0.0f64;
    for k in 0..steps {
        let t = k as f64 * h;
        // full model: RK4 on (q, qd) with the computed torque at each stage
        let mut f = |tt: f64, zz: [f64; 4]| {
            let (_, _, q2dd) = elbow(q0[1], tt);
            let (qdd, tau) = computed_torque(&robot, &mut ws, zz, q2dd);
            peak_tau = peak_tau.max(tau.abs());
            [zz[2], zz[3], qdd[0], qdd[1]]
        };
        let add = |a: [f64; 4], b: [f64; 4], s: f64| std::array::from_fn(|i| a[i] + s * b[i]);
        let k1 = f(t, z);
        let k2 = f(t + h / 2.0, add(z, k1, h / 2.0));
        let k3 = f(t + h / 2.0, add(z, k2, h / 2.0));
        let k4 = f(t + h, add(z, k3, h));
        z = std::array::from_fn(|i| z[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        // reduced model: the elbow's mean rate over the step, so q2 lands on the path exactly
        let u = (elbow(q0[1], t + h).0 - elbow(q0[1], t).0) / h;
        x = red.step(x, u, h, 1);
        let hz = red.momentum([z[0], z[1]], [z[2], z[3]]);
        worst[0] = worst[0].max((z[0] - x[0]).abs());
        worst[1] = worst[1].max((hz - x[1]).abs());
        worst[2] = worst[2].max((z[1] - x[2]).abs());
        swing = swing.max((z[0] - q0[0]).abs());
    }
    // the motion is a real one: the grip swings and the elbow needs torque
    assert!(swing > 0.5, "q1 moved only {swing}");
    assert!(peak_tau > 0.5, "peak torque {peak_tau}");
    assert!(worst[0] < 1e-5, "q1 differs by {}", worst[0]);
    assert!(worst[1] < 1e-6, "H differs by {}", worst[1]);
    assert!(worst[2] < 1e-6, "q2 differs by {}", worst[2]);
}

#[test]
fn reduced_model_has_the_full_models_mass_matrix_and_gravity() {
    let robot = hook();
    let red = ReducedTwoLink::new(&robot).unwrap();
    let mut ws = Scratch::new(2);
    let mut g = [0.0; 2];
    for k in 0..50 {
        let q = [-3.0 + 0.13 * k as f64, 2.9 - 0.11 * k as f64];
        let m = robot.mass_matrix(&q);
        assert!((m[0] - red.m11(q[1])).abs() < 1e-12);
        assert!((m[1] - red.m12(q[1])).abs() < 1e-12);
        robot.gravity_into(&mut ws, &q, &mut g);
        assert!((g[0] - red.dv_dq1(q[0], q[1])).abs() < 1e-12);
        assert!(g[0].abs() <= red.max_dv_dq1() + 1e-12);
    }
    let paper = Robot::from_toml_file(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../params/paper.toml"),
    )
    .unwrap();
    assert_eq!(
        ReducedTwoLink::new(&paper).unwrap_err(),
        ReducedModelError::LinkCount(4)
    );
}
