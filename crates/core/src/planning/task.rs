//! What to plan ([`SwingTask`]) and the checks a task passes before anything is solved.
//!
//! Conventions: `q0` in rad (`q0[0]` absolute from +x, the rest relative), `qd0` in rad/s, the target
//! bar and obstacle centres in m in the grip frame (origin at the grip, gravity along -y).

use crate::error::{Error, Result};
use crate::model::{Circle, ClearanceFn, Robot};
use crate::planning::settings::{PlannerSettings, ValidSettings};
use serde::{Deserialize, Serialize};

/// What to plan: where the robot starts, which bar it must reach, what is in the way.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SwingTask {
    /// Start joint angles (n), rad.
    pub q0: Vec<f64>,
    /// Start joint velocities (n), rad/s; empty = at rest.
    #[serde(default)]
    pub qd0: Vec<f64>,
    /// Target bar position in the grip frame, m.
    #[serde(deserialize_with = "crate::serde_exact::pair")]
    pub target: [f64; 2],
    /// Circular obstacles.
    #[serde(default)]
    pub obstacles: Vec<Circle>,
}

impl SwingTask {
    /// A swing of a ladder: from the start state `q0`, `qd0` (rad, rad/s; `qd0` empty = at rest) of
    /// the chain holding `grip` to `bar`, with `obstacles` given in the world frame: the target and the
    /// obstacles moved into the grip frame (m). The one rule the traverse and the joint multi-swing
    /// plan use.
    pub fn on_ladder(
        q0: &[f64],
        qd0: &[f64],
        grip: [f64; 2],
        bar: [f64; 2],
        obstacles: &[Circle],
    ) -> SwingTask {
        SwingTask {
            q0: q0.to_vec(),
            qd0: qd0.to_vec(),
            target: [bar[0] - grip[0], bar[1] - grip[1]],
            obstacles: obstacles
                .iter()
                .map(|o| Circle {
                    center: [o.center[0] - grip[0], o.center[1] - grip[1]],
                    radius: o.radius,
                })
                .collect(),
        }
    }

    /// The paper's Section V-B swing (Figs. 5-6, `scenarios/tracking.toml`): from rest at
    /// `q0 = [-2.35, 0, -1.55, 0]` rad (EE at (-1.014, -0.017) m) to the bar at (0.8, 0) m, no
    /// obstacles, for the 4-link robot of [`Robot::paper`].
    pub fn paper() -> Self {
        SwingTask {
            q0: vec![-2.35, 0.0, -1.55, 0.0],
            qd0: vec![],
            target: [0.8, 0.0],
            obstacles: vec![],
        }
    }
}

/// Most obstacles a task may have (each adds n clearance rows per collocation point).
pub const MAX_OBSTACLES: usize = 64;

/// Refuse planner bounds wider than the robot's own joint limits (`links[i].q_min`, `q_max`,
/// `qd_max` of its parameters): the planner's bounds may only tighten them.
fn check_bounds_within_robot(robot: &Robot, b: &super::Bounds, src: &str) -> Result<()> {
    let wider = |field: &str, value: String, link: usize, limit: &str, v: f64| {
        Err(Error::invalid(
            src,
            format!("planner.bounds.{field}"),
            value,
            format!(
                "reaches past the robot's own limit of joint {} (links[{link}].{limit} = {v}): \
                 the planner's bounds may only tighten the robot's limits",
                link + 1
            ),
        ))
    };
    for (i, l) in robot.params().links.iter().enumerate() {
        let (lo, hi) = if i == 0 {
            (b.q1[0], b.q1[1])
        } else {
            (-b.q_rel_max, b.q_rel_max)
        };
        let (field, value) = if i == 0 {
            ("q1", format!("{:?}", b.q1))
        } else {
            ("q_rel_max", b.q_rel_max.to_string())
        };
        if let Some(v) = l.q_min.filter(|&v| lo < v) {
            return wider(field, value, i, "q_min", v);
        }
        if let Some(v) = l.q_max.filter(|&v| hi > v) {
            return wider(field, value, i, "q_max", v);
        }
        if let Some(v) = l.qd_max.filter(|&v| b.qd_max > v) {
            return wider("qd_max", b.qd_max.to_string(), i, "qd_max", v);
        }
    }
    Ok(())
}

