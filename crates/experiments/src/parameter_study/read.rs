//! Reading a parameter study's run folder back (as [`crate::parameter_study_folder`] writes it), with
//! the run layer's checked readers ([`brachia_run::read`]).

use super::{
    BaseParams, ParameterStudy, ParameterStudySettings, StickDiagram, StudyCell, StudyRow,
};
use brachia::limits;
use brachia::model::RobotParams;
use brachia::planning::SolveStatus;
use brachia::{Error, Robot};
use brachia_run::read::{csv_rows, need, number, read_csv_text, read_json, read_plan_trajectory};
use brachia_run::schema::JsonKind;
use std::path::Path;

/// The part of the parameter study's `report.json` a reader needs.
#[derive(serde::Deserialize)]
struct StudyReport {
    settings: ParameterStudySettings,
    start_q: Vec<f64>,
    rows: Vec<StudyRow>,
    cells: usize,
    stick_r2: Vec<StudyStick>,
    wall_time_s: f64,
}

#[derive(serde::Deserialize)]
struct StudyStick {
    r2: f64,
    swing_time_s: f64,
    status: SolveStatus,
    energy_j: Option<f64>,
}

const STUDY_FOLDER: &str = "a parameter-study folder (report.json, cells.csv, stick_r2_*.csv)";

/// A solver status from its snake-case name as `cells.csv` writes it (the text of a status that carries
/// one is not in the CSV: it reads back empty).
fn status_from_name(name: &str) -> Option<SolveStatus> {
    serde_json::from_value(serde_json::Value::String(name.into()))
        .ok()
        .or_else(|| serde_json::from_value(serde_json::json!({ name: "" })).ok())
}

/// Read a parameter study's run folder (as [`crate::parameter_study_folder`] writes it): the settings,
/// rows and stick-diagram swings of `report.json`, every cell of `cells.csv` (in row-major order, one per
/// r2 and offset of the settings) and each stick swing's robot and trajectory.
pub fn read_parameter_study(dir: &Path) -> Result<ParameterStudy, Error> {
    let rfile = need(dir, "report.json", STUDY_FOLDER)?;
    let cfile = need(dir, "cells.csv", STUDY_FOLDER)?;
    let rep: StudyReport = read_json(&rfile, JsonKind::StudyReport)?;
    let base = match &rep.settings.base_params {
        BaseParams::Inline(p) => p.clone(),
        other => {
            return Err(Error::invalid(
                rfile.display().to_string(),
                "settings.base_params",
                format!("{other:?}"),
                "a study's report holds its base parameters inline",
            ))
        }
    };
    let (nr, no) = (rep.settings.r2.len(), rep.settings.offsets_s.len());
    if rep.rows.len() != nr || rep.cells != nr * no {
        return Err(Error::invalid(
            rfile.display().to_string(),
            "rows, cells",
            format!("{} rows, {} cells", rep.rows.len(), rep.cells),
            format!("the settings' grid has {nr} r2 x {no} offsets"),
        ));
    }
    let file = cfile.display().to_string();
    let text = read_csv_text(&cfile, "cells")?;
    let header = "r2,offset_s,swing_time_s,status,converged,energy_j,positive_work_j,objective,\
                  iterations,solve_time_s,start,replay_ee_error_m,torque_scale_reached";
    let rows = csv_rows(&text, &file, header)?;
    let columns = 13;
    if rows.len() != rep.cells {
        return Err(Error::invalid(
            &file,
            "rows",
            rows.len(),
            format!("report.json has {} cells", rep.cells),
        ));
    }
    let mut cells = Vec::with_capacity(rows.len());
    for (line, row) in rows {
        if row.len() != columns {
            return Err(Error::invalid(
                &file,
                format!("line {line}"),
                row.join(","),
                format!("expected {columns} columns: {header}"),
            ));
        }
        let num = |i: usize, c: &str| number(&file, line, c, row[i]);
        let opt = |i: usize, c: &str| {
            if row[i].is_empty() {
                Ok(None)
            } else {
                num(i, c).map(Some)
            }
        };
        let bad = |c: &str, v: &str, rule: &str| {
            Error::invalid(&file, format!("line {line}, {c}"), v, rule)
        };
        cells.push(StudyCell {
            r2: num(0, "r2")?,
            offset_s: num(1, "offset_s")?,
            swing_time_s: num(2, "swing_time_s")?,
            status: status_from_name(row[3])
                .ok_or_else(|| bad("status", row[3], "a solver status (solved, ...)"))?,
            converged: row[4]
                .parse()
                .map_err(|_| bad("converged", row[4], "true or false"))?,
            energy_j: opt(5, "energy_j")?,
            positive_work_j: opt(6, "positive_work_j")?,
            objective: opt(7, "objective")?,
            iterations: row[8]
                .parse()
                .map_err(|_| bad("iterations", row[8], "a whole number"))?,
            solve_time_s: num(9, "solve_time_s")?,
            start: serde_json::from_value(serde_json::Value::String(row[10].into())).map_err(
                |_| {
                    bad(
                        "start",
                        row[10],
                        "cold, warm, cold-after-warm or warm-from-row",
                    )
                },
            )?,
            replay_ee_error_m: opt(11, "replay_ee_error_m")?,
            torque_scale_reached: opt(12, "torque_scale_reached")?,
        });
    }
    let mut sticks = Vec::with_capacity(rep.stick_r2.len());
    for s in &rep.stick_r2 {
        let tag = crate::parameter_study::r2_tag(s.r2);
        let pfile = need(dir, &format!("stick_r2_{tag}_params.toml"), STUDY_FOLDER)?;
        let tfile = need(dir, &format!("stick_r2_{tag}.csv"), STUDY_FOLDER)?;
        let ptext = limits::read_text_capped(&pfile, limits::MAX_TOML_BYTES, "TOML file")?;
        let params = RobotParams::from_toml_str(&ptext, &pfile.display().to_string())?;
        let robot = Robot::from_params(params, &pfile.display().to_string())?;
        let whose = format!("the robot of {}", pfile.display());
        let trajectory = read_plan_trajectory(&tfile, &robot, &whose)?;
        sticks.push(StickDiagram {
            r2: s.r2,
            robot,
            swing_time_s: s.swing_time_s,
            status: s.status.clone(),
            energy_j: s.energy_j,
            trajectory,
        });
    }
    Ok(ParameterStudy {
        settings: rep.settings,
        base,
        start_q: rep.start_q,
        rows: rep.rows,
        cells,
        sticks,
        wall_time_s: rep.wall_time_s,
    })
}
