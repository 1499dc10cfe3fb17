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

/// The cancel flag of long work (a plan, a reproduction, the parameter study, a traverse, the
/// benchmark): one type for every layer, [`brachia::CancelToken`] (whose home is the solver crate, the
/// lowest that checks it). Set from anywhere (the CLI's Ctrl-C handler, another thread, Python),
/// checked by the library between units of work and by every solver between iterations. Work that
/// sees it set stops with [`crate::ExpError::Cancelled`] and writes nothing: staged output is removed,
/// never renamed into place, so the previous results stay as they were.
pub use brachia::CancelToken;
