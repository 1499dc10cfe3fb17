//! # brachia
//!
//! Energy-optimal swings for underactuated brachiation robots: the planar n-link model, an offline
//! swing planner (direct collocation or multiple shooting), a linear MPC tracker and the plants they
//! run against.
//!
//! ## The problem
//! A planar chain of n links hangs from a bar by a passive grip joint (joint 1) and drives joints
//! 2..n. Its dynamics are `M(q) qdd + C(q, qd) qd + G(q) = B tau` with `B = [0; I]`. The planner
//! finds the swing time `T` and torques that move the free end (the end effector, EE) from a start
//! state to the next bar at rest-to-rest while minimising `int |tau|^2_R dt` plus state terms
//! ([`planning::plan`]), subject to torque and joint bounds and, optionally, obstacle clearances.
//! The MPC ([`control::Mpc`]) linearises the dynamics at the measured state, condenses the horizon
//! into a box-constrained QP and tracks the plan at 1 kHz on a plant ([`sim::Plant`]).
//!
//! ## Conventions (stated once here; repeated in file headers and CSV headers)
//! - **Frame**: planar, body frame at the grip point (origin), x to the right, y up; gravity along -y.
//! - **Angles** (rad): `q[0]` = absolute angle of link 1 from +x, counter-clockwise positive (the passive
//!   grip joint); `q[i]`, i >= 1, = angle of link i+1 relative to link i (actuated). Absolute angle of
//!   link i: `th_i = q_0 + ... + q_i`.
//! - **State** `x = [q (n), qd (n)]`; **input** `u = tau` = torques of joints 2..n (n - 1), so
//!   `B = [0; I]`. The end effector (EE) is the distal tip of link n.
//! - **Units**: SI throughout (m, kg, s, rad, N m, J).
//! - **Arrays**: row-major; a trajectory's sample k holds `q[k n..(k + 1) n]` (see [`trajectory`]).
//! - **Ownership**: controllers and plants hold `Arc<Robot>` and references as `Arc<Trajectory>`;
//!   their constructors take `impl Into<Arc<..>>`, so pass an owned value or a shared `Arc`.
//!
//! ## Modules
//! - [`model`]: parameters ([`model::Robot`]), kinematics, dynamics `M qdd + C qd + G = B tau`, exact
//!   derivatives, the MPC's linearisation, capsule clearances.
//! - [`math`]: the `Scalar` trait model code is written over (f64 and dual numbers).
//! - [`ad`]: forward-mode automatic differentiation of `LocalFn`s (exact Jacobians and Hessians).
//! - [`geometry`]: exact point-segment and segment-segment distances.
//! - [`integrate`]: integrators over the same `f(x, u)` (RK4 with sub-steps).
//! - [`trajectory`]: time series of states and torques, interpolation, Hermite resampling, CSV.
//! - [`planning`]: the swing planner (task, settings, collocation, multiple shooting, NLP backends).
//! - [`control`]: the [`control::Controller`] trait, the box QP, the MPC, PD and open-loop baselines.
//! - [`sim`]: the [`sim::Plant`] trait, the model plant, plant wrappers ([`sim::Noisy`]) and the closed
//!   loop ([`sim::ClosedLoop`], [`sim::run_closed_loop`]).
//! - [`limits`]: the bounds every input is checked against.
//! - [`error`]: the typed [`Error`].
//! - [`serde_exact`]: serde helpers for fixed-length values.
//! - [`toml_path`]: TOML parse errors that name the dotted field (`links[2].mass`).
//!
//! ## Plan a swing
//! ```
//! use brachia::planning::{plan, NlpSettings, PlannerSettings, SwingTask};
//! let robot = brachia::Robot::paper();
//! let task = SwingTask {
//!     q0: vec![-2.35, 0.0, -1.55, 0.0],
//!     qd0: vec![],
//!     target: [0.8, 0.0],
//!     obstacles: vec![],
//! };
//! let settings = PlannerSettings { knot_dt: 0.05, ..PlannerSettings::default() };
//! let p = plan(&robot, &task, &settings, &NlpSettings::default())?;
//! assert!(p.converged(), "{:?}", p.status);
//! let ee = robot.ee_position(p.trajectory.q(p.trajectory.len() - 1));
//! assert!((ee[0] - 0.8).abs() < 1e-3 && ee[1].abs() < 1e-3);
//! # Ok::<(), brachia::Error>(())
//! ```
//!
//! ## Simulate the model
//! ```
//! use brachia::sim::{ModelPlant, Plant};
//! let robot = brachia::Robot::paper();
//! let mut plant = ModelPlant::new(robot, &[-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0]);
//! let e0 = plant.energy();
//! for _ in 0..500 {
//!     plant.step(&[0.0; 3], 1e-3); // 0.5 s of passive swing
//! }
//! assert!((plant.energy() - e0).abs() < 1e-6 * e0.abs().max(1.0)); // RK4 conserves energy
//! ```
//!
//! ## An MPC loop, one control period at a time
//! ```
//! use brachia::control::{Mpc, MpcSettings};
//! use brachia::sim::{ClosedLoop, ModelPlant, Plant, RunSettings};
//! use brachia::trajectory::Trajectory;
//! use std::sync::Arc;
//! let robot = Arc::new(brachia::Robot::paper());
//! // A reference: the passive swing from the paper's start pose, sampled at 1 ms.
//! let x0 = [-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0];
//! let mut sim = ModelPlant::new(Arc::clone(&robot), &x0);
//! let (mut reference, mut x) = (Trajectory::new(4), [0.0; 8]);
//! for _ in 0..=300 {
//!     sim.state(&mut x);
//!     reference.push(sim.time(), &x[..4], &x[4..], &[0.0; 3]);
//!     sim.step(&[0.0; 3], 1e-3);
//! }
//! let reference = Arc::new(reference);
//! // Track it from a perturbed start.
//! let mut start = x0;
//! start[1] += 0.05;
//! let plant = ModelPlant::new(Arc::clone(&robot), &start);
//! let mpc = Mpc::new(Arc::clone(&robot), Arc::clone(&reference), MpcSettings::default())?;
//! let run = RunSettings { duration_s: 0.25, ..RunSettings::default() };
//! let mut cl = ClosedLoop::new(plant, mpc, robot, Arc::clone(&reference), &run)?;
//! while let Some(step) = cl.step() {
//!     // Your logic between control periods: inspect cl.plant(), swap the plan with
//!     // cl.set_reference(..), stop early, ...
//!     assert!(step.t <= 0.25);
//! }
//! let log = cl.finish();
//! assert_eq!(log.len(), 251);
//! assert!(log.summary().joint_rms_error_rad < 0.05);
//! # Ok::<(), brachia::Error>(())
//! ```
//!
//! ## Track a plan to the end
//! ```
//! use brachia::control::{Pd, PdSettings};
//! use brachia::sim::{run_closed_loop, ModelPlant, NoiseSettings, Noisy, Plant, RunSettings};
//! use brachia::trajectory::Trajectory;
//! let robot = brachia::Robot::paper();
//! let x0 = [-2.35, 0.0, -1.55, 0.0, 0.0, 0.0, 0.0, 0.0];
//! let mut sim = ModelPlant::new(robot.clone(), &x0);
//! let (mut reference, mut x) = (Trajectory::new(4), [0.0; 8]);
//! for _ in 0..=200 {
//!     sim.state(&mut x);
//!     reference.push(sim.time(), &x[..4], &x[4..], &[0.0; 3]);
//!     sim.step(&[0.0; 3], 1e-3);
//! }
//! // A PD tracker on a model plant whose sensors add seeded Gaussian noise.
//! let noise = NoiseSettings { q_std: 1e-3, qd_std: 1e-2, seed: 1 };
//! let mut plant = Noisy::new(ModelPlant::new(robot.clone(), &x0), noise)?;
//! let mut pd = Pd::new(robot.clone(), reference.clone(), PdSettings::default())?;
//! let run = RunSettings { duration_s: 0.2, ..RunSettings::default() };
//! let log = run_closed_loop(&mut plant, &mut pd, &reference, &robot, &run)?;
//! assert_eq!(log.len(), 201);
//! assert!(log.summary().ee_error_max_m < 0.01);
//! # Ok::<(), brachia::Error>(())
//! ```
#![warn(missing_docs)]

