//! `plan_joint_swings(...)`: several swings of a ladder planned as one optimal-control problem
//! (`brachia::planning::plan_joint_swings`), and the `JointSwingPlan` / `JointPhase` it returns.
//!
//! World frame for the bars and obstacles (m); each swing's `Plan` is in its own grip frame (the bar
//! it holds at the origin), on its own clock, for the chain that holds (hand A: the robot as written;
//! hand B: the chain re-rooted at the other end). `x0 = [q, qd]` (2n) of the chain as written holding
//! `bars[0]`; rad, rad/s, N m, J.

use crate::convert::{arr1, bad, check_slice, matrix, rs, vector, Arg, Range};
use crate::dicts::{to_json, to_py};
use crate::model::Robot;
use crate::planning::{plan_settings_from, plan_with_report, Plan};
use brachia::model::Circle;
use brachia::planning::{JointStatus, JointSwingTask, SwingTask, Transcription, MAX_JOINT_SWINGS};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;

/// One swing of a joint plan: its ``plan`` (a ``Plan`` in the grip frame of ``grip``, on its own
/// clock), which hand holds (``holding_hand``: 0 the chain as written, 1 re-rooted), the bar held
/// (``grip``, world, m), and its cost in the joint plan and in the swing-by-swing plan.
#[pyclass(module = "brachia", frozen)]
pub struct JointPhase {
    plan: Py<Plan>,
    holding_hand: usize,
    grip: [f64; 2],
    objective: f64,
    reference_objective: f64,
}

#[pymethods]
impl JointPhase {
    /// The swing as a ``Plan`` (grip frame, its own clock; status that of the joint solve).
    #[getter]
    fn plan(&self, py: Python<'_>) -> Py<Plan> {
        self.plan.clone_ref(py)
    }

    /// 0: the chain as written holds the bar; 1: the chain re-rooted at the other end.
    #[getter]
    fn holding_hand(&self) -> usize {
        self.holding_hand
    }

    /// The bar held, shape ``(2,)``, world, m.
    #[getter]
    fn grip<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.grip)
    }

    /// The swing's cost in the joint plan.
    #[getter]
    fn objective(&self) -> f64 {
        self.objective
    }

    /// The same cost of the swing-by-swing plan of this swing.
    #[getter]
    fn reference_objective(&self) -> f64 {
        self.reference_objective
    }
}

/// A joint plan over several swings and the swing-by-swing plans it is compared with (its warm start).
///
/// ``status`` is ``"converged"``, ``"joint_failed"`` (the joint solve did not converge: ``phases``
/// hold its last iterate) or ``"reference_failed"`` (a swing-by-swing plan failed, no joint solve
/// ran: ``phases`` is empty); ``message`` says more. ``report`` is the ``joint_swings.json`` of
/// ``brachia reproduce`` (docs/ladders.md).
#[pyclass(module = "brachia", frozen)]
pub struct JointSwingPlan {
    inner: brachia::planning::JointSwingPlan,
    phases: Vec<Py<JointPhase>>,
    reference: Vec<Py<Plan>>,
    report: serde_json::Value,
}

impl JointSwingPlan {
    /// `v` when a joint solve ran and `v` is finite, else `None` (never a NaN standing for "none").
    fn joint(&self, v: f64) -> Option<f64> {
        (self.inner.solve.is_some() && !self.inner.phases.is_empty() && v.is_finite()).then_some(v)
    }
}

