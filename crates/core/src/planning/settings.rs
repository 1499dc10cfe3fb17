//! Planner settings: swing time, knot spacing, transcription, weights, bounds.
//!
//! Units: s, rad, rad/s, N m. Weights are the diagonals of the paper's Q1 (on qd, n values) and R1 (on tau,
//! n - 1 values).

use crate::error::{Error, Result};
use crate::limits;
use serde::{Deserialize, Serialize};

/// How the planner finds its initial guess when the task has obstacles (`[planner] obstacle_guess`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum ObstacleGuess {
    /// The smooth step to the target pose only, as without obstacles (one solve).
    Direct,
    /// The smooth step; when that solve fails, the detour seeds, then continuation on the obstacle
    /// radii, both from an obstacle-free plan (see the module docs). Default.
    #[default]
    Continuation,
}

/// How the dynamics are imposed between knots (paper eq. 6 and better rules).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Transcription {
    /// Paper eq. (6) with the `qd dt` term the paper dropped:
    /// `q+ = q + qd h + qdd h^2 / 2`, `qd+ = qd + qdd h`; torque held over the interval.
    Euler,
    /// Trapezoidal rule on `[qd, qdd]`; torque linear between knots.
    Trapezoidal,
    /// Hermite-Simpson (separated form: midpoint states and torques are variables); torque quadratic.
    /// Solved by pounce or ripopt (the paper's rule; a cross-check of the default).
    HermiteSimpson,
    /// RK4 multiple shooting (`"multiple-shooting"`): states and torques at the knots, torque held
    /// over each interval, `x_{k+1} = Phi(x_k, u_k)` by [`ShootingSettings::substeps`] RK4 steps. A
    /// stage-structured problem ([`crate::planning::SwingOcp`]): solved by the `ocp` backend (Riccati
    /// interior point, the default) or by pounce / ripopt through [`crate::planning::OcpNlp`]. Default.
    #[default]
    MultipleShooting,
}

/// Settings of the multiple-shooting transcription (`[planner.shooting]`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ShootingSettings {
    /// RK4 steps per shooting interval (>= 1). Default [`DEFAULT_SHOOTING_SUBSTEPS`] = 3: with the
    /// default 30 ms knots, RK4 steps of 10 ms, the step the paper's knots have (one step per 30 ms
    /// interval misses the bar by up to 2 cm on the long swings of the parameter study; docs/planner.md).
    pub substeps: usize,
    /// Evaluate half the stages on a helper thread when the problem has at least this many stages
    /// (and rayon has more than one thread); 0 = always, a huge value = never. Default 16
    /// (docs/planner.md, "Memory and threads").
    pub parallel_min_stages: usize,
    /// When a solve converged but its resampled trajectory breaks the clearance between the knots,
    /// solve again, warm from it, with the clearance rows also at the RK4 sub-step states inside each
    /// interval (the states after each of its first `substeps - 1` steps): with the default 30 ms
    /// knots and 3 steps, every 10 ms (docs/planner.md, "Clearance between the checked points").
    /// Default true.
    pub substep_clearance: bool,
}

impl Default for ShootingSettings {
    fn default() -> Self {
        ShootingSettings {
            substeps: DEFAULT_SHOOTING_SUBSTEPS,
            parallel_min_stages: 16,
            substep_clearance: true,
        }
    }
}

/// Default RK4 steps per shooting interval (see [`ShootingSettings::substeps`]).
pub const DEFAULT_SHOOTING_SUBSTEPS: usize = 3;

/// Largest number of RK4 steps per multiple-shooting interval (each costs a dynamics evaluation and
/// its derivatives per stage and iteration; 100 steps of a 10 ms interval are 0.1 ms each).
pub const MAX_SHOOTING_SUBSTEPS: usize = 100;

/// Default knot spacing, s: 30 ms shooting intervals of [`DEFAULT_SHOOTING_SUBSTEPS`] RK4 steps each
/// (10 ms steps, the paper's knot spacing, with the torque held over 30 ms). The plan's own torques,
/// replayed open loop, reach the bar to well under 1 mm on every scenario and study cell, with
/// a third of the stages of 10 ms knots (docs/interpretations.md, docs/planner.md).
pub const DEFAULT_KNOT_DT_S: f64 = 0.03;

/// Narrowest [`PlannerSettings::free_swing_time`] range solved with T free, s: a narrower one is the
/// fixed T it starts from (within the range, less than 1 ms from any T in it). Ranges of 1e-6 s
/// ended in `NumericalError` (every stage's T bounds nearly coincide).
pub const MIN_FREE_SWING_TIME_RANGE_S: f64 = 1e-3;

