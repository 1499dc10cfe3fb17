//! The swing planner: task checks, swing time, initial guess, solve, resampling and the report.
//!
//! Units: s, m, rad, rad/s, N m, J. Angles as in the crate docs (q1 absolute from +x, the rest relative).

use super::clearance_check::check_clearance;
use super::collocation::{CollocationNlp, EeTerminalFn, Layout};
use super::nlp::{
    solve, Backend, MuStrategy, NlpSettings, NlpSolution, PassStats, SolveStatus, SparseNlp,
    TimeSplit,
};
use super::profile::{replay_ee_error, resample, Clamped};
use super::settings::{PlannerSettings, SwingTime, Transcription};
use super::solve_log::SolveRole;
use super::task::check_task;
use super::task::SwingTask;
use crate::ad::LocalFn;
use crate::error::{Error, Result};
use crate::model::{
    ik_from_seed, mirrored_pose, wrap_angle, Circle, ClearanceFn, DynamicsFn, Robot,
};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The clearance constraints the planner imposes: the exact surface distance, not its square,
/// `g = sqrt(d^2 + eps^2) - (r_a + r_b + margin) >= 0` for every row of a [`ClearanceFn`] (the paper's
/// eq. (12) compares a squared distance with a length; what is meant is `d >= R`). The squared form
/// `d^2 - R^2` has a vanishing gradient when a link passes through an obstacle's centre (`grad d^2 =
/// 2 d grad d`), which stalls the solver's restoration phase on initial guesses that cut through an
/// obstacle; `sqrt(d^2 + eps^2)` keeps a unit-size gradient everywhere and differs from `d` by less
/// than `eps^2 / (2 d)` (1e-12 / (2 d) m with eps = 1e-6) where it matters.
///
/// Owns its rows (a [`ClearanceFn`]: shared handles to the robot and the obstacles).
#[derive(Debug, Clone)]
pub struct DistanceClearanceFn {
    inner: ClearanceFn,
    thresholds: Vec<f64>,
}

/// Smoothing of the distance at d = 0, m.
const DIST_EPS: f64 = 1e-6;

impl DistanceClearanceFn {
    /// Wrap `inner` (its rows, order and margin).
    pub fn new(inner: ClearanceFn) -> Self {
        let thresholds = inner
            .pairs()
            .into_iter()
            .map(|p| inner.threshold(p))
            .collect();
        DistanceClearanceFn { inner, thresholds }
    }

    /// The closed-form derivatives of these rows (the production path; this `LocalFn` through AD is
    /// their test oracle).
    pub fn derivatives(&self) -> crate::model::ClearanceDerivatives {
        crate::model::ClearanceDerivatives::new(
            self.inner.clone(),
            crate::model::ClearanceForm::Distance { eps: DIST_EPS },
        )
    }
}

impl LocalFn for DistanceClearanceFn {
    type Scratch<T: crate::math::Scalar> = <ClearanceFn as LocalFn>::Scratch<T>;
    fn n_in(&self) -> usize {
        self.inner.n_in()
    }
    fn n_out(&self) -> usize {
        self.thresholds.len()
    }
    fn scratch<T: crate::math::Scalar>(&self) -> Self::Scratch<T> {
        self.inner.scratch()
    }
    fn eval<T: crate::math::Scalar>(&self, ws: &mut Self::Scratch<T>, z: &[T], out: &mut [T]) {
        self.inner.eval(ws, z, out);
        for (o, r) in out.iter_mut().zip(&self.thresholds) {
            *o = (*o + (r * r + DIST_EPS * DIST_EPS)).sqrt() - *r;
        }
    }
    fn hessian_entry_is_zero(&self, i: usize, j: usize) -> bool {
        self.inner.hessian_entry_is_zero(i, j)
    }
}

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
    pub callback_timings: crate::planning::collocation::CallbackTimings,
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
    pub clearance_violation: Option<super::clearance_check::ClearanceViolation>,
    /// With obstacles avoided and no warm-start guess: how the initial guess was found and what every
    /// solve cost (see [`crate::planning::guess`]); `None` otherwise.
    pub guess: Option<crate::planning::guess::GuessReport>,
    /// When no strategy converged on a task with obstacles: which obstacle blocks which link
    /// ([`crate::planning::guess::Blockage`], its `Display` is the message); `None` otherwise.
    pub blockage: Option<crate::planning::guess::Blockage>,
    /// When a cold plan without obstacles did not converge within the torque limits (and
    /// `settings.torque_continuation` is on): what the continuation on the limits found (see
    /// [`crate::planning::torque_continuation`]); the plan is its result when it reached the real
    /// limits. `None` otherwise.
    pub torque_continuation: Option<crate::planning::torque_continuation::TorqueContinuation>,
    /// When the task's swing time did not plan (or `"auto"` had no free-fall time) on a cold plan
    /// without obstacles: what the search in T tried (see [`crate::planning::swing_time`]); the plan
    /// is its result when it converged. `None` otherwise.
    pub swing_time_search: Option<crate::planning::swing_time::SwingTimeSearch>,
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
        if let (true, Some(v)) = (self.status.is_converged(), &self.clearance_violation) {
            return Some(format!(
                "the solver converged ({:?}), but the plan breaks the clearance between its \
                 checked points: {v}",
                self.status
            ));
        }
        let mut msg = match &self.blockage {
            Some(b) => format!("the planner did not converge ({:?}): {b}", self.status),
            None => format!("the planner did not converge ({:?})", self.status),
        };
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

