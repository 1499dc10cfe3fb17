//! Candidate guesses solved side by side: the first candidate in order whose plan converges (and
//! keeps the clearance on its resampled trajectory) wins, unless a candidate before it is past its
//! first chance (below) when it converges; the candidates after the winner are cancelled.
//!
//! Each candidate is a closure that plans the task from one guess and returns its plans in the order
//! they were solved (the candidate's own solves: a coarse solve, the solve at the task's mesh, a
//! solve again from the seed). Up to [`RACE_WORKERS`] candidates run at a time, taken in their
//! order; a candidate starts only while no candidate before it has won and time is left. Each
//! candidate has a cancel token of its own, set when a candidate before it wins or when the
//! caller's token is set (the calling thread watches it every [`WATCH_PERIOD`]), so a cancelled
//! call ends within one iteration of every solve running.
//!
//! **Past the first chance.** A candidate whose first converged solve broke the clearance between
//! its rows (it is solving again with the rows at the sub-steps), or whose solve at the task's mesh
//! ended without a clear plan (it is solving again from its seed), marks itself (`yield_to_later`
//! of the shooting solve); so does a candidate whose solve at the task's mesh has run
//! [`FIRST_CHANCE_ITER_PER_INTERVAL`] iterations per knot interval without converging (the backend
//! raises the flag at that iteration, [`crate::IterationMark`], and the solve goes on unchanged).
//! A later candidate that has converged wins as soon as every candidate before it has ended or is
//! so marked, and those still running are cancelled: the race does not wait for a second chance
//! when a plan is already there.
//! Where no later candidate converges first, the earlier one runs to its end as before; which of
//! two plans a placement gets can then depend on which converges first.
//!
//! With one worker (one core, or called from a thread pool's worker whose cores are taken) the
//! candidates run one after the other on the calling thread, with the caller's own token, and the
//! first in order that converges wins.
//!
//! Units: s.

use crate::error::Result;
use crate::planning::nlp::NlpSettings;
use crate::planning::outcome::{Plan, SolveRole};
use crate::planning::solve::shooting::{with_yield_flag, yield_mark};
use brachia_ocp::CancelToken;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// Iterations per knot interval of a candidate's solve at the task's mesh (its first chance) after
/// which the candidate yields to a later one that has converged; the solve itself goes on
/// unchanged (measured on the placement scans: docs/planner-measurements.md).
pub const FIRST_CHANCE_ITER_PER_INTERVAL: f64 = 1.0;

/// Candidates solved at a time (the machine's cores, at most this many).
pub const RACE_WORKERS: usize = 2;
/// How often the calling thread looks at the caller's cancel token during a race.
pub const WATCH_PERIOD: Duration = Duration::from_millis(10);

/// The plans of one candidate, in the order solved, each with what it was for; the last is the
/// candidate's result.
pub(crate) type Plans = Vec<(SolveRole, Plan)>;

/// One candidate: plans the task with the settings given (cancel token and time limit set), every
/// plan it solved in order, the last its result; an empty list when it had nothing to solve.
pub(crate) type Candidate<'a> = Box<dyn Fn(&NlpSettings) -> Result<Plans> + Send + Sync + 'a>;

/// Whether a candidate's plans end in a converged plan.
pub(crate) fn won(plans: &Plans) -> bool {
    plans.last().is_some_and(|(_, p)| p.converged())
}

/// What a race gave: per candidate, its plans (`None`: never started), and which candidate won.
pub(crate) struct RaceOutcome {
    /// Per candidate, in the candidates' order, the plans it solved (`None`: not started).
    pub plans: Vec<Option<Plans>>,
    /// The first candidate, in order, whose last plan converged (the candidates before it ended
    /// without a plan, or were cancelled past their first chance).
    pub winner: Option<usize>,
}

/// The iterations of the first chance of a solve of a swing of `t_s` on knots `knot_dt` apart, s:
/// [`FIRST_CHANCE_ITER_PER_INTERVAL`] per knot interval; `None` without a swing time (`t_s` not
/// positive).
pub(crate) fn first_chance_iter(knot_dt: f64, t_s: f64) -> Option<usize> {
    if !(t_s > 0.0 && knot_dt > 0.0) {
        return None;
    }
    let intervals = (t_s / knot_dt).ceil();
    Some((FIRST_CHANCE_ITER_PER_INTERVAL * intervals).clamp(1.0, 1e6) as usize)
}

