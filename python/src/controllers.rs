//! The controllers of a scenario's `[tracking]` section as Python objects: `Tvlqr`, `Pd`, `OpenLoop`,
//! and the wrappers `Kalman` (the Kalman filter along the plan), `Replanning` (online re-planning
//! around the MPC) and `Adaptive` (the online mass estimate feeding the MPC and the re-planner).
//!
//! Each object is a recipe: its settings are read and checked when it is made (a dict and/or
//! keyword arguments with the fields of the scenario's section; an unknown field is refused, naming
//! it), and `track(...)` builds a fresh controller from it for every run, on the worker thread that
//! runs the closed loop (so a wrapper's cold plan stops on Ctrl-C too). The same recipe therefore
//! gives the same run every time, and the same run as `brachia track` on the same settings
//! (`brachia_experiments::track_run::make_controller` and `brachia_experiments::tracker::Tracker`
//! compose them in the same order). An `Mpc` inside a wrapper is copied when the run starts (its
//! state as it is then).

use crate::control::{reference_of, Mpc};
use crate::convert::{bad, rs};
use crate::dicts::{settings_from, to_py};
use crate::model::Robot;
use crate::planning::{plan_settings_from, task_from};
use brachia::control::{
    Adaptive, EstimateReport, Estimated, EstimatorSettings, OpenLoop as OpenLoopCtrl,
    ParamEstimatorSettings, Pd as PdCtrl, PdSettings, ReplanEvent, ReplanSettings, Replanning,
    Tvlqr as TvlqrCtrl, TvlqrSettings,
};
use brachia::planning::{NlpSettings, PlannerSettings, SwingTask};
use brachia::sim::Controller;
use brachia::trajectory::Trajectory;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::Arc;

/// A controller of joints 2..n, movable to the loop's worker thread.
pub(crate) type SendController = Box<dyn Controller + Send>;

/// What a controller object builds.
pub(crate) enum Spec {
    /// `brachia::control::Tvlqr`.
    Tvlqr(Arc<brachia::Robot>, Arc<Trajectory>, TvlqrSettings),
    /// `brachia::control::Pd`.
    Pd(Arc<brachia::Robot>, Arc<Trajectory>, PdSettings),
    /// `brachia::control::OpenLoop`.
    OpenLoop(Arc<brachia::Robot>, Arc<Trajectory>),
    /// An `Mpc` object, copied when a run starts.
    Mpc(Py<Mpc>),
    /// The Kalman filter along the plan around `inner`.
    Kalman(Arc<Spec>, EstimatorSettings),
    /// Online re-planning around `inner`.
    Replanning(Arc<Spec>, Box<ReplanParts>),
    /// The online mass estimate feeding `inner`.
    Adaptive(Arc<Spec>, ParamEstimatorSettings),
}

/// What a re-planner is built from.
pub(crate) struct ReplanParts {
    task: SwingTask,
    planner: PlannerSettings,
    nlp: NlpSettings,
    settings: ReplanSettings,
}

/// A [`Spec`] with its `Mpc` copied out: everything a worker thread needs to build the controller.
pub(crate) enum Plain {
    Tvlqr(Arc<brachia::Robot>, Arc<Trajectory>, TvlqrSettings),
    Pd(Arc<brachia::Robot>, Arc<Trajectory>, PdSettings),
    OpenLoop(Arc<brachia::Robot>, Arc<Trajectory>),
    Mpc(Box<brachia::control::Mpc>),
    Kalman(Box<Plain>, EstimatorSettings),
    Replanning(Box<Plain>, Box<ReplanParts>),
    Adaptive(Box<Plain>, ParamEstimatorSettings),
}

/// A built controller, kept typed so that a run can report its re-plans and its estimate.
pub(crate) enum Built {
    Plain(SendController),
    Replanning(Box<Replanning<SendController>>),
    Adaptive(Box<Adaptive<SendController>>),
    AdaptiveReplanning(Box<Adaptive<Replanning<SendController>>>),
}

impl Built {
    /// The controller the loop drives.
    pub(crate) fn controller(&mut self) -> &mut (dyn Controller + Send) {
        match self {
            Built::Plain(c) => c.as_mut(),
            Built::Replanning(c) => c.as_mut(),
            Built::Adaptive(c) => c.as_mut(),
            Built::AdaptiveReplanning(c) => c.as_mut(),
        }
    }

    /// The re-plans of the run (`None` without re-planning).
    pub(crate) fn replans(&self) -> Option<Vec<ReplanEvent>> {
        match self {
            Built::Replanning(c) => Some(c.events().to_vec()),
            Built::AdaptiveReplanning(c) => Some(c.inner().events().to_vec()),
            _ => None,
        }
    }

