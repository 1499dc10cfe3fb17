//! Ctrl-C (`KeyboardInterrupt`) during long Rust work. Python runs its signal handlers only on the
//! main thread, between bytecodes: a call that stays in Rust would see Ctrl-C only when it returns.
//! So the work runs on a scoped worker thread with a cancel token in its settings, while the calling
//! thread waits without the GIL in short slices and, between them, asks Python for pending signals
//! (`Python::check_signals`). A pending `KeyboardInterrupt` (or any exception a signal handler raises)
//! sets the token; the worker's solves stop at their next iteration, its loops at their next check,
//! and the call raises that exception once the worker has returned. Work that owns everything it
//! uses and changes nothing the caller can see (a plan, a scenario's run) is not waited for:
//! [`interruptible_owned`] raises at once and leaves the worker to end at its next check.

use brachia::CancelToken;
use pyo3::prelude::*;
use std::time::Duration;

/// How long the calling thread waits without the GIL between two checks for signals.
const POLL: Duration = Duration::from_millis(20);

/// Wait without the GIL for [`POLL`], in 1 ms slices, or until `finished` says the work has ended.
fn wait_released(py: Python<'_>, finished: impl Fn() -> bool + Sync) {
    py.detach(|| {
        let step = Duration::from_millis(1);
        let mut waited = Duration::ZERO;
        while waited < POLL && !finished() {
            std::thread::sleep(step);
            waited += step;
        }
    });
}

/// Run `work(token)` on a worker thread, checking for Python signals every [`POLL`]: on a signal the
/// token is set and the signal's exception is raised after the work has stopped. `cancel` is the
/// token the work was given (its settings carry it).
pub(crate) fn interruptible<T: Send>(
    py: Python<'_>,
    cancel: &CancelToken,
    work: impl FnOnce() -> T + Send,
) -> PyResult<T> {
    std::thread::scope(|s| {
        let handle = s.spawn(work);
        let mut raised: Option<PyErr> = None;
        while !handle.is_finished() {
            wait_released(py, || handle.is_finished());
            if raised.is_none() {
                if let Err(e) = py.check_signals() {
                    cancel.cancel();
                    raised = Some(e);
                }
            }
        }
        let out = py.detach(|| handle.join());
        match (raised, out) {
            (Some(e), _) => Err(e),
            (None, Ok(v)) => Ok(v),
            (None, Err(p)) => std::panic::resume_unwind(p),
        }
    })
}

/// [`interruptible`] for work that owns its data and changes nothing the caller sees: on a signal the
/// token is set and the signal's exception is raised at once, without waiting for the worker, which
/// stops at its next check and whose result is dropped.
pub(crate) fn interruptible_owned<T: Send + 'static>(
    py: Python<'_>,
    cancel: &CancelToken,
    work: impl FnOnce() -> T + Send + 'static,
) -> PyResult<T> {
    let handle = std::thread::Builder::new()
        .name("brachia-work".into())
        .spawn(work)
        .map_err(|e| crate::convert::bad(format!("could not start the work: {e}")))?;
    while !handle.is_finished() {
        wait_released(py, || handle.is_finished());
        if let Err(e) = py.check_signals() {
            cancel.cancel();
            return Err(e);
        }
    }
    match py.detach(|| handle.join()) {
        Ok(v) => Ok(v),
        Err(p) => std::panic::resume_unwind(p),
    }
}