/// RK4 step of [`freefall_time`], s (global error ~1e-11 s on the paper's robot; the crossing itself
/// is searched within the step, not interpolated).
const FREEFALL_DT: f64 = 1e-3;

/// Time for the robot, released at rest from `q0` with every joint locked (one rigid compound pendulum
/// about the grip), until its EE first reaches the x coordinate `x_mid`. Errors when it never does within
/// 20 s.
pub fn freefall_time(robot: &Robot, q0: &[f64], x_mid: f64) -> Result<f64> {
    freefall_time_with_step(robot, q0, x_mid, FREEFALL_DT)
}

/// [`freefall_time`] with RK4 steps of `dt` (s, > 0).
fn freefall_time_with_step(robot: &Robot, q0: &[f64], x_mid: f64, dt: f64) -> Result<f64> {
    let n = robot.n;
    if robot.gravity <= 0.0 {
        return Err(Error::invalid(
            "planner",
            "swing_time",
            "\"auto\"",
            format!(
                "needs gravity > 0 (the robot's gravity is {} m/s^2); give swing_time in seconds",
                robot.gravity
            ),
        ));
    }
    let m11 = robot.mass_matrix(q0)[0]; // inertia of the locked chain about the grip
    let mut ws = crate::model::Scratch::new(n);
    let mut g = vec![0.0; n];
    let mut q = q0.to_vec();
    let side = (robot.ee_position(&q)[0] - x_mid).signum();
    if side == 0.0 {
        return Ok(0.0);
    }
    // RK4 on (th, w) in steps of FREEFALL_DT; the step that crosses is then searched for the
    // crossing time tau in (0, dt] by regula falsi (Illinois) on one RK4 step of length tau from
    // the step's start, so the crossing is as accurate as the integration (no interpolation).
    let mut k: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; 2]);
    let mut tmp = [0.0; 2];
    let mut step = |th: f64, w: f64, dt: f64| {
        let mut x = [th, w];
        crate::integrate::rk4_step(&mut x, dt, &mut k, &mut tmp, |_, x, out| {
            out[0] = x[1];
            out[1] = locked_chain_acceleration(robot, m11, x[0], &mut q, &mut ws, &mut g);
        });
        (x[0], x[1])
    };
    let mut qx = q0.to_vec();
    let mut dist = |th: f64| {
        qx[0] = th;
        robot.ee_position(&qx)[0] - x_mid
    };
    let (mut t, mut th, mut w) = (0.0, q0[0], 0.0);
    let mut prev = dist(th);
    while t < 20.0 {
        let (th1, w1) = step(th, w, dt);
        let d = dist(th1);
        if d.signum() != side {
            // bracket [0, dt] of the partial step: f(0) = prev (on `side`), f(dt) = d (past it)
            let (mut a, mut fa, mut b, mut fb) = (0.0, prev, dt, d);
            let mut last_side = 0;
            for _ in 0..60 {
                if b - a <= 1e-14 {
                    break;
                }
                let c = (a * fb - b * fa) / (fb - fa);
                let c = if c > a && c < b { c } else { 0.5 * (a + b) };
                let fc = dist(step(th, w, c).0);
                if fc == 0.0 {
                    return Ok(t + c);
                }
                if fc.signum() == side {
                    (a, fa) = (c, fc);
                    if last_side == 1 {
                        fb *= 0.5;
                    }
                    last_side = 1;
                } else {
                    (b, fb) = (c, fc);
                    if last_side == -1 {
                        fa *= 0.5;
                    }
                    last_side = -1;
                }
            }
            return Ok(t + 0.5 * (a + b));
        }
        (th, w, prev, t) = (th1, w1, d, t + dt);
    }
    Err(Error::InfeasibleTask(format!(
        "the robot released with locked joints never reaches x = {x_mid:.3} m within 20 s"
    )))
}