/// A [`SwingTask`] that passed [`validate_task`] for a robot and [`ValidSettings`], with its start
/// velocities filled in ([`ValidTask::qd0`]): what the planner's internal functions take, so that a
/// plan checks its task once. Read the task through `Deref`.
///
/// It stays valid for settings derived from those it was checked with (their bounds and
/// `avoid_obstacles` are the same, or wider bounds that still hold the start state), and for a robot
/// of the same links and joint limits (the actuator-limit continuation's).
#[derive(Debug, Clone, PartialEq)]
pub struct ValidTask {
    task: SwingTask,
    qd0: Vec<f64>,
}

impl std::ops::Deref for ValidTask {
    type Target = SwingTask;

    fn deref(&self) -> &SwingTask {
        &self.task
    }
}

impl ValidTask {
    /// Check `task` for `robot` under `settings` ([`validate_task`]; `src` names the file and
    /// `prefix` the section in messages).
    pub fn new(
        robot: &Robot,
        task: SwingTask,
        settings: &ValidSettings,
        src: &str,
        prefix: &str,
    ) -> Result<Self> {
        let qd0 = validate_task(robot, &task, settings, src, prefix)?;
        Ok(ValidTask { task, qd0 })
    }

    /// The task.
    pub fn task(&self) -> &SwingTask {
        &self.task
    }

    /// The task, given back.
    pub fn into_inner(self) -> SwingTask {
        self.task
    }

    /// The start joint velocities (n), rad/s: the task's, or zeros when it gave none.
    pub fn qd0(&self) -> &[f64] {
        &self.qd0
    }

    /// The task without its obstacles (valid: nothing else changes).
    pub(crate) fn without_obstacles(&self) -> ValidTask {
        ValidTask {
            task: SwingTask {
                obstacles: vec![],
                ..self.task.clone()
            },
            qd0: self.qd0.clone(),
        }
    }

    /// The task with every obstacle's radius scaled by `s` in `(0, 1]` (valid: a smaller obstacle
    /// clears the start pose and the target by more). Panics on `s` outside `(0, 1]`, a caller's
    /// error.
    pub(crate) fn with_obstacles_scaled(&self, s: f64) -> ValidTask {
        assert!(s > 0.0 && s <= 1.0, "obstacle scale {s} outside (0, 1]");
        let obstacles = self
            .task
            .obstacles
            .iter()
            .map(|o| Circle {
                center: o.center,
                radius: s * o.radius,
            })
            .collect();
        ValidTask {
            task: SwingTask {
                obstacles,
                ..self.task.clone()
            },
            qd0: self.qd0.clone(),
        }
    }
}

