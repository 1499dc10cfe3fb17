//! `benchmark(...)`: the robustness benchmark of a scenario from Python, with Python policies scored
//! beside the built-in controllers on the same draws (`brachia_experiments::run_benchmark_with`).

use crate::convert::{bad, rs};
use crate::dicts::to_py;
use crate::interrupt::interruptible;
use crate::policy::{ErrorSink, PyPolicy};
use crate::scenario::Scenario;
use brachia::sim::Controller;
use brachia_experiments::benchmark::controllers;
use brachia_experiments::{
    no_progress, run_benchmark_with, run_plan, BenchmarkSettings, ExtraController, Uses,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

/// Run the robustness benchmark of ``scenario`` (a path or a ``Scenario``): plan it, then run every
/// chosen controller through the sweeps and the Monte Carlo draws, as ``brachia benchmark`` does.
///
/// ``controllers``: a dict ``name -> policy`` of callables ``policy(t, x) -> tau`` (N m) scored
/// beside the built-in ones (an object with ``reset()`` has it called before each run);
/// ``builtin``: the built-in controllers to run (``None``: all; ``[]``: none). ``levels`` per
/// sweep (>= 2), ``monte_carlo_runs`` (0 skips it; those runs use the rapier plant),
/// ``family_runs`` (runs of each other Monte Carlo family, as ``--family-runs``; 0 skips them), ``sweeps``
/// (names; ``None``: all), ``seed``. With Python policies the runs go one at a time (they need the
/// GIL). Returns a dict: ``scorecard`` (the ``scorecard.json`` of ``brachia benchmark``),
/// ``runs_csv`` (the text of its ``runs.csv``, led by the schema line ``# brachia runs schema 2``;
/// docs/formats.md) and ``summary_md`` (text), or ``plan_status`` when the plan did not converge. An
/// exception raised by a policy is raised here after the benchmark stops.
#[pyfunction]
#[pyo3(signature = (scenario, controllers = None, builtin = None, levels = None,
    monte_carlo_runs = None, family_runs = None, sweeps = None, seed = None))]
pub(crate) fn benchmark<'py>(
    py: Python<'py>,
    scenario: &Bound<'py, PyAny>,
    controllers: Option<&Bound<'py, PyDict>>,
    builtin: Option<Vec<String>>,
    levels: Option<&Bound<'py, PyAny>>,
    monte_carlo_runs: Option<&Bound<'py, PyAny>>,
    family_runs: Option<&Bound<'py, PyAny>>,
    sweeps: Option<Vec<String>>,
    seed: Option<&Bound<'py, PyAny>>,
) -> PyResult<Bound<'py, PyDict>> {
    // the counts and the seed are read as the CLI reads its flags: a negative, fractional or
    // oversized value is refused naming the argument, before any run (the range is checked by
    // BenchmarkSettings::validate)
    let levels = whole(levels, 3, "levels")? as usize;
    let monte_carlo_runs = whole(monte_carlo_runs, 6, "monte_carlo_runs")? as usize;
    let family_runs = whole(family_runs, 1, "family_runs")? as usize;
    let seed = whole(seed, 0, "seed")?;
    let ls = if let Ok(sc) = scenario.cast::<Scenario>() {
        sc.get().ls.clone()
    } else {
        let path: PathBuf = scenario
            .extract()
            .map_err(|_| bad("scenario: expected a path to a scenario file or a Scenario"))?;
        brachia_experiments::Scenario::load_for(&path, Uses::Track).map_err(rs)?
    };
    let sink: ErrorSink = Arc::new(Mutex::new(None));
    let mut extra = Vec::new();
    for (k, v) in controllers.into_iter().flat_map(|d| d.iter()) {
        let name: String = k
            .extract()
            .map_err(|_| bad("controllers: the keys are names (strings)"))?;
        if !v.is_callable() {
            return Err(bad(format!(
                "controllers[{name:?}]: expected a callable policy(t, x) -> tau"
            )));
        }
        let f = v.unbind();
        let sink = sink.clone();
        extra.push(ExtraController {
            name,
            build: Box::new(move |_, _| {
                let p = Python::attach(|py| PyPolicy::for_run(py, &f, sink.clone()));
                match p {
                    Ok(p) => Ok(Box::new(p) as Box<dyn Controller>),
                    Err(e) => {
                        let text = e.to_string();
                        if let Ok(mut slot) = sink.lock() {
                            slot.get_or_insert(e);
                        }
                        Err(brachia::Error::invalid(
                            "benchmark",
                            "controllers",
                            "reset()",
                            text,
                        ))
                    }
                }
            }),
        });
    }
    let all: Vec<String> = controllers_names();
    let mut settings = BenchmarkSettings {
        levels,
        monte_carlo_runs,
        family_runs,
        only_sweeps: sweeps.unwrap_or_default(),
        only_controllers: builtin.unwrap_or(all),
        seed,
        ..BenchmarkSettings::quick()
    };
    if !extra.is_empty() {
        settings.jobs = Some(1);
    }
    settings.validate().map_err(rs)?;
    let token = brachia::CancelToken::new();
    settings.cancel = Some(token.clone());
    let mut ls = ls;
    ls.scenario.solver.cancel = Some(token.clone());
    let out = interruptible(py, &token, || {
        let plan = run_plan(&ls)?;
        if !plan.plan.converged() {
            return Ok(Err(format!("{:?}", plan.plan.status)));
        }
        let reference = Arc::new(plan.plan.trajectory.clone());
        let b = run_benchmark_with(&ls, reference, &settings, &extra, &no_progress)?;
        Ok::<_, brachia::Error>(Ok(b))
    })?;
    if let Some(e) = sink.lock().ok().and_then(|mut s| s.take()) {
        return Err(e);
    }
    let d = PyDict::new(py);
    match out.map_err(rs)? {
        Err(status) => d.set_item("plan_status", status)?,
        Ok(b) => {
            d.set_item("scorecard", to_py(py, &b.scorecard_json())?)?;
            // the text of runs.csv as `brachia benchmark` writes it: its schema line first
            let runs = brachia_experiments::schema::stamp("runs.csv", b.runs_csv().into_bytes());
            d.set_item("runs_csv", String::from_utf8_lossy(&runs))?;
            d.set_item("summary_md", b.summary_md())?;
        }
    }
    Ok(d)
}

/// The names of the built-in controllers.
fn controllers_names() -> Vec<String> {
    controllers().iter().map(|c| c.name.to_string()).collect()
}

/// `obj` (`None`: `default`) as a count or seed: an integer (or anything with `__index__`, not a
/// bool or a float) in 0..=u64::MAX; `name` names it.
fn whole(obj: Option<&Bound<'_, PyAny>>, default: u64, name: &str) -> PyResult<u64> {
    let Some(obj) = obj.filter(|o| !o.is_none()) else {
        return Ok(default);
    };
    let shown = || {
        obj.repr()
            .map(|r| r.to_string())
            .unwrap_or_else(|_| "?".into())
    };
    if obj.is_instance_of::<pyo3::types::PyBool>() {
        return Err(bad(format!("{name} = {}: must be a whole number", shown())));
    }
    let v: i128 = obj
        .extract()
        .map_err(|_| bad(format!("{name} = {}: must be a whole number", shown())))?;
    u64::try_from(v).map_err(|_| bad(format!("{name} = {v}: must be in 0..={}", u64::MAX)))
}
