//! The page data of a passive simulation (`brachia simulate`): the chain hanging from its grip with no
//! torque, drawn from `trajectory.csv` (`t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,energy`) and the
//! robot of `params.toml`; the plots show q, qd and the mechanical energy (its drift is the
//! integrator's error).

use super::data::{draw_indices, r, robot_json, row, with_full};
use crate::read::{need, read_csv_text, read_json};
use crate::schema::JsonKind;
use brachia::{Error, Robot};
use serde_json::{json, Value};
use std::path::Path;

/// What a simulation's page draws.
#[derive(Debug, Clone, Copy)]
pub struct SimulateParts<'a> {
    /// The name of `trajectory.csv` in messages.
    pub file: &'a str,
    /// `trajectory.csv` after its schema line.
    pub csv: &'a str,
    /// The robot simulated.
    pub robot: &'a Robot,
    /// A line under the title (what `report.json` says of the run).
    pub subtitle: &'a str,
}

/// The header of a simulation's `trajectory.csv` for an `n`-link chain.
fn header(n: usize) -> String {
    crate::schema::state_columns(n) + ",energy"
}

/// Rows of finite numbers under exactly the header `want` (after the schema line), times increasing.
pub(super) fn numeric_rows(file: &str, text: &str, want: &str) -> Result<Vec<f64>, Error> {
    let text = crate::read::strip_bom(text);
    let mut lines = text.lines();
    let got = lines.next().unwrap_or("").trim();
    if got != want {
        return Err(Error::invalid(
            file,
            "header",
            got.chars().take(160).collect::<String>(),
            format!("expected {want}"),
        ));
    }
    let names: Vec<&str> = want.split(',').collect();
    let mut v = Vec::new();
    let mut last_t = f64::NEG_INFINITY;
    for (i, line) in lines.enumerate() {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() != names.len() {
            return Err(Error::invalid(
                file,
                format!("line {}", i + 3),
                line.chars().take(160).collect::<String>(),
                format!("expected {} columns", names.len()),
            ));
        }
        for (cell, name) in cells.iter().zip(&names) {
            let x = cell.parse::<f64>().ok().filter(|x| x.is_finite());
            let x = x.ok_or_else(|| {
                Error::invalid(
                    file,
                    format!("line {}, {name}", i + 3),
                    *cell,
                    "must be a finite number",
                )
            })?;
            v.push(x);
        }
        let t = v[v.len() - names.len()];
        if t <= last_t {
            return Err(Error::invalid(
                file,
                format!("line {}, t", i + 3),
                cells[0],
                format!("times must increase (the row before: {last_t} s)"),
            ));
        }
        last_t = t;
    }
    if v.len() < 2 * names.len() {
        return Err(Error::invalid(
            file,
            "rows",
            v.len() / names.len(),
            "at least two rows",
        ));
    }
    Ok(v)
}

/// The page data of a simulation.
pub fn simulate_view(p: SimulateParts<'_>) -> Result<Value, Error> {
    let n = p.robot.n();
    let want = header(n);
    let w = want.split(',').count();
    let v = numeric_rows(p.file, p.csv, &want)?;
    let len = v.len() / w;
    let t: Vec<f64> = (0..len).map(|k| v[k * w]).collect();
    let idx = draw_indices(&t);
    let col = |idx: &[usize], c: usize| -> Vec<f64> {
        idx.iter().map(|&k| r(row(&v, w, k)[c])).collect()
    };
    let cols = |idx: &[usize], a: usize, b: usize| -> Vec<Vec<f64>> {
        idx.iter()
            .map(|&k| row(&v, w, k)[a..b].iter().copied().map(r).collect())
            .collect()
    };
    let mut data = json!({
        "schema": super::VIEW_SCHEMA,
        "kind": "simulate",
        "title": format!("{}: passive swing", p.robot.params().name),
        "subtitle": p.subtitle,
        "robot": robot_json(p.robot),
        "grip": [0.0, 0.0],
        "target": null,
        "obstacles": [],
    });
    let series = |idx: &[usize]| {
        let m = json!({
            "t": col(idx, 0),
            "q": cols(idx, 1, 1 + n),
            "qd": cols(idx, 1 + n, 1 + 2 * n),
            "mechanical": col(idx, w - 1),
        });
        m.as_object().cloned().unwrap_or_default()
    };
    with_full(&mut data, len, &idx, &series);
    Ok(data)
}

const SIMULATE_FOLDER: &str =
    "a simulation folder written by `brachia simulate` (trajectory.csv, report.json, params.toml)";

/// The part of a simulation's `report.json` its page shows.
#[derive(serde::Deserialize)]
struct SimulateReport {
    command: String,
    duration_s: f64,
    energy_drift_max_abs_j: f64,
}

/// The page data of a simulation folder: `trajectory.csv`, `report.json`, `params.toml`.
pub fn simulate_folder_view(dir: &Path) -> Result<Value, Error> {
    let rfile = need(dir, "report.json", SIMULATE_FOLDER)?;
    let tfile = need(dir, "trajectory.csv", SIMULATE_FOLDER)?;
    let pfile = need(dir, crate::plan_run::PARAMS_FILE, SIMULATE_FOLDER)?;
    let report: SimulateReport = read_json(&rfile, JsonKind::SimulateReport)?;
    if report.command != "simulate" {
        return Err(Error::invalid(
            rfile.display().to_string(),
            "command",
            &report.command,
            "\"simulate\" (a folder with trajectory.csv and no scenario.toml is a simulation)",
        ));
    }
    let robot = Robot::from_toml_file(&pfile)?;
    let csv = read_csv_text(&tfile, "trajectory")?;
    simulate_view(SimulateParts {
        file: &tfile.display().to_string(),
        csv: &csv,
        robot: &robot,
        subtitle: &subtitle(report.duration_s, report.energy_drift_max_abs_j),
    })
}

/// The line under a simulation's title.
pub fn subtitle(duration_s: f64, drift_j: f64) -> String {
    format!(
        "simulate: zero torque on the RK4 model plant for {duration_s} s; mechanical energy drift at \
         most {drift_j:.2e} J"
    )
}
