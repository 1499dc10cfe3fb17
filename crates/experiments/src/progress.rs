//! Progress of long work (the parameter study, a reproduction), reported through a callback so the
//! library draws nothing: the CLI turns it into a progress bar, a Python caller into whatever it likes.

/// One progress report: `done` of `total` units of `what` are finished.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Units finished so far (1..=total).
    pub done: u64,
    /// Units in all (known before the first report).
    pub total: u64,
    /// What a unit is, e.g. "parameter-study solves".
    pub what: &'static str,
}

/// A progress callback: called from any thread (the study solves its rows in parallel), so it must
/// be `Sync`; calls may arrive out of order across threads, `done` counts up regardless.
pub type ProgressFn<'a> = &'a (dyn Fn(Progress) + Sync);

/// A callback that ignores every report.
pub fn no_progress(_: Progress) {}

/// A cancel flag for long work (a reproduction, the parameter study, a traverse): set from anywhere
/// (the CLI's Ctrl-C handler, another thread), checked by the library between units of work (a
/// parameter-study cell, an experiment, a swing). Cheap to clone; clones share the flag. Work that sees
/// it set stops with [`crate::ExpError::Cancelled`] and writes nothing: staged output is removed, never
/// renamed into place, so the previous results stay as they were.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(std::sync::Arc<std::sync::atomic::AtomicBool>);

impl CancelToken {
    /// A flag that is not set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Set the flag (idempotent).
    pub fn cancel(&self) {
        self.0.store(true, std::sync::atomic::Ordering::SeqCst);
    }

    /// The shared flag itself, for code that sets it from a signal handler (the CLI registers it
    /// for SIGINT).
    pub fn flag(&self) -> std::sync::Arc<std::sync::atomic::AtomicBool> {
        std::sync::Arc::clone(&self.0)
    }

    /// True once [`CancelToken::cancel`] was called on this token or a clone.
    pub fn is_cancelled(&self) -> bool {
        self.0.load(std::sync::atomic::Ordering::SeqCst)
    }

    /// `Err(ExpError::Cancelled)` once the flag is set: `token.check()?` between units of work.
    pub fn check(&self) -> Result<(), crate::ExpError> {
        if self.is_cancelled() {
            Err(crate::ExpError::Cancelled)
        } else {
            Ok(())
        }
    }
}