/// Angular acceleration of the chain locked at its start shape, turned to grip angle `q1` (rad/s^2):
/// gravity's torque about the grip over the locked chain's inertia `m11` (kg m^2); `q` holds the locked
/// shape and is overwritten at `q[0]`.
fn locked_chain_acceleration(
    robot: &Robot,
    m11: f64,
    q1: f64,
    q: &mut [f64],
    ws: &mut crate::model::Scratch<f64>,
    g: &mut [f64],
) -> f64 {
    q[0] = q1;
    robot.gravity_into(ws, q, g);
    -g[0] / m11
}

/// Wrap an angle to (-pi, pi].
/// Variable bounds for the layout (start state fixed, final torque zero).
pub(super) fn variable_bounds(
    robot: &Robot,
    layout: &Layout,
    settings: &PlannerSettings,
    q0: &[f64],
    qd0: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let (n, nv) = (robot.n, layout.n_vars());
    let b = &settings.bounds;
    let (mut lo, mut hi) = (vec![0.0; nv], vec![0.0; nv]);
    for p in 0..layout.points {
        let qd = b.qd_bound(p + 1 == layout.points);
        for i in 0..n {
            let (l, h) = if i == 0 {
                (b.q1[0], b.q1[1])
            } else {
                (-b.q_rel_max, b.q_rel_max)
            };
            lo[layout.var(p, i)] = l;
            hi[layout.var(p, i)] = h;
            lo[layout.var(p, n + i)] = -qd;
            hi[layout.var(p, n + i)] = qd;
        }
        for j in 0..n - 1 {
            lo[layout.var(p, 2 * n + j)] = robot.tau_min[j];
            hi[layout.var(p, 2 * n + j)] = robot.tau_max[j];
        }
    }
    for i in 0..n {
        lo[layout.var(0, i)] = q0[i];
        hi[layout.var(0, i)] = q0[i];
        lo[layout.var(0, n + i)] = qd0[i];
        hi[layout.var(0, n + i)] = qd0[i];
    }
    let last = layout.points - 1;
    for j in 0..n - 1 {
        lo[layout.var(last, 2 * n + j)] = 0.0;
        hi[layout.var(last, 2 * n + j)] = 0.0;
    }
    (lo, hi)
}

