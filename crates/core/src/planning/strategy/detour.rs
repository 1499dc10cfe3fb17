//! Detour guesses: collision-free deformations of the obstacle-free swing, for obstacles that swing
//! sweeps through (docs/planner.md, "Obstacles on the path").
//!
//! A planar chain hanging from the grip cannot let an obstacle it sweeps slip past a link: the obstacle
//! has to pass the chain's free end, so avoiding it changes the homotopy class of the whole swing (the
//! chain folds or bends around it), which neither a local deformation nor a growing radius finds. A
//! detour guess follows the obstacle-free plan's knots `q*_k` one after the other and keeps the chain out
//! of the obstacles: knot k is the minimiser of the barrier problem
//!
//! `phi(q) = 1/2 sum_i w_i (q_i - q*_k,i)^2 - mu sum_r ln g_r(q) - mu sum_b ln s_b(q)`,
//!
//! started from knot k-1's pose, where `g_r` are the clearance rows (surface distance minus the
//! required clearance: link radius, obstacle radius, the planner's margin plus [`EXTRA_CLEARANCE`];
//! self-collision rows included) and `s_b` the slacks of the joint bounds. Damped Gauss-Newton steps
//! (exact first derivatives of the rows through [`crate::ad::Diff`]) with a line search that keeps every
//! row positive never let the chain cross an obstacle, so the tracked pose slides around it: the
//! tracked path is collision-free by construction and as close to the unobstructed swing as the
//! barrier lets it be. Which way the chain goes around depends on where tracking starts, so the seeds
//! track forwards (from the start pose) and backwards (from the unobstructed swing's final pose, which
//! clears the obstacles), each with two joint weightings (equal, and the first joint held close so that
//! the distal links fold instead). A seed whose tracked path does not end where the swing must
//! (the start pose for a backward seed, the final pose for a forward one) scores worse.
//!
//! The guess's velocities are the unobstructed plan's plus the slope of the deformation between
//! neighbouring knots (the velocity of the guess's own piecewise-linear path); its torques are the
//! unobstructed plan's. The dynamics defects that leaves are the solver's to close. Units: m, s, rad.

use crate::ad::{Diff, LocalFn};
use crate::error::Result;
use crate::model::{Circle, ClearanceFn, Robot};
use crate::planning::settings::PlannerSettings;
use crate::planning::transcription::clearance_fn::DistanceClearanceFn;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Clearance a detour guess keeps beyond the planner's margin, m (room for the interior point).
pub const EXTRA_CLEARANCE: f64 = 0.01;
/// Barrier weight `mu` of the tracking problem (rad^2; the rows are in m).
const MU: f64 = 1e-4;
/// Gauss-Newton iterations per knot.
const ITERS_PER_KNOT: usize = 60;
/// Largest step of one iteration, rad (infinity norm).
const MAX_STEP: f64 = 0.2;
/// Weight of the first joint in the "folding" seeds (the others weigh 1).
const HOLD_WEIGHT: f64 = 20.0;

/// Two seeds whose knots agree to this, rad, are one seed (the one tried first is kept).
pub const SAME_PATH_RAD: f64 = 1e-6;

/// How a detour seed was made.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum SeedKind {
    /// Tracked from the start pose forwards in time, equal joint weights.
    Forward,
    /// Tracked forwards, the first joint held close to the unobstructed swing (the distal links fold).
    ForwardFold,
    /// Tracked from the unobstructed swing's final pose backwards in time, equal joint weights.
    Backward,
    /// Tracked backwards, the first joint held close.
    BackwardFold,
}

impl SeedKind {
    /// The order seeds are tried in, measured (docs/planner.md, "The scan"): the forward seeds first
    /// (they start at the start pose), the folding one before the plain one; the score did not
    /// predict the winner.
    pub const ORDER: [SeedKind; 4] = [
        SeedKind::ForwardFold,
        SeedKind::Forward,
        SeedKind::BackwardFold,
        SeedKind::Backward,
    ];

    /// Whether the seed is tracked from the final pose backwards in time.
    pub fn backward(self) -> bool {
        matches!(self, SeedKind::Backward | SeedKind::BackwardFold)
    }

    /// The tracking weights of the seed for an n-link chain.
    pub fn weights(self, n: usize) -> Vec<f64> {
        let mut w = vec![1.0; n];
        if matches!(self, SeedKind::ForwardFold | SeedKind::BackwardFold) {
            w[0] = HOLD_WEIGHT;
        }
        w
    }
}

