//! The paper's parameter study (Section V-A, Figs. 3 and 4): energy of the planned swing over a grid of
//! lower-to-total arm length ratios `r2 = L1 / (L1 + L2)` and swing times around `T = 2 T_freefall`.
//!
//! - **Scaled robots** ([`scaled_params`], any 3..=12 links, [`check_study_links`]): the robot is two
//!   mirrored arms of `A = arm_length_m` each (default 0.71 m), `n / 2` links per arm counted from each
//!   hand (links `1..=n/2` and `n+1-n/2..=n`) and, for an odd n, a middle link between the arms with
//!   half of it counted in each arm. `r2` is the hand link's share of its arm: `L1 = Ln = r2 A`; the
//!   rest `(1 - r2) A` of each arm is shared by its inner links (and half the middle link) in
//!   proportion to the base's lengths, averaged over mirror pairs, so link i and link n+1-i always
//!   have the same length. For 4 links: `L1 = L4 = r2 A` (lower arms), `L2 = L3 = (1 - r2) A` (upper
//!   arms), `r2 = L1 / (L1 + L2)`, the paper's rule. For 3 links the middle link is the two upper arms
//!   joined, `L2 = 2 (1 - r2) A`. 2 links are refused: each arm is its hand link alone.
//!   Each link of the base robot (Table I at r2 = 0.5) scales with its length ratio `s = L / L_base`:
//!   mass `* s` (same linear density), centre of mass `* s` (same fraction of the length), planar
//!   inertia `* s^3` (as `m L^2`); the capsule radius, gravity and torque limits stay. At r2 = 0.5 with
//!   A = 0.71 the base robot Table I comes back unchanged.
//! - **Start pose** ([`start_pose`]): the EE at the start bar with both arms straight (for 4 links
//!   `q2 = q4 = 0`) and the shoulder (joint 3) below the bar; the same for every r2 of an even link
//!   count, since only the arm lengths matter. For an odd count the middle link lies parallel to the
//!   line from the grip to the start bar, below it, the arms bent symmetrically at its two joints; it
//!   depends on r2, so each row has its own (a row whose middle link is too long to let the EE reach
//!   the start bar is refused, naming its `r2[i]`, before anything is solved).
//! - **Grid**: every r2 times every offset, swing time `T + offset` with `T = 2 T_freefall` of that r2
//!   (EE from the start to the x midway between start and target bars, joints locked; see
//!   [`brachia::planning::freefall_time`]).
//! - **Parallel rows, warm-started cells, continuation in r2**: (1) every row's centre cell (the offset
//!   closest to 0) cold, one rayon task per r2 row, the longest swings first; (2) a row whose centre did
//!   not converge is solved again warm-started ([`brachia::planning::plan_with_guess`]) from the
//!   converged centre of its neighbour in r2 (sweeping up, then down; [`CellStart::WarmFromRow`]);
//!   (3) every row walks outwards from its centre in both directions, in parallel, each cell
//!   warm-started from the last converged cell on its side; a cell with no converged neighbour starts
//!   cold, and a warm-started cell that does not converge is solved again cold (its iterations and
//!   time are then the sum of both solves). `solver.max_iter` caps each attempt.
//! - A cell that fails keeps its [`SolveStatus`], iterations and time and has no energy; nothing is
//!   dropped. A cold solve that fails is continued on the torque limits by the planner
//!   (`[planner] torque_continuation`, [`brachia::planning::strategy::torque_continuation`]; about 1-2 s per such
//!   cell): the cell converges if that reaches the real limits, else it records the scale reached
//!   ([`StudyCell::torque_scale_reached`]).
//!
//! Energy of a cell: paper eq. (18), `E = sum_{i=2..n} int_0^T qd_i tau_i dt` (signed work of the
//! actuated joints, J), i.e. [`brachia::planning::Plan::energy_j`].
//!
//! Units: m, kg, kg m^2, s, rad, N m, J.

use crate::progress::{CancelToken, Progress, ProgressFn};
use crate::run_folder::RunFolder;
use crate::scenario::{in_section, parse_toml, read_text};
use crate::ExpError;
use brachia::model::{Robot, RobotParams};
use brachia::planning::{
    freefall_time, plan_with_guess, NlpSettings, PlannerSettings, SolveStatus, SwingTask, SwingTime,
};
use brachia::trajectory::Trajectory;
use brachia::Error;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

mod geometry;
mod read;
use geometry::SRC;
pub use geometry::{check_study_links, scaled_params, start_pose};
pub use read::read_parameter_study;

/// Two r2 values (or offsets) closer than this are the same grid value.
const SAME: f64 = 1e-9;

/// Most cells a study's grid may have (`r2` values x offsets): every cell is one NLP solve. The
/// paper's grid has 99.
pub const MAX_STUDY_CELLS: usize = 10_000;

/// Most stick diagrams (`stick_r2` values): each is one more solve and a 1 ms trajectory in memory.
pub const MAX_STICKS: usize = 32;

/// Where the base robot (the one scaled to every r2) comes from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum BaseParams {
    /// The bundled `params/paper.toml` (Table I). Default. TOML: `base_params = "paper"`.
    #[default]
    Paper,
    /// A parameters file. TOML: `base_params = { file = "../params/paper-uniform-rod.toml" }`,
    /// relative to the settings file when read by [`ParameterStudySettings::from_toml_file`].
    File(PathBuf),
    /// Parameters given in place. TOML: `[base_params.inline]` with the fields of a parameters file.
    Inline(RobotParams),
}

