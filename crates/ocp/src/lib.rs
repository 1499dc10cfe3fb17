//! brachia-ocp: a primal-dual interior-point solver for discrete-time optimal-control problems whose
//! Newton step is a Riccati recursion over the stages (O(K) in the horizon). It knows nothing of robots.
//!
//! The problem is stated in [`problem`]. (Docs: to be completed.)
#![warn(missing_docs)]

mod dense;
pub mod problem;
mod riccati;
mod settings;
mod solver;

pub use problem::{
    EvalError, EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageBounds, StageDims,
    StageEval, TerminalEval,
};
pub use settings::{
    OcpError, OcpSettings, OcpStats, OcpStatus, OcpTimings, MAX_EQUALITY_ROWS, MAX_STAGE_VARIABLES,
};
pub use solver::OcpSolver;
