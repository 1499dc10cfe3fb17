//! `plan(robot, task, settings)` and the `Plan` it returns.
//!
//! A task is a dict `{q0 (n,), qd0 (n,) optional, target (2,), obstacles [{center (2,), radius}]}` (rad,
//! rad/s, m), the schema of a scenario's `[task]`. Settings are a dict and/or keyword arguments with the
//! fields of `brachia::planning::PlannerSettings` (a scenario's `[planner]`) plus an optional `solver`
//! dict with the fields of `brachia::planning::NlpSettings` (`[solver]`); a field left out keeps the
//! Rust default. The plan's arrays are the 1 ms output trajectory (`t`, `q`, `qd`, `tau`, `ee`).

use crate::convert::{arr1, arr2, bad, check_slice, exp, rs, Range};
use crate::dicts::{from_value, merged, to_py};
use crate::interrupt::interruptible_owned;
use crate::model::{Robot, Trajectory};
use brachia::planning::{NlpSettings, PlannerSettings, SwingTask};
use brachia_experiments::scenario::LoadedScenario;
use brachia_experiments::{RunFolder, Scenario};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A planned swing (converged or not: check ``converged`` and ``status``).
///
/// Arrays are the 1 ms output trajectory from 0 to exactly the swing time T: ``t`` (samples,) s,
/// ``q`` and ``qd`` (samples, n) rad and rad/s, ``tau`` (samples, n - 1) N m, ``ee`` (samples, 2) m.
/// ``report`` is the dict ``brachia plan`` writes as ``report.json``.
#[pyclass(module = "brachia", frozen)]
pub struct Plan {
    pub(crate) plan: brachia::planning::Plan,
    pub(crate) robot: Arc<brachia::Robot>,
    pub(crate) trajectory: Arc<brachia::trajectory::Trajectory>,
    pub(crate) report: serde_json::Value,
    pub(crate) folder: Option<RunFolder>,
    /// The task it was planned for (its start, target and obstacles).
    pub(crate) task: SwingTask,
}

impl Plan {
    /// Wrap a library plan of `task` with its report (and the run folder, for a scenario's plan).
    pub(crate) fn new(
        robot: Arc<brachia::Robot>,
        task: SwingTask,
        plan: brachia::planning::Plan,
        report: serde_json::Value,
        folder: Option<RunFolder>,
    ) -> Self {
        Plan {
            trajectory: Arc::new(plan.trajectory.clone()),
            plan,
            robot,
            report,
            folder,
            task,
        }
    }
}

#[pymethods]
impl Plan {
    /// Solver status in snake case: ``"solved"``, ``"solved_to_acceptable_level"``,
    /// ``"max_iterations"``, ``"restoration_failed"``, ... (see ``brachia::planning::SolveStatus``).
    #[getter]
    fn status(&self) -> String {
        brachia_experiments::parameter_study::status_name(&self.plan.status)
    }

    /// True when the solver converged (``solved`` or ``solved_to_acceptable_level``) and the
    /// resampled trajectory keeps the required clearance (see ``failure_message``).
    #[getter]
    fn converged(&self) -> bool {
        self.plan.converged()
    }

    /// Why the plan is not usable (``None`` when it converged).
    #[getter]
    fn failure_message(&self) -> Option<String> {
        self.plan.failure_message()
    }