impl BaseParams {
    /// Read (for `File`) and validate the base parameters, and check that the study's rule applies to
    /// their link count ([`check_study_links`]: 3..=12 links).
    pub fn load(&self) -> Result<RobotParams, Error> {
        let p = match self {
            BaseParams::Paper => Robot::paper().params().clone(),
            BaseParams::File(path) => RobotParams::from_toml_file(path)?,
            BaseParams::Inline(p) => p.clone(),
        };
        let src = match self {
            BaseParams::File(path) => path.display().to_string(),
            _ => "base_params".to_string(),
        };
        p.validate(&src)?;
        check_study_links(p.links.len(), &src, "links")?;
        Ok(p)
    }
}

/// Settings of the study. Plain data with [`Default`] (the paper's grid), serde and
/// [`ParameterStudySettings::validate`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ParameterStudySettings {
    /// The robot scaled to every r2. Default `paper` (the bundled Table I).
    pub base_params: BaseParams,
    /// Length of each arm, `L1 + L2 = L3 + L4`, m. Default 0.71.
    pub arm_length_m: f64,
    /// Lower-to-total arm length ratios r2 = L1 / (L1 + L2), each in (0, 1), strictly increasing.
    /// Default 0.1, 0.2, ..., 0.9.
    pub r2: Vec<f64>,
    /// Swing-time offsets from `T = 2 T_freefall`, s, strictly increasing. Default -0.5, -0.4, ..., 0.5.
    pub offsets_s: Vec<f64>,
    /// Start bar (the EE's start), m, in the grip frame. Default (-1, 0).
    pub start: [f64; 2],
    /// Target bar, m. Default (1, 0).
    pub target: [f64; 2],
    /// r2 values whose swing at their own T is kept as a 1 ms trajectory for stick diagrams (Fig. 4b).
    /// Default [0.2, 0.8] (a short and a long lower arm).
    pub stick_r2: Vec<f64>,
    /// Warm-start each cell from its converged neighbour in the row. Default true.
    pub warm_start: bool,
    /// Planner settings for every cell: `knot_dt` (default 0.03 s, the planner's; 0.04-0.05 for a
    /// quick run), `transcription` (default `multiple-shooting`, RK4 with held torques), weights,
    /// bounds: [`PlannerSettings::default`] unless given. `swing_time` must stay `"auto"`: the study
    /// sets each cell's swing time.
    pub planner: PlannerSettings,
    /// Solver settings for every cell (default `backend = "ocp"`, the Riccati interior-point solver).
    /// The paper's path is `transcription = "hermite-simpson"` with `backend = "pounce"`; `ocp` with a
    /// collocation transcription is refused by `validate()`.
    pub solver: NlpSettings,
}

impl Default for ParameterStudySettings {
    fn default() -> Self {
        ParameterStudySettings {
            base_params: BaseParams::Paper,
            arm_length_m: 0.71,
            r2: (1..=9).map(|i| i as f64 / 10.0).collect(),
            offsets_s: (-5..=5).map(|i| i as f64 / 10.0).collect(),
            start: [-1.0, 0.0],
            target: [1.0, 0.0],
            stick_r2: vec![0.2, 0.8],
            warm_start: true,
            planner: PlannerSettings::default(),
            solver: NlpSettings::default(),
        }
    }
}

impl ParameterStudySettings {
    /// Parse settings from TOML text (not validated); `source` names it in errors.
    pub fn from_toml_str(text: &str, source: &str) -> Result<Self, Error> {
        parse_toml(text, source)
    }

    /// Read settings from a TOML file, resolve a `base_params` file relative to it and validate.
    pub fn from_toml_file(path: &Path) -> Result<Self, Error> {
        let text = read_text(path)?;
        let src = path.display().to_string();
        let mut s = Self::from_toml_str(&text, &src)?;
        if let BaseParams::File(f) = &s.base_params {
            s.base_params = BaseParams::File(path.parent().unwrap_or(Path::new(".")).join(f));
        }
        s.validate_as(&src)?;
        Ok(s)
    }

    /// Check every value, read the base parameters ([`BaseParams::load`]) and build every robot of
    /// the study with its start pose and swing time, so that everything the study would refuse is
    /// refused here, before anything is solved; the error names the field.
    pub fn validate(&self) -> Result<(), Error> {
        self.validate_as(SRC)
    }

    fn validate_as(&self, src: &str) -> Result<(), Error> {
        self.prepare(src).map(|_| ())
    }

