//! The generalised robot model: centres of mass off the links' axes, an end effector anywhere in the
//! last link's frame, joint angle offsets and reversals, joint limits and links of zero length.
//!
//! - Every parameters file under `params/` gives exactly the mass matrix, Coriolis and gravity forces
//!   of the ideal chain's formulas (re-derived here), bit for bit, at random states.
//! - A generalised robot's M, C qd and G agree with an independent construction from the centres of
//!   mass (`M = sum m Jc^T Jc + I Jw^T Jw`, G the gradient of the potential, C qd from the
//!   Christoffel symbols), with Jacobians by automatic differentiation of the kinematics.
//! - Its closed-form derivatives agree with AD and with finite differences (`brachia::fdcheck`).
//! - The end effector's Jacobian, velocity and `Jdot qd` agree with AD of its position.
//!
//! Conventions: `q[0]` absolute, `q[1..]` relative (rad), z = [q, qd, tau].

use brachia::ad::{as_f64_fn, Diff};
use brachia::fdcheck::{assert_hessian, assert_jacobian};
use brachia::math::{Dual64, HyperDual64};
use brachia::model::{DynamicsDerivatives, DynamicsFn, LinkParams, Robot, RobotParams, Scratch};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::Path;

/// A three-link robot with every generalised field set, a zero-length link in the middle
/// (`tests/data/general.toml`).
fn general_robot() -> Robot {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/general.toml");
    Robot::from_toml_file(&path).unwrap()
}

fn random_q(rng: &mut ChaCha8Rng, n: usize, scale: f64) -> Vec<f64> {
    (0..n).map(|_| rng.gen_range(-scale..scale)).collect()
}

/// The ideal chain's M, C qd and G with the formulas of the paper's model (coefficients `d`, `g`
/// in absolute angles, mapped by `S`), in the model's order of operations.
fn ideal_formulas(robot: &Robot, q: &[f64], qd: &[f64]) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let n = robot.n();
    let (len, mass, com, inertia) = (
        robot.lengths(),
        robot.masses(),
        robot.coms(),
        robot.inertias(),
    );
    let distal: Vec<f64> = (0..n).map(|j| mass[j + 1..].iter().sum()).collect();
    let mut d = vec![0.0; n * n];
    for j in 0..n {
        d[j * n + j] = mass[j] * com[j] * com[j] + len[j] * len[j] * distal[j] + inertia[j];
        for k in j + 1..n {
            let v = len[j] * (mass[k] * com[k] + len[k] * distal[k]);
            d[j * n + k] = v;
            d[k * n + j] = v;
        }
    }
    let g: Vec<f64> = (0..n)
        .map(|j| robot.gravity() * (mass[j] * com[j] + len[j] * distal[j]))
        .collect();
    let (mut sn, mut co, mut thd) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let (mut th, mut w) = (0.0, 0.0);
    for i in 0..n {
        th += q[i];
        w += qd[i];
        (sn[i], co[i]) = th.sin_cos();
        thd[i] = w;
    }
    let mut mabs = vec![0.0; n * n];
    for j in 0..n {
        mabs[j * n + j] = d[j * n + j];
        for k in j + 1..n {
            let v = (co[j] * co[k] + sn[j] * sn[k]) * d[j * n + k];
            mabs[j * n + k] = v;
            mabs[k * n + j] = v;
        }
    }
    for i in 0..n {
        let mut acc = 0.0;
        for l in (0..n).rev() {
            acc += mabs[i * n + l];
            mabs[i * n + l] = acc;
        }
    }
    let mut m = vec![0.0; n * n];
    for l in 0..n {
        let mut acc = 0.0;
        for r in (0..n).rev() {
            acc += mabs[r * n + l];
            m[r * n + l] = acc;
        }
    }
    let suffix = |h: Vec<f64>| {
        let mut out = vec![0.0; n];
        let mut acc = 0.0;
        for l in (0..n).rev() {
            acc += h[l];
            out[l] = acc;
        }
        out
    };
    let cqd = suffix(
        (0..n)
            .map(|j| {
                let mut v = 0.0;
                for k in 0..n {
                    if k != j {
                        let sjk = sn[j] * co[k] - co[j] * sn[k];
                        v += sjk * thd[k] * thd[k] * d[j * n + k];
                    }
                }
                v
            })
            .collect(),
    );
    let grav = suffix((0..n).map(|j| 0.0 + co[j] * g[j]).collect());
    (m, cqd, grav)
}

