//! What the strategies report on a plan: how an initial guess around obstacles was found
//! ([`GuessReport`]), what blocks a swing no strategy planned ([`Blockage`]), and what the
//! continuation on the torque limits found ([`TorqueContinuation`]), and what a placement that no
//! strategy planned would need ([`Diagnosis`], filled in by
//! [`crate::planning::strategy::diagnosis`]).
//!
//! Units: m, s, N m.

use super::clearance_check::ClearanceViolation;
use super::nlp::SolveStatus;
use super::strategy::cspace::CspaceReport;
use super::strategy::detour::SeedReport;
use serde::{Deserialize, Serialize};
use std::fmt;

/// Which strategy produced a plan.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GuessStrategy {
    /// The smooth step to the target pose (it cleared the obstacles, or continuation was off).
    SmoothStep,
    /// A detour guess: the obstacle-free plan deformed around the obstacles
    /// ([`crate::planning::strategy::detour`]).
    Detour,
    /// The configuration-space seed: a collision-free joint path found by a grid search
    /// ([`crate::planning::strategy::cspace`]).
    Cspace,
    /// Continuation on the obstacle radii.
    Continuation,
}

/// How the plan's initial guess was found and what it cost. The plan's own `iterations` and
/// `solve_time_s` are these totals (every solve counted, failed ones too).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GuessReport {
    /// The strategy of the returned plan (the last one tried when none converged).
    pub strategy: GuessStrategy,
    /// Whether the default smooth-step guess already cleared every obstacle (margin included).
    pub smooth_step_clear: bool,
    /// Solves done, failed ones included.
    pub solves: usize,
    /// Solver iterations summed over all solves.
    pub iterations: usize,
    /// Solve time summed over all solves, s.
    pub solve_time_s: f64,
    /// Radius scales whose solve converged, in order (continuation only; 0 = no obstacles).
    pub scales: Vec<f64>,
    /// The detour seeds, in the order tried, and which were tried (empty when the smooth step
    /// converged).
    #[serde(default)]
    pub seeds: Vec<SeedReport>,
    /// The configuration-space search and whether the plan from its seed converged (`None`: no
    /// detour seed failed, so it was not run).
    #[serde(default)]
    pub cspace: Option<CspaceReport>,
    /// Every configuration-space search of the homotopy seeds (goal by goal, route by route;
    /// [`crate::planning::strategy::homotopy`]), with whether the plan from each seed converged.
    #[serde(default)]
    pub cspace_routes: Vec<CspaceReport>,
    /// True when the call's time limit (`max_wall_time_s`) ended the strategies: they went past the
    /// first solve, none converged, and the limit was spent.
    #[serde(default)]
    pub out_of_time: bool,
}

/// The closest approach of one link to one obstacle over a plan's attempt.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct LinkClearance {
    /// 0-based obstacle index (position in the task's list).
    pub obstacle: usize,
    /// 0-based link index.
    pub link: usize,
    /// Smallest surface distance between the link's capsule and the obstacle over the attempt's
    /// points, m (margin not subtracted; negative: they overlap).
    pub min_clearance_m: f64,
    /// Time of that point, s.
    pub time_s: f64,
    /// The clearance is below the planner's margin (the constraint is violated there).
    pub violated: bool,
}

impl fmt::Display for LinkClearance {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "obstacle {} vs link {}: closest {:.4} m at t = {:.3} s{}",
            self.obstacle,
            self.link + 1,
            self.min_clearance_m,
            self.time_s,
            if self.violated { " (violated)" } else { "" }
        )
    }
}

/// What blocks a swing that no strategy planned: the clearance row with the largest violation over
/// the attempt returned, every obstacle's closest approach to every link along it, and whether the
/// start pose, the obstacle-free swing's final pose or the target bar is within the margin of the
/// obstacle.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Blockage {
    /// 0-based link index.
    pub link: usize,
    /// 0-based obstacle index (position in the task's list).
    pub obstacle: usize,
    /// Time of the worst knot of the best attempt, s.
    pub time_s: f64,
    /// Required clearance (margin included) minus the surface distance there, m (> 0: violated).
    pub violation_m: f64,
    /// The obstacle is within `margin` of the start pose.
    pub start_overlaps: bool,
    /// The obstacle is within `margin` of the final pose of the obstacle-free swing (the pose that
    /// reaches the bar), when that swing was planned.
    pub final_pose_overlaps: Option<bool>,
    /// The obstacle's surface is within the link radius plus the margin of the target bar.
    pub bar_overlaps: bool,
    /// The task is infeasible for certain: some obstacle's surface is within the last link's radius
    /// plus the margin of the target bar, so no pose that grasps the bar clears it (the planner then
    /// tries no other guess after the first solve).
    #[serde(default)]
    pub infeasible: bool,
    /// Every obstacle's closest approach to every link along the attempt, obstacle-major then link.
    #[serde(default)]
    pub clearances: Vec<LinkClearance>,
}