/// `run` with the first chance of a solve of a swing of `t_s` on knots `knot_dt` apart, s: once
/// the solve has run its [`first_chance_iter`] iterations, the candidate running it yields to a
/// later one that has converged. `run` itself outside a race or without a swing time (`t_s` not
/// positive).
pub(crate) fn with_first_chance(run: &NlpSettings, knot_dt: f64, t_s: f64) -> NlpSettings {
    let Some(after) = first_chance_iter(knot_dt, t_s) else {
        return run.clone();
    };
    NlpSettings {
        iteration_mark: yield_mark(after),
        ..run.clone()
    }
}

/// How many workers a race of `candidates` gets: [`RACE_WORKERS`], the available cores, the
/// candidates, and one inside a thread pool's worker.
fn workers(candidates: usize) -> usize {
    if rayon::current_thread_index().is_some() {
        return 1;
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    RACE_WORKERS.min(cores).min(candidates).max(1)
}

/// Run `candidates` (see the module docs) within `nlp`'s time limit counted from `started` and its
/// cancel token. Errors: the first error a candidate returned (the race stops).
pub(crate) fn race(
    candidates: &[Candidate<'_>],
    nlp: &NlpSettings,
    started: Instant,
) -> Result<RaceOutcome> {
    let n = candidates.len();
    let mut out = RaceOutcome {
        plans: (0..n).map(|_| None).collect(),
        winner: None,
    };
    if workers(n) <= 1 {
        for (i, c) in candidates.iter().enumerate() {
            let Some(run) = nlp.remaining(started) else {
                break;
            };
            let plans = c(&run)?;
            let done = won(&plans);
            out.plans[i] = Some(plans);
            if done {
                out.winner = Some(i);
                break;
            }
        }
        return Ok(out);
    }
    // one token per candidate: a converged candidate cancels only the candidates after it, so the
    // winner is the first candidate in order that converges, short of those past their first chance
    let tokens: Vec<CancelToken> = (0..n).map(|_| CancelToken::new()).collect();
    let cancel_from = |first: usize| tokens.iter().skip(first).for_each(CancelToken::cancel);
    // per candidate: past its first chance (raised by its solves), and ended (or never to start)
    let yielding: Vec<Arc<AtomicBool>> = (0..n).map(|_| Arc::new(AtomicBool::new(false))).collect();
    let ended: Vec<AtomicBool> = (0..n).map(|_| AtomicBool::new(false)).collect();
    let next = AtomicUsize::new(0);
    let best = AtomicUsize::new(n);
    let running = AtomicUsize::new(workers(n));
    let results: Mutex<Vec<(usize, Result<Plans>)>> = Mutex::new(vec![]);
    // the first converged candidate wins once every candidate before it has ended or yields: the
    // ones still running are cancelled
    let decide = || {
        let b = best.load(Ordering::SeqCst);
        let earlier_done =
            |i: usize| ended[i].load(Ordering::SeqCst) || yielding[i].load(Ordering::SeqCst);
        if b < n && (0..b).all(earlier_done) {
            cancel_from(0);
        }
    };
    let worker = || {
        loop {
            let i = next.fetch_add(1, Ordering::SeqCst);
            if i >= n {
                break;
            }
            let run = nlp.remaining(started);
            let (true, Some(run)) = (
                i <= best.load(Ordering::SeqCst) && !tokens[i].is_cancelled(),
                run,
            ) else {
                ended[i].store(true, Ordering::SeqCst);
                break;
            };
            let run = NlpSettings {
                cancel: Some(tokens[i].clone()),
                ..run
            };
            let r = with_yield_flag(&yielding[i], || candidates[i](&run));
            match &r {
                Ok(plans) if won(plans) => {
                    best.fetch_min(i, Ordering::SeqCst);
                    cancel_from(i + 1);
                }
                Ok(_) => {}
                // an error ends the race
                Err(_) => cancel_from(0),
            }
            results
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .push((i, r));
            ended[i].store(true, Ordering::SeqCst);
            decide();
        }
        running.fetch_sub(1, Ordering::SeqCst);
    };
    std::thread::scope(|s| {
        for _ in 0..workers(n) {
            s.spawn(worker);
        }
        while running.load(Ordering::SeqCst) > 0 {
            if nlp.is_cancelled() {
                cancel_from(0);
            }
            decide();
            std::thread::sleep(WATCH_PERIOD);
        }
    });
    let mut results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    results.sort_by_key(|(i, _)| *i);
    for (i, r) in results {
        out.plans[i] = Some(r?);
    }
    let b = best.into_inner();
    out.winner = (b < n).then_some(b);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Robot;
    use crate::planning::nlp::SolveStatus;
    use crate::planning::settings::PlannerSettings;
    use crate::planning::solve::shooting::yield_to_later;
    use crate::planning::task::SwingTask;

    /// A converged plan (the paper's unobstructed swing) and the same plan marked cancelled.
    fn plans() -> (Plan, Plan) {
        let s = PlannerSettings::default();
        let nlp = NlpSettings::default();
        let p = crate::planning::plan(&Robot::paper(), &SwingTask::paper(), &s, &nlp).unwrap();
        assert!(p.converged(), "{:?}", p.failure_message());
        let mut c = p.clone();
        c.status = SolveStatus::Cancelled;
        (p, c)
    }

    /// Waits until `run`'s token is set (at most 20 s), then returns `out` (or `cancelled` when
    /// the token was set).
    fn wait_for_cancel(run: &NlpSettings, out: &Plan, cancelled: &Plan) -> Plans {
        let t0 = Instant::now();
        while t0.elapsed() < Duration::from_secs(20) {
            if run.is_cancelled() {
                return vec![(SolveRole::Task, cancelled.clone())];
            }
            std::thread::sleep(Duration::from_millis(2));
        }
        vec![(SolveRole::Task, out.clone())]
    }

    #[test]
    fn a_solve_past_its_first_chance_marks_its_candidate_and_nothing_outside_a_race() {
        let none = with_first_chance(&NlpSettings::default(), 0.03, 2.0);
        assert!(none.iteration_mark.is_none());
        let flag = Arc::new(AtomicBool::new(false));
        let run = with_yield_flag(&flag, || {
            with_first_chance(&NlpSettings::default(), 0.03, 2.0)
        });
        // one iteration per knot interval: 2 s on 30 ms knots is 67 intervals
        assert_eq!(run.iteration_mark.as_ref().map(|m| m.after), Some(67));
        assert!(with_yield_flag(&flag, || {
            with_first_chance(&NlpSettings::default(), 0.03, 0.0)
                .iteration_mark
                .is_none()
        }));
        // the paper's swing, planned in a candidate whose first chance is 2 or 10^4 iterations
        let robot = Robot::paper();
        let task = SwingTask::paper();
        let s = PlannerSettings::default();
        for (t_s, raised) in [(0.06, true), (300.0, false)] {
            let flag = Arc::new(AtomicBool::new(false));
            let p = with_yield_flag(&flag, || {
                let run = with_first_chance(&NlpSettings::default(), 0.03, t_s);
                crate::planning::plan(&robot, &task, &s, &run).unwrap()
            });
            assert!(p.converged(), "{:?}", p.failure_message());
            assert!(p.solves.iter().map(|a| a.iterations).sum::<usize>() > 2);
            assert_eq!(
                flag.load(Ordering::SeqCst),
                raised,
                "first chance over {t_s} s"
            );
        }
    }

    #[test]
    fn a_later_converged_candidate_wins_over_one_past_its_first_chance() {
        if workers(2) < 2 {
            return;
        }
        let (ok, cancelled) = plans();
        // candidate 0 yields and would go on for 20 s; candidate 1 converges at once
        let first: Candidate<'_> = Box::new(|run: &NlpSettings| {
            yield_to_later();
            Ok(wait_for_cancel(run, &ok, &cancelled))
        });
        let second: Candidate<'_> =
            Box::new(|_: &NlpSettings| Ok(vec![(SolveRole::Task, ok.clone())]));
        let t0 = Instant::now();
        let out = race(&[first, second], &NlpSettings::default(), Instant::now()).unwrap();
        assert_eq!(out.winner, Some(1));
        let p0 = out.plans[0].as_ref().unwrap();
        assert_eq!(p0.last().unwrap().1.status, SolveStatus::Cancelled);
        assert!(t0.elapsed() < Duration::from_secs(10), "{:?}", t0.elapsed());
    }

    #[test]
    fn a_candidate_in_its_first_chance_keeps_its_place_in_the_order() {
        if workers(2) < 2 {
            return;
        }
        let (ok, _) = plans();
        // candidate 0 converges after candidate 1 without yielding: it wins
        let first: Candidate<'_> = Box::new(|_: &NlpSettings| {
            std::thread::sleep(Duration::from_millis(200));
            Ok(vec![(SolveRole::Task, ok.clone())])
        });
        let second: Candidate<'_> =
            Box::new(|_: &NlpSettings| Ok(vec![(SolveRole::Task, ok.clone())]));
        let out = race(&[first, second], &NlpSettings::default(), Instant::now()).unwrap();
        assert_eq!(out.winner, Some(0));
        assert!(won(out.plans[1].as_ref().unwrap()));
    }
}
