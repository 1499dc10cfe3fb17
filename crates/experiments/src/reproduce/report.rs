//! The reproduction's report: figures, `summary.json` and `REPORT.md`, with the paper's numbers beside
//! ours. Reads finished runs only.
//!
//! Units: SI (s, m, N m, J); times of the MPC in microseconds where the name says so.

use super::figures::{self, FigureDir};
use super::results::{summary_skeleton, Results};
use crate::run_folder::resolved;
use crate::ExpError;
use serde_json::{json, Value};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The paper's reported values (Ji et al., Section V), for the comparison table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PaperValues {
    /// Direct-collocation solve time bound, s ("within 200 ms", SNOPT, 10 ms knots).
    pub plan_time_s: f64,
    /// MPC solve time bound, s ("within 1 ms", Quadprog++).
    pub mpc_time_s: f64,
    /// Energy of the planned swing, J (V-B, eq. 18).
    pub planned_energy_j: f64,
    /// Energy of the MPC-tracked swing, J.
    pub tracked_energy_j: f64,
    /// Final EE error bound, m ("less than 0.02 m in both x and y").
    pub ee_final_error_m: f64,
    /// Torque range of the tracked swing, N m.
    pub tau_range: [f64; 2],
    /// Time of the robot-ball collision in V-D, s.
    pub hit_time_s: f64,
}

impl PaperValues {
    /// The values printed in the paper.
    pub const PAPER: PaperValues = PaperValues {
        plan_time_s: 0.2,
        mpc_time_s: 1e-3,
        planned_energy_j: 5.27,
        tracked_energy_j: 5.31,
        ee_final_error_m: 0.02,
        tau_range: [-2.5, 4.0],
        hit_time_s: 0.62,
    };
}

/// Draw every figure and animation; returns the figures that failed (with the reason).
pub(crate) fn draw_figures(res: &Results, figs: &mut FigureDir) -> Vec<String> {
    let mut failed = Vec::new();
    let mut check = |what: &str, r: Result<(), brachia_plot::PlotError>| {
        if let Err(e) = r {
            failed.push(format!("figure {what}: {e}"));
        }
    };
    if let Some(t) = &res.tracking {
        let (robot, target) = (&t.ls.robot, t.ls.scenario.task.target);
        check(
            "fig5",
            figures::joint_tracking(
                figs,
                "fig5_tracking_joints",
                "Tracking (V-B): joints, desired (dashed) vs MPC on the rapier plant (solid)",
                &t.rapier,
            ),
        );
        check(
            "fig6a",
            figures::tracked_stick(
                figs,
                "fig6a_tracking_stick",
                "Tracking (V-B): the swing under MPC on the rapier plant",
                robot,
                &t.rapier,
                target,
            ),
        );
        let runs = [
            ("MPC, rapier plant", &t.rapier),
            ("MPC, model plant", &t.model),
        ];
        check(
            "fig6b",
            figures::ee_path(
                figs,
                "fig6b_tracking_ee_path",
                "Tracking (V-B): end-effector path",
                &runs,
                target,
            ),
        );
        check(
            "fig6c",
            figures::ee_error(
                figs,
                "fig6c_tracking_ee_error",
                "Tracking (V-B): end-effector error, tracked minus desired",
                &runs,
                None,
            ),
        );
        check(
            "tracking.gif",
            figures::tracked_gif(
                figs,
                "tracking",
                "Tracking (V-B), MPC on the rapier plant",
                robot,
                &t.rapier,
                target,
            ),
        );
    }
    if let Some(o) = &res.obstacle {
        for (p, name, title) in [
            (
                &o.ignored,
                "fig7a_obstacle_ignored",
                "Obstacle (V-C): planned without avoidance",
            ),
            (
                &o.avoid,
                "fig7b_obstacle_avoided",
                "Obstacle (V-C): planned with avoidance",
            ),
        ] {
            let (ls, traj) = (&p.scenario, &p.trajectory);
            let task = &ls.scenario.task;
            check(
                name,
                figures::planned_stick(
                    figs,
                    name,
                    title,
                    &ls.robot,
                    traj,
                    task.target,
                    &task.obstacles,
                ),
            );
            let gif = name
                .trim_start_matches("fig7a_")
                .trim_start_matches("fig7b_");
            check(
                gif,
                figures::planned_gif(
                    figs,
                    gif,
                    title,
                    &ls.robot,
                    traj,
                    task.target,
                    &task.obstacles,
                ),
            );
        }
    }
    if let Some(st) = &res.study {
        for (what, r) in super::study::draw_figures(st, figs) {
            check(&what, r);
        }
    }
    if let Some(r) = &res.robustness {
        let (robot, target) = (&r.ls.robot, r.ls.scenario.task.target);
        let mpc = &r.runs[0];
        let title = format!(
            "Robustness (V-D): MPC on the rapier plant, ball at {}",
            ball_at(&r.ls)
        );
        check(
            "fig8a",
            figures::tracked_stick(figs, "fig8a_robustness_stick", &title, robot, mpc, target),
        );
        let runs: Vec<(&str, &crate::TrackFolder)> = r
            .runs
            .iter()
            .map(|x| (controller_label(&x.log.controller), x))
            .collect();
        check(
            "fig8b",
            figures::ee_error(
                figs,
                "fig8b_robustness_ee_error",
                "Robustness (V-D): end-effector error after the hit",
                &runs,
                mpc.world.first_contact_s(),
            ),
        );
        check(
            "fig8c",
            figures::joint_tracking(
                figs,
                "fig8c_robustness_joints",
                "Robustness (V-D): joints, desired (dashed) vs MPC (solid)",
                mpc,
            ),
        );
        check(
            "robustness.gif",
            figures::tracked_gif(
                figs,
                "robustness",
                "Robustness (V-D), MPC on the rapier plant",
                robot,
                mpc,
                target,
            ),
        );
        if let Some(p) = &r.paper {
            let title = format!(
                "Robustness (V-D) with the paper's ball at {}: {}",
                paper_ball(p),
                match p.world.first_contact_s() {
                    None => "never touched".to_string(),
                    Some(t) => format!("first touched at {t:.3} s"),
                }
            );
            check(
                "fig8d",
                figures::tracked_stick(
                    figs,
                    "fig8d_robustness_paper_ball",
                    &title,
                    robot,
                    p,
                    target,
                ),
            );
        }
    }
    failed
}

