//! `brachia reproduce`: every experiment of the paper's Section V in one run, with figures, animations,
//! a Markdown report that puts our numbers beside the paper's, and a machine-readable summary.
//!
//! Output folder layout (`DIR`):
//! - `REPORT.md`, `summary.json`;
//! - `figures/`: `fig3_*.png` .. `fig8_*.png` (each with an `.svg` beside it) and one GIF per swing;
//! - one run folder per experiment (`parameter-study/`, `tracking/`, `tracking-model/`,
//!   `obstacle/avoid/`, `obstacle/ignored/`, `robustness/{mpc,pd,open-loop}/`, `robustness-paper/`),
//!   each with its resolved inputs, CSVs and `report.json`, as `brachia plan` / `brachia track` write them;
//! - `ladder/`: the even ladder traversed on the model plant (beyond the paper; `--quick`
//!   traverses its first three bars), as `brachia traverse` writes it (`traverse.gif` among them).
//!
//! Everything is written into a staging folder next to `DIR` and renamed into place when complete
//! ([`crate::run_folder`]): an interrupted run leaves the previous results as they were, and a re-run
//! replaces only the files the previous run wrote (its manifest), never the user's own. An experiment whose solver does not converge
//! is reported as such (its run folder is still written) and the others go on; [`Reproduction::failures`]
//! lists them. Units: SI (s, m, rad, N m, J).

mod check;
mod figures;
mod report;
mod results;
mod study;
mod views;

use crate::plan_run::{run_plan, PlanRun};
use crate::progress::{CancelToken, ProgressFn};
use crate::read::PlanFolder;
use crate::scenario::{ControllerKind, LoadedScenario, PlantKind, Scenario};
use crate::track_folder::TrackFolder;
use crate::track_run::{run_track, track_plan, TrackOutcome, TrackRun};
use crate::ExpError;
use figures::FigureDir;
use results::Results;
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::time::Instant;

pub use report::PaperValues;

/// What to run.
#[derive(Debug, Clone, PartialEq)]
pub struct ReproduceOptions {
    /// Folder holding the scenario files (`tracking.toml`, `obstacle.toml`, `obstacle-ignored.toml`,
    /// `robustness.toml`, `robustness-paper.toml`). Default `scenarios`.
    pub scenarios: PathBuf,
    /// A coarse parameter-study grid that CI can afford (the other experiments are unchanged).
    /// Default false.
    pub quick: bool,
    /// Also write the results page (e.g. `docs/results.md`) with the key figures copied into a folder
    /// named after it (`docs/results/`). Default none.
    pub results_page: Option<PathBuf>,
    /// Write into a non-empty output folder that is not a brachia run folder (its files are kept).
    /// Default false.
    pub force: bool,
}

impl Default for ReproduceOptions {
    fn default() -> Self {
        ReproduceOptions {
            scenarios: PathBuf::from("scenarios"),
            quick: false,
            results_page: None,
            force: false,
        }
    }
}

/// What a reproduction produced.
#[derive(Debug, Clone)]
pub struct Reproduction {
    /// The contents of `summary.json`.
    pub summary: Value,
    /// Experiments that did not succeed (a plan of V-B, V-C or V-D that did not converge, a figure that
    /// could not be drawn), each with the reason; empty when everything ran.
    pub failures: Vec<String>,
    /// Results worth a warning that are not failures of the run: parameter-study cells that did not
    /// converge (they are data of the study, shown as failed in the heat map and the tables).
    pub warnings: Vec<String>,
    /// Files written (figures, run folders' reports, REPORT.md, summary.json).
    pub files: Vec<PathBuf>,
    /// Wall time of the whole reproduction, s.
    pub wall_s: f64,
}

/// The ladder scenario of the reproduction (in [`ReproduceOptions::scenarios`]).
const LADDER_SCENARIO: &str = "ladder-even.toml";

/// Bars of the ladder traversed by `--quick` (two swings, one of each hand).
const QUICK_BARS: usize = 3;

/// Swings of the joint multi-swing plan compared with swing-by-swing planning (`--quick`: 2).
const JOINT_SWINGS: usize = 3;

