//! The record of a planning call that made several solves (the obstacle strategies, the continuation
//! on the torque limits, the free swing time's starts): every solver attempt of every solve, in the
//! order they ran, each tagged with what it was for ([`SolveRole`]) and which solve it belongs to, so
//! that the returned [`Plan`] lists all of them in `solves`, and its `iterations`, `attempts`,
//! `solve_time_s` and `time_split` are their totals. Exactly one attempt stays `adopted`: the one the
//! returned plan's point comes from.
//!
//! Units: times in seconds; scales are factors (1 = as the task or robot gives it).

use super::collocation::CallbackTimings;
use super::nlp::TimeSplit;
use super::planner::{Plan, SolveAttempt};
use serde::{Deserialize, Serialize};

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
    /// swing time did not plan ([`crate::planning::swing_time`]).
    SwingTimeAnchor {
        /// The swing time, s.
        t_s: f64,
    },
    /// The task at the swing time `t_s`, warm from the last converged plan of the continuation in T
    /// ([`crate::planning::swing_time`]).
    SwingTimeStep {
        /// The swing time, s.
        t_s: f64,
    },
    /// The task again, warm from the solve before it, with the clearance rows also at the RK4
    /// sub-step states (that solve's resampled trajectory broke the clearance between the knots).
    SubstepClearance,
}

/// Totals over some attempts: how many, their iterations and their time (s).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Totals {
    pub attempts: usize,
    pub iterations: usize,
    pub time_s: f64,
}

/// Every attempt of the solves of one planning call, in order (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct SolveLog {
    attempts: Vec<SolveAttempt>,
    callbacks: CallbackTimings,
    solves: usize,
}

impl SolveLog {
    /// Record the solve that produced `p` as the next one, for `role`: its attempts are tagged in `p`
    /// too, so that [`SolveLog::finish`] knows them when `p` is returned.
    ///
    /// A plan that already holds several solves (a free swing time's starts, each tagged by the
    /// search's own log) keeps them apart: their indices follow this log's, each keeps its role and
    /// gets `role` as `within`.
    pub fn record(&mut self, p: &mut Plan, role: SolveRole) {
        let base = self.solves;
        let mut inner = 1;
        for a in &mut p.solves {
            inner = inner.max(a.solve + 1);
            a.solve += base;
            if a.role == SolveRole::Task && a.within.is_none() {
                a.role = role;
            } else {
                a.within = Some(role);
            }
        }
        self.solves += inner;
        self.attempts.extend(p.solves.iter().cloned());
        self.callbacks.add(&p.callback_timings);
    }

    /// Totals over the recorded attempts whose solve's role (`within`, else `role`) passes `keep`.
    pub fn totals(&self, keep: impl Fn(&SolveRole) -> bool) -> Totals {
        let mut t = Totals::default();
        for a in self
            .attempts
            .iter()
            .filter(|a| keep(&a.within.unwrap_or(a.role)))
        {
            t.attempts += 1;
            t.iterations += a.iterations;
            t.time_s += a.time_s;
        }
        t
    }

    /// Make `p`, one of the recorded plans, the call's result: it lists every recorded attempt, the
    /// adopted one only among its own, and its counts, times and callback timings are the totals.
    pub fn finish(self, p: &mut Plan) {
        let own: Vec<usize> = p.solves.iter().map(|a| a.solve).collect();
        let mut all = self.attempts;
        for a in &mut all {
            a.adopted = a.adopted && own.contains(&a.solve);
        }
        p.iterations = all.iter().map(|a| a.iterations).sum();
        p.attempts = all.len();
        p.solve_time_s = all.iter().map(|a| a.time_s).sum();
        p.time_split = TimeSplit::default();
        for a in &all {
            p.time_split.add(&a.time_split);
        }
        p.callback_timings = self.callbacks;
        p.solves = all;
    }
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
            SolveRole::SwingTimeAnchor { t_s } => write!(f, "cold at T = {t_s:.4} s"),
            SolveRole::SwingTimeStep { t_s } => write!(f, "continued to T = {t_s:.4} s"),
        }
    }
}

/// What is wrong with `p`'s account of its solves, one line each (empty when nothing is): a plan of
/// [`super::plan`] or [`super::SwingPlanner`] keeps `attempts == solves.len()`, `iterations`,
/// `solve_time_s` and each part of `time_split` the totals of `solves`, exactly one attempt adopted,
/// ended with `p.status`, and solve indices 0, 1, 2, ... in order (an attempt has the index of the one
/// before it or the next). The tests run it on plans of every kind. (The phases of a joint multi-swing
/// plan list no attempts of their own: the joint solve's are in its report.)
pub fn audit(p: &Plan) -> Vec<String> {
    let mut bad = Vec::new();
    let s = &p.solves;
    if p.attempts != s.len() {
        bad.push(format!("attempts {} != {} listed", p.attempts, s.len()));
    }
    let it: usize = s.iter().map(|a| a.iterations).sum();
    if p.iterations != it {
        bad.push(format!("iterations {} != {it} summed", p.iterations));
    }
    let t: f64 = s.iter().map(|a| a.time_s).sum();
    let tol = 1e-9 * (1.0 + t);
    if (p.solve_time_s - t).abs() > tol {
        bad.push(format!("solve_time_s {} != {t} summed", p.solve_time_s));
    }
    let mut split = TimeSplit::default();
    for a in s {
        split.add(&a.time_split);
    }
    let (q, r) = (&p.time_split, &split);
    let parts = [
        ("callbacks", q.callbacks_s, r.callbacks_s),
        ("linear algebra", q.linear_algebra_s, r.linear_algebra_s),
        (
            "line search",
            q.line_search_and_other_s,
            r.line_search_and_other_s,
        ),
    ];
    for (name, have, sum) in parts {
        if (have - sum).abs() > tol {
            bad.push(format!("time_split {name} {have} s != {sum} s summed"));
        }
    }
    let adopted: Vec<_> = s.iter().filter(|a| a.adopted).collect();
    match adopted.as_slice() {
        [a] if a.status != p.status => bad.push(format!(
            "the adopted attempt ended {:?}, the plan {:?}",
            a.status, p.status
        )),
        [_] => {}
        _ => bad.push(format!("{} attempts adopted", adopted.len())),
    }
    let stepped = |w: &[SolveAttempt]| w[1].solve == w[0].solve || w[1].solve == w[0].solve + 1;
    if s.first().is_some_and(|a| a.solve != 0) || !s.windows(2).all(stepped) {
        bad.push(format!(
            "solve indices {:?}",
            s.iter().map(|a| a.solve).collect::<Vec<_>>()
        ));
    }
    bad
}