/// `$body` with `$n` bound to the link count `$count`: to the constant 4 for the paper's robot, so an
/// `#[inline(always)]` body called from it is compiled with constant sizes (unrolled, no bounds checks;
/// the same arithmetic), and to the run-time count for any other robot. The one dispatch of the crate's
/// constant-size kernels (forward dynamics, Cholesky, analytic derivatives, the shooting pass).
macro_rules! with_link_count {
    ($count:expr, |$n:ident| $body:expr) => {{
        let count: usize = $count;
        if count == 4 {
            let $n: usize = 4;
            $body
        } else {
            let $n: usize = count;
            $body
        }
    }};
}

/// The widest vector instructions this CPU has, detected once per process: the [`pulp::Arch`] the
/// crate's dispatched kernels (analytic derivatives, the shooting stages) run through. Bodies
/// dispatched on it are element-wise with no fused multiply-adds, so every CPU gets the same numbers.
pub(crate) fn simd_arch() -> pulp::Arch {
    static ARCH: std::sync::LazyLock<pulp::Arch> = std::sync::LazyLock::new(pulp::Arch::new);
    *ARCH
}

pub mod ad;
pub mod control;
pub mod error;
#[cfg(any(test, feature = "testing"))]
#[doc(hidden)]
pub mod fdcheck;
pub mod geometry;
pub mod integrate;
pub mod ladder;
pub mod limits;
pub mod math;
pub mod model;
pub mod planning;
pub mod serde_exact;
pub mod serde_nonfinite;
pub mod sim;
pub mod toml_path;
pub mod trajectory;
pub mod urdf;

pub use brachia_ocp::{CancelToken, Cancelled, IterationMark};
pub use error::{Error, Result};
pub use model::Robot;
