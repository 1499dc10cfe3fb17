//! The closed-form derivatives of the forward dynamics (`brachia::model::DynamicsDerivatives`) against
//! the two independent oracles: automatic differentiation of the same function (`Diff<DynamicsFn>`,
//! exact, to 1e-10 relative) and central finite differences through the shared `brachia::fdcheck`.
//! Random robots (lengths, masses, centres of mass, inertias) and random states, seeded, for
//! n = 2, 3, 4, 6 and 12 links; plus the properties the callers rely on: qdd identical to
//! `Robot::forward_dynamics_into`, an exactly symmetric Hessian, linearity in the weights, structural
//! zeros, and no allocation per call.
//!
//! Conventions: z = [q (n), qd (n), tau (n - 1)], q[0] absolute, q[1..] relative (rad).

// The allocation check needs a counting global allocator (`unsafe impl GlobalAlloc`, forwarding to
// `System`); nothing else here is unsafe.
#![allow(unsafe_code)]

use brachia::ad::{as_f64_fn, Diff, LocalFn};
use brachia::fdcheck::{assert_hessian, assert_jacobian};
use brachia::model::{
    ActuatorParams, DynamicsDerivatives, DynamicsFn, LinearModel, Linearizer, LinkParams, Robot,
    RobotParams, Scratch,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

const SIZES: [usize; 5] = [2, 3, 4, 6, 12];

struct Counting;

thread_local! {
    static ALLOCS: Cell<usize> = const { Cell::new(0) };
}

fn count() {
    let _ = ALLOCS.try_with(|c| c.set(c.get() + 1));
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// A random valid n-link robot.
fn random_robot(rng: &mut ChaCha8Rng, n: usize) -> Robot {
    let links = (0..n)
        .map(|_| {
            let length = rng.gen_range(0.15..0.5);
            LinkParams {
                length,
                mass: rng.gen_range(0.2..1.2),
                com: rng.gen_range(0.0..length),
                inertia: rng.gen_range(0.005..0.5),
                radius: 0.02,
                ..Default::default()
            }
        })
        .collect();
    let params = RobotParams {
        name: format!("random-{n}"),
        gravity: 9.81,
        links,
        actuators: ActuatorParams {
            tau_min: vec![-5.0; n - 1],
            tau_max: vec![5.0; n - 1],
        },
        end_effector: None,
    };
    Robot::from_params(params, "<random>").expect("valid random robot")
}

/// A random z = [q, qd, tau].
fn random_z(rng: &mut ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..3 * n - 1)
        .map(|i| match i / n {
            0 => rng.gen_range(-3.0..3.0),
            1 => rng.gen_range(-4.0..4.0),
            _ => rng.gen_range(-5.0..5.0),
        })
        .collect()
}

/// Each case: a robot and a few states.
fn cases(seed: u64, robots_per_size: usize, states: usize) -> Vec<(Robot, Vec<Vec<f64>>)> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut out = vec![(
        Robot::paper(),
        (0..states).map(|_| random_z(&mut rng, 4)).collect(),
    )];
    for n in SIZES {
        for _ in 0..robots_per_size {
            let robot = random_robot(&mut rng, n);
            let zs = (0..states).map(|_| random_z(&mut rng, n)).collect();
            out.push((robot, zs));
        }
    }
    out
}

/// Largest `|a - b|` over the matrices, relative to the largest `|b|` (at least 1).
fn rel_err(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = b.iter().fold(1f64, |m, v| m.max(v.abs()));
    let err = a.iter().zip(b).fold(0f64, |m, (x, y)| m.max((x - y).abs()));
    err / scale
}

#[test]
fn qdd_is_the_forward_dynamics_bit_for_bit() {
    for (robot, zs) in cases(11, 2, 5) {
        let n = robot.n();
        let mut dd = DynamicsDerivatives::new(&robot);
        let mut ws = Scratch::new(n);
        for z in zs {
            let (mut a, mut b) = (vec![0.0; n], vec![0.0; n]);
            dd.qdd(&robot, &z, &mut a);
            robot.forward_dynamics_into(&mut ws, &z[..n], &z[n..2 * n], &z[2 * n..], &mut b);
            assert_eq!(a, b, "n = {n}, z = {z:?}");
        }
    }
}

