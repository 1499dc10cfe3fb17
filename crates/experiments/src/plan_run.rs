//! A planning run: solve the scenario's swing and fill the run folder
//! (`knots.csv`, `trajectory.csv`, `scenario.toml`, `report.json`).

use crate::run_folder::RunFolder;
use crate::scenario::LoadedScenario;
use brachia::planning::{plan, Plan, SwingTime};
use serde_json::{json, Value};
use std::fmt::Write as _;

/// The outcome of [`run_plan`].
#[derive(Debug, Clone)]
pub struct PlanRun {
    /// The plan (converged or not).
    pub plan: Plan,
    /// The run folder's files.
    pub folder: RunFolder,
}

/// The solver's work on a plan in one line: every attempt, its barrier strategy, outcome and
/// passes, then the totals and the time split, e.g. `attempt 1 (monotone, restoration_failed):
/// pounce 10 it 0.52 s; attempt 2 (adopted, adaptive, solved): pounce 143 it 5.61 s | 153
/// iterations in 6.13 s: callbacks 4.20 s, linear algebra 1.51 s, line search and rest 0.42 s`.
pub fn solver_work_text(p: &Plan) -> String {
    let snake = |v: &Value| match v {
        Value::String(s) => s.clone(),
        Value::Object(m) => m.keys().next().cloned().unwrap_or_default(),
        other => other.to_string(),
    };
    let mut s = String::new();
    for (k, a) in p.solves.iter().enumerate() {
        let _ = write!(
            s,
            "{}attempt {} ({}{}, {}):",
            if k > 0 { "; " } else { "" },
            k + 1,
            if a.adopted { "adopted, " } else { "" },
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
    let t = &p.time_split;
    let _ = write!(
        s,
        " | {} iterations in {:.2} s: callbacks {:.2} s, linear algebra {:.2} s, line search and rest {:.2} s",
        p.iterations, p.solve_time_s, t.callbacks_s, t.linear_algebra_s, t.line_search_and_other_s
    );
    s
}

/// The plan's machine-readable report (the `report.json` of `brachia plan`). `iterations` and
/// `solve_time_s` are totals over every solver attempt and every pass of the backend inside it
/// (adopted or not); `solves` lists them, `time_split_s` splits the time (see
/// `brachia::planning::TimeSplit`).
pub fn plan_report(ls: &LoadedScenario, p: &Plan) -> Value {
    let t = ls.scenario.task.target;
    let v = &p.violations;
    let max_violation = v
        .dynamics
        .max(v.ee_position)
        .max(v.ee_velocity)
        .max(v.clearance)
        .max(v.bounds);
    json!({
        "scenario": ls.scenario.name,
        "status": p.status,
        "converged": p.converged(),
        "solver": p.backend.name(),
        "iterations": p.iterations,
        "attempts": p.attempts,
        "passes": p.solves.iter().map(|a| a.passes.len()).sum::<usize>(),
        "solve_time_s": p.solve_time_s,
        "time_split_s": p.time_split,
        "solves": p.solves,
        "callback_time_s": p.callback_timings,
        "objective": p.objective,
        "energy_j": p.energy_j,
        "positive_work_j": p.positive_work_j,
        "max_violation": max_violation,
        "violations": v,
        "ee_final": p.ee_final,
        "ee_final_error_m": (p.ee_final[0] - t[0]).hypot(p.ee_final[1] - t[1]),
        "swing_time_s": p.swing_time_s,
        "freefall_time_s": p.freefall_time_s,
        "knots": p.layout.intervals + 1,
        "intervals": p.layout.intervals,
        "collocation_points": p.layout.points,
        "knot_dt_s": p.layout.h,
        "transcription": ls.scenario.planner.transcription,
        "backend": ls.scenario.solver.backend,
        "replay_ee_error_m": p.replay_ee_error_m,
        "replay_torque_profile": ls.scenario.planner.transcription,
        "trajectory_end_s": p.trajectory.t.last(),
        "trajectory_clamped": p.resample_clamped,
        "min_obstacle_clearance_m": p.min_obstacle_clearance_m,
    })
}

/// Plan the scenario and prepare its run folder. Errors only on bad input; a solve that does not
/// converge still gives a [`PlanRun`] (check `plan.converged()`).
pub fn run_plan(ls: &LoadedScenario) -> Result<PlanRun, brachia::Error> {
    let sc = &ls.scenario;
    let p = plan(&ls.robot, &sc.task, &sc.planner, &sc.solver)?;
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
    let mut resolved = sc.clone();
    resolved.planner.swing_time = SwingTime::Seconds(p.swing_time_s);
    resolved.planner.q1_diag = sc.planner.q1(ls.robot.n);
    resolved.planner.r1_diag = sc.planner.r1(ls.robot.n);
    if resolved.task.qd0.is_empty() {
        resolved.task.qd0 = vec![0.0; ls.robot.n];
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
    folder.add_json("report.json", &plan_report(ls, &p));
    Ok(PlanRun { plan: p, folder })
}
