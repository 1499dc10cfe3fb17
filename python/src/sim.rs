//! The closed loop `track(...)` and its `TrackResult`.
//!
//! Conventions: a state is `x = [q, qd]` (2n; rad, rad/s; q1 absolute, the rest relative); torques
//! are those of joints 2..n (n - 1 values, N m). Logs are row-major arrays with one row per control
//! instant (`steps + 1` rows; the last row is the final state). The closed loop runs with the GIL
//! released, holding the locks of the plant and of an `Mpc` it was given (`crate::shared`).

use crate::control::{reference_of, Mpc, MpcState};
use crate::controllers::{spec_of, Plain, Spec};
use crate::convert::{arr1, arr2, bad, exp, num, rs, scalar, Count, Real};
use crate::dicts::{settings_from, to_py};
use crate::interrupt::interruptible;
use crate::model::Robot;
use crate::planning::Plan;
use crate::plants::{ModelPlant, PlantCell, RapierPlant};
use crate::policy::{raise_from, ErrorSink, PyPolicy};
use crate::shared::Guard;
use brachia::control::{EstimateReport, MpcSettings, PdSettings, ReplanEvent, TvlqrSettings};
use brachia::sim::{
    run_closed_loop, ClosedLoopLog, Controller, Disturbances, NoiseSettings, Noisy, Plant,
    RunSettings, RunSummary,
};
use brachia_experiments::RunFolder;
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

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

    /// Time at which the closed loop diverged, s (the plant's state left 1e6 or stopped being
    /// finite, or the controller returned a non-finite torque): the run stopped there and the arrays
    /// hold the rows before it; a diverged run is not to be trusted. ``None`` when it did not.
    #[getter]
    fn diverged_at_s(&self) -> Option<f64> {
        self.log.diverged_at_s
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

    /// The run page of a scenario's run (docs/viewer.md) as HTML text, drawn from the run folder it
    /// would write; ``None`` for a run without one (``track()`` outside a scenario) or with nothing
    /// tracked.
    fn _view_html(&self, py: Python<'_>) -> PyResult<Option<String>> {
        match (&self.folder, self.summary.is_some()) {
            (Some(folder), true) => py.detach(|| crate::view::folder_page(folder)).map(Some),
            _ => Ok(None),
        }
    }

    /// The run page inline in Jupyter (a frame of the notebook's width).
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<Option<String>> {
        Ok(self._view_html(py)?.map(|h| crate::view::frame(&h)))
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

/// The controller of a `track` call: a given `Mpc` (locked for the run, its state carried over), a
/// Python policy with the sink of its exception, or a recipe built afresh on the loop's thread.
enum Ctrl<'a> {
    Given(Guard<'a, MpcState>),
    Policy(PyPolicy, ErrorSink),
    Recipe(Option<Plain>),
}

/// The controller `controller` names or is, for `reference`.
fn controller_for<'a>(
    py: Python<'_>,
    controller: Option<&'a Bound<'_, PyAny>>,
    robot: &Arc<brachia::Robot>,
    reference: &Arc<brachia::trajectory::Trajectory>,
) -> PyResult<Ctrl<'a>> {
    let names = "expected a controller object (Mpc, Tvlqr, Pd, OpenLoop, Kalman, Replanning, \
                 Adaptive), a callable policy(t, x) -> tau, or one of \"mpc\", \"tvlqr\", \"pd\", \
                 \"open-loop\"";
    let name = match controller.filter(|c| !c.is_none()) {
        None => "mpc".to_string(),
        Some(c) => {
            if let Ok(m) = c.cast::<Mpc>() {
                let m: &'a Mpc = m.get();
                let g = m.lock(py)?;
                reference.check_reference(g.inner.robot()).map_err(rs)?;
                return Ok(Ctrl::Given(g));
            }
            if let Some(spec) = spec_of(c) {
                return recipe(py, &spec, robot, reference);
            }
            if let Some((p, sink)) = PyPolicy::of(c) {
                return Ok(Ctrl::Policy(p, sink));
            }
            c.extract::<String>()
                .map_err(|_| bad(format!("controller: {names}")))?
        }
    };
    let (r, t) = (robot.clone(), reference.clone());
    let plain = match name.as_str() {
        "mpc" => Plain::Mpc(Box::new(
            brachia::control::Mpc::new(r, t, MpcSettings::default()).map_err(rs)?,
        )),
        "tvlqr" => Plain::Tvlqr(r, t, TvlqrSettings::default()),
        "pd" => Plain::Pd(r, t, PdSettings::default()),
        "open-loop" => Plain::OpenLoop(r, t),
        other => return Err(bad(format!("controller = {other:?}: {names}"))),
    };
    Ok(Ctrl::Recipe(Some(plain)))
}