    /// The estimate of the run (`None` without it).
    pub(crate) fn estimate(&self) -> Option<EstimateReport> {
        match self {
            Built::Adaptive(c) => Some(c.report()),
            Built::AdaptiveReplanning(c) => Some(c.report()),
            _ => None,
        }
    }
}

impl Spec {
    /// The robot whose model the controller uses.
    fn robot(&self, py: Python<'_>) -> PyResult<Arc<brachia::Robot>> {
        Ok(match self {
            Spec::Tvlqr(r, ..) | Spec::Pd(r, ..) | Spec::OpenLoop(r, _) => r.clone(),
            Spec::Mpc(m) => m.get().lock(py)?.inner.robot().clone(),
            Spec::Kalman(i, _) | Spec::Replanning(i, _) | Spec::Adaptive(i, _) => i.robot(py)?,
        })
    }

    /// The reference it tracks.
    pub(crate) fn reference(&self, py: Python<'_>) -> PyResult<Arc<Trajectory>> {
        Ok(match self {
            Spec::Tvlqr(_, t, _) | Spec::Pd(_, t, _) | Spec::OpenLoop(_, t) => t.clone(),
            Spec::Mpc(m) => m.get().lock(py)?.inner.reference().clone(),
            Spec::Kalman(i, _) | Spec::Replanning(i, _) | Spec::Adaptive(i, _) => {
                i.reference(py)?
            }
        })
    }

    /// Whether it is an `Mpc`, bare or behind the Kalman filter (what re-planning wraps).
    fn is_mpc(&self, kalman_too: bool) -> bool {
        match self {
            Spec::Mpc(_) => true,
            Spec::Kalman(i, _) => kalman_too && i.is_mpc(false),
            _ => false,
        }
    }

    /// The spec with its `Mpc` copied (the GIL held, the `Mpc` locked for the copy).
    pub(crate) fn resolve(&self, py: Python<'_>) -> PyResult<Plain> {
        Ok(match self {
            Spec::Tvlqr(r, t, s) => Plain::Tvlqr(r.clone(), t.clone(), s.clone()),
            Spec::Pd(r, t, s) => Plain::Pd(r.clone(), t.clone(), s.clone()),
            Spec::OpenLoop(r, t) => Plain::OpenLoop(r.clone(), t.clone()),
            Spec::Mpc(m) => Plain::Mpc(Box::new(m.get().lock(py)?.inner.clone())),
            Spec::Kalman(i, s) => Plain::Kalman(Box::new(i.resolve(py)?), *s),
            Spec::Replanning(i, p) => Plain::Replanning(
                Box::new(i.resolve(py)?),
                Box::new(ReplanParts {
                    task: p.task.clone(),
                    planner: p.planner.clone(),
                    nlp: p.nlp.clone(),
                    settings: p.settings.clone(),
                }),
            ),
            Spec::Adaptive(i, s) => Plain::Adaptive(Box::new(i.resolve(py)?), *s),
        })
    }
}

impl Plain {
    /// The robot and the reference of the innermost controller.
    fn parts(&self) -> (Arc<brachia::Robot>, Arc<Trajectory>) {
        match self {
            Plain::Tvlqr(r, t, _) | Plain::Pd(r, t, _) | Plain::OpenLoop(r, t) => {
                (r.clone(), t.clone())
            }
            Plain::Mpc(m) => (m.robot().clone(), m.reference().clone()),
            Plain::Kalman(i, _) | Plain::Replanning(i, _) | Plain::Adaptive(i, _) => i.parts(),
        }
    }

    /// A controller without the typed wrappers (the tracking controller, maybe filtered).
    fn base(self, control_dt: f64) -> Result<SendController, brachia::Error> {
        Ok(match self {
            Plain::Tvlqr(r, t, s) => Box::new(TvlqrCtrl::new(r, t, s)?),
            Plain::Pd(r, t, s) => Box::new(PdCtrl::new(r, t, s)?),
            Plain::OpenLoop(r, t) => Box::new(OpenLoopCtrl::new(r, t)?),
            Plain::Mpc(m) => m,
            Plain::Kalman(i, s) => {
                let (r, t) = i.parts();
                Box::new(Estimated::new(i.base(control_dt)?, r, t, s, control_dt)?)
            }
            Plain::Replanning(..) | Plain::Adaptive(..) => {
                unreachable!("the wrappers are built by Plain::build")
            }
        })
    }

