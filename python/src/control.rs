//! `Mpc`: the linear MPC tracker (`brachia::control::Mpc`) owned together with its robot and reference.
//!
//! Conventions: `control(t, x)` takes the time (s) and the measured state `x = [q, qd]` (2n; rad, rad/s)
//! and returns the torques of joints 2..n, shape `(n - 1,)`, N m, inside the robot's limits. Settings are
//! a dict and/or keyword arguments with the fields of `brachia::control::MpcSettings` (a scenario's
//! `[tracking.mpc]`); fields left out keep the Rust defaults.
//!
//! The library's `Mpc` owns its robot and reference (`Arc`s), so this class holds it directly;
//! `set_reference` swaps the plan in place (`brachia::control::Mpc::set_reference`).

use crate::convert::{arr1, bad, finite_result, read_vector, rs, scalar, Arg, Count, Range, Real};
use crate::dicts::{settings_from, to_py};
use crate::model::{Robot, Trajectory};
use crate::planning::Plan;
use crate::shared::{Guard, Shared};
use brachia::control::MpcSettings;
use brachia::sim::Controller;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;
use std::time::Instant;

/// The reference of a `Plan` or a `Trajectory`.
pub(crate) fn reference_of(
    obj: &Bound<'_, PyAny>,
) -> PyResult<Arc<brachia::trajectory::Trajectory>> {
    if let Ok(p) = obj.cast::<Plan>() {
        return Ok(p.get().trajectory.clone());
    }
    if let Ok(t) = obj.cast::<Trajectory>() {
        return Ok(t.get().inner.clone());
    }
    Err(bad(format!(
        "reference: expected a Plan or a Trajectory, got {}",
        obj.get_type().name()?
    )))
}

/// The linear MPC tracker of the paper's Section IV (``brachia::control::Mpc``).
///
/// ``Mpc(robot, reference, settings=None, **kwargs)``: ``reference`` is a ``Plan`` or a
/// ``Trajectory``; ``settings`` (dict) and keyword arguments are ``[tracking.mpc]`` fields
/// (``horizon``, ``dt_mpc``, ``q_diag``, ``w_diag``, ``r_diag``, ``rate_diag``, ``terminal_factor``,
/// ``discretization``, ``torque_reference``, ``linearization``, ``prediction``, ``qp``).
///
/// Usable from any thread: calls on one ``Mpc`` run one after the other (its warm start is state).
#[pyclass(module = "brachia", frozen)]
pub struct Mpc {
    state: Shared<MpcState>,
}

/// The controller and the buffers of its calls.
pub(crate) struct MpcState {
    pub(crate) inner: brachia::control::Mpc,
    x: Vec<f64>,
    tau: Vec<f64>,
}

impl Mpc {
    /// The locked controller, to run in a closed loop.
    pub(crate) fn lock(&self, py: Python<'_>) -> PyResult<Guard<'_, MpcState>> {
        self.state.lock(py)
    }
}

#[pymethods]
impl Mpc {
    #[new]
    #[pyo3(signature = (robot, reference, settings = None, **kwargs))]
    fn new(
        robot: &Robot,
        reference: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let settings: MpcSettings = settings_from(settings, kwargs, "mpc settings")?;
        let reference = reference_of(reference)?;
        let n = robot.inner.n();
        let inner =
            brachia::control::Mpc::new(robot.inner.clone(), reference, settings).map_err(rs)?;
        let state = MpcState {
            inner,
            x: vec![0.0; 2 * n],
            tau: vec![0.0; n - 1],
        };
        Ok(Mpc {
            state: Shared::new("Mpc", state),
        })
    }

    /// Torques of joints 2..n (shape ``(n - 1,)``, N m) at time ``t`` (s) for the measured state
    /// ``x = [q, qd]`` (2n values, rad and rad/s).
    fn control<'py>(
        &self,
        py: Python<'py>,
        t: Real,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let t = scalar("t", t.0, None)?;
        let mut s = self.lock(py)?;
        let s = &mut *s;
        let n = s.x.len() / 2;
        let what = format!("[q, qd] of the {n}-link robot, rad and rad/s");
        read_vector(x, Arg::new("x", &what, Range::State), &mut s.x)?;
        s.inner.control(t, &s.x, &mut s.tau);
        arr1(py, finite_result(&s.tau, "Mpc.control")?)
    }

    /// Track a new reference (a ``Plan`` or a ``Trajectory`` of the same robot) with the same
    /// settings, without rebuilding the controller; a reference that does not fit the robot
    /// raises ``BrachiaError`` and the old one is kept.
    fn set_reference(&self, py: Python<'_>, reference: &Bound<'_, PyAny>) -> PyResult<()> {
        let reference = reference_of(reference)?;
        self.lock(py)?.inner.set_reference(reference).map_err(rs)
    }

    /// Forget the previous solution and the last applied torque (the next call starts cold).
    fn reset(&self, py: Python<'_>) -> PyResult<()> {
        self.lock(py)?.inner.reset();
        Ok(())
    }

    /// The settings in use (per-link defaults filled in) as a dict.
    #[getter]
    fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, self.lock(py)?.inner.settings())
    }

    /// Iterations of the last QP solve (``None`` before the first call).
    #[getter]
    fn last_qp_iterations(&self, py: Python<'_>) -> PyResult<Option<usize>> {
        Ok(self.lock(py)?.inner.last_qp_info().map(|i| i.iterations))
    }

    /// The reference being tracked.
    #[getter]
    fn reference(&self, py: Python<'_>) -> PyResult<Trajectory> {
        Ok(Trajectory {
            inner: self.lock(py)?.inner.reference().clone(),
        })
    }
}

/// Wall-clock time of ``steps`` MPC control calls made in Rust, s each, shape ``(steps,)``: a fresh
/// ``Mpc(robot, reference, settings)`` is called at ``t_k = k dt`` with the reference state at
/// ``t_k`` (the same sequence ``bench/mpc_step.py`` makes from Python), to compare the two in one
/// process.
#[pyfunction]
#[pyo3(signature = (robot, reference, steps, dt = Real(0.001), settings = None))]
pub(crate) fn rust_mpc_step_times<'py>(
    py: Python<'py>,
    robot: &Robot,
    reference: &Bound<'py, PyAny>,
    steps: Count,
    dt: Real,
    settings: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyAny>> {
    let steps = match usize::try_from(steps.0) {
        Ok(k) if (1..=1_000_000).contains(&k) => k,
        _ => return Err(bad(format!("steps = {}: must be in 1..=1000000", steps.0))),
    };
    let dt = scalar("dt", dt.0, Some(([1e-6, 0.1], "s")))?;
    let settings: MpcSettings = settings_from(settings, None, "mpc settings")?;
    let reference = reference_of(reference)?;
    let n = robot.inner.n();
    let mut m =
        brachia::control::Mpc::new(robot.inner.clone(), reference.clone(), settings).map_err(rs)?;
    let mut times = vec![0.0; steps];
    let mut x = vec![0.0; 2 * n];
    let mut tau = vec![0.0; n - 1];
    // Ctrl-C stops the calls between two of them and raises KeyboardInterrupt
    let cancel = brachia::CancelToken::new();
    crate::interrupt::interruptible(py, &cancel, || {
        for (k, out) in times.iter_mut().enumerate() {
            if cancel.is_cancelled() {
                break;
            }
            let t = k as f64 * dt;
            reference.state_at(t, &mut x);
            let start = Instant::now();
            m.control(t, &x, &mut tau);
            *out = start.elapsed().as_secs_f64();
        }
    })?;
    arr1(py, &times)
}
