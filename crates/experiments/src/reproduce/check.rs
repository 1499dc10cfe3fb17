//! The JSON files of a reproduction folder that `brachia report` reads as loose JSON (`summary.json`,
//! `ladder/report.json`, `ladder/joint_swings.json`), checked field by field before anything is drawn:
//! a missing field, a wrong type or a null where the writer puts a value is refused, naming the file
//! and the field, never drawn as "0 s on 1 cores" or a table with missing rows.

use brachia::Error;
use serde_json::Value;
use std::path::Path;

/// The part of `summary.json` a redrawn report needs.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct SummaryHead {
    /// `mode = "quick"`.
    pub quick: bool,
    /// `wall_time_s`, s.
    pub wall_s: f64,
    /// `cores`.
    pub cores: usize,
    /// `failures`.
    pub failures: Vec<String>,
    /// `warnings`.
    pub warnings: Vec<String>,
}

/// Most cores a reproduction may say it ran on (a sanity bound on the count read back).
const MAX_CORES: u64 = 1 << 16;

fn bad(file: &Path, field: &str, v: &Value, rule: &str) -> Error {
    let shown = match v {
        Value::Null => "null".to_string(),
        other => other.to_string().chars().take(80).collect(),
    };
    Error::invalid(file.display().to_string(), field, shown, rule)
}

fn missing(file: &Path, field: &str, what: &str) -> Error {
    Error::invalid(
        file.display().to_string(),
        field,
        "missing",
        format!("must be {what}"),
    )
}

/// `obj[key]`, refused when `obj` is not an object or has no `key` (`field` names it in full).
fn get<'a>(
    file: &Path,
    obj: &'a Value,
    key: &str,
    field: &str,
    what: &str,
) -> Result<&'a Value, Error> {
    if !obj.is_object() {
        let parent = field.rsplit_once('.').map_or("(the file)", |(p, _)| p);
        return Err(bad(file, parent, obj, "must be a JSON object"));
    }
    obj.get(key).ok_or_else(|| missing(file, field, what))
}

fn string(file: &Path, obj: &Value, key: &str, field: &str) -> Result<String, Error> {
    let v = get(file, obj, key, field, "a string")?;
    v.as_str()
        .map(String::from)
        .ok_or_else(|| bad(file, field, v, "must be a string"))
}

fn boolean(file: &Path, obj: &Value, key: &str, field: &str) -> Result<bool, Error> {
    let v = get(file, obj, key, field, "true or false")?;
    v.as_bool()
        .ok_or_else(|| bad(file, field, v, "must be true or false"))
}

/// A finite number (no null).
fn number(file: &Path, obj: &Value, key: &str, field: &str) -> Result<f64, Error> {
    let v = get(file, obj, key, field, "a finite number")?;
    v.as_f64()
        .filter(|x| x.is_finite())
        .ok_or_else(|| bad(file, field, v, "must be a finite number"))
}

/// A finite number or null (a value a failed solve leaves out).
fn number_or_null(file: &Path, obj: &Value, key: &str, field: &str) -> Result<(), Error> {
    let v = get(file, obj, key, field, "a number or null")?;
    if v.is_null() || v.as_f64().is_some_and(f64::is_finite) {
        Ok(())
    } else {
        Err(bad(file, field, v, "must be a finite number or null"))
    }
}

fn array<'a>(file: &Path, obj: &'a Value, key: &str, field: &str) -> Result<&'a Vec<Value>, Error> {
    let v = get(file, obj, key, field, "an array")?;
    v.as_array()
        .ok_or_else(|| bad(file, field, v, "must be an array"))
}

fn strings(file: &Path, obj: &Value, key: &str) -> Result<Vec<String>, Error> {
    array(file, obj, key, key)?
        .iter()
        .enumerate()
        .map(|(i, v)| {
            v.as_str()
                .map(String::from)
                .ok_or_else(|| bad(file, &format!("{key}[{i}]"), v, "must be a string"))
        })
        .collect()
}