    /// The re-planner around `inner`.
    fn replanning(
        inner: Plain,
        p: ReplanParts,
        control_dt: f64,
        cancel: &brachia::CancelToken,
    ) -> Result<Replanning<SendController>, brachia::Error> {
        let (robot, reference) = inner.parts();
        let nlp = NlpSettings {
            cancel: Some(cancel.clone()),
            ..p.nlp
        };
        let base = inner.base(control_dt)?;
        Replanning::build(
            base, robot, &p.task, &p.planner, &nlp, reference, p.settings,
        )
    }

    /// Build the controller for a closed loop of period `control_dt`; `cancel` stops a wrapper's
    /// solves (Ctrl-C).
    pub(crate) fn build(
        self,
        control_dt: f64,
        cancel: &brachia::CancelToken,
    ) -> Result<Built, brachia::Error> {
        Ok(match self {
            Plain::Replanning(i, p) => {
                Built::Replanning(Box::new(Self::replanning(*i, *p, control_dt, cancel)?))
            }
            Plain::Adaptive(i, s) => {
                let (robot, _) = i.parts();
                match *i {
                    Plain::Replanning(ii, p) => {
                        let r = Self::replanning(*ii, *p, control_dt, cancel)?;
                        Built::AdaptiveReplanning(Box::new(Adaptive::new(r, robot, s)?))
                    }
                    inner => {
                        Built::Adaptive(Box::new(Adaptive::new(inner.base(control_dt)?, robot, s)?))
                    }
                }
            }
            other => Built::Plain(other.base(control_dt)?),
        })
    }
}

/// The spec of a controller object (`None` when `obj` is none of them).
pub(crate) fn spec_of(obj: &Bound<'_, PyAny>) -> Option<Arc<Spec>> {
    if let Ok(m) = obj.cast::<Mpc>() {
        return Some(Arc::new(Spec::Mpc(m.clone().unbind())));
    }
    macro_rules! try_class {
        ($($c:ty),*) => {$(
            if let Ok(c) = obj.cast::<$c>() {
                return Some(c.get().spec.clone());
            }
        )*};
    }
    try_class!(Tvlqr, Pd, OpenLoop, Kalman, ReplanningCtrl, AdaptiveCtrl);
    None
}

/// The spec of the controller a wrapper wraps.
fn inner_spec(obj: &Bound<'_, PyAny>, wrapper: &str) -> PyResult<Arc<Spec>> {
    spec_of(obj).ok_or_else(|| {
        bad(format!(
            "{wrapper}: controller: expected a controller object (Mpc, Tvlqr, Pd, Kalman, \
             Replanning), got {}",
            obj.get_type()
                .name()
                .map(|n| n.to_string())
                .unwrap_or_default()
        ))
    })
}

/// Settings of type `T` from a dict and keyword arguments, checked by `check`; `name` names them.
fn checked<T: serde::de::DeserializeOwned>(
    settings: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
    name: &str,
    check: impl FnOnce(&T) -> brachia::Result<()>,
) -> PyResult<T> {
    let s: T = settings_from(settings, kwargs, name)?;
    check(&s).map_err(|e| rs(named(e, name)))?;
    Ok(s)
}

/// The recipe of a feedback controller along `reference` and its settings: a dict and keyword
/// arguments (`name` names them in errors) checked by `validate` for the robot's link count.
fn feedback<S: serde::de::DeserializeOwned + Clone>(
    robot: &Robot,
    reference: &Bound<'_, PyAny>,
    settings: Option<&Bound<'_, PyAny>>,
    kwargs: Option<&Bound<'_, PyDict>>,
    name: &str,
    validate: fn(&S, usize) -> brachia::Result<()>,
    make: impl FnOnce(Arc<brachia::Robot>, Arc<Trajectory>, S) -> Spec,
) -> PyResult<(Arc<Spec>, S)> {
    let n = robot.inner.n();
    let s = checked(settings, kwargs, name, |s: &S| validate(s, n))?;
    let reference = reference_of(reference)?;
    reference.check_reference(&robot.inner).map_err(rs)?;
    Ok((Arc::new(make(robot.inner.clone(), reference, s.clone())), s))
}

/// A settings check's error under the name the settings go by here (`tvlqr settings`), as the
/// scenario's errors name its file.
fn named(e: brachia::Error, name: &str) -> brachia::Error {
    match e {
        brachia::Error::InvalidValue {
            field,
            value,
            reason,
            ..
        } => brachia::Error::InvalidValue {
            source_name: name.to_string(),
            field,
            value,
            reason,
        },
        other => other,
    }
}