/// Pick the target pose for the initial guess: IK seeded by the mirrored start pose and variants,
/// keeping poses inside the bounds, preferring obstacle-free ones, then the one closest to its seed.
pub(super) fn target_pose(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    cf: Option<&ClearanceFn>,
) -> Result<Vec<f64>> {
    let n = robot.n;
    let m = mirrored_pose(&task.q0);
    let flipped: Vec<f64> = m
        .iter()
        .enumerate()
        .map(|(i, v)| if i == 0 { *v } else { -v })
        .collect();
    let mut straight = vec![0.0; n];
    straight[0] = task.target[1].atan2(task.target[0]);
    // fallback: the chain dipping below the line to the target (a start pose that points above the
    // bar, as a re-rooted chain on a ladder may, mirrors to seeds above it)
    let mut vee = straight.clone();
    let sgn = if task.target[0] < 0.0 { 1.0 } else { -1.0 };
    vee[0] = wrap_angle(straight[0] + 0.8 * sgn);
    vee[n / 2] = -1.6 * sgn;
    let b = &settings.bounds;
    let mut best: Option<(bool, f64, Vec<f64>)> = None;
    for (i, seed) in [m, flipped, task.q0.clone(), straight, vee]
        .into_iter()
        .enumerate()
    {
        if i == 4 && best.is_some() {
            break;
        }
        let Some(q) = ik_from_seed(robot, &seed, task.target) else {
            continue;
        };
        let q: Vec<f64> = q.iter().map(|v| wrap_angle(*v)).collect();
        let inside =
            q[0] >= b.q1[0] && q[0] <= b.q1[1] && q[1..].iter().all(|v| v.abs() <= b.q_rel_max);
        if !inside {
            continue;
        }
        let free = cf.is_none_or(|c| c.min_clearance(&q) >= 0.0);
        let dist: f64 = q.iter().zip(&seed).map(|(a, s)| (a - s).powi(2)).sum();
        let better = match &best {
            None => true,
            Some((bf, bd, _)) => (free && !bf) || (free == *bf && dist < *bd),
        };
        if better {
            best = Some((free, dist, q));
        }
    }
    best.map(|b| b.2).ok_or_else(|| {
        Error::InfeasibleTask(format!(
            "no joint configuration within the bounds reaches the target ({:.3}, {:.3})",
            task.target[0], task.target[1]
        ))
    })
}

/// Plan an energy-optimal swing. Bad input and impossible tasks are errors (nothing is solved); a solve
/// that does not converge is a [`Plan`] whose `status` says so. Same as [`plan_with_guess`] without a
/// guess: the initial guess is the smooth step to an inverse-kinematics target pose.
pub fn plan(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
) -> Result<Plan> {
    plan_with_guess(robot, task, settings, nlp, None)
}

/// Check a warm-start trajectory: n links, at least two samples, finite values, strictly increasing
/// times.
pub(super) fn check_guess(robot: &Robot, g: &Trajectory) -> Result<()> {
    let (n, src) = (robot.n, "guess");
    if g.n != n {
        return Err(Error::Dimension {
            what: "guess: links".into(),
            expected: n,
            got: g.n,
        });
    }
    let len = g.len();
    if len < 2 {
        return Err(Error::invalid(
            src,
            "t",
            format!("{len} samples"),
            "a guess needs at least 2 samples",
        ));
    }
    for (what, have, per) in [
        ("guess: q", g.q.len(), n),
        ("guess: qd", g.qd.len(), n),
        ("guess: tau", g.tau.len(), n - 1),
    ] {
        if have != len * per {
            return Err(Error::Dimension {
                what: what.into(),
                expected: len * per,
                got: have,
            });
        }
    }
    if let Some(x) =
        g.t.iter()
            .chain(&g.q)
            .chain(&g.qd)
            .chain(&g.tau)
            .find(|x| !x.is_finite())
    {
        return Err(Error::invalid(src, "values", x, "must be finite"));
    }
    if let Some(k) = (1..len).find(|&k| g.t[k] <= g.t[k - 1]) {
        return Err(Error::invalid(
            src,
            format!("t[{k}]"),
            g.t[k],
            "times must increase strictly",
        ));
    }
    Ok(())
}

/// Fill `x0` from a guess trajectory: its time axis is mapped linearly onto `[0, T]`, each collocation
/// point takes q, qd (scaled by `T_guess / T`) and tau interpolated linearly from it, clamped to the
/// variable bounds (so the start state and the zero final torque hold exactly).
pub(super) fn guess_from_trajectory(
    g: &Trajectory,
    layout: &Layout,
    t_final: f64,
    bounds: &(Vec<f64>, Vec<f64>),
    x0: &mut [f64],
) {
    let (n, m) = (g.n, g.n - 1);
    let t0 = g.t[0];
    let dur = g.duration();
    let speed = dur / t_final; // d t_guess / d t
    for p in 0..layout.points {
        let (k, r) = g.locate(t0 + layout.time(p) / t_final * dur);
        let k1 = (k + 1).min(g.len() - 1);
        let lerp =
            |v: &[f64], w: usize, i: usize| v[k * w + i] + r * (v[k1 * w + i] - v[k * w + i]);
        for i in 0..n {
            x0[layout.var(p, i)] = lerp(&g.q, n, i);
            x0[layout.var(p, n + i)] = speed * lerp(&g.qd, n, i);
        }
        for j in 0..m {
            x0[layout.var(p, 2 * n + j)] = lerp(&g.tau, m, j);
        }
    }
    for (v, (lo, hi)) in x0.iter_mut().zip(bounds.0.iter().zip(&bounds.1)) {
        *v = v.clamp(*lo, *hi);
    }
}