/// Load scenario `name`; its solves, re-plans and closed loops stop once `cancel` is set.
fn load(
    opts: &ReproduceOptions,
    name: &str,
    cancel: &CancelToken,
) -> Result<LoadedScenario, ExpError> {
    let mut ls = Scenario::load(&opts.scenarios.join(name))?;
    ls.scenario.solver.cancel = Some(cancel.clone());
    Ok(ls)
}

fn write(folder: &crate::RunFolder, dir: &Path, files: &mut Vec<PathBuf>) -> Result<(), ExpError> {
    folder.write(dir)?;
    files.extend(folder.names().map(|n| dir.join(n)));
    Ok(())
}

/// Plan `ls`, then track that plan with each `(controller, plant)`. `Err(plan)` if the plan did not
/// converge.
/// A failure entry when the closed loop of `run` diverged (its run folder holds the rows before it).
fn note_divergence(name: &str, run: &TrackRun, failures: &mut Vec<String>) {
    if let Some(t) = run.summary.diverged_at_s {
        failures.push(format!(
            "{name}: the closed loop diverged at t = {t:.3} s (the run folder holds the rows before it)"
        ));
    }
}

fn plan_and_track(
    ls: &LoadedScenario,
    runs: &[(ControllerKind, PlantKind)],
    cancel: &CancelToken,
) -> Result<Result<Vec<TrackRun>, Box<PlanRun>>, ExpError> {
    let first = match run_track(ls, runs[0].0, runs[0].1, None)?.into_tracked() {
        Ok(r) => r,
        Err(p) => return Ok(Err(p)),
    };
    let mut out = Vec::with_capacity(runs.len());
    for &(c, p) in &runs[1..] {
        cancel.check()?;
        let (r, rep) = (first.reference.clone(), first.plan_report.clone());
        out.push(track_plan(ls, c, p, None, r, rep)?);
    }
    out.insert(0, first);
    Ok(Ok(out))
}

/// Run every experiment, write `out`, and return the summary. Errors on bad input (a scenario that does
/// not load) or when a file cannot be written; solver failures are collected in
/// [`Reproduction::failures`] instead. `progress` hears of every parameter-study solve (the long part);
/// pass [`crate::no_progress`] to ignore it.
pub fn reproduce(
    opts: &ReproduceOptions,
    out: &Path,
    progress: ProgressFn<'_>,
) -> Result<Reproduction, ExpError> {
    reproduce_cancellable(opts, out, progress, &CancelToken::new())
}