/// The `#[pymethods]` of a controller class: the items given (its constructor), `__repr__`
/// (`Name(...)`) and, when a docstring subject is given (`"The settings"`), the getter `settings`
/// (the class's `settings` field, defaults filled in, as a dict).
macro_rules! controller_methods {
    ($class:ident, $name:literal, $settings_doc:literal, { $($items:tt)* }) => {
        #[pymethods]
        impl $class {
            $($items)*

            #[doc = concat!($settings_doc, " (defaults filled in) as a dict.")]
            #[getter]
            fn settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
                to_py(py, &self.settings)
            }

            fn __repr__(&self) -> String {
                concat!($name, "(...)").into()
            }
        }
    };
    ($class:ident, $name:literal, { $($items:tt)* }) => {
        #[pymethods]
        impl $class {
            $($items)*

            fn __repr__(&self) -> String {
                concat!($name, "(...)").into()
            }
        }
    };
}

/// Time-varying LQR along the plan (a scenario's ``controller = "tvlqr"``).
///
/// ``Tvlqr(robot, reference, settings=None, **kwargs)``: ``reference`` a ``Plan`` or a
/// ``Trajectory``; ``settings`` (dict) and keyword arguments are ``[tracking.tvlqr]`` fields.
/// Use it as ``track(..., controller=Tvlqr(...))``; every run builds it afresh.
#[pyclass(module = "brachia", frozen)]
pub struct Tvlqr {
    spec: Arc<Spec>,
    settings: TvlqrSettings,
}

controller_methods!(Tvlqr, "Tvlqr", "The settings", {
    #[new]
    #[pyo3(signature = (robot, reference, settings = None, **kwargs))]
    fn new(
        robot: &Robot,
        reference: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let name = "tvlqr settings";
        let (spec, settings) = feedback(
            robot,
            reference,
            settings,
            kwargs,
            name,
            TvlqrSettings::validate,
            Spec::Tvlqr,
        )?;
        Ok(Tvlqr { spec, settings })
    }
});

/// PD on the actuated joints plus the planned torque (a scenario's ``controller = "pd"``).
///
/// ``Pd(robot, reference, settings=None, **kwargs)``: ``settings`` and keyword arguments are
/// ``[tracking.pd]`` fields.
#[pyclass(module = "brachia", frozen)]
pub struct Pd {
    spec: Arc<Spec>,
    settings: PdSettings,
}

controller_methods!(Pd, "Pd", "The settings", {
    #[new]
    #[pyo3(signature = (robot, reference, settings = None, **kwargs))]
    fn new(
        robot: &Robot,
        reference: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let name = "pd settings";
        let (spec, settings) = feedback(
            robot,
            reference,
            settings,
            kwargs,
            name,
            PdSettings::validate,
            Spec::Pd,
        )?;
        Ok(Pd { spec, settings })
    }
});

/// The planned torques replayed without feedback (a scenario's ``controller = "open-loop"``).
#[pyclass(module = "brachia", frozen)]
pub struct OpenLoop {
    spec: Arc<Spec>,
}

controller_methods!(OpenLoop, "OpenLoop", {
    #[new]
    fn new(robot: &Robot, reference: &Bound<'_, PyAny>) -> PyResult<Self> {
        let reference = reference_of(reference)?;
        reference.check_reference(&robot.inner).map_err(rs)?;
        Ok(OpenLoop {
            spec: Arc::new(Spec::OpenLoop(robot.inner.clone(), reference)),
        })
    }
});

/// A controller fed through the Kalman filter along its plan (a scenario's ``kalman = true``).
///
/// ``Kalman(controller, settings=None, **kwargs)``: ``controller`` an ``Mpc``, ``Tvlqr`` or ``Pd``;
/// ``settings`` and keyword arguments are ``[tracking.estimator]`` fields (noise model, known
/// delays). The filter runs at the run's ``control_dt``.
#[pyclass(module = "brachia", frozen)]
pub struct Kalman {
    spec: Arc<Spec>,
    settings: EstimatorSettings,
}

controller_methods!(Kalman, "Kalman", "The filter's settings", {
    #[new]
    #[pyo3(signature = (controller, settings = None, **kwargs))]
    fn new(
        controller: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let inner = inner_spec(controller, "Kalman")?;
        match &*inner {
            Spec::Mpc(_) | Spec::Tvlqr(..) | Spec::Pd(..) => {}
            _ => {
                return Err(bad(
                    "Kalman: controller: the filter feeds an Mpc, a Tvlqr or a Pd (the open-loop \
                     replay reads no measurement; wrap the filtered controller in Replanning or \
                     Adaptive, not the other way round)",
                ))
            }
        }
        let s: EstimatorSettings = checked(
            settings,
            kwargs,
            "kalman settings",
            |s: &EstimatorSettings| s.validate(),
        )?;
        Ok(Kalman {
            spec: Arc::new(Spec::Kalman(inner, s)),
            settings: s,
        })
    }
});

