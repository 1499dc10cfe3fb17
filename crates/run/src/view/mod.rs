//! `view.html`: one self-contained interactive page of a run (plan, track, traverse, simulation, or a
//! benchmark's scorecard, [`mod@bench`]), drawn from its folder. The paper layer adds the parameter
//! study's page (`brachia_experiments::view`).
//!
//! The page embeds its data as JSON ([`data`]) and its own small script and style sheet (the files under
//! `crates/run/assets/view/`, included at build time): it opens from disk in any browser,
//! offline, and makes no network request. It shows the robot to scale (link capsules, joints, hand,
//! grip and target bars, obstacles), the planned swing as a ghost beside the tracked one, the hand's
//! path, and plots of q, qd, tau (with the limits), energy and the EE error, all with one time cursor.
//! A `#t=SECONDS` fragment opens the page at that time. A traverse ([`traverse`]) is drawn in the
//! world frame with its grip switches marked; a simulation ([`simulate`]) shows the passive chain and
//! its mechanical energy.

pub mod bench;
pub mod data;
pub mod page;
pub mod simulate;
pub mod traverse;

use crate::ladder::LoadedLadder;
use crate::plan_run::PlanRun;
use crate::read::{inside, need, read_csv_text, read_json, PlanFolder};
use crate::scenario::LoadedScenario;
use crate::schema::JsonKind;
use crate::track_folder::TrackFolder;
use crate::track_run::TrackRun;
use crate::traverse::Traverse;
use crate::ExpError;
use brachia::{Error, Robot};
use serde_json::Value;
use std::path::{Path, PathBuf};

use data::html_escape;
pub use data::{plan_view, track_view, PlanParts, TrackParts, DRAW_DT_S, VIEW_SCHEMA};
pub use simulate::{simulate_view, SimulateParts};
pub use traverse::{traverse_view, TraverseParts, TraverseReportView};

/// The page's file name in a run folder.
pub const VIEW_FILE: &str = "view.html";

pub use page::{header, page, VIEW_STYLE};

const TEMPLATE: &str = include_str!("../../assets/view/view.html");
const SCRIPT: &str = include_str!("../../assets/view/view.js");

/// The page for the data `data` (as [`plan_view`] or [`track_view`] make it).
pub fn render(data: &Value) -> String {
    let title = data
        .get("title")
        .and_then(Value::as_str)
        .unwrap_or("brachia run");
    // no `</script` or `<!--` may appear inside a script element: `<` only occurs inside JSON strings,
    // where `\u003c` stands for it
    let json = data.to_string().replace('<', "\\u003c");
    let body = TEMPLATE
        .replace("{{TITLE}}", &html_escape(title))
        .replace("/*{{SCRIPT}}*/", SCRIPT)
        .replace("{{DATA}}", &json);
    page(title, "", &body)
}

/// The page data of a plan folder.
pub fn plan_folder_view(p: &PlanFolder) -> Value {
    plan_view(PlanParts {
        name: &p.scenario.scenario.name,
        report: &p.report,
        task: &p.scenario.scenario.task,
        robot: &p.scenario.robot,
        trajectory: &p.trajectory,
    })
}

/// The page data of a track folder: the robot of the plan under `plan/`, or, in a folder without
/// one (a run that tracked a plan read from elsewhere), the chain as `closed_loop.csv` describes it
/// (the page says what it could not draw).
pub fn track_folder_view(f: &TrackFolder) -> Result<Value, Error> {
    Ok(track_view(TrackParts {
        report: &f.report,
        log: &f.log,
        world: &f.world,
        planned_obstacles: f
            .plan
            .as_ref()
            .map_or(&[], |p| p.scenario.scenario.task.obstacles.as_slice()),
        robot: f.plan.as_ref().map(|p| &p.scenario.robot),
    }))
}

/// The page of a plan just made from the scenario `ls` (what `brachia plan` adds to its run folder).
pub fn plan_run_page(ls: &LoadedScenario, run: &PlanRun) -> String {
    render(&plan_view(PlanParts {
        name: &ls.scenario.name,
        report: &run.report,
        task: &ls.scenario.task,
        robot: &ls.robot,
        trajectory: &run.plan.trajectory,
    }))
}

