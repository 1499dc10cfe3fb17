//! Planning time of the paper's tracking scenario (T = 2 T_freefall ~ 2.23 s, 10 ms knots, Hermite-
//! Simpson, pounce-rs), with the trapezoidal rule beside it as the in-process baseline.

use brachia::planning::{plan, NlpSettings, PlannerSettings, SwingTask, Transcription};
use brachia::Robot;
use criterion::{criterion_group, criterion_main, Criterion};

fn bench(c: &mut Criterion) {
    let robot = Robot::paper();
    let task = SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    };
    let mut g = c.benchmark_group("plan/tracking");
    g.sample_size(10);
    for tr in [Transcription::HermiteSimpson, Transcription::Trapezoidal] {
        let s = PlannerSettings {
            transcription: tr,
            ..Default::default()
        };
        g.bench_function(format!("{tr:?}"), |b| {
            b.iter(|| {
                let p = plan(&robot, &task, &s, &NlpSettings::default()).unwrap();
                assert!(p.converged());
                p.objective
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
