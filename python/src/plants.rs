//! The plants: `ModelPlant` (RK4 on the robot's own dynamics) and `RapierPlant` (the physics engine).
//!
//! Conventions: a plant's state is `x = [q, qd]` (2n; rad, rad/s; q1 absolute, the rest relative);
//! `step(tau, dt)` holds the torques of joints 2..n (n - 1 values, N m, clamped to the robot's limits)
//! for `dt` seconds. A start state obeys the CLI's rules for a start state (`|q| <=
//! brachia::limits::MAX_ANGLE_RAD`, `|qd| <= MAX_RATE_RAD_S`). A step whose state leaves
//! `brachia::sim::DIVERGENCE_BOUND` (or stops being finite) raises, and the plant refuses every use
//! but `reset` from then on: no NaN state is ever returned.
//!
//! Both classes keep their state behind a lock (`crate::shared`): any thread may use them, one call
//! at a time.

use crate::convert::{arr1, bad, check_slice, num, read_vector, rs, Arg, Count, Range, Real};
use crate::dicts::settings_from;
use crate::model::Robot;
use crate::shared::{Guard, Shared};
use brachia::sim::{Plant, DIVERGENCE_BOUND};
use brachia_rapier::{ContactBody, Obstacle, RapierSettings};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use std::sync::Arc;

/// Largest `dt` of one plant step, s.
const MAX_STEP_DT: f64 = 1.0;

/// `x0` (or the robot at rest hanging straight down when `None`) as a checked state.
pub(crate) fn start_state(
    robot: &brachia::Robot,
    name: &str,
    x0: Option<&Bound<'_, PyAny>>,
) -> PyResult<Vec<f64>> {
    let n = robot.n();
    let mut v = vec![0.0; 2 * n];
    match x0 {
        Some(x) => {
            let what = format!("[q, qd] of the {n}-link robot, rad and rad/s");
            read_vector(x, Arg::new(name, &what, Range::State), &mut v)?;
        }
        None => v[0] = -std::f64::consts::FRAC_PI_2,
    }
    Ok(v)
}

/// Check a substep count.
fn check_substeps(substeps: u64) -> PyResult<usize> {
    let kmax = brachia::limits::MAX_SUBSTEPS;
    match usize::try_from(substeps) {
        Ok(k) if (1..=kmax).contains(&k) => Ok(k),
        _ => Err(bad(format!("substeps = {substeps}: must be 1..={kmax}"))),
    }
}

/// A plant with the buffers of its calls and whether it diverged.
pub(crate) struct PlantCell<P> {
    pub(crate) plant: P,
    tau: Vec<f64>,
    x: Vec<f64>,
    /// Time at which the state left `DIVERGENCE_BOUND` (or stopped being finite), if it did.
    diverged_at: Option<f64>,
    /// The class, for messages.
    class: &'static str,
}

impl<P: Plant> PlantCell<P> {
    fn new(class: &'static str, plant: P, n: usize) -> Self {
        PlantCell {
            plant,
            tau: vec![0.0; n - 1],
            x: vec![0.0; 2 * n],
            diverged_at: None,
            class,
        }
    }

    /// An error for a call on a plant that diverged.
    pub(crate) fn usable(&self, call: &str) -> PyResult<()> {
        match self.diverged_at {
            None => Ok(()),
            Some(t) => Err(bad(format!(
                "{}.{call}: the simulation diverged at t = {} s (the state left {DIVERGENCE_BOUND:e} \
                 or stopped being finite); reset() the plant to use it again",
                self.class,
                num(t)
            ))),
        }
    }

    /// After the plant moved: record a divergence (the state beyond `DIVERGENCE_BOUND` or not
    /// finite, or a non-finite energy); true when it diverged.
    pub(crate) fn note_divergence(&mut self) -> bool {
        self.plant.state(&mut self.x);
        let energy = self.plant.energy();
        let gone = self
            .x
            .iter()
            .any(|v| !v.is_finite() || v.abs() > DIVERGENCE_BOUND)
            || !energy.is_finite();
        if gone && self.diverged_at.is_none() {
            self.diverged_at = Some(self.plant.time());
        }
        gone
    }

