//! Plants (`ModelPlant`, `RapierPlant`), the closed loop `track(...)` and its `TrackResult`.
//!
//! Conventions: a plant's state is `x = [q, qd]` (2n; rad, rad/s; q1 absolute, the rest relative);
//! `step(tau, dt)` holds the torques of joints 2..n (n - 1 values, N m, clamped to the robot's limits)
//! for `dt` seconds. Logs are row-major arrays with one row per control instant (`steps + 1` rows; the
//! last row is the final state).

use crate::control::{reference_of, Mpc};
use crate::convert::{arr1, arr2, bad, exp, read_vector, rs, settings_from, to_py};
use crate::model::Robot;
use crate::planning::Plan;
use brachia::control::{OpenLoop, Pd, PdSettings};
use brachia::sim::{
    run_closed_loop, ClosedLoopLog, Controller, NoiseSettings, Noisy, Plant, RunSettings,
    RunSummary,
};
use brachia_experiments::RunFolder;
use brachia_rapier::{ContactBody, Obstacle, RapierSettings};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::path::PathBuf;
use std::sync::Arc;

/// Largest `dt` of one plant step, s.
const MAX_STEP_DT: f64 = 1.0;

/// `x0` (or the robot at rest hanging straight down when `None`) as a checked state.
fn start_state(robot: &brachia::Robot, x0: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<f64>> {
    let n = robot.n();
    match x0 {
        Some(x) => {
            let mut v = vec![0.0; 2 * n];
            read_vector(x, "x", &format!("[q, qd] of the {n}-link robot"), &mut v)?;
            Ok(v)
        }
        None => {
            let mut v = vec![0.0; 2 * n];
            v[0] = -std::f64::consts::FRAC_PI_2;
            Ok(v)
        }
    }
}

/// Check `tau` and `dt` of a plant step; `tau` is read into `buf`.
fn step_input(tau: &Bound<'_, PyAny>, dt: f64, buf: &mut [f64]) -> PyResult<()> {
    if !(dt.is_finite() && dt > 0.0 && dt <= MAX_STEP_DT) {
        return Err(bad(format!("dt = {dt}: must be in (0, {MAX_STEP_DT}] s")));
    }
    read_vector(tau, "tau", "torques of joints 2..n, N m", buf)
}

/// Check a substep count.
fn check_substeps(substeps: usize) -> PyResult<()> {
    let kmax = brachia::limits::MAX_SUBSTEPS;
    if substeps == 0 || substeps > kmax {
        return Err(bad(format!("substeps = {substeps}: must be 1..={kmax}")));
    }
    Ok(())
}

/// The model plant: the robot's own dynamics integrated by RK4 (``substeps`` steps per ``step``).
///
/// ``ModelPlant(robot, x0=None, substeps=1)``; ``x0 = [q, qd]`` (default: hanging straight down at
/// rest). Torques are clamped to the robot's limits.
#[pyclass(module = "brachia")]
pub struct ModelPlant {
    robot: Arc<brachia::Robot>,
    pub(crate) plant: brachia::sim::ModelPlant,
    tau: Vec<f64>,
}

#[pymethods]
impl ModelPlant {
    #[new]
    #[pyo3(signature = (robot, x0 = None, substeps = 1))]
    fn new(robot: &Robot, x0: Option<&Bound<'_, PyAny>>, substeps: usize) -> PyResult<Self> {
        check_substeps(substeps)?;
        let x = start_state(&robot.inner, x0)?;
        let mut plant = brachia::sim::ModelPlant::new((*robot.inner).clone(), &x);
        plant.substeps = substeps;
        Ok(ModelPlant {
            tau: vec![0.0; robot.inner.nu()],
            robot: robot.inner.clone(),
            plant,
        })
    }

    /// Restart at state ``x = [q, qd]`` and time 0.
    fn reset(&mut self, x: &Bound<'_, PyAny>) -> PyResult<()> {
        let x = start_state(&self.robot, Some(x))?;
        let substeps = self.plant.substeps;
        self.plant = brachia::sim::ModelPlant::new((*self.robot).clone(), &x);
        self.plant.substeps = substeps;
        Ok(())
    }

    /// Hold ``tau`` (n - 1 values, N m; clamped to the limits) for ``dt`` seconds (0 < dt <= 1).
    fn step(&mut self, tau: &Bound<'_, PyAny>, dt: f64) -> PyResult<()> {
        step_input(tau, dt, &mut self.tau)?;
        self.plant.step(&self.tau, dt);
        Ok(())
    }

    /// The state ``[q, qd]``, shape ``(2n,)``.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut x = vec![0.0; self.robot.nx()];
        self.plant.state(&mut x);
        arr1(py, &x)
    }

    /// Simulated time, s.
    #[getter]
    fn time(&self) -> f64 {
        self.plant.time()
    }

    /// RK4 steps per ``step`` call.
    #[getter]
    fn substeps(&self) -> usize {
        self.plant.substeps
    }

    /// Total mechanical energy of the robot, J.
    fn energy(&self) -> f64 {
        self.plant.energy()
    }
}

