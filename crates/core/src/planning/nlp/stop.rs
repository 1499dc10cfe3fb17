//! When a backend must stop early: the caller's cancel token ([`NlpSettings::cancel`]) or the
//! wall-clock limit ([`NlpSettings::max_wall_time_s`]), checked by the backends' per-iteration hooks
//! (pounce's `intermediate_callback`, ripopt's intermediate callback) so neither runs more than one
//! iteration past either. The backends' own time checks are coarser (ripopt polls its clock only
//! every tenth iteration after the tenth) and their internal re-solves restart their clocks.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::problem::{NlpSettings, SolveStatus};
use crate::{CancelToken, IterationMark};

/// The stop rule of one solve; cheap to clone (clones share what they observed), `Send`.
#[derive(Debug, Clone)]
pub(crate) struct Stop {
    cancel: Option<CancelToken>,
    deadline: Option<Instant>,
    /// Set when [`Stop::now`] said stop because the deadline passed.
    timed_out: Arc<AtomicBool>,
    /// The caller's mark of the solve's progress ([`NlpSettings::iteration_mark`]).
    mark: Option<IterationMark>,
}

impl Stop {
    /// The rule of a solve of `settings` that began at `start`.
    pub fn new(settings: &NlpSettings, start: Instant) -> Self {
        let deadline = settings
            .max_wall_time_s
            .filter(|t| t.is_finite() && *t > 0.0)
            .map(|t| start + Duration::from_secs_f64(t.min(1e9)));
        Stop {
            cancel: settings.cancel.clone(),
            deadline,
            timed_out: Arc::new(AtomicBool::new(false)),
            mark: settings.iteration_mark.clone(),
        }
    }

    /// True once the token is set.
    pub fn cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(|c| c.is_cancelled())
    }

    /// The backend is at the top of its iteration `iter` (0-based): raises the caller's mark once
    /// it is reached.
    pub fn at_iteration(&self, iter: usize) {
        if let Some(m) = &self.mark {
            m.reached(iter);
        }
    }

    /// Should the backend stop at this iteration? (Records a stop by the deadline.)
    pub fn now(&self) -> bool {
        if self.cancelled() {
            return true;
        }
        if self.deadline.is_some_and(|d| Instant::now() >= d) {
            self.timed_out.store(true, Ordering::Relaxed);
            return true;
        }
        false
    }

    /// The status of a solve that ended with the backend's `status`: a solve that did not converge
    /// is [`SolveStatus::Cancelled`] once the token is set, and [`SolveStatus::MaxWallTime`] when
    /// this rule stopped it at the deadline (the backend reports a user stop).
    pub fn verdict(&self, status: SolveStatus) -> SolveStatus {
        if status.is_converged() {
            status
        } else if self.cancelled() {
            SolveStatus::Cancelled
        } else if self.timed_out.load(Ordering::Relaxed) {
            SolveStatus::MaxWallTime
        } else {
            status
        }
    }
}
