//! A persistent helper thread for the stage evaluations of one problem: the second core's share of
//! every evaluation, handed over without a wake-up.
//!
//! A thread pool's workers (rayon's) fall asleep between the evaluations of a solve, and waking one
//! costs 50-80 us on this project's 2-core machines: more than the half of a 74-stage evaluation it
//! would take over (measured: rayon's split of a plan's stages was 0.96x of serial; docs/planner.md).
//! A [`SpinWorker`] owns its state (the stages it evaluates and their buffers) behind a mutex, runs
//! [`Job::run`] on it whenever its owner posts, and between posts keeps polling (yielding the core to
//! any other runnable thread) for [`SPIN`] before it parks, so within a solve, whose evaluations
//! come every few hundred microseconds, a post is seen within a microsecond, and an idle problem
//! costs nothing. A job the worker has not started by the time its owner waits for it (a parked
//! thread whose core was asleep) is run by the owner itself, so a split job is never slower than
//! the owner alone by more than the copies. The owner reads and writes the state only between a
//! [`SpinWorker::wait`] and the next [`SpinWorker::post`]. A panic inside a job is caught on the worker and handed to the owner
//! by [`SpinWorker::wait`]; the thread is stopped and joined when the worker is dropped.

use crate::planning::nlp::panic_text;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long the worker keeps polling for the next job before it parks.
pub(crate) const SPIN: Duration = Duration::from_millis(2);

/// How long the owner polls for the end of a job before it yields the core between polls.
const WAIT_SPIN: Duration = Duration::from_micros(200);

/// Work that a [`SpinWorker`] runs on its own state.
pub(crate) trait Job: Send + 'static {
    /// Run the job the owner last described in the state.
    fn run(&mut self);
}

struct Shared<S> {
    state: Mutex<S>,
    /// Jobs posted, claimed (by the worker, or by the owner when the worker has not started the
    /// job by the time the owner waits for it) and finished, each a count; all equal when idle.
    posted: AtomicU64,
    claimed: AtomicU64,
    done: AtomicU64,
    /// The message of a job that panicked, taken by the next `wait`.
    panic: Mutex<Option<String>>,
    stop: AtomicBool,
}

/// A helper thread that runs [`Job::run`] on its state `S` when posted (module docs).
pub(crate) struct SpinWorker<S: Job> {
    shared: Arc<Shared<S>>,
    handle: Option<JoinHandle<()>>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(PoisonError::into_inner)
}

impl<S: Job> SpinWorker<S> {
    /// Start the thread with `state`. If the system refuses a thread, the worker has none and
    /// [`Self::post`] runs the job on the caller's thread ([`Self::has_thread`] tells).
    pub(crate) fn spawn(state: S) -> Self {
        let shared = Arc::new(Shared {
            state: Mutex::new(state),
            posted: AtomicU64::new(0),
            claimed: AtomicU64::new(0),
            done: AtomicU64::new(0),
            panic: Mutex::new(None),
            stop: AtomicBool::new(false),
        });
        let theirs = Arc::clone(&shared);
        let handle = std::thread::Builder::new()
            .name("brachia-stages".into())
            .spawn(move || worker_loop(&theirs))
            .ok();
        SpinWorker { shared, handle }
    }

    /// Whether the jobs run on a thread of their own.
    pub(crate) fn has_thread(&self) -> bool {
        self.handle.is_some()
    }

    /// The state, for the owner to describe the next job or read the last one's results. Call it
    /// only while the worker is idle (before [`Self::post`] or after [`Self::wait`]); the worker
    /// holds the lock while it runs a job.
    pub(crate) fn state(&self) -> MutexGuard<'_, S> {
        lock(&self.shared.state)
    }

    /// Have the worker run the job described in the state (on the caller's thread, finished on
    /// return, if the worker has no thread). A job posted before and never waited for (its owner
    /// unwound in between) is settled first: not run if it had not started, its outcome dropped.
    pub(crate) fn post(&mut self) {
        let _ = self.finish(false);
        let Some(h) = &self.handle else {
            run_job(&self.shared);
            return;
        };
        self.shared.posted.fetch_add(1, Ordering::SeqCst);
        h.thread().unpark();
    }

    /// Wait for the posted job to finish: if the worker has not started it yet (a parked thread
    /// that is slow to wake, a core that is taken), run it here instead; otherwise poll until it
    /// is done. `Err` with the panic message if the job panicked (the state is then as the panic
    /// left it).
    pub(crate) fn wait(&mut self) -> Result<(), String> {
        self.finish(true)
    }

    /// End the posted job: claim it if the worker has not (and then run it here when `run`, or drop
    /// it), else poll until the worker has finished it; then take its panic message, if any.
    fn finish(&mut self, run: bool) -> Result<(), String> {
        let sh = &self.shared;
        let target = sh.posted.load(Ordering::SeqCst);
        if target > 0
            && sh
                .claimed
                .compare_exchange(target - 1, target, Ordering::AcqRel, Ordering::Acquire)
                .is_ok()
        {
            if run {
                run_job(sh);
            }
            sh.done.store(target, Ordering::Release);
        }
        // the worker claimed the job and runs it (it catches every panic, so it finishes)
        let start = Instant::now();
        let mut polls = 0u32;
        while sh.done.load(Ordering::Acquire) < target {
            polls = polls.wrapping_add(1);
            // past a job's usual length, give the core away if another thread wants it (the worker
            // itself, when more threads than cores are runnable)
            if polls.is_multiple_of(64) && start.elapsed() > WAIT_SPIN {
                std::thread::yield_now();
            }
            std::hint::spin_loop();
        }
        match lock(&sh.panic).take() {
            Some(msg) => Err(msg),
            None => Ok(()),
        }
    }
}