/// The rapier2d physics-engine plant, with contacts against obstacles (``brachia_rapier``).
///
/// ``RapierPlant(robot, x0=None, settings=None, obstacles=None, **kwargs)``: settings (dict and/or
/// keyword arguments) are ``substeps``, ``self_contacts``, ``link_friction``, ``link_restitution``;
/// ``obstacles`` a list of dicts ``{"kind": "circle", "center": (2,), "radius": r}`` or ``{"kind":
/// "ball", "center", "radius", "mass", "restitution", "gravity"}`` (m, kg).
#[pyclass(module = "brachia", unsendable)]
pub struct RapierPlant {
    robot: Arc<brachia::Robot>,
    settings: RapierSettings,
    obstacles: Vec<Obstacle>,
    pub(crate) plant: brachia_rapier::RapierPlant,
    tau: Vec<f64>,
}

impl RapierPlant {
    /// A world at `x` with the obstacles added.
    fn build(
        robot: &brachia::Robot,
        x: &[f64],
        settings: &RapierSettings,
        obstacles: &[Obstacle],
    ) -> PyResult<brachia_rapier::RapierPlant> {
        let mut p = brachia_rapier::RapierPlant::new(robot, x, settings).map_err(rs)?;
        for o in obstacles {
            p.add_obstacle(o).map_err(rs)?;
        }
        Ok(p)
    }
}

#[pymethods]
impl RapierPlant {
    #[new]
    #[pyo3(signature = (robot, x0 = None, settings = None, obstacles = None, **kwargs))]
    fn new(
        robot: &Robot,
        x0: Option<&Bound<'_, PyAny>>,
        settings: Option<&Bound<'_, PyAny>>,
        obstacles: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let settings: RapierSettings = settings_from(settings, kwargs, "rapier settings")?;
        let obstacles: Vec<Obstacle> = match obstacles {
            Some(o) if !o.is_none() => {
                let text = crate::convert::to_json(o, "obstacles")?;
                serde_json::from_str(&text).map_err(|e| bad(format!("obstacles: {e}")))?
            }
            _ => Vec::new(),
        };
        let max = brachia::planning::MAX_OBSTACLES;
        if obstacles.len() > max {
            return Err(bad(format!(
                "obstacles: {} obstacles; at most {max}",
                obstacles.len()
            )));
        }
        for (i, o) in obstacles.iter().enumerate() {
            o.validate("obstacles", i).map_err(rs)?;
        }
        let x = start_state(&robot.inner, x0)?;
        let plant = Self::build(&robot.inner, &x, &settings, &obstacles)?;
        Ok(RapierPlant {
            tau: vec![0.0; robot.inner.nu()],
            robot: robot.inner.clone(),
            settings,
            obstacles,
            plant,
        })
    }

    /// Rebuild the world at state ``x = [q, qd]``, time 0, obstacles at their starting places.
    fn reset(&mut self, x: &Bound<'_, PyAny>) -> PyResult<()> {
        let x = start_state(&self.robot, Some(x))?;
        self.plant = Self::build(&self.robot, &x, &self.settings, &self.obstacles)?;
        Ok(())
    }

    /// Hold ``tau`` (n - 1 values, N m; clamped to the limits) for ``dt`` seconds (0 < dt <= 1;
    /// ``substeps`` engine steps).
    fn step(&mut self, tau: &Bound<'_, PyAny>, dt: f64) -> PyResult<()> {
        step_input(tau, dt, &mut self.tau)?;
        self.plant.step(&self.tau, dt);
        Ok(())
    }

    /// The state ``[q, qd]`` read from the engine, shape ``(2n,)``.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut x = vec![0.0; self.robot.nx()];
        self.plant.state(&mut x);
        arr1(py, &x)
    }

    /// Simulated time, s.
    #[getter]
    fn time(&self) -> f64 {
        self.plant.time()
    }

    /// Total mechanical energy of the robot from the engine's bodies, J.
    fn energy(&self) -> f64 {
        self.plant.energy()
    }

    /// Every contact of a link so far: dicts ``{"t": s, "link": 1..n, "body": "obstacle_<id>" |
    /// "link_<j>", "impulse": N s}``.
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let list = PyList::empty(py);
        for c in self.plant.contacts() {
            let d = PyDict::new(py);
            d.set_item("t", c.t)?;
            d.set_item("link", c.link + 1)?;
            let body = match c.body {
                ContactBody::Obstacle(id) => format!("obstacle_{id}"),
                ContactBody::Link(j) => format!("link_{}", j + 1),
            };
            d.set_item("body", body)?;
            d.set_item("impulse", c.impulse)?;
            list.append(d)?;
        }
        Ok(list)
    }
}

