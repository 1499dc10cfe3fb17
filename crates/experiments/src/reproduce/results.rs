//! What the report reads: the run folders of a reproduction read back ([`Results::read`]) and the
//! facts of its run.

use super::check;
use crate::parameter_study::ParameterStudy;
use crate::read::{read_json, PlanFolder};
use crate::scenario::LoadedScenario;
use crate::schema::JsonKind;
use crate::track_folder::TrackFolder;
use serde_json::{json, Value};
use std::path::Path;

/// The tracking experiment (paper V-B), read from its run folders.
pub(crate) struct Tracking {
    /// The resolved scenario (`tracking/plan/scenario.toml`).
    pub(crate) ls: LoadedScenario,
    /// MPC on the rapier plant (the paper's Webots run), `tracking/`.
    pub(crate) rapier: TrackFolder,
    /// MPC on the RK4 model plant (the same plan), `tracking-model/`.
    pub(crate) model: TrackFolder,
}

/// The obstacle experiment (paper V-C), read from `obstacle/avoid/` and `obstacle/ignored/`.
pub(crate) struct ObstacleRuns {
    pub(crate) avoid: PlanFolder,
    pub(crate) ignored: PlanFolder,
}

/// The robustness experiment (paper V-D), read from its run folders.
pub(crate) struct Robustness {
    /// The resolved scenario (`robustness/mpc/plan/scenario.toml`).
    pub(crate) ls: LoadedScenario,
    /// MPC, PD, open loop on the rapier plant, the same plan (`robustness/{mpc,pd,open-loop}/`).
    pub(crate) runs: Vec<TrackFolder>,
    /// MPC with the paper's ball placement (`robustness-paper/`), when its plan converged.
    pub(crate) paper: Option<TrackFolder>,
}

/// Everything the report reads: the run folders of a reproduction and the facts of its run.
#[derive(Default)]
pub(crate) struct Results {
    pub(crate) tracking: Option<Tracking>,
    pub(crate) obstacle: Option<ObstacleRuns>,
    pub(crate) robustness: Option<Robustness>,
    pub(crate) study: Option<ParameterStudy>,
    /// The ladder traverse's `ladder/report.json`.
    pub(crate) ladder: Option<Value>,
    /// The joint multi-swing plan against swing by swing, `ladder/joint_swings.json`.
    pub(crate) ladder_joint: Option<Value>,
    pub(crate) quick: bool,
    pub(crate) wall_s: f64,
    pub(crate) cores: usize,
}

/// The controllers of the robustness experiment, by run folder name.
const ROBUSTNESS_RUNS: [&str; 3] = ["mpc", "pd", "open-loop"];

impl Results {
    /// Read the run folders of the reproduction in `dir` (an experiment whose folder holds no
    /// `report.json` of its kind, because its plan did not converge, is absent).
    pub(crate) fn read(dir: &Path) -> Result<Results, brachia::Error> {
        let has = |p: &str| dir.join(p).join("report.json").is_file();
        let scenario_of = |t: &TrackFolder| {
            t.plan.as_ref().map(|p| p.scenario.clone()).ok_or_else(|| {
                brachia::Error::invalid(
                    t.dir.display().to_string(),
                    "plan",
                    "missing",
                    "the run that planned holds its plan folder plan/",
                )
            })
        };
        let mut res = Results::default();
        if has("tracking") && has("tracking-model") {
            let rapier = TrackFolder::read(&dir.join("tracking"))?;
            let model = TrackFolder::read(&dir.join("tracking-model"))?;
            res.tracking = Some(Tracking {
                ls: scenario_of(&rapier)?,
                rapier,
                model,
            });
        }
        if has("obstacle/avoid") && has("obstacle/ignored") {
            res.obstacle = Some(ObstacleRuns {
                avoid: PlanFolder::read(&dir.join("obstacle/avoid"))?,
                ignored: PlanFolder::read(&dir.join("obstacle/ignored"))?,
            });
        }
        if has("robustness/mpc") {
            let runs = ROBUSTNESS_RUNS
                .iter()
                .map(|c| TrackFolder::read(&dir.join("robustness").join(c)))
                .collect::<Result<Vec<_>, _>>()?;
            let paper = if has("robustness-paper") {
                Some(TrackFolder::read(&dir.join("robustness-paper"))?)
            } else {
                None
            };
            res.robustness = Some(Robustness {
                ls: scenario_of(&runs[0])?,
                runs,
                paper,
            });
        }
        if has("ladder") {
            let path = dir.join("ladder/report.json");
            let l: Value = read_json(&path, JsonKind::TraverseReport)?;
            check::ladder_report(&path, &l)?;
            res.ladder = Some(l);
            let path = dir.join("ladder/joint_swings.json");
            if path.is_file() {
                let j: Value = read_json(&path, JsonKind::JointSwings)?;
                check::joint_swings(&path, &j)?;
                res.ladder_joint = Some(j);
            }
        }
        if has("parameter-study") {
            res.study = Some(crate::parameter_study::read_parameter_study(
                &dir.join("parameter-study"),
            )?);
        }
        Ok(res)
    }
}

/// Keys of `summary.json` (stable names other tools read).
pub(crate) fn summary_skeleton(res: &Results) -> Value {
    json!({
        "mode": if res.quick { "quick" } else { "full" },
        "wall_time_s": res.wall_s,
        "cores": res.cores,
    })
}
