//! A warm re-plan of the persistent planner does not allocate: a counting global allocator (this test
//! binary only) sees zero allocations across re-plans (stages evaluated serially, or in parallel with
//! the planner on a rayon worker) from disturbed states and restores of the
//! checkpoint, after the first ones (the solver's filter and rayon's pool grow once).

// A global allocator needs `unsafe impl GlobalAlloc`; it only forwards to `System`.
#![allow(unsafe_code)]

use brachia::model::Robot;
use brachia::planning::{
    Backend, NlpSettings, PlannerSettings, SwingPlanner, SwingTask, Transcription,
};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static ALLOCS: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        ALLOCS.fetch_add(1, Ordering::SeqCst);
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Warm-up re-plans, then the allocations of as many more.
fn count_replan_allocations(parallel_min_stages: usize) -> usize {
    let robot = Robot::paper();
    let task = SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    };
    let mut s = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.01,
        shooting: brachia::planning::ShootingSettings {
            substeps: 1,
            ..Default::default()
        },
        ..Default::default()
    };
    s.shooting.parallel_min_stages = parallel_min_stages;
    let nlp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    let mut planner = SwingPlanner::new(&robot, &task, &s, &nlp).unwrap();
    assert!(planner.plan_outcome().unwrap().converged());
    let k = 60;
    let t_now = planner.knot_time(k);
    let x_nom = planner.knots().x[k].clone();
    let cp = planner.checkpoint();
    // fixed disturbances (inside the bounds), preallocated
    let shifts: [[f64; 2]; 4] = [[0.05, -0.3], [-0.08, 0.4], [0.02, 0.1], [-0.03, -0.45]];
    let mut x = x_nom.clone();
    let run = |planner: &mut SwingPlanner, x: &mut Vec<f64>, d: &[f64; 2]| {
        assert!(planner.restore(&cp).unwrap().converged());
        for i in 0..4 {
            x[i] = x_nom[i] + d[0] * if i % 2 == 0 { 1.0 } else { -1.0 };
            x[4 + i] = x_nom[4 + i] + d[1];
        }
        let out = planner.replan(t_now, x).unwrap();
        assert!(out.converged(), "{:?}", out.status);
        out.iterations
    };
    // warm-up: the first re-plans may grow buffers once
    for d in &shifts[..2] {
        run(&mut planner, &mut x, d);
    }
    let before = ALLOCS.load(Ordering::SeqCst);
    let mut iters = 0;
    for d in &shifts {
        iters += run(&mut planner, &mut x, d);
    }
    let allocs = ALLOCS.load(Ordering::SeqCst) - before;
    assert!(iters > 0);
    allocs
}

#[test]
fn warm_replan_does_not_allocate() {
    // The counter sees allocations at all.
    let before = ALLOCS.load(Ordering::SeqCst);
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(ALLOCS.load(Ordering::SeqCst) > before && v.len() == 16);

    // serial stage evaluation
    let allocs = count_replan_allocations(usize::MAX);
    assert_eq!(
        allocs, 0,
        "serial: {allocs} allocations over 4 warm re-plans"
    );
    // parallel stage evaluation with the planner running on a rayon worker: the stage jobs go to
    // the worker's own deque (a job injected from a thread outside the pool goes through rayon's
    // injector queue, which allocates a block every 63 injections)
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let allocs = pool.install(|| count_replan_allocations(0));
    assert_eq!(
        allocs, 0,
        "parallel: {allocs} allocations over 4 warm re-plans"
    );
}
