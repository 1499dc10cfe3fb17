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

#[test]
fn mpc_control_step_does_not_allocate() {
    // The counter sees allocations at all.
    let before = ALLOCS.load(Ordering::SeqCst);
    let v = std::hint::black_box(vec![1u8; 16]);
    assert!(ALLOCS.load(Ordering::SeqCst) > before && v.len() == 16);

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
                    let before = ALLOCS.load(Ordering::SeqCst);
                    mpc.control(t, &x, &mut tau);
                    counted += ALLOCS.load(Ordering::SeqCst) - before;
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
