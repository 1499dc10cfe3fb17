//! Physics invariants and derivative checks of the robot model.
//!
//! Conventions: q[0] absolute angle of link 1 from +x, q[1..] relative; x = [q, qd]; u = tau (joints 2..n).

use brachia::ad::{as_f64_fn, Diff, LocalFn};
use brachia::fdcheck::{assert_hessian, assert_jacobian};
use brachia::integrate::Rk4;
use brachia::math::Dual64;
use brachia::model::{DynamicsFn, LinearModel, Linearizer, Robot, RobotParams, Scratch};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const PAPER_Q0: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];

fn robots() -> Vec<Robot> {
    let mut v = vec![Robot::paper()];
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../params/paper-uniform-rod.toml"
    );
    v.push(Robot::from_toml_file(std::path::Path::new(path)).unwrap());
    // a 6-link robot: nothing is tied to four links
    let mut p = Robot::paper().params().clone();
    let extra = p.links[1].clone();
    p.links.insert(2, extra.clone());
    p.links.insert(3, extra);
    p.actuators.tau_min = vec![-5.0; 5];
    p.actuators.tau_max = vec![5.0; 5];
    v.push(Robot::from_params(p, "six-link").unwrap());
    v
}

fn random_state(rng: &mut ChaCha8Rng, n: usize) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let q = (0..n).map(|_| rng.gen_range(-3.0..3.0)).collect();
    let qd = (0..n).map(|_| rng.gen_range(-4.0..4.0)).collect();
    let tau = (0..n - 1).map(|_| rng.gen_range(-5.0..5.0)).collect();
    (q, qd, tau)
}

#[test]
fn mass_matrix_is_symmetric_positive_definite() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for robot in robots() {
        let n = robot.n();
        for _ in 0..200 {
            let (q, _, _) = random_state(&mut rng, n);
            let m = robot.mass_matrix(&q);
            for i in 0..n {
                for j in 0..n {
                    assert!((m[i * n + j] - m[j * n + i]).abs() < 1e-12);
                }
            }
            let mm = nalgebra::DMatrix::from_row_slice(n, n, &m);
            let eig = mm.symmetric_eigen().eigenvalues;
            assert!(eig.min() > 1e-6, "M not positive definite: {eig}");
        }
    }
}

#[test]
fn forward_kinematics_matches_paper_start() {
    let robot = Robot::paper();
    let ee = robot.ee_position(&PAPER_Q0);
    assert!(
        (ee[0] - -1.014).abs() < 1e-3 && (ee[1] - -0.017).abs() < 1e-3,
        "{ee:?}"
    );
}

#[test]
fn forward_then_inverse_dynamics_round_trip() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for robot in robots() {
        let n = robot.n();
        let mut ws = Scratch::new(n);
        for _ in 0..200 {
            let (q, qd, tau) = random_state(&mut rng, n);
            let mut qdd = vec![0.0; n];
            robot.forward_dynamics_into(&mut ws, &q, &qd, &tau, &mut qdd);
            let mut gen = vec![0.0; n];
            robot.inverse_dynamics_into(&mut ws, &q, &qd, &qdd, &mut gen);
            assert!(gen[0].abs() < 1e-10, "passive joint force {}", gen[0]);
            for j in 0..n - 1 {
                assert!((gen[j + 1] - tau[j]).abs() < 1e-10);
            }
        }
    }
}

/// Kinetic energy computed independently of M: COM velocities by differentiating the COM positions
/// along qd (dual numbers), link angular velocities as sums of joint rates.
fn kinetic_energy_independent(robot: &Robot, q: &[f64], qd: &[f64]) -> f64 {
    let n = robot.n();
    let qdual: Vec<Dual64> = q.iter().zip(qd).map(|(&a, &b)| Dual64::new(a, b)).collect();
    let mut coms = vec![[Dual64::from(0.0); 2]; n];
    robot.com_positions(&qdual, &mut coms);
    let mut e = 0.0;
    let mut w = 0.0;
    for i in 0..n {
        w += qd[i];
        let (vx, vy) = (coms[i][0].eps, coms[i][1].eps);
        e += 0.5 * robot.masses()[i] * (vx * vx + vy * vy) + 0.5 * robot.inertias()[i] * w * w;
    }
    e
}

fn potential_energy_independent<T: brachia::math::Scalar>(robot: &Robot, q: &[T]) -> T {
    let mut coms = vec![[T::zero(); 2]; robot.n()];
    robot.com_positions(q, &mut coms);
    (0..robot.n())
        .map(|i| coms[i][1] * (robot.masses()[i] * robot.gravity))
        .sum()
}

