//! Reading run folders back: the data a figure or a report needs, loaded from what `brachia plan`,
//! `brachia track` and the other runs wrote, checked before it is used.
//!
//! Every file is read with a size cap ([`brachia::limits`]); a missing file, a header that is not the
//! writer's, a value that does not parse, a non-finite number or times that do not increase is an
//! [`Error::InvalidValue`] naming the file, the field (line and column), the value and the rule. Nothing
//! here plans or simulates. In a JSON report, a `null` where a number belongs is how the writer put a
//! number that was not finite: it reads as infinite ([`read_json`]).
//!
//! Every JSON file must carry `schema_version` 1 (a track report or a scorecard: 1 or 2) and every CSV
//! file its schema line (`# brachia KIND schema 1`, [`crate::schema`]); a file read from a folder must
//! lie inside it ([`inside`]).
//!
//! Units and CSV layouts as written (SI: s, m, rad, rad/s, N m, N s, J): `trajectory.csv`
//! `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y`; `closed_loop.csv` as [`brachia::sim::ClosedLoopLog::to_csv`];
//! `contacts.csv` `t,link,body,impulse`; `obstacles.csv` `t,obstacle_0_x,obstacle_0_y,...`.

use crate::plan_run::PlanReport;
use crate::scenario::{LoadedScenario, Scenario, Uses};
use crate::schema::JsonKind;
use brachia::limits;
use brachia::trajectory::Trajectory;
use brachia::{Error, Robot};
use brachia_rapier::{ContactBody, ContactEvent, Obstacle};
use serde::de::DeserializeOwned;
use std::path::{Path, PathBuf};

/// `dir/name` (a plain relative name), refused (naming `what` the folder should be) when it is missing,
/// or (see [`inside`]) when it leaves `dir` or is not a regular file.
pub fn need(dir: &Path, name: &str, what: &str) -> Result<PathBuf, Error> {
    match inside(dir, name)? {
        Some(p) => Ok(p),
        None => Err(Error::invalid(
            dir.display().to_string(),
            name,
            "missing",
            format!("{what} holds {name}"),
        )),
    }
}

/// `dir/name` when it exists, `None` when it does not. A folder read back is untrusted input: the
/// entry is refused when it leaves `dir` (a `..` or absolute name, or a symbolic link, on the way or
/// at the end, that resolves outside `dir`) or is not a regular file (a folder, FIFO or device).
pub fn inside(dir: &Path, name: &str) -> Result<Option<PathBuf>, Error> {
    let file = dir.join(name).display().to_string();
    if crate::manifest::inside_rel(name).is_none() {
        return Err(Error::invalid(
            &file,
            "(the path)",
            name,
            "a file of a run folder is a plain path inside it (no `..`, no absolute path)",
        ));
    }
    let p = dir.join(name);
    if std::fs::symlink_metadata(&p).is_err() {
        return Ok(None);
    }
    let (Ok(root), Ok(real)) = (dir.canonicalize(), p.canonicalize()) else {
        return Err(Error::invalid(
            &file,
            "(the path)",
            name,
            "a symbolic link that leads nowhere (or a loop); a run folder's files are regular files",
        ));
    };
    if !real.starts_with(&root) {
        return Err(Error::invalid(
            &file,
            "(the path)",
            real.display(),
            format!(
                "leads outside the folder {}; a run folder's files lie inside it",
                dir.display()
            ),
        ));
    }
    if !real.is_file() {
        return Err(Error::invalid(
            &file,
            "(the path)",
            if real.is_dir() {
                "a folder"
            } else {
                "not a regular file"
            },
            "must be a regular file",
        ));
    }
    Ok(Some(p))
}

/// `dir/name` as a sub-folder inside `dir` when it is one (also through a symbolic link that stays
/// inside `dir`), `None` when there is nothing of that name; refused when it leads outside `dir`.
pub fn inside_dir(dir: &Path, name: &str) -> Result<Option<PathBuf>, Error> {
    let p = dir.join(name);
    if std::fs::symlink_metadata(&p).is_err() {
        return Ok(None);
    }
    let ok = match (dir.canonicalize(), p.canonicalize()) {
        (Ok(root), Ok(real)) => real.starts_with(&root) && real != root,
        _ => false,
    };
    if !ok {
        return Err(Error::invalid(
            p.display().to_string(),
            "(the path)",
            name,
            format!(
                "leads outside the folder {} (or nowhere); a run folder's sub-folders lie inside it",
                dir.display()
            ),
        ));
    }
    Ok(p.is_dir().then_some(p))
}

