//! Candidate guesses solved side by side: the first plan that converges (and keeps the clearance on
//! its resampled trajectory) wins, and the solves still running are cancelled.
//!
//! Each candidate is a closure that plans the task from one guess and returns its plans in the order
//! they were solved (the candidate's own solves: a coarse solve, the solve at the task's mesh, a
//! resume). Up to [`RACE_WORKERS`] candidates run at a time, taken in their order; a candidate
//! starts only while no plan has won and time is left. The solves of a race share one cancel token
//! of their own, set when a plan wins or when the caller's token is set (the calling thread watches
//! it every [`WATCH_PERIOD`]), so a cancelled call ends within one iteration of every solve running.
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
    /// The candidate whose last plan converged first.
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
    let token = CancelToken::new();
    let next = AtomicUsize::new(0);
    let running = AtomicUsize::new(workers(n));
    let results: Mutex<Vec<(usize, Result<Plans>)>> = Mutex::new(vec![]);
    let winner: Mutex<Option<usize>> = Mutex::new(None);
    let worker = || {
        loop {
            let i = next.fetch_add(1, Ordering::SeqCst);
            if i >= n || token.is_cancelled() {
                break;
            }
            let Some(run) = nlp.remaining(started) else {
                break;
            };
            let run = NlpSettings {
                cancel: Some(token.clone()),
                ..run
            };
            let r = candidates[i](&run);
            if r.as_ref().map_or(true, won) {
                // a converged plan ends the race; so does an error
                let mut w = winner.lock().unwrap_or_else(|e| e.into_inner());
                if w.is_none() && r.is_ok() {
                    *w = Some(i);
                }
                token.cancel();
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
                token.cancel();
            }
            std::thread::sleep(WATCH_PERIOD);
        }
    });
    let mut results = results.into_inner().unwrap_or_else(|e| e.into_inner());
    results.sort_by_key(|(i, _)| *i);
    for (i, r) in results {
        out.plans[i] = Some(r?);
    }
    out.winner = winner.into_inner().unwrap_or_else(|e| e.into_inner());
    Ok(out)
}
