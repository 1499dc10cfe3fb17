//! What a planning call returns: the plan, the solves it made and the violations at its solution.
//! Plain types, filled in by the solves and strategies.
//!
//! Units: s, m, rad, rad/s, N m, J.

use super::clearance_check::ClearanceViolation;
use super::nlp::{Backend, MuStrategy, NlpSolution, PassStats, SolveStatus, TimeSplit};
use super::profile::Clamped;
use super::report::{Blockage, Diagnosis, GuessReport, TorqueContinuation};
use super::transcription::collocation::{CallbackTimings, Layout};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};

/// Largest violation per kind of constraint at the solution.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Violations {
    /// Collocation defects (rad, rad/s).
    pub dynamics: f64,
    /// Final EE position, m.
    pub ee_position: f64,
    /// Final EE velocity, m/s.
    pub ee_velocity: f64,
    /// Clearance constraints (distance below the required clearance), m.
    pub clearance: f64,
    /// Variable bounds.
    pub bounds: f64,
}

/// One call of the NLP solver by the planner, adopted or not.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SolveAttempt {
    /// Barrier strategy of this attempt.
    pub mu_strategy: MuStrategy,
    /// How it ended.
    pub status: SolveStatus,
    /// True when the plan is this attempt's point.
    pub adopted: bool,
    /// Iterations over its passes.
    pub iterations: usize,
    /// Wall-clock time of the call, s (the sum of its passes).
    pub time_s: f64,
    /// Where that time went.
    pub time_split: TimeSplit,
    /// Every pass the backend ran in this call.
    pub passes: Vec<PassStats>,
    /// What the solve this attempt belongs to was for (the task itself, unless the planning call
    /// made several solves; see [`crate::planning::solve_log`]).
    #[serde(default)]
    pub role: SolveRole,
    /// 0-based index of that solve in the planning call (one solve is one problem, solved in one or
    /// two attempts); 0 when the call made one solve.
    #[serde(default)]
    pub solve: usize,
    /// The role of the enclosing solve when this attempt is one start of a free swing time's search
    /// made as one solve of an obstacle strategy or of the continuation on the torque limits (`role`
    /// is then the start's `free-time-start`); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub within: Option<SolveRole>,
    /// When this attempt's plan converged on its knots but its 1 ms trajectory breaks the clearance
    /// between them: where and by how much (that plan's [`Plan::clearance_violation`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub between_knots: Option<ClearanceViolation>,
    /// When the attempt ended in [`SolveStatus::NumericalError`] on the `ocp` backend: the
    /// solver's own message, which step failed (e.g. `"the Hessian could not be regularised
    /// (delta_w > 1e40)"`, `"non-finite Newton step"`); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub numerical_error: Option<String>,
}

/// The adopted attempt of `solves` (a plan's own attempts) with `violation`, the plan's
/// [`Plan::clearance_violation`], when the plan's `status` converged: the record of a solve that
/// converged on its knots but not between them, kept when a later solve's plan is returned.
pub(crate) fn note_between_knots(
    solves: &mut [SolveAttempt],
    status: &SolveStatus,
    violation: Option<&ClearanceViolation>,
) {
    if let (true, Some(v)) = (status.is_converged(), violation) {
        for a in solves.iter_mut().filter(|a| a.adopted) {
            a.between_knots = Some(*v);
        }
    }
}

impl SolveAttempt {
    pub(crate) fn new(sol: &NlpSolution, mu_strategy: MuStrategy) -> Self {
        SolveAttempt {
            mu_strategy,
            status: sol.status.clone(),
            adopted: false,
            iterations: sol.iterations,
            time_s: sol.solve_time_s,
            time_split: sol.time_split,
            passes: sol.passes.clone(),
            role: SolveRole::Task,
            solve: 0,
            within: None,
            between_knots: None,
            numerical_error: None,
        }
    }
}