    /// The checks of [`Self::validate`]; returns what the study solves.
    fn prepare(&self, src: &str) -> Result<Prepared, Error> {
        let cells = self.r2.len().saturating_mul(self.offsets_s.len());
        if cells > MAX_STUDY_CELLS {
            return Err(Error::invalid(
                src,
                "r2, offsets_s",
                format!("{} x {} cells", self.r2.len(), self.offsets_s.len()),
                format!(
                    "the grid may have at most {MAX_STUDY_CELLS} cells (parameter_study::MAX_STUDY_CELLS; \
                     the paper's has 99)"
                ),
            ));
        }
        if self.stick_r2.len() > MAX_STICKS {
            return Err(Error::invalid(
                src,
                "stick_r2",
                format!("{} values", self.stick_r2.len()),
                format!("at most {MAX_STICKS} stick diagrams (parameter_study::MAX_STICKS)"),
            ));
        }
        let a = self.arm_length_m;
        if !(a.is_finite() && a > 0.0) {
            return Err(Error::invalid(
                src,
                "arm_length_m",
                a,
                "must be finite and > 0",
            ));
        }
        let ratio = |field: &str, v: &[f64], need_increasing: bool| -> Result<(), Error> {
            for (i, &x) in v.iter().enumerate() {
                if !(x.is_finite() && x > 0.0 && x < 1.0) {
                    return Err(Error::invalid(
                        src,
                        format!("{field}[{i}]"),
                        x,
                        "must lie in (0, 1)",
                    ));
                }
                if need_increasing && i > 0 && x <= v[i - 1] {
                    return Err(Error::invalid(
                        src,
                        format!("{field}[{i}]"),
                        x,
                        "values must increase strictly",
                    ));
                }
            }
            Ok(())
        };
        if self.r2.is_empty() {
            return Err(Error::invalid(src, "r2", "[]", "needs at least one value"));
        }
        ratio("r2", &self.r2, true)?;
        ratio("stick_r2", &self.stick_r2, false)?;
        if self.offsets_s.is_empty() {
            return Err(Error::invalid(
                src,
                "offsets_s",
                "[]",
                "needs at least one value",
            ));
        }
        for (i, &x) in self.offsets_s.iter().enumerate() {
            if !x.is_finite() || (i > 0 && x <= self.offsets_s[i - 1]) {
                return Err(Error::invalid(
                    src,
                    format!("offsets_s[{i}]"),
                    x,
                    "must be finite and increase strictly",
                ));
            }
        }
        for (field, p) in [("start", self.start), ("target", self.target)] {
            if !(p[0].is_finite() && p[1].is_finite()) {
                return Err(Error::invalid(
                    src,
                    field,
                    format!("{p:?}"),
                    "must be finite",
                ));
            }
        }
        if self.start == self.target {
            return Err(Error::invalid(
                src,
                "target",
                format!("{:?}", self.target),
                "must differ from start",
            ));
        }
        if self.planner.swing_time != SwingTime::default() {
            return Err(Error::invalid(
                src,
                "planner.swing_time",
                format!("{:?}", self.planner.swing_time),
                "the study sets each cell's swing time (T + offset); leave it \"auto\"",
            ));
        }
        self.solver
            .validate()
            .map_err(|e| in_section(e, src, "solver"))?;
        self.planner.check_backend(&self.solver, src)?;
        let base = match &self.base_params {
            BaseParams::Inline(p) => {
                p.validate(src)
                    .map_err(|e| in_section(e, src, "base_params.inline"))?;
                check_study_links(p.links.len(), src, "base_params.inline.links")?;
                p.clone()
            }
            other => other.load()?,
        };
        self.planner
            .validate(base.links.len(), src)
            .map_err(|e| in_section(e, src, "planner"))?;
        prepare_rows(base, self, src)
    }
}

/// How a cell's solve started.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum CellStart {
    /// From the planner's own guess (no converged neighbour, or warm starts off).
    Cold,
    /// From the converged neighbour's plan.
    Warm,
    /// The warm-started solve did not converge; this is the result of a second, cold solve.
    ColdAfterWarm,
    /// The row's centre cell did not converge cold; this is the result of a solve warm-started from the
    /// converged centre of the neighbouring r2 row (continuation in r2, its time axis rescaled).
    WarmFromRow,
}

impl CellStart {
    fn name(self) -> &'static str {
        match self {
            CellStart::Cold => "cold",
            CellStart::Warm => "warm",
            CellStart::ColdAfterWarm => "cold-after-warm",
            CellStart::WarmFromRow => "warm-from-row",
        }
    }
}

/// One cell of the grid.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyCell {
    /// Lower-to-total arm length ratio.
    pub r2: f64,
    /// Offset from T = 2 T_freefall, s.
    pub offset_s: f64,
    /// Swing time T + offset, s.
    pub swing_time_s: f64,
    /// Solver outcome.
    pub status: SolveStatus,
    /// True when the solver converged.
    pub converged: bool,
    /// Energy, paper eq. (18), J; `None` when the solve did not converge.
    pub energy_j: Option<f64>,
    /// Positive work of the actuated joints, J; `None` when the solve did not converge.
    pub positive_work_j: Option<f64>,
    /// Objective (the planner's cost), `None` when the solve did not converge.
    pub objective: Option<f64>,
    /// Solver iterations (all attempts of the cell).
    pub iterations: usize,
    /// Solve wall time (all attempts of the cell), s.
    pub solve_time_s: f64,
    /// How the solve started.
    pub start: CellStart,
    /// Independent open-loop replay of the adopted plan's own torque profile: distance of the end
    /// effector from the bar at T, m (`None` for a cell the planner refused).
    pub replay_ee_error_m: Option<f64>,
    /// When the cell's cold plan failed within the torque limits: the smallest factor on the limits
    /// at which the planner's continuation on them converged (`Some(1.0)`: it planned the cell within
    /// the limits; above 1: the cell likely needs that much more torque). `None` when the continuation
    /// did not run or no widened plan converged (`brachia::planning::strategy::torque_continuation`).
    #[serde(default)]
    pub torque_scale_reached: Option<f64>,
}

/// Per-r2 summary.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StudyRow {
    /// Lower-to-total arm length ratio.
    pub r2: f64,
    /// Link lengths L1..Ln, m.
    pub lengths_m: Vec<f64>,
    /// The row's start pose, rad: the same for every row of an even link count, the row's own for an
    /// odd one (empty when read from a report written before it was recorded).
    #[serde(default)]
    pub start_q: Vec<f64>,
    /// T_freefall, s.
    pub freefall_time_s: f64,
    /// T = 2 T_freefall, s.
    pub swing_time_s: f64,
    /// Energy of the cell at offset 0, J (`None` when it failed or 0 is not an offset).
    pub energy_at_t_j: Option<f64>,
    /// Swing time of the lowest-energy converged cell, s.
    pub argmin_swing_time_s: Option<f64>,
    /// Its offset from T, s.
    pub argmin_offset_s: Option<f64>,
    /// Its energy, J.
    pub min_energy_j: Option<f64>,
    /// True when the minimum is at the first or last offset (the true minimum may lie outside).
    pub argmin_at_edge: Option<bool>,
    /// Cells of this row that did not converge.
    pub failed_cells: usize,
}