/// The figures of one `brachia plan` run folder: its stick diagram and animation (`plan_stick`,
/// `plan.gif`). Returns the figures that failed.
pub(crate) fn draw_plan_run(p: &crate::PlanFolder, figs: &mut FigureDir) -> Vec<String> {
    let (ls, title) = (&p.scenario, format!("Plan of {}", p.report.scenario));
    let task = &ls.scenario.task;
    let mut failed = Vec::new();
    for (what, r) in [
        (
            "plan_stick",
            figures::planned_stick(
                figs,
                "plan_stick",
                &title,
                &ls.robot,
                &p.trajectory,
                task.target,
                &task.obstacles,
            ),
        ),
        (
            "plan.gif",
            figures::planned_gif(
                figs,
                "plan",
                &title,
                &ls.robot,
                &p.trajectory,
                task.target,
                &task.obstacles,
            ),
        ),
    ] {
        if let Err(e) = r {
            failed.push(format!("figure {what}: {e}"));
        }
    }
    failed
}

/// The figures of one `brachia track` run folder: joints, EE path and EE error (`track_joints`,
/// `track_ee_path`, `track_ee_error`) and, when it planned (its robot is in `plan/`), the stick diagram and
/// animation (`track_stick`, `track.gif`). Returns the figures that failed.
pub(crate) fn draw_track_run(t: &crate::TrackFolder, figs: &mut FigureDir) -> Vec<String> {
    let rep = &t.report;
    let title = format!(
        "{} on the {} plant ({})",
        rep.controller, rep.plant, rep.scenario
    );
    let runs = [(controller_label(&rep.controller), t)];
    let mut out = vec![
        (
            "track_joints",
            figures::joint_tracking(figs, "track_joints", &title, t),
        ),
        (
            "track_ee_path",
            figures::ee_path(figs, "track_ee_path", &title, &runs, rep.target),
        ),
        (
            "track_ee_error",
            figures::ee_error(
                figs,
                "track_ee_error",
                &title,
                &runs,
                t.world.first_contact_s(),
            ),
        ),
    ];
    if let Some(p) = &t.plan {
        let robot = &p.scenario.robot;
        out.push((
            "track_stick",
            figures::tracked_stick(figs, "track_stick", &title, robot, t, rep.target),
        ));
        out.push((
            "track.gif",
            figures::tracked_gif(figs, "track", &title, robot, t, rep.target),
        ));
    }
    out.into_iter()
        .filter_map(|(what, r)| r.err().map(|e| format!("figure {what}: {e}")))
        .collect()
}

/// "a free 0.4 kg ball (radius 0.05 m, no gravity, restitution 0.3) at (0.02, -0.44)" for the first ball
/// of a scenario's plant.
fn ball_text(ls: &crate::scenario::LoadedScenario) -> String {
    ls.scenario
        .plant
        .obstacles
        .iter()
        .find_map(|o| match o {
            brachia_rapier::Obstacle::Ball(b) => Some(format!(
                "a free {} kg ball (radius {} m, {}, restitution {}) at ({}, {})",
                b.mass,
                b.radius,
                if b.gravity {
                    "under gravity"
                } else {
                    "no gravity"
                },
                b.restitution,
                b.center[0],
                b.center[1]
            )),
            _ => None,
        })
        .unwrap_or_else(|| "no ball".into())
}