/// Largest [`PlannerSettings::swing_time_starts`] (each start is a whole plan).
pub const MAX_SWING_TIME_STARTS: usize = 16;

fn one() -> usize {
    1
}

fn is_one(v: &usize) -> bool {
    *v == 1
}

/// The swing time T.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum SwingTime {
    /// A fixed time in seconds.
    Seconds(f64),
    /// `"auto"`: T = 2 T_freefall (see [`crate::planning::freefall_time`]).
    Auto(AutoTag),
}

/// The literal `"auto"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AutoTag {
    /// T = 2 T_freefall.
    Auto,
}

impl Default for SwingTime {
    fn default() -> Self {
        SwingTime::Auto(AutoTag::Auto)
    }
}

/// Box bounds on the knot variables (paper eq. 10). Torque limits come from the robot.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Bounds {
    /// Range of q1 (absolute angle of link 1), rad. Default [-pi, 0]: link 1 stays below the bar.
    #[serde(deserialize_with = "crate::serde_exact::pair")]
    pub q1: [f64; 2],
    /// Largest |q_i| of the relative joints 2..n, rad. Default 2.9 (links may fold but not pass through
    /// each other).
    pub q_rel_max: f64,
    /// Largest |qd_i| of every joint, rad/s. Default 15.
    pub qd_max: f64,
    /// Largest |qd_i| of every joint at the **last knot**, rad/s (the rest condition of a traverse:
    /// the chain ends the swing nearly at rest, not only its EE, docs/interpretations.md). Default
    /// none (only `qd_max`); when set, finite, > 0 and at most `qd_max`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qd_end_max: Option<f64>,
}

/// Margin by which [`Bounds::widened_for_start`] widens the q1 range (and `q_rel_max`) past a start
/// state, rad.
pub const START_WIDEN_MARGIN: f64 = 0.1;

impl Bounds {
    /// These bounds widened to take a start state `x = [q, qd]` (2n) that a tracked chain reached
    /// (the start of a later swing of a traverse, the measured state of a re-plan): the q1 range to
    /// include `x[0]` with [`START_WIDEN_MARGIN`] to spare either side; `q_rel_max` to the largest
    /// start |q_i| (i >= 2) plus the margin, at most pi, when that |q_i| exceeds it (a relative angle
    /// past pi is a link through its neighbour, which no wrapped angle reaches); `qd_max` to 1.05
    /// times the largest start rate (at most [`crate::limits::MAX_RATE_RAD_S`]) when that rate
    /// exceeds it. The bounds are on the plan; a tracked chain follows the plan within its tracking
    /// error and may end a little past them, and a knot-0 state outside the bounds of knot 1 makes
    /// the problem infeasible. `qd_end_max` (the rest condition at the last knot) is kept.
    pub fn widened_for_start(&self, x: &[f64]) -> Bounds {
        let n = x.len() / 2;
        let m = START_WIDEN_MARGIN;
        let mut b = self.clone();
        b.q1 = [b.q1[0].min(x[0] - m), b.q1[1].max(x[0] + m)];
        let q_rel = x[1..n].iter().fold(0.0, |a: f64, v| a.max(v.abs()));
        if q_rel > b.q_rel_max {
            b.q_rel_max = (q_rel + m).min(std::f64::consts::PI);
        }
        let qd = x[n..].iter().fold(0.0, |a: f64, v| a.max(v.abs()));
        if qd > b.qd_max {
            b.qd_max = (qd * 1.05).min(crate::limits::MAX_RATE_RAD_S);
        }
        b
    }

    /// The representative of the angle `q1` (mod 2 pi, one turn either way) nearest the range
    /// [`Bounds::q1`]: the start angle a later swing of a traverse (or a joint multi-swing plan)
    /// plans from after the grasp switch, whose map wraps `q'_1` into (-pi, pi].
    pub fn nearest_q1(&self, q1: f64) -> f64 {
        let [lo, hi] = self.q1;
        let tau = std::f64::consts::TAU;
        let dist = |v: f64| (lo - v).max(v - hi).max(0.0);
        [q1 - tau, q1, q1 + tau]
            .into_iter()
            .fold(q1, |b, v| if dist(v) < dist(b) { v } else { b })
    }

    /// True when the state `x = [q, qd]` (2n) lies strictly inside the box bounds of an inner knot:
    /// `q1` inside its range, every relative angle and every rate below `q_rel_max` and `qd_max` in
    /// absolute value (the rest condition `qd_end_max` is not checked).
    pub fn strictly_contains(&self, x: &[f64]) -> bool {
        let n = x.len() / 2;
        x[0] > self.q1[0]
            && x[0] < self.q1[1]
            && x[1..n].iter().all(|q| q.abs() < self.q_rel_max)
            && x[n..].iter().all(|v| v.abs() < self.qd_max)
    }

