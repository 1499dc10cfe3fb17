//! Cost of the clearance constraints (value, Jacobian, weighted Hessian) for the paper's 4-link robot
//! with the paper's obstacle and self-collision on (4 link-obstacle rows + 3 link-link rows).
//! Conventions: q[0] absolute angle of link 1 from +x, q[i > 0] relative; SI units.

use brachia::ad::{Diff, LocalFn};
use brachia::model::{ActuatorParams, Circle, ClearanceFn, LinkParams, Robot, RobotParams};
use criterion::{black_box, criterion_group, criterion_main, Criterion};

fn paper_robot() -> Robot {
    let m = [0.35, 0.56, 0.56, 0.35];
    let com = [0.2059, 0.1832, 0.1718, 0.1491];
    let inertia = [0.98, 0.10, 0.10, 0.98];
    let links = (0..4)
        .map(|i| LinkParams {
            length: 0.355,
            mass: m[i],
            com: com[i],
            inertia: inertia[i],
            radius: 0.02,
            ..Default::default()
        })
        .collect();
    let params = RobotParams {
        name: "paper".into(),
        gravity: 9.81,
        links,
        actuators: ActuatorParams {
            tau_min: vec![-5.0; 3],
            tau_max: vec![5.0; 3],
        },
        end_effector: None,
    };
    Robot::from_params(params, "<bench>").expect("valid paper robot")
}

fn bench(c: &mut Criterion) {
    let robot = paper_robot();
    let obstacles = [Circle::PAPER];
    let f = ClearanceFn::new(robot.clone(), &obstacles[..], 0.01).expect("valid obstacles");
    let (n, m) = (f.n_in(), f.n_out());
    let mut diff = Diff::new(&f);
    // a pose mid-swing, away from piece boundaries
    let q = [-1.2, 0.4, -0.9, 0.6];
    let w: Vec<f64> = (0..m).map(|k| 0.1 + 0.05 * k as f64).collect();
    let (mut out, mut jac, mut hess) = (vec![0.0; m], vec![0.0; m * n], vec![0.0; n * n]);

    c.bench_function("clearance value (4 links, 1 obstacle + self)", |b| {
        b.iter(|| diff.value(&f, black_box(&q), &mut out))
    });
    c.bench_function("clearance jacobian (4 links, 1 obstacle + self)", |b| {
        b.iter(|| diff.jacobian(&f, black_box(&q), &mut out, &mut jac))
    });
    c.bench_function(
        "clearance weighted hessian (4 links, 1 obstacle + self)",
        |b| b.iter(|| diff.hessian_weighted(&f, black_box(&q), &w, &mut hess)),
    );
    c.bench_function(
        "clearance min_clearance f64 (4 links, 1 obstacle + self)",
        |b| b.iter(|| f.min_clearance(black_box(&q))),
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