/// A swing kept for a stick diagram (Fig. 4b): r2, its robot and its 1 ms trajectory at T.
#[derive(Debug, Clone, PartialEq)]
pub struct StickDiagram {
    /// Lower-to-total arm length ratio.
    pub r2: f64,
    /// The scaled robot.
    pub robot: Robot,
    /// Swing time T = 2 T_freefall, s.
    pub swing_time_s: f64,
    /// Solver outcome.
    pub status: SolveStatus,
    /// Energy, paper eq. (18), J (`None` when it did not converge).
    pub energy_j: Option<f64>,
    /// The 1 ms trajectory (`Plan::trajectory`; the last iterate when it did not converge).
    pub trajectory: Trajectory,
}

/// The outcome of [`run_parameter_study`].
#[derive(Debug, Clone, PartialEq)]
pub struct ParameterStudy {
    /// The settings that ran.
    pub settings: ParameterStudySettings,
    /// The base robot parameters (r2 = 0.5 at 0.71 m arms for Table I).
    pub base: RobotParams,
    /// The start pose of the first row, rad: for an even link count the start pose of every row; an
    /// odd link count's rows each have their own ([`StudyRow::start_q`]).
    pub start_q: Vec<f64>,
    /// One summary per r2, in the order of `settings.r2`.
    pub rows: Vec<StudyRow>,
    /// Every cell, row-major: `cells[i * offsets + j]` is r2 `i`, offset `j`.
    pub cells: Vec<StudyCell>,
    /// The stick-diagram swings, in the order of `settings.stick_r2`.
    pub sticks: Vec<StickDiagram>,
    /// Wall time of the whole study, s.
    pub wall_time_s: f64,
}

impl ParameterStudy {
    /// The cell of r2 index `i` and offset index `j`.
    pub fn cell(&self, i: usize, j: usize) -> &StudyCell {
        &self.cells[i * self.settings.offsets_s.len() + j]
    }

    /// Number of cells that did not converge.
    pub fn failed_cells(&self) -> usize {
        self.cells.iter().filter(|c| !c.converged).count()
    }
}

/// A solved row: its cells in offset order and, when wanted, the stick diagram of its centre cell.
type RowResult = (Vec<StudyCell>, Option<StickDiagram>);

/// One r2 row before solving.
struct RowSetup {
    r2: f64,
    robot: Robot,
    /// The row's task: its start pose, the target bar.
    task: SwingTask,
    freefall: f64,
    t_nominal: f64,
}

/// The task of the study: start pose, target bar, no obstacles.
fn task(start_q: &[f64], target: [f64; 2]) -> SwingTask {
    SwingTask {
        q0: start_q.to_vec(),
        qd0: vec![],
        target,
        obstacles: vec![],
    }
}

/// Plan one swing of `swing_time_s`, warm-started from `guess` when given (cold again if that fails).
fn solve_cell(
    setup: &RowSetup,
    settings: &ParameterStudySettings,
    swing_time_s: f64,
    guess: Option<&Trajectory>,
) -> Result<(brachia::planning::Plan, CellStart, usize, f64), Error> {
    let planner = PlannerSettings {
        swing_time: SwingTime::Seconds(swing_time_s),
        // the study continues its own rows in T (warm from the neighbouring cell): a cell is
        // planned at its swing time only, without the planner's search in T
        swing_time_search: false,
        ..settings.planner.clone()
    };
    let first = plan_with_guess(&setup.robot, &setup.task, &planner, &settings.solver, guess)?;
    if guess.is_none() || first.converged() {
        let start = if guess.is_some() {
            CellStart::Warm
        } else {
            CellStart::Cold
        };
        let (it, t) = (first.iterations, first.solve_time_s);
        return Ok((first, start, it, t));
    }
    let cold = plan_with_guess(&setup.robot, &setup.task, &planner, &settings.solver, None)?;
    let (it, t) = (
        first.iterations + cold.iterations,
        first.solve_time_s + cold.solve_time_s,
    );
    Ok((cold, CellStart::ColdAfterWarm, it, t))
}

fn make_cell(
    r2: f64,
    offset_s: f64,
    p: &brachia::planning::Plan,
    start: CellStart,
    iterations: usize,
    solve_time_s: f64,
) -> StudyCell {
    let ok = p.converged();
    StudyCell {
        r2,
        offset_s,
        swing_time_s: p.swing_time_s,
        status: p.status.clone(),
        converged: ok,
        energy_j: ok.then_some(p.energy_j),
        positive_work_j: ok.then_some(p.positive_work_j),
        objective: ok.then_some(p.objective),
        iterations,
        solve_time_s,
        start,
        replay_ee_error_m: Some(p.replay_ee_error_m),
        torque_scale_reached: p.torque_continuation.as_ref().and_then(|t| t.reached_scale),
    }
}

/// A cell the planner refused before solving (an impossible task at that swing time): failed, with the
/// planner's message as its status.
fn refused_cell(setup: &RowSetup, offset_s: f64, e: &Error) -> StudyCell {
    StudyCell {
        r2: setup.r2,
        offset_s,
        swing_time_s: setup.t_nominal + offset_s,
        status: SolveStatus::Other(format!("planner refused the cell: {e}")),
        converged: false,
        energy_j: None,
        positive_work_j: None,
        objective: None,
        iterations: 0,
        solve_time_s: 0.0,
        start: CellStart::Cold,
        replay_ee_error_m: None,
        torque_scale_reached: None,
    }
}