#[test]
fn jacobian_matches_automatic_differentiation() {
    for (robot, zs) in cases(12, 3, 6) {
        let n = robot.n();
        let f = DynamicsFn::new(robot.clone());
        let nz = f.n_in();
        let mut diff = Diff::new(&f);
        let mut dd = DynamicsDerivatives::new(&robot);
        for z in zs {
            let (mut qa, mut qb) = (vec![0.0; n], vec![0.0; n]);
            let (mut ja, mut jb) = (vec![f64::NAN; n * nz], vec![0.0; n * nz]);
            dd.jacobian(&robot, &z, &mut qa, &mut ja);
            diff.jacobian(&f, &z, &mut qb, &mut jb);
            // Dual64 arithmetic may round the value part differently
            let e = rel_err(&qa, &qb);
            assert!(
                e <= 1e-13,
                "n = {n}: qdd differs from the AD value part by {e:.2e}"
            );
            let e = rel_err(&ja, &jb);
            assert!(
                e <= 1e-10,
                "n = {n}: Jacobian differs from AD by {e:.2e} at z = {z:?}"
            );
        }
    }
}

#[test]
fn weighted_hessian_matches_automatic_differentiation() {
    for (robot, zs) in cases(13, 2, 3) {
        let n = robot.n();
        let f = DynamicsFn::new(robot.clone());
        let nz = f.n_in();
        let mut diff = Diff::new(&f);
        let mut dd = DynamicsDerivatives::new(&robot);
        let mut rng = ChaCha8Rng::seed_from_u64(n as u64);
        for z in zs {
            let w: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let (mut ha, mut hb) = (vec![f64::NAN; nz * nz], vec![0.0; nz * nz]);
            dd.hessian_weighted(&robot, &z, &w, &mut ha);
            diff.hessian_weighted(&f, &z, &w, &mut hb);
            let e = rel_err(&ha, &hb);
            assert!(
                e <= 1e-10,
                "n = {n}: Hessian differs from AD by {e:.2e} at z = {z:?}, w = {w:?}"
            );
        }
    }
}

#[test]
fn jacobian_matches_finite_differences() {
    for (robot, zs) in cases(14, 2, 4) {
        let n = robot.n();
        let f = DynamicsFn::new(robot.clone());
        let mut dd = DynamicsDerivatives::new(&robot);
        for z in zs {
            let mut qdd = vec![0.0; n];
            let mut jac = vec![0.0; n * f.n_in()];
            dd.jacobian(&robot, &z, &mut qdd, &mut jac);
            // finite differences of the plain forward dynamics, not of the analytic code
            // The 12-link chains have larger third derivatives, so the central differences themselves
            // are off by up to ~2e-6 there (the AD comparison above holds to 1e-10 for them too).
            let tol = if n <= 6 { 1e-6 } else { 1e-5 };
            assert_jacobian("analytic d qdd / dz", as_f64_fn(&f), &z, &jac, tol);
        }
    }
}

#[test]
fn weighted_hessian_matches_finite_differences_of_the_gradient() {
    for (robot, zs) in cases(15, 2, 3) {
        let n = robot.n();
        let nz = 3 * n - 1;
        let f = DynamicsFn::new(robot.clone());
        let mut dd = DynamicsDerivatives::new(&robot);
        let mut rng = ChaCha8Rng::seed_from_u64(100 + n as u64);
        for z in zs {
            let w: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let mut hess = vec![0.0; nz * nz];
            dd.hessian_weighted(&robot, &z, &w, &mut hess);
            // gradient of w . qdd by AD (an independent path), differentiated numerically
            let mut gdiff = Diff::new(&f);
            let (mut out, mut jac) = (vec![0.0; n], vec![0.0; n * nz]);
            let grad = |z: &[f64], g: &mut [f64]| {
                gdiff.jacobian(&f, z, &mut out, &mut jac);
                for j in 0..nz {
                    g[j] = (0..n).map(|i| w[i] * jac[i * nz + j]).sum();
                }
            };
            assert_hessian("analytic Hessian of w . qdd", grad, &z, &hess, 1e-5);
        }
    }
}

