//! `Scenario`: a scenario file (robot, task, planner, solver, tracking, plant), planned and tracked
//! exactly as `brachia plan` and `brachia track` do (the same library calls, the same reports and run
//! folders).

use crate::convert::{bad, rs};
use crate::dicts::to_py;
use crate::interrupt::interruptible_owned;
use crate::model::Robot;
use crate::planning::Plan;
use crate::sim::TrackResult;
use brachia::model::RobotParams;
use brachia_experiments::ladder::{swing_scenario, LoadedLadder};
use brachia_experiments::scenario::LoadedScenario;
use brachia_experiments::{
    run_plan, run_track, ControllerKind, LadderScenario, PlanReport, PlantKind, RunFolder,
    TrackOutcome, Uses,
};
use pyo3::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// The report.json of a run folder (`null` if absent or unreadable, which a folder built by the
/// library never is).
fn folder_report(f: &RunFolder) -> serde_json::Value {
    f.get("report.json")
        .and_then(|b| serde_json::from_slice(b).ok())
        .unwrap_or_default()
}

/// A scenario file, loaded and validated (nothing solved yet).
///
/// ``Scenario.from_toml(path)`` reads and checks every section, as ``brachia track`` does (a
/// traverse scenario, one with a ``[ladder]`` section, as ``brachia traverse`` does); errors name
/// the file, the field as written (``planner.knot_dt``), the value and the rule.
#[pyclass(module = "brachia", frozen)]
pub struct Scenario {
    /// The swing scenario (of a traverse scenario: its first swing).
    pub(crate) ls: LoadedScenario,
    robot: Arc<brachia::Robot>,
    /// The traverse scenario, when it is one.
    pub(crate) ladder: Option<Arc<LoadedLadder>>,
}

/// Whether the TOML text is a traverse scenario (it has a `[ladder]` table); text that does not
/// parse is left to the scenario reader, whose error names the line.
fn is_ladder(text: &str) -> bool {
    text.parse::<toml::Table>()
        .map(|t| t.contains_key("ladder"))
        .unwrap_or(false)
}

/// A scenario from TOML text: `source` names it in errors, `base` resolves its `params` path.
fn load_scenario(text: &str, source: &Path, base: &Path) -> PyResult<Scenario> {
    if is_ladder(text) {
        let ll = LadderScenario::load_str(text, source, base).map_err(rs)?;
        let n = ll.robot.n();
        let first = swing_scenario(
            &ll.scenario,
            &ll.x0[..n],
            &ll.x0[n..],
            ll.scenario.ladder.bars[0].p(),
            1,
        );
        let ls = LoadedScenario {
            scenario: first,
            robot: ll.robot.clone(),
            path: ll.path.clone(),
        };
        let robot = Arc::new(ll.robot.clone());
        return Ok(Scenario {
            ls,
            robot,
            ladder: Some(Arc::new(ll)),
        });
    }
    let ls =
        brachia_experiments::Scenario::load_str_for(text, source, base, Uses::Track).map_err(rs)?;
    let robot = Arc::new(ls.robot.clone());
    Ok(Scenario {
        ls,
        robot,
        ladder: None,
    })
}

fn controller_kind(name: &str) -> PyResult<ControllerKind> {
    match name {
        "mpc" => Ok(ControllerKind::Mpc),
        "pd" => Ok(ControllerKind::Pd),
        "open-loop" => Ok(ControllerKind::OpenLoop),
        "tvlqr" => Ok(ControllerKind::Tvlqr),
        other => Err(bad(format!(
            "controller = {other:?}: expected \"mpc\", \"pd\", \"open-loop\" or \"tvlqr\""
        ))),
    }
}

fn plant_kind(name: &str) -> PyResult<PlantKind> {
    match name {
        "model" => Ok(PlantKind::Model),
        "rapier" => Ok(PlantKind::Rapier),
        other => Err(bad(format!(
            "plant = {other:?}: expected \"model\" or \"rapier\""
        ))),
    }
}

