//! The state of a mutable class (`Mpc`, `SwingPlanner`, `ModelPlant`, `RapierPlant`) behind a mutex,
//! so that any Python thread may call it: calls on one object run one after the other, never at once.
//!
//! A thread waiting for the lock does not hold the GIL (`MutexExt::lock_py_attached`), so a call that
//! works with the GIL released (a plan, a re-plan, a closed loop) cannot deadlock with a thread that
//! waits for it. The classes are `frozen` (PyO3 never borrows them mutably), so no call raises
//! "Already borrowed" and none is tied to the thread that made the object. `track` is the one call that
//! holds two locks (the plant's, then the controller's), always in that order, so no two calls wait
//! for each other.

use crate::convert::bad;
use pyo3::prelude::*;
use pyo3::sync::MutexExt;
use std::sync::{Mutex, MutexGuard};

/// A value used by several Python threads, one call at a time.
pub(crate) struct Shared<T> {
    inner: Mutex<T>,
    /// The class, for messages.
    class: &'static str,
}

impl<T> Shared<T> {
    /// `value` behind a new lock; `class` names the Python class in messages.
    pub(crate) fn new(class: &'static str, value: T) -> Self {
        Shared {
            inner: Mutex::new(value),
            class,
        }
    }

    /// The value, once no other thread uses it (waiting with the GIL released). An object whose
    /// earlier call panicked inside the library is refused: its state may be half-updated.
    pub(crate) fn lock(&self, py: Python<'_>) -> PyResult<MutexGuard<'_, T>> {
        self.inner.lock_py_attached(py).map_err(|_| {
            bad(format!(
                "{}: unusable: an earlier call on it failed inside the library; make a new one",
                self.class
            ))
        })
    }
}