impl fmt::Display for Blockage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "obstacle {} blocks link {}: clearance violated by {:.4} m at t = {:.3} s over the best attempt",
            self.obstacle,
            self.link + 1,
            self.violation_m,
            self.time_s
        )?;
        if self.start_overlaps {
            write!(f, "; the start pose is within the margin of it")?;
        }
        if self.final_pose_overlaps == Some(true) {
            write!(f, "; the obstacle-free swing's final pose overlaps it")?;
        }
        if self.bar_overlaps {
            write!(f, "; it touches the target bar")?;
        }
        if self.infeasible {
            write!(
                f,
                " (infeasible: an obstacle is within the last link's radius plus the margin of the bar)"
            )?;
        }
        Ok(())
    }
}

/// Most warm plans of the tightening (the real limits first, then the bisection, then the real limits
/// once more): enough to close a bracket from 8x to [`SCALE_TOL`](crate::planning::strategy::torque_continuation::SCALE_TOL) by geometric midpoints (6 steps).
pub const MAX_STEPS: usize = 10;

/// Why the continuation on the actuator limits stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContinuationStop {
    /// A plan converged within the real limits (it is the plan returned).
    WithinLimits,
    /// The converged and the failed scale are within [`SCALE_TOL`](crate::planning::strategy::torque_continuation::SCALE_TOL) of each other.
    Bracketed,
    /// [`MAX_STEPS`] plans were made before the bracket closed.
    StepsSpent,
    /// The call's `max_wall_time_s` ran out (a solve ended for lack of time, or none could start).
    TimeSpent,
    /// No relaxed cold plan converged.
    NothingConverged,
}

/// What the continuation on the actuator limits found (`Plan::torque_continuation`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorqueContinuation {
    /// The scale of the last relaxed cold solve (the first that converged, or the last tried).
    pub relaxed_scale: f64,
    /// Whether a relaxed cold solve converged. When none did, widening the limits did not help (the
    /// swing fails for another reason, or needs more than the widest scale).
    pub relaxed_converged: bool,
    /// Smallest limit scale at which a plan of the continuation converged; `Some(1.0)`: the plan returned
    /// is within the real limits. `None` when no relaxed solve converged.
    pub reached_scale: Option<f64>,
    /// The largest scale below `reached_scale` whose plan failed (the last failure of the bisection,
    /// warm-started from the converged plan of that moment, not necessarily `reached_scale`'s): the
    /// bracket's lower end. `None` when the real limits converged or no warm plan failed.
    pub failed_scale: Option<f64>,
    /// Why the continuation stopped.
    pub stopped: ContinuationStop,
    /// Largest |tau| of the plan at `reached_scale` per actuated joint, over its collocation points, N m
    /// (empty when none converged).
    pub peak_torque_nm: Vec<f64>,
    /// The real limit of each actuated joint, `max(|tau_min|, |tau_max|)`, N m.
    pub limit_nm: Vec<f64>,
    /// Solver attempts of the continuation (not counting the failed cold plan before it).
    pub solves: usize,
    /// Solver iterations of the continuation.
    pub iterations: usize,
    /// Solve time of the continuation, s.
    pub solve_time_s: f64,
}

impl TorqueContinuation {
    /// True when the continuation planned the swing within the real limits.
    pub fn within_limits(&self) -> bool {
        self.stopped == ContinuationStop::WithinLimits
    }

    /// The actuated joint (0-based among the actuated ones) whose peak torque exceeds its limit the
    /// most, relative to the limit, with that peak and limit; `None` when nothing converged.
    pub fn worst_joint(&self) -> Option<(usize, f64, f64)> {
        self.peak_torque_nm
            .iter()
            .zip(&self.limit_nm)
            .enumerate()
            .map(|(j, (&p, &l))| (j, p, l))
            .fold(None, |b: Option<(usize, f64, f64)>, c| match b {
                Some(b) if b.1 / b.2 >= c.1 / c.2 => Some(b),
                _ => Some(c),
            })
    }
}