/// Where the first ball of a scenario's plant starts, `(x, y)`.
fn ball_at(ls: &crate::scenario::LoadedScenario) -> String {
    ls.scenario.plant.obstacles.first().map_or("-".into(), |o| {
        let c = o.shape().0;
        format!("({}, {})", c[0], c[1])
    })
}

/// [`ball_at`] of the scenario a track run planned with (`-` when it did not plan).
fn paper_ball(p: &crate::TrackFolder) -> String {
    p.plan.as_ref().map_or("-".into(), |x| ball_at(&x.scenario))
}

fn controller_label(name: &str) -> &'static str {
    match name {
        "mpc" => "MPC",
        "pd" => "PD + planned torque",
        "open-loop" => "open loop",
        _ => "controller",
    }
}

/// `summary.json`: every number of the comparison table, by experiment.
pub(crate) fn summary(res: &Results, failures: &[String], warnings: &[String]) -> Value {
    let mut s = summary_skeleton(res);
    let m = s.as_object_mut().expect("an object");
    m.insert("failures".into(), json!(failures));
    m.insert("warnings".into(), json!(warnings));
    if let Some(st) = &res.study {
        m.insert("parameter_study".into(), super::study::summary(st));
    }
    if let Some(t) = &res.tracking {
        let plan = t.rapier.plan.as_ref().map(|p| &p.report);
        m.insert(
            "tracking".into(),
            json!({
                "plan_solve_time_s": plan.map(|p| p.solve_time_s),
                "plan_iterations": plan.map(|p| p.iterations),
                "plan_solver": plan.map(|p| &p.solver),
                "plan_time_split_s": plan.map(|p| p.time_split_s),
                "plan_solves": plan.map(|p| &p.solves),
                "plan_replay_ee_error_m": plan.map(|p| p.replay_ee_error_m),
                "swing_time_s": plan.map(|p| p.swing_time_s),
                "freefall_time_s": plan.and_then(|p| p.freefall_time_s),
                "planned_energy_j": plan.map(|p| p.energy_j),
                "rapier": track_summary(&t.rapier),
                "model": track_summary(&t.model),
            }),
        );
    }
    if let Some(o) = &res.obstacle {
        let one = |p: &crate::PlanFolder| {
            let p = &p.report;
            json!({
                "converged": p.converged,
                "status": p.status,
                "min_clearance_m": p.min_obstacle_clearance_m,
                "energy_j": p.energy_j,
                "solve_time_s": p.solve_time_s,
                "iterations": p.iterations,
                "solver": p.solver,
                "time_split_s": p.time_split_s,
                "solves": p.solves,
            })
        };
        m.insert(
            "obstacle".into(),
            json!({ "avoid": one(&o.avoid), "ignored": one(&o.ignored) }),
        );
    }
    if let Some(l) = &res.ladder {
        m.insert(
            "ladder".into(),
            json!({
                "scenario": l["scenario"],
                "completed": l["completed"],
                "message": l["message"],
                "bars": l["bars"].as_array().map(|b| b.len()),
                "swings": l["swings"].as_array().map(|v| v.iter().map(|w| json!({
                    "energy_j": w["energy_j"],
                    "positive_work_j": w["positive_work_j"],
                    "capture_error_m": w["capture_error_m"],
                    "switch_residual_m_s": w["switch_residual_m_s"],
                    "duration_s": w["duration_s"],
                })).collect::<Vec<_>>()),
                "totals": l["totals"],
                "joint_swings": res.ladder_joint.as_ref().map(|j| json!({
                    "swings": j["swings"],
                    "converged": j["converged"],
                    "status": j["status"],
                    "joint": j["joint"],
                    "swing_by_swing": j["swing_by_swing"],
                })),
            }),
        );
    }
    if let Some(r) = &res.robustness {
        let mut runs = serde_json::Map::new();
        for x in &r.runs {
            runs.insert(x.log.controller.clone(), track_summary(x));
        }
        m.insert(
            "robustness".into(),
            json!({
                "ball": r.ls.scenario.plant.obstacles,
                "runs": runs,
                "paper_placement": r.paper.as_ref().map(track_summary),
            }),
        );
    }
    s
}

fn track_summary(r: &crate::TrackFolder) -> Value {
    let s = &r.report.summary;
    json!({
        "controller": r.log.controller,
        "plant": r.log.plant,
        "ee_final_error_m": s.ee_final_error_m,
        "ee_error_max_m": s.ee_error_max_m,
        "joint_rms_error_rad": s.joint_rms_error_rad,
        "energy_j": s.energy_j,
        "tau_min": s.tau_min,
        "tau_max": s.tau_max,
        "control_step_us_p50": s.control_step_us_p50,
        "control_step_us_p99": s.control_step_us_p99,
        "control_step_us_max": s.control_step_us_max,
        "first_contact_s": r.world.first_contact_s(),
        "contact_events": r.world.contacts.len(),
    })
}