/// The page of a track run just made from the scenario `ls` (what `brachia track` adds to its run
/// folder).
pub fn track_run_page(ls: &LoadedScenario, run: &TrackRun) -> String {
    render(&track_view(TrackParts {
        report: &run.report,
        log: &run.log,
        world: &run.world,
        planned_obstacles: &ls.scenario.task.obstacles,
        robot: Some(&ls.robot),
    }))
}

/// The robot parameters file a traverse or simulate folder holds (as a plan folder does).
pub const PARAMS_FILE: &str = crate::plan_run::PARAMS_FILE;

/// The text of `params.toml` for `robot`, read from `source`.
pub fn params_toml(robot: &Robot, source: &Path) -> String {
    format!(
        "# Robot parameters of this run (from {}). Units: m, kg, kg m^2, N m.\n{}",
        source.display(),
        toml::to_string(robot.params()).unwrap_or_default()
    )
}

/// The robot of `dir/params.toml`, when the folder holds one.
fn folder_robot(dir: &Path) -> Result<Option<Robot>, Error> {
    match inside(dir, PARAMS_FILE)? {
        Some(p) => Robot::from_toml_file(&p).map(Some),
        None => Ok(None),
    }
}

const TRAVERSE_FOLDER: &str =
    "a traverse folder written by `brachia traverse` (traverse.csv, report.json)";

/// The page data of a traverse folder: `traverse.csv`, `report.json`, `params.toml` when present
/// (the links' radii and torque limits), and on the rapier plant `contacts.csv` and `obstacles.csv`.
pub fn traverse_folder_view(dir: &Path) -> Result<Value, Error> {
    let rfile = need(dir, "report.json", TRAVERSE_FOLDER)?;
    let tfile = need(dir, "traverse.csv", TRAVERSE_FOLDER)?;
    let report: TraverseReportView = read_json(&rfile, JsonKind::TraverseReport)?;
    let csv = read_csv_text(&tfile, "traverse")?;
    let robot = folder_robot(dir)?;
    let n = match &robot {
        Some(r) => r.n(),
        None => csv
            .lines()
            .next()
            .unwrap_or("")
            .split(',')
            .filter(|c| c.starts_with("qd"))
            .count(),
    };
    let contacts = match inside(dir, "contacts.csv")? {
        Some(p) => crate::read::read_contacts(&p, n, report.plant_obstacles.len())?,
        None => Vec::new(),
    };
    let track = match inside(dir, "obstacles.csv")? {
        Some(p) => crate::read::read_obstacle_track(&p, &report.plant_obstacles)?,
        None => Vec::new(),
    };
    traverse_view(TraverseParts {
        file: &tfile.display().to_string(),
        csv: &csv,
        report: &report,
        robot: robot.as_ref(),
        contacts: &contacts,
        obstacle_track: &track,
    })
}

/// The page of a traverse just run from the ladder scenario `ll` (what `brachia traverse` adds to
/// its run folder).
pub fn traverse_run_page(ll: &LoadedLadder, tr: &Traverse) -> Result<String, Error> {
    let report: TraverseReportView =
        brachia::serde_nonfinite::from_value(tr.report(ll)).map_err(|e| {
            Error::invalid(
                "report.json",
                "(the report)",
                e.to_string(),
                "a traverse report",
            )
        })?;
    let csv = tr.to_csv();
    Ok(render(&traverse_view(TraverseParts {
        file: "traverse.csv",
        csv: &csv,
        report: &report,
        robot: Some(&ll.robot),
        contacts: &tr.world.contacts,
        obstacle_track: &tr.world.track,
    })?))
}

/// The kind of run folder `dir` is, from the files it holds.
fn folder_kind(dir: &Path) -> Option<&'static str> {
    let has = |f: &str| dir.join(f).exists();
    if has("closed_loop.csv") {
        Some("track")
    } else if has("traverse.csv") {
        Some("traverse")
    } else if has("trajectory.csv") && !has("scenario.toml") && has("report.json") {
        Some("simulate")
    } else if has("trajectory.csv") {
        Some("plan")
    } else if has("scorecard.json") {
        Some("benchmark")
    } else {
        None
    }
}

