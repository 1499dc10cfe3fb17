//! One traverse of the irregular ladder (`scenarios/ladder-irregular.toml`: the paper robot, 6 bars,
//! spacing 0.7-1.2 m, heights +-0.2 m; every swing planned from the state the last one left, multiple
//! shooting on backend `ocp` at 30 ms knots, tracked by the MPC on the model plant, the grip switched at
//! every bar), **planning included**: whether one traverse of the irregular ladder runs faster than real time
//! on 2 cores.
//!
//! A manual pass runs the traverse once and prints its simulated duration (the sum of the tracked
//! swings' durations) beside the wall time and their ratio, the real-time factor (> 1 is faster than
//! real time), with the planning and tracking shares; then the criterion group times whole traverses
//! (10 samples). No run folder is written (figures and the GIF are not timed).
//! `BRACHIA_TRAVERSE_BENCH_ONCE=1` runs only the manual pass (for `valgrind --tool=callgrind`, with
//! `RAYON_NUM_THREADS=1`).
//!
//! Units: s.

use brachia_run::{run_traverse, LadderScenario, LoadedLadder};
use criterion::{criterion_group, criterion_main, Criterion};
use std::path::Path;
use std::time::{Duration, Instant};

fn scenario() -> LoadedLadder {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/ladder-irregular.toml");
    LadderScenario::load(&path).unwrap_or_else(|e| panic!("{e}"))
}

/// One traverse: its simulated duration (s) and wall time (s), and the planning and tracking wall
/// times the traverse measured itself (s).
fn once(ll: &LoadedLadder) -> (f64, Duration, f64, f64) {
    let t = Instant::now();
    let tr = run_traverse(ll).unwrap_or_else(|e| panic!("{e}"));
    let wall = t.elapsed();
    assert!(tr.status.completed(), "{}", tr.status);
    let sim: f64 = tr.swings.iter().map(|s| s.duration_s).sum();
    let plan: f64 = tr.swings.iter().map(|s| s.plan_time_s).sum();
    let track: f64 = tr.swings.iter().map(|s| s.track_time_s).sum();
    (sim, wall, plan, track)
}

fn bench(c: &mut Criterion) {
    let ll = scenario();
    let (sim, wall, plan, track) = once(&ll);
    let w = wall.as_secs_f64();
    eprintln!(
        "traverse/ladder-irregular: simulated {sim:.3} s, wall {w:.3} s (planning {plan:.3} s, \
         tracking {track:.3} s), real-time factor {:.2} ({} swings)",
        sim / w,
        ll.scenario.ladder.bars.len() - 1
    );
    if std::env::var_os("BRACHIA_TRAVERSE_BENCH_ONCE").is_some() {
        return;
    }
    let mut g = c.benchmark_group("traverse");
    g.sample_size(10);
    g.bench_function("ladder-irregular", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let (sim_i, wall_i, _, _) = once(&ll);
                std::hint::black_box(sim_i);
                total += wall_i;
            }
            total
        })
    });
    g.finish();
    eprintln!(
        "traverse/ladder-irregular: simulated duration {sim:.3} s per traverse (divide by the \
         criterion time for the real-time factor)"
    );
}

criterion_group!(benches, bench);
criterion_main!(benches);
