//! Cost of one 1 ms step of the rapier plant (paper's 4-link robot, passive swing from the paper's start
//! pose, constant mid-range torques) for 1, 2 and 4 engine sub-steps.

use brachia::sim::Plant;
use brachia::Robot;
use brachia_rapier::{RapierPlant, RapierSettings};
use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};

fn paper_robot() -> Robot {
    Robot::paper()
}

fn bench_step(c: &mut Criterion) {
    let robot = paper_robot();
    let x0 = [-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0];
    let tau = [0.3, -0.2, 0.1];
    let mut group = c.benchmark_group("rapier_step_1ms");
    for substeps in [1usize, 2, 4] {
        let settings = RapierSettings {
            substeps,
            ..RapierSettings::default()
        };
        let mut plant = RapierPlant::new(&robot, &x0, &settings).expect("plant builds");
        group.bench_with_input(BenchmarkId::from_parameter(substeps), &substeps, |b, _| {
            b.iter(|| {
                // restart every 2 s of simulated time so the pose stays in the swing's range
                if plant.time() > 2.0 {
                    plant = RapierPlant::new(&robot, &x0, &settings).expect("plant builds");
                }
                plant.step(&tau, 1e-3);
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_step);
criterion_main!(benches);
