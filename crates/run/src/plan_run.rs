//! A planning run: solve the scenario's swing and fill the run folder
//! (`knots.csv`, `trajectory.csv`, `scenario.toml` with the resolved inputs, `params.toml` with the
//! robot it names, `report.json` = [`PlanReport`]).

use crate::run_folder::RunFolder;
use crate::scenario::LoadedScenario;
use brachia::planning::profile::Clamped;
use brachia::planning::{
    plan, Backend, Blockage, CallbackTimings, ClearanceViolation, GuessReport, Plan, SolveAttempt,
    SolveRole, SolveStatus, SwingTime, TimeSplit, TorqueContinuation, Transcription, Violations,
};
use serde::{Deserialize, Serialize};
use serde_json::{json, Value};
use std::fmt::Write as _;

/// The robot parameters file of a plan's run folder (the resolved `scenario.toml` names it).
pub const PARAMS_FILE: &str = "params.toml";

/// The outcome of [`run_plan`].
#[derive(Debug, Clone)]
pub struct PlanRun {
    /// The plan (converged or not).
    pub plan: Plan,
    /// Its report (the run folder's `report.json`).
    pub report: PlanReport,
    /// The run folder's files.
    pub folder: RunFolder,
}

/// The solver's work on a plan in one line: every attempt, what its solve was for (unless the task
/// itself, e.g. `torque limits x2.000`), its barrier strategy, outcome and passes, then the totals
/// and the time split, e.g. `attempt 1 (monotone, restoration_failed):
/// pounce 10 it 0.52 s; attempt 2 (adopted, adaptive, solved): pounce 143 it 5.61 s | 153
/// iterations in 6.13 s: callbacks 4.20 s, linear algebra 1.51 s, line search and rest 0.42 s`.
pub fn solver_work_text(p: &Plan) -> String {
    work_text(&p.solves, p.iterations, p.solve_time_s, &p.time_split)
}

fn work_text(solves: &[SolveAttempt], iterations: usize, time_s: f64, t: &TimeSplit) -> String {
    let snake = |v: &Value| match v {
        Value::String(s) => s.clone(),
        Value::Object(m) => m.keys().next().cloned().unwrap_or_default(),
        other => other.to_string(),
    };
    let mut s = String::new();
    for (k, a) in solves.iter().enumerate() {
        let _ = write!(
            s,
            "{}attempt {} ({}{}{}, {}):",
            if k > 0 { "; " } else { "" },
            k + 1,
            if a.adopted { "adopted, " } else { "" },
            match (a.within, a.role) {
                (None, SolveRole::Task) => String::new(),
                (None, role) => format!("{role}, "),
                (Some(within), role) => format!("{within}, {role}, "),
            },
            snake(&json!(a.mu_strategy)),
            snake(&json!(a.status))
        );
        for (j, ps) in a.passes.iter().enumerate() {
            let _ = write!(
                s,
                "{} {} {} it {:.2} s{}",
                if j > 0 { " +" } else { "" },
                ps.what,
                ps.iterations,
                ps.time_s,
                if a.passes.len() > 1 && ps.returned {
                    " (returned)"
                } else {
                    ""
                }
            );
        }
    }
    let _ = write!(
        s,
        " | {} iterations in {:.2} s: callbacks {:.2} s, linear algebra {:.2} s, line search and rest {:.2} s",
        iterations, time_s, t.callbacks_s, t.linear_algebra_s, t.line_search_and_other_s
    );
    s
}

/// Largest open-loop replay error (EE distance to the bar, m) of a plan that can be trusted: a larger
/// one means the discrete problem does not describe the swing. `brachia plan` exits 1 for such a plan
/// (its report is still written) and `brachia track --plan` refuses its folder.
pub const REPLAY_TRUST_M: f64 = 0.05;

/// Whether an open-loop replay error (m) is small enough to trust the plan ([`REPLAY_TRUST_M`]; a NaN
/// is not).
pub fn replay_trusted(replay_ee_error_m: f64) -> bool {
    replay_ee_error_m.is_finite() && replay_ee_error_m <= REPLAY_TRUST_M
}