/// A plan's solver work (every attempt and pass, totals, time split) and what it hands on: the
/// open-loop replay of its own torque profile and its 1 ms trajectory.
fn plan_text(p: &crate::PlanReport) -> String {
    let c = &p.trajectory_clamped;
    format!(
        "the planner's solver ({}): {}. Open-loop replay of the {:?} torque profile from the start \
         state ends {:.2e} m from the bar; the 1 ms trajectory ends at T = {:.4} s and was clamped into \
         the bounds by at most {:.1e} rad, {:.1e} rad/s, {:.1e} N m.",
        p.solver,
        p.solver_work_text(),
        p.replay_torque_profile,
        p.replay_ee_error_m,
        p.trajectory_end_s.unwrap_or(0.0),
        c.q_rad,
        c.qd_rad_s,
        c.tau_nm
    )
}

/// Format a number for the table (`-` when absent).
fn num(v: Option<f64>, digits: usize) -> String {
    match v {
        Some(x) if x.is_finite() => format!("{x:.digits$}"),
        _ => "-".into(),
    }
}

/// One row of the comparison table.
struct Row {
    quantity: String,
    paper: String,
    ours: String,
    note: String,
}

fn rows(res: &Results) -> Vec<Row> {
    let p = PaperValues::PAPER;
    let mut out = Vec::new();
    let mut row = |q: &str, pv: String, ours: String, note: &str| {
        out.push(Row {
            quantity: q.into(),
            paper: pv,
            ours,
            note: note.into(),
        })
    };
    if let Some(t) = &res.tracking {
        let plan = t.rapier.plan.as_ref().map(|x| &x.report);
        let (sr, sm) = (&t.rapier.report.summary, &t.model.report.summary);
        row(
            "plan time (V-B swing)",
            format!("<= {:.0} ms (SNOPT)", p.plan_time_s * 1e3),
            format!(
                "{} ms ({} iterations{})",
                num(plan.map(|x| x.solve_time_s * 1e3), 0),
                plan.map_or(0, |x| x.iterations),
                plan.map_or(String::new(), |x| format!(
                    "; callbacks {:.0} ms, linear algebra {:.0} ms, line search and rest {:.0} ms",
                    x.time_split_s.callbacks_s * 1e3,
                    x.time_split_s.linear_algebra_s * 1e3,
                    x.time_split_s.line_search_and_other_s * 1e3
                ))
            ),
            &format!(
                "{} interior point with the exact sparse Hessian, every attempt and pass counted (section B); \
                 {:?} at {} s knots ({} collocation points; the paper's Euler mesh has one per knot); see \
                 docs/benchmarks.md",
                plan.map_or("pounce", |x| x.solver.as_str()),
                t.ls.scenario.planner.transcription,
                t.ls.scenario.planner.knot_dt,
                plan.map_or(0, |x| x.collocation_points)
            ),
        );
        row(
            "MPC time per 1 kHz step",
            format!("<= {:.0} ms (Quadprog++)", p.mpc_time_s * 1e3),
            format!(
                "p50 {:.0} us, p99 {:.0} us, max {:.0} us",
                sr.control_step_us_p50, sr.control_step_us_p99, sr.control_step_us_max
            ),
            "dense active-set box-QP, horizon and weights of docs/mpc.md; wall-clock of the controller call on a \
             shared 2-core machine (the max includes the OS preempting the process)",
        );
        row(
            "planned energy (eq. 18)",
            format!("{:.2} J", p.planned_energy_j),
            format!("{} J", num(plan.map(|x| x.energy_j), 3)),
            "the paper does not give Q1 and R1; ours are Q1 = 0.01 I, R1 = I (docs/interpretations.md), \
             so the optimum differs",
        );
        row(
            "tracked energy (eq. 18)",
            format!("{:.2} J", p.tracked_energy_j),
            format!(
                "{:.3} J (rapier), {:.3} J (model)",
                sr.energy_j, sm.energy_j
            ),
            "MPC on the physics engine and on the RK4 model",
        );
        row(
            "final EE error",
            format!("< {:.2} m", p.ee_final_error_m),
            format!(
                "{:.2e} m (rapier), {:.2e} m (model)",
                sr.ee_final_error_m, sm.ee_final_error_m
            ),
            "distance to the planned EE position at T",
        );
        row(
            "torque range (tracked)",
            format!("[{}, {}] N m", p.tau_range[0], p.tau_range[1]),
            format!("[{:.2}, {:.2}] N m", sr.tau_min, sr.tau_max),
            "limits +-5 N m (Table I); our cost weights give a different optimum",
        );
        row(
            "swing time T = 2 T_freefall (V-B)",
            "about 2.2 s (Figs. 5-6)".into(),
            format!("{} s", num(plan.map(|x| x.swing_time_s), 3)),
            "T_freefall: the locked robot released at rest until its EE reaches the midpoint's x",
        );
    }
    if let Some(st) = &res.study {
        for (q, pv, ours, note) in super::study::trend_rows(st) {
            row(&q, pv, ours, &note);
        }
    }
    if let Some(o) = &res.obstacle {
        row(
            "obstacle (V-C): clearance without / with avoidance",
            "contact / no contact (Fig. 7)".into(),
            format!(
                "{} m / {} m",
                num(o.ignored.report.min_obstacle_clearance_m, 3),
                num(o.avoid.report.min_obstacle_clearance_m, 3)
            ),
            "smallest surface distance between any link capsule and the obstacle over the 1 ms plan \
             (negative = penetration)",
        );
    }
    if let Some(r) = &res.robustness {
        let mpc = &r.runs[0];
        row(
            "robustness (V-D): hit time",
            format!("{:.2} s", p.hit_time_s),
            format!("{} s", num(mpc.world.first_contact_s(), 3)),
            "the paper's ball position (-1.2, 0.2) is never reached by the planned swing (0.28 m away; \
             see below); our ball sits on the planned path",
        );
        let finals: Vec<String> = r
            .runs
            .iter()
            .map(|x| {
                format!(
                    "{} {:.2e} m",
                    controller_label(&x.log.controller),
                    x.report.summary.ee_final_error_m
                )
            })
            .collect();
        row(
            "robustness (V-D): final EE error",
            "nearly zero (Fig. 8b)".into(),
            finals.join(", "),
            "rapier plant, the same plan for all three controllers",
        );
    }
    out
}