    /// The joint-rate bound at a knot: [`Bounds::qd_end_max`] at the last one (when set), else
    /// [`Bounds::qd_max`].
    pub fn qd_bound(&self, last: bool) -> f64 {
        match (last, self.qd_end_max) {
            (true, Some(v)) => v.min(self.qd_max),
            _ => self.qd_max,
        }
    }
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds {
            q1: [-std::f64::consts::PI, 0.0],
            q_rel_max: 2.9,
            qd_max: 15.0,
            qd_end_max: None,
        }
    }
}

/// Everything the planner needs besides the robot and the task.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PlannerSettings {
    /// Swing time: `"auto"` (2 T_freefall) or seconds. With `free_swing_time`, the start of the
    /// search (clamped into that range). Default `auto`.
    pub swing_time: SwingTime,
    /// A free swing time `[t_min, t_max]`, s: T becomes a decision variable of the plan in that range,
    /// starting from `swing_time` clamped into it; the plan's `swing_time_s` is the optimum. Needs the
    /// multiple-shooting transcription; plans and the persistent planner (whose re-plans keep the
    /// plan's T), not a joint multi-swing plan. Default none: T is `swing_time`. The number of intervals K is
    /// `round(t_max / knot_dt)` and stays fixed, so the plan's knot spacing `T / K` is at most
    /// about `knot_dt`.
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        deserialize_with = "crate::serde_exact::opt_pair"
    )]
    pub free_swing_time: Option<[f64; 2]>,
    /// Solves of a free swing time from this many starts (1 ..= [`MAX_SWING_TIME_STARTS`]; default
    /// 1): `swing_time` clamped into the range, then the centres of `starts - 1` equal parts of the
    /// range; the plan is the converged one of lowest objective (the objective has several local
    /// optima in T), or the first start's if none converged. Only with `free_swing_time`; a range
    /// of one value (or narrower than [`MIN_FREE_SWING_TIME_RANGE_S`]) has one start. The solver's
    /// `max_wall_time_s` bounds the whole search: each start gets what is left, and no start begins
    /// once it is spent.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    pub swing_time_starts: usize,
    /// Knot spacing, s (default [`DEFAULT_KNOT_DT_S`] = 0.03, the multiple-shooting mesh that replays
    /// within 1 mm; the paper's 10 ms knots are `0.01`, the value to give with a collocation rule);
    /// the number of intervals is `round(T / knot_dt)`.
    pub knot_dt: f64,
    /// How the dynamics are imposed between knots. Default `multiple-shooting`.
    pub transcription: Transcription,
    /// Diagonal of Q1, the weight on joint velocities (n values). Default empty: 0.01 each.
    pub q1_diag: Vec<f64>,
    /// Diagonal of R1, the weight on torques (n - 1 values). Default empty: 1 each.
    pub r1_diag: Vec<f64>,
    /// Box bounds.
    pub bounds: Bounds,
    /// Extra clearance kept from obstacles and between non-adjacent links, m (default 0.01).
    pub obstacle_margin: f64,
    /// Avoid obstacles (default true; false plans as if they were absent).
    pub avoid_obstacles: bool,
    /// Keep non-adjacent links apart (default true).
    pub self_collision: bool,
    /// Period of the resampled output trajectory, s (default 0.001).
    pub output_dt: f64,
    /// Multiple-shooting settings (used by `transcription = "multiple-shooting"` only).
    pub shooting: ShootingSettings,
    /// Initial guess with obstacles, `"continuation"` or `"direct"` (see
    /// [`crate::planning::strategy::obstacles`]). Default `continuation`.
    pub obstacle_guess: ObstacleGuess,
    /// When a cold plan without obstacles does not converge: plan it again with the torque limits
    /// widened and tighten them back by continuation, returning the plan within the limits when one is
    /// found, else the failure with how much torque the swing likely needs (default true; see
    /// [`crate::planning::strategy::torque_continuation`]).
    pub torque_continuation: bool,
    /// When a cold plan without obstacles does not converge at its swing time (or `"auto"` has no
    /// free-fall time): search in T, planning at neighbouring swing times and continuing a swing that
    /// plans towards the one asked for; with `"auto"` the first that plans is the plan (default true;
    /// see [`crate::planning::strategy::swing_time`]).
    pub swing_time_search: bool,
}