#[test]
fn every_params_file_gives_the_ideal_chain_bit_for_bit() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../params");
    let mut files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    assert!(files.len() >= 5, "params files: {files:?}");
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for f in files {
        let robot = Robot::from_toml_file(&f).unwrap();
        assert!(robot.is_ideal_chain(), "{}", f.display());
        let n = robot.n();
        let mut ws = Scratch::<f64>::new(n);
        let (mut m, mut c, mut g) = (vec![0.0; n * n], vec![0.0; n], vec![0.0; n]);
        for _ in 0..50 {
            let q = random_q(&mut rng, n, 3.2);
            let qd = random_q(&mut rng, n, 5.0);
            robot.mass_matrix_into(&mut ws, &q, &mut m);
            robot.coriolis_into(&mut ws, &q, &qd, &mut c);
            robot.gravity_into(&mut ws, &q, &mut g);
            let (m0, c0, g0) = ideal_formulas(&robot, &q, &qd);
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&m), bits(&m0), "M of {}", f.display());
            assert_eq!(bits(&c), bits(&c0), "C qd of {}", f.display());
            assert_eq!(bits(&g), bits(&g0), "G of {}", f.display());
        }
    }
}

/// Jacobian (2 x n, row-major) of the centre of mass of link `i` by AD of `com_positions`.
fn com_jacobian(robot: &Robot, q: &[f64], i: usize) -> Vec<f64> {
    let n = robot.n();
    let mut jac = vec![0.0; 2 * n];
    for j in 0..n {
        let qd: Vec<Dual64> = (0..n)
            .map(|k| Dual64::new(q[k], if k == j { 1.0 } else { 0.0 }))
            .collect();
        let mut out = vec![[Dual64::from(0.0); 2]; n];
        robot.com_positions(&qd, &mut out);
        jac[j] = out[i][0].eps;
        jac[n + j] = out[i][1].eps;
    }
    jac
}

/// M from the centres of mass: `sum_i m_i Jc_i^T Jc_i + I_i Jw_i^T Jw_i` (`Jw_i` ones up to i).
fn mass_matrix_from_coms(robot: &Robot, q: &[f64]) -> Vec<f64> {
    let n = robot.n();
    let mut m = vec![0.0; n * n];
    for i in 0..n {
        let jc = com_jacobian(robot, q, i);
        for a in 0..n {
            for b in 0..n {
                let lin = jc[a] * jc[b] + jc[n + a] * jc[n + b];
                let rot = if a <= i && b <= i { 1.0 } else { 0.0 };
                m[a * n + b] += robot.masses()[i] * lin + robot.inertias()[i] * rot;
            }
        }
    }
    m
}

fn max_rel(a: &[f64], b: &[f64]) -> f64 {
    let scale = b.iter().fold(1e-12f64, |m, v| m.max(v.abs()));
    a.iter().zip(b).fold(0f64, |m, (x, y)| m.max((x - y).abs())) / scale
}

#[test]
fn general_model_matches_the_centres_of_mass() {
    let robot = general_robot();
    assert!(!robot.is_ideal_chain());
    let n = robot.n();
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut ws = Scratch::<f64>::new(n);
    let mut wsd = Scratch::<Dual64>::new(n);
    for _ in 0..30 {
        let q = random_q(&mut rng, n, 3.0);
        let qd = random_q(&mut rng, n, 4.0);
        let m = robot.mass_matrix(&q);
        let mref = mass_matrix_from_coms(&robot, &q);
        assert!(max_rel(&m, &mref) < 1e-12, "M {m:?} vs {mref:?}");
        // G: the gradient of the potential (AD), and from the centres of mass
        let mut g = vec![0.0; n];
        robot.gravity_into(&mut ws, &q, &mut g);
        let mut gref = vec![0.0; n];
        for j in 0..n {
            let qv: Vec<Dual64> = (0..n)
                .map(|k| Dual64::new(q[k], if k == j { 1.0 } else { 0.0 }))
                .collect();
            gref[j] = robot.potential_energy(&qv).eps;
        }
        assert!(max_rel(&g, &gref) < 1e-12, "G {g:?} vs {gref:?}");
        let mut gcom = vec![0.0; n];
        for i in 0..n {
            let jc = com_jacobian(&robot, &q, i);
            for j in 0..n {
                gcom[j] += robot.masses()[i] * robot.gravity() * jc[n + j];
            }
        }
        assert!(max_rel(&g, &gcom) < 1e-12, "G {g:?} vs {gcom:?}");
        // C qd_i = sum_jk (dM_ij/dq_k - 1/2 dM_jk/dq_i) qd_j qd_k, dM/dq by AD
        let mut dm = vec![0.0; n * n * n]; // [k][i][j]
        let mut md = vec![Dual64::from(0.0); n * n];
        for k in 0..n {
            let qv: Vec<Dual64> = (0..n)
                .map(|l| Dual64::new(q[l], if l == k { 1.0 } else { 0.0 }))
                .collect();
            robot.mass_matrix_into(&mut wsd, &qv, &mut md);
            for e in 0..n * n {
                dm[k * n * n + e] = md[e].eps;
            }
        }
        let mut cref = vec![0.0; n];
        for i in 0..n {
            for j in 0..n {
                for k in 0..n {
                    cref[i] += (dm[k * n * n + i * n + j] - 0.5 * dm[i * n * n + j * n + k])
                        * qd[j]
                        * qd[k];
                }
            }
        }
        let mut c = vec![0.0; n];
        robot.coriolis_into(&mut ws, &q, &qd, &mut c);
        assert!(max_rel(&c, &cref) < 1e-11, "C qd {c:?} vs {cref:?}");
        // the forward and inverse dynamics are consistent: no torque, no generalised force
        let qdd = robot.forward_dynamics(&q, &qd, &[0.0; 2]);
        let mut pd = vec![0.0; n];
        robot.inverse_dynamics_into(&mut ws, &q, &qd, &qdd, &mut pd);
        assert!(pd.iter().all(|v| v.abs() < 1e-10), "{pd:?}");
    }
}

