//! The state of a mutable class (`Mpc`, `SwingPlanner`, `ModelPlant`, `RapierPlant`) behind a mutex,
//! so that any Python thread may call it: calls on one object run one after the other, never at once.
//!
//! A thread waiting for the lock does not hold the GIL (`MutexExt::lock_py_attached`), so a call that
//! works with the GIL released (a plan, a re-plan, a closed loop) cannot deadlock with a thread that
//! waits for it. The classes are `frozen` (PyO3 never borrows them mutably), so no call raises
//! "Already borrowed" and none is tied to the thread that made the object. `track` is the one call that
//! holds two locks (the plant's, then the controller's), always in that order, so no two calls wait
//! for each other. A call made on an object from inside one of its own calls (an argument's
//! `__array__` calling back) is refused instead of waiting for itself.

use crate::convert::bad;
use pyo3::prelude::*;
use pyo3::sync::MutexExt;
use std::ops::{Deref, DerefMut};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Mutex, MutexGuard};

thread_local! {
    /// A byte whose address tells threads apart (nonzero, unique among live threads).
    static THREAD_KEY: u8 = const { 0 };
}

/// This thread's key.
fn thread_key() -> usize {
    THREAD_KEY.with(|k| k as *const u8 as usize)
}

/// A value used by several Python threads, one call at a time.
pub(crate) struct Shared<T> {
    inner: Mutex<T>,
    /// The key of the thread holding the lock, 0 when none.
    owner: AtomicUsize,
    /// The class, for messages.
    class: &'static str,
}

/// The locked value; unlocks when dropped.
pub(crate) struct Guard<'a, T> {
    guard: MutexGuard<'a, T>,
    owner: &'a AtomicUsize,
}

impl<T> Deref for Guard<'_, T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.guard
    }
}

impl<T> DerefMut for Guard<'_, T> {
    fn deref_mut(&mut self) -> &mut T {
        &mut self.guard
    }
}

impl<T> Drop for Guard<'_, T> {
    fn drop(&mut self) {
        self.owner.store(0, Ordering::Release);
    }
}

impl<T> Shared<T> {
    /// `value` behind a new lock; `class` names the Python class in messages.
    pub(crate) fn new(class: &'static str, value: T) -> Self {
        Shared {
            inner: Mutex::new(value),
            owner: AtomicUsize::new(0),
            class,
        }
    }

    /// The value, once no other thread uses it (waiting with the GIL released). A call from inside
    /// a call on the same object in this thread is refused (it would wait for itself); so is an
    /// object whose earlier call panicked inside the library (its state may be half-updated).
    pub(crate) fn lock(&self, py: Python<'_>) -> PyResult<Guard<'_, T>> {
        let me = thread_key();
        if self.owner.load(Ordering::Acquire) == me {
            return Err(bad(format!(
                "{}: called again from inside one of its own calls (an argument's __array__ or \
                 __float__ calling back); make the call after the first one returns",
                self.class
            )));
        }
        let guard = self.inner.lock_py_attached(py).map_err(|_| {
            bad(format!(
                "{}: unusable: an earlier call on it failed inside the library; make a new one",
                self.class
            ))
        })?;
        self.owner.store(me, Ordering::Release);
        Ok(Guard {
            guard,
            owner: &self.owner,
        })
    }
}