/// Index of the offset closest to 0 (the row's first, cold-started cell).
fn centre_index(offsets: &[f64]) -> usize {
    let mut best = 0;
    for (j, o) in offsets.iter().enumerate() {
        if o.abs() < offsets[best].abs() {
            best = j;
        }
    }
    best
}

/// A row's centre cell (the offset closest to 0) once solved: the cell, the plan's knots when it
/// converged (the seed of the row's walk and of the neighbouring rows' continuation) and, when a stick
/// diagram wants it, the centre's swing.
struct Centre {
    cell: StudyCell,
    seed: Option<Trajectory>,
    stick: Option<StickDiagram>,
    /// The planner refused the cell before solving (nothing to continue from or into).
    refused: bool,
}

/// The [`Centre`] of a row from a solve of its centre cell.
fn centre_of(
    setup: &RowSetup,
    settings: &ParameterStudySettings,
    keep_stick: bool,
    solved: Result<(brachia::planning::Plan, CellStart, usize, f64), Error>,
) -> Centre {
    let off = settings.offsets_s[centre_index(&settings.offsets_s)];
    match solved {
        Ok((p, start, it, t)) => Centre {
            cell: make_cell(setup.r2, off, &p, start, it, t),
            seed: p.converged().then(|| p.points.clone()),
            stick: (keep_stick && off.abs() < SAME).then(|| StickDiagram {
                r2: setup.r2,
                robot: setup.robot.clone(),
                swing_time_s: p.swing_time_s,
                status: p.status.clone(),
                energy_j: p.converged().then_some(p.energy_j),
                trajectory: p.trajectory.clone(),
            }),
            refused: false,
        },
        Err(e) => Centre {
            cell: refused_cell(setup, off, &e),
            seed: None,
            stick: None,
            refused: true,
        },
    }
}

/// Phase 1 of the study: a row's centre cell, cold (the planner's own guess). A planner error of the
/// cell (e.g. no joint configuration reaches the target) is a failed cell, not an error of the study.
fn solve_centre(
    setup: &RowSetup,
    settings: &ParameterStudySettings,
    keep_stick: bool,
    tick: &(dyn Fn() + Sync),
    stop: &(dyn Fn() -> bool + Sync),
) -> Centre {
    let off = settings.offsets_s[centre_index(&settings.offsets_s)];
    let solved = if stop() {
        Err(Error::InfeasibleTask("cancelled".into()))
    } else {
        let r = solve_cell(setup, settings, setup.t_nominal + off, None);
        tick();
        r
    };
    centre_of(setup, settings, keep_stick, solved)
}

/// Phase 2 of the study, continuation in r2: a row whose centre did not converge from the planner's own
/// guess is solved again, warm-started ([`plan_with_guess`], the guess's time axis rescaled to this
/// row's swing time) from the converged centre of its neighbour in `settings.r2`: first sweeping up
/// (from the row below), then down (from the row above), so that a centre converged this way seeds
/// the next row in the sweep. The cell then counts the iterations and time of every attempt and has
/// `start = warm-from-row`. Rows run one after another here (only rows whose centre failed solve).
fn continue_centres(
    setups: &[RowSetup],
    settings: &ParameterStudySettings,
    centres: &mut [Centre],
    wants_stick: &dyn Fn(f64) -> bool,
    stop: &(dyn Fn() -> bool + Sync),
) {
    let n = centres.len();
    let up = (1..n).map(|i| (i, i - 1));
    let down = (0..n.saturating_sub(1)).rev().map(|i| (i, i + 1));
    for (i, from) in up.chain(down) {
        if stop() {
            return;
        }
        if centres[i].seed.is_some() || centres[i].refused {
            continue;
        }
        let Some(seed) = centres[from].seed.clone() else {
            continue;
        };
        let s = &setups[i];
        let off = settings.offsets_s[centre_index(&settings.offsets_s)];
        let (it0, t0) = (centres[i].cell.iterations, centres[i].cell.solve_time_s);
        let planner = PlannerSettings {
            swing_time: SwingTime::Seconds(s.t_nominal + off),
            ..settings.planner.clone()
        };
        let solved = plan_with_guess(&s.robot, &s.task, &planner, &settings.solver, Some(&seed))
            .map(|p| {
                let (it, t) = (it0 + p.iterations, t0 + p.solve_time_s);
                (p, CellStart::WarmFromRow, it, t)
            });
        // a planner error here (it accepted the cell cold) keeps the cold attempt's result
        if solved.is_ok() {
            // a warm attempt that fails too keeps the cold attempt's torque diagnosis
            let scale = centres[i].cell.torque_scale_reached;
            centres[i] = centre_of(s, settings, wants_stick(s.r2), solved);
            if !centres[i].cell.converged && centres[i].cell.torque_scale_reached.is_none() {
                centres[i].cell.torque_scale_reached = scale;
            }
        }
    }
}