#[test]
fn general_derivatives_match_ad_and_finite_differences() {
    let robot = general_robot();
    let n = robot.n();
    let nz = 3 * n - 1;
    let f = DynamicsFn::new(robot.clone());
    let mut diff = Diff::new(&f);
    let mut dd = DynamicsDerivatives::new(&robot);
    let mut ws = Scratch::new(n);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    for _ in 0..10 {
        let z: Vec<f64> = (0..nz).map(|_| rng.gen_range(-3.0..3.0)).collect();
        let w: Vec<f64> = (0..n).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let (mut a0, mut a1, mut a2) = (vec![0.0; n], vec![0.0; n], vec![0.0; n]);
        let (mut j0, mut j1) = (vec![0.0; n * nz], vec![0.0; n * nz]);
        let (mut h0, mut h1) = (vec![0.0; nz * nz], vec![0.0; nz * nz]);
        dd.jacobian(&robot, &z, &mut a0, &mut j0);
        diff.jacobian(&f, &z, &mut a1, &mut j1);
        robot.forward_dynamics_into(&mut ws, &z[..n], &z[n..2 * n], &z[2 * n..], &mut a2);
        assert_eq!(
            a0, a2,
            "closed-form qdd is the forward dynamics bit for bit"
        );
        assert!(max_rel(&a0, &a1) < 1e-12);
        assert!(max_rel(&j0, &j1) < 1e-10, "Jacobian vs AD");
        assert_jacobian("general qdd", as_f64_fn(&f), &z, &j0, 1e-6);
        dd.hessian_weighted(&robot, &z, &w, &mut h0);
        diff.hessian_weighted(&f, &z, &w, &mut h1);
        assert!(max_rel(&h0, &h1) < 1e-9, "Hessian vs AD");
        let mut dd2 = DynamicsDerivatives::new(&robot);
        let mut grad = |x: &[f64], out: &mut [f64]| {
            let (mut a, mut jac) = (vec![0.0; n], vec![0.0; n * nz]);
            dd2.jacobian(&robot, x, &mut a, &mut jac);
            for c in 0..nz {
                out[c] = (0..n).map(|i| w[i] * jac[i * nz + c]).sum();
            }
        };
        assert_hessian("general weighted qdd", &mut grad, &z, &h0, 1e-5);
    }
}