/// Smallest surface distance between a link and an obstacle over `trajectory`, m (no margin, no
/// self-collision); `None` without obstacles.
pub(super) fn min_obstacle_clearance(
    robot: &Robot,
    obstacles: &[Circle],
    trajectory: &Trajectory,
) -> Result<Option<f64>> {
    if obstacles.is_empty() {
        return Ok(None);
    }
    let cf = ClearanceFn::new(robot.clone(), obstacles, 0.0)?.with_self_collision(false);
    Ok(Some(
        (0..trajectory.len())
            .map(|k| cf.min_clearance(trajectory.q(k)))
            .fold(f64::INFINITY, f64::min),
    ))
}

/// The cold initial guess on `layout`'s points: a smooth step (3 r^2 - 2 r^3 of the time fraction r) of
/// every joint from `q0` to the target pose `q_t`, its velocities the step's derivative, zero torque, the
/// start velocity `qd0` at point 0. `x0` is stacked `[q, qd, tau]` per point as in [`Layout::var`].
pub(super) fn smooth_step_guess(
    layout: &Layout,
    t_final: f64,
    q0: &[f64],
    q_t: &[f64],
    qd0: &[f64],
    x0: &mut [f64],
) {
    let n = layout.n;
    for p in 0..layout.points {
        let r = layout.time(p) / t_final;
        let s = r * r * (3.0 - 2.0 * r);
        let sd = 6.0 * r * (1.0 - r) / t_final;
        for i in 0..n {
            x0[layout.var(p, i)] = q0[i] + s * (q_t[i] - q0[i]);
            x0[layout.var(p, n + i)] = sd * (q_t[i] - q0[i]);
        }
    }
    for i in 0..n {
        x0[layout.var(0, n + i)] = qd0[i];
    }
}

/// Initial barrier parameter of a warm-started solve when [`NlpSettings::mu_init`] is not set. IPOPT's
/// default (0.1) pushes a good guess back towards the centre of the feasible region; on the tracking
/// scenario (20 ms knots) its own solution as the guess then takes 13 iterations against 16 cold, with
/// 1e-4 it takes 6 (and a swing 0.2 s longer 13 instead of 21); measured in docs/planner.md.
pub const WARM_START_MU_INIT: f64 = 1e-4;

/// Solve `problem` with the seam's backend; when that does not converge (and the barrier strategy was
/// not already adaptive), a second attempt with the adaptive barrier update, which recovers from initial
/// guesses that cut through obstacles (measured on the paper's obstacle scenario; docs/planner.md). The
/// second is adopted when it converged or ended less infeasible. `max_wall_time_s` bounds both together:
/// the second gets what the first left, and does not run when nothing is left. Returns the adopted
/// solution and every attempt (exactly one marked adopted).
pub(super) fn solve_with_retry(
    problem: &mut dyn SparseNlp,
    nlp: &NlpSettings,
) -> (NlpSolution, Vec<SolveAttempt>) {
    let start = std::time::Instant::now();
    let mut sol = solve(problem, nlp);
    let mut solves = vec![SolveAttempt::new(&sol, nlp.mu_strategy)];
    let mut adopted = 0;
    // a refusal (settings, problem) is the same under another barrier strategy
    let refused = matches!(
        sol.status,
        SolveStatus::InvalidProblem(_) | SolveStatus::InvalidSettings(_)
    );
    let retry_wanted =
        !sol.status.is_converged() && !refused && nlp.mu_strategy != MuStrategy::Adaptive;
    // the wall-time limit is the whole call's: the retry gets what is left, and none once it is spent
    if let Some(left) = nlp.remaining(start).filter(|_| retry_wanted) {
        let retry = NlpSettings {
            mu_strategy: MuStrategy::Adaptive,
            ..left
        };
        let second = solve(problem, &retry);
        solves.push(SolveAttempt::new(&second, MuStrategy::Adaptive));
        if second.status.is_converged()
            || second.max_constraint_violation < sol.max_constraint_violation
        {
            sol = second;
            adopted = 1;
        }
    }
    solves[adopted].adopted = true;
    (sol, solves)
}