/// One detour seed: its kind, its score (lower first) and, once tried, whether the plan from it
/// converged.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedReport {
    /// How the seed was made.
    pub kind: SeedKind,
    /// Mean squared deviation from the unobstructed knots plus the squared mismatch at the two ends
    /// (the start pose and the unobstructed final pose), rad^2.
    pub score: f64,
    /// Smallest clearance row of the seed's knots (surface distance minus the planner's
    /// required clearance), m; >= [`EXTRA_CLEARANCE`] minus the barrier's slack.
    pub min_clearance_m: f64,
    /// Whether the plan from this seed converged (`None`: not tried, or stopped when another
    /// candidate of the race won).
    pub converged: Option<bool>,
}

/// The barrier tracker: the clearance rows, their derivatives and the joint bounds.
struct Tracker {
    rows: DistanceClearanceFn,
    diff: Diff<DistanceClearanceFn>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    g: Vec<f64>,
    jac: Vec<f64>,
}

impl Tracker {
    fn new(rows: DistanceClearanceFn, lo: Vec<f64>, hi: Vec<f64>) -> Self {
        let (m, n) = (rows.n_out(), rows.n_in());
        Tracker {
            diff: Diff::new(&rows),
            rows,
            lo,
            hi,
            g: vec![0.0; m],
            jac: vec![0.0; m * n],
        }
    }

    /// `phi(q)` for target `qt` and weights `w`; `None` outside the barrier's domain.
    fn phi(&mut self, q: &[f64], qt: &[f64], w: &[f64]) -> Option<f64> {
        self.diff.value(&self.rows, q, &mut self.g);
        let mut v = 0.0;
        for (i, qi) in q.iter().enumerate() {
            let (s_lo, s_hi) = (qi - self.lo[i], self.hi[i] - qi);
            if s_lo <= 0.0 || s_hi <= 0.0 {
                return None;
            }
            v += 0.5 * w[i] * (qi - qt[i]).powi(2) - MU * (s_lo.ln() + s_hi.ln());
        }
        for g in &self.g {
            if *g <= 0.0 {
                return None;
            }
            v -= MU * g.ln();
        }
        Some(v)
    }

    /// Move `q` (inside the domain) to the barrier minimiser near it for target `qt`.
    fn settle(&mut self, q: &mut [f64], qt: &[f64], w: &[f64]) {
        let n = q.len();
        let m = self.g.len();
        let (mut grad, mut h, mut trial) = (vec![0.0; n], vec![0.0; n * n], vec![0.0; n]);
        for _ in 0..ITERS_PER_KNOT {
            let Some(p0) = self.phi(q, qt, w) else {
                return;
            };
            self.diff
                .jacobian(&self.rows, q, &mut self.g, &mut self.jac);
            h.iter_mut().for_each(|v| *v = 0.0);
            for i in 0..n {
                let (s_lo, s_hi) = (q[i] - self.lo[i], self.hi[i] - q[i]);
                grad[i] = w[i] * (q[i] - qt[i]) - MU / s_lo + MU / s_hi;
                h[i * n + i] = w[i] + MU / (s_lo * s_lo) + MU / (s_hi * s_hi);
            }
            for r in 0..m {
                let (g, jr) = (self.g[r], &self.jac[r * n..(r + 1) * n]);
                let c = MU / (g * g);
                for i in 0..n {
                    grad[i] -= MU / g * jr[i];
                    for j in 0..n {
                        h[i * n + j] += c * jr[i] * jr[j];
                    }
                }
            }
            let gnorm = grad.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if gnorm < 1e-9 {
                return;
            }
            let mut step: Vec<f64> = grad.iter().map(|v| -v).collect();
            let divide = brachia_linalg::Scaling::Divide;
            if brachia_linalg::cholesky_with_pivot(&mut h, n, divide, 0.0).is_err() {
                return;
            }
            brachia_linalg::cholesky_solve_vec(&h, n, &mut step, divide);
            let big = step.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            if big > MAX_STEP {
                step.iter_mut().for_each(|v| *v *= MAX_STEP / big);
            }
            let slope: f64 = grad.iter().zip(&step).map(|(a, b)| a * b).sum();
            let mut alpha = 1.0;
            let mut moved = false;
            while alpha > 1e-6 {
                for i in 0..n {
                    trial[i] = q[i] + alpha * step[i];
                }
                if let Some(p1) = self.phi(&trial, qt, w) {
                    if p1 <= p0 + 1e-4 * alpha * slope {
                        q.copy_from_slice(&trial);
                        moved = true;
                        break;
                    }
                }
                alpha *= 0.5;
            }
            if !moved {
                return;
            }
        }
    }
}

