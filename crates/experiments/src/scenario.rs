//! The scenario file: one experiment, declared.
//!
//! ```toml
//! params = "../params/paper.toml"       # robot parameters, relative to this file
//! [task]
//! q0 = [-2.35, 0.0, -1.55, 0.0]         # rad: q1 absolute from +x, the rest relative
//! qd0 = [0.0, 0.0, 0.0, 0.0]            # rad/s (optional, default at rest)
//! target = [0.8, 0.0]                   # m, the target bar in the grip frame
//! obstacles = [{ center = [0.55, -0.2], radius = 0.1 }]
//! [planner]                             # every field optional; see brachia::planning::PlannerSettings
//! swing_time = "auto"                   # or seconds
//! knot_dt = 0.01
//! transcription = "hermite-simpson"     # euler | trapezoidal | hermite-simpson
//! q1_diag = [0.01, 0.01, 0.01, 0.01]
//! r1_diag = [1.0, 1.0, 1.0]
//! avoid_obstacles = true
//! [solver]                              # see brachia::planning::NlpSettings
//! backend = "pounce"                    # pounce | ripopt
//! ```

use brachia::planning::{NlpSettings, PlannerSettings, SwingTask};
use brachia::{Error, Robot};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// A scenario as written in a TOML file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Scenario {
    /// A name for reports (default: the file stem).
    #[serde(default)]
    pub name: String,
    /// Robot parameters file, relative to the scenario file.
    pub params: PathBuf,
    /// What to plan.
    pub task: SwingTask,
    /// Planner settings.
    #[serde(default)]
    pub planner: PlannerSettings,
    /// NLP solver settings.
    #[serde(default)]
    pub solver: NlpSettings,
}

/// A scenario with its robot loaded and its paths resolved.
#[derive(Debug, Clone)]
pub struct LoadedScenario {
    /// The scenario (with `params` made absolute or relative to the working directory).
    pub scenario: Scenario,
    /// The validated robot.
    pub robot: Robot,
    /// Where it was read from.
    pub path: PathBuf,
}

impl Scenario {
    /// Parse a scenario from TOML text; `source` names it in errors.
    pub fn from_toml_str(text: &str, source: &str) -> Result<Self, Error> {
        toml::from_str(text).map_err(|e| Error::Parse {
            path: source.into(),
            message: e.to_string().trim_end().replace('\n', " "),
        })
    }

    /// Read a scenario file, load its robot and validate everything (nothing is solved).
    pub fn load(path: &Path) -> Result<LoadedScenario, Error> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.into(),
            source,
        })?;
        let src = path.display().to_string();
        let mut sc = Self::from_toml_str(&text, &src)?;
        if sc.name.is_empty() {
            sc.name = path
                .file_stem()
                .map(|s| s.to_string_lossy().to_string())
                .unwrap_or_default();
        }
        let base = path.parent().unwrap_or(Path::new("."));
        sc.params = base.join(&sc.params);
        let robot = Robot::from_toml_file(&sc.params)?;
        sc.planner.validate(robot.n, &src)?;
        sc.solver.validate().map_err(|e| match e {
            Error::InvalidValue {
                field,
                value,
                reason,
                ..
            } => Error::InvalidValue {
                source_name: src.clone(),
                field: format!("solver.{field}"),
                value,
                reason,
            },
            other => other,
        })?;
        let n = robot.n;
        if sc.task.q0.len() != n {
            return Err(Error::invalid(
                &src,
                "task.q0",
                format!("{:?}", sc.task.q0),
                format!("needs {n} values"),
            ));
        }
        if !sc.task.qd0.is_empty() && sc.task.qd0.len() != n {
            return Err(Error::invalid(
                &src,
                "task.qd0",
                format!("{:?}", sc.task.qd0),
                format!("needs {n} values"),
            ));
        }
        for (i, o) in sc.task.obstacles.iter().enumerate() {
            o.validate(&src, &format!("task.obstacles[{i}]"))?;
        }
        Ok(LoadedScenario {
            scenario: sc,
            robot,
            path: path.to_path_buf(),
        })
    }
}
