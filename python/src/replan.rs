//! `SwingPlanner`, the persistent planner (`brachia::planning::SwingPlanner`): the problem and the
//! solver's workspace built once, a cold plan, then warm re-plans from measured states; and the
//! `ReplanOutcome` a re-plan returns.
//!
//! Units and conventions as everywhere in brachia: s, m, rad, rad/s, N m; `x = [q (n), qd (n)]`,
//! `q[0]` absolute from +x, the rest relative; torques of joints 2..n. Knot times are absolute (0 at
//! the start of the swing); a `Plan` of a re-plan runs on its own clock, 0 at `t_now`.

use crate::convert::{arr1, arr2, bad, read_vector, rs, Arg, Range, Real};
use crate::interrupt::interruptible;
use crate::model::Robot;
use crate::planning::{plan_settings_from, plan_with_report, task_from, Plan};
use crate::shared::{Guard, Shared};
use brachia::planning::{
    validate_task, Backend, NlpSettings, PlannerSettings, SwingTask, Transcription,
};
use brachia::CancelToken;
use brachia_experiments::parameter_study::status_name;
use pyo3::prelude::*;
use pyo3::types::PyDict;

/// How one plan or re-plan of a ``SwingPlanner`` ended: the solver's status and diagnostics.
///
/// ``t_start`` is the absolute time of the solution's first knot (``t_now``; 0 for a full plan),
/// ``interval_s`` the time between knots, ``ee_final`` the end-effector position at the last knot (m)
/// and ``ee_error_m`` its distance from the target.
#[pyclass(module = "brachia", frozen)]
pub struct ReplanOutcome {
    inner: brachia::planning::ReplanOutcome,
}

#[pymethods]
impl ReplanOutcome {
    /// Solver status in snake case (``"solved"``, ``"max_iterations"``, ...), as ``Plan.status``.
    #[getter]
    fn status(&self) -> String {
        status_name(&self.inner.status)
    }

    /// True when the solver converged (``solved`` or ``solved_to_acceptable_level``).
    #[getter]
    fn converged(&self) -> bool {
        self.inner.converged()
    }

    /// Interior-point iterations of this solve.
    #[getter]
    fn iterations(&self) -> usize {
        self.inner.iterations
    }

    /// Wall time of the solve, s.
    #[getter]
    fn solve_time_s(&self) -> f64 {
        self.inner.solve_time_s
    }

    /// Objective at the solution.
    #[getter]
    fn objective(&self) -> f64 {
        self.inner.objective
    }

    /// Absolute time of the first knot, s.
    #[getter]
    fn t_start(&self) -> f64 {
        self.inner.t_start
    }

    /// Time between knots, s.
    #[getter]
    fn interval_s(&self) -> f64 {
        self.inner.interval_s
    }

    /// End-effector position at the last knot, shape ``(2,)``, m.
    #[getter]
    fn ee_final<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.inner.ee_final)
    }

    /// Distance of ``ee_final`` from the target, m.
    #[getter]
    fn ee_error_m(&self) -> f64 {
        self.inner.ee_error_m
    }

    fn __repr__(&self) -> String {
        format!(
            "ReplanOutcome(status={:?}, iterations={}, objective={:.6}, t_start={:.6}, ee_error_m={:.3e})",
            self.status(),
            self.inner.iterations,
            self.inner.objective,
            self.inner.t_start,
            self.inner.ee_error_m
        )
    }
}

/// The persistent planner: build the multiple-shooting problem of ``task`` once, plan the swing
/// cold, then re-plan warm from measured states (``replan``) in a few milliseconds, without
/// allocating in the library.
///
/// ``task`` and ``settings`` / keyword arguments as for ``brachia.plan`` (the transcription is
/// always multiple shooting: knots ``knot_dt`` apart, ``shooting.substeps`` RK4 steps each; the
/// solver is the Riccati interior-point method). Raises ``BrachiaError`` on bad input.
///
/// The number of intervals K is fixed for the planner's life: a re-plan from ``t_now`` spreads the
/// K intervals over the remaining ``T - t_now``.
///
/// Usable from any thread: calls on one planner run one after the other (a ``replan`` made while
/// another thread's ``replan`` runs waits for it), with the GIL released while solving.
#[pyclass(module = "brachia", frozen)]
pub struct SwingPlanner {
    state: Shared<PlannerState>,
}