#[test]
fn end_effector_kinematics_match_ad() {
    let robot = general_robot();
    let n = robot.n();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for _ in 0..20 {
        let q = random_q(&mut rng, n, 3.0);
        let qd = random_q(&mut rng, n, 3.0);
        let mut jac = vec![0.0; 2 * n];
        robot.ee_jacobian(&q, &mut jac);
        let mut jad = vec![0.0; 2 * n];
        let mut jdot_qd = [0.0; 2];
        for j in 0..n {
            let qv: Vec<Dual64> = (0..n)
                .map(|k| Dual64::new(q[k], if k == j { 1.0 } else { 0.0 }))
                .collect();
            let p = robot.ee_position(&qv);
            jad[j] = p[0].eps;
            jad[n + j] = p[1].eps;
        }
        // Jdot qd = d2 ee / dt2 at qdd = 0: the second directional derivative along qd
        let qh: Vec<HyperDual64> = (0..n)
            .map(|k| HyperDual64::new(q[k], qd[k], qd[k], 0.0))
            .collect();
        let p = robot.ee_position(&qh);
        jdot_qd[0] = p[0].eps1eps2;
        jdot_qd[1] = p[1].eps1eps2;
        assert!(max_rel(&jac, &jad) < 1e-13, "{jac:?} vs {jad:?}");
        let v = robot.ee_velocity(&q, &qd);
        let vref: Vec<f64> = (0..2)
            .map(|r| (0..n).map(|j| jad[r * n + j] * qd[j]).sum())
            .collect();
        assert!(max_rel(&v, &vref) < 1e-13);
        let a = robot.ee_jdot_qd(&q, &qd);
        assert!(max_rel(&a, &jdot_qd) < 1e-12, "{a:?} vs {jdot_qd:?}");
    }
    // the end effector is the stated point of the last link's frame
    let q = [0.4, -0.7, 1.1];
    let mut pts = [[0.0; 2]; 4];
    robot.joint_positions(&q, &mut pts);
    let th: f64 = q.iter().sum();
    let (s, c) = th.sin_cos();
    let [ex, ey] = robot.end_effector();
    let want = [pts[2][0] + c * ex - s * ey, pts[2][1] + s * ex + c * ey];
    let ee = robot.ee_position(&q);
    assert!((ee[0] - want[0]).abs() < 1e-15 && (ee[1] - want[1]).abs() < 1e-15);
    // the zero-length link: joints 2 and 3 coincide
    assert_eq!(pts[1], pts[2]);
}

#[test]
fn joint_angle_maps_are_inverse() {
    let robot = general_robot();
    let q = [0.5, -0.25, 1.0];
    let phi = robot.q_to_joint_angles(&q);
    assert!((phi[0] - (0.5 - 0.3)).abs() < 1e-15);
    assert!((phi[1] - 0.25).abs() < 1e-15, "reversed joint");
    assert!((phi[2] - 2.2).abs() < 1e-15);
    let back = robot.q_from_joint_angles(&phi);
    for i in 0..3 {
        assert!((back[i] - q[i]).abs() < 1e-15);
    }
    assert_eq!(
        robot.qd_to_joint_rates(&[1.0, 2.0, 3.0]),
        vec![1.0, -2.0, 3.0]
    );
}

#[test]
fn off_axis_rerooting_keeps_the_energy() {
    // the end effector at the last joint, centres of mass off the axes: the re-rooted chain at the
    // mapped state (the end effector at rest) has the same kinetic energy, and the same potential
    // energy measured from the same height
    let mut p = general_robot().params().clone();
    p.end_effector = None;
    let robot = Robot::from_params(p, "<test>").unwrap();
    let rr = robot.rerooted().unwrap();
    assert_eq!(rr.coms_across()[0], -robot.coms_across()[2]);
    let n = robot.n();
    let mut rng = ChaCha8Rng::seed_from_u64(21);
    let mut ws = Scratch::<f64>::new(n);
    let mut offset = None;
    for _ in 0..10 {
        let mut x: Vec<f64> = random_q(&mut rng, 2 * n, 2.0);
        // the end effector at rest (the state in which the switch keeps every world velocity):
        // qd projected onto the null space of the EE Jacobian
        let mut jac = vec![0.0; 2 * n];
        robot.ee_jacobian(&x[..n], &mut jac);
        let a = |r: usize, c: usize| (0..n).map(|j| jac[r * n + j] * jac[c * n + j]).sum::<f64>();
        let (a00, a01, a11) = (a(0, 0), a(0, 1), a(1, 1));
        let det = a00 * a11 - a01 * a01;
        let jv = [0, 1].map(|r| (0..n).map(|j| jac[r * n + j] * x[n + j]).sum::<f64>());
        let y = [
            (a11 * jv[0] - a01 * jv[1]) / det,
            (a00 * jv[1] - a01 * jv[0]) / det,
        ];
        for j in 0..n {
            x[n + j] -= jac[j] * y[0] + jac[n + j] * y[1];
        }
        let v = robot.ee_velocity(&x[..n], &x[n..]);
        assert!(v[0].hypot(v[1]) < 1e-12);
        let mut xr = vec![0.0; 2 * n];
        brachia::model::reroot_state(&x, &mut xr);
        let ke = robot.kinetic_energy(&mut ws, &x[..n], &x[n..]);
        let ker = rr.kinetic_energy(&mut ws, &xr[..n], &xr[n..]);
        assert!((ke - ker).abs() < 1e-12 * ke.max(1.0), "{ke} vs {ker}");
        // the potential is measured from the grip: the difference is m_total g y_ee
        let ee = robot.ee_position(&x[..n]);
        let dv = robot.potential_energy(&x[..n])
            - (rr.potential_energy(&xr[..n]) + robot.total_mass() * robot.gravity() * ee[1]);
        let o = *offset.get_or_insert(dv);
        assert!((dv - o).abs() < 1e-12, "{dv} vs {o}");
    }
    // an end effector off the last joint cannot be re-rooted
    let err = general_robot().rerooted().unwrap_err().to_string();
    assert!(err.contains("end_effector"), "{err}");
}

