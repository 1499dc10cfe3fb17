//! `view.html`: one self-contained interactive page of a run (plan or track), drawn from its folder.
//!
//! The page embeds its data as JSON ([`data`]) and its own small script and style sheet (the files under
//! `crates/experiments/assets/view/`, included at build time): it opens from disk in any browser,
//! offline, and makes no network request. It shows the robot to scale (link capsules, joints, hand,
//! grip and target bars, obstacles), the planned swing as a ghost beside the tracked one, the hand's
//! path, and plots of q, qd, tau (with the limits), energy and the EE error, all with one time cursor.
//! A `#t=SECONDS` fragment opens the page at that time.

pub mod data;

use crate::plan_run::PlanRun;
use crate::read::{PlanFolder, TrackFolder};
use crate::scenario::LoadedScenario;
use crate::track_run::TrackRun;
use crate::ExpError;
use brachia::Error;
use serde_json::Value;
use std::path::{Path, PathBuf};

pub use data::{plan_view, track_view, PlanParts, TrackParts, DRAW_DT_S, VIEW_SCHEMA};

/// The page's file name in a run folder.
pub const VIEW_FILE: &str = "view.html";

const TEMPLATE: &str = include_str!("../../assets/view/view.html");
const STYLE: &str = include_str!("../../assets/view/view.css");
const SCRIPT: &str = include_str!("../../assets/view/view.js");

/// Text safe inside HTML element content.
fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('{', "&#123;")
}

/// The page for the data `data` (as [`plan_view`] or [`track_view`] make it).
pub fn render(data: &Value) -> String {
    let title = data
        .get("title")
        .and_then(Value::as_str)
        .unwrap_or("brachia run");
    // no `</script` or `<!--` may appear inside a script element: `<` only occurs inside JSON strings,
    // where `\u003c` stands for it
    let json = data.to_string().replace('<', "\\u003c");
    TEMPLATE
        .replace("{{TITLE}}", &html_escape(title))
        .replace("/*{{STYLE}}*/", STYLE)
        .replace("/*{{SCRIPT}}*/", SCRIPT)
        .replace("{{DATA}}", &json)
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

/// The page data of a track folder; it draws the robot of the plan under `plan/`, so a track folder
/// without one (a run that tracked a plan read from elsewhere) is refused.
pub fn track_folder_view(f: &TrackFolder) -> Result<Value, Error> {
    let Some(plan) = &f.plan else {
        return Err(Error::invalid(
            f.dir.display().to_string(),
            "plan/",
            "missing",
            "the view draws the robot of the plan's scenario.toml and params.toml under plan/ \
             (written by a track run that planned its swing)",
        ));
    };
    Ok(track_view(TrackParts {
        report: &f.report,
        log: &f.log,
        world: &f.world,
        planned_obstacles: &plan.scenario.scenario.task.obstacles,
        robot: &plan.scenario.robot,
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
        robot: &ls.robot,
    }))
}

/// Read the run folder `dir` (a track folder when it holds `closed_loop.csv`, else a plan folder) and
/// make its page. Every file is checked as the readers check it ([`PlanFolder::read`],
/// [`TrackFolder::read`]); a folder that is neither is refused naming what it lacks.
pub fn view_html(dir: &Path) -> Result<String, Error> {
    if !dir.is_dir() {
        return Err(Error::invalid(
            dir.display().to_string(),
            "folder",
            "missing or not a folder",
            "a run folder written by `brachia plan` or `brachia track`",
        ));
    }
    let data = if dir.join("closed_loop.csv").exists() {
        track_folder_view(&TrackFolder::read(dir)?)?
    } else if dir.join("trajectory.csv").exists() {
        plan_folder_view(&PlanFolder::read(dir)?)
    } else {
        return Err(Error::invalid(
            dir.display().to_string(),
            "closed_loop.csv, trajectory.csv",
            "missing",
            "a run folder written by `brachia track` (closed_loop.csv, report.json, plan/) or \
             `brachia plan` (trajectory.csv, scenario.toml, params.toml, report.json)",
        ));
    };
    Ok(render(&data))
}

/// Write `dir/view.html` for the run folder `dir` ([`view_html`]): staged in a fresh folder beside `dir`
/// and installed under the folder's lock; no other file of `dir` changes, except that the manifest
/// lists `view.html` with its stamp (so a later run into the folder replaces the page instead of
/// keeping it as the user's) and a `view.html` of the user's is moved aside as `view.html.user`.
/// Returns the page's path.
pub fn write_view(dir: &Path) -> Result<PathBuf, ExpError> {
    let html = view_html(dir)?;
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
    let _ = std::fs::remove_dir(&stage);
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
