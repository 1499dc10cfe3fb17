//! The MPC control step does not allocate: a counting global allocator (this test binary only) sees
//! zero allocations across many control calls, for every discretisation / linearisation / torque
//! reference variant.

// A global allocator needs `unsafe impl GlobalAlloc`; it only forwards to `System`.
#![allow(unsafe_code)]

mod common;

use brachia::control::{Discretization, Linearization, Mpc, MpcSettings, TorqueReference};
use brachia::sim::{Controller, ModelPlant, Plant};
use common::*;
use std::alloc::{GlobalAlloc, Layout, System};

struct Counting;

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = MINE.try_with(|c| c.set(c.get() + 1));
        System.alloc(layout)
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        System.dealloc(ptr, layout)
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        let _ = MINE.try_with(|c| c.set(c.get() + 1));
        System.realloc(ptr, layout, new_size)
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

thread_local! {
    /// Allocations made by this thread (the harness runs tests in threads of their own).
    static MINE: std::cell::Cell<usize> = const { std::cell::Cell::new(0) };
}

/// Allocations made so far by the calling thread.
fn allocs() -> usize {
    MINE.with(|c| c.get())
}

#[test]
fn mpc_control_step_does_not_allocate() {
    // The counter sees allocations at all.
    let before = allocs();
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(allocs() > before && v.len() == 16);

    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 0.5);
    for disc in [Discretization::Euler, Discretization::Zoh] {
        for lin in [Linearization::Measured, Linearization::AlongReference] {
            for tref in [TorqueReference::Zero, TorqueReference::Planned] {
                let settings = MpcSettings {
                    discretization: disc,
                    linearization: lin,
                    torque_reference: tref,
                    ..MpcSettings::default()
                };
                let mut x0 = start_state();
                x0[1] += 0.05;
                let mut plant = ModelPlant::new(robot.clone(), &x0);
                let mut mpc = Mpc::new(robot.clone(), tr.clone(), settings).unwrap();
                let mut x = vec![0.0; 8];
                let mut tau = vec![0.0; 3];
                let mut counted = 0;
                for _ in 0..200 {
                    plant.state(&mut x);
                    let t = plant.time();
                    let before = allocs();
                    mpc.control(t, &x, &mut tau);
                    counted += allocs() - before;
                    plant.step(&tau, 1e-3);
                }
                assert_eq!(
                    counted, 0,
                    "{disc:?} {lin:?} {tref:?}: allocations in control()"
                );
                assert!(tau.iter().all(|v| v.is_finite()));
                assert!(mpc.last_qp_info().is_some());
            }
        }
    }
}

/// A [`ClosedLoop::step`] of the MPC on a noisy model plant does not allocate either (the log is
/// reserved at construction), and swapping the plan with an `Arc` between steps does not allocate.
#[test]
fn closed_loop_step_and_set_reference_do_not_allocate() {
    use brachia::sim::{ClosedLoop, NoiseSettings, Noisy, RunSettings};
    use std::sync::Arc;
    let robot = Arc::new(paper_robot(5.0));
    let tr = Arc::new(model_reference(&robot, &start_state(), 0.5));
    let plant = Noisy::new(
        ModelPlant::new(Arc::clone(&robot), &start_state()),
        NoiseSettings {
            q_std: 1e-3,
            qd_std: 1e-2,
            seed: 1,
        },
    )
    .unwrap();
    let mpc = Mpc::new(Arc::clone(&robot), Arc::clone(&tr), MpcSettings::default()).unwrap();
    let rs = RunSettings {
        duration_s: 0.2,
        ..RunSettings::default()
    };
    let mut cl = ClosedLoop::new(plant, mpc, Arc::clone(&robot), Arc::clone(&tr), &rs).unwrap();
    let before = allocs();
    let mut steps = 0;
    while cl.step().is_some() {
        steps += 1;
        if steps == 100 {
            cl.set_reference(Arc::clone(&tr)).unwrap();
        }
    }
    let counted = allocs() - before;
    assert_eq!(steps, 200);
    assert_eq!(counted, 0, "allocations in ClosedLoop::step");
    let log = cl.finish();
    assert_eq!(log.len(), 201);
}

/// The Kalman-filter wrapper around the MPC (with the input-rate penalty and delay prediction) and
/// the TVLQR do not allocate per control call either.
#[test]
fn estimated_mpc_and_tvlqr_do_not_allocate() {
    use brachia::control::{Estimated, EstimatorSettings, Tvlqr, TvlqrSettings};
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 0.5);
    let settings = MpcSettings {
        rate_diag: vec![1.0; 3],
        ..MpcSettings::default()
    };
    let mpc = Mpc::new(robot.clone(), tr.clone(), settings).unwrap();
    let est = EstimatorSettings {
        measurement_delay_s: 0.002,
        actuation_delay_s: 0.005,
        ..EstimatorSettings::default()
    };
    let kf = Estimated::new(mpc, robot.clone(), tr.clone(), est, 1e-3).unwrap();
    let lqr = Tvlqr::new(robot.clone(), tr.clone(), TvlqrSettings::default()).unwrap();
    let mut controllers: Vec<Box<dyn Controller>> = vec![Box::new(kf), Box::new(lqr)];
    for c in controllers.iter_mut() {
        let mut x0 = start_state();
        x0[1] += 0.05;
        let mut plant = ModelPlant::new(robot.clone(), &x0);
        let (mut x, mut tau) = (vec![0.0; 8], vec![0.0; 3]);
        let mut counted = 0;
        for _ in 0..200 {
            plant.state(&mut x);
            let t = plant.time();
            let before = allocs();
            c.control(t, &x, &mut tau);
            counted += allocs() - before;
            plant.step(&tau, 1e-3);
        }
        assert_eq!(counted, 0, "{}: allocations in control()", c.name());
        assert!(tau.iter().all(|v| v.is_finite()));
    }
}