/// [`reproduce`] that can be cancelled: `cancel` is checked between the experiments and before every
/// parameter-study solve. Once it is set the run stops with [`ExpError::Cancelled`]: the staging folder
/// is removed, nothing is renamed into place, `out` (and the results page) stay as they were. A solve
/// or closed loop already running finishes first.
pub fn reproduce_cancellable(
    opts: &ReproduceOptions,
    out: &Path,
    progress: ProgressFn<'_>,
    cancel: &CancelToken,
) -> Result<Reproduction, ExpError> {
    let start = Instant::now();
    // load every scenario first: bad input stops the run before anything is computed or written
    let ls_track = load(opts, "tracking.toml", cancel)?;
    let ls_avoid = load(opts, "obstacle.toml", cancel)?;
    let ls_ignored = load(opts, "obstacle-ignored.toml", cancel)?;
    let ls_robust = load(opts, "robustness.toml", cancel)?;
    let ls_robust_paper = load(opts, "robustness-paper.toml", cancel)?;
    let mut ll_ladder = crate::LadderScenario::load(&opts.scenarios.join(LADDER_SCENARIO))?;
    if opts.quick {
        ll_ladder.scenario.ladder.bars.truncate(QUICK_BARS);
    }
    // its figures' animation stops on the token too
    ll_ladder.scenario.solver.cancel = Some(cancel.clone());
    let study_settings = study::settings(&ls_track, opts.quick);
    study_settings.validate()?;
    // the output places are checked before any work
    crate::run_folder::check_out_dir(out, opts.force)?;
    if let Some(page) = &opts.results_page {
        report::check_page(page, out)?;
    }
    let final_out = out;
    let stage = crate::run_folder::stage_for(out)?;
    let _cleanup = RemoveOnDrop(stage.clone());
    let out = stage.as_path();
    let mut failures = Vec::new();
    let mut files = Vec::new();
    cancel.check()?;

    // V-B: tracking, MPC on the physics engine and on the model
    match plan_and_track(
        &ls_track,
        &[
            (ControllerKind::Mpc, PlantKind::Rapier),
            (ControllerKind::Mpc, PlantKind::Model),
        ],
        cancel,
    )? {
        Ok(runs) => {
            write(&runs[0].folder, &out.join("tracking"), &mut files)?;
            write(&runs[1].folder, &out.join("tracking-model"), &mut files)?;
            note_divergence("tracking", &runs[0], &mut failures);
            note_divergence("tracking-model", &runs[1], &mut failures);
        }
        Err(p) => {
            write(&p.folder, &out.join("tracking/plan"), &mut files)?;
            failures.push(format!(
                "tracking: the planner did not converge ({:?})",
                p.plan.status
            ));
        }
    }

    cancel.check()?;

    // V-C: obstacle avoidance, with and without
    let avoid = run_plan(&ls_avoid)?;
    cancel.check()?;
    let ignored = run_plan(&ls_ignored)?;
    write(&avoid.folder, &out.join("obstacle/avoid"), &mut files)?;
    write(&ignored.folder, &out.join("obstacle/ignored"), &mut files)?;
    for (name, p) in [
        ("obstacle (avoid)", &avoid),
        ("obstacle (ignored)", &ignored),
    ] {
        if !p.plan.converged() {
            failures.push(format!(
                "{name}: the planner did not converge ({:?})",
                p.plan.status
            ));
        }
    }

    cancel.check()?;

    // V-D: robustness, a ball on the path, MPC and the baselines on the physics engine
    match plan_and_track(
        &ls_robust,
        &[
            (ControllerKind::Mpc, PlantKind::Rapier),
            (ControllerKind::Pd, PlantKind::Rapier),
            (ControllerKind::OpenLoop, PlantKind::Rapier),
        ],
        cancel,
    )? {
        Ok(runs) => {
            for r in &runs {
                write(
                    &r.folder,
                    &out.join("robustness").join(&r.log.controller),
                    &mut files,
                )?;
                note_divergence(
                    &format!("robustness ({})", r.log.controller),
                    r,
                    &mut failures,
                );
            }
            cancel.check()?;
            match run_track(
                &ls_robust_paper,
                ControllerKind::Mpc,
                PlantKind::Rapier,
                None,
            )? {
                TrackOutcome::Tracked(r) => {
                    write(&r.folder, &out.join("robustness-paper"), &mut files)?;
                    note_divergence("robustness (paper placement)", &r, &mut failures);
                }
                TrackOutcome::PlanFailed(p) => {
                    write(&p.folder, &out.join("robustness-paper/plan"), &mut files)?;
                    failures.push(format!(
                        "robustness (paper placement): the planner did not converge ({:?})",
                        p.plan.status
                    ));
                }
            }
        }
        Err(p) => {
            write(&p.folder, &out.join("robustness/mpc/plan"), &mut files)?;
            failures.push(format!(
                "robustness: the planner did not converge ({:?})",
                p.plan.status
            ));
        }
    }

    cancel.check()?;

    // a ladder traverse on the model plant
    let tr = crate::run_traverse_cancellable(&ll_ladder, cancel)?;
    let mut ladder_folder = tr.folder(&ll_ladder)?;
    // its robot, so the traverse's page draws the links to scale
    ladder_folder.add(
        crate::view::PARAMS_FILE,
        crate::view::params_toml(&ll_ladder.robot, &ll_ladder.scenario.params),
    );
    // the joint multi-swing plan of its first swings against swing-by-swing planning, in the same
    // folder (written with it)
    let joint = JOINT_SWINGS.min(ll_ladder.scenario.ladder.bars.len() - 1);
    match crate::ladder::joint_swings(&ll_ladder, joint, false) {
        Ok(j) => {
            if !j.converged() {
                failures.push(format!("ladder joint plan: {}", j.status));
            }
            ladder_folder.add_json("joint_swings.json", &crate::ladder::joint_swings_json(&j));
        }
        Err(e) => failures.push(format!("ladder joint plan: {e}")),
    }
    write(&ladder_folder, &out.join("ladder"), &mut files)?;
    if !tr.status.completed() {
        failures.push(format!("ladder: {}", tr.status));
    }
    drop(tr);

    // V-A: the parameter study (the longest part)
    let st =
        crate::parameter_study::run_parameter_study_cancellable(&study_settings, progress, cancel)?;
    write(
        &crate::parameter_study::parameter_study_folder(&st),
        &out.join("parameter-study"),
        &mut files,
    )?;
    let mut warnings = Vec::new();
    if st.failed_cells() > 0 {
        warnings.push(format!(
            "parameter study: {} of {} cells did not converge (shown as failed)",
            st.failed_cells(),
            st.cells.len()
        ));
    }
    drop(st);

    // figures, animations, the report: drawn from the run folders just written, as `brachia report`
    // redraws them
    let mut res = Results::read(out)?;
    res.quick = opts.quick;
    res.cores = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1);
    let (mut failures, figs) = draw_figures_into(&res, failures, out, cancel)?;
    cancel.check()?;
    files.extend(figs);
    let (pages, page_files) = views::write_pages(out, out, &mut failures)?;
    files.extend(page_files);
    res.wall_s = start.elapsed().as_secs_f64();
    let summary = report::summary(&res, &failures, &warnings);
    let summary_text = serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n";
    let md = report_md(&res, &failures, &warnings, &pages);
    let mut top = crate::RunFolder::default();
    top.add("summary.json", summary_text);
    top.add("REPORT.md", md);
    top.write_into(out)?;
    files.extend(top.names().map(|n| out.join(n)));
    cancel.check()?;
    crate::run_folder::install(out, final_out)?;
    let files: Vec<PathBuf> = files
        .iter()
        .map(|f| final_out.join(f.strip_prefix(out).unwrap_or(f)))
        .collect();
    let mut files = files;
    if let Some(page) = &opts.results_page {
        report::publish(&res, &failures, &warnings, final_out, page)?;
        files.push(page.clone());
    }
    Ok(Reproduction {
        summary,
        failures,
        warnings,
        files,
        wall_s: res.wall_s,
    })
}

