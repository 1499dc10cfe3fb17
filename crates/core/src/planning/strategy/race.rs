//! Candidate guesses solved side by side: the first candidate in order whose plan converges (and
//! keeps the clearance on its resampled trajectory) wins, whichever finishes first, and the
//! candidates after it are cancelled; the result is the one solving them one after the other gives
//! (short of the time limit).
//!
//! Each candidate is a closure that plans the task from one guess and returns its plans in the order
//! they were solved (the candidate's own solves: a coarse solve, the solve at the task's mesh, a
//! resume). Up to [`RACE_WORKERS`] candidates run at a time, taken in their order; a candidate
//! starts only while no candidate before it has won and time is left. Each candidate has a cancel
//! token of its own, set when a candidate before it wins or when the caller's token is set (the
//! calling thread watches it every [`WATCH_PERIOD`]), so a cancelled call ends within one iteration
//! of every solve running.
//! With one worker (one core, or called from a thread pool's worker whose cores are taken) the
//! candidates run one after the other on the calling thread, with the caller's own token.
//!
//! Units: s.

use crate::error::Result;
use crate::planning::nlp::NlpSettings;
use crate::planning::outcome::{Plan, SolveRole};
use brachia_ocp::CancelToken;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

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
    /// The first candidate, in order, whose last plan converged.
    pub winner: Option<usize>,
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
    // winner is the first candidate in order that converges, whatever the threads' timing
    let tokens: Vec<CancelToken> = (0..n).map(|_| CancelToken::new()).collect();
    let cancel_from = |first: usize| tokens.iter().skip(first).for_each(CancelToken::cancel);
    let next = AtomicUsize::new(0);
    let best = AtomicUsize::new(n);
    let running = AtomicUsize::new(workers(n));
    let results: Mutex<Vec<(usize, Result<Plans>)>> = Mutex::new(vec![]);
    let worker = || {
        loop {
            let i = next.fetch_add(1, Ordering::SeqCst);
            if i >= n || i > best.load(Ordering::SeqCst) || tokens[i].is_cancelled() {
                break;
            }
            let Some(run) = nlp.remaining(started) else {
                break;
            };
            let run = NlpSettings {
                cancel: Some(tokens[i].clone()),
                ..run
            };
            let r = candidates[i](&run);
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
