//! A warm re-plan of the persistent planner does not allocate: a counting global allocator (this test
//! binary only) sees zero allocations across re-plans (stages evaluated serially, half of them on the
//! problem's helper thread, or on a rayon worker) from disturbed states and restores of the
//! checkpoint, after the first ones (the solver's filter grows once). The same for the
//! owned planner on the 30 ms re-planning mesh (`SwingPlanner`) and for the capture-miss
//! prediction of `control::Replanning`; and repeated cold solves of the shooting problem with obstacle and
//! self-collision rows (closed-form clearance derivatives) on one `OcpSolver`, with a fixed or a free
//! swing time, allocate nothing after the first solve. One `#[test]`: the counter is global to the binary.

// A global allocator needs `unsafe impl GlobalAlloc`; it only forwards to `System`.
#![allow(unsafe_code)]

use brachia::control::{Mpc, MpcSettings, ReplanSettings, Replanning};
use brachia::model::{Circle, ClearanceFn, Robot};
use brachia::planning::workload::replan_settings;
use brachia::planning::DistanceClearanceFn;
use brachia::planning::{
    plan, NlpSettings, PlannerSettings, SwingOcp, SwingOcpSpec, SwingPlanner, SwingTask,
};
use brachia_ocp::{OcpProblem, OcpSettings, OcpSolver, OcpStatus};
use std::alloc::{GlobalAlloc, Layout, System};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;

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

/// The tracking swing's task, multiple-shooting settings at `knot_dt` with the stage-parallelism
/// threshold, and the Riccati backend.
fn problem(knot_dt: f64, parallel_min_stages: usize) -> (SwingTask, PlannerSettings, NlpSettings) {
    let (mut s, nlp) = replan_settings(knot_dt);
    s.shooting.parallel_min_stages = parallel_min_stages;
    let task = SwingTask::paper();
    (task, s, nlp)
}