/// Read and parse a JSON file of kind `kind` (at most [`limits::MAX_JSON_BYTES`]).
/// The file must carry a schema version this brachia reads for the kind
/// ([`crate::schema::json_version`]). A `null` where `T` holds a number is read as infinite: it is
/// how serde_json writes a number that was not finite (a diverged prediction, a failed solve;
/// [`brachia::serde_nonfinite::from_value`], docs/formats.md "Values that are not finite").
pub fn read_json<T: DeserializeOwned>(path: &Path, kind: JsonKind) -> Result<T, Error> {
    let text = limits::read_text_capped(path, limits::MAX_JSON_BYTES, "JSON file")?;
    let parse = |e: serde_json::Error| Error::Parse {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let value: serde_json::Value = serde_json::from_str(&text).map_err(parse)?;
    crate::schema::json_version(&value, &path.display().to_string(), kind)?;
    brachia::serde_nonfinite::from_value(value).map_err(parse)
}

/// An error of a CSV parser given the text after the schema line ([`read_csv_text`]): its `line N`
/// counted from the header becomes the file's line, `line N+1`.
pub(crate) fn past_schema_line(e: Error) -> Error {
    match e {
        Error::InvalidValue {
            source_name,
            field,
            value,
            reason,
        } => {
            let shifted = field.strip_prefix("line ").and_then(|r| {
                let digits: String = r.chars().take_while(char::is_ascii_digit).collect();
                digits
                    .parse::<usize>()
                    .ok()
                    .map(|n| format!("line {}{}", n + 1, &r[digits.len()..]))
            });
            let field = shifted.unwrap_or(field);
            Error::InvalidValue {
                source_name,
                field,
                value,
                reason,
            }
        }
        other => other,
    }
}

/// Read a CSV file brachia wrote (at most [`limits::MAX_CSV_BYTES`]): its schema line is checked
/// ([`crate::schema::csv_body`]) and the text after it returned.
pub fn read_csv_text(path: &Path, what: &str) -> Result<String, Error> {
    let text = limits::read_text_capped(path, limits::MAX_CSV_BYTES, what)?;
    let text = strip_bom(&text);
    let name = path
        .file_name()
        .map(|f| f.to_string_lossy().to_string())
        .unwrap_or_default();
    let kind = crate::schema::csv_kind(&name).unwrap_or(what);
    let body = crate::schema::csv_body(text, &path.display().to_string(), kind)?;
    Ok(body.to_string())
}

/// The text of a CSV file without a leading UTF-8 byte-order mark (a spreadsheet's export): the
/// mark is not part of the first column's name.
pub(crate) fn strip_bom(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

/// Shortest step between two rows of a plan's `trajectory.csv`, s: the file keeps times to 1 us, so
/// a shorter step is no step a plan writes (times 0, 1e-300, ... describe no swing).
pub const MIN_PLAN_STEP_S: f64 = 1e-7;

/// Largest distance between a row's `ee_x, ee_y` and the forward kinematics of its `q`, m: the file
/// keeps 9 decimals, so a written plan agrees to about 1e-9 m.
pub const PLAN_EE_TOLERANCE_M: f64 = 1e-6;

/// Read a plan's 1 ms `trajectory.csv` for `robot` (`whose` names the robot in the message): the
/// header names its joints and the hand (`t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y,...`), every value is
/// finite, times start at 0 and increase strictly by steps between [`MIN_PLAN_STEP_S`] and
/// [`limits::MAX_OUTPUT_DT_S`], at least two and at most
/// [`limits::MAX_OUTPUT_SAMPLES`] rows, the swing lasts at most [`limits::MAX_SWING_TIME_S`], and every
/// row's `ee_x, ee_y` is the forward kinematics of its `q` on `robot` (within
/// [`PLAN_EE_TOLERANCE_M`]). A leading byte-order mark is skipped. Each refusal names the file, the
/// row (line) and the column.
pub fn read_plan_trajectory(file: &Path, robot: &Robot, whose: &str) -> Result<Trajectory, Error> {
    let n = robot.n();
    let tpath = file.display().to_string();
    let text = read_csv_text(file, "trajectory")?;
    let text = text.as_str();
    let header = text.lines().next().unwrap_or("");
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let links = cols
        .iter()
        .filter(|c| {
            c.strip_prefix('q')
                .is_some_and(|r| r.parse::<usize>().is_ok())
        })
        .count();
    let mut want = vec!["t".to_string()];
    want.extend((1..=n).map(|i| format!("q{i}")));
    want.extend((1..=n).map(|i| format!("qd{i}")));
    want.extend((2..=n).map(|i| format!("tau{i}")));
    want.extend(["ee_x".to_string(), "ee_y".to_string()]);
    if links != n || cols.len() < want.len() || cols[..want.len()] != want[..] {
        let rule = if links == n {
            format!("expected {},...", want.join(","))
        } else {
            format!(
                "the plan is for a {links}-link robot, {whose} has {n} links: expected {},...",
                want.join(",")
            )
        };
        return Err(Error::invalid(
            &tpath,
            "header",
            header.chars().take(120).collect::<String>(),
            rule,
        ));
    }
    check_plan_cells(text, &tpath, &want).map_err(past_schema_line)?;
    let traj = Trajectory::from_csv(text, n, &tpath).map_err(past_schema_line)?;
    if traj.len() < 2 {
        return Err(Error::invalid(
            &tpath,
            "rows",
            traj.len(),
            "a plan needs at least two samples",
        ));
    }
    let most = limits::MAX_OUTPUT_SAMPLES + 1;
    if traj.len() > most {
        return Err(Error::invalid(
            &tpath,
            "rows",
            traj.len(),
            format!("a plan has at most {most} samples (brachia::limits::MAX_OUTPUT_SAMPLES)"),
        ));
    }
    check_plan_times(&traj, &tpath).map_err(past_schema_line)?;
    check_plan_ee(text, &traj, robot, &tpath, whose).map_err(past_schema_line)?;
    Ok(traj)
}

/// Every cell of the columns `want` (and the hand's) of every row is a finite number: a refusal names
/// the line and the column.
fn check_plan_cells(text: &str, tpath: &str, want: &[String]) -> Result<(), Error> {
    for (i, line) in text.lines().enumerate().skip(1) {
        if line.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = line.split(',').map(str::trim).collect();
        if cells.len() < want.len() {
            return Err(Error::invalid(
                tpath,
                format!("line {}", i + 1),
                line.chars().take(120).collect::<String>(),
                format!("too few columns: expected {}", want.len()),
            ));
        }
        for (v, col) in cells.iter().zip(want) {
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() => {}
                Ok(_) => {
                    return Err(Error::invalid(
                        tpath,
                        format!("line {}, {col}", i + 1),
                        v,
                        "every value of a plan must be finite",
                    ))
                }
                Err(e) => {
                    return Err(Error::invalid(
                        tpath,
                        format!("line {}, {col}", i + 1),
                        v,
                        e.to_string(),
                    ))
                }
            }
        }
    }
    Ok(())
}

/// Times increase strictly from 0, over at most [`limits::MAX_SWING_TIME_S`], by steps between
/// [`MIN_PLAN_STEP_S`] and [`limits::MAX_OUTPUT_DT_S`] (to the file's 1 us).
fn check_plan_times(traj: &Trajectory, tpath: &str) -> Result<(), Error> {
    if let Some(k) = (1..traj.len()).find(|&k| traj.t[k] <= traj.t[k - 1]) {
        return Err(Error::invalid(
            tpath,
            format!("line {}, t", k + 2),
            traj.t[k],
            format!(
                "times must increase strictly (previous row: {})",
                traj.t[k - 1]
            ),
        ));
    }
    if traj.t[0].abs() > 1e-9 {
        return Err(Error::invalid(
            tpath,
            "line 2, t",
            traj.t[0],
            "a plan starts at t = 0",
        ));
    }
    let tmax = limits::MAX_SWING_TIME_S;
    if traj.duration() > tmax {
        return Err(Error::invalid(
            tpath,
            "t",
            traj.duration(),
            format!("a plan may last at most {tmax} s (brachia::limits::MAX_SWING_TIME_S)"),
        ));
    }
    let max_step = limits::MAX_OUTPUT_DT_S + 1e-6;
    for k in 1..traj.len() {
        let step = traj.t[k] - traj.t[k - 1];
        if !(MIN_PLAN_STEP_S..=max_step).contains(&step) {
            return Err(Error::invalid(
                tpath,
                format!("line {}, t", k + 2),
                traj.t[k],
                format!(
                    "a step of {step:e} s after the previous row ({}): a plan's samples are between \
                     {MIN_PLAN_STEP_S:e} s and {} s apart (output_dt, brachia::limits::MAX_OUTPUT_DT_S)",
                    traj.t[k - 1],
                    limits::MAX_OUTPUT_DT_S
                ),
            ));
        }
    }
    Ok(())
}

/// Every row's `ee_x, ee_y` is the forward kinematics of its `q` on `robot`, within
/// [`PLAN_EE_TOLERANCE_M`] (a plan for another robot, or a file edited by hand, is refused).
fn check_plan_ee(
    text: &str,
    traj: &Trajectory,
    robot: &Robot,
    tpath: &str,
    whose: &str,
) -> Result<(), Error> {
    let n = robot.n();
    let at = 1 + 2 * n + (n - 1);
    let rows = text
        .lines()
        .enumerate()
        .skip(1)
        .filter(|(_, l)| !l.trim().is_empty());
    for (k, (i, line)) in rows.enumerate() {
        let mut cells = line.split(',').skip(at).map(str::trim);
        let (Some(x), Some(y)) = (cells.next(), cells.next()) else {
            continue; // checked by check_plan_cells
        };
        let (Ok(x), Ok(y)) = (x.parse::<f64>(), y.parse::<f64>()) else {
            continue;
        };
        let fk = robot.ee_position(traj.q(k));
        let off = (fk[0] - x).hypot(fk[1] - y);
        if off > PLAN_EE_TOLERANCE_M || !off.is_finite() {
            return Err(Error::invalid(
                tpath,
                format!("line {}, ee_x/ee_y", i + 1),
                format!("[{x}, {y}]"),
                format!(
                    "the hand must be the forward kinematics of the row's q on {whose}: [{:.9}, {:.9}] \
                     ({off:.3e} m apart, at most {PLAN_EE_TOLERANCE_M:e} m); a plan for another robot \
                     or an edited file is not tracked",
                    fk[0], fk[1]
                ),
            ));
        }
    }
    Ok(())
}

/// The robot file `params` a plan folder's `scenario.toml` (`sfile`) names must be a file of the
/// folder `dir` (as `brachia plan` writes it): a path that leaves the folder is refused.
fn check_params_inside(dir: &Path, sfile: &Path, params: &Path) -> Result<(), Error> {
    let ok = match (dir.canonicalize(), params.canonicalize()) {
        (Ok(root), Ok(real)) => real.starts_with(&root) && real.is_file(),
        _ => false,
    };
    if ok {
        Ok(())
    } else {
        Err(Error::invalid(
            sfile.display().to_string(),
            "params",
            params.display(),
            format!(
                "a plan folder's scenario names its robot file inside the folder {} (params.toml)",
                dir.display()
            ),
        ))
    }
}

/// Load a plan folder's `scenario.toml` (`sfile`, inside `dir`): the robot file it names is checked
/// to be a regular file inside `dir` (no link or `..` leading out) before anything reads it.
pub(crate) fn load_plan_scenario(dir: &Path, sfile: &Path) -> Result<LoadedScenario, Error> {
    let stext = limits::read_text_capped(sfile, limits::MAX_TOML_BYTES, "scenario file")?;
    let named = toml::from_str::<toml::Table>(&stext)
        .ok()
        .and_then(|t| t.get("params").and_then(|v| v.as_str().map(PathBuf::from)));
    if let Some(params) = named {
        check_params_inside(dir, sfile, &dir.join(params))?;
    }
    let scenario = Scenario::load_for(sfile, Uses::Plan)?;
    check_params_inside(dir, sfile, &scenario.scenario.params)?;
    Ok(scenario)
}

/// A plan's run folder read back (`brachia plan`, or the `plan/` of a track run).
#[derive(Debug, Clone)]
pub struct PlanFolder {
    /// The folder.
    pub dir: PathBuf,
    /// The resolved scenario (`scenario.toml`) with its robot (`params.toml` beside it).
    pub scenario: LoadedScenario,
    /// `report.json`.
    pub report: PlanReport,
    /// The 1 ms trajectory (`trajectory.csv`).
    pub trajectory: Trajectory,
}

const PLAN_FOLDER: &str = "a plan folder written by `brachia plan` (scenario.toml, params.toml, \
                           trajectory.csv, report.json)";

impl PlanFolder {
    /// Read the plan folder `dir`: its resolved `scenario.toml` (loaded and validated like any scenario;
    /// its robot is the `params` file it names, `params.toml` in the folder), `report.json` and
    /// `trajectory.csv` (checked by [`read_plan_trajectory`]).
    pub fn read(dir: &Path) -> Result<Self, Error> {
        let sfile = need(dir, "scenario.toml", PLAN_FOLDER)?;
        let rfile = need(dir, "report.json", PLAN_FOLDER)?;
        let tfile = need(dir, "trajectory.csv", PLAN_FOLDER)?;
        let scenario = load_plan_scenario(dir, &sfile)?;
        let report: PlanReport = read_json(&rfile, JsonKind::PlanReport)?;
        let whose = format!("the robot of {}", sfile.display());
        let trajectory = read_plan_trajectory(&tfile, &scenario.robot, &whose)?;
        Ok(PlanFolder {
            dir: dir.to_path_buf(),
            scenario,
            report,
            trajectory,
        })
    }
}

/// Split a CSV file into its header and its non-empty rows (each with its 1-based line number), the
/// header checked against `header`.
pub fn csv_rows<'a>(
    text: &'a str,
    file: &str,
    header: &str,
) -> Result<Vec<(usize, Vec<&'a str>)>, Error> {
    let mut lines = strip_bom(text).lines();
    let got = lines.next().unwrap_or("").trim();
    if got != header {
        return Err(Error::invalid(
            file,
            "header",
            got.chars().take(160).collect::<String>(),
            format!("expected {header}"),
        ));
    }
    Ok(lines
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|(i, l)| (i + 3, l.split(',').map(str::trim).collect()))
        .collect())
}