/// `REPORT.md` of a reproduction folder: the report of `res` (its figures under `figures/`) and the
/// list of its interactive pages.
fn report_md(
    res: &Results,
    failures: &[String],
    warnings: &[String],
    pages: &[(&str, &str)],
) -> String {
    let figs = Path::new("figures");
    report::markdown(res, failures, warnings, figs, report::Target::Report)
        + &views::markdown(pages)
}

/// Draw every figure and animation of `res` into `out/figures/` (created); returns `failures` with the
/// figures that could not be drawn appended, and the figure files written.
fn draw_figures_into(
    res: &Results,
    mut failures: Vec<String>,
    out: &Path,
    cancel: &CancelToken,
) -> Result<(Vec<String>, Vec<PathBuf>), ExpError> {
    let fig_dir = out.join("figures");
    std::fs::create_dir_all(&fig_dir).map_err(|source| ExpError::Write {
        path: fig_dir.clone(),
        source,
    })?;
    let mut figs = FigureDir::new(&fig_dir, cancel);
    failures.extend(report::draw_figures(res, &mut figs));
    // a figure that failed was never written (the folder started empty)
    figs.written.retain(|p| p.is_file());
    Ok((failures, figs.written))
}

/// What [`redraw`] wrote.
#[derive(Debug, Clone)]
pub struct Redraw {
    /// The figures and REPORT.md, in place.
    pub files: Vec<PathBuf>,
    /// The failures REPORT.md lists: the reproduction's own (from `summary.json`) and the figures that
    /// could not be drawn now.
    pub failures: Vec<String>,
}