#[pymethods]
impl JointSwingPlan {
    /// ``"converged"``, ``"joint_failed"``, ``"clearance_violated"`` or ``"reference_failed"``.
    #[getter]
    fn status(&self) -> &'static str {
        match self.inner.status {
            JointStatus::Converged => "converged",
            JointStatus::JointFailed { .. } => "joint_failed",
            JointStatus::ClearanceViolated { .. } => "clearance_violated",
            JointStatus::ReferenceFailed { .. } => "reference_failed",
        }
    }

    /// What happened, in words (the solver's status, or which swing-by-swing plan failed).
    #[getter]
    fn message(&self) -> String {
        self.inner.status.to_string()
    }

    /// True when the joint solve converged and every swing keeps the required clearance.
    #[getter]
    fn converged(&self) -> bool {
        self.inner.converged()
    }

    /// The joint objective (sum of the swings' costs; ``None`` when no joint solve ran).
    #[getter]
    fn objective(&self) -> Option<f64> {
        self.joint(self.inner.objective)
    }

    /// The same sum over the swing-by-swing plans (``None`` when no joint solve ran).
    #[getter]
    fn reference_objective(&self) -> Option<f64> {
        self.joint(self.inner.reference_objective)
    }

    /// Paper eq. 18 summed over the joint plan's swings, J (``None`` when no joint solve ran).
    #[getter]
    fn energy(&self) -> Option<f64> {
        self.joint(self.inner.energy_j())
    }

    /// Paper eq. 18 summed over the swing-by-swing plans that were made, J.
    #[getter]
    fn reference_energy(&self) -> f64 {
        self.inner.reference_energy_j()
    }

    /// Largest defect of the joint plan's transitions (shooting, capture, grip switch), rad or
    /// rad/s (``None`` when no joint solve ran).
    #[getter]
    fn max_defect(&self) -> Option<f64> {
        self.joint(self.inner.max_defect)
    }

    /// The largest capture residuals over the switches and the last bar: ``(distance m, speed
    /// m/s)`` (``None`` when no joint solve ran).
    #[getter]
    fn capture_residual(&self) -> Option<(f64, f64)> {
        let (d, v) = self.inner.capture_residual();
        Some((self.joint(d)?, self.joint(v)?))
    }

    /// Iterations of the joint solve (``None`` when none ran).
    #[getter]
    fn iterations(&self) -> Option<usize> {
        self.inner.solve.as_ref().map(|s| s.iterations)
    }

    /// The swings of the joint plan (empty when no joint solve ran).
    #[getter]
    fn phases(&self, py: Python<'_>) -> Vec<Py<JointPhase>> {
        self.phases.iter().map(|p| p.clone_ref(py)).collect()
    }

    /// The swing-by-swing plans (all of them unless one failed).
    #[getter]
    fn reference(&self, py: Python<'_>) -> Vec<Py<Plan>> {
        self.reference.iter().map(|p| p.clone_ref(py)).collect()
    }

    /// The ``joint_swings.json`` report as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    fn __repr__(&self) -> String {
        format!(
            "JointSwingPlan(status={:?}, swings={}, objective={:.6}, reference_objective={:.6})",
            self.status(),
            self.inner.reference.len().max(self.inner.phases.len()),
            self.inner.objective,
            self.inner.reference_objective
        )
    }
}