impl Default for PlannerSettings {
    fn default() -> Self {
        PlannerSettings {
            swing_time: SwingTime::default(),
            free_swing_time: None,
            swing_time_starts: 1,
            knot_dt: DEFAULT_KNOT_DT_S,
            transcription: Transcription::default(),
            q1_diag: vec![],
            r1_diag: vec![],
            bounds: Bounds::default(),
            obstacle_margin: 0.01,
            avoid_obstacles: true,
            self_collision: true,
            output_dt: 0.001,
            shooting: ShootingSettings::default(),
            obstacle_guess: ObstacleGuess::default(),
            torque_continuation: true,
            swing_time_search: true,
        }
    }
}

impl PlannerSettings {
    /// Check values for an n-link robot; `src` names the origin in messages.
    pub fn validate(&self, n: usize, src: &str) -> Result<()> {
        let pos = |field: &str, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid(src, field, v, "must be a finite number > 0"))
            }
        };
        if let SwingTime::Seconds(t) = self.swing_time {
            pos("swing_time", t)?;
            if t > limits::MAX_SWING_TIME_S {
                return Err(Error::invalid(
                    src,
                    "swing_time",
                    t,
                    format!(
                        "must be at most {} s (brachia::limits::MAX_SWING_TIME_S)",
                        limits::MAX_SWING_TIME_S
                    ),
                ));
            }
            self.grid(n, t, src)?;
        }
        pos("knot_dt", self.knot_dt)?;
        pos("output_dt", self.output_dt)?;
        if self.output_dt > limits::MAX_OUTPUT_DT_S {
            return Err(Error::invalid(
                src,
                "output_dt",
                self.output_dt,
                format!(
                    "must be at most {} s (brachia::limits::MAX_OUTPUT_DT_S): the energy and the \
                     tracked reference come from the resampled trajectory",
                    limits::MAX_OUTPUT_DT_S
                ),
            ));
        }
        if let Some([lo, hi]) = self.free_swing_time {
            let range = format!("[{lo}, {hi}]");
            if !(lo.is_finite() && hi.is_finite() && lo > 0.0 && lo <= hi) {
                return Err(Error::invalid(
                    src,
                    "free_swing_time",
                    range,
                    "must be [min, max] with 0 < min <= max, in seconds",
                ));
            }
            if hi > limits::MAX_SWING_TIME_S {
                return Err(Error::invalid(
                    src,
                    "free_swing_time",
                    range,
                    format!(
                        "max must be at most {} s (brachia::limits::MAX_SWING_TIME_S)",
                        limits::MAX_SWING_TIME_S
                    ),
                ));
            }
            if self.transcription != Transcription::MultipleShooting {
                return Err(Error::invalid(
                    src,
                    "free_swing_time",
                    range,
                    "needs transcription = \"multiple-shooting\" (the collocation rules plan at a fixed T)",
                ));
            }
            self.grid(n, hi, src).map_err(|e| {
                Error::invalid(
                    src,
                    "free_swing_time",
                    format!("[{lo}, {hi}]"),
                    format!("its longest swing does not fit the grid ({e})"),
                )
            })?;
        }
        if !(1..=MAX_SWING_TIME_STARTS).contains(&self.swing_time_starts) {
            return Err(Error::invalid(
                src,
                "swing_time_starts",
                self.swing_time_starts,
                format!("must be in 1..={MAX_SWING_TIME_STARTS}"),
            ));
        }
        if self.swing_time_starts > 1 && self.free_swing_time.is_none() {
            return Err(Error::invalid(
                src,
                "swing_time_starts",
                self.swing_time_starts,
                "needs free_swing_time (a fixed swing time has one start)",
            ));
        }
        pos("bounds.q_rel_max", self.bounds.q_rel_max)?;
        pos("bounds.qd_max", self.bounds.qd_max)?;
        if let Some(v) = self.bounds.qd_end_max {
            pos("bounds.qd_end_max", v)?;
            if v > self.bounds.qd_max {
                return Err(Error::invalid(
                    src,
                    "bounds.qd_end_max",
                    v,
                    format!("must be at most bounds.qd_max = {}", self.bounds.qd_max),
                ));
            }
        }
        if self.shooting.substeps == 0 || self.shooting.substeps > MAX_SHOOTING_SUBSTEPS {
            return Err(Error::invalid(
                src,
                "shooting.substeps",
                self.shooting.substeps,
                format!("must be in 1..={MAX_SHOOTING_SUBSTEPS}"),
            ));
        }
        if self.bounds.qd_max > limits::MAX_RATE_RAD_S {
            return Err(Error::invalid(
                src,
                "bounds.qd_max",
                self.bounds.qd_max,
                format!("must be at most {} rad/s", limits::MAX_RATE_RAD_S),
            ));
        }
        if self.obstacle_margin > 10.0 {
            return Err(Error::invalid(
                src,
                "obstacle_margin",
                self.obstacle_margin,
                "must be at most 10 m",
            ));
        }
        let [lo, hi] = self.bounds.q1;
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(Error::invalid(
                src,
                "bounds.q1",
                format!("[{lo}, {hi}]"),
                "need lo < hi",
            ));
        }
        if !(self.obstacle_margin.is_finite() && self.obstacle_margin >= 0.0) {
            return Err(Error::invalid(
                src,
                "obstacle_margin",
                self.obstacle_margin,
                "must be >= 0",
            ));
        }
        for (name, v, len) in [
            ("q1_diag", &self.q1_diag, n),
            ("r1_diag", &self.r1_diag, n - 1),
        ] {
            if !v.is_empty() && v.len() != len {
                return Err(Error::invalid(
                    src,
                    name,
                    format!("{v:?}"),
                    format!("needs {len} values (or none for the default)"),
                ));
            }
            if let Some(x) = v.iter().find(|x| !x.is_finite() || **x < 0.0) {
                return Err(Error::invalid(
                    src,
                    name,
                    x,
                    "weights must be finite and >= 0",
                ));
            }
        }
        Ok(())
    }

    /// The range of a free swing time that is planned as one: `free_swing_time` when at least
    /// [`MIN_FREE_SWING_TIME_RANGE_S`] wide (a narrower one is planned at [`Self::start_swing_time`],
    /// as a fixed T), else `None`.
    pub fn free_range(&self) -> Option<[f64; 2]> {
        self.free_swing_time
            .filter(|[lo, hi]| hi - lo >= MIN_FREE_SWING_TIME_RANGE_S)
    }

    /// Where a plan of swing time `t` (s, `swing_time` resolved) starts: `t` clamped into
    /// `free_swing_time`, or `t` itself.
    pub fn start_swing_time(&self, t: f64) -> f64 {
        self.free_swing_time.map_or(t, |[lo, hi]| t.clamp(lo, hi))
    }

    /// The longest swing a plan of swing time `t` (s, `swing_time` resolved) can end with: the top of
    /// `free_swing_time`, or `t` itself. The grid ([`Self::grid`]) and a run's length are sized by it.
    pub fn longest_swing_time(&self, t: f64) -> f64 {
        self.free_swing_time.map_or(t, |[_, hi]| hi)
    }

    /// An error naming `free_swing_time` when it is set, for a planner (`what`) that plans at a fixed
    /// swing time; `src` names the origin.
    pub fn refuse_free_swing_time(&self, src: &str, what: &str) -> Result<()> {
        match self.free_swing_time {
            Some([lo, hi]) => Err(Error::invalid(
                src,
                "free_swing_time",
                format!("[{lo}, {hi}]"),
                format!(
                    "{what} plans at a fixed swing time: plan the swing once with a free one \
                     (brachia::planning::plan) and give its swing_time_s as swing_time"
                ),
            )),
            None => Ok(()),
        }
    }

    /// The number of collocation intervals `N = round(T / knot_dt)` of a swing of `t_final` seconds,
    /// checked against [`limits::MIN_INTERVALS`], [`limits::MAX_INTERVALS`] and, for a robot of
    /// `links` links, [`limits::MAX_LINK_INTERVALS`]` / links^2`, and the output samples
    /// `T / output_dt` against [`limits::MAX_OUTPUT_SAMPLES`] (before anything of that size is allocated).
    pub fn grid(&self, links: usize, t_final: f64, src: &str) -> Result<usize> {
        let (lo, hi) = (
            limits::MIN_INTERVALS,
            (limits::MAX_LINK_INTERVALS / (links * links).max(1)).min(limits::MAX_INTERVALS),
        );
        let n = limits::count(t_final, self.knot_dt, hi);
        match n {
            Some(n) if n >= lo => {}
            _ => {
                return Err(Error::invalid(
                    src,
                    "knot_dt",
                    self.knot_dt,
                    format!(
                        "a swing of {t_final:.4} s needs between {lo} and {hi} intervals for {links} links (brachia::limits: MIN_INTERVALS, MAX_INTERVALS, MAX_LINK_INTERVALS / links^2); knot_dt must be in [{:.3e}, {:.3e}] s",
                        t_final / hi as f64,
                        t_final / lo as f64
                    ),
                ))
            }
        }
        let max_s = limits::MAX_OUTPUT_SAMPLES - 1;
        if limits::count(t_final, self.output_dt, max_s).is_none() {
            return Err(Error::invalid(
                src,
                "output_dt",
                self.output_dt,
                format!(
                    "a swing of {t_final:.4} s would have more than {max_s} output samples (brachia::limits::MAX_OUTPUT_SAMPLES); output_dt must be >= {:.3e} s",
                    t_final / max_s as f64
                ),
            ));
        }
        Ok(n.unwrap_or(lo))
    }

    /// Check that the solver backend `nlp.backend` can solve this transcription: `ocp` solves multiple
    /// shooting only (collocation needs pounce or ripopt). `src` names the origin in the error.
    pub fn check_backend(&self, nlp: &crate::planning::nlp::NlpSettings, src: &str) -> Result<()> {
        if nlp.backend == crate::planning::Backend::Ocp
            && self.transcription != Transcription::MultipleShooting
        {
            let name = serde_json::to_value(self.transcription)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string))
                .unwrap_or_default();
            return Err(Error::invalid(
                src,
                "solver.backend, planner.transcription",
                format!("\"ocp\" with \"{name}\""),
                "the ocp backend (the default) solves the stage-structured problem only: set \
                 planner.transcription = \"multiple-shooting\" (the default), or choose backend \
                 \"pounce\" or \"ripopt\" for collocation",
            ));
        }
        Ok(())
    }

    /// Q1 diagonal with defaults filled in.
    pub fn q1(&self, n: usize) -> Vec<f64> {
        if self.q1_diag.is_empty() {
            vec![0.01; n]
        } else {
            self.q1_diag.clone()
        }
    }

    /// R1 diagonal with defaults filled in.
    pub fn r1(&self, n: usize) -> Vec<f64> {
        if self.r1_diag.is_empty() {
            vec![1.0; n - 1]
        } else {
            self.r1_diag.clone()
        }
    }
}