/// The kind of a run folder `report` does not draw (a traverse, a benchmark, a simulation), told by
/// its files as `brachia view` tells them.
fn not_drawn_here(dir: &Path) -> Option<&'static str> {
    let has = |f: &str| std::fs::symlink_metadata(dir.join(f)).is_ok();
    if has("closed_loop.csv") || has("summary.json") {
        None
    } else if has("traverse.csv") {
        Some("a `brachia traverse` folder")
    } else if has("scorecard.json") {
        Some("a `brachia benchmark` folder")
    } else if has("trajectory.csv") && !has("scenario.toml") {
        let report = crate::read::inside(dir, "report.json").ok().flatten()?;
        let text = brachia::limits::read_text_capped(
            &report,
            brachia::limits::MAX_JSON_BYTES,
            "JSON file",
        )
        .ok()?;
        let v: serde_json::Value = serde_json::from_str(&text).ok()?;
        (v.get("command").and_then(|c| c.as_str()) == Some("simulate"))
            .then_some("a `brachia simulate` folder")
    } else {
        None
    }
}

/// A folder that is not a reproduction: `dir` and what it lacks.
fn not_a_reproduction(dir: &Path, missing: &str) -> ExpError {
    ExpError::Input(brachia::Error::invalid(
        dir.display().to_string(),
        missing,
        "missing",
        format!(
            "a folder written by `brachia reproduce` holds {} and summary.json (or give a `brachia \
             plan` or `brachia track` run folder)",
            crate::MANIFEST
        ),
    ))
}

/// Redraw every figure and animation (`figures/`) and `REPORT.md` of the reproduction folder `dir` from
/// its run folders, without planning or simulating (or, for a single `brachia plan` / `brachia track` run
/// folder, draw its figures into its `figures/`); `summary.json` gives the run's mode, wall time,
/// cores, failures and warnings (it is not rewritten). Refused before anything is written when `dir` is
/// not a reproduction folder (no manifest or no `summary.json`) or a run folder does not read back.
/// Staged: everything is drawn into a hidden folder inside `dir`, then each file is renamed into place;
/// the figures of the previous drawing that are not drawn again are removed (only those its manifest
/// lists), the user's files are never touched.
pub fn redraw(dir: &Path) -> Result<Redraw, ExpError> {
    redraw_cancellable(dir, &CancelToken::new())
}

/// [`redraw`] that can be cancelled: `cancel` is checked before every figure and before anything is
/// put in place; once it is set the drawing ends with [`ExpError::Cancelled`], its staging folder is
/// removed and `dir` is as it was.
pub fn redraw_cancellable(dir: &Path, cancel: &CancelToken) -> Result<Redraw, ExpError> {
    if !dir.is_dir() {
        return Err(not_a_reproduction(dir, "(the folder itself)"));
    }
    // a manifest that lists a path leaving the folder, or of another schema, is refused before any work
    crate::manifest::read_manifest(dir)?;
    if let Some(kind) = not_drawn_here(dir) {
        return Err(ExpError::Input(brachia::Error::invalid(
            dir.display().to_string(),
            "(the folder)",
            kind,
            "`brachia report` draws the figures of plan, track and reproduce folders; `brachia view \
             DIR` shows this one",
        )));
    }
    // a report.json of any kind (a folder or a link in its place is refused by the run's reading,
    // naming it) makes it a single run folder
    let exists = |name: &str| std::fs::symlink_metadata(dir.join(name)).is_ok();
    let single = exists("report.json") && !exists("summary.json");
    if single && dir.join(crate::MANIFEST).is_file() {
        return redraw_run(dir, cancel);
    }
    for need in [crate::MANIFEST, "summary.json"] {
        if !dir.join(need).is_file() {
            return Err(not_a_reproduction(dir, need));
        }
    }
    check_complete(dir)?;
    let spath = dir.join("summary.json");
    let sum: Value = crate::read::read_json(&spath, crate::schema::JsonKind::Summary)?;
    let head = check::summary_head(&spath, &sum)?;
    let (quick, wall_s, cores) = (head.quick, head.wall_s, head.cores);
    let run_failures: Vec<String> = head
        .failures
        .into_iter()
        .filter(|f| !f.starts_with("figure "))
        .collect();
    let warnings = head.warnings;
    let mut res = Results::read(dir)?;
    res.quick = quick;
    res.wall_s = wall_s;
    res.cores = cores;
    // staged: draw into a hidden folder inside dir, then rename each file into place
    let stage = redraw_stage(dir)?;
    let _cleanup = RemoveOnDrop(stage.clone());
    let (mut failures, _drawn) = draw_figures_into(&res, run_failures, &stage, cancel)?;
    cancel.check()?;
    let (pages, _pages) = views::write_pages(dir, &stage, &mut failures)?;
    cancel.check()?;
    let md = report_md(&res, &failures, &warnings, &pages);
    let mut top = crate::RunFolder::default();
    top.add("REPORT.md", md);
    top.write_into(&stage)?;
    cancel.check()?;
    let files = put_in_place(dir, &stage)?;
    Ok(Redraw { files, failures })
}