/// Phase 3 of the study: one r2 row walks outwards from its centre in both directions, every cell
/// warm-started from the last converged cell on its side (cold when there is none, or again cold when
/// the warm start does not converge). Returns the cells in offset order.
fn walk_row(
    setup: &RowSetup,
    settings: &ParameterStudySettings,
    centre: &Centre,
    tick: &(dyn Fn() + Sync),
    stop: &(dyn Fn() -> bool + Sync),
) -> Vec<StudyCell> {
    let offs = &settings.offsets_s;
    let c = centre_index(offs);
    let mut cells: Vec<Option<StudyCell>> = vec![None; offs.len()];
    cells[c] = Some(centre.cell.clone());
    let solve = |j: usize, guess: Option<&Trajectory>| {
        // once cancelled, the remaining cells are skipped (the whole study is then discarded)
        if stop() {
            return Err(Error::InfeasibleTask("cancelled".into()));
        }
        let r = solve_cell(setup, settings, setup.t_nominal + offs[j], guess);
        tick();
        r
    };
    let up: Vec<usize> = (c + 1..offs.len()).collect();
    let down: Vec<usize> = (0..c).rev().collect();
    for side in [up, down] {
        let mut guess = centre.seed.clone();
        for j in side {
            let g = if settings.warm_start {
                guess.as_ref()
            } else {
                None
            };
            // a planner error of one cell is a failed cell of the study
            cells[j] = Some(match solve(j, g) {
                Ok((p, start, it, t)) => {
                    if p.converged() {
                        guess = Some(p.points.clone());
                    }
                    make_cell(setup.r2, offs[j], &p, start, it, t)
                }
                Err(e) => refused_cell(setup, offs[j], &e),
            });
        }
    }
    cells.into_iter().flatten().collect()
}

/// Summary of one row from its cells.
fn summarise(setup: &RowSetup, cells: &[StudyCell]) -> StudyRow {
    let best = cells
        .iter()
        .enumerate()
        .filter_map(|(j, c)| c.energy_j.map(|e| (j, e)))
        .min_by(|a, b| a.1.total_cmp(&b.1));
    StudyRow {
        r2: setup.r2,
        lengths_m: setup.robot.lengths().to_vec(),
        start_q: setup.task.q0.clone(),
        freefall_time_s: setup.freefall,
        swing_time_s: setup.t_nominal,
        energy_at_t_j: cells
            .iter()
            .find(|c| c.offset_s.abs() < SAME)
            .and_then(|c| c.energy_j),
        argmin_swing_time_s: best.map(|(j, _)| cells[j].swing_time_s),
        argmin_offset_s: best.map(|(j, _)| cells[j].offset_s),
        min_energy_j: best.map(|(_, e)| e),
        argmin_at_edge: best.map(|(j, _)| j == 0 || j + 1 == cells.len()),
        failed_cells: cells.iter().filter(|c| !c.converged).count(),
    }
}

/// Scaled robot, start pose, T_freefall and T for one r2. `shared_q` is the start pose every row of
/// an even link count shares (only the arm lengths, the same for every r2, decide it); an odd link
/// count's pose depends on r2 (the middle link's length) and is found for each row. `field` names
/// the r2 value in errors.
fn row_setup(
    base: &RobotParams,
    r2: f64,
    settings: &ParameterStudySettings,
    shared_q: Option<&[f64]>,
    src: &str,
    field: &str,
) -> Result<RowSetup, Error> {
    let p = scaled_params(base, r2, settings.arm_length_m)?;
    let robot = Robot::from_params(p, &format!("r2 = {r2}"))?;
    let q0 = match shared_q {
        Some(q) => q.to_vec(),
        None => start_pose(&robot, settings.start).map_err(|e| {
            let (what, value) = if robot.n() % 2 == 0 {
                ("start".to_string(), format!("{:?}", settings.start))
            } else {
                (field.to_string(), r2.to_string())
            };
            Error::invalid(
                src,
                what,
                value,
                format!(
                    "the {}-link study robot of r2 = {r2} has no start pose: {e}",
                    robot.n()
                ),
            )
        })?,
    };
    let freefall = freefall_time(&robot, &q0, 0.5 * (settings.start[0] + settings.target[0]))?;
    Ok(RowSetup {
        r2,
        robot,
        task: task(&q0, settings.target),
        freefall,
        t_nominal: 2.0 * freefall,
    })
}

/// Everything a study solves, built before any solving.
struct Prepared {
    base: RobotParams,
    /// One per `settings.r2`.
    setups: Vec<RowSetup>,
    /// The stick diagrams the grid does not provide.
    extra: Vec<RowSetup>,
}

/// Every row's robot, start pose and swing time, the stick diagrams' too; refuses an offset that
/// gives a swing time <= 0.
fn prepare_rows(
    base: RobotParams,
    settings: &ParameterStudySettings,
    src: &str,
) -> Result<Prepared, Error> {
    let even = base.links.len().is_multiple_of(2);
    let mut shared: Option<Vec<f64>> = None;
    let mut setups = Vec::with_capacity(settings.r2.len());
    for (i, &r2) in settings.r2.iter().enumerate() {
        let s = row_setup(
            &base,
            r2,
            settings,
            shared.as_deref(),
            src,
            &format!("r2[{i}]"),
        )?;
        if even {
            shared.get_or_insert_with(|| s.task.q0.clone());
        }
        setups.push(s);
    }
    let first_off = settings.offsets_s[0];
    for s in &setups {
        if s.t_nominal + first_off <= 0.0 {
            return Err(Error::invalid(
                src,
                "offsets_s[0]",
                first_off,
                format!(
                    "gives a swing time <= 0 for r2 = {} (T = {:.3} s)",
                    s.r2, s.t_nominal
                ),
            ));
        }
    }
    let centre_is_zero = settings.offsets_s[centre_index(&settings.offsets_s)].abs() < SAME;
    // stick diagrams that the grid does not provide are solved separately
    let mut extra: Vec<RowSetup> = Vec::new();
    for (i, &s) in settings.stick_r2.iter().enumerate() {
        let in_grid = centre_is_zero && settings.r2.iter().any(|r| (r - s).abs() < SAME);
        let dup = extra.iter().any(|e| (e.r2 - s).abs() < SAME);
        if !in_grid && !dup {
            let field = format!("stick_r2[{i}]");
            extra.push(row_setup(
                &base,
                s,
                settings,
                shared.as_deref(),
                src,
                &field,
            )?);
        }
    }
    Ok(Prepared {
        base,
        setups,
        extra,
    })
}