/// A controller object's recipe, checked against the run's robot and reference: the reference it
/// was made with must be the run's (a wrapper's cold plan and filter follow it).
fn recipe<'a>(
    py: Python<'_>,
    spec: &Spec,
    robot: &Arc<brachia::Robot>,
    reference: &Arc<brachia::trajectory::Trajectory>,
) -> PyResult<Ctrl<'a>> {
    let mine = spec.reference(py)?;
    if !Arc::ptr_eq(&mine, reference) && *mine != **reference {
        return Err(bad(
            "controller: it was made for another reference than the one given to track(); make \
             it with this reference",
        ));
    }
    reference.check_reference(robot).map_err(rs)?;
    Ok(Ctrl::Recipe(Some(spec.resolve(py)?)))
}

/// What a run left besides its log: the re-plans and the estimate of a wrapped controller.
#[derive(Default)]
struct Extras {
    replans: Option<Vec<ReplanEvent>>,
    estimate: Option<EstimateReport>,
}

/// Everything a `track` call runs besides the plant and the controller.
struct Job<'a> {
    reference: &'a brachia::trajectory::Trajectory,
    robot: &'a brachia::Robot,
    settings: RunSettings,
    noise: NoiseSettings,
    disturbances: Disturbances,
}

impl Job<'_> {
    /// Run `ctrl` against `plant` (wrapped in the disturbances, then the sensor noise) with the GIL
    /// released, stopped by Ctrl-C (`KeyboardInterrupt`); a recipe is built on the worker thread.
    fn run(
        &self,
        py: Python<'_>,
        plant: &mut (dyn Plant + Send),
        ctrl: &mut Ctrl<'_>,
    ) -> PyResult<(ClosedLoopLog, Extras)> {
        // Ctrl-C stops the loop at its next check (every 64 control steps), and a wrapper's solves
        let cancel = brachia::CancelToken::new();
        let settings = RunSettings {
            cancel: Some(cancel.clone()),
            ..self.settings.clone()
        };
        let (given, plain): (Option<&mut (dyn Controller + Send)>, Option<Plain>) = match ctrl {
            Ctrl::Given(m) => (Some(&mut m.inner), None),
            Ctrl::Policy(p, _) => (Some(p), None),
            Ctrl::Recipe(r) => (None, r.take()),
        };
        let out = interruptible(py, &cancel, || {
            let mut built = match plain {
                Some(p) => Some(p.build(settings.control_dt, &cancel)?),
                None => None,
            };
            let c: &mut (dyn Controller + Send) = match (given, built.as_mut()) {
                (Some(c), _) => c,
                (None, Some(b)) => b.controller(),
                (None, None) => unreachable!("a controller is given or built"),
            };
            let mut wrapped = self
                .disturbances
                .wrap_send(Box::new(plant), settings.control_dt)?;
            if !self.noise.is_zero() {
                wrapped = Box::new(Noisy::new(wrapped, self.noise)?);
            }
            let log = run_closed_loop(wrapped.as_mut(), c, self.reference, self.robot, &settings)?;
            let extras = built.map_or_else(Extras::default, |b| Extras {
                replans: b.replans(),
                estimate: b.estimate(),
            });
            Ok::<_, brachia::Error>((log, extras))
        })?;
        if let Ctrl::Policy(_, sink) = ctrl {
            raise_from(sink)?;
        }
        out.map_err(rs)
    }

    /// [`Job::run`] on a plant object's plant, recording a divergence on it.
    fn run_on<P: Plant + Send>(
        &self,
        py: Python<'_>,
        cell: &mut PlantCell<P>,
        ctrl: &mut Ctrl<'_>,
    ) -> PyResult<(ClosedLoopLog, Extras)> {
        let out = self.run(py, &mut cell.plant, ctrl);
        cell.note_divergence();
        out
    }
}

