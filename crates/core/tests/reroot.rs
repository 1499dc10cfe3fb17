//! The grasp switch map (brachia::model::reroot): the chain re-rooted at its swing hand.
//!
//! Conventions: q[0] absolute angle of link 1 from +x, q[1..] relative; x = [q, qd]; tau of joints 2..n;
//! world frame x right, y up, gravity along -y; SI units.
//!
//! What is proven here: the map is an involution (states, parameters, grips); it keeps every world point
//! of the chain where it is; with the EE at rest it keeps the world velocities and the energy; the
//! re-rooted chain's mass matrix is the EE-pinned chain's, transformed by the map's constant linear part
//! (`M_pinned = P^T M' P`), computed independently from link velocities relative to the pinned EE; and the
//! re-rooted chain's dynamics reproduce, to 1e-9 m in world coordinates, the motion of the original chain
//! with its EE pinned and its old grip free, integrated from an independent Lagrangian (exact second
//! derivatives by hyper-dual numbers), on a symmetric, an asymmetric, a 3-link and a 5-link robot.

use brachia::ad::{Diff, LocalFn};
use brachia::integrate::Rk4;
use brachia::math::{c, Scalar};
use brachia::model::{reroot_state, reroot_tau, switch_grip, Robot, P2};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn robots() -> Vec<Robot> {
    let paper = Robot::paper();
    // asymmetric: link 1 differs from link n in length, mass, com, inertia, and torque limits differ
    let mut p = paper.params().clone();
    p.links[0].length = 0.42;
    p.links[0].com = 0.12;
    p.links[0].mass = 0.6;
    p.links[3].inertia = 0.05;
    p.links[2].com = 0.3;
    p.actuators.tau_min = vec![-3.0, -5.0, -7.0];
    p.actuators.tau_max = vec![4.0, 6.0, 8.0];
    let asym = Robot::from_params(p, "asymmetric").unwrap();
    let mut p3 = paper.params().clone();
    p3.links.truncate(3);
    p3.links[2].com = 0.1;
    p3.actuators.tau_min = vec![-5.0, -2.0];
    p3.actuators.tau_max = vec![5.0, 3.0];
    let three = Robot::from_params(p3, "three").unwrap();
    let mut p5 = paper.params().clone();
    let extra = p5.links[1].clone();
    p5.links.insert(2, extra);
    p5.links[4].mass = 0.9;
    p5.actuators.tau_min = vec![-5.0; 4];
    p5.actuators.tau_max = vec![5.0; 4];
    let five = Robot::from_params(p5, "five").unwrap();
    vec![paper, asym, three, five]
}

fn random_x(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    let mut x: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.5..2.5)).collect();
    x[0] = rng.gen_range(-3.0..0.0);
    x.extend((0..n).map(|_| rng.gen_range(-2.0..2.0)));
    x
}

/// World joint positions of `robot` gripping at `grip`: n + 1 points, grip first, EE last.
fn world_joints(robot: &Robot, grip: P2<f64>, q: &[f64]) -> Vec<P2<f64>> {
    let mut p = vec![[0.0; 2]; robot.n() + 1];
    robot.joint_positions(q, &mut p);
    p.iter().map(|v| [v[0] + grip[0], v[1] + grip[1]]).collect()
}

/// Project `qd` onto the null space of the EE Jacobian (the EE at rest).
fn ee_at_rest(robot: &Robot, q: &[f64], qd: &mut [f64]) {
    let n = robot.n();
    let mut j = vec![0.0; 2 * n];
    robot.ee_jacobian(q, &mut j);
    let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
    let (a00, a01, a11) = (
        dot(&j[..n], &j[..n]),
        dot(&j[..n], &j[n..]),
        dot(&j[n..], &j[n..]),
    );
    let v = [dot(&j[..n], qd), dot(&j[n..], qd)];
    let det = a00 * a11 - a01 * a01;
    let y = [
        (a11 * v[0] - a01 * v[1]) / det,
        (a00 * v[1] - a01 * v[0]) / det,
    ];
    for i in 0..n {
        qd[i] -= j[i] * y[0] + j[n + i] * y[1];
    }
}