/// Check a task for `robot` under `settings` before anything is solved: lengths of `q0` and `qd0`,
/// finite values, the start state inside the bounds (q1 range, |q_i| <= q_rel_max, |qd_i| <= qd_max),
/// the target within reach, the obstacles valid and clear of the start pose and the target. `src`
/// names the file and `prefix` the section (e.g. `task.`) in messages. Returns qd0 (zeros when empty).
pub fn validate_task(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    src: &str,
    prefix: &str,
) -> Result<Vec<f64>> {
    let n = robot.n();
    let field = |f: &str| format!("{prefix}{f}");
    let fmt = |v: &[f64]| format!("{v:?}");
    if task.q0.len() != n {
        return Err(Error::invalid(
            src,
            field("q0"),
            fmt(&task.q0),
            format!("needs {n} values, one per joint of the {n}-link robot"),
        ));
    }
    let qd0 = if task.qd0.is_empty() {
        vec![0.0; n]
    } else {
        task.qd0.clone()
    };
    if qd0.len() != n {
        return Err(Error::invalid(
            src,
            field("qd0"),
            fmt(&task.qd0),
            format!("needs {n} values, one per joint of the {n}-link robot (or none: at rest)"),
        ));
    }
    for (name, v) in [("q0", &task.q0), ("qd0", &qd0)] {
        if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(Error::invalid(
                src,
                field(&format!("{name}[{i}]")),
                x,
                "must be finite",
            ));
        }
    }
    if let Some((i, x)) = task.target.iter().enumerate().find(|(_, x)| !x.is_finite()) {
        return Err(Error::invalid(
            src,
            field(&format!("target[{i}]")),
            x,
            "must be finite",
        ));
    }
    let b = &settings.bounds;
    check_bounds_within_robot(robot, b, src)?;
    if task.q0[0] < b.q1[0] || task.q0[0] > b.q1[1] {
        return Err(Error::invalid(
            src,
            field("q0[0]"),
            task.q0[0],
            format!(
                "the start pose must lie inside planner.bounds.q1 = [{}, {}] rad",
                b.q1[0], b.q1[1]
            ),
        ));
    }
    for i in 1..n {
        if task.q0[i].abs() > b.q_rel_max {
            return Err(Error::invalid(
                src,
                field(&format!("q0[{i}]")),
                task.q0[i],
                format!(
                    "the start pose must lie inside planner.bounds.q_rel_max = {} rad",
                    b.q_rel_max
                ),
            ));
        }
    }
    for (i, v) in qd0.iter().enumerate() {
        if v.abs() > b.qd_max {
            return Err(Error::invalid(
                src,
                field(&format!("qd0[{i}]")),
                v,
                format!(
                    "the start velocity must lie inside planner.bounds.qd_max = {} rad/s",
                    b.qd_max
                ),
            ));
        }
    }
    let dist = task.target[0].hypot(task.target[1]);
    if dist > robot.reach() - 1e-6 {
        return Err(Error::invalid(
            src,
            field("target"),
            fmt(&task.target),
            format!(
                "is {dist:.3} m from the grip; the robot reaches at most {:.3} m",
                robot.reach()
            ),
        ));
    }
    if task.obstacles.len() > MAX_OBSTACLES {
        return Err(Error::invalid(
            src,
            field("obstacles"),
            format!("{} obstacles", task.obstacles.len()),
            format!("at most {MAX_OBSTACLES}"),
        ));
    }
    for (i, o) in task.obstacles.iter().enumerate() {
        o.validate(src, &field(&format!("obstacles[{i}]")))?;
        if o.center.iter().any(|c| c.abs() > 1e3) || o.radius > 1e3 {
            return Err(Error::invalid(
                src,
                field(&format!("obstacles[{i}]")),
                format!("center {:?}, radius {}", o.center, o.radius),
                "must lie within 1000 m of the grip",
            ));
        }
    }
    if settings.avoid_obstacles && !task.obstacles.is_empty() {
        let cf = ClearanceFn::new(robot.clone(), task.obstacles.as_slice(), 0.0)?
            .with_self_collision(false);
        let c = cf.min_clearance(&task.q0);
        if c < 0.0 {
            return Err(Error::invalid(
                src,
                field("q0"),
                fmt(&task.q0),
                format!("the start pose overlaps an obstacle (surface distance {c:.4} m)"),
            ));
        }
        for (i, o) in task.obstacles.iter().enumerate() {
            let d = (task.target[0] - o.center[0]).hypot(task.target[1] - o.center[1]);
            if d < o.radius {
                return Err(Error::invalid(
                    src,
                    field("target"),
                    fmt(&task.target),
                    format!("lies inside {}", field(&format!("obstacles[{i}]"))),
                ));
            }
        }
        check_grasp(robot, task, settings, src, prefix)?;
    }
    Ok(qd0)
}