/// Read the head of `summary.json` (`file`, parsed as `sum`): `mode` "quick" or "full", `wall_time_s`
/// a finite number >= 0, `cores` a whole number 1..=65536, `failures` and `warnings` arrays of strings.
pub(crate) fn summary_head(file: &Path, sum: &Value) -> Result<SummaryHead, Error> {
    let mode = string(file, sum, "mode", "mode")?;
    if mode != "quick" && mode != "full" {
        return Err(bad(
            file,
            "mode",
            &sum["mode"],
            "must be \"quick\" or \"full\"",
        ));
    }
    let wall_s = number(file, sum, "wall_time_s", "wall_time_s")?;
    if wall_s < 0.0 {
        return Err(bad(
            file,
            "wall_time_s",
            &sum["wall_time_s"],
            "must be >= 0 s",
        ));
    }
    let c = get(file, sum, "cores", "cores", "a whole number of cores")?;
    let cores = c
        .as_u64()
        .filter(|&c| (1..=MAX_CORES).contains(&c))
        .ok_or_else(|| bad(file, "cores", c, "must be a whole number in 1..=65536"))?;
    Ok(SummaryHead {
        quick: mode == "quick",
        wall_s,
        cores: cores as usize,
        failures: strings(file, sum, "failures")?,
        warnings: strings(file, sum, "warnings")?,
    })
}

/// Check a traverse's `report.json` (`file`, parsed as `l`) for the fields the report draws: `scenario`
/// and `message` strings, `completed` a bool, `bars` an array of at least two bars (each with finite
/// `x`, `y`), `swings` an array of objects with finite `energy_j`, `positive_work_j`, `duration_s`,
/// `capture_error_m`, `switch_residual_m_s`, and `totals` with finite `energy_j`, `duration_s`,
/// `real_time_factor`.
pub(crate) fn ladder_report(file: &Path, l: &Value) -> Result<(), Error> {
    string(file, l, "scenario", "scenario")?;
    string(file, l, "message", "message")?;
    boolean(file, l, "completed", "completed")?;
    let bars = array(file, l, "bars", "bars")?;
    if bars.len() < 2 {
        return Err(bad(
            file,
            "bars",
            &l["bars"],
            "a ladder has at least two bars",
        ));
    }
    for (i, b) in bars.iter().enumerate() {
        for k in ["x", "y"] {
            number(file, b, k, &format!("bars[{i}].{k}"))?;
        }
    }
    for (i, w) in array(file, l, "swings", "swings")?.iter().enumerate() {
        for k in [
            "energy_j",
            "positive_work_j",
            "duration_s",
            "capture_error_m",
            "switch_residual_m_s",
        ] {
            number(file, w, k, &format!("swings[{i}].{k}"))?;
        }
    }
    let t = get(file, l, "totals", "totals", "an object")?;
    for k in ["energy_j", "duration_s", "real_time_factor"] {
        number(file, t, k, &format!("totals.{k}"))?;
    }
    Ok(())
}

/// Check `joint_swings.json` (`file`, parsed as `j`): `swings` a whole number, `status` a string,
/// `converged` a bool, `phases` an array of objects (`swing` a whole number, each value a number or
/// null), `joint` and `swing_by_swing` objects with `objective`, `energy_j`, `positive_work_j` and
/// `iterations` numbers or null (a failed joint solve has none).
pub(crate) fn joint_swings(file: &Path, j: &Value) -> Result<(), Error> {
    let s = get(file, j, "swings", "swings", "a whole number")?;
    if s.as_u64().is_none() {
        return Err(bad(file, "swings", s, "must be a whole number"));
    }
    string(file, j, "status", "status")?;
    boolean(file, j, "converged", "converged")?;
    for (i, p) in array(file, j, "phases", "phases")?.iter().enumerate() {
        let w = get(
            file,
            p,
            "swing",
            &format!("phases[{i}].swing"),
            "a whole number",
        )?;
        if w.as_u64().is_none() {
            return Err(bad(
                file,
                &format!("phases[{i}].swing"),
                w,
                "must be a whole number",
            ));
        }
        for k in [
            "objective",
            "reference_objective",
            "energy_j",
            "reference_energy_j",
            "positive_work_j",
            "reference_positive_work_j",
            "capture_position_m",
            "capture_speed_m_s",
        ] {
            number_or_null(file, p, k, &format!("phases[{i}].{k}"))?;
        }
    }
    for part in ["joint", "swing_by_swing"] {
        let o = get(file, j, part, part, "an object")?;
        for k in ["objective", "energy_j", "positive_work_j", "iterations"] {
            number_or_null(file, o, k, &format!("{part}.{k}"))?;
        }
    }
    Ok(())
}
