//! Does a plan folder belong to a scenario? Before `brachia track --plan DIR --scenario S` tracks
//! anything, every field the plan (`DIR/scenario.toml` with its robot, and the trajectory itself) and
//! `S` share must agree: the robot (gravity, every link's length, mass, centre of mass, inertia and
//! radius, the torque limits), the start state, the target bar, the obstacles and the planner's bounds.
//! A plan made for another bar, robot or world is refused (naming the field and both values), never
//! tracked as if it were the scenario's.

use crate::scenario::LoadedScenario;
use brachia::trajectory::Trajectory;
use brachia::Error;
use std::path::Path;

/// Relative tolerance of two shared values: `|a - b| <= PLAN_MATCH_TOLERANCE * (1 + max(|a|, |b|))`
/// (the TOML files hold the values exactly; only the last digits of a re-written number may differ).
pub const PLAN_MATCH_TOLERANCE: f64 = 1e-9;

/// Largest distance between the plan's final hand position (the forward kinematics of its last `q` on
/// the scenario's robot) and the scenario's target bar, m: a converged plan ends at its bar to the
/// solver's tolerance.
pub const PLAN_TARGET_TOLERANCE_M: f64 = 1e-3;

/// Largest difference between the plan's duration and its report's `swing_time_s`, s (the file keeps
/// times to 1 us).
pub const PLAN_DURATION_TOLERANCE_S: f64 = 1e-5;

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= PLAN_MATCH_TOLERANCE * (1.0 + a.abs().max(b.abs()))
}

fn fmt(v: &[f64]) -> String {
    let parts: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
    if parts.len() == 1 {
        parts[0].clone()
    } else {
        format!("[{}]", parts.join(", "))
    }
}

/// The values of every field a plan's scenario and a tracking scenario share, by the field's name as
/// a scenario or its robot file spells it.
fn shared_fields(ls: &LoadedScenario) -> Vec<(String, Vec<f64>)> {
    let p = ls.robot.params();
    let sc = &ls.scenario;
    let n = ls.robot.n();
    let mut f: Vec<(String, Vec<f64>)> = vec![
        ("robot links (count)".into(), vec![p.links.len() as f64]),
        ("robot gravity".into(), vec![p.gravity]),
    ];
    for (i, l) in p.links.iter().enumerate() {
        f.push((format!("robot links[{i}].length"), vec![l.length]));
        f.push((format!("robot links[{i}].mass"), vec![l.mass]));
        f.push((format!("robot links[{i}].com"), vec![l.com]));
        f.push((format!("robot links[{i}].inertia"), vec![l.inertia]));
        f.push((format!("robot links[{i}].radius"), vec![l.radius]));
    }
    f.push((
        "robot actuators.tau_min".into(),
        p.actuators.tau_min.clone(),
    ));
    f.push((
        "robot actuators.tau_max".into(),
        p.actuators.tau_max.clone(),
    ));
    let t = &sc.task;
    f.push(("task.q0".into(), t.q0.clone()));
    let qd0 = if t.qd0.is_empty() {
        vec![0.0; n]
    } else {
        t.qd0.clone()
    };
    f.push(("task.qd0".into(), qd0));
    f.push(("task.target".into(), t.target.to_vec()));
    f.push((
        "task.obstacles (count)".into(),
        vec![t.obstacles.len() as f64],
    ));
    for (i, o) in t.obstacles.iter().enumerate() {
        f.push((format!("task.obstacles[{i}].center"), o.center.to_vec()));
        f.push((format!("task.obstacles[{i}].radius"), vec![o.radius]));
    }
    let b = &sc.planner.bounds;
    f.push(("planner.bounds.q1".into(), b.q1.to_vec()));
    f.push(("planner.bounds.q_rel_max".into(), vec![b.q_rel_max]));
    f.push(("planner.bounds.qd_max".into(), vec![b.qd_max]));
    f.push((
        "planner.bounds.qd_end_max".into(),
        b.qd_end_max.into_iter().collect(),
    ));
    f.push((
        "planner.obstacle_margin".into(),
        vec![sc.planner.obstacle_margin],
    ));
    f
}

/// Refuse (naming the scenario file, the field, both values and the plan's file) the first field the
/// plan's scenario `plan` and the tracking scenario `ls` share that differs beyond
/// [`PLAN_MATCH_TOLERANCE`].
pub fn check_same_task(plan: &LoadedScenario, ls: &LoadedScenario) -> Result<(), Error> {
    let ours = shared_fields(ls);
    let theirs = shared_fields(plan);
    for ((field, a), (_, b)) in ours.iter().zip(&theirs) {
        let same = a.len() == b.len() && a.iter().zip(b).all(|(x, y)| close(*x, *y));
        if !same {
            return Err(Error::invalid(
                ls.path.display().to_string(),
                field.clone(),
                fmt(a),
                format!(
                    "the plan was made for {field} = {} ({}); every field a plan and a scenario \
                     share must agree (to a relative {PLAN_MATCH_TOLERANCE:e}): track the plan with \
                     the scenario it was planned for",
                    if b.is_empty() { "none".into() } else { fmt(b) },
                    plan.path.display()
                ),
            ));
        }
    }
    Ok(())
}

/// Refuse a plan whose last sample does not put the scenario robot's hand on the scenario's target
/// bar (within [`PLAN_TARGET_TOLERANCE_M`]): a plan made for another bar.
pub fn check_ends_at_target(
    traj: &Trajectory,
    ls: &LoadedScenario,
    tfile: &Path,
) -> Result<(), Error> {
    let last = traj.len() - 1;
    let ee = ls.robot.ee_position(traj.q(last));
    let bar = ls.scenario.task.target;
    let off = (ee[0] - bar[0]).hypot(ee[1] - bar[1]);
    if off > PLAN_TARGET_TOLERANCE_M || !off.is_finite() {
        return Err(Error::invalid(
            ls.path.display().to_string(),
            "task.target",
            fmt(&bar),
            format!(
                "the plan in {} ends with the hand at [{:.6}, {:.6}], {off:.4} m from this target \
                 (at most {PLAN_TARGET_TOLERANCE_M} m): it was made for another bar; track it with \
                 the scenario it was planned for",
                tfile.display(),
                ee[0],
                ee[1]
            ),
        ));
    }
    Ok(())
}

/// Refuse a plan whose trajectory does not last its report's `swing_time_s` (within
/// [`PLAN_DURATION_TOLERANCE_S`]).
pub fn check_duration(traj: &Trajectory, swing_time_s: f64, report: &Path) -> Result<(), Error> {
    let d = traj.duration();
    if (d - swing_time_s).abs() > PLAN_DURATION_TOLERANCE_S || !swing_time_s.is_finite() {
        return Err(Error::invalid(
            report.display().to_string(),
            "swing_time_s",
            swing_time_s,
            format!(
                "the plan's trajectory.csv lasts {d} s: a plan's trajectory lasts its swing time \
                 (within {PLAN_DURATION_TOLERANCE_S:e} s)"
            ),
        ));
    }
    Ok(())
}