/// A planned swing and how it was found.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Solver outcome (of the adopted attempt).
    pub status: SolveStatus,
    /// The backend that ran.
    pub backend: Backend,
    /// Iterations of the NLP solver, summed over every attempt in `solves` (adopted or not) and
    /// every pass.
    pub iterations: usize,
    /// Solver attempts, `solves.len()`: 1, or 2 when the first did not converge and was retried
    /// with the adaptive barrier strategy; more when the planning call made several solves (the
    /// obstacle strategies `guess`, the continuation on the torque limits `torque_continuation`,
    /// the starts of a free swing time).
    pub attempts: usize,
    /// Every solver attempt of the planning call, in the order they ran, with its passes, the
    /// solve it belongs to (`solve`) and what that solve was for (`role`); exactly one is
    /// `adopted`: the one this plan's point comes from.
    pub solves: Vec<SolveAttempt>,
    /// Wall-clock time of every attempt together, s (the sum of `solves[..].time_s`).
    pub solve_time_s: f64,
    /// Where the time of the attempts in `solves` went (the sum of their splits; see [`TimeSplit`]).
    pub time_split: TimeSplit,
    /// Time spent in the problems' callbacks by kind, over every attempt of every solve (the
    /// transcription's own measurement, inside `time_split.callbacks_s`).
    pub callback_timings: CallbackTimings,
    /// Objective value (the transcription's quadrature of ||qd||^2_Q1 + ||tau||^2_R1).
    pub objective: f64,
    /// Swing time T, s.
    pub swing_time_s: f64,
    /// T_freefall when the swing time was `auto`, s.
    pub freefall_time_s: Option<f64>,
    /// The layout (intervals, points, h).
    pub layout: Layout,
    /// The collocation points (knots, and midpoints for Hermite-Simpson).
    pub points: Trajectory,
    /// Accelerations at the points, row-major `points x n`.
    pub points_qdd: Vec<f64>,
    /// The swing at `output_dt` from 0 to exactly T (the last step the shorter one), states as the
    /// transcription implies between the points, torques as it assumes, clamped into the bounds
    /// (see [`crate::planning::profile::resample`]).
    pub trajectory: Trajectory,
    /// How far the clamp moved samples of `trajectory` into the bounds, per kind of variable.
    pub resample_clamped: Clamped,
    /// Paper eq. (18): signed work of the actuated joints over the 1 ms trajectory, J.
    pub energy_j: f64,
    /// Positive work of the actuated joints, J.
    pub positive_work_j: f64,
    /// EE position at the final knot, m.
    pub ee_final: [f64; 2],
    /// Largest constraint violations by kind.
    pub violations: Violations,
    /// EE distance from the target after replaying open loop, on the RK4 model from the start state,
    /// the torque profile the transcription assumes between its points, m (see
    /// [`crate::planning::profile::replay_ee_error`]).
    pub replay_ee_error_m: f64,
    /// Smallest surface distance to an obstacle (or between non-adjacent links) over the resampled
    /// trajectory, m; `None` without obstacles.
    pub min_obstacle_clearance_m: Option<f64>,
    /// The closest approach of `trajectory` that breaks the required clearance (obstacles avoided,
    /// non-adjacent links with self-collision on) by more than
    /// [`crate::planning::CLEARANCE_TOLERANCE_M`]; a plan with one is not converged, whatever its
    /// `status` (see [`crate::planning::clearance_check`]). `None`: the trajectory keeps it.
    pub clearance_violation: Option<ClearanceViolation>,
    /// With obstacles avoided and no warm-start guess: how the initial guess was found and what every
    /// solve cost (see [`crate::planning::strategy::obstacles`]); `None` otherwise.
    pub guess: Option<GuessReport>,
    /// When no strategy converged on a task with obstacles: which obstacle blocks which link
    /// ([`Blockage`], its `Display` is the message); `None` otherwise.
    pub blockage: Option<Blockage>,
    /// When no strategy converged on a task with obstacles (and the call was not cancelled): the
    /// obstacle and the link it blocks, and how much more torque or swing time the best detour
    /// found would need ([`Diagnosis`], its `Display` is the message; see
    /// [`crate::planning::strategy::diagnosis`]); `None` otherwise.
    pub diagnosis: Option<Diagnosis>,
    /// When a cold plan without obstacles did not converge within the torque limits (and
    /// `settings.torque_continuation` is on): what the continuation on the limits found (see
    /// [`crate::planning::strategy::torque_continuation`]); the plan is its result when it reached the real
    /// limits. `None` otherwise.
    pub torque_continuation: Option<TorqueContinuation>,
    /// When the task's swing time did not plan (or `"auto"` had no free-fall time) on a cold plan
    /// without obstacles: what the search in T tried (see [`crate::planning::strategy::swing_time`]);
    /// the plan is its result when it converged. `None` otherwise.
    pub swing_time_search: Option<super::report::SwingTimeSearch>,
}

impl Plan {
    /// True when the solver converged and the resampled trajectory keeps the required clearance
    /// (no [`Plan::clearance_violation`]).
    pub fn converged(&self) -> bool {
        self.status.is_converged() && self.clearance_violation.is_none()
    }