/// Online re-planning around the MPC (a scenario's ``[tracking] replan``, docs/replanning.md).
///
/// ``Replanning(controller, task, plan_settings=None, settings=None, **kwargs)``: ``controller`` an
/// ``Mpc`` (or ``Kalman(Mpc)``) tracking a plan of ``task`` (the dict ``brachia.plan`` takes);
/// ``plan_settings`` the planner settings (``Scenario.plan_settings``, with ``solver``); ``settings``
/// and keyword arguments are ``[tracking.replan]`` fields. Each run plans the swing cold on the
/// re-planning mesh first, then re-plans from measured states; ``TrackResult.report["replans"]``
/// lists them.
#[pyclass(module = "brachia", frozen, name = "Replanning")]
pub struct ReplanningCtrl {
    spec: Arc<Spec>,
    settings: ReplanSettings,
}

controller_methods!(ReplanningCtrl, "Replanning", "The re-planning settings", {
    #[new]
    #[pyo3(signature = (controller, task, plan_settings = None, settings = None, **kwargs))]
    fn new(
        py: Python<'_>,
        controller: &Bound<'_, PyAny>,
        task: &Bound<'_, PyAny>,
        plan_settings: Option<&Bound<'_, PyAny>>,
        settings: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let inner = inner_spec(controller, "Replanning")?;
        if !inner.is_mpc(true) {
            return Err(bad(
                "Replanning: controller: online re-planning wraps the MPC only (an Mpc, or \
                 Kalman(Mpc))",
            ));
        }
        let src = "replan settings";
        let s: ReplanSettings =
            checked(settings, kwargs, src, |s: &ReplanSettings| s.validate(src))?;
        let task = task_from(task)?;
        let (planner, nlp) = plan_settings_from(plan_settings, None)?;
        let robot = inner.robot(py)?;
        let reference = inner.reference(py)?;
        // the settings and the task as a scenario's are checked, and the re-planning mesh's grid
        planner.validate(robot.n(), "plan_settings").map_err(rs)?;
        nlp.validate().map_err(rs)?;
        brachia::planning::validate_task(&robot, &task, &planner, "task", "task.").map_err(rs)?;
        let mesh = PlannerSettings {
            knot_dt: s.knot_dt_s,
            ..planner.clone()
        };
        mesh.grid(robot.n(), reference.duration(), src)
            .map_err(rs)?;
        let parts = ReplanParts {
            task,
            planner,
            nlp,
            settings: s.clone(),
        };
        Ok(ReplanningCtrl {
            spec: Arc::new(Spec::Replanning(inner, Box::new(parts))),
            settings: s,
        })
    }
});

/// The MPC fed an online estimate of the robot's masses and inertias (a scenario's
/// ``[tracking] estimate_params``, docs/estimation.md).
///
/// ``Adaptive(controller, settings=None, **kwargs)``: ``controller`` an ``Mpc`` or
/// ``Replanning(Mpc)`` (the estimate then feeds the re-planner too); ``settings`` and keyword
/// arguments are ``[tracking.estimate_params]`` fields. ``TrackResult.report["estimate"]`` holds the
/// estimate and its history.
#[pyclass(module = "brachia", frozen, name = "Adaptive")]
pub struct AdaptiveCtrl {
    spec: Arc<Spec>,
    settings: ParamEstimatorSettings,
}

controller_methods!(AdaptiveCtrl, "Adaptive", "The estimator's settings", {
    #[new]
    #[pyo3(signature = (controller, settings = None, **kwargs))]
    fn new(
        controller: &Bound<'_, PyAny>,
        settings: Option<&Bound<'_, PyAny>>,
        kwargs: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Self> {
        let inner = inner_spec(controller, "Adaptive")?;
        let fits = match &*inner {
            Spec::Mpc(_) => true,
            Spec::Replanning(i, _) => i.is_mpc(false),
            _ => false,
        };
        if !fits {
            return Err(bad(
                "Adaptive: controller: the mass estimate feeds the MPC only: an Mpc or \
                 Replanning(Mpc), without the Kalman filter",
            ));
        }
        let src = "estimate_params settings";
        let s: ParamEstimatorSettings =
            checked(settings, kwargs, src, |s: &ParamEstimatorSettings| {
                s.validate(src)
            })?;
        Ok(AdaptiveCtrl {
            spec: Arc::new(Spec::Adaptive(inner, s)),
            settings: s,
        })
    }
});