/// The planner and what the binding keeps beside it.
struct PlannerState {
    inner: brachia::planning::SwingPlanner,
    planner: PlannerSettings,
    nlp: NlpSettings,
    /// The start state of the current solution (the task's, or the last re-plan's `x_now`).
    x_start: Vec<f64>,
    /// The `x_now` of the re-plan being read (kept apart so that a refused one leaves `x_start`).
    x_in: Vec<f64>,
}

/// A copy of a ``SwingPlanner``'s solution (``SwingPlanner.checkpoint()``), opaque; give it back to
/// the same planner's ``restore``.
#[pyclass(module = "brachia", frozen)]
pub struct Checkpoint {
    inner: brachia::planning::Checkpoint,
    /// Links of the planner's robot.
    n_links: usize,
}

#[pymethods]
impl Checkpoint {
    fn __repr__(&self) -> String {
        format!("Checkpoint(n_links={})", self.n_links)
    }
}

/// The start state `[q0, qd0]` of `task` into `out` (2n; an empty `qd0` is rest).
fn task_start(task: &SwingTask, out: &mut [f64]) {
    let n = task.q0.len();
    out[..n].copy_from_slice(&task.q0);
    out[n..].fill(0.0);
    if !task.qd0.is_empty() {
        out[n..].copy_from_slice(&task.qd0);
    }
}

impl PlannerState {
    /// The task of the current solution: the planner's, started from `x_start`.
    fn current_task(&self) -> SwingTask {
        let n = self.inner.robot().n();
        SwingTask {
            q0: self.x_start[..n].to_vec(),
            qd0: self.x_start[n..].to_vec(),
            ..self.inner.task().clone()
        }
    }

    /// Re-plan from `x_now` (2n finite values, read without allocating for a float64 array) at
    /// `t_now`, warm or cold; on success the solution starts at `x_now`.
    fn replan_from(
        &mut self,
        py: Python<'_>,
        t_now: f64,
        x_now: &Bound<'_, PyAny>,
        warm: bool,
    ) -> PyResult<ReplanOutcome> {
        let what = "the state [q, qd], rad and rad/s";
        read_vector(x_now, Arg::new("x_now", what, Range::State), &mut self.x_in)?;
        let x = self.x_in.clone();
        let out = self
            .interruptible(py, |inner| {
                if warm {
                    inner.replan(t_now, &x)
                } else {
                    inner.replan_cold(t_now, &x)
                }
            })?
            .map_err(rs)?;
        self.x_start.copy_from_slice(&self.x_in);
        Ok(ReplanOutcome { inner: out })
    }

    /// Run `work` on the planner with a fresh cancel token in its cold and warm solver settings,
    /// the calling thread waiting for Python signals (`crate::interrupt`): Ctrl-C stops the solve at
    /// its next iteration and raises `KeyboardInterrupt`. The token is removed afterwards.
    fn interruptible<T: Send>(
        &mut self,
        py: Python<'_>,
        work: impl FnOnce(&mut brachia::planning::SwingPlanner) -> T + Send,
    ) -> PyResult<T> {
        let cancel = CancelToken::new();
        self.inner.cold_settings_mut().cancel = Some(cancel.clone());
        self.inner.warm_settings_mut().cancel = Some(cancel.clone());
        let inner = &mut self.inner;
        let out = interruptible(py, &cancel, || work(inner));
        self.inner.cold_settings_mut().cancel = None;
        self.inner.warm_settings_mut().cancel = None;
        out
    }