impl fmt::Display for TorqueContinuation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.reached_scale {
            Some(1.0) => write!(
                f,
                "planned by continuation on the torque limits (from {:.2}x the limits)",
                self.relaxed_scale
            ),
            Some(s) => {
                write!(
                    f,
                    "likely torque-limited: it converges with the torque limits scaled by {s:.3}"
                )?;
                if let Some((j, p, l)) = self.worst_joint() {
                    // joints are numbered from 1 with the passive grip joint first
                    write!(f, " (peak |tau| {p:.2} N m at joint {}, limit {l} N m)", j + 2)?;
                }
                if let Some(lo) = self.failed_scale {
                    write!(f, ", not at {lo:.3}")?;
                }
                match self.stopped {
                    ContinuationStop::StepsSpent => write!(
                        f,
                        " (the bracket was not closed within {MAX_STEPS} plans)"
                    )?,
                    ContinuationStop::TimeSpent => {
                        write!(f, " (the continuation ran out of max_wall_time_s)")?
                    }
                    _ => {}
                }
                write!(f, " (a local estimate, not a proof)")
            }
            None if self.stopped == ContinuationStop::TimeSpent => write!(
                f,
                "the continuation on the torque limits ran out of max_wall_time_s before a widened \
                 plan (up to {:.0}x) converged",
                self.relaxed_scale
            ),
            None => write!(
                f,
                "widening the torque limits up to {:.0}x did not help: no plan converged with them either",
                self.relaxed_scale
            ),
        }
    }
}

/// One swing time the search planned at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TriedSwingTime {
    /// The swing time, s.
    pub swing_time_s: f64,
    /// Whether it was an anchor (cold) or a step of a continuation (warm).
    pub warm: bool,
    /// How the plan ended.
    pub status: SolveStatus,
    /// Whether it converged.
    pub converged: bool,
}

/// What the search in T tried (see [`crate::planning::strategy::swing_time`]); `Plan::swing_time_search`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SwingTimeSearch {
    /// The swing time asked for, s: the seconds given or the free-fall rule's `2 T_freefall`;
    /// `None` when the rule gave no time.
    pub requested_s: Option<f64>,
    /// Why the free-fall rule gave no time, when it did not.
    pub rule_failure: Option<String>,
    /// The locked chain's half period of small oscillation, s, when the anchors were taken around
    /// it (the rule gave no time).
    pub reference_s: Option<f64>,
    /// Every plan of the search, in the order it ran.
    pub tried: Vec<TriedSwingTime>,
    /// The swing time of the plan returned when it converged, s.
    pub planned_s: Option<f64>,
    /// The search stopped because `max_wall_time_s` was spent or the call was cancelled.
    pub out_of_time: bool,
    /// Where each continuation in T that stopped short of the swing time asked for ended: its last
    /// converged plan and the bounds that plan presses against.
    #[serde(default)]
    pub stops: Vec<SwingTimeStop>,
}

/// The last converged plan of a continuation in T that could not step further towards the swing
/// time asked for, and what that plan presses against (within [`AT_BOUND`] of each bound): its
/// torque limits, the rate bound `qd_max`, the relative joints' bound `q_rel_max`. Whether more
/// torque alone would reach the swing time asked for is the continuation on the torque limits'
/// answer (`Plan::torque_continuation`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SwingTimeStop {
    /// The swing time of the last converged plan, s.
    pub swing_time_s: f64,
    /// Its largest `|tau|` over the limit of its joint (1 = at the limit).
    pub torque_use: f64,
    /// Its largest `|qd|`, rad/s.
    pub peak_rate_rad_s: f64,
    /// The rate bound `qd_max`, rad/s.
    pub rate_bound_rad_s: f64,
    /// The relative joints (2..n) that reach the bound `q_rel_max`.
    pub joints_at_bound: Vec<usize>,
    /// The bound `q_rel_max`, rad.
    pub joint_bound_rad: f64,
}

/// Within this fraction of a bound a plan presses against it.
pub const AT_BOUND: f64 = 0.005;