/// A finite number of a CSV cell.
pub fn number(file: &str, line: usize, col: &str, v: &str) -> Result<f64, Error> {
    match v.parse::<f64>() {
        Ok(x) if x.is_finite() => Ok(x),
        Ok(_) => Err(Error::invalid(
            file,
            format!("line {line}, {col}"),
            v,
            "must be finite",
        )),
        Err(e) => Err(Error::invalid(
            file,
            format!("line {line}, {col}"),
            v,
            e.to_string(),
        )),
    }
}

/// `contacts.csv` of an `n`-link robot in a world of `obstacles` obstacles.
pub(crate) fn read_contacts(
    path: &Path,
    n: usize,
    obstacles: usize,
) -> Result<Vec<ContactEvent>, Error> {
    let file = path.display().to_string();
    let text = read_csv_text(path, "contacts")?;
    let mut out = Vec::new();
    for (line, row) in csv_rows(&text, &file, "t,link,body,impulse")? {
        if row.len() != 4 {
            return Err(Error::invalid(
                &file,
                format!("line {line}"),
                row.join(","),
                "expected 4 columns: t,link,body,impulse",
            ));
        }
        let link = row[1].parse::<usize>().ok().filter(|l| (1..=n).contains(l));
        let Some(link) = link else {
            return Err(Error::invalid(
                &file,
                format!("line {line}, link"),
                row[1],
                format!("a link number 1..{n}"),
            ));
        };
        let id = |p: &str, max: usize| {
            row[2]
                .strip_prefix(p)
                .and_then(|r| r.parse::<usize>().ok())
                .filter(|&i| i < max)
        };
        let body = if let Some(i) = id("obstacle_", obstacles) {
            ContactBody::Obstacle(i)
        } else if let Some(j) = id("link_", n + 1).filter(|&j| j >= 1) {
            ContactBody::Link(j - 1)
        } else {
            return Err(Error::invalid(
                &file,
                format!("line {line}, body"),
                row[2],
                format!(
                    "obstacle_<id> with id 0..{} (the report's plant_obstacles) or link_<j> with j 1..{n}",
                    obstacles.saturating_sub(1)
                ),
            ));
        };
        out.push(ContactEvent {
            t: number(&file, line, "t", row[0])?,
            link: link - 1,
            body,
            impulse: number(&file, line, "impulse", row[3])?,
        });
    }
    Ok(out)
}

/// `obstacles.csv`: one column pair per obstacle of the report.
pub(crate) fn read_obstacle_track(
    path: &Path,
    obstacles: &[Obstacle],
) -> Result<Vec<Vec<f64>>, Error> {
    let file = path.display().to_string();
    let text = read_csv_text(path, "obstacles")?;
    let mut header = String::from("t");
    for i in 0..obstacles.len() {
        header.push_str(&format!(",obstacle_{i}_x,obstacle_{i}_y"));
    }
    let cols: Vec<&str> = header.split(',').collect();
    let mut out = Vec::new();
    for (line, row) in csv_rows(&text, &file, &header)? {
        if row.len() != cols.len() {
            return Err(Error::invalid(
                &file,
                format!("line {line}"),
                row.join(","),
                format!("expected {} columns: {header}", cols.len()),
            ));
        }
        let vals = row
            .iter()
            .zip(&cols)
            .map(|(v, c)| number(&file, line, c, v))
            .collect::<Result<Vec<f64>, Error>>()?;
        out.push(vals);
    }
    Ok(out)
}