    /// The current solution as a `Plan`.
    fn current_plan(&mut self, py: Python<'_>) -> PyResult<Plan> {
        let inner = &mut self.inner;
        let p = py.detach(|| inner.current_plan()).map_err(rs)?;
        Ok(plan_with_report(
            self.inner.robot().clone(),
            self.current_task(),
            self.planner.clone(),
            self.nlp.clone(),
            p,
        ))
    }
}

impl SwingPlanner {
    /// The locked planner.
    fn lock(&self, py: Python<'_>) -> PyResult<Guard<'_, PlannerState>> {
        self.state.lock(py)
    }
}

#[pymethods]
impl SwingPlanner {
    #[new]
    #[pyo3(signature = (robot, task, settings = None, **kwargs))]
    fn new(
        robot: &Robot,
        task: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let task = task_from(task)?;
        let (mut planner, mut nlp) = plan_settings_from(settings, kwargs)?;
        // what the planner runs, whatever the settings say, so that the reports name it
        planner.transcription = Transcription::MultipleShooting;
        nlp.backend = Backend::Ocp;
        let inner = brachia::planning::SwingPlanner::new(robot.inner.clone(), task, &planner, &nlp)
            .map_err(rs)?;
        let mut x_start = vec![0.0; 2 * robot.inner.n()];
        task_start(inner.task(), &mut x_start);
        let state = PlannerState {
            inner,
            planner,
            nlp,
            x_in: x_start.clone(),
            x_start,
        };
        Ok(SwingPlanner {
            state: Shared::new("SwingPlanner", state),
        })
    }

    /// Plan the whole swing cold from the task's start state; the solution becomes the one re-plans
    /// start from. Returns the ``Plan`` (with its report), converged or not.
    fn plan(&self, py: Python<'_>) -> PyResult<Plan> {
        let mut s = self.lock(py)?;
        let s = &mut *s;
        s.interruptible(py, |inner| inner.plan_outcome())?
            .map_err(rs)?;
        task_start(s.inner.task(), &mut s.x_start);
        s.current_plan(py)
    }

    /// Warm re-plan from the measured state ``x_now`` (shape ``(2n,)``: ``[q, qd]``) at the absolute
    /// time ``t_now`` (s, in ``[0, T)``) to the target over the remaining time. Needs a converged
    /// plan first. Returns a ``ReplanOutcome``; the trajectory is ``current_plan()``.
    fn replan(
        &self,
        py: Python<'_>,
        t_now: Real,
        x_now: &Bound<'_, PyAny>,
    ) -> PyResult<ReplanOutcome> {
        self.lock(py)?.replan_from(py, t_now.0, x_now, true)
    }

    /// The same re-plan started cold (the shifted solution as the initial guess, multipliers reset),
    /// for comparison with ``replan``.
    fn replan_cold(
        &self,
        py: Python<'_>,
        t_now: Real,
        x_now: &Bound<'_, PyAny>,
    ) -> PyResult<ReplanOutcome> {
        self.lock(py)?.replan_from(py, t_now.0, x_now, false)
    }

    /// The current solution as a ``Plan`` (1 ms trajectory from 0 at its first knot, report
    /// included). Raises ``BrachiaError`` before any solve.
    fn current_plan(&self, py: Python<'_>) -> PyResult<Plan> {
        self.lock(py)?.current_plan(py)
    }

    /// True once a solve converged (a re-plan has a solution to start from).
    #[getter]
    fn has_plan(&self, py: Python<'_>) -> PyResult<bool> {
        Ok(self.lock(py)?.inner.has_plan())
    }

    /// The full swing time T, s.
    #[getter]
    fn swing_time(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.inner.swing_time())
    }

    /// Number of intervals K (fixed for the planner's life).
    #[getter]
    fn intervals(&self, py: Python<'_>) -> PyResult<usize> {
        Ok(self.lock(py)?.inner.intervals())
    }

