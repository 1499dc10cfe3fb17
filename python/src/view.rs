//! The run page (`view.html`, docs/viewer.md) from Python: a `Plan` or a scenario's `TrackResult`
//! inline in Jupyter (`_repr_html_`, the page in a sandboxed frame) and `brachia.view(folder)`.

use crate::convert::{exp, rs};
use brachia_experiments::plan_run::PlanReport;
use brachia_experiments::view::{plan_view, render, PlanParts};
use brachia_experiments::{staging, ExpError, RunFolder};
use pyo3::prelude::*;
use std::path::PathBuf;

/// Height of the inline frame in a notebook, px (the stage and the first plots on a laptop screen).
const FRAME_HEIGHT_PX: u32 = 760;

/// The page `html` in a frame of a notebook's width: the page's own script runs in the frame
/// (`srcdoc`, sandboxed: no access to the notebook), nothing is loaded from elsewhere.
pub(crate) fn frame(html: &str) -> String {
    let doc = html.replace('&', "&amp;").replace('"', "&quot;");
    format!(
        "<iframe srcdoc=\"{doc}\" sandbox=\"allow-scripts\" title=\"brachia run\" \
         style=\"width: 100%; height: {FRAME_HEIGHT_PX}px; border: 0\"></iframe>"
    )
}

/// The page of a plan: its report read as `brachia plan` writes it (`None` when it does not read).
pub(crate) fn plan_page(
    report: &serde_json::Value,
    task: &brachia::planning::SwingTask,
    robot: &brachia::Robot,
    trajectory: &brachia::trajectory::Trajectory,
) -> Option<String> {
    let rep: PlanReport = serde_json::from_value(report.clone()).ok()?;
    if trajectory.len() < 2 {
        return None;
    }
    Some(render(&plan_view(PlanParts {
        name: &rep.scenario,
        report: &rep,
        task,
        robot,
        trajectory,
    })))
}

/// The page of a run whose folder is in memory: written into a private staging folder in the
/// temporary folder (locked while this process lives, cleared by a later call if it dies), read back
/// as `brachia view` reads it, then removed.
pub(crate) fn folder_page(folder: &RunFolder) -> PyResult<String> {
    let tmp = std::env::temp_dir();
    let stage = staging::create_unique(&tmp, staging::VIEW_STAGE_PREFIX).map_err(|e| {
        exp(ExpError::Write {
            path: tmp.join(staging::VIEW_STAGE_PREFIX),
            source: e,
        })
    })?;
    let dir = stage.join("run");
    let page = folder
        .write(&dir)
        .map_err(exp)
        .and_then(|()| brachia_experiments::view::view_html(&dir).map_err(rs));
    staging::remove(&stage);
    page
}

/// Write `view.html` into the run folder `path` (any folder `brachia view` takes) and return its path.
#[pyfunction]
pub(crate) fn view_folder(py: Python<'_>, path: PathBuf) -> PyResult<PathBuf> {
    py.detach(|| brachia_experiments::view::write_view(&path))
        .map_err(exp)
}