/// [`PlannerSettings`] that passed [`PlannerSettings::validate`] for a robot of
/// [`ValidSettings::links`] links: what the planner's internal functions take, so that a plan checks
/// its settings once, where they enter ([`crate::planning::plan`], a scenario file, the persistent
/// planner's constructor). Read the fields through `Deref`; the only ways to make one are
/// [`ValidSettings::new`] and the derivations below, each of which keeps it valid: the fallible ones
/// apply the checks of [`PlannerSettings::validate`] to what they change (errors name the source
/// `"planner"`), the infallible ones only turn off an option or drop a constraint.
///
/// The bounds and `avoid_obstacles` (what a task is checked against, [`crate::planning::ValidTask`])
/// change only through [`ValidSettings::with_bounds`] and [`ValidSettings::without_end_rest`].
#[derive(Debug, Clone, PartialEq)]
pub struct ValidSettings {
    settings: PlannerSettings,
    links: usize,
}

impl std::ops::Deref for ValidSettings {
    type Target = PlannerSettings;

    fn deref(&self) -> &PlannerSettings {
        &self.settings
    }
}

impl ValidSettings {
    /// Check `settings` for a robot of `links` links ([`PlannerSettings::validate`]; `src` names
    /// the origin in messages).
    pub fn new(settings: PlannerSettings, links: usize, src: &str) -> Result<Self> {
        settings.validate(links, src)?;
        Ok(ValidSettings { settings, links })
    }