    /// A one-line account of a plan that did not converge: the status and, when known, what blocks
    /// the swing; `None` for a converged plan.
    pub fn failure_message(&self) -> Option<String> {
        if self.converged() {
            return None;
        }
        let mut msg = match (
            self.status.is_converged(),
            &self.clearance_violation,
            &self.blockage,
        ) {
            (true, Some(v), _) => format!(
                "the solver converged ({:?}), but the plan breaks the clearance between its \
                 checked points: {v}",
                self.status
            ),
            (_, _, Some(b)) => format!("the planner did not converge ({:?}): {b}", self.status),
            _ => format!("the planner did not converge ({:?})", self.status),
        };
        if let Some(d) = &self.diagnosis {
            msg += &format!("; {d}");
        }
        if let Some(t) = &self.torque_continuation {
            msg += &format!("; {t}");
        }
        if let Some(s) = &self.swing_time_search {
            msg += &format!("; {s}");
        }
        if self.guess.as_ref().is_some_and(|g| g.out_of_time) {
            msg += "; the obstacle strategies stopped at max_wall_time_s before one converged";
        }
        Some(msg)
    }
}

/// What a solve of a planning call was for.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, Default)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum SolveRole {
    /// The task as given, from the caller's guess or the planner's own.
    #[default]
    Task,
    /// The task without its obstacles: the swing the detour seeds deform.
    ObstacleFree,
    /// The task from detour seed `index` (0-based, in the order of `GuessReport::seeds`).
    DetourSeed {
        /// Which seed.
        index: usize,
    },
    /// The task from the configuration-space seed.
    CspaceSeed,
    /// The task again, from the point where the solve before it stopped at its iteration cap.
    Resumed,
    /// The task with every obstacle radius scaled by `scale` (continuation on the radii).
    ObstacleScale {
        /// Factor on the radii.
        scale: f64,
    },
    /// The task with every actuator limit scaled by `scale` (continuation on the torque limits; 1 =
    /// the real limits, solved from a plan with wider ones).
    TorqueScale {
        /// Factor on the limits.
        scale: f64,
    },
    /// The task with the swing time fixed at `t0_s` (one start of a free swing time's search).
    FreeTimeStart {
        /// The start's swing time, s.
        t0_s: f64,
    },
    /// The task at the swing time `t_s`, cold: an anchor of the search in T after the task's own
    /// swing time did not plan ([`crate::planning::strategy::swing_time`]).
    SwingTimeAnchor {
        /// The swing time, s.
        t_s: f64,
    },
    /// The task at the swing time `t_s`, warm from the last converged plan of the continuation in T
    /// ([`crate::planning::strategy::swing_time`]).
    SwingTimeStep {
        /// The swing time, s.
        t_s: f64,
    },
    /// The task again, warm from the solve before it, with the clearance rows also at the RK4
    /// sub-step states (that solve's resampled trajectory broke the clearance between the knots).
    SubstepClearance,
    /// The task from a seed of the obstacle chain on a coarser mesh (knots `knot_dt_s` apart): the
    /// guess of the solve on the task's own mesh that follows it
    /// ([`crate::planning::strategy::candidate`]).
    CoarseMesh {
        /// Knot spacing of the coarse mesh, s.
        knot_dt_s: f64,
    },
    /// The task again from a seed of the obstacle chain on the task's own mesh, after the solve
    /// warm from that seed's coarse plan ended without a clear plan
    /// ([`crate::planning::strategy::candidate`]; the seed is the one of the solves before it).
    FromSeed,
    /// The task from the configuration-space seed with the swing time free from the automatic
    /// swing time up to `t_max_s` ([`crate::planning::strategy::candidate`]).
    LongerSwing {
        /// Longest swing time allowed, s.
        t_max_s: f64,
    },
}

impl std::fmt::Display for SolveRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SolveRole::Task => write!(f, "the task"),
            SolveRole::ObstacleFree => write!(f, "without obstacles"),
            SolveRole::DetourSeed { index } => write!(f, "detour seed {index}"),
            SolveRole::CspaceSeed => write!(f, "c-space seed"),
            SolveRole::Resumed => write!(f, "resumed"),
            SolveRole::ObstacleScale { scale } => write!(f, "radii x{scale:.3}"),
            SolveRole::TorqueScale { scale } => write!(f, "torque limits x{scale:.3}"),
            SolveRole::FreeTimeStart { t0_s } => write!(f, "from T = {t0_s:.4} s"),
            SolveRole::SubstepClearance => write!(f, "clearance rows at the sub-steps"),
            SolveRole::CoarseMesh { knot_dt_s } => write!(f, "coarse mesh {knot_dt_s:.3} s"),
            SolveRole::FromSeed => write!(f, "again from the seed"),
            SolveRole::LongerSwing { t_max_s } => write!(f, "swing time free up to {t_max_s:.4} s"),
            SolveRole::SwingTimeAnchor { t_s } => write!(f, "cold at T = {t_s:.4} s"),
            SolveRole::SwingTimeStep { t_s } => write!(f, "continued to T = {t_s:.4} s"),
        }
    }
}