/// One barrier-tracked path: the obstacle-free plan's knots `free` followed forwards (from its start
/// pose) or `backward` (from its final pose) with joint weights `w` (n values), keeping
/// `extra_clearance` (m) beyond the planner's margin. Returns the seed's report (kind `kind`, not tried)
/// and its guess trajectory, or `None` when the pose tracking starts from is outside the barrier's
/// domain.
pub fn track_seed(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    free: &Trajectory,
    kind: SeedKind,
    w: &[f64],
    extra_clearance: f64,
) -> Result<Option<(SeedReport, Trajectory)>> {
    let n = robot.n;
    let len = free.len();
    if len < 2 || obstacles.is_empty() {
        return Ok(None);
    }
    let shared = Arc::new(robot.clone());
    let obstacles: Arc<[Circle]> = obstacles.into();
    let cf = ClearanceFn::new(
        Arc::clone(&shared),
        Arc::clone(&obstacles),
        settings.obstacle_margin + extra_clearance,
    )?
    .with_self_collision(true);
    let b = &settings.bounds;
    let mut lo = vec![-b.q_rel_max; n];
    let mut hi = vec![b.q_rel_max; n];
    (lo[0], hi[0]) = (b.q1[0], b.q1[1]);
    // the bounds' own slack for the barrier: the start pose may sit on a bound
    for (l, h) in lo.iter_mut().zip(hi.iter_mut()) {
        *l -= 1e-3;
        *h += 1e-3;
    }
    let mut tr = Tracker::new(DistanceClearanceFn::new(cf), lo, hi);
    let margin = settings.obstacle_margin;
    let check = ClearanceFn::new(shared, obstacles, margin)?.with_self_collision(true);
    let backward = kind.backward();
    let order: Vec<usize> = if backward {
        (0..len).rev().collect()
    } else {
        (0..len).collect()
    };
    let mut q = free.q(order[0]).to_vec();
    if tr.phi(&q, &q.clone(), w).is_none() {
        return Ok(None);
    }
    let mut path = vec![0.0; len * n];
    for &k in &order {
        tr.settle(&mut q, free.q(k), w);
        path[k * n..(k + 1) * n].copy_from_slice(&q);
    }
    let dev = |k: usize| -> f64 {
        (0..n)
            .map(|i| (path[k * n + i] - free.q[k * n + i]).powi(2))
            .sum()
    };
    let score = (0..len).map(dev).sum::<f64>() / len as f64 + dev(0) + dev(len - 1);
    let min_clearance_m = (0..len)
        .map(|k| check.min_clearance(&path[k * n..(k + 1) * n]) - margin)
        .fold(f64::INFINITY, f64::min);
    let mut g = Trajectory::new(n);
    for k in 0..len {
        let (a, c) = (k.saturating_sub(1), (k + 1).min(len - 1));
        let dt = free.t[c] - free.t[a];
        let qd: Vec<f64> = (0..n)
            .map(|i| {
                let da = path[a * n + i] - free.q[a * n + i];
                let dc = path[c * n + i] - free.q[c * n + i];
                free.qd[k * n + i] + (dc - da) / dt
            })
            .collect();
        g.push(free.t[k], &path[k * n..(k + 1) * n], &qd, free.tau(k));
    }
    Ok(Some((
        SeedReport {
            kind,
            score,
            min_clearance_m,
            converged: None,
        },
        g,
    )))
}

/// The detour seeds of the obstacle-free plan `free` (its knots; `q0` its start pose) against
/// `obstacles`, in the order to try them (forward-fold, forward, backward-fold, backward), each with
/// the guess trajectory to plan from. Seeds whose start
/// (forward) or final (backward) pose is inside the barrier's domain only; none when neither is. Seeds
/// that tracked the same path (to [`SAME_PATH_RAD`]) as an earlier one are dropped.
pub fn detour_seeds(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    free: &Trajectory,
) -> Result<Vec<(SeedReport, Trajectory)>> {
    let n = robot.n;
    let mut out = vec![];
    for kind in SeedKind::ORDER {
        if let Some(s) = track_seed(
            robot,
            obstacles,
            settings,
            free,
            kind,
            &kind.weights(n),
            EXTRA_CLEARANCE,
        )? {
            out.push(s);
        }
    }
    // a seed that tracked the same path as an earlier one (the obstacle never touched the weighted
    // joints' choice) is not worth a solve
    let mut kept: Vec<(SeedReport, Trajectory)> = Vec::with_capacity(out.len());
    for (r, g) in out {
        let same = kept.iter().any(|(_, h)| {
            g.q.iter()
                .zip(&h.q)
                .all(|(a, b)| (a - b).abs() <= SAME_PATH_RAD)
        });
        if !same {
            kept.push((r, g));
        }
    }
    Ok(kept)
}