/// A closed-loop run: arrays of the log (one row per control instant), its summary and, for a
/// scenario's run, the report ``brachia track`` writes.
#[pyclass(module = "brachia", frozen)]
pub struct TrackResult {
    log: ClosedLoopLog,
    summary: Option<RunSummary>,
    report: serde_json::Value,
    plan: Option<Py<Plan>>,
    folder: Option<RunFolder>,
}

#[pymethods]
impl TrackResult {
    /// False when a scenario's plan did not converge and nothing was tracked (see ``plan``); the
    /// arrays are then empty.
    #[getter]
    fn tracked(&self) -> bool {
        self.summary.is_some()
    }

    /// Times, s, shape ``(rows,)``.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.log.t)
    }

    /// True plant states ``[q, qd]``, shape ``(rows, 2n)``.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.log.x.clone(), 2 * self.log.n)
    }

    /// Joint angles, rad, shape ``(rows, n)``.
    #[getter]
    fn q<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.log.n;
        let v: Vec<f64> = self
            .log
            .x
            .chunks(2 * n.max(1))
            .flat_map(|r| r[..n].to_vec())
            .collect();
        arr2(py, v, n)
    }

    /// Joint velocities, rad/s, shape ``(rows, n)``.
    #[getter]
    fn qd<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.log.n;
        let v: Vec<f64> = self
            .log
            .x
            .chunks(2 * n.max(1))
            .flat_map(|r| r[n..].to_vec())
            .collect();
        arr2(py, v, n)
    }

    /// Applied (clamped) torques of joints 2..n over ``[t_k, t_k + dt)``, N m, shape ``(rows, n - 1)``.
    #[getter]
    fn tau<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.log.tau.clone(), self.log.n.saturating_sub(1))
    }

    /// End-effector positions, m, shape ``(rows, 2)``.
    #[getter]
    fn ee<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.log.ee.concat(), 2)
    }

    /// Reference states at the control instants, shape ``(rows, 2n)``.
    #[getter]
    fn ref_x<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.log.ref_x.clone(), 2 * self.log.n)
    }

    /// Reference end-effector positions, m, shape ``(rows, 2)``.
    #[getter]
    fn ref_ee<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr2(py, self.log.ref_ee.concat(), 2)
    }

    /// Controller wall time per step, us, shape ``(rows,)`` (0 in the last row).
    #[getter]
    fn control_us<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        arr1(py, &self.log.control_us)
    }

    /// Summary metrics (EE final and largest error, joint RMS error, energy, torque range,
    /// control-step time percentiles, QP iterations) as a dict; ``None`` when nothing was tracked.
    #[getter]
    fn summary<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.summary {
            Some(s) => to_py(py, s),
            None => Ok(py.None().into_bound(py)),
        }
    }

    /// The report as a dict (for a scenario's run: the ``report.json`` of ``brachia track``).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// The plan that was tracked, when it was planned by ``Scenario.track`` (else ``None``).
    #[getter]
    fn plan(&self, py: Python<'_>) -> Option<Py<Plan>> {
        self.plan.as_ref().map(|p| p.clone_ref(py))
    }

    /// Write the run folder ``brachia track`` writes into ``out`` (a scenario's run only).
    #[pyo3(signature = (out, force = false))]
    fn write(&self, py: Python<'_>, out: PathBuf, force: bool) -> PyResult<()> {
        let Some(folder) = &self.folder else {
            return Err(bad(
                "write: only a scenario's run (Scenario.track()) has a run folder to write",
            ));
        };
        brachia_experiments::check_out_dir(&out, force).map_err(exp)?;
        py.detach(|| folder.write(&out)).map_err(exp)
    }

    fn __repr__(&self) -> String {
        match &self.summary {
            Some(s) => format!(
                "TrackResult(rows={}, ee_final_error_m={:.3e}, joint_rms_error_rad={:.3e})",
                self.log.len(),
                s.ee_final_error_m,
                s.joint_rms_error_rad
            ),
            None => "TrackResult(tracked=False)".into(),
        }
    }
}

impl TrackResult {
    /// A run's result.
    pub(crate) fn new(
        log: ClosedLoopLog,
        summary: Option<RunSummary>,
        report: serde_json::Value,
        plan: Option<Py<Plan>>,
        folder: Option<RunFolder>,
    ) -> Self {
        TrackResult {
            log,
            summary,
            report,
            plan,
            folder,
        }
    }
}