    /// The settings.
    pub fn settings(&self) -> &PlannerSettings {
        &self.settings
    }

    /// The settings, given back.
    pub fn into_inner(self) -> PlannerSettings {
        self.settings
    }

    /// The number of links of the robot the settings were checked for.
    pub fn links(&self) -> usize {
        self.links
    }

    /// A copy changed by `change`, checked again.
    pub(crate) fn derive(&self, change: impl FnOnce(&mut PlannerSettings)) -> Result<Self> {
        let mut settings = self.settings.clone();
        change(&mut settings);
        ValidSettings::new(settings, self.links, "planner")
    }

    /// These settings at the fixed swing time `t` (s). Errors as [`PlannerSettings::validate`] on a
    /// `t` that is not finite and > 0, longer than [`limits::MAX_SWING_TIME_S`], or whose mesh of
    /// `knot_dt` does not fit [`PlannerSettings::grid`].
    pub fn with_swing_time(&self, t: f64) -> Result<Self> {
        self.derive(|s| s.swing_time = SwingTime::Seconds(t))
    }

    /// These settings with the swing time free in `range` (s), starting at `t0` (s), one start.
    /// Errors as [`PlannerSettings::validate`] (the range, its transcription, its grid; `t0`).
    pub fn with_free_swing_time(&self, t0: f64, range: [f64; 2]) -> Result<Self> {
        self.derive(|s| {
            s.swing_time = SwingTime::Seconds(t0);
            s.free_swing_time = Some(range);
            s.swing_time_starts = 1;
        })
    }

