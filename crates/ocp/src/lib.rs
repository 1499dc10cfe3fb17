//! brachia-ocp: a primal-dual interior-point solver for discrete-time optimal-control problems whose
//! Newton step is a Riccati recursion over the stages (O(K) in the horizon). It knows nothing of robots.
//!
//! The problem is stated in [`problem`]. (Solver: to be written; see docs/planner.md.)

pub mod problem;

pub use problem::{
    EvalError, EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageBounds, StageDims,
    StageEval, TerminalEval,
};
