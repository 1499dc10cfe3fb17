//! `brachia reproduce`: every experiment of the paper's Section V in one run, with figures, animations,
//! a Markdown report that puts our numbers beside the paper's, and a machine-readable summary.
//!
//! Output folder layout (`DIR`):
//! - `REPORT.md`, `summary.json`;
//! - `figures/`: `fig3_*.png` .. `fig8_*.png` (each with an `.svg` beside it) and one GIF per swing;
//! - one run folder per experiment (`parameter-study/`, `tracking/`, `tracking-model/`,
//!   `obstacle/avoid/`, `obstacle/ignored/`, `robustness/{mpc,pd,open-loop}/`, `robustness-paper/`),
//!   each with its resolved inputs, CSVs and `report.json`, as `brachia plan` / `brachia track` write them.
//!
//! Everything is written into a staging folder next to `DIR` and renamed into place when complete
//! ([`crate::run_folder`]): an interrupted run leaves the previous results as they were, and a re-run
//! replaces only the files the previous run wrote (its manifest), never the user's own. An experiment whose solver does not converge
//! is reported as such (its run folder is still written) and the others go on; [`Reproduction::failures`]
//! lists them. Units: SI (s, m, rad, N m, J).

mod figures;
mod report;
mod study;

use crate::plan_run::{run_plan, PlanRun};
use crate::scenario::{ControllerKind, LoadedScenario, PlantKind, Scenario};
use crate::track_run::{run_track, track_plan, TrackRun};
use crate::ExpError;
use figures::FigureDir;
use serde_json::{json, Value};
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
    /// Show a progress bar for the parameter study (hidden anyway when stderr is not a terminal).
    /// Default true.
    pub progress: bool,
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
            progress: true,
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

/// The results of the tracking experiment (paper V-B).
pub(crate) struct Tracking {
    pub(crate) ls: LoadedScenario,
    /// MPC on the rapier plant (the paper's Webots run).
    pub(crate) rapier: TrackRun,
    /// MPC on the RK4 model plant (the same plan).
    pub(crate) model: TrackRun,
}

/// The results of the obstacle experiment (paper V-C).
pub(crate) struct ObstacleRuns {
    pub(crate) avoid: (LoadedScenario, PlanRun),
    pub(crate) ignored: (LoadedScenario, PlanRun),
}

/// The results of the robustness experiment (paper V-D).
pub(crate) struct Robustness {
    pub(crate) ls: LoadedScenario,
    /// MPC, PD, open loop on the rapier plant, the same plan.
    pub(crate) runs: Vec<TrackRun>,
    /// The scenario with the paper's ball placement.
    pub(crate) paper_ls: LoadedScenario,
    /// MPC with the paper's ball placement.
    pub(crate) paper: Option<TrackRun>,
}

/// Everything the report reads.
#[derive(Default)]
pub(crate) struct Results {
    pub(crate) tracking: Option<Tracking>,
    pub(crate) obstacle: Option<ObstacleRuns>,
    pub(crate) robustness: Option<Robustness>,
    pub(crate) study: Option<crate::parameter_study::ParameterStudy>,
    pub(crate) quick: bool,
    pub(crate) wall_s: f64,
}

fn load(opts: &ReproduceOptions, name: &str) -> Result<LoadedScenario, ExpError> {
    Ok(Scenario::load(&opts.scenarios.join(name))?)
}

fn write(folder: &crate::RunFolder, dir: &Path, files: &mut Vec<PathBuf>) -> Result<(), ExpError> {
    folder.write(dir)?;
    files.extend(folder.names().map(|n| dir.join(n)));
    Ok(())
}

/// Plan `ls`, then track that plan with each `(controller, plant)`. `Err(plan)` if the plan did not
/// converge.
fn plan_and_track(
    ls: &LoadedScenario,
    runs: &[(ControllerKind, PlantKind)],
) -> Result<Result<Vec<TrackRun>, Box<PlanRun>>, ExpError> {
    let first = match run_track(ls, runs[0].0, runs[0].1, None)? {
        Ok(r) => r,
        Err(p) => return Ok(Err(p)),
    };
    let mut out = Vec::with_capacity(runs.len());
    for &(c, p) in &runs[1..] {
        let (r, rep) = (first.reference.clone(), first.plan_report.clone());
        out.push(track_plan(ls, c, p, None, r, rep)?);
    }
    out.insert(0, first);
    Ok(Ok(out))
}