/// Run the study: every cell of `settings.r2 x settings.offsets_s` in parallel rows (rayon's global
/// pool: all cores, or `RAYON_NUM_THREADS`), plus the stick-diagram swings of `settings.stick_r2`.
/// `progress` is called once per finished solve (from the worker threads) with the count so far and
/// the total; pass [`crate::no_progress`] to ignore it. Errors on bad settings or base parameters and on a swing time `T + offset <= 0`, before
/// anything is solved; cells that do not converge are results, not errors.
pub fn run_parameter_study(
    settings: &ParameterStudySettings,
    progress: ProgressFn<'_>,
) -> Result<ParameterStudy, Error> {
    let never = || false;
    // `never` is never set, so the study always finishes
    study(settings, progress, &never)?
        .ok_or_else(|| Error::InfeasibleTask("the parameter study was cancelled".into()))
}

/// [`run_parameter_study`] that can be cancelled: `cancel` is checked before every solve and by the
/// solves themselves at every iteration; once it is set the remaining cells are skipped and the study
/// ends with [`ExpError::Cancelled`] (nothing of it is returned).
pub fn run_parameter_study_cancellable(
    settings: &ParameterStudySettings,
    progress: ProgressFn<'_>,
    cancel: &CancelToken,
) -> Result<ParameterStudy, ExpError> {
    let mut settings = settings.clone();
    settings.solver.cancel = Some(cancel.clone());
    let stop = || cancel.is_cancelled();
    let done = study(&settings, progress, &stop);
    cancel.check()?;
    done?.ok_or(ExpError::Cancelled)
}

/// The study; `None` when `stop` said so before it finished.
fn study(
    settings: &ParameterStudySettings,
    progress: ProgressFn<'_>,
    stop: &(dyn Fn() -> bool + Sync),
) -> Result<Option<ParameterStudy>, Error> {
    let wall = Instant::now();
    let Prepared {
        base,
        setups,
        extra,
    } = settings.prepare(SRC)?;
    let start_q = setups
        .first()
        .map(|s| s.task.q0.clone())
        .unwrap_or_default();
    let wants_stick = |r2: f64| settings.stick_r2.iter().any(|s| (s - r2).abs() < SAME);
    let total = (setups.len() * settings.offsets_s.len() + extra.len()) as u64;
    let done = AtomicU64::new(0);
    let tick = || {
        progress(Progress {
            done: done.fetch_add(1, Ordering::Relaxed) + 1,
            total,
            what: "parameter-study solves",
        })
    };
    // Longest swings first: they have the most knots and iterations, and a long row started last
    // would leave the other cores idle at the end.
    let mut order: Vec<usize> = (0..setups.len()).collect();
    order.sort_by(|&a, &b| setups[b].t_nominal.total_cmp(&setups[a].t_nominal));
    // phase 1: every row's centre cold, in parallel
    let mut centres: Vec<Centre> = {
        let mut solved: Vec<(usize, Centre)> = order
            .par_iter()
            .with_max_len(1)
            .map(|&i| {
                let s = &setups[i];
                (i, solve_centre(s, settings, wants_stick(s.r2), &tick, stop))
            })
            .collect();
        solved.sort_by_key(|(i, _)| *i);
        solved.into_iter().map(|(_, c)| c).collect()
    };
    // phase 2: continuation in r2 for the centres that failed (warm starts only)
    if settings.warm_start {
        continue_centres(&setups, settings, &mut centres, &wants_stick, stop);
    }
    // phase 3: every row walks outwards from its centre, in parallel
    let walked: Vec<(usize, Vec<StudyCell>)> = order
        .par_iter()
        .with_max_len(1)
        .map(|&i| (i, walk_row(&setups[i], settings, &centres[i], &tick, stop)))
        .collect();
    if stop() {
        return Ok(None);
    }
    let mut rows: Vec<Option<RowResult>> = (0..setups.len()).map(|_| None).collect();
    for (i, cells) in walked {
        rows[i] = Some((cells, centres[i].stick.take()));
    }
    // a stick swing the planner refuses (no pose reaches the target) has nothing to draw: it is left out
    let extra_sticks: Vec<StickDiagram> = extra
        .par_iter()
        .filter_map(|s| {
            if stop() {
                return None;
            }
            let solved = solve_cell(s, settings, s.t_nominal, None);
            tick();
            let (p, _, _, _) = solved.ok()?;
            Some(StickDiagram {
                r2: s.r2,
                robot: s.robot.clone(),
                swing_time_s: p.swing_time_s,
                status: p.status.clone(),
                energy_j: p.converged().then_some(p.energy_j),
                trajectory: p.trajectory,
            })
        })
        .collect();
    let mut summaries = Vec::with_capacity(rows.len());
    let mut cells = Vec::with_capacity(total as usize);
    let mut grid_sticks = Vec::new();
    for (s, (row_cells, stick)) in setups.iter().zip(rows.into_iter().flatten()) {
        summaries.push(summarise(s, &row_cells));
        cells.extend(row_cells);
        grid_sticks.extend(stick);
    }
    let mut sticks = Vec::new();
    for &s in &settings.stick_r2 {
        let found = grid_sticks
            .iter()
            .chain(&extra_sticks)
            .find(|d| (d.r2 - s).abs() < SAME);
        if let Some(d) = found {
            if !sticks
                .iter()
                .any(|e: &StickDiagram| (e.r2 - s).abs() < SAME)
            {
                sticks.push(d.clone());
            }
        }
    }
    if stop() {
        return Ok(None);
    }
    Ok(Some(ParameterStudy {
        settings: settings.clone(),
        base,
        start_q,
        rows: summaries,
        cells,
        sticks,
        wall_time_s: wall.elapsed().as_secs_f64(),
    }))
}