/// Every file the manifest of the reproduction folder `dir` lists, except the figures and REPORT.md
/// that [`redraw`] draws again, must be there: a run folder removed (or a file of it) would silently drop
/// its section from the report, so it is refused, naming the first file missing.
fn check_complete(dir: &Path) -> Result<(), ExpError> {
    let listed = crate::manifest::read_manifest(dir)?.unwrap_or_default();
    let redrawn = |p: &Path| {
        p.starts_with("figures") || p.starts_with(views::VIEWS_DIR) || p == Path::new("REPORT.md")
    };
    match listed
        .files
        .keys()
        .find(|p| !redrawn(p) && !crate::manifest::plain_file(dir, p))
    {
        None => Ok(()),
        Some(p) => Err(ExpError::Input(brachia::Error::invalid(
            dir.display().to_string(),
            p.display().to_string(),
            "missing",
            format!(
                "a reproduction's report is redrawn from every file its manifest ({}) lists; \
                 run `brachia reproduce` again to rebuild the folder",
                crate::MANIFEST
            ),
        ))),
    }
}

/// Install what [`redraw`] drew into `stage` (figures, REPORT.md) into `dir` under its lock
/// ([`crate::run_folder::install_part`]): the previous drawing's figures that were not drawn again are
/// removed when brachia can prove it wrote them; the user's files are moved aside, never replaced.
fn put_in_place(dir: &Path, stage: &Path) -> Result<Vec<PathBuf>, ExpError> {
    crate::run_folder::install_part(stage, dir, &|p| {
        p.starts_with("figures") || p.starts_with(views::VIEWS_DIR)
    })
}

/// A fresh hidden staging folder inside `dir` for [`redraw`] (a name no entry has yet), marked as
/// this run's ([`crate::staging`]); first the staging folders of a drawing killed earlier are removed.
fn redraw_stage(dir: &Path) -> Result<PathBuf, ExpError> {
    crate::staging::clear_stale(dir, crate::staging::REPORT_STAGE_PREFIX);
    let mut k = 0;
    loop {
        let stage = dir.join(format!(
            "{}{}-{k}",
            crate::staging::REPORT_STAGE_PREFIX,
            std::process::id()
        ));
        match crate::staging::create(&stage) {
            Ok(()) => return Ok(stage),
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => k += 1,
            Err(source) => {
                return Err(ExpError::Write {
                    path: stage,
                    source,
                })
            }
        }
    }
}

/// [`redraw`] of a single `brachia plan` or `brachia track` run folder: its figures into `dir/figures/`
/// (a plan: stick diagram and animation; a track run: joints, EE path and error, and, when it planned,
/// stick diagram and animation).
fn redraw_run(dir: &Path, cancel: &CancelToken) -> Result<Redraw, ExpError> {
    let stage = redraw_stage(dir)?;
    let _cleanup = RemoveOnDrop(stage.clone());
    let fig_dir = stage.join("figures");
    std::fs::create_dir_all(&fig_dir).map_err(|source| ExpError::Write {
        path: fig_dir.clone(),
        source,
    })?;
    let mut figs = FigureDir::new(&fig_dir, cancel);
    let failures = if dir.join("closed_loop.csv").is_file() {
        report::draw_track_run(&TrackFolder::read(dir)?, &mut figs)
    } else {
        report::draw_plan_run(&PlanFolder::read(dir)?, &mut figs)
    };
    figs.written.retain(|p| p.is_file());
    cancel.check()?;
    let files = put_in_place(dir, &stage)?;
    Ok(Redraw { files, failures })
}

/// Removes a staging folder when a run stops early (an error or a panic); a no-op once the folder has
/// been renamed into place.
struct RemoveOnDrop(PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        crate::staging::remove(&self.0);
    }
}
