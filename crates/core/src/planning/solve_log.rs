//! The record of a planning call that made several solves (the obstacle strategies, the continuation
//! on the torque limits, the free swing time's starts): every solver attempt of every solve, in the
//! order they ran, each tagged with what it was for ([`SolveRole`]) and which solve it belongs to, so
//! that the returned [`Plan`] lists all of them in `solves`, and its `iterations`, `attempts`,
//! `solve_time_s` and `time_split` are their totals. Exactly one attempt stays `adopted`: the one the
//! returned plan's point comes from.
//!
//! Units: times in seconds; scales are factors (1 = as the task or robot gives it).

use super::outcome::{Plan, SolveAttempt, SolveRole};
use crate::planning::nlp::TimeSplit;
use crate::planning::transcription::collocation::CallbackTimings;

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
    /// A log that goes on after `p`, a plan that [`SolveLog::finish`] made the result of a call (or
    /// one solve's plan): its attempts, callback timings and solves come first.
    pub fn resume(p: &Plan) -> Self {
        Self {
            attempts: p.solves.clone(),
            callbacks: p.callback_timings,
            solves: p.solves.iter().map(|a| a.solve + 1).max().unwrap_or(0),
        }
    }

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