/// The swing time T of `task` (s) and, when `settings.swing_time` is `"auto"`, the free-fall time
/// `T_freefall` it is twice of (the locked chain falling until the EE passes the midpoint between its
/// start and the target).
pub(super) fn swing_time(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
) -> Result<(f64, Option<f64>)> {
    Ok(match settings.swing_time {
        SwingTime::Seconds(t) => (t, None),
        SwingTime::Auto(_) => {
            let start_ee = robot.ee_position(&task.q0);
            let tf = freefall_time(robot, &task.q0, 0.5 * (start_ee[0] + task.target[0]))?;
            (2.0 * tf, Some(tf))
        }
    })
}

/// The clearance rows the planner imposes on `task` (its obstacles when `settings.avoid_obstacles`,
/// the non-adjacent link pairs when `settings.self_collision`, margin `settings.obstacle_margin`);
/// `None` when there are none.
pub(super) fn clearance_rows(
    robot: &Arc<Robot>,
    task: &SwingTask,
    settings: &PlannerSettings,
) -> Result<Option<ClearanceFn>> {
    let obstacles: &[Circle] = if settings.avoid_obstacles {
        &task.obstacles
    } else {
        &[]
    };
    if obstacles.is_empty() && !settings.self_collision {
        return Ok(None);
    }
    Ok(Some(
        ClearanceFn::new(Arc::clone(robot), obstacles, settings.obstacle_margin)?
            .with_self_collision(settings.self_collision),
    ))
}

/// [`plan`] with an optional initial guess. `guess` is any trajectory of the robot (a neighbouring
/// plan's `points` or `trajectory`, possibly of another swing time): its time axis is scaled linearly
/// onto `[0, T]` of this problem and every collocation point takes q, qd (scaled by `T_guess / T`, so
/// the path is the same and only its speed changes) and tau interpolated linearly from it. The start
/// state and the zero final torque are fixed by the bounds; the guess is clamped into the bounds so it
/// agrees with them. With a guess the inverse-kinematics target pose is not computed. Errors on a
/// guess with the wrong number of links, fewer than two samples, non-finite values or times that do
/// not increase. Unless `nlp.mu_init` is set, a warm-started solve starts its barrier parameter at
/// [`WARM_START_MU_INIT`].
///
/// Without a guess, on a task whose obstacles are avoided, the initial guess comes from
/// [`crate::planning::guess`] (`settings.obstacle_guess`): detour seeds, then continuation on the
/// obstacle radii, when the solve from the smooth step fails; the plan then reports the strategy and
/// the summed cost of every solve, and names what blocks the swing when nothing converged.
///
/// Without a guess and without obstacles, a plan that does not converge is continued on the torque
/// limits (`settings.torque_continuation`, [`crate::planning::torque_continuation`]): up to 3 widened
/// cold plans and [`crate::planning::torque_continuation::MAX_STEPS`] warm ones, about 1-2 s on the
/// parameter study's failing cell; the plan within the limits when one is found, else the failure
/// with how much torque the swing likely needs. `nlp.max_wall_time_s` bounds the whole call.
pub fn plan_with_guess(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    let mut p = plan_strategies(robot, task, settings, nlp, guess)?;
    // a cancelled call ends between strategies or inside a solve: whatever it returns did not
    // converge and is no failure of the task
    if nlp.is_cancelled() && !p.converged() {
        p.status = SolveStatus::Cancelled;
    }
    Ok(p)
}