    /// After the plant moved: report a divergence.
    fn check(&mut self, call: &str) -> PyResult<()> {
        self.note_divergence();
        self.usable(call)
    }

    /// One step: `tau` held for `dt`.
    fn step(&mut self, tau: &Bound<'_, PyAny>, dt: Real) -> PyResult<()> {
        self.usable("step")?;
        let dt = dt.0;
        if !(dt.is_finite() && dt > 0.0 && dt <= MAX_STEP_DT) {
            return Err(bad(format!(
                "dt = {}: must be in (0, {MAX_STEP_DT}] s",
                num(dt)
            )));
        }
        let what = "torques of joints 2..n, N m (clamped to the limits)";
        read_vector(tau, Arg::new("tau", what, Range::Torque), &mut self.tau)?;
        self.plant.step(&self.tau, dt);
        self.check("step")
    }

    /// The state as a new array.
    fn state<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.usable("state")?;
        self.plant.state(&mut self.x);
        arr1(py, &self.x)
    }

    /// The mechanical energy.
    fn energy(&self) -> PyResult<f64> {
        self.usable("energy")?;
        Ok(self.plant.energy())
    }
}

/// The model plant: the robot's own dynamics integrated by RK4 (``substeps`` steps per ``step``).
///
/// ``ModelPlant(robot, x0=None, substeps=1)``; ``x0 = [q, qd]`` (default: hanging straight down at
/// rest; ``|q| <= 4 pi`` rad, ``|qd| <= 1000`` rad/s). Torques are clamped to the robot's limits. A
/// step that makes the simulation diverge raises ``BrachiaError``; the plant then needs ``reset``.
/// Usable from any thread (one call at a time).
#[pyclass(module = "brachia", frozen)]
pub struct ModelPlant {
    robot: Arc<brachia::Robot>,
    substeps: usize,
    pub(crate) cell: Shared<PlantCell<brachia::sim::ModelPlant>>,
}

impl ModelPlant {
    /// The locked plant.
    pub(crate) fn lock(
        &self,
        py: Python<'_>,
    ) -> PyResult<Guard<'_, PlantCell<brachia::sim::ModelPlant>>> {
        self.cell.lock(py)
    }

    fn build(robot: &Arc<brachia::Robot>, x: &[f64], substeps: usize) -> brachia::sim::ModelPlant {
        let mut plant = brachia::sim::ModelPlant::new(robot.clone(), x);
        plant.substeps = substeps;
        plant
    }
}

#[pymethods]
impl ModelPlant {
    #[new]
    #[pyo3(signature = (robot, x0 = None, substeps = Count(1)))]
    fn new(robot: &Robot, x0: Option<&Bound<'_, PyAny>>, substeps: Count) -> PyResult<Self> {
        let substeps = check_substeps(substeps.0)?;
        let x = start_state(&robot.inner, "x0", x0)?;
        let plant = Self::build(&robot.inner, &x, substeps);
        Ok(ModelPlant {
            substeps,
            cell: Shared::new(
                "ModelPlant",
                PlantCell::new("ModelPlant", plant, robot.inner.n()),
            ),
            robot: robot.inner.clone(),
        })
    }

    /// Restart at state ``x = [q, qd]`` and time 0.
    fn reset(&self, py: Python<'_>, x: &Bound<'_, PyAny>) -> PyResult<()> {
        let x = start_state(&self.robot, "x", Some(x))?;
        let mut c = self.lock(py)?;
        c.plant = Self::build(&self.robot, &x, self.substeps);
        c.diverged_at = None;
        Ok(())
    }

    /// Hold ``tau`` (n - 1 values, N m; clamped to the limits) for ``dt`` seconds (0 < dt <= 1).
    fn step(&self, py: Python<'_>, tau: &Bound<'_, PyAny>, dt: Real) -> PyResult<()> {
        self.lock(py)?.step(tau, dt)
    }

    /// The state ``[q, qd]``, shape ``(2n,)``.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.lock(py)?.state(py)
    }

    /// Simulated time, s.
    #[getter]
    fn time(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.plant.time())
    }

    /// RK4 steps per ``step`` call.
    #[getter]
    fn substeps(&self) -> usize {
        self.substeps
    }

    /// Total mechanical energy of the robot, J.
    fn energy(&self, py: Python<'_>) -> PyResult<f64> {
        self.lock(py)?.energy()
    }
}