    /// The target bar position, shape ``(2,)``, m.
    #[getter]
    fn target<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.lock(py)?.inner.target())
    }

    /// Move the target bar (shape ``(2,)``, m) for the next plan or re-plan. Checked as the
    /// constructor checks the task's ``target`` (within reach of the grip, outside the obstacles);
    /// a refused target leaves the planner as it was.
    fn set_target(&self, py: Python<'_>, target: &Bound<'_, PyAny>) -> PyResult<()> {
        let mut t = [0.0; 2];
        let arg = Arg::new("target", "the bar position, m", Range::Position);
        read_vector(target, arg, &mut t)?;
        let mut s = self.lock(py)?;
        let task = SwingTask {
            target: t,
            ..s.inner.task().clone()
        };
        validate_task(s.inner.robot(), &task, &s.planner, "set_target", "").map_err(rs)?;
        s.inner.set_target(t).map_err(rs)
    }

    /// Absolute times of the current solution's K + 1 knots, shape ``(K + 1,)``, s.
    fn knot_times<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = self.lock(py)?;
        let t: Vec<f64> = (0..=s.inner.intervals())
            .map(|k| s.inner.knot_time(k))
            .collect();
        arr1(py, &t)
    }

    /// States of the current solution's knots, shape ``(K + 1, 2n)``: ``[q, qd]``, rad and rad/s.
    fn knot_states<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = self.lock(py)?;
        let z = s.inner.knots();
        let cols = 2 * s.inner.robot().n();
        arr2(py, z.x.concat(), cols)
    }

    /// Torques of the current solution's K intervals (held over each), shape ``(K, n - 1)``, N m.
    fn knot_torques<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let s = self.lock(py)?;
        let z = s.inner.knots();
        let cols = s.inner.robot().n() - 1;
        let k = s.inner.intervals();
        let v: Vec<f64> = z.u[..k].concat();
        if v.len() != k * cols {
            return Err(bad(format!(
                "knot_torques: {} values for {k} intervals of {cols} torques",
                v.len()
            )));
        }
        arr2(py, v, cols)
    }

    /// A copy of the solution re-plans start from, to come back to with ``restore`` (e.g. to
    /// re-plan many disturbed states from one plan). Taken right after a converged solve, it also
    /// holds the solver's multipliers, so that a restore puts the planner back exactly.
    fn checkpoint(&self, py: Python<'_>) -> PyResult<Checkpoint> {
        let s = self.lock(py)?;
        Ok(Checkpoint {
            inner: s.inner.checkpoint(),
            n_links: s.inner.robot().n(),
        })
    }

    /// Make a ``checkpoint()`` of this planner current again (its solution, problem and, where it
    /// holds them, the solver's multipliers): what follows is the same, bit for bit, whatever was
    /// solved in between, if the target is still the checkpoint's (otherwise its solution is
    /// re-solved for the current target). Returns the outcome of the checkpoint's solve, or of that
    /// re-solve. Raises ``BrachiaError`` for a checkpoint of another planner (nothing changes).
    fn restore(&self, py: Python<'_>, checkpoint: &Checkpoint) -> PyResult<ReplanOutcome> {
        let mut s = self.lock(py)?;
        let s = &mut *s;
        let out = s
            .interruptible(py, |inner| inner.restore(&checkpoint.inner))?
            .map_err(rs)?;
        // the restored solution starts where the checkpoint's does (not necessarily at the last
        // x_now handed in: that re-plan may not have converged)
        s.x_start.copy_from_slice(&s.inner.knots().x[0]);
        Ok(ReplanOutcome { inner: out })
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        let s = self.lock(py)?;
        Ok(format!(
            "SwingPlanner(n_links={}, intervals={}, swing_time={:.6}, has_plan={})",
            s.inner.robot().n(),
            s.inner.intervals(),
            s.inner.swing_time(),
            s.inner.has_plan()
        ))
    }
}
