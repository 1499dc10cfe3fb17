//! A cancel flag shared between the code that runs long work and whoever may stop it (a Ctrl-C
//! handler, another thread, a Python caller). It lives in this, the lowest, crate so every layer
//! above (the solver here, the planner, the experiments, the command line) passes the same type.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// A cancel flag: set from anywhere, checked by long work between its units (a solver iteration, a
/// solve of a planning strategy, a swing, a run). Cheap to clone; clones share the flag. Work that
/// sees it set stops and says so: a solver with [`crate::OcpStatus::Cancelled`], other work with its
/// own "cancelled" outcome. Two tokens compare equal only when they share the flag.
#[derive(Debug, Clone, Default)]
pub struct CancelToken(Arc<AtomicBool>);

/// The error of [`CancelToken::check`]: the flag was set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("cancelled")]
pub struct Cancelled;

impl CancelToken {
    /// A flag that is not set.
    pub fn new() -> Self {
        Self::default()
    }

    /// Set the flag (idempotent).
    pub fn cancel(&self) {
        self.0.store(true, Ordering::SeqCst);
    }

    /// The shared flag itself, for code that sets it from a signal handler (e.g. `signal-hook`).
    pub fn flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.0)
    }

    /// True once [`CancelToken::cancel`] was called on this token or a clone (or the shared flag
    /// was set).
    pub fn is_cancelled(&self) -> bool {
        self.0.load(Ordering::SeqCst)
    }

    /// `Err(Cancelled)` once the flag is set: `token.check()?` between units of work.
    pub fn check(&self) -> Result<(), Cancelled> {
        if self.is_cancelled() {
            Err(Cancelled)
        } else {
            Ok(())
        }
    }
}

impl PartialEq for CancelToken {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.0, &other.0)
    }
}
