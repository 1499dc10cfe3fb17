//! Solve times of the NLP seam's test problems on both backends (numbers recorded in docs/nlp.md).

#[path = "../tests/nlp_problems/mod.rs"]
mod nlp_problems;

use brachia::planning::{solve, Backend, NlpSettings, SparseNlp};
use criterion::{criterion_group, criterion_main, Criterion};
use nlp_problems::{DoubleIntegrator, Hs071, RosenbrockDisk};

fn bench_problem<P: SparseNlp + Clone>(c: &mut Criterion, name: &str, problem: P) {
    let mut group = c.benchmark_group(name);
    group.sample_size(20);
    for backend in [Backend::Pounce, Backend::Ripopt] {
        let settings = NlpSettings {
            backend,
            ..NlpSettings::default()
        };
        group.bench_function(backend.name(), |b| {
            b.iter(|| {
                let mut p = problem.clone();
                let sol = solve(&mut p, &settings);
                assert!(sol.status.is_converged());
                sol.iterations
            })
        });
    }
    group.finish();
}

fn benches(c: &mut Criterion) {
    bench_problem(c, "hs071", Hs071::default());
    bench_problem(c, "double_integrator_n50", DoubleIntegrator { n_int: 50 });
    bench_problem(c, "double_integrator_n500", DoubleIntegrator { n_int: 500 });
    bench_problem(c, "rosenbrock_disk", RosenbrockDisk);
}

criterion_group!(nlp, benches);
criterion_main!(nlp);