#[test]
fn mass_matrix_and_gravity_match_energy_functions() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for robot in robots() {
        let n = robot.n();
        let mut ws = Scratch::new(n);
        for _ in 0..100 {
            let (q, _, _) = random_state(&mut rng, n);
            let m = robot.mass_matrix(&q);
            // KE is a quadratic form in qd: recover M from it exactly.
            let e = |i: usize| {
                let mut v = vec![0.0; n];
                v[i] = 1.0;
                v
            };
            for i in 0..n {
                let mii = 2.0 * kinetic_energy_independent(&robot, &q, &e(i));
                assert!((mii - m[i * n + i]).abs() < 1e-10, "M[{i}][{i}]");
                for j in 0..i {
                    let mut v = e(i);
                    v[j] = 1.0;
                    let mij = kinetic_energy_independent(&robot, &q, &v)
                        - kinetic_energy_independent(&robot, &q, &e(i))
                        - kinetic_energy_independent(&robot, &q, &e(j));
                    assert!((mij - m[i * n + j]).abs() < 1e-10, "M[{i}][{j}]");
                }
            }
            // G = dV/dq by dual numbers on the independent potential.
            let mut g = vec![0.0; n];
            robot.gravity_into(&mut ws, &q, &mut g);
            for i in 0..n {
                let qd: Vec<Dual64> = (0..n)
                    .map(|k| Dual64::new(q[k], if k == i { 1.0 } else { 0.0 }))
                    .collect();
                let dv = potential_energy_independent(&robot, &qd).eps;
                assert!((dv - g[i]).abs() < 1e-10, "G[{i}]: {dv} vs {}", g[i]);
            }
            let v1: f64 = potential_energy_independent(&robot, &q);
            assert!((v1 - robot.potential_energy(&q)).abs() < 1e-10);
        }
    }
}

#[test]
fn coriolis_matches_lagrange_equations() {
    // C(q, qd) qd = Mdot qd - dT/dq, with Mdot and dT/dq by dual numbers on M and the independent T.
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for robot in robots() {
        let n = robot.n();
        let mut wsd = Scratch::<Dual64>::new(n);
        let mut ws = Scratch::<f64>::new(n);
        for _ in 0..100 {
            let (q, qd, _) = random_state(&mut rng, n);
            let qdual: Vec<Dual64> = q
                .iter()
                .zip(&qd)
                .map(|(&a, &b)| Dual64::new(a, b))
                .collect();
            let mut md = vec![Dual64::from(0.0); n * n];
            robot.mass_matrix_into(&mut wsd, &qdual, &mut md);
            let mut cq = vec![0.0; n];
            robot.coriolis_into(&mut ws, &q, &qd, &mut cq);
            let ke = |q: &[f64]| kinetic_energy_independent(&robot, q, &qd);
            for i in 0..n {
                let mdot_qd: f64 = (0..n).map(|j| md[i * n + j].eps * qd[j]).sum();
                let h = 1e-6;
                let (mut qp, mut qm) = (q.clone(), q.clone());
                qp[i] += h;
                qm[i] -= h;
                let dtdq = (ke(&qp) - ke(&qm)) / (2.0 * h);
                let want = mdot_qd - dtdq;
                assert!(
                    (want - cq[i]).abs() < 1e-6 * want.abs().max(1.0),
                    "Cqd[{i}]: {want} vs {}",
                    cq[i]
                );
            }
        }
    }
}

#[test]
fn passive_swing_conserves_energy_for_ten_seconds() {
    let robot = Robot::paper();
    let mut rk4 = Rk4::new(&robot);
    let mut x = [PAPER_Q0.as_slice(), &[0.0; 4]].concat();
    let e0 = robot.energy(&x[..4], &x[4..]);
    let mut worst: f64 = 0.0;
    for _ in 0..10_000 {
        rk4.step(&robot, &mut x, &[0.0; 3], 1e-3);
        let e = robot.energy(&x[..4], &x[4..]);
        worst = worst.max(((e - e0) / e0).abs());
    }
    assert!(worst < 1e-6, "relative energy drift {worst:e}");
    // the chain really swung: link 1 moved far from its start
    assert!((x[0] - PAPER_Q0[0]).abs() > 0.1 || x[4].abs() > 0.1);
}

#[test]
fn dynamics_jacobian_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for robot in robots() {
        let n = robot.n();
        let f = DynamicsFn::new(robot.clone());
        let mut diff = Diff::new(&f);
        for _ in 0..20 {
            let (q, qd, tau) = random_state(&mut rng, n);
            let z = [q, qd, tau].concat();
            let mut out = vec![0.0; n];
            let mut jac = vec![0.0; n * f.n_in()];
            diff.jacobian(&f, &z, &mut out, &mut jac);
            assert_jacobian("d qdd / d [q, qd, tau]", as_f64_fn(&f), &z, &jac, 1e-6);
        }
    }
}