    /// When an obstacle plan failed: the obstacle and the link it blocks, the verdict and how much
    /// more torque or swing time the best detour found would need, as a dict (the ``diagnosis`` of
    /// ``report.json``, see docs/planner.md); ``None`` otherwise.
    #[getter]
    fn diagnosis<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        self.plan
            .diagnosis
            .as_ref()
            .map(|d| to_py(py, d))
            .transpose()
    }

    /// Objective value (the transcription's quadrature of ``|qd|^2_Q1 + |tau|^2_R1``).
    #[getter]
    fn objective(&self) -> f64 {
        self.plan.objective
    }

    /// Interior-point iterations over every attempt and pass.
    #[getter]
    fn iterations(&self) -> usize {
        self.plan.iterations
    }

    /// Solver attempts (1, or 2 after a retry with the adaptive barrier).
    #[getter]
    fn attempts(&self) -> usize {
        self.plan.attempts
    }

    /// Wall-clock time of every attempt together, s.
    #[getter]
    fn solve_time_s(&self) -> f64 {
        self.plan.solve_time_s
    }

    /// Swing time T, s.
    #[getter]
    fn swing_time(&self) -> f64 {
        self.plan.swing_time_s
    }

    /// Signed work of the actuated joints over the 1 ms trajectory (paper eq. 18), J.
    #[getter]
    fn energy(&self) -> f64 {
        self.plan.energy_j
    }

    /// Times of the 1 ms trajectory, s, shape ``(samples,)``.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.trajectory.t)
    }

    /// Joint angles, rad, shape ``(samples, n)``.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.trajectory.q.clone(), self.robot.n())
    }

    /// Joint velocities, rad/s, shape ``(samples, n)``.
    #[getter]
    fn qd<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.trajectory.qd.clone(), self.robot.n())
    }

    /// Torques of joints 2..n, N m, shape ``(samples, n - 1)``.
    #[getter]
    fn tau<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.trajectory.tau.clone(), self.robot.nu())
    }

    /// End-effector positions, m, shape ``(samples, 2)``.
    #[getter]
    fn ee<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let tr = &self.trajectory;
        let v: Vec<f64> = (0..tr.len())
            .flat_map(|k| self.robot.ee_position(tr.q(k)))
            .collect();
        arr2(py, v, 2)
    }

    /// The 1 ms trajectory as a ``Trajectory`` (what ``Mpc`` and ``track`` take).
    #[getter]
    fn trajectory(&self) -> Trajectory {
        Trajectory {
            inner: self.trajectory.clone(),
        }
    }

    /// The collocation points (knots, and midpoints for Hermite-Simpson) as a ``Trajectory``.
    #[getter]
    fn knots(&self) -> Trajectory {
        Trajectory {
            inner: Arc::new(self.plan.points.clone()),
        }
    }

    /// The machine-readable report (the ``report.json`` of ``brachia plan``) as a dict.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// Write the run folder ``brachia plan`` writes (knots.csv, trajectory.csv, scenario.toml,
    /// report.json) into ``out`` (staged, then renamed into place). Only for a scenario's plan.
    /// ``force`` writes into a non-empty folder that is not a brachia run folder.
    #[pyo3(signature = (out, force = false))]
    fn write(&self, py: Python<'_>, out: PathBuf, force: bool) -> PyResult<()> {
        let Some(folder) = &self.folder else {
            return Err(bad(
                "write: only a scenario's plan (Scenario.plan()) has a run folder to write",
            ));
        };
        brachia_experiments::check_out_dir(&out, force).map_err(exp)?;
        py.detach(|| folder.write(&out)).map_err(exp)
    }

    /// The run page of this plan (docs/viewer.md) as HTML text; ``None`` when the plan has no
    /// trajectory to draw.
    fn _view_html(&self) -> Option<String> {
        crate::view::plan_page(&self.report, &self.task, &self.robot, &self.trajectory)
    }

    /// The run page inline in Jupyter (a frame of the notebook's width).
    fn _repr_html_(&self) -> Option<String> {
        self._view_html().map(|h| crate::view::frame(&h))
    }

    fn __repr__(&self) -> String {
        format!(
            "Plan(status={:?}, objective={:.6}, iterations={}, swing_time={:.6}, samples={})",
            self.status(),
            self.plan.objective,
            self.plan.iterations,
            self.plan.swing_time_s,
            self.trajectory.len()
        )
    }
}

