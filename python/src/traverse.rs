//! Traverses from Python: `brachia.traverse(scenario)` / `Scenario.traverse()` (in `crate::scenario`)
//! run a ladder traverse as `brachia traverse` does (`brachia_experiments::run_traverse_cancellable`)
//! and return a `TraverseResult`: the per-swing outcomes, the whole traverse in the world frame, the
//! grip switches, the report, the run folder and the run page.
//!
//! Conventions: world frame (m), traverse time (s, from the start of the first swing); a row of the
//! arrays is a control instant of one swing (each swing's rows follow the last one's, so the time at
//! a switch appears twice: the end of one swing and the start of the next); `x = [q, qd]` of the
//! chain holding the bar in that row (its own link order: hand A holds on even swings, hand B on
//! odd ones); `joints` in the parameters file's order (hand A first).

use crate::convert::{arr1, arr2, exp, rs};
use crate::dicts::to_py;
use crate::interrupt::interruptible_owned;
use brachia_experiments::ladder::LoadedLadder;
use brachia_experiments::view::{params_toml, traverse_run_page, PARAMS_FILE, VIEW_FILE};
use brachia_experiments::{check_ladder_settings_apply, run_traverse_cancellable, Traverse};
use pyo3::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;

/// A traverse run from Python: the arrays, the swings, the grip switches and the report of
/// ``brachia traverse``; ``write(out)`` writes its run folder, ``brachia.view(result)`` its page.
#[pyclass(module = "brachia", frozen)]
pub struct TraverseResult {
    ll: Arc<LoadedLadder>,
    tr: Traverse,
    report: serde_json::Value,
}

impl TraverseResult {
    /// Rows of every swing's log, in order, as `(swing, row)`.
    fn rows(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.tr
            .logs
            .iter()
            .enumerate()
            .flat_map(|(k, log)| (0..log.len()).map(move |r| (k, r)))
    }

    /// One value per row, from `f(swing, row)`, flattened.
    fn per_row(&self, f: impl Fn(usize, usize) -> Vec<f64>) -> Vec<f64> {
        self.rows().flat_map(|(k, r)| f(k, r)).collect()
    }
}

#[pymethods]
impl TraverseResult {
    /// True when every bar was caught.
    #[getter]
    fn completed(&self) -> bool {
        self.tr.status.completed()
    }

    /// How it ended, in words (``"completed: every bar caught"``, a missed capture, a failed plan).
    #[getter]
    fn status(&self) -> String {
        self.tr.status.to_string()
    }