/// Run every experiment, write `out`, and return the summary. Errors on bad input (a scenario that does
/// not load) or when a file cannot be written; solver failures are collected in
/// [`Reproduction::failures`] instead.
pub fn reproduce(opts: &ReproduceOptions, out: &Path) -> Result<Reproduction, ExpError> {
    let start = Instant::now();
    // load every scenario first: bad input stops the run before anything is computed or written
    let ls_track = load(opts, "tracking.toml")?;
    let ls_avoid = load(opts, "obstacle.toml")?;
    let ls_ignored = load(opts, "obstacle-ignored.toml")?;
    let ls_robust = load(opts, "robustness.toml")?;
    let ls_robust_paper = load(opts, "robustness-paper.toml")?;
    let study_settings = study::settings(&ls_track, opts.quick);
    study_settings.validate()?;
    // the output places are checked before any work
    crate::run_folder::check_out_dir(out, opts.force)?;
    if let Some(page) = &opts.results_page {
        report::check_page(page)?;
    }
    let final_out = out;
    let stage = crate::run_folder::stage_for(out)?;
    let _cleanup = RemoveOnDrop(stage.clone());
    let out = stage.as_path();
    let mut failures = Vec::new();
    let mut files = Vec::new();
    let mut res = Results {
        quick: opts.quick,
        ..Results::default()
    };

    // V-B: tracking, MPC on the physics engine and on the model
    match plan_and_track(
        &ls_track,
        &[
            (ControllerKind::Mpc, PlantKind::Rapier),
            (ControllerKind::Mpc, PlantKind::Model),
        ],
    )? {
        Ok(mut runs) => {
            let model = runs.pop().expect("two runs");
            let rapier = runs.pop().expect("two runs");
            write(&rapier.folder, &out.join("tracking"), &mut files)?;
            write(&model.folder, &out.join("tracking-model"), &mut files)?;
            res.tracking = Some(Tracking {
                ls: ls_track.clone(),
                rapier,
                model,
            });
        }
        Err(p) => {
            write(&p.folder, &out.join("tracking/plan"), &mut files)?;
            failures.push(format!(
                "tracking: the planner did not converge ({:?})",
                p.plan.status
            ));
        }
    }

    // V-C: obstacle avoidance, with and without
    let avoid = run_plan(&ls_avoid)?;
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
    res.obstacle = Some(ObstacleRuns {
        avoid: (ls_avoid, avoid),
        ignored: (ls_ignored, ignored),
    });

    // V-D: robustness, a ball on the path, MPC and the baselines on the physics engine
    match plan_and_track(
        &ls_robust,
        &[
            (ControllerKind::Mpc, PlantKind::Rapier),
            (ControllerKind::Pd, PlantKind::Rapier),
            (ControllerKind::OpenLoop, PlantKind::Rapier),
        ],
    )? {
        Ok(runs) => {
            for r in &runs {
                write(
                    &r.folder,
                    &out.join("robustness").join(&r.log.controller),
                    &mut files,
                )?;
            }
            let paper = match run_track(
                &ls_robust_paper,
                ControllerKind::Mpc,
                PlantKind::Rapier,
                None,
            )? {
                Ok(r) => {
                    write(&r.folder, &out.join("robustness-paper"), &mut files)?;
                    Some(r)
                }
                Err(p) => {
                    write(&p.folder, &out.join("robustness-paper/plan"), &mut files)?;
                    failures.push(format!(
                        "robustness (paper placement): the planner did not converge ({:?})",
                        p.plan.status
                    ));
                    None
                }
            };
            res.robustness = Some(Robustness {
                ls: ls_robust,
                runs,
                paper_ls: ls_robust_paper,
                paper,
            });
        }
        Err(p) => {
            write(&p.folder, &out.join("robustness/mpc/plan"), &mut files)?;
            failures.push(format!(
                "robustness: the planner did not converge ({:?})",
                p.plan.status
            ));
        }
    }

    // V-A: the parameter study (the longest part)
    let st = crate::parameter_study::run_parameter_study(&study_settings, opts.progress)?;
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
    res.study = Some(st);

    // figures, animations, the report
    let fig_dir = out.join("figures");
    std::fs::create_dir_all(&fig_dir).map_err(|source| ExpError::Write {
        path: fig_dir.clone(),
        source,
    })?;
    let mut figs = FigureDir::new(&fig_dir);
    let fig_failures = report::draw_figures(&res, &mut figs);
    failures.extend(fig_failures);
    // a figure that failed was never written (the folder started empty)
    figs.written.retain(|p| p.is_file());
    files.extend(figs.written.iter().cloned());
    res.wall_s = start.elapsed().as_secs_f64();
    let summary = report::summary(&res, &failures, &warnings);
    let summary_text = serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n";
    let md = report::markdown(
        &res,
        &failures,
        &warnings,
        Path::new("figures"),
        report::Target::Report,
    );
    let mut top = crate::RunFolder::default();
    top.add("summary.json", summary_text);
    top.add("REPORT.md", md);
    top.write_into(out)?;
    files.extend(top.names().map(|n| out.join(n)));
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

/// Removes a staging folder when a run stops early (an error or a panic); a no-op once the folder has
/// been renamed into place.
struct RemoveOnDrop(PathBuf);

impl Drop for RemoveOnDrop {
    fn drop(&mut self) {
        if self.0.is_dir() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// Keys of `summary.json` (stable names other tools read).
pub(crate) fn summary_skeleton(res: &Results) -> Value {
    json!({
        "mode": if res.quick { "quick" } else { "full" },
        "wall_time_s": res.wall_s,
        "cores": std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1),
    })
}
