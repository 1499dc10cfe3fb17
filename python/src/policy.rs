//! A Python callable as a controller: `policy(t, x) -> tau`, called once per control period of a
//! closed loop (`track(..., controller=policy)`), with the GIL taken for the call and released again.
//!
//! `t` is the time in s (float), `x` the measured state `[q, qd]` as a float64 numpy array `(2n,)`;
//! the result is read as the torques of joints 2..n (n - 1 values, N m; clamped by the plant). An
//! exception in the policy (or a result of the wrong shape) stops the loop at that step: its torques
//! are not finite, so the loop records a divergence there, and `track` raises the exception once the
//! loop has returned: the policy leaves it in its error sink, which `track` holds beside it (the loop
//! may run on a worker thread).

use crate::convert::{arr1, read_vector, Arg, Range};
use brachia::sim::{ControlInfo, Controller};
use pyo3::prelude::*;
use pyo3::types::PyString;
use std::sync::{Arc, Mutex};

/// Where a policy leaves its first exception, for the thread that started its run to raise.
pub(crate) type ErrorSink = Arc<Mutex<Option<PyErr>>>;

/// Raise the exception left in `sink`, if any.
pub(crate) fn raise_from(sink: &ErrorSink) -> PyResult<()> {
    match sink.lock().ok().and_then(|mut slot| slot.take()) {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

/// A Python callable driving the plant.
pub(crate) struct PyPolicy {
    f: Py<PyAny>,
    /// The exception's destination.
    sink: ErrorSink,
}

impl PyPolicy {
    /// `obj` as a policy when it is callable (and not a controller's name), with the sink its
    /// exception goes to.
    pub(crate) fn of(obj: &Bound<'_, PyAny>) -> Option<(Self, ErrorSink)> {
        if obj.is_callable() && !obj.is_instance_of::<PyString>() {
            let sink: ErrorSink = Arc::new(Mutex::new(None));
            let policy = PyPolicy {
                f: obj.clone().unbind(),
                sink: sink.clone(),
            };
            Some((policy, sink))
        } else {
            None
        }
    }

    /// A policy for one run of a worker thread: `f` (whose `reset()`, when it has one, is called
    /// first), its exception left in `sink`.
    pub(crate) fn for_run(py: Python<'_>, f: &Py<PyAny>, sink: ErrorSink) -> PyResult<Self> {
        let f = f.clone_ref(py);
        if f.bind(py).hasattr("reset")? {
            f.bind(py).call_method0("reset")?;
        }
        Ok(PyPolicy { f, sink })
    }

    /// One call: `tau` from `policy(t, x)`.
    fn call(&self, py: Python<'_>, t: f64, x: &[f64], tau: &mut [f64]) -> PyResult<()> {
        let xs = arr1(py, x)?;
        let out = self.f.bind(py).call1((t, xs))?;
        let what = "torques of joints 2..n returned by the policy, N m";
        read_vector(&out, Arg::new("policy(t, x)", what, Range::Torque), tau)
    }
}

impl Controller for PyPolicy {
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let failed = Python::attach(|py| match self.call(py, t, x, tau) {
            Ok(()) => false,
            Err(e) => {
                if let Ok(mut slot) = self.sink.lock() {
                    slot.get_or_insert(e);
                }
                true
            }
        });
        if failed {
            tau.iter_mut().for_each(|v| *v = f64::NAN);
        }
        ControlInfo::default()
    }

    fn name(&self) -> &'static str {
        "python"
    }
}
