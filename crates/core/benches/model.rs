//! Cost of the model's hot functions at the paper's start state: f(x, u), the exact first derivatives
//! of qdd (one Dual64 pass per input) and the weighted Hessian of qdd per collocation point (one
//! HyperDual64 pass per non-zero input pair), each against the closed form of
//! `brachia::model::DynamicsDerivatives`. Baseline in the same process: plain f(x, u). A manual pass
//! before the criterion groups prints the median of each and the AD / analytic ratios.

use brachia::ad::{Diff, LocalFn};
use brachia::model::{DynamicsDerivatives, DynamicsFn, Robot, Scratch};
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use shared::median;
use std::time::Instant;

mod shared;

/// Median time per call of `f`, ns, over 201 batches of 200 calls.
fn median_ns(mut f: impl FnMut()) -> f64 {
    let t: Vec<f64> = (0..201)
        .map(|_| {
            let s = Instant::now();
            for _ in 0..200 {
                f();
            }
            s.elapsed().as_secs_f64() * 1e9 / 200.0
        })
        .collect();
    median(&t)
}

fn bench(c: &mut Criterion) {
    let robot = Robot::paper();
    let (q, qd, tau) = (
        [-2.35, 0.1, -1.55, 0.2],
        [0.3, -0.2, 0.5, 0.1],
        [0.4, -0.3, 0.2],
    );
    let mut ws = Scratch::new(4);
    let mut qdd = [0.0; 4];
    ratios(&robot, &q, &qd, &tau);
    c.bench_function("model/f(x,u) forward dynamics", |b| {
        b.iter(|| {
            robot.forward_dynamics_into(
                &mut ws,
                black_box(&q),
                black_box(&qd),
                black_box(&tau),
                &mut qdd,
            )
        })
    });
    let f = DynamicsFn::new(robot.clone());
    let mut diff = Diff::new(&f);
    let z: Vec<f64> = q.iter().chain(&qd).chain(&tau).copied().collect();
    let mut jac = vec![0.0; 4 * f.n_in()];
    c.bench_function("model/jacobian of qdd (4x11, AD)", |b| {
        b.iter(|| diff.jacobian(&f, black_box(&z), &mut qdd, &mut jac))
    });
    let w = [0.3, -1.2, 0.7, 0.1];
    let mut hess = vec![0.0; f.n_in() * f.n_in()];
    c.bench_function("model/weighted hessian of qdd per knot (11x11, AD)", |b| {
        b.iter(|| diff.hessian_weighted(&f, black_box(&z), &w, &mut hess))
    });
    let mut dd = DynamicsDerivatives::new(&robot);
    c.bench_function("model/jacobian of qdd (4x11, analytic)", |b| {
        b.iter(|| dd.jacobian(&robot, black_box(&z), &mut qdd, &mut jac))
    });
    c.bench_function(
        "model/weighted hessian of qdd per knot (11x11, analytic)",
        |b| b.iter(|| dd.hessian_weighted(&robot, black_box(&z), black_box(&w), &mut hess)),
    );
    c.bench_function(
        "model/jacobian and weighted hessian of qdd (analytic, shared)",
        |b| {
            b.iter(|| {
                dd.jacobian_and_hessian(
                    &robot,
                    black_box(&z),
                    black_box(&w),
                    &mut qdd,
                    &mut jac,
                    &mut hess,
                )
            })
        },
    );
}

/// The manual pass: medians in one process and the ratios AD / analytic.
fn ratios(robot: &Robot, q: &[f64], qd: &[f64], tau: &[f64]) {
    let f = DynamicsFn::new(robot.clone());
    let nz = f.n_in();
    let z: Vec<f64> = q.iter().chain(qd).chain(tau).copied().collect();
    let w = [0.3, -1.2, 0.7, 0.1];
    let (mut qdd, mut jac, mut hess) = (vec![0.0; 4], vec![0.0; 4 * nz], vec![0.0; nz * nz]);
    let mut diff = Diff::new(&f);
    let mut dd = DynamicsDerivatives::new(robot);
    let mut ws = Scratch::new(4);
    let fx = median_ns(|| robot.forward_dynamics_into(&mut ws, q, qd, black_box(tau), &mut qdd));
    let ja = median_ns(|| diff.jacobian(&f, black_box(&z), &mut qdd, &mut jac));
    let jn = median_ns(|| dd.jacobian(robot, black_box(&z), &mut qdd, &mut jac));
    let ha = median_ns(|| diff.hessian_weighted(&f, black_box(&z), &w, &mut hess));
    let hn = median_ns(|| dd.hessian_weighted(robot, black_box(&z), &w, &mut hess));
    let both = median_ns(|| {
        dd.jacobian_and_hessian(robot, black_box(&z), &w, &mut qdd, &mut jac, &mut hess)
    });
    eprintln!("model medians (ns): f(x,u) {fx:.0}");
    eprintln!(
        "  jacobian: AD {ja:.0}, analytic {jn:.0}, ratio AD/analytic {:.1}",
        ja / jn
    );
    eprintln!(
        "  weighted hessian: AD {ha:.0}, analytic {hn:.0}, ratio AD/analytic {:.1}",
        ha / hn
    );
    eprintln!("  jacobian + hessian (analytic, shared): {both:.0}");
}

criterion_group!(benches, bench);
criterion_main!(benches);
