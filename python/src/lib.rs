//! # brachia-py
//!
//! Python bindings of brachia (PyO3, abi3): the extension module `brachia._brachia`, re-exported by the
//! Python package `brachia` (python/brachia/__init__.py; type stubs in `__init__.pyi`). Thin: every
//! computation is a call of the Rust library; this crate only converts arrays and errors.
//!
//! ## Conventions (the crate docs of `brachia`, repeated)
//! - Planar, grip point at the origin, x right, y up, gravity along -y; SI units (m, kg, s, rad, N m, J).
//! - `q[0]` absolute angle of link 1 from +x (counter-clockwise), `q[i >= 1]` relative; state
//!   `x = [q (n), qd (n)]`; torques `tau` of joints 2..n (n - 1 values).
//! - Arrays out are float64 numpy arrays: vectors `(n,)`, time series `(samples, columns)` row-major,
//!   matrices `(rows, cols)`.
//!
//! ## Errors
//! Bad input raises `brachia.BrachiaError` (a `ValueError`) whose text is the Rust error's `Display`
//! unchanged (file, field, value, rule). A solve that does not converge is a `Plan` with its status,
//! not an exception. Every input array goes through one reader (`convert`): dtype (real numbers only),
//! byte order, shape, finiteness and the range of its quantity are checked before any Rust call, so no
//! call with a wrong shape reaches an assertion and no out-of-range value reaches the model. Results
//! are checked finite before they are returned (a non-finite one raises).
//!
//! ## Threads
//! Immutable classes (`Robot`, `Trajectory`, `Plan`, `Scenario`, results, the controller recipes of
//! `controllers`) are shared freely. The classes with state (`Mpc`, `SwingPlanner`, `ModelPlant`,
//! `RapierPlant`) hold it behind a lock (`shared`): any thread may call them, calls on one object run
//! one at a time, long work runs with the GIL released.

use convert::BrachiaError;
use pyo3::prelude::*;

mod bench;
mod control;
mod controllers;
mod convert;
mod dicts;
mod gym;
mod interrupt;
mod ladder;
mod model;
mod planning;
mod plants;
mod policy;
mod replan;
mod scenario;
mod shared;
mod sim;
mod traverse;
mod view;

/// The extension module `brachia._brachia` (use it through the package `brachia`).
#[pymodule]
fn _brachia(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("BrachiaError", py.get_type::<BrachiaError>())?;
    // the one capture rule (brachia_experiments::success): a scenario's TrackResult.report has its
    // verdict `reaches_bar`, the time `capture_t_s` and the distance `bar_error_m`
    m.add("SUCCESS_RADIUS_M", brachia_experiments::SUCCESS_RADIUS_M)?;
    m.add("CAPTURE_SPEED_M_S", brachia_experiments::CAPTURE_SPEED_M_S)?;
    m.add_class::<model::Robot>()?;
    m.add_class::<model::Trajectory>()?;
    m.add_class::<planning::Plan>()?;
    m.add_class::<replan::SwingPlanner>()?;
    m.add_class::<replan::ReplanOutcome>()?;
    m.add_class::<replan::Checkpoint>()?;
    m.add_class::<ladder::JointSwingPlan>()?;
    m.add_class::<ladder::JointPhase>()?;
    m.add_class::<control::Mpc>()?;
    m.add_class::<controllers::Tvlqr>()?;
    m.add_class::<controllers::Pd>()?;
    m.add_class::<controllers::OpenLoop>()?;
    m.add_class::<controllers::Kalman>()?;
    m.add_class::<controllers::ReplanningCtrl>()?;
    m.add_class::<controllers::AdaptiveCtrl>()?;
    m.add_class::<plants::ModelPlant>()?;
    m.add_class::<plants::RapierPlant>()?;
    m.add_class::<sim::TrackResult>()?;
    m.add_class::<scenario::Scenario>()?;
    m.add_class::<traverse::TraverseResult>()?;
    m.add_class::<gym::SwingCore>()?;
    m.add_class::<gym::SwingBatchCore>()?;
    m.add_function(wrap_pyfunction!(planning::plan, m)?)?;
    m.add_function(wrap_pyfunction!(ladder::plan_joint_swings, m)?)?;
    m.add_function(wrap_pyfunction!(sim::track, m)?)?;
    m.add_function(wrap_pyfunction!(scenario::traverse, m)?)?;
    m.add_function(wrap_pyfunction!(bench::benchmark, m)?)?;
    m.add_function(wrap_pyfunction!(control::rust_mpc_step_times, m)?)?;
    m.add_function(wrap_pyfunction!(dicts::jsonable, m)?)?;
    m.add_function(wrap_pyfunction!(view::view_folder, m)?)?;
    Ok(())
}