/// The snake_case name of a status (`solved`, `max_iterations`, `evaluation_error`, ...).
pub fn status_name(s: &SolveStatus) -> String {
    match serde_json::to_value(s) {
        Ok(serde_json::Value::String(name)) => name,
        Ok(serde_json::Value::Object(m)) => m.keys().next().cloned().unwrap_or_default(),
        _ => format!("{s:?}"),
    }
}

fn opt(v: Option<f64>) -> String {
    v.map(|x| format!("{x:.9}")).unwrap_or_default()
}

/// File-name tag of an r2 value: `0.20`.
pub(crate) fn r2_tag(r2: f64) -> String {
    format!("{r2:.2}")
}

/// The run folder of a study:
/// - `cells.csv`: one row per cell, header
///   `r2,offset_s,swing_time_s,status,converged,energy_j,positive_work_j,objective,iterations,solve_time_s,start,replay_ee_error_m,torque_scale_reached`
///   (energy, work and objective empty for a cell that did not converge, the replay miss for a cell
///   the planner refused, the torque scale where the continuation on the limits did not run or
///   reached nothing);
/// - `freefall.csv`: per r2, `r2,l1_m,..,ln_m,freefall_time_s,swing_time_s,energy_at_t_j,
///   argmin_swing_time_s,argmin_offset_s,min_energy_j,failed_cells`;
/// - `report.json`: the settings (with the base parameters resolved), the start pose, the per-r2
///   summaries, the count of failed cells, the wall time;
/// - `stick_r2_<r2>.csv` (the 1 ms trajectory, `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y`) and
///   `stick_r2_<r2>_params.toml` (the scaled robot) for every stick diagram.
pub fn parameter_study_folder(study: &ParameterStudy) -> RunFolder {
    let mut folder = RunFolder::default();
    let mut csv = String::from(
        "r2,offset_s,swing_time_s,status,converged,energy_j,positive_work_j,objective,iterations,solve_time_s,start,replay_ee_error_m,torque_scale_reached\n",
    );
    for c in &study.cells {
        let _ = writeln!(
            csv,
            "{},{},{:.6},{},{},{},{},{},{},{:.4},{},{},{}",
            c.r2,
            c.offset_s,
            c.swing_time_s,
            status_name(&c.status),
            c.converged,
            opt(c.energy_j),
            opt(c.positive_work_j),
            opt(c.objective),
            c.iterations,
            c.solve_time_s,
            c.start.name(),
            c.replay_ee_error_m
                .map(|v| format!("{v:e}"))
                .unwrap_or_default(),
            opt(c.torque_scale_reached)
        );
    }
    folder.add("cells.csv", csv);
    let n = study.base.links.len();
    let mut ff = String::from("r2");
    for i in 1..=n {
        let _ = write!(ff, ",l{i}_m");
    }
    ff.push_str(
        ",freefall_time_s,swing_time_s,energy_at_t_j,argmin_swing_time_s,argmin_offset_s,min_energy_j,failed_cells\n",
    );
    for r in &study.rows {
        let _ = write!(ff, "{}", r.r2);
        for l in &r.lengths_m {
            let _ = write!(ff, ",{l:.6}");
        }
        let _ = writeln!(
            ff,
            ",{:.6},{:.6},{},{},{},{},{}",
            r.freefall_time_s,
            r.swing_time_s,
            opt(r.energy_at_t_j),
            r.argmin_swing_time_s
                .map(|v| format!("{v:.6}"))
                .unwrap_or_default(),
            r.argmin_offset_s.map(|v| v.to_string()).unwrap_or_default(),
            opt(r.min_energy_j),
            r.failed_cells
        );
    }
    folder.add("freefall.csv", ff);
    for s in &study.sticks {
        let tag = r2_tag(s.r2);
        folder.add(
            &format!("stick_r2_{tag}.csv"),
            s.trajectory.to_csv(&s.robot, &[]),
        );
        let head = format!(
            "# Robot of the parameter study at r2 = {} (arm length {} m), scaled from `{}`: mass and centre of\n\
             # mass with the link length, inertia with its cube. Swing time T = {:.6} s. Units: m, kg, kg m^2, N m.\n",
            s.r2, study.settings.arm_length_m, study.base.name, s.swing_time_s
        );
        folder.add(
            &format!("stick_r2_{tag}_params.toml"),
            head + &toml::to_string(s.robot.params()).unwrap_or_default(),
        );
    }
    let mut resolved = study.settings.clone();
    resolved.base_params = BaseParams::Inline(study.base.clone());
    resolved.planner.q1_diag = resolved.planner.q1(n);
    resolved.planner.r1_diag = resolved.planner.r1(n);
    let report = json!({
        "settings": resolved,
        "base_params_source": study.settings.base_params,
        "start_q": study.start_q,
        "rows": study.rows,
        "cells": study.cells.len(),
        "failed_cells": study.failed_cells(),
        "stick_r2": study.sticks.iter().map(|s| json!({
            "r2": s.r2,
            "swing_time_s": s.swing_time_s,
            "status": s.status,
            "energy_j": s.energy_j,
        })).collect::<Vec<_>>(),
        "wall_time_s": study.wall_time_s,
    });
    folder.add_json("report.json", &report);
    folder
}