fn table(res: &Results) -> String {
    let mut s = String::from("| quantity | paper | brachia | note |\n|---|---|---|---|\n");
    for r in rows(res) {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            r.quantity, r.paper, r.ours, r.note
        );
    }
    s
}

fn image(s: &mut String, figs: &Path, name: &str, alt: &str) {
    let _ = writeln!(
        s,
        "![{alt}]({})\n",
        figs.join(format!("{name}.png")).display()
    );
}

/// Animations of the reproduction: (file stem, what it shows).
const ANIMATIONS: [(&str, &str); 4] = [
    ("tracking", "tracking (V-B)"),
    ("obstacle_ignored", "obstacle ignored (V-C)"),
    ("obstacle_avoided", "obstacle avoided (V-C)"),
    ("robustness", "robustness (V-D)"),
];

/// The animations the results page carries (the others stay in the reproduction folder).
const PAGE_ANIMATIONS: [&str; 2] = ["tracking", "robustness"];

/// Where a Markdown rendering goes: the reproduction's own REPORT.md, or the results page in docs/.
#[derive(Clone, Copy, PartialEq)]
pub(crate) enum Target {
    Report,
    Page,
}

/// `REPORT.md` (or the results page); `figs` is the figure folder relative to the file.
pub(crate) fn markdown(
    res: &Results,
    failures: &[String],
    warnings: &[String],
    figs: &Path,
    target: Target,
) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# brachia: reproduction of Ji et al., Section V\n\nGenerated by `brachia reproduce{}` in {:.0} s \
         on {} cores. {}\n",
        if res.quick { " --quick" } else { "" },
        res.wall_s,
        res.cores,
        match target {
            Target::Report => "Every number below comes from the run folders beside this file; \
                               `summary.json` has them in machine-readable form.",
            Target::Page => "Every number below comes from that run's folders (`out/reproduce/` by \
                             default: run folders, `summary.json`, every figure as PNG and SVG).",
        }
    );
    if failures.is_empty() {
        s.push_str("Every experiment ran to completion.\n\n");
    } else {
        s.push_str("**Not everything succeeded:**\n\n");
        for f in failures {
            let _ = writeln!(s, "- {f}");
        }
        s.push('\n');
    }
    for w in warnings {
        let _ = writeln!(s, "Note: {w}.\n");
    }
    s.push_str("## The paper's numbers beside ours\n\n");
    s.push_str(&table(res));
    s.push('\n');
    if let Some(st) = &res.study {
        s.push_str("## A. Parameter study (Figs. 3 and 4)\n\n");
        s.push_str(&super::study::markdown(st, figs));
    }
    if let Some(t) = &res.tracking {
        let _ = writeln!(
            s,
            "## B. Trajectory tracking (Figs. 5 and 6)\n\nStart at rest at q = {:?} (EE at ({:.3}, {:.3})), \
             target ({}, {}). The plan is tracked by the MPC at 1 kHz on the rapier physics engine (the \
             paper's Webots run) and on the RK4 model plant (`tracking/`, `tracking-model/`).\n",
            t.ls.scenario.task.q0,
            t.rapier.log.ee[0][0],
            t.rapier.log.ee[0][1],
            t.ls.scenario.task.target[0],
            t.ls.scenario.task.target[1]
        );
        if let Some(p) = t.rapier.plan.as_ref().map(|x| &x.report) {
            let _ = writeln!(s, "{}\n", plan_text(p));
        }
        image(
            &mut s,
            figs,
            "fig5_tracking_joints",
            "Fig. 5: joint tracking",
        );
        image(
            &mut s,
            figs,
            "fig6a_tracking_stick",
            "Fig. 6a: stick diagram",
        );
        image(&mut s, figs, "fig6b_tracking_ee_path", "Fig. 6b: EE path");
        image(&mut s, figs, "fig6c_tracking_ee_error", "Fig. 6b: EE error");
    }
    if let Some(o) = &res.obstacle {
        let _ = writeln!(
            s,
            "## C. Obstacle avoidance (Fig. 7)\n\nObstacles {}, target ({}, {}). Without avoidance the plan passes {} m from the obstacle's surface (negative: through it); with \
             avoidance every link keeps at least {} m (the margin is {} m). Energy {} J without, {} J with \
             avoidance (`obstacle/ignored/`, `obstacle/avoid/`).\n",
            o.avoid
                .scenario
                .scenario
                .task
                .obstacles
                .iter()
                .map(|c| format!("radius {} m at ({}, {})", c.radius, c.center[0], c.center[1]))
                .collect::<Vec<_>>()
                .join(", "),
            o.avoid.scenario.scenario.task.target[0],
            o.avoid.scenario.scenario.task.target[1],
            num(o.ignored.report.min_obstacle_clearance_m, 3),
            num(o.avoid.report.min_obstacle_clearance_m, 3),
            o.avoid.scenario.scenario.planner.obstacle_margin,
            num(Some(o.ignored.report.energy_j), 3),
            num(Some(o.avoid.report.energy_j), 3),
        );
        let _ = writeln!(
            s,
            "With avoidance: {}\n\nWithout: {}\n",
            plan_text(&o.avoid.report),
            plan_text(&o.ignored.report)
        );
        image(
            &mut s,
            figs,
            "fig7a_obstacle_ignored",
            "Fig. 7a: without avoidance",
        );
        image(
            &mut s,
            figs,
            "fig7b_obstacle_avoided",
            "Fig. 7b: with avoidance",
        );
    }
    if let Some(r) = &res.robustness {
        let mpc = &r.runs[0];
        let _ = writeln!(
            s,
            "## D. Robustness (Fig. 8)\n\nThe tracking scenario with {} that the planner does not know, on the \
             rapier plant. The first contact comes at {} s ({} contact events); the MPC ends {:.2e} m from the bar (largest EE error {:.2e} m). \
             The same plan under the baselines: {}.\n",
            ball_text(&r.ls),
            num(mpc.world.first_contact_s(), 3),
            mpc.world.contacts.len(),
            mpc.report.summary.ee_final_error_m,
            mpc.report.summary.ee_error_max_m,
            r.runs[1..]
                .iter()
                .map(|x| format!(
                    "{} ends {:.2e} m from the bar (largest error {:.2e} m)",
                    controller_label(&x.log.controller),
                    x.report.summary.ee_final_error_m,
                    x.report.summary.ee_error_max_m
                ))
                .collect::<Vec<_>>()
                .join("; ")
        );
        if let Some(p) = &r.paper {
            let _ = writeln!(
                s,
                "With the paper's placement, {}, the ball is {} (final EE error {:.2e} m; `robustness-paper/`). \
                 The planned swing starts below the bar and moves down and forward, away from that point \
                 (docs/rapier.md measures 0.28 m between it and the nearest link axis).\n",
                paper_ball(p),
                match p.world.first_contact_s() {
                    None => "never touched".to_string(),
                    Some(t) => format!("first touched at {t:.3} s"),
                },
                p.report.summary.ee_final_error_m
            );
        }
        image(
            &mut s,
            figs,
            "fig8a_robustness_stick",
            "Fig. 8a: stick diagram with the ball",
        );
        image(
            &mut s,
            figs,
            "fig8b_robustness_ee_error",
            "Fig. 8b: EE error",
        );
        image(
            &mut s,
            figs,
            "fig8c_robustness_joints",
            "Fig. 8: joints after the hit",
        );
        if r.paper.is_some() {
            image(
                &mut s,
                figs,
                "fig8d_robustness_paper_ball",
                "the paper's ball placement",
            );
        }
    }
    if let Some(l) = &res.ladder {
        s.push_str(&ladder_markdown(l, res.ladder_joint.as_ref(), target));
    }
    s.push_str("## Animations\n\n");
    for (name, what) in ANIMATIONS {
        if target == Target::Page && !PAGE_ANIMATIONS.contains(&name) {
            continue;
        }
        let _ = writeln!(
            s,
            "- [{what}]({})",
            figs.join(format!("{name}.gif")).display()
        );
    }
    s.push_str(
        "\nIn the reproduction folder every static figure has an SVG beside its PNG. Each run folder holds \
         its CSVs (1 ms) and a `report.json`; the folders that planned also hold the plan's resolved inputs \
         (`scenario.toml`, under `plan/` for track runs), and the others track that same plan.\n",
    );
    s
}