/// The strategies of [`plan_with_guess`] (obstacles, torque continuation), each stopping once
/// `nlp.max_wall_time_s` is spent or `nlp.cancel` is set.
fn plan_strategies(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    if guess.is_none() && settings.avoid_obstacles && !task.obstacles.is_empty() {
        settings.validate(robot.n, "planner")?;
        nlp.validate()?;
        settings.check_backend(nlp, "planner")?;
        check_task(robot, task, settings)?;
        return super::guess::plan_around_obstacles(robot, task, settings, nlp);
    }
    let started = std::time::Instant::now();
    let centred = match super::swing_time::before_plan(robot, task, settings, nlp, guess, started)?
    {
        super::swing_time::Before::Planned(p) => return Ok(*p),
        super::swing_time::Before::Plan(s) => s,
    };
    let settings = centred.as_ref().unwrap_or(settings);
    let mut p = plan_single(robot, task, settings, nlp, guess)?;
    if guess.is_none()
        && !p.converged()
        && settings.torque_continuation
        && super::torque_continuation::worth_continuing(&p.status)
    {
        p = super::torque_continuation::plan_by_torque_continuation(
            robot, task, settings, nlp, p, started,
        )?;
    }
    super::swing_time::after_plan(robot, task, settings, nlp, guess, p, started)
}

/// One plan from one initial guess (the guess given, or the smooth step): [`plan_with_guess`] without
/// the obstacle strategies.
pub(super) fn plan_single(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    nlp: &NlpSettings,
    guess: Option<&Trajectory>,
) -> Result<Plan> {
    settings.validate(robot.n, "planner")?;
    nlp.validate()?;
    settings.check_backend(nlp, "planner")?;
    if let Some(g) = guess {
        check_guess(robot, g)?;
    }
    let warm_nlp;
    let nlp = match (guess, nlp.mu_init) {
        (Some(_), None) => {
            warm_nlp = NlpSettings {
                mu_init: Some(WARM_START_MU_INIT),
                ..nlp.clone()
            };
            &warm_nlp
        }
        _ => nlp,
    };
    if settings.transcription == Transcription::MultipleShooting
        || nlp.backend == super::nlp::Backend::Ocp
    {
        return super::plan_shooting::plan_shooting(
            &Arc::new(robot.clone()),
            task,
            settings,
            nlp,
            guess,
        );
    }
    // the evaluators the problem holds share one copy of the robot
    let shared = Arc::new(robot.clone());
    let n = robot.n;
    let qd0 = check_task(robot, task, settings)?;
    let (t_final, freefall) = swing_time(robot, task, settings)?;
    let intervals = settings.grid(robot.n, t_final, "planner")?;
    let layout = Layout::new(n, n - 1, intervals, t_final, settings.transcription);
    let path = clearance_rows(&shared, task, settings)?.map(DistanceClearanceFn::new);
    let bounds = variable_bounds(robot, &layout, settings, &task.q0, &qd0);
    let mut x0 = vec![0.0; layout.n_vars()];
    if let Some(g) = guess {
        guess_from_trajectory(g, &layout, t_final, &bounds, &mut x0);
    } else {
        // initial guess: smooth-step from q0 to the target pose, zero torque
        let q_t = target_pose(robot, task, settings, path.as_ref().map(|p| &p.inner))?;
        smooth_step_guess(&layout, t_final, &task.q0, &q_t, &qd0, &mut x0);
    }
    let (q1, r1) = (settings.q1(n), settings.r1(n));
    let target = vec![task.target[0], task.target[1], 0.0, 0.0];
    let mut problem = CollocationNlp::new(
        DynamicsFn::new(Arc::clone(&shared)),
        EeTerminalFn::new(shared),
        layout,
        target,
        bounds.clone(),
        x0,
        (&q1, &r1),
        path,
    );
    let (sol, solves) = solve_with_retry(&mut problem, nlp);
    let mut time_split = TimeSplit::default();
    for a in &solves {
        time_split.add(&a.time_split);
    }
    let callback_timings = problem.timings;
    let x = if sol.x.len() == layout.n_vars() {
        sol.x.clone()
    } else {
        problem_guess(&problem)
    };

    // collocation points and their accelerations
    let mut points = Trajectory::new(n);
    let nz = layout.nz;
    for p in 0..layout.points {
        let z = &x[p * nz..(p + 1) * nz];
        points.push(layout.time(p), &z[..n], &z[n..2 * n], &z[2 * n..]);
    }
    let points_qdd = problem.accelerations(&x).to_vec();
    let (trajectory, resample_clamped) = resample(
        robot,
        &points,
        &points_qdd,
        &layout,
        settings.transcription,
        &settings.bounds,
        settings.output_dt,
    );
    let (energy_j, positive_work_j) = trajectory.work();
    let ql = points.q(layout.points - 1);
    let ee_final = robot.ee_position(ql);

    // violations by kind
    let mut g = vec![0.0; crate::planning::nlp::SparseNlp::n_cons(&problem)];
    crate::planning::nlp::SparseNlp::constraints(&mut problem, &x, &mut g);
    let rows = problem.row_blocks(&g);
    let maxabs = |s: &[f64]| s.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let ee = rows.terminal;
    let violations = Violations {
        dynamics: maxabs(rows.defects),
        ee_position: (ee[0] - task.target[0]).hypot(ee[1] - task.target[1]),
        ee_velocity: ee[2].hypot(ee[3]),
        clearance: rows.path.iter().fold(0.0f64, |m, v| m.max(-v)),
        bounds: x
            .iter()
            .zip(bounds.0.iter().zip(&bounds.1))
            .fold(0.0f64, |m, (v, (lo, hi))| m.max(lo - v).max(v - hi)),
    };
    let replay_ee_error_m =
        replay_ee_error(robot, &points, &layout, settings.transcription, task.target);
    let min_obstacle_clearance_m = min_obstacle_clearance(robot, &task.obstacles, &trajectory)?;
    let clearance_violation = check_clearance(robot, task, settings, &trajectory)?;
    Ok(Plan {
        status: sol.status,
        backend: sol.backend,
        iterations: solves.iter().map(|a| a.iterations).sum(),
        attempts: solves.len(),
        solve_time_s: solves.iter().map(|a| a.time_s).sum(),
        solves,
        time_split,
        callback_timings,
        objective: sol.objective,
        swing_time_s: t_final,
        freefall_time_s: freefall,
        layout,
        points,
        points_qdd,
        trajectory,
        resample_clamped,
        energy_j,
        positive_work_j,
        ee_final,
        violations,
        replay_ee_error_m,
        min_obstacle_clearance_m,
        clearance_violation,
        guess: None,
        blockage: None,
        torque_continuation: None,
        swing_time_search: None,
    })
}

