//! Box-QP solver timings: a random 60-variable SPD problem with condition number 1e5, and the
//! 60-variable QPs of the MPC (4 links, horizon 20, 3 inputs) along a closed-loop run; cold (start at
//! zero) vs warm (previous solution) starts.

#[path = "../tests/common/mod.rs"]
mod common;

use brachia::control::{BoxQp, Mpc, MpcSettings};
use brachia::sim::{Controller, ModelPlant, Plant};
use common::*;
use criterion::{black_box, criterion_group, criterion_main, Criterion};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn random_spd(rng: &mut ChaCha8Rng, n: usize, cond: f64) -> Vec<f64> {
    let mut a = nalgebra::DMatrix::<f64>::zeros(n, n);
    for v in a.iter_mut() {
        *v = rng.gen_range(-1.0..1.0);
    }
    let q = a.qr().q();
    let d = nalgebra::DMatrix::from_diagonal(&nalgebra::DVector::from_fn(n, |k, _| {
        cond.powf(k as f64 / (n - 1) as f64)
    }));
    let h = &q * d * q.transpose();
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            out[i * n + j] = 0.5 * (h[(i, j)] + h[(j, i)]);
        }
    }
    out
}

/// QPs `(H, g)` of a run and the common bounds `(lb, ub)`.
type QpSequence = (Vec<(Vec<f64>, Vec<f64>)>, Vec<f64>, Vec<f64>);

/// The MPC's QPs `(H, g)` along a closed-loop run from a perturbed start (bounds are the torque box).
fn mpc_qps() -> QpSequence {
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let mut x0 = start_state();
    x0[1] += 0.1;
    x0[2] -= 0.1;
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), MpcSettings::default()).unwrap();
    let mut out = Vec::new();
    let (mut x, mut tau) = (vec![0.0; 8], vec![0.0; 3]);
    for _ in 0..300 {
        plant.state(&mut x);
        mpc.control(plant.time(), &x, &mut tau);
        let (h, g, _, _) = mpc.qp_data();
        out.push((h.to_vec(), g.to_vec()));
        plant.step(&tau, 1e-3);
    }
    let (_, _, lb, ub) = mpc.qp_data();
    (out, lb.to_vec(), ub.to_vec())
}

fn bench(c: &mut Criterion) {
    let n = 60;
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    let h = random_spd(&mut rng, n, 1e5);
    let g: Vec<f64> = (0..n).map(|_| rng.gen_range(-100.0..100.0)).collect();
    let g2: Vec<f64> = g
        .iter()
        .map(|v| v * (1.0 + rng.gen_range(-0.01..0.01)))
        .collect();
    let (lb, ub) = (vec![-1.0; n], vec![1.0; n]);
    let mut qp = BoxQp::new(n);
    let mut warm = vec![0.0; n];
    qp.solve(&h, &g2, &lb, &ub, &mut warm);
    let mut u = vec![0.0; n];
    c.bench_function("boxqp random60 cond1e5 cold", |b| {
        b.iter(|| {
            u.fill(0.0);
            black_box(qp.solve(&h, &g, &lb, &ub, &mut u))
        })
    });
    c.bench_function("boxqp random60 cond1e5 warm", |b| {
        b.iter(|| {
            u.copy_from_slice(&warm);
            black_box(qp.solve(&h, &g, &lb, &ub, &mut u))
        })
    });

    let (qps, lb, ub) = mpc_qps();
    let mut k = 0;
    c.bench_function("boxqp mpc60 sequence cold", |b| {
        b.iter(|| {
            k = (k + 1) % qps.len();
            u.fill(0.0);
            black_box(qp.solve(&qps[k].0, &qps[k].1, &lb, &ub, &mut u))
        })
    });
    // Warm: each QP starts from the solution of its predecessor in the run.
    let mut sols = Vec::new();
    for (h, g) in &qps {
        let mut s = vec![0.0; n];
        qp.solve(h, g, &lb, &ub, &mut s);
        sols.push(s);
    }
    let mut k = 0;
    c.bench_function("boxqp mpc60 sequence warm", |b| {
        b.iter(|| {
            k = (k % (qps.len() - 1)) + 1;
            u.copy_from_slice(&sols[k - 1]);
            black_box(qp.solve(&qps[k].0, &qps[k].1, &lb, &ub, &mut u))
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