/// Plan the swings of a ladder jointly: from ``x0`` (shape ``(2n,)``, the chain as written holding
/// ``bars[0]``) through ``bars[1:]`` (shape ``(swings + 1, 2)``, world, m; 1 to 16 swings), switching
/// the grip at every bar, as one optimal-control problem on the Riccati backend, warm-started at the
/// swing-by-swing plans (which it returns too, as ``reference``).
///
/// ``obstacles``: ``[{"center": (2,), "radius": r}, ...]`` in the world frame. ``rest_at_switches``:
/// keep the rest condition ``bounds.qd_end_max`` at the inner switches too (else only at the last
/// bar). ``settings`` and keyword arguments as for ``brachia.plan`` (multiple shooting whatever
/// ``transcription`` says; ``solver.backend`` must be ``"ocp"``).
///
/// Returns a ``JointSwingPlan`` (also when a solve did not converge: see ``status``). Raises
/// ``BrachiaError`` on bad input (nothing is planned).
#[pyfunction]
#[pyo3(signature = (robot, x0, bars, obstacles = None, rest_at_switches = false, settings = None, **kwargs))]
pub(crate) fn plan_joint_swings(
    py: Python<'_>,
    robot: &Robot,
    x0: &Bound<'_, PyAny>,
    bars: &Bound<'_, PyAny>,
    obstacles: Option<&Bound<'_, PyAny>>,
    rest_at_switches: bool,
    settings: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<JointSwingPlan> {
    let n = robot.inner.n();
    let what = "the start state [q, qd], rad and rad/s";
    let x0 = vector(x0, Arg::new("x0", what, Range::State), 2 * n)?;
    let what = "the grip, then one bar per swing, world frame, m";
    let (flat, rows, _) = matrix(bars, Arg::new("bars", what, Range::Position), None, Some(2))?;
    if !(2..=MAX_JOINT_SWINGS + 1).contains(&rows) {
        return Err(bad(format!(
            "bars: {rows} rows: must be 2 to {} (the grip, then one bar per swing)",
            MAX_JOINT_SWINGS + 1
        )));
    }
    let bars: Vec<[f64; 2]> = flat.chunks_exact(2).map(|b| [b[0], b[1]]).collect();
    let obstacles: Vec<Circle> = match obstacles.filter(|o| !o.is_none()) {
        None => Vec::new(),
        Some(o) => serde_json::from_str(&to_json(o, "obstacles")?)
            .map_err(|e| bad(format!("obstacles: {e}")))?,
    };
    for (i, o) in obstacles.iter().enumerate() {
        let shape = [o.center[0], o.center[1], o.radius];
        check_slice(
            &shape,
            &format!("obstacles[{i}] (center, radius)"),
            Range::Position,
        )?;
    }
    let (mut planner, mut nlp) = plan_settings_from(settings, kwargs)?;
    // what the joint plan runs, whatever the settings say, so that the swings' reports name it
    planner.transcription = Transcription::MultipleShooting;
    let task = JointSwingTask {
        x0,
        bars: bars.clone(),
        obstacles: obstacles.clone(),
        rest_at_switches,
    };
    let r = robot.inner.clone();
    let cancel = brachia::CancelToken::new();
    nlp.cancel = Some(cancel.clone());
    let j = crate::interrupt::interruptible(py, &cancel, || {
        brachia::planning::plan_joint_swings(&r, &task, &planner, &nlp)
    })?
    .map_err(rs)?;
    nlp.cancel = None;
    let chains = [r.clone(), Arc::new(r.rerooted().map_err(rs)?)];
    // a Plan per swing, with the report `brachia plan` would write for its swing task
    let wrap = |i: usize, p: &brachia::planning::Plan| -> PyResult<Py<Plan>> {
        let task = SwingTask::on_ladder(
            p.points.q(0),
            p.points.qd(0),
            bars[i],
            bars[i + 1],
            &obstacles,
        );
        let plan = plan_with_report(
            chains[brachia::ladder::holding_hand(i)].clone(),
            task,
            planner.clone(),
            nlp.clone(),
            p.clone(),
        );
        Py::new(py, plan)
    };
    let reference = j
        .reference
        .iter()
        .enumerate()
        .map(|(i, p)| wrap(i, p))
        .collect::<PyResult<Vec<_>>>()?;
    let phases = j
        .phases
        .iter()
        .enumerate()
        .map(|(i, ph)| {
            Py::new(
                py,
                JointPhase {
                    plan: wrap(i, &ph.plan)?,
                    holding_hand: ph.holding_hand,
                    grip: ph.grip,
                    objective: ph.objective,
                    reference_objective: ph.reference_objective,
                },
            )
        })
        .collect::<PyResult<Vec<_>>>()?;
    let report = brachia::ladder::joint_swings_json(&j);
    Ok(JointSwingPlan {
        inner: j,
        phases,
        reference,
        report,
    })
}
