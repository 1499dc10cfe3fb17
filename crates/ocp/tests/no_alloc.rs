//! A solve does not allocate after the first: a counting global allocator (this test binary only)
//! sees zero allocations across cold and warm re-solves of a QP and of the nonlinear pendulum,
//! restoration phase included.

// A global allocator needs `unsafe impl GlobalAlloc`; it only forwards to `System`.
#![allow(unsafe_code)]

mod common;

use brachia_ocp::*;
use common::*;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Counting is on for this thread only: the test harness's own threads allocate at times
    /// that depend on the machine's load (a flaky count of 4 seen under load).
    static COUNTING: Cell<bool> = const { Cell::new(false) };
}

fn counted() {
    if COUNTING.with(|c| c.get()) {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        counted();
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        counted();
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

fn count(f: impl FnOnce() -> OcpStats) -> (usize, OcpStats) {
    let before = ALLOCS.load(Ordering::SeqCst);
    COUNTING.with(|c| c.set(true));
    let stats = f();
    COUNTING.with(|c| c.set(false));
    (ALLOCS.load(Ordering::SeqCst) - before, stats)
}

#[test]
fn solves_after_the_first_do_not_allocate() {
    // The counter sees allocations at all.
    let before = ALLOCS.load(Ordering::SeqCst);
    COUNTING.with(|c| c.set(true));
    let v = std::hint::black_box(vec![1u8; 16]);
    COUNTING.with(|c| c.set(false));
    assert!(ALLOCS.load(Ordering::SeqCst) > before && v.len() == 16);

    let cold = OcpSettings::default();
    let warm = OcpSettings {
        warm_start: true,
        ..OcpSettings::default()
    };
    let warm_stored = OcpSettings {
        warm_start: true,
        warm_duals: WarmDuals::Stored,
        mu_init: 1e-6,
        warm_bound_push: 1e-9,
        ..OcpSettings::default()
    };

    // a random QP with bounds, stage rows and terminal rows
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut qp = random_qp(&mut rng, 20, 4, 2, 2, 2, true);
    let mut solver = OcpSolver::new(&qp.dims.clone()).unwrap();
    let first = solver.solve(&mut qp, &cold);
    assert_eq!(first.status, OcpStatus::Solved);
    let correctors = OcpSettings {
        centrality_correctors: 3,
        ..OcpSettings::default()
    };
    for (i, settings) in [&cold, &warm, &warm_stored, &cold, &correctors]
        .into_iter()
        .enumerate()
    {
        let (n, stats) = count(|| solver.solve(&mut qp, settings));
        assert_eq!(stats.status, OcpStatus::Solved);
        assert_eq!(n, 0, "QP solve {i} allocated {n} times");
        if i == 4 {
            assert!(stats.centrality_correctors > 0, "{stats:?}");
        }
    }

    // the pendulum (nonlinear, inertia correction), cold and warm after a change of x_0
    let mut p = Pendulum::new(100, 0.05, 4.0);
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    assert_eq!(solver.solve(&mut p, &cold).status, OcpStatus::Solved);
    let (n, stats) = count(|| solver.solve(&mut p, &cold));
    assert_eq!(stats.status, OcpStatus::Solved);
    assert_eq!(n, 0, "cold pendulum solve allocated {n} times");
    p.x0 = [0.01, 0.0];
    let (n, stats) = count(|| solver.solve(&mut p, &warm));
    assert_eq!(stats.status, OcpStatus::Solved);
    assert_eq!(n, 0, "warm pendulum solve allocated {n} times");

    // an infeasible problem goes through the restoration phase without allocating either
    let mut bad = Pendulum::new(30, 0.05, 1.0);
    let mut solver = OcpSolver::new(&bad.dims).unwrap();
    let first = solver.solve(&mut bad, &cold);
    assert!(!first.status.is_converged());
    let (n, stats) = count(|| solver.solve(&mut bad, &cold));
    assert!(
        matches!(
            stats.status,
            OcpStatus::LocallyInfeasible | OcpStatus::RestorationFailed
        ),
        "{stats:?}"
    );
    assert_eq!(n, 0, "failing solve allocated {n} times");
}
