//! The plan-and-measure loop shared by the obstacle placement scans (`placement_scan.rs`,
//! `placement_heldout.rs`): a placement's obstacles, the solver settings under a wall-time limit,
//! and one planning call with its wall time and the smallest clearance of its 1 ms trajectory.
//! Units: m, s.

use brachia::model::{Circle, ClearanceFn, Robot};
use brachia::planning::{
    plan, workload, Backend, NlpSettings, Plan, PlannerSettings, SwingTask, Verdict,
    CLEARANCE_TOLERANCE_M,
};
use brachia::trajectory::Trajectory;
use std::time::Instant;

/// One placement: its obstacles and how they were drawn.
#[derive(Debug, Clone)]
pub struct Placement {
    pub seed: u64,
    pub what: String,
    pub obstacles: Vec<Circle>,
}

/// The solver settings of a scan: the Riccati backend, `time_limit_s` of wall time per call.
pub fn nlp(time_limit_s: f64) -> NlpSettings {
    NlpSettings {
        backend: Backend::Ocp,
        max_wall_time_s: Some(time_limit_s),
        ..Default::default()
    }
}

/// The smallest surface distance from the robot to `obstacles` over the samples of `trajectory`
/// (self-collision left out), m.
pub fn min_clearance(robot: &Robot, obstacles: &[Circle], trajectory: &Trajectory) -> f64 {
    let cf = ClearanceFn::new(robot.clone(), obstacles, 0.0)
        .unwrap()
        .with_self_collision(false);
    (0..trajectory.len())
        .map(|k| cf.min_clearance(trajectory.q(k)))
        .fold(f64::INFINITY, f64::min)
}

/// Whether a clearance keeps the settings' obstacle margin (less the tolerance).
pub fn keeps_margin(s: &PlannerSettings, min_clearance_m: f64) -> bool {
    min_clearance_m >= s.obstacle_margin - CLEARANCE_TOLERANCE_M
}

/// What one planning call of a placement gave.
pub struct Measured {
    /// The plan, or the task check's refusal.
    pub plan: Result<Plan, brachia::Error>,
    /// Wall time of the call, s.
    pub time_s: f64,
    /// Smallest surface distance to an obstacle over the plan's 1 ms trajectory, m (NaN when
    /// refused).
    pub min_clearance_m: f64,
}

/// Plan `task` with the placement's obstacles (settings `s`, `time_limit_s` of wall time) and
/// measure the call.
pub fn plan_placement(
    robot: &Robot,
    task: &SwingTask,
    s: &PlannerSettings,
    pl: &Placement,
    time_limit_s: f64,
) -> Measured {
    let task = SwingTask {
        obstacles: pl.obstacles.clone(),
        ..task.clone()
    };
    let t0 = Instant::now();
    let plan = plan(robot, &task, s, &nlp(time_limit_s));
    let time_s = t0.elapsed().as_secs_f64();
    let min_clearance_m = plan.as_ref().map_or(f64::NAN, |p| {
        min_clearance(robot, &pl.obstacles, &p.trajectory)
    });
    Measured {
        plan,
        time_s,
        min_clearance_m,
    }
}

/// The unobstructed swing of `robot` for `task` with the default planner, which must plan (`name`
/// names the robot in the failure).
pub fn free_swing(robot: &Robot, task: &SwingTask, name: &str, time_limit_s: f64) -> Plan {
    let p = plan(robot, task, &PlannerSettings::default(), &nlp(time_limit_s)).unwrap();
    assert!(p.converged(), "{name}: {:?}", p.failure_message());
    p
}

/// The placement of `seed` on the paper robot's unobstructed swing `free` (`placement_scan.rs`;
/// the draw of [`workload::swing_placement`]); `None` when an obstacle overlaps the start pose (the
/// task is then refused, not planned).
pub fn swing_placement(robot: &Robot, free: &Plan, seed: u64) -> Option<Placement> {
    let drawn = workload::swing_placement(robot, free, &SwingTask::paper().q0, seed)?;
    Some(Placement {
        seed,
        what: drawn.what,
        obstacles: drawn.obstacles,
    })
}

/// The settings of one solve of the placement searches: the swing time (`t_s`, or free in `range`
/// from `t_s`) and the knots; on a coarse mesh (knots over 50 ms) without the sub-step clearance rows.
pub fn settings_for(t_s: f64, range: Option<[f64; 2]>, knot_dt: f64) -> PlannerSettings {
    let mut s = PlannerSettings {
        swing_time: brachia::planning::SwingTime::Seconds(t_s),
        free_swing_time: range,
        knot_dt,
        ..PlannerSettings::default()
    };
    if knot_dt > 0.05 {
        s.shooting.substep_clearance = false;
    }
    s
}

/// What a plan that did not converge says blocks it, as one class: `no grid path` when every
/// configuration-space search to every goal pose tried ran out of free cells (the strongest
/// evidence the placement is infeasible), otherwise its diagnosis's verdict; `no diagnosis` when
/// it has none.
pub fn failure_class(p: &Plan) -> &'static str {
    let Some(d) = p.diagnosis.as_ref() else {
        return "no diagnosis";
    };
    if d.paths_exhausted {
        return "no grid path";
    }
    match d.verdict {
        Verdict::Unreachable => "unreachable",
        Verdict::NeedsTorque => "needs torque",
        Verdict::NeedsSwingTime => "needs swing time",
        Verdict::DetourWithinLimits => "detour within limits",
        Verdict::NoDetourFound => "no detour found",
        Verdict::ShortBetweenKnots => "short between knots",
    }
}

/// The failures of a scan counted by [`failure_class`], most first ("3 no grid path, 1 needs
/// torque"; "none" without failures).
pub fn class_counts(classes: &[&'static str]) -> String {
    let mut counts: Vec<(&'static str, usize)> = vec![];
    for c in classes {
        match counts.iter_mut().find(|(k, _)| k == c) {
            Some((_, n)) => *n += 1,
            None => counts.push((c, 1)),
        }
    }
    counts.sort_by(|a, b| b.1.cmp(&a.1).then(a.0.cmp(b.0)));
    if counts.is_empty() {
        return "none".into();
    }
    counts
        .iter()
        .map(|(k, n)| format!("{n} {k}"))
        .collect::<Vec<_>>()
        .join(", ")
}