#[test]
fn the_map_applied_twice_is_the_identity() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for robot in robots() {
        let n = robot.n();
        let back = robot.rerooted().unwrap().rerooted().unwrap();
        for (a, b) in robot.params().links.iter().zip(&back.params().links) {
            assert_eq!(a.length, b.length);
            assert_eq!(a.mass, b.mass);
            assert_eq!(a.inertia, b.inertia);
            assert!((a.com - b.com).abs() < 1e-15, "{} vs {}", a.com, b.com);
        }
        assert_eq!(robot.params().actuators, back.params().actuators);
        let r1 = robot.rerooted().unwrap();
        for _ in 0..50 {
            let x = random_x(&mut rng, n);
            let (mut x1, mut x2) = (vec![0.0; 2 * n], vec![0.0; 2 * n]);
            reroot_state(&x, &mut x1);
            reroot_state(&x1, &mut x2);
            for (a, b) in x.iter().zip(&x2) {
                assert!((a - b).abs() < 1e-12, "{x:?} -> {x2:?}");
            }
            // the grip: there and back
            let mut xr = x.clone();
            ee_at_rest(&robot, &x[..n], &mut xr[n..]);
            let g0 = [0.3, -0.1];
            let s1 = switch_grip(&robot, g0, &xr).unwrap();
            let s2 = switch_grip(&r1, s1.grip, &s1.x).unwrap();
            assert!((s2.grip[0] - g0[0]).abs() < 1e-12 && (s2.grip[1] - g0[1]).abs() < 1e-12);
            let tau: Vec<f64> = (0..n - 1).map(|_| rng.gen_range(-5.0..5.0)).collect();
            let (mut t1, mut t2) = (vec![0.0; n - 1], vec![0.0; n - 1]);
            reroot_tau(&tau, &mut t1);
            reroot_tau(&t1, &mut t2);
            assert_eq!(tau, t2);
            // power is unchanged
            let p0: f64 = (0..n - 1).map(|j| tau[j] * x[n + 1 + j]).sum();
            let p1: f64 = (0..n - 1).map(|j| t1[j] * x1[n + 1 + j]).sum();
            assert!((p0 - p1).abs() < 1e-12);
        }
    }
}

#[test]
fn the_rerooted_chain_keeps_every_world_point_and_with_the_ee_at_rest_every_velocity_and_the_energy(
) {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    for robot in robots() {
        let n = robot.n();
        let r = robot.rerooted().unwrap();
        for _ in 0..50 {
            let mut x = random_x(&mut rng, n);
            let grip = [rng.gen_range(-1.0..1.0), rng.gen_range(-0.3..0.3)];
            let (q, qd) = x.split_at_mut(n);
            ee_at_rest(&robot, q, qd);
            let s = switch_grip(&robot, grip, &x).unwrap();
            assert!(s.ee_speed < 1e-12 && s.impact_energy_j.abs() < 1e-12);
            let mut xm = vec![0.0; 2 * n];
            reroot_state(&x, &mut xm);
            for (a, b) in s.x.iter().zip(&xm) {
                assert!(
                    (a - b).abs() < 1e-12,
                    "with the EE at rest the switch is the bare map"
                );
            }
            let (q, qd) = x.split_at(n);
            let (qr, qdr) = s.x.split_at(n);
            let pw = world_joints(&robot, grip, q);
            let pr = world_joints(&r, s.grip, qr);
            for j in 0..=n {
                let (a, b) = (pw[j], pr[n - j]);
                assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12);
            }
            // centres of mass coincide too (com measured from the other end)
            let (mut cw, mut cr) = (vec![[0.0; 2]; n], vec![[0.0; 2]; n]);
            robot.com_positions(q, &mut cw);
            r.com_positions(qr, &mut cr);
            for i in 0..n {
                let (a, b) = (cw[i], cr[n - 1 - i]);
                assert!((a[0] + grip[0] - b[0] - s.grip[0]).abs() < 1e-12);
                assert!((a[1] + grip[1] - b[1] - s.grip[1]).abs() < 1e-12);
            }
            // the old grip is the new EE, at rest; world energy is kept
            let v = r.ee_velocity(qr, qdr);
            assert!(v[0].hypot(v[1]) < 1e-12);
            let mg = robot.total_mass() * robot.gravity;
            let e0 = robot.energy(q, qd) + mg * grip[1];
            let e1 = r.energy(qr, qdr) + mg * s.grip[1];
            assert!((e0 - e1).abs() < 1e-10 * (1.0 + e0.abs()), "{e0} vs {e1}");
        }
    }
}