/// Run ``controller`` against ``plant`` in closed loop from the plant's current state, logging
/// against ``reference`` (a ``Plan`` or a ``Trajectory``).
///
/// ``controller``: an ``Mpc`` (used as it is; its state carries over), or ``"mpc"`` (default: an
/// ``Mpc`` with default settings), ``"pd"``, ``"open-loop"``. ``plant``: a ``ModelPlant`` or a
/// ``RapierPlant`` (stepped in place), or ``None`` for a model plant at the reference's first state.
/// ``duration`` defaults to the reference's; ``control_dt`` is the control period (s; the torque is
/// held over it); ``noise_q_std`` / ``noise_qd_std`` add Gaussian sensor noise (rad, rad/s) seeded by
/// ``seed``. Returns a ``TrackResult``; raises ``BrachiaError`` on bad input.
#[pyfunction]
#[pyo3(signature = (robot, reference, controller = None, plant = None, duration = None,
    control_dt = 0.001, noise_q_std = 0.0, noise_qd_std = 0.0, seed = 0))]
pub(crate) fn track(
    robot: &Robot,
    reference: &Bound<'_, PyAny>,
    controller: Option<&Bound<'_, PyAny>>,
    plant: Option<&Bound<'_, PyAny>>,
    duration: Option<f64>,
    control_dt: f64,
    noise_q_std: f64,
    noise_qd_std: f64,
    seed: u64,
) -> PyResult<TrackResult> {
    let r = robot.inner.clone();
    let reference = reference_of(reference)?;
    let settings = RunSettings {
        duration_s: duration.unwrap_or_else(|| reference.duration()),
        control_dt,
        cancel: None,
    };
    settings.validate().map_err(rs)?;
    let noise = NoiseSettings {
        q_std: noise_q_std,
        qd_std: noise_qd_std,
        seed,
    };
    noise.validate().map_err(rs)?;
    let run = |plant: &mut dyn Plant, ctrl: &mut dyn Controller| -> PyResult<ClosedLoopLog> {
        if noise.q_std == 0.0 && noise.qd_std == 0.0 {
            run_closed_loop(plant, ctrl, &reference, &r, &settings).map_err(rs)
        } else {
            let mut noisy = Noisy::new(plant, noise).map_err(rs)?;
            run_closed_loop(&mut noisy, ctrl, &reference, &r, &settings).map_err(rs)
        }
    };
    let with_controller = |plant: &mut dyn Plant| -> PyResult<ClosedLoopLog> {
        match controller.filter(|c| !c.is_none()) {
            Some(c) if c.is_instance_of::<Mpc>() => {
                let mut m = c.cast::<Mpc>()?.try_borrow_mut()?;
                m.with_controller(|ctrl| run(plant, ctrl))
            }
            Some(c) => {
                let name: String = c.extract().map_err(|_| {
                    bad("controller: expected an Mpc or one of \"mpc\", \"pd\", \"open-loop\"")
                })?;
                match name.as_str() {
                    "mpc" => {
                        let mut m = brachia::control::Mpc::new(r.clone(), reference.clone(), Default::default())
                            .map_err(rs)?;
                        run(plant, &mut m)
                    }
                    "pd" => {
                        let mut m = Pd::new(r.clone(), reference.clone(), PdSettings::default()).map_err(rs)?;
                        run(plant, &mut m)
                    }
                    "open-loop" => {
                        let mut m = OpenLoop::new(r.clone(), reference.clone()).map_err(rs)?;
                        run(plant, &mut m)
                    }
                    other => Err(bad(format!(
                        "controller = {other:?}: expected an Mpc or one of \"mpc\", \"pd\", \"open-loop\""
                    ))),
                }
            }
            None => {
                let mut m =
                    brachia::control::Mpc::new(r.clone(), reference.clone(), Default::default())
                        .map_err(rs)?;
                run(plant, &mut m)
            }
        }
    };
    let log = match plant.filter(|p| !p.is_none()) {
        Some(p) if p.is_instance_of::<ModelPlant>() => {
            let mut p = p.cast::<ModelPlant>()?.try_borrow_mut()?;
            with_controller(&mut p.plant)?
        }
        Some(p) if p.is_instance_of::<RapierPlant>() => {
            let mut p = p.cast::<RapierPlant>()?.try_borrow_mut()?;
            with_controller(&mut p.plant)?
        }
        Some(p) => {
            return Err(bad(format!(
                "plant: expected a ModelPlant or a RapierPlant, got {}",
                p.get_type().name()?
            )))
        }
        None => {
            if reference.n != r.n() {
                return Err(bad(format!(
                    "reference: a trajectory of {} links for the {}-link robot",
                    reference.n,
                    r.n()
                )));
            }
            let x0 = [reference.q(0), reference.qd(0)].concat();
            let mut p = brachia::sim::ModelPlant::new((*r).clone(), &x0);
            with_controller(&mut p)?
        }
    };
    let summary = log.summary();
    let report = serde_json::to_value(summary).unwrap_or_default();
    Ok(TrackResult::new(log, Some(summary), report, None, None))
}