/// The run settings of a `track` call, checked as the CLI checks a scenario's `[tracking]`.
fn run_settings(
    duration: Option<Real>,
    control_dt: Real,
    reference: &brachia::trajectory::Trajectory,
) -> PyResult<RunSettings> {
    let dmax = brachia::limits::MAX_RUN_DURATION_S;
    let control_dt = scalar("control_dt", control_dt.0, Some(([1e-6, 0.1], "s")))?;
    let duration_s = match duration {
        Some(d) => scalar("duration", d.0, Some(([0.0, dmax], "s")))?,
        None => reference.duration(),
    };
    let settings = RunSettings {
        duration_s,
        control_dt,
        cancel: None,
    };
    settings.validate().map_err(rs)?;
    if settings.steps() == 0 {
        return Err(bad(format!(
            "duration = {} s: shorter than half a control period (control_dt = {} s): nothing \
             would be tracked",
            num(duration_s),
            num(control_dt)
        )));
    }
    Ok(settings)
}

/// The `disturbances` dict of a `track` call (the scenario's `[disturbances]` schema), checked as
/// the scenario's are; the model mismatch and the start offset need the plant `track` makes.
fn disturbances_of(
    d: Option<&Bound<'_, PyAny>>,
    n: usize,
    control_dt: f64,
    noise: &NoiseSettings,
    plant_given: bool,
) -> PyResult<Disturbances> {
    let d: Disturbances = settings_from(d, None, "disturbances")?;
    d.validate(n, control_dt, "disturbances").map_err(rs)?;
    if !noise.is_zero() && (d.noise_q_std > 0.0 || d.noise_qd_std > 0.0) {
        return Err(bad(
            "disturbances.noise_q_std: sensor noise is given twice: use the disturbances' \
             noise_q_std / noise_qd_std or track()'s noise_q_std / noise_qd_std, not both",
        ));
    }
    if plant_given {
        let mismatch = [
            ("mass_scale", &d.mass_scale),
            ("com_scale", &d.com_scale),
            ("inertia_scale", &d.inertia_scale),
            ("length_scale", &d.length_scale),
            ("start_offset", &d.start_offset),
        ];
        if let Some((field, _)) = mismatch.iter().find(|(_, v)| !v.is_empty()) {
            return Err(bad(format!(
                "disturbances.{field}: a plant given to track() has its robot and state already: \
                 make it with the mismatched robot and start state, or pass plant=None and \
                 track() makes the model plant from the disturbances"
            )));
        }
    }
    Ok(d)
}

/// The report of a `track` call: the summary, the controller's name and, for a wrapped
/// controller, its re-plans and estimate.
fn track_report(summary: &RunSummary, extras: Extras, d: &Disturbances) -> serde_json::Value {
    let mut v = serde_json::to_value(summary).unwrap_or_default();
    if let Some(m) = v.as_object_mut() {
        m.insert("replanning".into(), extras.replans.is_some().into());
        if let Some(r) = extras.replans {
            m.insert("replan_count".into(), r.len().into());
            m.insert(
                "replans".into(),
                serde_json::to_value(r).unwrap_or_default(),
            );
        }
        if let Some(e) = extras.estimate {
            m.insert(
                "estimate".into(),
                serde_json::to_value(e).unwrap_or_default(),
            );
        }
        m.insert(
            "disturbances".into(),
            serde_json::to_value(d).unwrap_or_default(),
        );
    }
    v
}