#[test]
fn a_moving_hand_is_stopped_by_the_capture_impulse_and_the_lost_energy_is_reported() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for robot in robots() {
        let n = robot.n();
        let r = robot.rerooted().unwrap();
        for _ in 0..20 {
            let x = random_x(&mut rng, n);
            let (q, qd) = x.split_at(n);
            let v = robot.ee_velocity(q, qd);
            let s = switch_grip(&robot, [0.0, 0.0], &x).unwrap();
            assert!((s.ee_speed - v[0].hypot(v[1])).abs() < 1e-15);
            let (qr, qdr) = s.x.split_at(n);
            // after the impulse the old grip (now the EE) and the new grip are both at rest
            let ve = r.ee_velocity(qr, qdr);
            assert!(ve[0].hypot(ve[1]) < 1e-9, "{ve:?}");
            let mg = robot.total_mass() * robot.gravity;
            let e0 = robot.energy(q, qd);
            let e1 = r.energy(qr, qdr) + mg * s.grip[1];
            assert!(s.impact_energy_j >= 0.0);
            assert!(
                (e0 - e1 - s.impact_energy_j).abs() < 1e-9 * (1.0 + e0.abs()),
                "lost {} J, reported {} J",
                e0 - e1,
                s.impact_energy_j
            );
        }
    }
}

/// The Lagrangian of the original chain with its EE pinned at `pin` (world) and its grip free, in the
/// original coordinates: `z = [q, qd]`, one output `L = T - V`. Written from the link velocities relative
/// to the pinned EE, independently of the model's mass-matrix coefficients.
struct PinnedEe<'a> {
    robot: &'a Robot,
    pin: P2<f64>,
}

impl LocalFn for PinnedEe<'_> {
    type Scratch<T: Scalar> = ();
    fn n_in(&self) -> usize {
        2 * self.robot.n()
    }
    fn n_out(&self) -> usize {
        1
    }
    fn scratch<T: Scalar>(&self) -> Self::Scratch<T> {}
    fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
        let r = self.robot;
        let n = r.n();
        let (mut th, mut thd) = (T::zero(), T::zero());
        let (mut p, mut v) = ([T::zero(); 2], [T::zero(); 2]);
        let mut com = Vec::with_capacity(n);
        let mut vcom = Vec::with_capacity(n);
        let mut rot = T::zero();
        for i in 0..n {
            th += z[i];
            thd += z[n + i];
            let (s, co) = th.sin_cos();
            com.push([p[0] + co * r.coms()[i], p[1] + s * r.coms()[i]]);
            vcom.push([v[0] - s * thd * r.coms()[i], v[1] + co * thd * r.coms()[i]]);
            p = [p[0] + co * r.lengths()[i], p[1] + s * r.lengths()[i]];
            v = [
                v[0] - s * thd * r.lengths()[i],
                v[1] + co * thd * r.lengths()[i],
            ];
            rot += thd * thd * r.inertias()[i];
        }
        let mut ke = rot * 0.5;
        let mut pe = T::zero();
        for i in 0..n {
            let (vx, vy) = (vcom[i][0] - v[0], vcom[i][1] - v[1]);
            ke += (vx * vx + vy * vy) * (0.5 * r.masses()[i]);
            let y = com[i][1] - p[1] + c::<T>(self.pin[1]);
            pe += y * (r.masses()[i] * r.gravity);
        }
        out[0] = ke - pe;
    }
}

/// `xdot` of the EE-pinned chain from its Lagrangian: `M qdd = B tau + dL/dq - (d2L/dqd dq) qd` with
/// `M = d2L/dqd2`.
fn pinned_deriv<'a>(
    f: &PinnedEe<'a>,
    d: &mut Diff<PinnedEe<'a>>,
    x: &[f64],
    tau: &[f64],
    out: &mut [f64],
) {
    let n = f.robot.n();
    let nz = 2 * n;
    let mut h = vec![0.0; nz * nz];
    let mut g = vec![0.0; nz];
    let mut l = [0.0];
    d.hessian_weighted(f, x, &[1.0], &mut h);
    d.jacobian(f, x, &mut l, &mut g);
    let mut m = vec![0.0; n * n];
    let mut rhs = vec![0.0; n];
    for i in 0..n {
        rhs[i] = g[i] + if i > 0 { tau[i - 1] } else { 0.0 };
        for k in 0..n {
            m[i * n + k] = h[(n + i) * nz + n + k];
            rhs[i] -= h[(n + i) * nz + k] * x[n + k];
        }
    }
    brachia_linalg::cholesky_solve_in_place(
        &mut m,
        n,
        &mut rhs,
        brachia_linalg::Scaling::Reciprocal,
        brachia_linalg::Scaling::Divide,
    )
    .expect("M is SPD");
    out[..n].copy_from_slice(&x[n..]);
    out[n..].copy_from_slice(&rhs);
}