    /// These settings with knots `knot_dt` (s) apart. Errors as [`PlannerSettings::validate`] (a
    /// spacing not finite and > 0; a fixed swing time whose mesh does not fit the grid).
    pub fn with_knot_dt(&self, knot_dt: f64) -> Result<Self> {
        self.derive(|s| s.knot_dt = knot_dt)
    }

    /// These settings with `bounds`. Errors as [`PlannerSettings::validate`] on the bounds.
    pub fn with_bounds(&self, bounds: Bounds) -> Result<Self> {
        self.derive(|s| s.bounds = bounds)
    }

    /// These settings at their own swing time (`swing_time`), not free: no `free_swing_time`, one
    /// start.
    pub fn without_free_swing_time(&self) -> Self {
        let mut v = self.clone();
        v.settings.free_swing_time = None;
        v.settings.swing_time_starts = 1;
        v
    }

    /// These settings with one start of a free swing time ([`PlannerSettings::swing_time_starts`]).
    pub fn with_one_start(&self) -> Self {
        let mut v = self.clone();
        v.settings.swing_time_starts = 1;
        v
    }

    /// These settings without the recoveries of a failed plan (`torque_continuation`,
    /// `swing_time_search` off).
    pub fn without_recoveries(&self) -> Self {
        let mut v = self.clone();
        v.settings.torque_continuation = false;
        v.settings.swing_time_search = false;
        v
    }

    /// These settings without the sub-step clearance rows
    /// ([`ShootingSettings::substep_clearance`] off).
    pub fn without_substep_clearance(&self) -> Self {
        let mut v = self.clone();
        v.settings.shooting.substep_clearance = false;
        v
    }

    /// These settings with `substeps` RK4 steps per shooting interval
    /// ([`ShootingSettings::substeps`], clamped to 1..=[`MAX_SHOOTING_SUBSTEPS`]).
    pub fn with_substeps(&self, substeps: usize) -> Self {
        let mut v = self.clone();
        v.settings.shooting.substeps = substeps.clamp(1, MAX_SHOOTING_SUBSTEPS);
        v
    }

