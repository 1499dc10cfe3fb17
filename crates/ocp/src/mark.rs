//! A flag a solve raises once it has run a given number of iterations, for a caller that acts on
//! a solve's progress while it runs (another thread reads the flag; the solve goes on unchanged).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Raised by a solve at the top of its iteration `after` (0-based: `after` iterations have run),
/// restoration iterations included; never lowered by the solve. Cheap to clone; clones share the
/// flag. Two marks compare equal when they share the flag and the iteration.
#[derive(Debug, Clone)]
pub struct IterationMark {
    /// Iterations run before the flag is raised.
    pub after: usize,
    /// The flag.
    pub flag: Arc<AtomicBool>,
}

impl IterationMark {
    /// A mark raised after `after` iterations, on a flag of its own (not raised).
    pub fn new(after: usize) -> Self {
        IterationMark {
            after,
            flag: Arc::new(AtomicBool::new(false)),
        }
    }

    /// Raise the flag when `iter` iterations have run and it is at least [`IterationMark::after`].
    pub fn reached(&self, iter: usize) {
        if iter >= self.after {
            self.flag.store(true, Ordering::SeqCst);
        }
    }

    /// True once the flag is raised (by this solve or anyone sharing it).
    pub fn is_raised(&self) -> bool {
        self.flag.load(Ordering::SeqCst)
    }
}

impl PartialEq for IterationMark {
    fn eq(&self, other: &Self) -> bool {
        self.after == other.after && Arc::ptr_eq(&self.flag, &other.flag)
    }
}
