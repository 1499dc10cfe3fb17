//! Offline swing planning by direct collocation (paper Section III): the sparse NLP seam ([`nlp`], its two
//! backends in its submodules), the transcriptions ([`collocation`]), the settings and the planner.
//!
//! Conventions follow the crate docs (SI units; `x = [q, qd]`, `q[0]` absolute, the rest relative;
//! `u = tau` of joints 2..n; gravity along -y).

pub mod clearance_check;
pub mod collocation;
pub mod cspace;
pub mod detour;
pub mod guess;
pub mod multi_swing;
pub mod nlp;
pub mod ocp_nlp;
pub mod plan_shooting;
pub mod planner;
pub mod profile;
pub mod settings;
pub mod shooting;
pub mod solve_log;
pub mod swing_planner;
pub mod swing_time;
pub mod task;
pub mod torque_continuation;
mod worker;
pub mod workload;

pub use clearance_check::{
    check_clearance, ClearanceSubject, ClearanceViolation, CLEARANCE_TOLERANCE_M,
};
pub use collocation::{CallbackTimings, CollocationNlp, EeTerminalFn, Layout, NoPath, RowBlocks};
pub use guess::{Blockage, GuessReport, GuessStrategy, LinkClearance, ObstacleGuess};
pub use multi_swing::{
    plan_joint_swings, JointPhase, JointStatus, JointSwingPlan, JointSwingTask, MultiSwingOcp,
    MAX_JOINT_SWINGS,
};
pub use nlp::{solve, Backend, MuStrategy, NlpSettings, NlpSolution, SolveStatus, SparseNlp};
pub use nlp::{PassStats, TimeSplit};
pub use ocp_nlp::{AdapterTimings, OcpNlp};
pub use planner::SolveAttempt;
pub use planner::{freefall_time, plan, plan_with_guess, Plan, Violations, WARM_START_MU_INIT};
pub use settings::{
    Bounds, PlannerSettings, ShootingSettings, SwingTime, Transcription, DEFAULT_KNOT_DT_S,
    DEFAULT_SHOOTING_SUBSTEPS, MAX_SWING_TIME_STARTS, MIN_FREE_SWING_TIME_RANGE_S,
    START_WIDEN_MARGIN,
};
pub use shooting::{
    AdDynamics, AnalyticDynamics, PointDynamics, ShootingTimings, SwingOcp, SwingOcpSpec,
};
pub use solve_log::SolveRole;
pub use swing_planner::{Checkpoint, ReplanOutcome, SwingPlanner, WarmPrimal};
pub use swing_time::{reference_swing_time, SwingTimeSearch, TriedSwingTime};
pub use task::{validate_task, SwingTask, MAX_OBSTACLES};
pub use torque_continuation::{ContinuationStop, TorqueContinuation};