impl fmt::Display for SwingTimeStop {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut at = vec![];
        if self.torque_use >= 1.0 - AT_BOUND {
            at.push("the torque at its limit".to_string());
        }
        if self.peak_rate_rad_s >= (1.0 - AT_BOUND) * self.rate_bound_rad_s {
            at.push(format!(
                "a rate at its {} rad/s bound",
                self.rate_bound_rad_s
            ));
        }
        if !self.joints_at_bound.is_empty() {
            let j: Vec<String> = self.joints_at_bound.iter().map(|j| j.to_string()).collect();
            at.push(format!(
                "joint {} at its {} rad bound",
                j.join(", "),
                self.joint_bound_rad
            ));
        }
        if at.is_empty() {
            write!(f, "{:.3} s (within every bound)", self.swing_time_s)
        } else {
            write!(f, "{:.3} s with {}", self.swing_time_s, at.join(", "))
        }
    }
}

impl SwingTimeStop {
    /// The plan presses against a joint or rate bound (not only its torque limits).
    pub fn at_joint_or_rate_bound(&self) -> bool {
        !self.joints_at_bound.is_empty()
            || self.peak_rate_rad_s >= (1.0 - AT_BOUND) * self.rate_bound_rad_s
    }
}

impl SwingTimeSearch {
    /// The converged swing times nearest the one asked for, below and above it, s.
    pub fn nearest_planned(&self) -> (Option<f64>, Option<f64>) {
        let t = self.requested_s.unwrap_or(f64::NAN);
        let ok = self.tried.iter().filter(|x| x.converged);
        let below = ok
            .clone()
            .map(|x| x.swing_time_s)
            .filter(|&s| s < t)
            .fold(None, |m: Option<f64>, s| Some(m.map_or(s, |m| m.max(s))));
        let above = ok
            .map(|x| x.swing_time_s)
            .filter(|&s| s > t)
            .fold(None, |m: Option<f64>, s| Some(m.map_or(s, |m| m.min(s))));
        (below, above)
    }
}

impl fmt::Display for SwingTimeSearch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (&self.rule_failure, self.requested_s) {
            (Some(why), _) => write!(f, "the free-fall rule gave no swing time ({why})")?,
            (None, Some(t)) => write!(f, "T = {t:.3} s did not plan")?,
            (None, None) => write!(f, "the free swing time did not plan")?,
        }
        if let Some(r) = self.reference_s {
            write!(
                f,
                "; swing times around the locked chain's half period {r:.3} s were tried"
            )?;
        }
        let cold: Vec<String> = self
            .tried
            .iter()
            .filter(|x| !x.warm)
            .map(|x| {
                format!(
                    "{:.3} s {}",
                    x.swing_time_s,
                    if x.converged { "planned" } else { "failed" }
                )
            })
            .collect();
        if !cold.is_empty() {
            write!(f, "; cold plans at {}", cold.join(", "))?;
        }
        let warm = self.tried.iter().filter(|x| x.warm).count();
        if warm > 0 {
            write!(f, "; {warm} warm plans continued in T")?;
        }
        match self.planned_s {
            Some(t) => write!(f, "; planned at T = {t:.3} s"),
            None => {
                let (lo, hi) = self.nearest_planned();
                let name = |v: Option<f64>| v.map_or("none".to_string(), |v| format!("{v:.3} s"));
                if self.requested_s.is_some() {
                    write!(
                        f,
                        "; nearest swing times that plan: {} below, {} above (a local search, \
                         not a proof that none between plans)",
                        name(lo),
                        name(hi)
                    )?;
                }
                if !self.stops.is_empty() {
                    let s: Vec<String> = self.stops.iter().map(|s| s.to_string()).collect();
                    write!(f, "; the continuations in T stop at {}", s.join("; "))?;
                }
                if self.out_of_time {
                    write!(f, "; stopped at max_wall_time_s")?;
                }
                Ok(())
            }
        }
    }
}

/// What the diagnosis concludes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    /// The obstacles block every pose that grasps the target bar within the joint limits (by the
    /// margin; [`crate::planning::grasp::grasp_blocked`]) or the obstacle is within the margin of the
    /// start pose: no motion clears it, whatever the torque or swing time.
    Unreachable,
    /// A detour was found with the limits widened, and not within the real limits at a longer swing
    /// time: it needs more torque (the [`TorqueProbe`]'s ratios).
    NeedsTorque,
    /// A detour plans within the real torque limits with a longer swing time (the
    /// [`SwingTimeProbe`]'s `swing_time_s`).
    NeedsSwingTime,
    /// The torque probe's detour keeps the real limits: a detour exists that the strategies did not
    /// find from their guesses.
    DetourWithinLimits,
    /// No probe converged (or no time was left for one): no detour was found.
    NoDetourFound,
    /// No plan kept the clearance, but a detour converged on its knots and passes inside the margin
    /// only between them, by the [`Diagnosis::between_knots`] shortfall: a detour nearly exists
    /// (a finer mesh may plan it); nothing is said about more torque.
    ShortBetweenKnots,
}