/// Run ``controller`` against ``plant`` in closed loop from the plant's current state, logging
/// against ``reference`` (a ``Plan`` or a ``Trajectory``).
///
/// ``controller``: an ``Mpc`` (used as it is; its state carries over), a controller object
/// (``Tvlqr``, ``Pd``, ``OpenLoop``, ``Kalman``, ``Replanning``, ``Adaptive``: built afresh for the
/// run, made for this reference), ``"mpc"`` (default), ``"tvlqr"``, ``"pd"``, ``"open-loop"`` (default
/// settings), or any callable ``policy(t, x) -> tau`` (s, ``[q, qd]`` float64, N m for joints 2..n;
/// its exception is raised after the loop). ``plant``: a ``ModelPlant`` or a ``RapierPlant``
/// (stepped in place), or ``None`` for a model plant at the reference's first state.
/// ``duration`` defaults to the reference's (at least one control period); ``control_dt`` is the
/// control period (s, at most 0.1; the torque is held over it); ``noise_q_std`` / ``noise_qd_std``
/// add Gaussian sensor noise (rad, rad/s) seeded by ``seed``. ``disturbances``: a dict of a
/// scenario's ``[disturbances]`` section (mismatch, noise, delays, motor lag, friction, torque
/// noise and limit, pushes, start offset); with ``plant=None`` the model plant is made with the
/// mismatched robot and the offset start, a given plant refuses those two. Returns a
/// ``TrackResult`` (a run that diverged stops there: ``diverged_at_s``); raises ``BrachiaError`` on
/// bad input. The loop runs with the GIL released; the plant and a given ``Mpc`` are locked for it.
#[pyfunction]
#[pyo3(signature = (robot, reference, controller = None, plant = None, duration = None,
    control_dt = Real(0.001), noise_q_std = Real(0.0), noise_qd_std = Real(0.0), seed = Count(0),
    disturbances = None))]
pub(crate) fn track(
    py: Python<'_>,
    robot: &Robot,
    reference: &Bound<'_, PyAny>,
    controller: Option<&Bound<'_, PyAny>>,
    plant: Option<&Bound<'_, PyAny>>,
    duration: Option<Real>,
    control_dt: Real,
    noise_q_std: Real,
    noise_qd_std: Real,
    seed: Count,
    disturbances: Option<&Bound<'_, PyAny>>,
) -> PyResult<TrackResult> {
    let r = robot.inner.clone();
    let reference = reference_of(reference)?;
    reference.check_reference(&r).map_err(rs)?;
    let settings = run_settings(duration, control_dt, &reference)?;
    let noise = NoiseSettings {
        q_std: noise_q_std.0,
        qd_std: noise_qd_std.0,
        seed: seed.0,
    };
    noise.validate().map_err(rs)?;
    let plant = plant.filter(|p| !p.is_none());
    let d = disturbances_of(
        disturbances,
        r.n(),
        settings.control_dt,
        &noise,
        plant.is_some(),
    )?;
    let job = Job {
        reference: &reference,
        robot: &r,
        settings,
        noise,
        disturbances: d,
    };
    // the plant's lock first, then the controller's (the one order of two locks: crate::shared)
    let (log, extras) = match plant {
        Some(p) => {
            if let Ok(p) = p.cast::<ModelPlant>() {
                let mut cell = p.get().lock(py)?;
                cell.usable("track")?;
                let mut ctrl = controller_for(py, controller, &r, &reference)?;
                job.run_on(py, &mut cell, &mut ctrl)?
            } else if let Ok(p) = p.cast::<RapierPlant>() {
                let mut cell = p.get().lock(py)?;
                cell.usable("track")?;
                let mut ctrl = controller_for(py, controller, &r, &reference)?;
                job.run_on(py, &mut cell, &mut ctrl)?
            } else {
                return Err(bad(format!(
                    "plant: expected a ModelPlant or a RapierPlant, got {}",
                    p.get_type().name()?
                )));
            }
        }
        None => {
            let x0 = job
                .disturbances
                .start_state(&[reference.q(0), reference.qd(0)].concat());
            let params = job.disturbances.plant_params(r.params());
            let probot =
                brachia::Robot::from_params(params, "plant (track() disturbances)").map_err(rs)?;
            let mut p = brachia::sim::ModelPlant::new(probot, &x0);
            let mut ctrl = controller_for(py, controller, &r, &reference)?;
            job.run(py, &mut p, &mut ctrl)?
        }
    };
    let summary = log.summary();
    let report = track_report(&summary, extras, &job.disturbances);
    Ok(TrackResult::new(log, Some(summary), report, None, None))
}