/// Read the run folder `dir` and make its page: a track folder (`closed_loop.csv`), a traverse
/// (`traverse.csv`), a simulation (`trajectory.csv` without `scenario.toml`), a plan
/// (`trajectory.csv`) or a benchmark (`scorecard.json`); the paper layer adds the parameter study's
/// page (`brachia_experiments::view`). Every file is checked as the readers check
/// it ([`PlanFolder::read`], [`TrackFolder::read`], ...); a folder that is none of them is refused
/// naming what it lacks.
pub fn view_html(dir: &Path) -> Result<String, Error> {
    if !dir.is_dir() {
        return Err(Error::invalid(
            dir.display().to_string(),
            "folder",
            "missing or not a folder",
            "a run folder written by `brachia plan`, `track`, `traverse`, `simulate` or `benchmark`",
        ));
    }
    let data = match folder_kind(dir) {
        Some("track") => track_folder_view(&TrackFolder::read(dir)?)?,
        Some("traverse") => traverse_folder_view(dir)?,
        Some("simulate") => simulate::simulate_folder_view(dir)?,
        Some("plan") => plan_folder_view(&PlanFolder::read(dir)?),
        Some(_) => return bench::benchmark_folder_html(dir),
        None => {
            return Err(Error::invalid(
                dir.display().to_string(),
                "closed_loop.csv, traverse.csv, trajectory.csv, scorecard.json, cells.csv",
                "missing",
                "a run folder written by `brachia track` (closed_loop.csv, report.json), \
                 `brachia traverse` (traverse.csv, report.json), `brachia plan` or `brachia \
                 simulate` (trajectory.csv, report.json), `brachia benchmark` (scorecard.json, \
                 runs.csv) or a reproduction's parameter-study/ (cells.csv, freefall.csv, report.json)",
            ))
        }
    };
    Ok(render(&data))
}

/// Write `dir/view.html` for the run folder `dir` ([`view_html`]): staged in a fresh folder beside `dir`
/// and installed under the folder's lock; no other file of `dir` changes, except that the manifest
/// lists `view.html` with its stamp (so a later run into the folder replaces the page instead of
/// keeping it as the user's) and a `view.html` of the user's is moved aside as `view.html.user`.
/// Returns the page's path.
pub fn write_view(dir: &Path) -> Result<PathBuf, ExpError> {
    write_page(dir, &view_html(dir)?)
}

/// Write the page `html` as `dir/view.html`, as [`write_view`] does.
pub fn write_page(dir: &Path, html: &str) -> Result<PathBuf, ExpError> {
    // staged next to the folder, then installed under the folder's lock like any run's files: a
    // view.html of the user's is moved aside, the manifest lists the new page with its stamp
    let stage = crate::run_folder::stage_for(dir)?;
    let staged = stage.join(VIEW_FILE);
    let result = std::fs::write(&staged, html)
        .map_err(|source| ExpError::Write {
            path: staged.clone(),
            source,
        })
        .and_then(|()| crate::run_folder::install_part(&stage, dir, &|_| false));
    let _ = std::fs::remove_file(stage.join(crate::MANIFEST));
    let _ = std::fs::remove_file(&staged);
    let _ = std::fs::remove_file(stage.join(crate::staging::STAGE_LOCK));
    let _ = std::fs::remove_dir(&stage);
    crate::staging::release(&stage);
    result?;
    Ok(dir.join(VIEW_FILE))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn render_keeps_markup_in_the_data_out_of_the_page() {
        let data = serde_json::json!({ "title": "a </script><!-- {{DATA}} & b", "t": [0.0, 1.0] });
        let page = render(&data);
        let start = page.find("id=\"brachia-data\">").unwrap() + "id=\"brachia-data\">".len();
        let end = start + page[start..].find("</script>").unwrap();
        let back: Value = serde_json::from_str(&page[start..end]).unwrap();
        assert_eq!(back, data);
        assert!(page.contains(
            "<title>a &lt;/script&gt;&lt;!-- &#123;&#123;DATA}} &amp; b - brachia</title>"
        ));
        assert_eq!(page.matches("<script").count(), 2);
    }
}