/// The plan's machine-readable report: the `report.json` of `brachia plan` (and the `plan` entry of a
/// track run's report). Units: s, m, rad, N m, J. `iterations` and `solve_time_s` are totals over every
/// solver attempt and every pass of the backend inside it (adopted or not); `solves` lists them,
/// `time_split_s` splits the time (see `brachia::planning::TimeSplit`). Written with its keys sorted;
/// read back by [`crate::read::PlanFolder::read`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlanReport {
    /// The scenario's name.
    pub scenario: String,
    /// The solver's outcome (of the adopted attempt).
    pub status: SolveStatus,
    /// True when the status counts as converged.
    pub converged: bool,
    /// The backend's name (`pounce`, `ripopt`, `ocp`).
    pub solver: String,
    /// Solver iterations over every attempt and pass.
    pub iterations: usize,
    /// Solver calls.
    pub attempts: usize,
    /// Backend passes over every attempt.
    pub passes: usize,
    /// Solve wall time over every attempt, s.
    pub solve_time_s: f64,
    /// Where that time went, s.
    pub time_split_s: TimeSplit,
    /// Every solver call, adopted or not.
    pub solves: Vec<SolveAttempt>,
    /// Wall time per kind of NLP callback, s.
    pub callback_time_s: CallbackTimings,
    /// The planner's cost at the plan.
    pub objective: f64,
    /// Energy of the plan, paper eq. (18), J.
    pub energy_j: f64,
    /// Positive work of the actuated joints, J.
    pub positive_work_j: f64,
    /// The largest of `violations`.
    pub max_violation: f64,
    /// Largest violation per kind of constraint.
    pub violations: Violations,
    /// EE position at the end of the plan, m.
    pub ee_final: [f64; 2],
    /// Its distance to the target bar, m.
    pub ee_final_error_m: f64,
    /// Swing time T, s.
    pub swing_time_s: f64,
    /// T_freefall when the swing time was `auto`, s.
    pub freefall_time_s: Option<f64>,
    /// Knots of the grid (`intervals + 1`).
    pub knots: usize,
    /// Intervals N of the grid.
    pub intervals: usize,
    /// Collocation points (knots and, for Hermite-Simpson, midpoints).
    pub collocation_points: usize,
    /// Knot spacing, s.
    pub knot_dt_s: f64,
    /// The transcription.
    pub transcription: Transcription,
    /// The NLP backend as the scenario chose it.
    pub backend: Backend,
    /// EE distance to the bar at T of the open-loop replay of the plan's torques, m.
    pub replay_ee_error_m: f64,
    /// The torque profile that replay used (the transcription's).
    pub replay_torque_profile: Transcription,
    /// Last time of the 1 ms trajectory, s.
    pub trajectory_end_s: Option<f64>,
    /// How far resampling clamped the 1 ms trajectory into the bounds.
    pub trajectory_clamped: Clamped,
    /// Smallest link-to-obstacle clearance of the 1 ms plan, m (`None` without obstacles).
    pub min_obstacle_clearance_m: Option<f64>,
    /// The closest approach of the resampled trajectory that breaks the required clearance (the
    /// obstacle or link pair, the time, the shortfall); such a plan is not converged, whatever its
    /// `status` (`brachia::planning::ClearanceViolation`).
    #[serde(default)]
    pub clearance_violation: Option<ClearanceViolation>,
    /// When the plan failed on a task with obstacles: which obstacle blocks which link, and every
    /// obstacle's closest approach to every link with its time (`brachia::planning::Blockage`).
    #[serde(default)]
    pub blockage: Option<Blockage>,
    /// When the plan failed on a task with obstacles: the obstacle and the link it blocks, the
    /// verdict, and how much more torque (`torque_probe`) or swing time (`swing_time_probe`) the best
    /// detour found would need (`brachia::planning::Diagnosis`).
    #[serde(default)]
    pub diagnosis: Option<brachia::planning::Diagnosis>,
    /// When the cold plan failed within the torque limits: the continuation on the limits, how far it
    /// got and the peak torques there (`brachia::planning::TorqueContinuation`).
    #[serde(default)]
    pub torque_continuation: Option<TorqueContinuation>,
    /// When the task's swing time did not plan (or `"auto"` had no free-fall time): every swing time
    /// the search in T planned at, and the one it planned at or the nearest that plan
    /// (`brachia::planning::SwingTimeSearch`).
    #[serde(default)]
    pub swing_time_search: Option<brachia::planning::SwingTimeSearch>,
    /// On a task with obstacles planned without a guess: which strategies ran (smooth step, detour
    /// and C-space seeds, radius continuation), what each found, and whether `max_wall_time_s` ended
    /// them (`out_of_time`) (`brachia::planning::GuessReport`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub guess: Option<GuessReport>,
}

impl PlanReport {
    /// The report of plan `p` of scenario `ls`.
    pub fn new(ls: &LoadedScenario, p: &Plan) -> Self {
        let t = ls.scenario.task.target;
        let v = &p.violations;
        let max_violation = v
            .dynamics
            .max(v.ee_position)
            .max(v.ee_velocity)
            .max(v.clearance)
            .max(v.bounds);
        PlanReport {
            scenario: ls.scenario.name.clone(),
            status: p.status.clone(),
            converged: p.converged(),
            solver: p.backend.name().to_string(),
            iterations: p.iterations,
            attempts: p.attempts,
            passes: p.solves.iter().map(|a| a.passes.len()).sum::<usize>(),
            solve_time_s: p.solve_time_s,
            time_split_s: p.time_split,
            solves: p.solves.clone(),
            callback_time_s: p.callback_timings,
            objective: p.objective,
            energy_j: p.energy_j,
            positive_work_j: p.positive_work_j,
            max_violation,
            violations: *v,
            ee_final: p.ee_final,
            ee_final_error_m: (p.ee_final[0] - t[0]).hypot(p.ee_final[1] - t[1]),
            swing_time_s: p.swing_time_s,
            freefall_time_s: p.freefall_time_s,
            knots: p.layout.intervals + 1,
            intervals: p.layout.intervals,
            collocation_points: p.layout.points,
            knot_dt_s: p.layout.h,
            transcription: ls.scenario.planner.transcription,
            backend: ls.scenario.solver.backend,
            replay_ee_error_m: p.replay_ee_error_m,
            replay_torque_profile: ls.scenario.planner.transcription,
            trajectory_end_s: p.trajectory.t.last().copied(),
            trajectory_clamped: p.resample_clamped,
            min_obstacle_clearance_m: p.min_obstacle_clearance_m,
            clearance_violation: p.clearance_violation,
            blockage: p.blockage.clone(),
            diagnosis: p.diagnosis.clone(),
            torque_continuation: p.torque_continuation.clone(),
            swing_time_search: p.swing_time_search.clone(),
            guess: p.guess.clone(),
        }
    }

