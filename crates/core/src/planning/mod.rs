//! Offline swing planning (paper Section III), in layers; each uses only the ones above it in this
//! list:
//! - plain types: the task ([`task`]) and the proof that its obstacles leave no pose grasping the
//!   target bar ([`grasp`], which the task check uses), the settings ([`settings`]), the plan and its solves
//!   ([`outcome`]), the strategies' reports ([`report`]); the solver seam's problem trait, settings and
//!   status ([`nlp`]);
//! - checks and rules on a trajectory: the torque between points, the resampling and the replay
//!   ([`profile`]), the clearance check between knots ([`clearance_check`]), the record of several
//!   solves ([`solve_log`]);
//! - the transcriptions ([`transcription`]): direct collocation, multiple shooting;
//! - the solver backends ([`nlp`]: pounce-rs and ripopt behind one `solve`; the stage-structured
//!   solver of `brachia_ocp`);
//! - one solve of one swing from one guess (`solve`, crate-internal);
//! - the strategies that recover a failed solve ([`strategy`]: the obstacle chain, the torque
//!   continuation);
//! - the entries: one swing ([`planner`]: [`plan`], [`plan_with_guess`]), several swings planned
//!   jointly ([`multi_swing`]), and the persistent re-planner ([`swing_planner`]).
//!
//! Conventions follow the crate docs (SI units; `x = [q, qd]`, `q[0]` absolute, the rest relative;
//! `u = tau` of joints 2..n; gravity along -y).

pub mod clearance_check;
pub mod grasp;
pub mod multi_swing;
pub mod nlp;
pub mod outcome;
pub mod planner;
pub mod profile;
pub mod report;
pub mod settings;
pub(crate) mod solve;
pub mod solve_log;
pub mod strategy;
pub mod swing_planner;
pub mod task;
pub mod transcription;
#[cfg(any(test, feature = "testing"))]
#[doc(hidden)]
pub mod workload;

pub use clearance_check::{
    check_clearance, ClearanceSubject, ClearanceViolation, CLEARANCE_TOLERANCE_M,
};
pub use multi_swing::{
    plan_joint_swings, JointPhase, JointStatus, JointSwingPlan, JointSwingTask, MultiSwingOcp,
    MAX_JOINT_SWINGS,
};
pub use nlp::{solve, Backend, MuStrategy, NlpSettings, NlpSolution, SolveStatus, SparseNlp};
pub use nlp::{AdapterTimings, OcpNlp, PassStats, TimeSplit};
pub use outcome::{Plan, SolveAttempt, SolveRole, Violations};
pub use planner::{plan, plan_validated, plan_with_guess};
pub use report::{
    BetweenKnots, Blockage, ContinuationStop, Diagnosis, GuessReport, GuessStrategy, LinkClearance,
    ProbeSolve, SwingTimeProbe, TorqueContinuation, TorqueProbe, Verdict,
};
pub use settings::{
    Bounds, ObstacleGuess, PlannerSettings, ShootingSettings, SwingTime, Transcription,
    ValidSettings, DEFAULT_KNOT_DT_S, DEFAULT_SHOOTING_SUBSTEPS, MAX_SWING_TIME_STARTS,
    MIN_FREE_SWING_TIME_RANGE_S, START_WIDEN_MARGIN,
};
pub use solve::{freefall_time, WARM_START_MU_INIT};
pub use strategy::swing_time::{
    reference_swing_time, SwingTimeSearch, SwingTimeStop, TriedSwingTime,
};
pub use swing_planner::{Checkpoint, ReplanOutcome, SwingPlanner, WarmPrimal};
pub use task::{validate_task, SwingTask, ValidTask, MAX_OBSTACLES};
pub use transcription::collocation::{
    CallbackTimings, CollocationNlp, EeTerminalFn, Layout, NoPath, RowBlocks,
};
pub use transcription::shooting::{
    AdDynamics, AnalyticDynamics, PointDynamics, ShootingTimings, SwingOcp, SwingOcpSpec,
};
pub use transcription::DistanceClearanceFn;
