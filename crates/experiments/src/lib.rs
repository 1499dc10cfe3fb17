//! # brachia-experiments
//!
//! The paper-and-benchmark layer of brachia, built on the run layer ([`brachia_run`]): the paper's
//! parameter study (Section V-A, Figs. 3 and 4: [`run_parameter_study`] and [`parameter_study_folder`]),
//! the reproduction of the paper's figures (`brachia reproduce`), and the robustness benchmark with its
//! Monte Carlo families (`brachia benchmark`).
//!
//! The run layer's modules and items are re-exported here unchanged (`brachia_experiments::scenario` is
//! `brachia_run::scenario`): this crate depends on the run layer, never the other way round.
//!
//! Conventions as in `brachia`: SI units; q1 absolute from +x, q2..qn relative; `x = [q, qd]`; torques of
//! joints 2..n. CSV headers: `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y[,extra]`.

pub mod benchmark;
pub mod parameter_study;
pub mod reproduce;
mod study_view;
pub mod view;

#[doc(no_inline)]
pub use brachia_run::*;

pub use benchmark::{
    run_benchmark, run_benchmark_on, run_benchmark_with, Benchmark, BenchmarkOutcome,
    BenchmarkSettings, ExtraController,
};
pub use parameter_study::{
    parameter_study_folder, read_parameter_study, run_parameter_study,
    run_parameter_study_cancellable, scaled_params, start_pose, BaseParams, CellStart,
    ParameterStudy, ParameterStudySettings, StickDiagram, StudyCell, StudyRow,
};
