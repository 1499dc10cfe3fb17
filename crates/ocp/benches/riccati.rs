//! Riccati interior-point benchmarks on a random convex OCP of the brachiation robot's size:
//! K = 223 stages, nx = 8, nu = 3, nr = 4 terminal rows, 2 inequality rows per stage, bounds.
//! `newton_step`: one Newton step at a stored iterate (condensing, factorisation, Schur, solves);
//! `full_solve`: a cold solve to tol = 1e-8;
//! `warm_resolve_x0_shift`: a warm re-solve (default warm start: stored primal, multipliers reset)
//! after every component of x_0 moved by 0.1, alternating between the two x_0 so that each solve
//! starts from the other's solution;
//! `pendulum_warm_x0_shift`: the same for the pendulum swing-up (K = 100, |tau| <= 4) between
//! x_0 = [0, 0] and [0.05, 0].

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
    // warm re-solves after a shift of x_0 (fixed through its bounds)
    let warm = OcpSettings {
        warm_start: true,
        ..OcpSettings::default()
    };
    let x0a = qp.stages[0].bounds.x_lo.clone();
    let x0b: Vec<f64> = x0a.iter().map(|v| v + 0.1).collect();
    let mut qp_b = qp.clone();
    qp_b.stages[0].bounds.x_lo = x0b.clone();
    qp_b.stages[0].bounds.x_hi = x0b;
    let first = solver.solve(&mut qp_b, &settings);
    assert_eq!(first.status, OcpStatus::Solved);
    let s = solver.solve(&mut qp, &warm);
    eprintln!(
        "QP warm re-solve after the x_0 shift: {} iterations (cold {})",
        s.iterations, stats.iterations
    );
    let mut flip = false;
    g.bench_function("warm_resolve_x0_shift", |b| {
        b.iter(|| {
            flip = !flip;
            let p = if flip { &mut qp_b } else { &mut qp };
            let s = solver.solve(p, &warm);
            assert_eq!(s.status, OcpStatus::Solved);
            s.iterations
        })
    });
    g.finish();

    let mut pa = common::Pendulum::new(100, 0.05, 4.0);
    let mut pb = pa.clone();
    pb.x0 = [0.05, 0.0];
    let mut ps = OcpSolver::new(&pa.dims).unwrap();
    let cold = ps.solve(&mut pb, &settings);
    assert_eq!(cold.status, OcpStatus::Solved);
    let s = ps.solve(&mut pa, &warm);
    eprintln!(
        "pendulum warm re-solve after 0.05 rad: {} iterations (cold {})",
        s.iterations, cold.iterations
    );
    let mut g = c.benchmark_group("pendulum_K100");
    g.sample_size(30);
    g.measurement_time(std::time::Duration::from_secs(4));
    g.bench_function("cold_solve", |b| {
        b.iter(|| {
            let mut fresh = OcpSolver::new(&pa.dims).unwrap();
            let s = fresh.solve(&mut pa, &settings);
            assert_eq!(s.status, OcpStatus::Solved);
            s.iterations
        })
    });
    let mut flip = false;
    g.bench_function("warm_x0_shift_0.05", |b| {
        b.iter(|| {
            flip = !flip;
            let p = if flip { &mut pb } else { &mut pa };
            let s = ps.solve(p, &warm);
            assert_eq!(s.status, OcpStatus::Solved);
            s.iterations
        })
    });
    g.finish();
}

criterion_group!(riccati, benches);
criterion_main!(riccati);