/// The ladder section of the report, from the traverse's `report.json` (docs/ladders.md).
fn ladder_markdown(l: &Value, joint: Option<&Value>, target: Target) -> String {
    let mut s = String::new();
    let f = |v: &Value, d: usize| num(v.as_f64(), d);
    let _ = writeln!(
        s,
        "## E. A ladder traverse (beyond the paper)\n\n`{}`: {} bars on the model plant under MPC, \
         the grip switching at every bar (docs/ladders.md). {}.\n\n\
         | swing | energy eq. 18 (J) | positive work (J) | duration (s) | capture error (m) | switch residual (m/s) |\n\
         |---|---|---|---|---|---|",
        l["scenario"].as_str().unwrap_or("?"),
        l["bars"].as_array().map_or(0, |b| b.len()),
        l["message"].as_str().unwrap_or("?"),
    );
    for (k, w) in l["swings"].as_array().into_iter().flatten().enumerate() {
        let _ = writeln!(
            s,
            "| {k} | {} | {} | {} | {:.1e} | {:.1e} |",
            f(&w["energy_j"], 3),
            f(&w["positive_work_j"], 3),
            f(&w["duration_s"], 3),
            w["capture_error_m"].as_f64().unwrap_or(f64::NAN),
            w["switch_residual_m_s"].as_f64().unwrap_or(f64::NAN),
        );
    }
    let t = &l["totals"];
    let _ = writeln!(
        s,
        "\nTotal energy {} J over {} s; real-time factor {} (planning and tracking).\n",
        f(&t["energy_j"], 3),
        f(&t["duration_s"], 3),
        f(&t["real_time_factor"], 2),
    );
    if target == Target::Report {
        s.push_str(
            "![energy per swing](ladder/energy_per_swing.png)\n\n[The whole traverse](ladder/traverse.gif)\n\n",
        );
    }
    if let Some(j) = joint {
        s.push_str(&joint_swings_markdown(j));
    }
    s
}

