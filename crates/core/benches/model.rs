//! Cost of the model's hot functions at the paper's start state: f(x, u), the exact first derivatives
//! of qdd (one Dual64 pass per input) and the weighted Hessian of qdd per collocation point (one
//! HyperDual64 pass per non-zero input pair). Baseline in the same process: plain f(x, u).

use brachia::ad::{Diff, LocalFn};
use brachia::model::{DynamicsFn, Robot, Scratch};
use criterion::{black_box, criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let robot = Robot::paper();
    let (q, qd, tau) = (
        [-2.35, 0.1, -1.55, 0.2],
        [0.3, -0.2, 0.5, 0.1],
        [0.4, -0.3, 0.2],
    );
    let mut ws = Scratch::new(4);
    let mut qdd = [0.0; 4];
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
    let f = DynamicsFn { robot: &robot };
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
}

criterion_group!(benches, bench);
criterion_main!(benches);