fn problem_guess(p: &dyn crate::planning::nlp::SparseNlp) -> Vec<f64> {
    let mut x = vec![0.0; p.n_vars()];
    p.initial_guess(&mut x);
    x
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bracketed crossing at 1 ms steps agrees with a ten times finer integration, for the
    /// paper's start pose and three crossings.
    #[test]
    fn freefall_crossing_is_converged_in_the_step() {
        let robot = Robot::paper();
        let q0 = [-2.35, 0.0, -1.55, 0.0];
        let ee = robot.ee_position(&q0)[0];
        for x_mid in [0.5 * (ee + 0.8), 0.0, 0.3] {
            let coarse = freefall_time(&robot, &q0, x_mid).unwrap();
            let fine = freefall_time_with_step(&robot, &q0, x_mid, 1e-4).unwrap();
            assert!(coarse > 0.1, "x_mid {x_mid}: {coarse}");
            assert!((coarse - fine).abs() < 1e-10, "{coarse} vs {fine}");
            // the EE is at x_mid at the time found (one more integration, to the time found)
            let m11 = robot.mass_matrix(&q0)[0];
            let steps = (coarse / 1e-5).ceil() as usize;
            let dt = coarse / steps as f64;
            let mut ws = crate::model::Scratch::new(4);
            let mut g = vec![0.0; 4];
            let mut q = q0.to_vec();
            let mut x = [q0[0], 0.0];
            let mut k: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; 2]);
            let mut tmp = [0.0; 2];
            for _ in 0..steps {
                crate::integrate::rk4_step(&mut x, dt, &mut k, &mut tmp, |_, x, out| {
                    out[0] = x[1];
                    out[1] = locked_chain_acceleration(&robot, m11, x[0], &mut q, &mut ws, &mut g);
                });
            }
            let th = x[0];
            let mut qf = q0.to_vec();
            qf[0] = th;
            assert!((robot.ee_position(&qf)[0] - x_mid).abs() < 1e-9);
        }
    }
}