/// A solve that converged on its knots but whose 1 ms trajectory passes inside the margin between
/// them: the closest of them to keeping the clearance ([`Verdict::ShortBetweenKnots`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BetweenKnots {
    /// Which solve: `plan` (the obstacle strategies' own plan, at the real limits), another solve
    /// of the strategies at the real limits on the task's own mesh (its role, e.g. `swing time free
    /// up to 4.4595 s`; [`crate::planning::SolveAttempt::between_knots`]) or the torque probe's
    /// guess (`cspace-seed`, `failed-attempt`; `torque_scale` above 1).
    pub solve: String,
    /// Factor on the actuator limits of that solve (1: the real limits).
    pub torque_scale: f64,
    /// Where its 1 ms trajectory comes closest inside the margin, and by how much.
    pub violation: ClearanceViolation,
}

/// The task planned with every actuator limit widened by `scale`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TorqueProbe {
    /// Factor on the actuator limits.
    pub scale: f64,
    /// Whether a plan with the widened limits converged (and kept the clearance).
    pub converged: bool,
    /// The guess of the plan that converged (or of the last one tried): `cspace-seed` or
    /// `failed-attempt`.
    pub guess: String,
    /// Largest |tau| per actuated joint over that plan's 1 ms trajectory, N m (empty when none
    /// converged).
    pub peak_torque_nm: Vec<f64>,
    /// The real limit per actuated joint, `max(|tau_min|, |tau_max|)`, N m.
    pub limit_nm: Vec<f64>,
    /// `peak_torque_nm / limit_nm` per actuated joint (empty when none converged): above 1, the
    /// detour needs that many times the limit.
    pub ratio: Vec<f64>,
    /// Every solve of the probe, in order: its guess and how it ended.
    pub tried: Vec<ProbeSolve>,
}

/// One solve of the torque probe.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ProbeSolve {
    /// The guess: `cspace-seed` or `failed-attempt`.
    pub guess: String,
    /// How the solve ended.
    pub status: SolveStatus,
    /// When it converged on its knots but its 1 ms trajectory breaks the clearance between them:
    /// where and by how much.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub between_knots: Option<ClearanceViolation>,
}

impl TorqueProbe {
    /// The actuated joint (0-based among the actuated ones) with the largest ratio, and that ratio.
    pub fn worst_joint(&self) -> Option<(usize, f64)> {
        self.ratio
            .iter()
            .copied()
            .enumerate()
            .fold(None, |b: Option<(usize, f64)>, c| match b {
                Some(b) if b.1 >= c.1 => Some(b),
                _ => Some(c),
            })
    }
}

/// The task planned at the real limits with a free swing time, from the torque probe's detour.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SwingTimeProbe {
    /// The range of T searched, s.
    pub range_s: [f64; 2],
    /// Whether it converged (and kept the clearance).
    pub converged: bool,
    /// The swing time of the plan that converged, s.
    pub swing_time_s: Option<f64>,
}

/// Why an obstacle plan failed and what it would need (see the module docs); `Plan::diagnosis`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Diagnosis {
    /// 0-based index of the obstacle that blocks the swing (position in the task's list).
    pub obstacle: usize,
    /// 0-based index of the link it blocks.
    pub link: usize,
    /// The conclusion.
    pub verdict: Verdict,
    /// The task's swing time, s.
    pub swing_time_s: f64,
    /// The torque probe; `None` when it did not run (unreachable, or no time left).
    pub torque_probe: Option<TorqueProbe>,
    /// The swing-time probe; `None` when it did not run (no widened detour, not multiple shooting,
    /// or no time left).
    pub swing_time_probe: Option<SwingTimeProbe>,
    /// The time limit or the cancel token stopped the probe before it was done.
    pub out_of_time: bool,
    /// Solves of the probe.
    pub solves: usize,
    /// Solver iterations of the probe.
    pub iterations: usize,
    /// Solve time of the probe, s.
    pub solve_time_s: f64,
    /// Every configuration-space search of the obstacle chain (to every goal pose tried) ran out of
    /// free cells without a path: no collision-free path of poses within the joint limits joins
    /// the start to the bar (at the search's grid and margin; evidence, not proof).
    #[serde(default)]
    pub paths_exhausted: bool,
    /// The solve (of the strategies or the torque probe) that converged on its knots and came
    /// closest to keeping the clearance between them, when no plan kept it; `None` when none
    /// converged on its knots.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub between_knots: Option<BetweenKnots>,
}