/// Refuse a task whose obstacles block every pose that grasps the target bar
/// ([`super::grasp::grasp_blocked`]): no swing can end there with the margin kept.
fn check_grasp(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    src: &str,
    prefix: &str,
) -> Result<()> {
    let margin = settings.obstacle_margin;
    let bounds = &settings.bounds;
    let q1 = bounds.q1;
    let Some(b) = super::grasp::grasp_blocked(robot, task.target, &task.obstacles, margin, bounds)
    else {
        return Ok(());
    };
    let n = robot.n();
    let o = &task.obstacles[b.nearest];
    let others: Vec<String> = b
        .obstacles
        .iter()
        .filter(|&&k| k != b.nearest)
        .map(|k| format!("{prefix}obstacles[{k}]"))
        .collect();
    let together = if others.is_empty() {
        String::new()
    } else {
        format!(" (together with {})", others.join(", "))
    };
    let at_bar = if b.link == n - 1 {
        format!(
            "the last link (link {n}, capsule radius {} m) ends at the bar, and ",
            robot.radii()[n - 1]
        )
    } else {
        String::new()
    };
    // the proof splits a box only until its bound falls below the margin, so a best bound within
    // 0.1 mm of the margin says no more than "below the margin"
    let best = if margin - b.best_clearance_m > 1e-4 {
        format!("which keeps at most {:.5} m", b.best_clearance_m)
    } else {
        "which keeps less than that".to_string()
    };
    Err(Error::invalid(
        src,
        format!("{prefix}obstacles[{}]", b.nearest),
        format!("center {:?}, radius {}", o.center, o.radius),
        format!(
            "its surface is {:.4} m from the target bar {:?}, and no pose that grasps the bar \
             clears it{together}: {at_bar}every pose that grasps the bar with link 1 inside \
             planner.bounds.q1 = [{}, {}] rad and every relative joint within \
             planner.bounds.q_rel_max = {} rad brings a link closer to the obstacles than \
             planner.obstacle_margin = {} m (link {} near {prefix}obstacles[{}] in the best of \
             them, {best}); move the obstacles or the bar",
            b.bar_distance_m,
            task.target,
            q1[0],
            q1[1],
            bounds.q_rel_max,
            margin,
            b.link + 1,
            b.link_obstacle,
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_valid_task_fills_qd0_and_its_derivations_stay_valid() {
        let robot = Robot::paper();
        let s = ValidSettings::new(PlannerSettings::default(), robot.n, "s.toml").unwrap();
        let task = SwingTask {
            obstacles: vec![Circle::PAPER],
            ..SwingTask::paper()
        };
        let v = ValidTask::new(&robot, task.clone(), &s, "s.toml", "task.").unwrap();
        assert_eq!((v.task(), v.qd0()), (&task, &[0.0; 4][..]));
        let free = v.without_obstacles();
        assert!(free.obstacles.is_empty() && free.qd0() == v.qd0());
        for k in [0.25, 0.5, 1.0] {
            let t = v.with_obstacles_scaled(k);
            assert_eq!(t.obstacles[0].radius, k * task.obstacles[0].radius);
            validate_task(&robot, &t, &s, "s.toml", "").unwrap();
        }
        validate_task(&robot, &free, &s, "s.toml", "").unwrap();
        // refused as validate_task refuses, with its message
        let far = SwingTask {
            target: [5.0, 0.0],
            ..SwingTask::paper()
        };
        let want = validate_task(&robot, &far, &s, "s.toml", "task.")
            .unwrap_err()
            .to_string();
        let got = ValidTask::new(&robot, far, &s, "s.toml", "task.")
            .unwrap_err()
            .to_string();
        assert_eq!(got, want);
        assert!(got.contains("task.target"), "{got}");
    }

    /// `SwingTask::paper()` is the task of `scenarios/tracking.toml` (the file a user runs).
    #[test]
    fn the_paper_task_is_the_tracking_scenarios_task() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenarios/tracking.toml");
        let text = std::fs::read_to_string(path).expect("scenarios/tracking.toml in the workspace");
        let doc: toml::Value = toml::from_str(&text).expect("the scenario parses");
        let task = &doc["task"];
        let floats = |v: &toml::Value| -> Vec<f64> {
            v.as_array()
                .expect("an array")
                .iter()
                .map(|x| x.as_float().expect("a float"))
                .collect()
        };
        let paper = SwingTask::paper();
        assert_eq!(floats(&task["q0"]), paper.q0);
        assert_eq!(floats(&task["target"]), paper.target.to_vec());
        assert!(floats(&task["qd0"]).iter().all(|v| *v == 0.0));
        assert!(paper.qd0.is_empty() && paper.obstacles.is_empty());
        let robot = Robot::paper();
        let qd0 = validate_task(&robot, &paper, &PlannerSettings::default(), "paper", "").unwrap();
        assert_eq!(qd0, vec![0.0; 4]);
    }
}