    /// These settings without the rest condition at the last knot ([`Bounds::qd_end_max`] none).
    pub fn without_end_rest(&self) -> Self {
        let mut v = self.clone();
        v.settings.bounds.qd_end_max = None;
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widened_bounds_take_the_start_state_and_keep_the_rest_condition() {
        let b = Bounds {
            qd_end_max: Some(1.0),
            ..Bounds::default()
        };
        // inside: only the q1 range gains the margin around q1 where q1 is near an edge
        let inside = [-1.0, 0.5, -0.5, 1.0, 0.0, 1.0, -2.0, 3.0];
        let w = b.widened_for_start(&inside);
        assert_eq!(w.q1, b.q1);
        assert_eq!(
            (w.q_rel_max, w.qd_max, w.qd_end_max),
            (2.9, 15.0, Some(1.0))
        );
        // link 1 above the bar, a fold past q_rel_max, a rate past qd_max
        let outside = [0.03, -2.95, 3.1, 0.0, 0.0, 16.0, 0.0, 0.0];
        let w = b.widened_for_start(&outside);
        assert_eq!(w.q1, [b.q1[0], 0.03 + START_WIDEN_MARGIN]);
        assert_eq!(w.q_rel_max, std::f64::consts::PI);
        assert!((w.qd_max - 16.8).abs() < 1e-12);
        assert_eq!(w.qd_end_max, Some(1.0));
        // a relative angle just past the bound: the bound plus the margin
        let w = b.widened_for_start(&[-1.0, 2.95, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert!((w.q_rel_max - 3.05).abs() < 1e-12);
    }

    #[test]
    fn the_interval_limit_shrinks_with_the_links_squared() {
        let s = PlannerSettings {
            knot_dt: 0.01,
            ..PlannerSettings::default()
        };
        // 4 links: the plain limit (2000); 12 links: 32000 / 144 = 222 intervals
        assert_eq!(s.grid(4, 2.5, "s.toml").unwrap(), 250);
        assert_eq!(s.grid(12, 2.2, "s.toml").unwrap(), 220);
        let e = s.grid(12, 2.5, "s.toml").unwrap_err().to_string();
        assert!(
            e.contains("knot_dt") && e.contains("222") && e.contains("12 links"),
            "{e}"
        );
        assert!(s.grid(4, 20.5, "s.toml").is_err());
        assert_eq!(s.grid(2, 20.0, "s.toml").unwrap(), 2000);
    }

    #[test]
    fn valid_settings_refuse_what_validate_refuses_with_its_message() {
        let bad = PlannerSettings {
            knot_dt: -1.0,
            ..PlannerSettings::default()
        };
        let want = bad.validate(4, "s.toml").unwrap_err().to_string();
        let got = ValidSettings::new(bad, 4, "s.toml")
            .unwrap_err()
            .to_string();
        assert_eq!(got, want);
        assert!(got.contains("s.toml") && got.contains("knot_dt"), "{got}");
        let v = ValidSettings::new(PlannerSettings::default(), 4, "s.toml").unwrap();
        assert_eq!((v.links(), v.settings()), (4, &PlannerSettings::default()));
    }

    #[test]
    fn derivations_check_what_they_change() {
        let v = ValidSettings::new(PlannerSettings::default(), 4, "s.toml").unwrap();
        // a fixed swing time: set, and refused past the limit or on a mesh that does not fit
        let t = v.with_swing_time(1.5).unwrap();
        assert_eq!(t.swing_time, SwingTime::Seconds(1.5));
        let e = v
            .with_swing_time(limits::MAX_SWING_TIME_S * 2.0)
            .unwrap_err();
        assert!(e.to_string().contains("swing_time"), "{e}");
        assert!(v.with_swing_time(f64::NAN).is_err());
        // a coarser mesh: fine with "auto", refused for a fixed swing too short for it
        assert_eq!(v.with_knot_dt(0.09).unwrap().knot_dt, 0.09);
        let e = t.with_knot_dt(1.0).unwrap_err().to_string();
        assert!(e.contains("knot_dt") && e.contains("intervals"), "{e}");
        // a free swing time: set with one start, refused for a collocation rule
        let f = v.with_free_swing_time(1.0, [1.0, 1.5]).unwrap();
        assert_eq!(
            (f.swing_time, f.free_swing_time, f.swing_time_starts),
            (SwingTime::Seconds(1.0), Some([1.0, 1.5]), 1)
        );
        let coll = ValidSettings::new(
            PlannerSettings {
                transcription: Transcription::Trapezoidal,
                ..PlannerSettings::default()
            },
            4,
            "s.toml",
        )
        .unwrap();
        let e = coll.with_free_swing_time(1.0, [1.0, 1.5]).unwrap_err();
        assert!(e.to_string().contains("multiple-shooting"), "{e}");
        // bounds: refused when they break the rules of validate
        let wide = Bounds {
            qd_max: limits::MAX_RATE_RAD_S * 2.0,
            ..Bounds::default()
        };
        assert!(v.with_bounds(wide).is_err());
        let b = Bounds::default().widened_for_start(&[0.2, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(v.with_bounds(b.clone()).unwrap().bounds, b);
    }

    #[test]
    fn infallible_derivations_stay_valid() {
        let s = PlannerSettings {
            free_swing_time: Some([1.0, 2.0]),
            swing_time_starts: 3,
            bounds: Bounds {
                qd_end_max: Some(1.0),
                ..Bounds::default()
            },
            ..PlannerSettings::default()
        };
        let v = ValidSettings::new(s, 4, "s.toml").unwrap();
        let derived = [
            v.without_free_swing_time(),
            v.with_one_start(),
            v.without_recoveries(),
            v.without_substep_clearance(),
            v.without_end_rest(),
        ];
        for d in &derived {
            d.settings().validate(d.links(), "derived").unwrap();
        }
        let [fixed, one, norec, knots, norest] = derived;
        assert_eq!((fixed.free_swing_time, fixed.swing_time_starts), (None, 1));
        assert_eq!(
            (one.free_swing_time, one.swing_time_starts),
            (Some([1.0, 2.0]), 1)
        );
        assert!(!norec.torque_continuation && !norec.swing_time_search);
        assert!(!knots.shooting.substep_clearance);
        assert_eq!(norest.bounds.qd_end_max, None);
        // each changes only what it names
        assert_eq!(
            PlannerSettings {
                torque_continuation: true,
                swing_time_search: true,
                ..norec.into_inner()
            },
            *v.settings()
        );
    }

    #[test]
    fn an_output_period_too_coarse_for_the_energy_is_refused() {
        let at = |dt: f64| {
            PlannerSettings {
                output_dt: dt,
                ..PlannerSettings::default()
            }
            .validate(4, "s.toml")
        };
        assert!(at(limits::MAX_OUTPUT_DT_S).is_ok());
        let e = at(0.5).unwrap_err().to_string();
        assert!(
            e.contains("s.toml") && e.contains("output_dt") && e.contains("MAX_OUTPUT_DT_S"),
            "{e}"
        );
    }
}