impl<S: Job> Drop for SpinWorker<S> {
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::SeqCst);
        if let Some(h) = self.handle.take() {
            h.thread().unpark();
            // a worker that panicked outside a job has nothing left to report
            let _ = h.join();
        }
    }
}

/// Run the job on the calling thread, a panic kept for the owner's `wait`.
fn run_job<S: Job>(sh: &Shared<S>) {
    let r = catch_unwind(AssertUnwindSafe(|| lock(&sh.state).run()));
    if let Err(p) = r {
        *lock(&sh.panic) = Some(panic_text(&*p));
    }
}

fn worker_loop<S: Job>(sh: &Shared<S>) {
    let mut seen = 0u64;
    loop {
        let mut idle_since = Instant::now();
        loop {
            if sh.stop.load(Ordering::SeqCst) {
                return;
            }
            if sh.posted.load(Ordering::SeqCst) > seen {
                break;
            }
            if idle_since.elapsed() > SPIN {
                // a post after this check unparks the thread (the token makes park return)
                std::thread::park();
                idle_since = Instant::now();
            } else {
                std::thread::yield_now();
            }
        }
        seen += 1;
        // the owner may have run this job itself (it claims a job the worker has not started)
        if sh
            .claimed
            .compare_exchange(seen - 1, seen, Ordering::AcqRel, Ordering::Acquire)
            .is_ok()
        {
            run_job(sh);
            sh.done.store(seen, Ordering::Release);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    struct Sum {
        input: Vec<f64>,
        out: f64,
        fail: bool,
        runs: usize,
    }

    impl Job for Sum {
        fn run(&mut self) {
            assert!(!self.fail, "asked to fail");
            self.out = self.input.iter().sum();
            self.runs += 1;
        }
    }

    #[test]
    fn jobs_run_on_the_worker_in_order_and_panics_come_back_as_errors() {
        let mut w = SpinWorker::spawn(Sum {
            input: vec![],
            out: 0.0,
            fail: false,
            runs: 0,
        });
        assert!(w.has_thread());
        for n in 1..200usize {
            w.state().input = (0..n).map(|i| i as f64).collect();
            w.post();
            w.wait().unwrap();
            assert_eq!(w.state().out, (n * (n - 1) / 2) as f64);
            if n % 50 == 0 {
                // past the spin time the worker parks; a post must wake it
                std::thread::sleep(SPIN * 2);
            }
        }
        // a job posted and waited for at once, often before the worker has seen it (then the owner
        // runs it: both paths must give the job's result, exactly once per post)
        let runs = w.state().runs;
        for n in 0..5000usize {
            w.state().input = vec![n as f64, 1.0];
            w.post();
            w.wait().unwrap();
            assert_eq!(w.state().out, n as f64 + 1.0);
            assert_eq!(w.state().runs, runs + n + 1, "each job runs once");
        }
        w.state().fail = true;
        w.post();
        let e = w.wait().unwrap_err();
        assert!(e.contains("asked to fail"), "{e}");
        // a failed job posted and never waited for (its owner unwound) leaves neither its error nor
        // a second run to the next job
        w.state().fail = true;
        w.post();
        w.state().fail = false;
        w.state().input = vec![4.0, 5.0];
        let runs = w.state().runs;
        w.post();
        w.wait().unwrap();
        assert_eq!(w.state().out, 9.0);
        assert_eq!(w.state().runs, runs + 1);
        // the worker survives a panicking job
        w.state().fail = false;
        w.state().input = vec![1.0, 2.0];
        w.post();
        w.wait().unwrap();
        assert_eq!(w.state().out, 3.0);
    }
}