/// Warm-up re-plans, then the allocations of as many more.
fn count_replan_allocations(parallel_min_stages: usize) -> usize {
    let robot = Robot::paper();
    let (task, s, nlp) = problem(0.01, parallel_min_stages);
    let mut planner = SwingPlanner::new(robot.clone(), task.clone(), &s, &nlp).unwrap();
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

/// The owned planner on the 30 ms mesh: warm-up re-plans, then the allocations of four more; then
/// the allocations of four miss predictions of a `Replanning` holding it.
fn count_owned_allocations() -> (usize, usize) {
    let robot = Arc::new(Robot::paper());
    let (task, s, nlp) = problem(0.03, usize::MAX);
    let mut p = SwingPlanner::new(Arc::clone(&robot), task, &s, &nlp).unwrap();
    let reference = Arc::new(p.plan().unwrap().trajectory);
    let k = 20;
    let (t_now, x_nom, cp) = (p.knot_time(k), p.knots().x[k].clone(), p.checkpoint());
    let shifts: [[f64; 2]; 4] = [[0.05, -0.3], [-0.08, 0.4], [0.02, 0.1], [-0.03, -0.45]];
    let mut x = x_nom.clone();
    let mut run = |p: &mut SwingPlanner, d: &[f64; 2]| {
        assert!(p.restore(&cp).unwrap().converged());
        for i in 0..4 {
            x[i] = x_nom[i] + d[0] * if i % 2 == 0 { 1.0 } else { -1.0 };
            x[4 + i] = x_nom[4 + i] + d[1];
        }
        let out = p.replan(t_now, &x).unwrap();
        assert!(out.converged(), "{:?}", out.status);
    };
    for d in &shifts[..2] {
        run(&mut p, d);
    }
    let before = ALLOCS.load(Ordering::SeqCst);
    for d in &shifts {
        run(&mut p, d);
    }
    let replans = ALLOCS.load(Ordering::SeqCst) - before;

    let mpc = Mpc::new(
        Arc::clone(&robot),
        Arc::clone(&reference),
        MpcSettings::default(),
    )
    .unwrap();
    let mut rp =
        Replanning::new(mpc, p, Arc::clone(&reference), ReplanSettings::default()).unwrap();
    let mut xs = x_nom.clone();
    let before = ALLOCS.load(Ordering::SeqCst);
    let mut total = 0.0;
    for d in &shifts {
        xs[5] = x_nom[5] + d[1];
        total += rp.predict_miss(t_now, &xs);
    }
    let predictions = ALLOCS.load(Ordering::SeqCst) - before;
    assert!(total > 0.0 && total.is_finite());
    (replans, predictions)
}

/// Allocations of two cold solves, after a first one, of the 30 ms shooting problem with two
/// obstacles (one near the swing's path, one far) and self-collision, started from a plan's knots;
/// with `free`, the swing time free in [1.8, 2.6] s.
fn count_cold_solve_allocations_with_clearances(free: bool) -> usize {
    let robot = Robot::paper();
    let (task, s, nlp) = problem(0.03, usize::MAX);
    let p = plan(&robot, &task, &s, &nlp).unwrap();
    assert!(p.converged());
    let k_last = p.layout.intervals;
    let spec = SwingOcpSpec {
        intervals: k_last,
        swing_time_s: p.swing_time_s,
        substeps: 1,
        q1_diag: vec![0.01; 4],
        r1_diag: vec![1.0; 3],
        x_start: [p.points.q(0), p.points.qd(0)].concat(),
        target: task.target,
        bounds: Default::default(),
        parallel_min_stages: usize::MAX,
        substep_clearance: true,
    };
    let obstacles = [
        Circle {
            center: [0.0, -0.9],
            radius: 0.05,
        },
        Circle {
            center: [0.0, 1.0],
            radius: 0.1,
        },
    ];
    let cf = ClearanceFn::new(robot.clone(), &obstacles[..], 0.01).unwrap();
    let mut ocp: SwingOcp =
        SwingOcp::new(robot.clone(), spec, Some(DistanceClearanceFn::new(cf))).unwrap();
    assert_eq!(ocp.n_clearance(), 4 * 2 + 10);
    for k in 0..=k_last {
        ocp.guess_mut().x[k] = [p.points.q(k), p.points.qd(k)].concat();
        if k < k_last {
            ocp.guess_mut().u[k] = p.points.tau(k).to_vec();
        }
    }
    if free {
        ocp = ocp.with_free_swing_time(1.8, 2.6).unwrap();
        assert_eq!(ocp.dims().stages[0].nx, 9);
    }
    let mut solver = OcpSolver::new(ocp.dims()).unwrap();
    let settings = OcpSettings::default();
    let first = solver.solve(&mut ocp, &settings);
    assert_eq!(first.status, OcpStatus::Solved, "{first:?}");
    let before = ALLOCS.load(Ordering::SeqCst);
    let mut iters = 0;
    for _ in 0..2 {
        let st = solver.solve(&mut ocp, &settings);
        assert_eq!(st.status, OcpStatus::Solved);
        assert_eq!(st.iterations, first.iterations);
        iters += st.iterations;
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
    // half the stages on the problem's helper thread (the planner on a thread outside rayon's pool;
    // the counter sees both threads)
    let allocs = count_replan_allocations(0);
    assert_eq!(
        allocs, 0,
        "helper thread: {allocs} allocations over 4 warm re-plans"
    );
    // the planner running on a rayon worker: every stage on that worker
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .unwrap();
    let allocs = pool.install(|| count_replan_allocations(0));
    assert_eq!(
        allocs, 0,
        "on a rayon worker: {allocs} allocations over 4 warm re-plans"
    );
    // the owned planner on the re-planning mesh, and the miss prediction
    let (replans, predictions) = count_owned_allocations();
    assert_eq!(
        replans, 0,
        "owned: {replans} allocations over 4 warm re-plans"
    );
    assert_eq!(
        predictions, 0,
        "{predictions} allocations over 4 miss predictions"
    );
    // cold solves of the shooting problem with clearance rows, on the calling thread
    for free in [false, true] {
        let allocs = count_cold_solve_allocations_with_clearances(free);
        assert_eq!(
            allocs, 0,
            "cold solves with clearances (free swing time {free}): {allocs} allocations over 2 solves"
        );
    }
}