#[test]
fn dynamics_weighted_hessian_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(6);
    for robot in robots() {
        let n = robot.n();
        let f = DynamicsFn::new(robot.clone());
        let nz = f.n_in();
        let mut diff = Diff::new(&f);
        for _ in 0..10 {
            let (q, qd, tau) = random_state(&mut rng, n);
            let z = [q, qd, tau].concat();
            let w: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let mut hess = vec![0.0; nz * nz];
            diff.hessian_weighted(&f, &z, &w, &mut hess);
            // exact gradient of w . qdd, differentiated numerically
            let mut gdiff = Diff::new(&f);
            let grad = |z: &[f64], g: &mut [f64]| {
                let mut out = vec![0.0; n];
                let mut jac = vec![0.0; n * nz];
                gdiff.jacobian(&f, z, &mut out, &mut jac);
                for j in 0..nz {
                    g[j] = (0..n).map(|i| w[i] * jac[i * nz + j]).sum();
                }
            };
            assert_hessian("Hessian of w . qdd", grad, &z, &hess, 1e-5);
        }
    }
}

#[test]
fn ee_jacobian_and_jdot_match_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    for robot in robots() {
        let n = robot.n();
        for _ in 0..20 {
            let (q, qd, _) = random_state(&mut rng, n);
            let mut jac = vec![0.0; 2 * n];
            robot.ee_jacobian(&q, &mut jac);
            let fk = |q: &[f64], out: &mut [f64]| out.copy_from_slice(&robot.ee_position(q));
            assert_jacobian("EE Jacobian", fk, &q, &jac, 1e-7);
            // J qd equals the EE velocity
            let v = robot.ee_velocity(&q, &qd);
            for r in 0..2 {
                let jv: f64 = (0..n).map(|j| jac[r * n + j] * qd[j]).sum();
                assert!((jv - v[r]).abs() < 1e-12);
            }
            // Jdot qd = d/ds [J(q + s qd) qd] at s = 0
            let jdq = robot.ee_jdot_qd(&q, &qd);
            let vel = |s: &[f64], out: &mut [f64]| {
                let qs: Vec<f64> = q.iter().zip(&qd).map(|(a, b)| a + s[0] * b).collect();
                out.copy_from_slice(&robot.ee_velocity(&qs, &qd));
            };
            assert_jacobian("Jdot qd", vel, &[0.0], &jdq, 1e-7);
        }
    }
}

#[test]
fn linearization_matches_finite_differences_of_f() {
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    for robot in robots() {
        let n = robot.n();
        let (nx, nu) = (2 * n, n - 1);
        let mut lin = Linearizer::new(robot.clone());
        let mut model = LinearModel::zeros(n);
        for _ in 0..10 {
            let (q, qd, tau) = random_state(&mut rng, n);
            let x = [q, qd].concat();
            lin.linearize_into(&x, &tau, &mut model);
            let mut rk = Rk4::new(&robot);
            let fx = |xx: &[f64], out: &mut [f64]| rk.deriv(&robot, xx, &tau, out);
            assert_jacobian("A", fx, &x, &model.a, 1e-6);
            let mut rk = Rk4::new(&robot);
            let fu = |uu: &[f64], out: &mut [f64]| rk.deriv(&robot, &x, uu, out);
            assert_jacobian("B", fu, &tau, &model.b, 1e-6);
            // the affine model reproduces f at the linearisation point
            let mut f0 = vec![0.0; nx];
            Rk4::new(&robot).deriv(&robot, &x, &tau, &mut f0);
            for i in 0..nx {
                let ax: f64 = (0..nx).map(|j| model.a[i * nx + j] * x[j]).sum();
                let bu: f64 = (0..nu).map(|j| model.b[i * nu + j] * tau[j]).sum();
                assert!((ax + bu + model.f[i] - f0[i]).abs() < 1e-9);
            }
            let ee = robot.ee_position(&x[..n]);
            for r in 0..2 {
                let cx: f64 = (0..nx).map(|j| model.c[r * nx + j] * x[j]).sum();
                assert!((cx + model.fy[r] - ee[r]).abs() < 1e-12);
            }
        }
    }
}

#[test]
fn invalid_parameters_name_file_field_and_value() {
    let good = include_str!("../../../params/paper.toml");
    let cases = [
        ("mass = 0.56", "mass = -0.56", "links[1].mass"),
        ("com = 0.2059", "com = 0.5", "links[0].com"),
        ("length = 0.355", "length = nan", "links[0].length"),
        (
            "tau_max = [5.0, 5.0, 5.0]",
            "tau_max = [5.0, 5.0]",
            "actuators.tau_max",
        ),
        (
            "tau_min = [-5.0, -5.0, -5.0]",
            "tau_min = [6.0, -5.0, -5.0]",
            "tau_min[0]",
        ),
    ];
    for (from, to, field) in cases {
        let text = good.replacen(from, to, 1);
        let p = RobotParams::from_toml_str(&text, "bad.toml").unwrap();
        let err = Robot::from_params(p, "bad.toml").unwrap_err().to_string();
        assert!(err.contains("bad.toml") && err.contains(field), "{err}");
    }
    let err = RobotParams::from_toml_str("links = 3", "x.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("x.toml"), "{err}");
    let err = RobotParams::from_toml_str(&good.replace("mass =", "masss ="), "y.toml")
        .unwrap_err()
        .to_string();
    assert!(err.contains("y.toml") && err.contains("masss"), "{err}");
}