/// The rapier2d physics-engine plant, with contacts against obstacles (``brachia_rapier``).
///
/// ``RapierPlant(robot, x0=None, settings=None, obstacles=None, **kwargs)``: settings (dict and/or
/// keyword arguments) are ``substeps``, ``self_contacts``, ``link_friction``, ``link_restitution``;
/// ``obstacles`` a list of dicts ``{"kind": "circle", "center": (2,), "radius": r}`` or ``{"kind":
/// "ball", "center", "radius", "mass", "restitution", "gravity"}`` (m, kg). A step that makes the
/// simulation diverge raises ``BrachiaError``; the plant then needs ``reset``. Usable from any thread
/// (one call at a time).
#[pyclass(module = "brachia", frozen)]
pub struct RapierPlant {
    robot: Arc<brachia::Robot>,
    settings: RapierSettings,
    obstacles: Vec<Obstacle>,
    pub(crate) cell: Shared<PlantCell<brachia_rapier::RapierPlant>>,
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

    /// The locked plant.
    pub(crate) fn lock(
        &self,
        py: Python<'_>,
    ) -> PyResult<Guard<'_, PlantCell<brachia_rapier::RapierPlant>>> {
        self.cell.lock(py)
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
                let text = crate::dicts::to_json(o, "obstacles")?;
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
            let (c, r) = o.shape();
            let name = format!("obstacles[{i}] (center, radius)");
            check_slice(&[c[0], c[1], r], &name, Range::Position)?;
        }
        let x = start_state(&robot.inner, "x0", x0)?;
        let plant = Self::build(&robot.inner, &x, &settings, &obstacles)?;
        Ok(RapierPlant {
            cell: Shared::new(
                "RapierPlant",
                PlantCell::new("RapierPlant", plant, robot.inner.n()),
            ),
            robot: robot.inner.clone(),
            settings,
            obstacles,
        })
    }

    /// Rebuild the world at state ``x = [q, qd]``, time 0, obstacles at their starting places.
    fn reset(&self, py: Python<'_>, x: &Bound<'_, PyAny>) -> PyResult<()> {
        let x = start_state(&self.robot, "x", Some(x))?;
        let plant = Self::build(&self.robot, &x, &self.settings, &self.obstacles)?;
        let mut c = self.lock(py)?;
        c.plant = plant;
        c.diverged_at = None;
        Ok(())
    }

    /// Hold ``tau`` (n - 1 values, N m; clamped to the limits) for ``dt`` seconds (0 < dt <= 1;
    /// ``substeps`` engine steps).
    fn step(&self, py: Python<'_>, tau: &Bound<'_, PyAny>, dt: Real) -> PyResult<()> {
        self.lock(py)?.step(tau, dt)
    }

    /// The state ``[q, qd]`` read from the engine, shape ``(2n,)``.
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        self.lock(py)?.state(py)
    }

    /// Simulated time, s.
    #[getter]
    fn time(&self, py: Python<'_>) -> PyResult<f64> {
        Ok(self.lock(py)?.plant.time())
    }

    /// Total mechanical energy of the robot from the engine's bodies, J.
    fn energy(&self, py: Python<'_>) -> PyResult<f64> {
        self.lock(py)?.energy()
    }

    /// Every contact of a link so far: dicts ``{"t": s, "link": 1..n, "body": "obstacle_<id>" |
    /// "link_<j>", "impulse": N s}``.
    fn contacts<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyList>> {
        let c = self.lock(py)?;
        let list = PyList::empty(py);
        for e in c.plant.contacts() {
            let d = PyDict::new(py);
            d.set_item("t", e.t)?;
            d.set_item("link", e.link + 1)?;
            let body = match e.body {
                ContactBody::Obstacle(id) => format!("obstacle_{id}"),
                ContactBody::Link(j) => format!("link_{}", j + 1),
            };
            d.set_item("body", body)?;
            d.set_item("impulse", e.impulse)?;
            list.append(d)?;
        }
        Ok(list)
    }
}