impl Scenario {
    /// Read a scenario file (a swing or a traverse scenario).
    pub(crate) fn read(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        let text =
            brachia::limits::read_text_capped(&path, brachia::limits::MAX_TOML_BYTES, "TOML file")
                .map_err(rs)?;
        let base = path.parent().unwrap_or(Path::new(".")).to_path_buf();
        py.detach(|| load_scenario(&text, &path, &base))
    }

    /// Run its traverse (a traverse scenario only).
    pub(crate) fn traverse_result(
        &self,
        py: Python<'_>,
    ) -> PyResult<crate::traverse::TraverseResult> {
        match &self.ladder {
            Some(ll) => crate::traverse::run(py, ll),
            None => Err(bad(format!(
                "traverse: {} is a swing scenario; a traverse scenario has a [ladder] section \
                 (scenarios/ladder-even.toml)",
                self.ls.path.display()
            ))),
        }
    }

    /// Refuse a plan made for another robot or another task than this scenario's: every field they
    /// share (the robot's parameters, the start state, the target, the obstacles) must agree.
    fn check_reference(&self, plan: &Plan) -> PyResult<()> {
        let file = self.ls.path.display();
        let (mine, theirs) = (self.robot.params(), plan.robot.params());
        let same_robot = RobotParams {
            name: mine.name.clone(),
            ..theirs.clone()
        } == *mine;
        if !same_robot {
            return Err(bad(format!(
                "reference: a plan for another robot ({:?}, {} links) than {file}'s params ({:?}, \
                 {} links, or other link values): plan it with this scenario",
                theirs.name,
                plan.robot.n(),
                mine.name,
                self.robot.n()
            )));
        }
        let n = self.robot.n();
        let rest = |qd: &[f64]| {
            if qd.is_empty() {
                vec![0.0; n]
            } else {
                qd.to_vec()
            }
        };
        let (a, b) = (&self.ls.scenario.task, &plan.task);
        let fields: [(&str, String, String, bool); 4] = [
            (
                "q0",
                format!("{:?}", b.q0),
                format!("{:?}", a.q0),
                a.q0 == b.q0,
            ),
            (
                "qd0",
                format!("{:?}", rest(&b.qd0)),
                format!("{:?}", rest(&a.qd0)),
                rest(&a.qd0) == rest(&b.qd0),
            ),
            (
                "target",
                format!("{:?}", b.target),
                format!("{:?}", a.target),
                a.target == b.target,
            ),
            (
                "obstacles",
                format!("{:?}", b.obstacles),
                format!("{:?}", a.obstacles),
                a.obstacles == b.obstacles,
            ),
        ];
        match fields.into_iter().find(|f| !f.3) {
            Some((field, theirs, mine, _)) => Err(bad(format!(
                "reference: a plan for another task: its {field} = {theirs}, {file}'s task.{field} = \
                 {mine}; a reference must be planned for this scenario's task"
            ))),
            None => Ok(()),
        }
    }
}

#[pymethods]
impl Scenario {
    /// Read a scenario file (TOML; its ``params`` path is relative to the file) and validate every
    /// section.
    #[staticmethod]
    fn from_toml(py: Python<'_>, path: PathBuf) -> PyResult<Self> {
        Self::read(py, path)
    }

    /// Read a scenario from TOML text, as ``from_toml`` reads a file: its ``params`` path is
    /// relative to ``base_dir`` (default: the working directory), and errors name
    /// ``source_name`` (default ``"<string>"``; its stem is the default scenario name).
    #[staticmethod]
    #[pyo3(signature = (text, base_dir = None, source_name = None))]
    fn from_toml_str(
        py: Python<'_>,
        text: &str,
        base_dir: Option<PathBuf>,
        source_name: Option<String>,
    ) -> PyResult<Self> {
        let max = brachia::limits::MAX_TOML_BYTES;
        let source = PathBuf::from(source_name.unwrap_or_else(|| "<string>".into()));
        if text.len() as u64 > max {
            return Err(bad(format!(
                "{}: {} bytes of TOML text: at most {max}",
                source.display(),
                text.len()
            )));
        }
        let base = base_dir.unwrap_or_else(|| PathBuf::from("."));
        py.detach(|| load_scenario(text, &source, &base))
    }