    /// The solver's work in one line, as [`solver_work_text`] gives it for the plan.
    pub fn solver_work_text(&self) -> String {
        work_text(
            &self.solves,
            self.iterations,
            self.solve_time_s,
            &self.time_split_s,
        )
    }

    /// The report as JSON (keys sorted, as `report.json` holds it).
    pub fn to_json(&self) -> Value {
        serde_json::to_value(self).unwrap_or(Value::Null)
    }
}

/// The plan's machine-readable report as JSON (the `report.json` of `brachia plan`); see [`PlanReport`].
pub fn plan_report(ls: &LoadedScenario, p: &Plan) -> Value {
    PlanReport::new(ls, p).to_json()
}

/// An infeasible task found while planning, as a refusal naming the scenario file and the field at
/// fault: the target (no pose within the bounds reaches it) or an `"auto"` swing time (the locked
/// chain never falls to the midpoint).
pub fn name_infeasible(e: brachia::Error, ls: &LoadedScenario) -> brachia::Error {
    match e {
        brachia::Error::InfeasibleTask(m) => {
            let src = ls.path.display().to_string();
            let t = ls.scenario.task.target;
            if m.contains("locked joints") {
                brachia::Error::invalid(src, "planner.swing_time", "\"auto\"", m)
            } else {
                brachia::Error::invalid(src, "task.target", format!("[{}, {}]", t[0], t[1]), m)
            }
        }
        other => other,
    }
}

/// Plan the scenario and prepare its run folder. Errors only on bad input; a solve that does not
/// converge still gives a [`PlanRun`] (check `plan.converged()`).
pub fn run_plan(ls: &LoadedScenario) -> Result<PlanRun, brachia::Error> {
    let sc = &ls.scenario;
    let p =
        plan(&ls.robot, &sc.task, &sc.planner, &sc.solver).map_err(|e| name_infeasible(e, ls))?;
    let mut folder = RunFolder::default();
    let midpoint: Vec<f64> = (0..p.points.len())
        .map(|k| {
            if sc.planner.transcription == brachia::planning::Transcription::HermiteSimpson {
                (k % 2) as f64
            } else {
                0.0
            }
        })
        .collect();
    folder.add(
        "knots.csv",
        p.points.to_csv(&ls.robot, &[("is_midpoint", &midpoint)]),
    );
    folder.add("trajectory.csv", p.trajectory.to_csv(&ls.robot, &[]));
    // resolved inputs
    // the robot's parameters beside the resolved scenario, so the folder reads back anywhere
    let mut resolved = sc.clone();
    resolved.params = PARAMS_FILE.into();
    // a URDF robot is written as its equivalent parameters file
    resolved.urdf = None;
    folder.add(
        PARAMS_FILE,
        format!(
            "# Robot parameters of this run (from {}). Units: m, kg, kg m^2, N m.\n{}",
            sc.params.display(),
            toml::to_string(ls.robot.params()).unwrap_or_default()
        ),
    );
    // "auto" resolved to seconds; with a free swing time the resolved input is where the search
    // started (the plan's T is its result, in the header and the report)
    resolved.planner.swing_time = SwingTime::Seconds(match sc.planner.free_swing_time {
        None => p.swing_time_s,
        Some(_) => sc.planner.start_swing_time(match sc.planner.swing_time {
            SwingTime::Seconds(t) => t,
            SwingTime::Auto(_) => 2.0 * p.freefall_time_s.unwrap_or(0.5 * p.swing_time_s),
        }),
    });
    resolved.planner.q1_diag = sc.planner.q1(ls.robot.n());
    resolved.planner.r1_diag = sc.planner.r1(ls.robot.n());
    if resolved.task.qd0.is_empty() {
        resolved.task.qd0 = vec![0.0; ls.robot.n()];
    }
    let mut text = format!(
        "# Resolved inputs of this run (swing time T = {:.6} s, N = {} intervals{}).\n",
        p.swing_time_s,
        p.layout.intervals,
        p.freefall_time_s
            .map(|f| format!(", T_freefall = {f:.6} s"))
            .unwrap_or_default()
    );
    text.push_str(&toml::to_string(&resolved).unwrap_or_default());
    folder.add("scenario.toml", text);
    let report = PlanReport::new(ls, &p);
    folder.add_json("report.json", &report.to_json());
    Ok(PlanRun {
        plan: p,
        report,
        folder,
    })
}