/// Relative distance below the torque probe's widened limit within which its plan's peak torque is
/// read as on that limit: the probe's bound, not what the detour needs.
const ON_WIDENED_LIMIT: f64 = 1e-3;

impl fmt::Display for Diagnosis {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (o, l) = (self.obstacle, self.link + 1);
        match self.verdict {
            Verdict::Unreachable => {
                return write!(
                f,
                "obstacle {o} blocks link {l} where it must pass (at the target bar or the start \
                     pose): no torque or swing time clears it"
            )
            }
            Verdict::ShortBetweenKnots => {
                write!(f, "obstacle {o} blocks link {l}")?;
                if let Some(b) = &self.between_knots {
                    let v = &b.violation;
                    let what = if b.solve == "plan" {
                        "the strategies' best plan, at the real limits".to_string()
                    } else if b.torque_scale == 1.0 {
                        format!("the strategies' solve \"{}\", at the real limits", b.solve)
                    } else {
                        format!(
                            "the torque probe from its {} guess, limits widened {:.0}x",
                            b.solve, b.torque_scale
                        )
                    };
                    write!(
                        f,
                        "; a detour converged on its knots ({what}) but passes {:.1} mm inside \
                         the margin between them ({} at t = {:.3} s, {:.4} m from each other \
                         against {:.4} m): no detour found keeps the clearance along the whole \
                         motion (a smaller planner.knot_dt may plan it)",
                        v.shortfall_m() * 1e3,
                        v.subject,
                        v.time_s,
                        v.clearance_m,
                        v.required_m
                    )?;
                }
            }
            Verdict::NoDetourFound if self.torque_probe.is_none() => write!(
                f,
                "obstacle {o} blocks link {l}; no time was left to probe what a detour would need"
            )?,
            Verdict::NoDetourFound => {
                write!(
                    f,
                    "obstacle {o} blocks link {l}; no detour was found, not with the torque limits \
                     widened {:.0}x either",
                    self.torque_probe.as_ref().map_or(0.0, |t| t.scale)
                )?;
                let tried = self.torque_probe.as_ref().map_or(&[][..], |t| &t.tried[..]);
                if !tried.is_empty()
                    && tried
                        .iter()
                        .all(|t| t.status == SolveStatus::LocallyInfeasible)
                {
                    write!(
                        f,
                        " (every widened solve, from {} guesses, ended locally infeasible: the \
                         obstacle's place against the start, the bar and the joint limits blocks \
                         it, not the torque)",
                        tried.len()
                    )?;
                }
            }
            _ => write!(f, "obstacle {o} blocks link {l}")?,
        }
        if self.paths_exhausted {
            write!(
                f,
                "; the configuration-space search found no collision-free path of poses within the \
                 joint limits to any goal pose tried (every reachable grid cell searched)"
            )?;
        }
        if let Some(tp) = self.torque_probe.as_ref().filter(|t| t.converged) {
            if let Some((j, r)) = tp.worst_joint() {
                // joints are numbered from 1 with the passive grip joint first
                write!(
                    f,
                    "; the detour found with the limits widened {:.0}x needs peak |tau| {:.2} N m at \
                     joint {}, {r:.2}x its limit {} N m",
                    tp.scale,
                    tp.peak_torque_nm[j],
                    j + 2,
                    tp.limit_nm[j]
                )?;
                if r >= tp.scale * (1.0 - ON_WIDENED_LIMIT) {
                    write!(
                        f,
                        " (on the widened limit itself: the bound searched, not a measured need)"
                    )?;
                }
            }
        }
        match &self.swing_time_probe {
            Some(SwingTimeProbe {
                swing_time_s: Some(t),
                ..
            }) => write!(
                f,
                "; within the limits it plans with a swing time of {t:.3} s ({:+.3} s)",
                t - self.swing_time_s
            )?,
            Some(s) => write!(
                f,
                "; not within the limits with a swing time in [{:.3}, {:.3}] s",
                s.range_s[0], s.range_s[1]
            )?,
            None => {}
        }
        if self.verdict == Verdict::DetourWithinLimits {
            write!(f, "; that detour keeps the real limits")?;
        }
        if self.out_of_time {
            write!(f, "; the probe stopped at the time limit")?;
        }
        write!(f, " (a local search, not a proof)")
    }
}