    /// The scenario's name (default: the file stem).
    #[getter]
    fn name(&self) -> String {
        match &self.ladder {
            Some(ll) => ll.scenario.name.clone(),
            None => self.ls.scenario.name.clone(),
        }
    }

    /// The file it was read from.
    #[getter]
    fn path(&self) -> PathBuf {
        self.ls.path.clone()
    }

    /// The robot of its ``params`` file.
    #[getter]
    fn robot(&self) -> Robot {
        Robot {
            inner: self.robot.clone(),
        }
    }

    /// The ``[task]`` section as a dict (what ``brachia.plan`` takes).
    #[getter]
    fn task<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.ls.scenario.task)
    }

    /// The ``[planner]`` section with its defaults filled in, plus ``solver`` = the ``[solver]``
    /// section (what ``brachia.plan`` takes as settings).
    #[getter]
    fn plan_settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let mut v = serde_json::to_value(&self.ls.scenario.planner).unwrap_or_default();
        if let Some(m) = v.as_object_mut() {
            m.insert(
                "solver".into(),
                serde_json::to_value(&self.ls.scenario.solver).unwrap_or_default(),
            );
        }
        to_py(py, &v)
    }

    /// The ``[tracking.mpc]`` settings (what ``Mpc`` takes).
    #[getter]
    fn mpc_settings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.ls.scenario.tracking.mpc)
    }

    /// Plan the swing as ``brachia plan`` does; the ``Plan`` keeps its run folder (``Plan.write``).
    /// A solve that does not converge is a ``Plan`` with its status.
    fn plan(&self, py: Python<'_>) -> PyResult<Plan> {
        let (ls, cancel) = with_cancel(&self.ls);
        let run = {
            let ls = ls.clone();
            interruptible_owned(py, &cancel, move || run_plan(&ls))?.map_err(rs)?
        };
        let report = folder_report(&run.folder);
        Ok(Plan::new(
            self.robot.clone(),
            ls.scenario.task.clone(),
            run.plan,
            report,
            Some(run.folder),
        ))
    }

    /// Plan (or take ``reference``, a ``Plan`` of this scenario: made for its robot and task, else
    /// ``BrachiaError``) and track it in closed loop as ``brachia track`` does. ``controller`` (``"mpc"``, ``"pd"``, ``"open-loop"``) and ``plant``
    /// (``"model"``, ``"rapier"``) default to the scenario's. When the plan does not converge nothing
    /// is tracked: ``TrackResult.tracked`` is False and ``TrackResult.plan`` has the status.
    #[pyo3(signature = (controller = None, plant = None, reference = None))]
    fn track(
        &self,
        py: Python<'_>,
        controller: Option<&str>,
        plant: Option<&str>,
        reference: Option<&Bound<'_, Plan>>,
    ) -> PyResult<TrackResult> {
        let ls = &self.ls;
        let c = match controller {
            Some(name) => controller_kind(name)?,
            None => ls.scenario.tracking.controller,
        };
        let p = match plant {
            Some(name) => plant_kind(name)?,
            None => ls.scenario.plant.kind,
        };
        let given = match reference {
            Some(r) => {
                let r = r.get();
                self.check_reference(r)?;
                let report: PlanReport = serde_json::from_value(r.report.clone()).map_err(|e| {
                    bad(format!(
                        "reference: its report is not a brachia plan report: {e}"
                    ))
                })?;
                Some(((*r.trajectory).clone(), report))
            }
            None => None,
        };
        // a setting that would have no effect on this controller and plant is refused, as the CLI does
        brachia_experiments::check_settings_apply(ls, c, p).map_err(rs)?;
        let (ls, cancel) = with_cancel(ls);
        let out = {
            let ls = ls.clone();
            interruptible_owned(py, &cancel, move || run_track(&ls, c, p, given))?.map_err(rs)?
        };
        // a plan of the run as a Python object, its report read from its folder
        let plan_of = |pr: brachia_experiments::PlanRun| {
            let rep = folder_report(&pr.folder);
            let task = ls.scenario.task.clone();
            Plan::new(self.robot.clone(), task, pr.plan, rep, Some(pr.folder))
        };
        match out {
            TrackOutcome::Tracked(run) => {
                let report = folder_report(&run.folder);
                let plan = match run.plan {
                    Some(pr) => Some(Py::new(py, plan_of(pr))?),
                    None => reference.map(|r| r.clone().unbind()),
                };
                Ok(TrackResult::new(
                    run.log,
                    Some(run.summary),
                    report,
                    plan,
                    Some(run.folder),
                ))
            }
            TrackOutcome::PlanFailed(pr) => Ok(TrackResult::new(
                Default::default(),
                None,
                serde_json::Value::Null,
                Some(Py::new(py, plan_of(*pr))?),
                None,
            )),
        }
    }

    /// Whether it is a traverse scenario (a ``[ladder]`` section: ``traverse()``; ``plan``,
    /// ``track`` and the other swing views are of its first swing).
    #[getter]
    fn is_traverse(&self) -> bool {
        self.ladder.is_some()
    }

    /// The ``[tracking]`` section with its defaults filled in (``controller``, ``mpc``, ``pd``,
    /// ``tvlqr``, ``kalman``, ``estimator``, ``control_dt``, ``replan``, ``estimate_params``, ...):
    /// the settings of the controller objects.
    #[getter]
    fn tracking<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.ls.scenario.tracking)
    }

    /// The ``[disturbances]`` section with its defaults filled in (what ``track`` takes as
    /// ``disturbances``; of a traverse scenario, its own section).
    #[getter]
    fn disturbances<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match &self.ladder {
            Some(ll) => to_py(py, &ll.scenario.disturbances),
            None => to_py(py, &self.ls.scenario.disturbances),
        }
    }

    /// The ``[plant]`` section with its defaults filled in.
    #[getter]
    fn plant<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.ls.scenario.plant)
    }

    /// Run the traverse of a traverse scenario as ``brachia traverse`` does (every swing planned
    /// from the state the last one left, tracked, the grip switched at every bar); Ctrl-C stops it
    /// (``KeyboardInterrupt``). Returns a ``TraverseResult``.
    fn traverse(&self, py: Python<'_>) -> PyResult<crate::traverse::TraverseResult> {
        self.traverse_result(py)
    }

    fn __repr__(&self) -> String {
        format!(
            "Scenario(name={:?}, path={:?}, n_links={}{})",
            self.ladder
                .as_ref()
                .map_or(&self.ls.scenario.name, |l| &l.scenario.name),
            self.ls.path.display().to_string(),
            self.robot.n(),
            if self.ladder.is_some() {
                ", traverse"
            } else {
                ""
            }
        )
    }
}