    /// Every tracked swing's outcome (a list of dicts: bars, holding hand, grip, times, planner
    /// status and work, energy by eq. 18, positive work, capture error, switch residual, contacts,
    /// re-plans), as ``report["swings"]``.
    #[getter]
    fn swings<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.tr.swings)
    }

    /// The grip switches, one dict per tracked swing: ``swing``, ``bar`` (the bar it aimed at),
    /// ``t_s`` (traverse time at its end), ``captured``, ``hand`` (the hand that holds after it:
    /// 0 = A, 1 = B), ``switch_residual_m_s``, ``capture_impact_j`` and, on the rapier plant,
    /// ``regrip`` (joint positions and velocities before and after the chain was rebuilt).
    #[getter]
    fn grip_switches<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v: Vec<serde_json::Value> = self
            .tr
            .swings
            .iter()
            .map(|s| {
                serde_json::json!({
                    "swing": s.swing,
                    "bar": s.to_bar,
                    "t_s": s.t_start_s + s.duration_s,
                    "captured": s.captured,
                    "hand": 1 - s.holding_hand,
                    "switch_residual_m_s": s.switch_residual_m_s,
                    "capture_impact_j": s.capture_impact_j,
                    "regrip": s.regrip,
                })
            })
            .collect();
        to_py(py, &v)
    }

    /// Traverse time of every row, s, shape ``(rows,)``.
    #[getter]
    fn t<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.per_row(|k, r| {
            let log = &self.tr.logs[k];
            vec![self.tr.swings[k].t_start_s - log.t[0] + log.t[r]]
        });
        arr1(py, &v)
    }

    /// The swing of every row (0 = from bar 0 to bar 1), shape ``(rows,)``.
    #[getter]
    fn swing<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.per_row(|k, _| vec![k as f64]);
        arr1(py, &v)
    }

    /// States ``[q, qd]`` of the holding chain, shape ``(rows, 2n)``.
    #[getter]
    fn x<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.per_row(|k, r| self.tr.logs[k].x(r).to_vec());
        arr2(py, v, 2 * self.ll.robot.n())
    }

    /// Applied torques of the holding chain's joints 2..n, N m, shape ``(rows, n - 1)``.
    #[getter]
    fn tau<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.per_row(|k, r| self.tr.logs[k].tau(r).to_vec());
        arr2(py, v, self.ll.robot.n() - 1)
    }

    /// The swinging hand in the world, m, shape ``(rows, 2)``.
    #[getter]
    fn ee<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let v = self.per_row(|k, r| {
            let (e, g) = (self.tr.logs[k].ee[r], self.tr.swings[k].grip);
            vec![e[0] + g[0], e[1] + g[1]]
        });
        arr2(py, v, 2)
    }

    /// Every joint in the world (hand A, the inner joints, hand B), m, shape ``(rows, n + 1, 2)``.
    #[getter]
    fn joints<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let n = self.ll.robot.n();
        let v = self.per_row(|k, r| self.tr.world_joints(k, r).concat());
        let a = arr2(py, v, 2 * (n + 1))?;
        a.call_method1("reshape", ((-1i64, (n + 1) as i64, 2i64),))
    }

    /// The report as a dict (the ``report.json`` of ``brachia traverse``: status, swings, totals).
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        to_py(py, &self.report)
    }

    /// Write the run folder ``brachia traverse`` writes into ``out`` (``traverse.csv``,
    /// ``report.json``, ``scenario.toml``, ``params.toml``, ``view.html``, the figures; rapier:
    /// ``contacts.csv``, ``obstacles.csv``).
    #[pyo3(signature = (out, force = false))]
    fn write(&self, py: Python<'_>, out: PathBuf, force: bool) -> PyResult<()> {
        brachia_experiments::check_out_dir(&out, force).map_err(exp)?;
        py.detach(|| {
            let ll = &*self.ll;
            let mut folder = self.tr.folder(ll).map_err(exp)?;
            folder.add(PARAMS_FILE, params_toml(&ll.robot, &ll.scenario.params));
            if self.tr.logs.iter().map(|l| l.len()).sum::<usize>() >= 2 {
                folder.add(VIEW_FILE, traverse_run_page(ll, &self.tr).map_err(rs)?);
            }
            folder.write(&out).map_err(exp)
        })
    }

    /// The run page (docs/viewer.md) as HTML text; ``None`` when no row was tracked.
    fn _view_html(&self, py: Python<'_>) -> PyResult<Option<String>> {
        if self.tr.logs.iter().map(|l| l.len()).sum::<usize>() < 2 {
            return Ok(None);
        }
        py.detach(|| traverse_run_page(&self.ll, &self.tr))
            .map(Some)
            .map_err(rs)
    }

    /// The run page inline in Jupyter.
    fn _repr_html_(&self, py: Python<'_>) -> PyResult<Option<String>> {
        Ok(self._view_html(py)?.map(|h| crate::view::frame(&h)))
    }

    fn __repr__(&self) -> String {
        format!(
            "TraverseResult(swings={}, completed={}, status={:?})",
            self.tr.swings.len(),
            self.tr.status.completed(),
            self.tr.status.to_string()
        )
    }
}

/// Run the traverse of `ll` (Ctrl-C raises `KeyboardInterrupt`).
pub(crate) fn run(py: Python<'_>, ll: &Arc<LoadedLadder>) -> PyResult<TraverseResult> {
    // a setting that would have no effect on the ladder's controller and plant is refused
    check_ladder_settings_apply(ll).map_err(rs)?;
    // the traverse's solves and loops stop at their next check once the token is set
    let cancel = brachia::CancelToken::new();
    let (mine, token) = ((**ll).clone(), cancel.clone());
    let tr = interruptible_owned(py, &cancel, move || run_traverse_cancellable(&mine, &token))?
        .map_err(exp)?;
    let report = tr.report(ll);
    Ok(TraverseResult {
        ll: ll.clone(),
        tr,
        report,
    })
}