/// The joint multi-swing plan against swing-by-swing planning, from `ladder/joint_swings.json`.
fn joint_swings_markdown(j: &Value) -> String {
    let mut s = String::new();
    let f = |v: &Value, d: usize| num(v.as_f64(), d);
    let _ = writeln!(
        s,
        "**The first {} swings planned jointly** (one problem sharing the switch states, warm-started \
         from the swing-by-swing plans; docs/ladders.md, \"The joint multi-swing plan\"): {}.\n\n\
         | plan | swing | objective | energy eq. 18 (J) | positive work (J) | capture residual (m, m/s) |\n\
         |---|---|---|---|---|---|",
        j["swings"],
        j["status"].as_str().unwrap_or("?"),
    );
    for w in j["phases"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "| swing by swing | {} | {} | {} | {} | - |",
            w["swing"],
            f(&w["reference_objective"], 3),
            f(&w["reference_energy_j"], 3),
            f(&w["reference_positive_work_j"], 3),
        );
    }
    for w in j["phases"].as_array().into_iter().flatten() {
        let _ = writeln!(
            s,
            "| joint | {} | {} | {} | {} | {:.1e}, {:.1e} |",
            w["swing"],
            f(&w["objective"], 3),
            f(&w["energy_j"], 3),
            f(&w["positive_work_j"], 3),
            w["capture_position_m"].as_f64().unwrap_or(f64::NAN),
            w["capture_speed_m_s"].as_f64().unwrap_or(f64::NAN),
        );
    }
    let (r, t) = (&j["swing_by_swing"], &j["joint"]);
    let _ = writeln!(
        s,
        "\nTotals: objective {} swing by swing, {} joint; energy eq. 18 {} J and {} J; positive work \
         {} J and {} J; solver iterations {} and {}.\n",
        f(&r["objective"], 3),
        f(&t["objective"], 3),
        f(&r["energy_j"], 3),
        f(&t["energy_j"], 3),
        f(&r["positive_work_j"], 2),
        f(&t["positive_work_j"], 2),
        r["iterations"],
        t["iterations"],
    );
    s
}

/// Manifest of the figures a results page's folder holds that `publish` wrote (a re-run removes only
/// these).
const PAGE_MANIFEST: &str = ".brachia-page";