#[test]
fn generalised_fields_are_validated() {
    let base = general_robot().params().clone();
    let check = |edit: &dyn Fn(&mut RobotParams), field: &str, rule: &str| {
        let mut p = base.clone();
        edit(&mut p);
        let err = Robot::from_params(p, "robot.toml").unwrap_err().to_string();
        assert!(
            err.contains("robot.toml") && err.contains(field) && err.contains(rule),
            "{err}"
        );
    };
    check(
        &|p| p.links[0].com_across = f64::NAN,
        "links[0].com_across",
        "finite",
    );
    check(
        &|p| p.links[1].q_min = Some(3.0),
        "links[1].q_min, links[1].q_max",
        "below the upper",
    );
    check(&|p| p.links[2].qd_max = Some(0.0), "links[2].qd_max", "> 0");
    check(&|p| p.links[0].length = -0.1, "links[0].length", ">= 0");
    check(
        &|p| p.end_effector = Some([f64::INFINITY, 0.0]),
        "end_effector",
        "finite",
    );
    check(
        &|p| p.links[2].joint_offset = 100.0,
        "links[2].joint_offset",
        "4 pi",
    );
    check(
        &|p| {
            for l in &mut p.links {
                l.length = 0.0;
            }
        },
        "length",
        "at least one link",
    );
    // the ideal chain keeps its rule for com (on the link) unless com_across is set
    check(
        &|p| {
            p.links[0].com_across = 0.0;
            p.links[0].com = 0.5;
        },
        "links[0].com",
        "0 <= com <= length",
    );
    // unknown fields are still refused, the new ones parse from TOML
    let toml = |extra: &str| {
        format!(
            "[actuators]\ntau_min = [-1.0]\ntau_max = [1.0]\n[[links]]\nlength = 0.3\nmass = 1.0\n\
             com = 0.1\ninertia = 0.1\n{extra}\n[[links]]\nlength = 0.3\nmass = 1.0\ncom = 0.1\n\
             inertia = 0.1\n"
        )
    };
    let err = RobotParams::from_toml_str(&toml("com_sideways = 0.1"), "x.toml").unwrap_err();
    assert!(err.to_string().contains("com_sideways"), "{err}");
    let p = RobotParams::from_toml_str(&toml("com_across = 0.1\nq_max = 1.0"), "x.toml").unwrap();
    assert_eq!((p.links[0].com_across, p.links[0].q_max), (0.1, Some(1.0)));
    let l = LinkParams::default();
    assert_eq!(
        (l.com_across, l.joint_offset, l.joint_reversed),
        (0.0, 0.0, false)
    );
}

#[test]
fn planner_bounds_may_only_tighten_the_robots_limits() {
    use brachia::planning::{validate_task, PlannerSettings, SwingTask};
    let robot = general_robot();
    let task = SwingTask {
        q0: vec![-1.5, 0.3, -0.4],
        qd0: vec![],
        target: [0.3, 0.0],
        obstacles: vec![],
    };
    // joint 2 allows [-2.0, 2.5] rad and 8 rad/s: the default bounds (+-2.9 rad, 15 rad/s) are wider
    let mut s = PlannerSettings::default();
    let err = validate_task(&robot, &task, &s, "scenario.toml", "task.")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("scenario.toml")
            && err.contains("planner.bounds.q_rel_max")
            && err.contains("links[1].q_min = -2")
            && err.contains("may only tighten"),
        "{err}"
    );
    s.bounds.q_rel_max = 2.0;
    let err = validate_task(&robot, &task, &s, "scenario.toml", "task.")
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("planner.bounds.qd_max") && err.contains("links[1].qd_max = 8"),
        "{err}"
    );
    s.bounds.qd_max = 8.0;
    validate_task(&robot, &task, &s, "scenario.toml", "task.").unwrap();
}
