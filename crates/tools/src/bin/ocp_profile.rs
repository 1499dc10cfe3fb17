//! A fixed workload for instruction counts (`valgrind --tool=callgrind`, `perf stat`), which do
//! not depend on machine load: `cargo run -p brachia-tools --release --bin ocp_profile -- step 100`
//! (100 Newton steps at the solution of the robot-sized random QP of the bench) or `-- solve 3`
//! (3 cold solves).

use brachia_ocp::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;

#[path = "../../../ocp/tests/common/mod.rs"]
mod common;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let what = args.get(1).map(String::as_str).unwrap_or("step");
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(10);
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let mut qp = common::random_qp_with(&mut rng, 223, 8, 3, 2, 4, false, 0.9, 0.05);
    let mut solver = OcpSolver::new(&qp.dims.clone()).unwrap();
    let settings = OcpSettings::default();
    let stats = solver.solve(&mut qp, &settings);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    match what {
        "step" => {
            for _ in 0..n {
                assert!(solver.bench_newton_step(1e-3));
            }
        }
        _ => {
            let mut it = 0;
            for _ in 0..n {
                let s = solver.solve(&mut qp, &settings);
                assert_eq!(s.status, OcpStatus::Solved);
                it += s.iterations;
            }
            println!("{it} iterations");
        }
    }
}
