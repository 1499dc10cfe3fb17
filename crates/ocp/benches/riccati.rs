//! Riccati interior-point benchmarks on a random convex OCP of the brachiation robot's size:
//! K = 223 stages, nx = 8, nu = 3, nr = 4 terminal rows, 2 inequality rows per stage, bounds.
//! `newton_step`: one Newton step at a stored iterate (condensing, factorisation, Schur, solves);
//! `full_solve`: a cold solve to tol = 1e-8.

use brachia_ocp::*;
use criterion::{criterion_group, criterion_main, Criterion};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[path = "../tests/common/mod.rs"]
mod common;

fn robot_sized_qp() -> common::LqProblem {
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    common::random_qp_with(&mut rng, 223, 8, 3, 2, 4, false, 0.9, 0.05)
}

fn benches(c: &mut Criterion) {
    let mut qp = robot_sized_qp();
    let mut solver = OcpSolver::new(&qp.dims.clone()).unwrap();
    let settings = OcpSettings::default();
    let stats = solver.solve(&mut qp, &settings);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    eprintln!(
        "full solve: {} iterations, {} regularisations, time split {:?}",
        stats.iterations, stats.regularizations, stats.time
    );
    let mut g = c.benchmark_group("riccati_K223_nx8_nu3_nr4_nc2");
    g.sample_size(30);
    g.measurement_time(std::time::Duration::from_secs(4));
    g.bench_function("newton_step", |b| {
        b.iter(|| assert!(solver.bench_newton_step(1e-3)))
    });
    g.bench_function("full_solve", |b| {
        b.iter(|| {
            let s = solver.solve(&mut qp, &settings);
            assert_eq!(s.status, OcpStatus::Solved);
            s.iterations
        })
    });
    g.finish();
}

criterion_group!(riccati, benches);
criterion_main!(riccati);