/// The task dict as a `SwingTask`.
///
/// Its values obey the binding's rules for their quantities before the planner checks the task
/// against the robot and the settings: `q0` angles, `qd0` velocities, `target` and the obstacles'
/// centres and radii positions (within 1000 m).
pub(crate) fn task_from(task: &Bound<'_, PyAny>) -> PyResult<SwingTask> {
    let v = merged(Some(task), None, "task")?;
    let task: SwingTask = from_value(v, "task")?;
    check_slice(&task.q0, "task.q0", Range::Angle)?;
    check_slice(&task.qd0, "task.qd0", Range::Rate)?;
    check_slice(&task.target, "task.target", Range::Position)?;
    for (i, o) in task.obstacles.iter().enumerate() {
        let shape = [o.center[0], o.center[1], o.radius];
        check_slice(
            &shape,
            &format!("task.obstacles[{i}] (center, radius)"),
            Range::Position,
        )?;
    }
    Ok(task)
}

/// Planner and solver settings from a dict and keyword arguments (`solver` = the NLP settings).
pub(crate) fn plan_settings_from(
    settings: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<(PlannerSettings, NlpSettings)> {
    let mut v = merged(settings, kwargs, "settings")?;
    let solver = v
        .as_object_mut()
        .and_then(|m| m.remove("solver"))
        .unwrap_or_else(|| serde_json::json!({}));
    let planner: PlannerSettings = from_value(v, "settings")?;
    let nlp: NlpSettings = from_value(solver, "settings.solver")?;
    Ok((planner, nlp))
}

/// Plan an energy-optimal swing of ``robot`` for ``task``.
///
/// ``task``: dict ``{"q0": (n,), "qd0": (n,) (optional, default at rest), "target": (2,),
/// "obstacles": [{"center": (2,), "radius": r}, ...] (optional)}`` in rad, rad/s, m.
/// ``settings`` (dict) and keyword arguments: the fields of a scenario's ``[planner]`` section
/// (``swing_time`` = ``"auto"`` or seconds, ``free_swing_time`` = ``[min, max]`` to optimise T in that
/// range, ``knot_dt``, ``transcription``, ``q1_diag``, ``r1_diag``,
/// ``bounds``, ``obstacle_margin``, ...) and ``solver`` = a dict of ``[solver]`` fields (``backend``,
/// ``max_iter``, ``tol``, ...); fields left out keep the Rust defaults.
///
/// Returns a ``Plan`` (also when the solver did not converge: see ``Plan.status``). Raises
/// ``BrachiaError`` on bad input (nothing is solved).
#[pyfunction]
#[pyo3(signature = (robot, task, settings = None, **kwargs))]
pub(crate) fn plan(
    py: Python<'_>,
    robot: &Robot,
    task: &Bound<'_, PyAny>,
    settings: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
) -> PyResult<Plan> {
    let task = task_from(task)?;
    let (planner, mut nlp) = plan_settings_from(settings, kwargs)?;
    let r = robot.inner.clone();
    // Ctrl-C stops the solve at its next iteration and raises KeyboardInterrupt
    let cancel = brachia::CancelToken::new();
    nlp.cancel = Some(cancel.clone());
    let p = {
        let (r, task, planner, nlp) = (r.clone(), task.clone(), planner.clone(), nlp.clone());
        interruptible_owned(py, &cancel, move || {
            brachia::planning::plan(&r, &task, &planner, &nlp)
        })?
        .map_err(rs)?
    };
    nlp.cancel = None;
    Ok(plan_with_report(r, task, planner, nlp, p))
}

/// A library plan of `task` wrapped with the report `brachia plan` would write for it (the scenario
/// named "python", its robot and settings those of the call).
pub(crate) fn plan_with_report(
    robot: Arc<brachia::Robot>,
    task: SwingTask,
    planner: PlannerSettings,
    nlp: NlpSettings,
    p: brachia::planning::Plan,
) -> Plan {
    let ls = LoadedScenario {
        scenario: Scenario {
            name: "python".into(),
            params: PathBuf::from("<python>"),
            urdf: None,
            task,
            planner,
            solver: nlp,
            tracking: Default::default(),
            plant: Default::default(),
            disturbances: Default::default(),
        },
        robot: (*robot).clone(),
        path: Path::new("<python>").to_path_buf(),
    };
    let report = brachia_experiments::plan_report(&ls, &p);
    let task = ls.scenario.task;
    Plan::new(robot, task, p, report, None)
}