#[test]
fn the_rerooted_mass_matrix_is_the_ee_pinned_chains_transformed_by_the_map() {
    let mut rng = ChaCha8Rng::seed_from_u64(4);
    for robot in robots() {
        let n = robot.n();
        let r = robot.rerooted().unwrap();
        let f = PinnedEe {
            robot: &robot,
            pin: [0.0, 0.0],
        };
        let mut d = Diff::new(&f);
        // P: qd' = P qd
        let mut p = vec![0.0; n * n];
        for k in 0..n {
            let mut e = vec![0.0; 2 * n];
            e[n + k] = 1.0;
            let mut o = vec![0.0; 2 * n];
            reroot_state(&e, &mut o);
            for i in 0..n {
                p[i * n + k] = o[n + i];
            }
        }
        for _ in 0..20 {
            let x = random_x(&mut rng, n);
            let mut h = vec![0.0; 4 * n * n];
            d.hessian_weighted(&f, &x, &[1.0], &mut h);
            let mut xr = vec![0.0; 2 * n];
            reroot_state(&x, &mut xr);
            let mr = r.mass_matrix(&xr[..n]);
            for i in 0..n {
                for k in 0..n {
                    let ptmp: f64 = (0..n)
                        .flat_map(|a| (0..n).map(move |b| (a, b)))
                        .map(|(a, b)| p[a * n + i] * mr[a * n + b] * p[b * n + k])
                        .sum();
                    let pinned = h[(n + i) * 2 * n + n + k];
                    assert!(
                        (ptmp - pinned).abs() < 1e-12 * (1.0 + pinned.abs()),
                        "{}: M[{i}][{k}] {pinned} vs {ptmp}",
                        robot.params().name
                    );
                }
            }
        }
    }
}

#[test]
fn the_rerooted_dynamics_reproduce_the_ee_pinned_chains_motion_in_world_coordinates() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for robot in robots() {
        let n = robot.n();
        let r = robot.rerooted().unwrap();
        let x = random_x(&mut rng, n);
        let grip = [0.0, 0.0];
        let pin = {
            let e = robot.ee_position(&x[..n]);
            [grip[0] + e[0], grip[1] + e[1]]
        };
        let f = PinnedEe { robot: &robot, pin };
        let mut d = Diff::new(&f);
        let mut xo = x.clone();
        let mut xr = vec![0.0; 2 * n];
        reroot_state(&x, &mut xr);
        let mut rk = Rk4::new(&r);
        let dt = 1e-3;
        let (mut tau, mut taur) = (vec![0.0; n - 1], vec![0.0; n - 1]);
        let mut worst: f64 = 0.0;
        let nx = 2 * n;
        let (mut k1, mut k2, mut k3, mut k4, mut tmp) = (
            vec![0.0; nx],
            vec![0.0; nx],
            vec![0.0; nx],
            vec![0.0; nx],
            vec![0.0; nx],
        );
        for step in 0..400 {
            let t = step as f64 * dt;
            for (j, v) in tau.iter_mut().enumerate() {
                *v = 0.8 * (3.0 * t + j as f64).sin();
            }
            reroot_tau(&tau, &mut taur);
            // RK4 on the pinned Lagrangian
            pinned_deriv(&f, &mut d, &xo, &tau, &mut k1);
            for i in 0..nx {
                tmp[i] = xo[i] + 0.5 * dt * k1[i];
            }
            pinned_deriv(&f, &mut d, &tmp, &tau, &mut k2);
            for i in 0..nx {
                tmp[i] = xo[i] + 0.5 * dt * k2[i];
            }
            pinned_deriv(&f, &mut d, &tmp, &tau, &mut k3);
            for i in 0..nx {
                tmp[i] = xo[i] + dt * k3[i];
            }
            pinned_deriv(&f, &mut d, &tmp, &tau, &mut k4);
            for i in 0..nx {
                xo[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            rk.step(&r, &mut xr, &taur, dt);
            // world joints: the pinned chain's base is pin - ee(q)
            let e = robot.ee_position(&xo[..n]);
            let base = [pin[0] - e[0], pin[1] - e[1]];
            let pw = world_joints(&robot, base, &xo[..n]);
            let pr = world_joints(&r, pin, &xr[..n]);
            for j in 0..=n {
                let (a, b) = (pw[j], pr[n - j]);
                worst = worst.max((a[0] - b[0]).hypot(a[1] - b[1]));
            }
        }
        // the chain really moved
        let moved: f64 = (0..n).map(|i| (xo[i] - x[i]).abs()).fold(0.0, f64::max);
        assert!(moved > 0.05, "{}: moved {moved}", robot.params().name);
        assert!(
            worst < 1e-9,
            "{}: world positions differ by {worst:.3e} m",
            robot.params().name
        );
    }
}