#[test]
fn hessian_is_symmetric_linear_in_the_weights_and_structurally_sparse() {
    for (robot, zs) in cases(16, 2, 3) {
        let n = robot.n();
        let nz = 3 * n - 1;
        let mut dd = DynamicsDerivatives::new(&robot);
        let mut rng = ChaCha8Rng::seed_from_u64(200 + n as u64);
        for z in zs {
            let w: Vec<f64> = (0..n).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let mut hess = vec![f64::NAN; nz * nz];
            dd.hessian_weighted(&robot, &z, &w, &mut hess);
            let mut sum = vec![0.0; nz * nz];
            let mut hi = vec![f64::NAN; nz * nz];
            for i in 0..n {
                let mut e = vec![0.0; n];
                e[i] = 1.0;
                dd.hessian_weighted(&robot, &z, &e, &mut hi);
                for (s, h) in sum.iter_mut().zip(&hi) {
                    *s += w[i] * h;
                }
            }
            let e = rel_err(&hess, &sum);
            assert!(
                e <= 1e-12,
                "n = {n}: w-weighted Hessian vs sum of per-output Hessians: {e:.2e}"
            );
            for i in 0..nz {
                for j in 0..nz {
                    assert_eq!(
                        hess[i * nz + j],
                        hess[j * nz + i],
                        "asymmetric at ({i}, {j})"
                    );
                    // qdd is linear in tau and M does not depend on qd
                    if i >= 2 * n && j >= n {
                        assert_eq!(hess[i * nz + j], 0.0, "structural zero at ({i}, {j})");
                    }
                }
            }
            // a vanishing weight gives a vanishing Hessian
            dd.hessian_weighted(&robot, &z, &vec![0.0; n], &mut hi);
            assert!(hi.iter().all(|&v| v == 0.0));
        }
    }
}

#[test]
fn combined_call_equals_the_separate_calls() {
    for (robot, zs) in cases(17, 1, 3) {
        let n = robot.n();
        let nz = 3 * n - 1;
        let mut dd = DynamicsDerivatives::new(&robot);
        let w: Vec<f64> = (0..n).map(|i| 0.5 - i as f64 * 0.3).collect();
        for z in zs {
            let (mut q1, mut j1, mut h1) = (vec![0.0; n], vec![0.0; n * nz], vec![0.0; nz * nz]);
            dd.jacobian(&robot, &z, &mut q1, &mut j1);
            dd.hessian_weighted(&robot, &z, &w, &mut h1);
            let (mut q2, mut j2, mut h2) = (vec![1.0; n], vec![1.0; n * nz], vec![1.0; nz * nz]);
            dd.jacobian_and_hessian(&robot, &z, &w, &mut q2, &mut j2, &mut h2);
            assert_eq!((q1, j1, h1), (q2, j2, h2), "n = {n}");
        }
    }
}

#[test]
fn mpc_linearisation_equals_the_ad_jacobian() {
    // The Linearizer runs on the analytic Jacobian; its A and B rows of qdd must be the AD ones.
    for (robot, zs) in cases(18, 1, 3) {
        let n = robot.n();
        let (nx, nu, nz) = (2 * n, n - 1, 3 * n - 1);
        let f = DynamicsFn::new(robot.clone());
        let mut diff = Diff::new(&f);
        let mut lin = Linearizer::new(robot.clone());
        let mut lm = LinearModel::zeros(n);
        for z in zs {
            lin.linearize_into(&z[..nx], &z[nx..], &mut lm);
            let (mut qdd, mut jac) = (vec![0.0; n], vec![0.0; n * nz]);
            diff.jacobian(&f, &z, &mut qdd, &mut jac);
            let mut ab = vec![0.0; n * nz];
            for i in 0..n {
                ab[i * nz..i * nz + nx].copy_from_slice(&lm.a[(n + i) * nx..(n + i + 1) * nx]);
                ab[i * nz + nx..(i + 1) * nz]
                    .copy_from_slice(&lm.b[(n + i) * nu..(n + i + 1) * nu]);
            }
            let e = rel_err(&ab, &jac);
            assert!(
                e <= 1e-10,
                "n = {n}: linearisation differs from AD by {e:.2e}"
            );
        }
    }
}

#[test]
fn calls_do_not_allocate() {
    // the counter sees allocations at all
    let before = ALLOCS.with(Cell::get);
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(ALLOCS.with(Cell::get) > before && v.len() == 16);
    for n in SIZES {
        let mut rng = ChaCha8Rng::seed_from_u64(300 + n as u64);
        let robot = random_robot(&mut rng, n);
        let nz = 3 * n - 1;
        let z = random_z(&mut rng, n);
        let w = vec![0.7; n];
        let (mut qdd, mut jac, mut hess) = (vec![0.0; n], vec![0.0; n * nz], vec![0.0; nz * nz]);
        let mut dd = DynamicsDerivatives::new(&robot);
        let before = ALLOCS.with(Cell::get);
        for _ in 0..10 {
            dd.qdd(&robot, &z, &mut qdd);
            dd.jacobian(&robot, &z, &mut qdd, &mut jac);
            dd.hessian_weighted(&robot, &z, &w, &mut hess);
            dd.jacobian_and_hessian(&robot, &z, &w, &mut qdd, &mut jac, &mut hess);
        }
        assert_eq!(ALLOCS.with(Cell::get), before, "n = {n}: a call allocated");
    }
}