/// A copy of `ls` whose solves and closed loops stop once the returned token is set (Ctrl-C).
fn with_cancel(ls: &LoadedScenario) -> (LoadedScenario, brachia::CancelToken) {
    let cancel = brachia::CancelToken::new();
    let mut ls = ls.clone();
    ls.scenario.solver.cancel = Some(cancel.clone());
    (ls, cancel)
}

/// Run the traverse of ``scenario``: a traverse ``Scenario`` or the path of a traverse scenario
/// file (a ``[ladder]`` section), as ``brachia traverse`` does. Returns a ``TraverseResult`` (also
/// when a bar was missed: ``completed`` is False and ``status`` says where); raises
/// ``BrachiaError`` on bad input and ``KeyboardInterrupt`` on Ctrl-C.
#[pyfunction]
pub(crate) fn traverse(
    py: Python<'_>,
    scenario: &Bound<'_, PyAny>,
) -> PyResult<crate::traverse::TraverseResult> {
    if let Ok(s) = scenario.cast::<Scenario>() {
        return s.get().traverse_result(py);
    }
    let path: PathBuf = scenario.extract().map_err(|_| {
        bad("traverse: scenario: expected a Scenario or the path of a traverse scenario file")
    })?;
    let s = Scenario::read(py, path)?;
    s.traverse_result(py)
}