/// Check a results page before any work: a `.md` file (not a folder) whose folder of figures (the page
/// path without `.md`) is not a regular file, in a place that can be written.
pub(crate) fn check_page(page: &Path, out: &Path) -> Result<(), ExpError> {
    let bad = |reason: String| ExpError::OutDir {
        path: page.to_path_buf(),
        reason,
    };
    if page.extension().is_none_or(|x| x != "md") {
        return Err(bad(
            "--results-page must be a Markdown file ending in .md (its figures go into the folder \
             of the same name without .md)"
                .into(),
        ));
    }
    if page.is_dir() {
        return Err(bad("is a folder; --results-page must be a .md file".into()));
    }
    let dir = page.with_extension("");
    // the page and its figure folder apart from --out: a run replaces --out (the page would be
    // dropped with the old run, or written over REPORT.md), and the page's figures are copied from it
    let (r_out, r_dir) = (resolved(out), resolved(&dir));
    if let (Some(o), Some(d)) = (r_out, r_dir) {
        if o == d || o.starts_with(&d) || d.starts_with(&o) {
            return Err(bad(format!(
                "it or its figure folder {} overlaps --out {}; put the results page outside --out \
                 (e.g. docs/results.md)",
                dir.display(),
                out.display()
            )));
        }
    }
    if dir.exists() && !dir.is_dir() {
        return Err(bad(format!(
            "{} (where the page's figures go) exists and is not a folder",
            dir.display()
        )));
    }
    if dir.is_dir() {
        // a listing of the previous publication brachia cannot read is refused before any work
        crate::manifest::read_listing(&dir, PAGE_MANIFEST)?;
    }
    let parent = match page.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    if !parent.is_dir() {
        return Err(bad(format!(
            "its folder {} does not exist",
            parent.display()
        )));
    }
    let probe = parent.join(format!(".brachia-probe-page-{}", std::process::id()));
    match std::fs::create_dir(&probe) {
        Ok(()) => {
            let _ = std::fs::remove_dir(&probe);
            Ok(())
        }
        Err(e) => Err(bad(format!(
            "nothing can be written in {}: {e}",
            parent.display()
        ))),
    }
}

/// Write the results page (`page`, e.g. docs/results.md) with the key figures copied beside it into a
/// folder named after the page (docs/results/). Only the figures the previous publication wrote (listed
/// in the folder's `.brachia-page`) are replaced or removed; other files there are the user's and stay.
pub(crate) fn publish(
    res: &Results,
    failures: &[String],
    warnings: &[String],
    out: &Path,
    page: &Path,
) -> Result<(), ExpError> {
    check_page(page, out)?;
    let dir = page.with_extension("");
    let rel = Path::new(dir.file_name().unwrap_or_default());
    let werr = |path: &Path, source| ExpError::Write {
        path: path.to_path_buf(),
        source,
    };
    std::fs::create_dir_all(&dir).map_err(|e| werr(&dir, e))?;
    // the previous publication's figures go first: only those its listing proves brachia wrote
    let previous = crate::manifest::read_listing(&dir, PAGE_MANIFEST)?.unwrap_or_default();
    for rel in crate::manifest::proven_files(&dir, &previous) {
        if rel.components().count() == 1 {
            let p = dir.join(&rel);
            std::fs::remove_file(&p).map_err(|e| werr(&p, e))?;
        }
    }
    // only the figures this reproduction provably wrote, never the user's files in figures/
    let ours = crate::manifest::read_manifest(out)?
        .map(|m| crate::manifest::proven_files(out, &m))
        .unwrap_or_default();
    let mut folder = crate::RunFolder::default();
    let mut stamps = std::collections::BTreeMap::new();
    for rel in &ours {
        let Ok(name) = rel.strip_prefix("figures") else {
            continue;
        };
        let name = name.to_string_lossy().to_string();
        // the PNGs and two animations: the page's key figures, without every GIF's megabyte
        let keep =
            name.ends_with(".png") || PAGE_ANIMATIONS.iter().any(|g| name == format!("{g}.gif"));
        if !keep || name.contains('/') {
            continue;
        }
        let p = out.join(rel);
        let data = std::fs::read(&p).map_err(|e| werr(&p, e))?;
        // a user's entry of the same name beside the page is moved aside as NAME.user
        let target = dir.join(&name);
        if std::fs::symlink_metadata(&target).is_ok() {
            crate::run_folder::move_aside(&target)?;
        }
        stamps.insert(PathBuf::from(&name), crate::manifest::Stamp::of(&data));
        folder.add(&name, data);
    }
    let listing = crate::manifest::manifest_text(&stamps);
    folder.add(PAGE_MANIFEST, listing);
    folder.write_into(&dir)?;
    let mut md = markdown(res, failures, warnings, rel, Target::Page);
    md = md.replacen(
        "# brachia: reproduction of Ji et al., Section V",
        "# Results\n\nThis page is generated by `brachia reproduce --results-page docs/results.md` from \
         the latest full run; do not edit it by hand.\n\n## Reproduction of Ji et al., Section V",
        1,
    );
    let mut top = crate::RunFolder::default();
    let name = page
        .file_name()
        .unwrap_or_default()
        .to_string_lossy()
        .to_string();
    top.add(&name, md);
    top.write_into(page.parent().unwrap_or(Path::new(".")))
}
