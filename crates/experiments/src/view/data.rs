//! The data a run's page draws, gathered from a plan or track folder and decimated for drawing.
//!
//! One JSON object (the schema the page's script reads, [`VIEW_SCHEMA`]): SI units throughout (s, m,
//! rad, rad/s, N m, J); every series is sampled at the same times `t` (the run's samples closest to a
//! grid of [`DRAW_DT_S`], the first and last sample always kept); numbers are rounded to what a screen
//! can show (1e-5 of the unit).

use crate::plan_run::PlanReport;
use crate::track_run::{PlantWorld, TrackReport};
use brachia::model::Circle;
use brachia::planning::SwingTask;
use brachia::sim::ClosedLoopLog;
use brachia::trajectory::Trajectory;
use brachia::Robot;
use brachia_rapier::{ContactBody, Obstacle};
use serde_json::{json, Value};

/// Version of the embedded data's layout.
pub const VIEW_SCHEMA: u32 = 1;

/// Drawing interval, s: the page shows one sample per 10 ms (more for runs longer than
/// [`MAX_DRAW_SAMPLES`] samples at that rate).
pub const DRAW_DT_S: f64 = 0.01;

/// Most samples a page embeds; a longer run is drawn at a coarser interval.
pub const MAX_DRAW_SAMPLES: usize = 6000;

/// `x` rounded to 1e-5 (what a page can show), so the embedded JSON stays small.
fn r(x: f64) -> f64 {
    (x * 1e5).round() / 1e5
}

fn rv(v: &[f64]) -> Vec<f64> {
    v.iter().copied().map(r).collect()
}

/// Indices of the samples of `t` kept for drawing: the first sample at or after each multiple of the
/// drawing interval, and the last sample.
pub fn draw_indices(t: &[f64]) -> Vec<usize> {
    let Some(&last) = t.last() else {
        return Vec::new();
    };
    let span = last - t[0];
    let dt = DRAW_DT_S.max(span / MAX_DRAW_SAMPLES as f64);
    let mut out = Vec::new();
    let mut next = t[0];
    for (i, &ti) in t.iter().enumerate() {
        if ti >= next - 1e-9 {
            out.push(i);
            next = t[0] + dt * ((ti - t[0]) / dt + 1e-6).floor() + dt;
        }
    }
    if out.last() != Some(&(t.len() - 1)) {
        out.push(t.len() - 1);
    }
    out
}

/// Row `k` of a row-major matrix of width `w`.
fn row(v: &[f64], w: usize, k: usize) -> &[f64] {
    &v[k * w..(k + 1) * w]
}

/// Energy of eq. 18 accumulated over the samples: `sum tau_k . (q_{k+1} - q_k)` over the actuated
/// joints (the torque held over each interval), J, with the positive work beside it.
fn energy(q: &[f64], tau: &[f64], n: usize, rows: usize) -> (Vec<f64>, Vec<f64>) {
    let (mut e, mut w) = (vec![0.0; rows], vec![0.0; rows]);
    for k in 1..rows {
        let (q0, q1, u) = (row(q, n, k - 1), row(q, n, k), row(tau, n - 1, k - 1));
        let p: Vec<f64> = (1..n).map(|j| u[j - 1] * (q1[j] - q0[j])).collect();
        e[k] = e[k - 1] + p.iter().sum::<f64>();
        w[k] = w[k - 1] + p.iter().map(|x| x.max(0.0)).sum::<f64>();
    }
    (e, w)
}

/// The robot's geometry and limits.
fn robot_json(robot: &Robot) -> Value {
    json!({
        "n": robot.n(),
        "lengths": rv(robot.lengths()),
        "radii": rv(robot.radii()),
        "tau_min": rv(robot.tau_min()),
        "tau_max": rv(robot.tau_max()),
    })
}

fn circle(x: [f64; 2], radius: f64, kind: &str) -> Value {
    json!({ "x": r(x[0]), "y": r(x[1]), "r": r(radius), "kind": kind })
}

/// Columns `cols` of the rows `idx` of a row-major matrix of width `w`, rounded.
fn pick(v: &[f64], w: usize, idx: &[usize], cols: std::ops::Range<usize>) -> Vec<Vec<f64>> {
    idx.iter()
        .map(|&k| rv(&row(v, w, k)[cols.clone()]))
        .collect()
}

/// What a plan's page draws: the scenario's name, its report, task and robot and the 1 ms plan.
#[derive(Debug, Clone, Copy)]
pub struct PlanParts<'a> {
    /// The scenario's name.
    pub name: &'a str,
    /// The plan's report.
    pub report: &'a PlanReport,
    /// The swing task (target bar and obstacles, grip frame).
    pub task: &'a SwingTask,
    /// The robot.
    pub robot: &'a Robot,
    /// The planned swing.
    pub trajectory: &'a Trajectory,
}

/// What a track run's page draws.
#[derive(Debug, Clone, Copy)]
pub struct TrackParts<'a> {
    /// The run's report.
    pub report: &'a TrackReport,
    /// The closed-loop log.
    pub log: &'a ClosedLoopLog,
    /// The plant's obstacles, contacts and obstacle track.
    pub world: &'a PlantWorld,
    /// The obstacles the plan avoided (grip frame).
    pub planned_obstacles: &'a [Circle],
    /// The plan's robot (geometry and limits).
    pub robot: &'a Robot,
}

/// The page data of a plan: the planned swing (no ghost, no tracking error).
pub fn plan_view(p: PlanParts<'_>) -> Value {
    let (robot, task, tr) = (p.robot, p.task, p.trajectory);
    let n = tr.n;
    let idx = draw_indices(&tr.t);
    let (e, w) = energy(&tr.q, &tr.tau, n, tr.len());
    let obstacles: Vec<Value> = task
        .obstacles
        .iter()
        .map(|c| circle(c.center, c.radius, "planned"))
        .collect();
    json!({
        "schema": VIEW_SCHEMA,
        "kind": "plan",
        "title": p.name,
        "subtitle": format!(
            "plan: {:?}, energy {:.3} J, swing {:.3} s, EE final error {:.2e} m",
            p.report.status, p.report.energy_j, p.report.swing_time_s, p.report.ee_final_error_m
        ),
        "robot": robot_json(robot),
        "grip": [0.0, 0.0],
        "target": rv(&task.target),
        "obstacles": obstacles,
        "t": idx.iter().map(|&k| r(tr.t[k])).collect::<Vec<_>>(),
        "q": pick(&tr.q, n, &idx, 0..n),
        "qd": pick(&tr.qd, n, &idx, 0..n),
        "tau": pick(&tr.tau, n - 1, &idx, 0..n - 1),
        "energy": idx.iter().map(|&k| r(e[k])).collect::<Vec<_>>(),
        "work": idx.iter().map(|&k| r(w[k])).collect::<Vec<_>>(),
    })
}

/// The page data of a track run: the tracked swing, the plan it followed as a ghost, the EE error,
/// contacts, moving obstacles and re-plans.
pub fn track_view(f: TrackParts<'_>) -> Value {
    let (log, robot) = (f.log, f.robot);
    let n = log.n;
    let rows = log.t.len();
    let idx = draw_indices(&log.t);
    let q: Vec<f64> = (0..rows)
        .flat_map(|k| row(&log.x, 2 * n, k)[..n].to_vec())
        .collect();
    let (e, w) = energy(&q, &log.tau, n, rows);
    let ee_err: Vec<f64> = idx
        .iter()
        .map(|&k| {
            let (a, b) = (log.ee[k], log.ref_ee[k]);
            r(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt())
        })
        .collect();
    let mut obstacles: Vec<Value> = Vec::new();
    for c in f.planned_obstacles {
        obstacles.push(circle(c.center, c.radius, "planned"));
    }
    for o in &f.world.obstacles {
        let (c, radius) = o.shape();
        let kind = match o {
            Obstacle::Ball(_) => "ball",
            Obstacle::Circle(_) => "plant",
        };
        obstacles.push(circle(c, radius, kind));
    }
    let track = &f.world.track;
    let tt: Vec<f64> = track.iter().map(|row| row[0]).collect();
    let obstacle_track: Vec<Vec<f64>> = draw_indices(&tt).iter().map(|&k| rv(&track[k])).collect();
    let contacts: Vec<Value> = f
        .world
        .contacts
        .iter()
        .map(|c| {
            let body = match c.body {
                ContactBody::Obstacle(i) => format!("obstacle {i}"),
                ContactBody::Link(j) => format!("link {}", j + 1),
            };
            json!({ "t": r(c.t), "link": c.link + 1, "body": body, "impulse": r(c.impulse) })
        })
        .collect();
    let replans: Vec<Value> = f
        .report
        .replans
        .iter()
        .map(|e| json!({ "t": r(e.t_trigger_s), "switch": e.t_switch_s.map(r), "adopted": e.adopted }))
        .collect();
    // the controller's step times are in the run's memory, not in closed_loop.csv
    let control_us = (log.control_us.len() == rows).then(|| {
        idx.iter()
            .map(|&k| r(log.control_us[k]))
            .collect::<Vec<_>>()
    });
    let s = &f.report.summary;
    json!({
        "schema": VIEW_SCHEMA,
        "kind": "track",
        "title": f.report.scenario,
        "subtitle": format!(
            "{} on the {} plant: EE final error {:.2e} m (max {:.2e} m), energy {:.3} J",
            f.report.controller, f.report.plant, s.ee_final_error_m, s.ee_error_max_m, s.energy_j
        ),
        "robot": robot_json(robot),
        "grip": [0.0, 0.0],
        "target": rv(&f.report.target),
        "obstacles": obstacles,
        "obstacle_track": obstacle_track,
        "t": idx.iter().map(|&k| r(log.t[k])).collect::<Vec<_>>(),
        "q": pick(&log.x, 2 * n, &idx, 0..n),
        "qd": pick(&log.x, 2 * n, &idx, n..2 * n),
        "tau": pick(&log.tau, n - 1, &idx, 0..n - 1),
        "ghost": pick(&log.ref_x, 2 * n, &idx, 0..n),
        "ee_error": ee_err,
        "energy": idx.iter().map(|&k| r(e[k])).collect::<Vec<_>>(),
        "work": idx.iter().map(|&k| r(w[k])).collect::<Vec<_>>(),
        "control_us": control_us,
        "contacts": contacts,
        "replans": replans,
        "diverged_at": log.diverged_at_s.map(r),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draw_indices_keep_first_last_and_one_per_interval() {
        let t: Vec<f64> = (0..=1234).map(|k| k as f64 * 1e-3).collect();
        let idx = draw_indices(&t);
        assert_eq!(idx[0], 0);
        assert_eq!(*idx.last().unwrap(), 1234);
        // 0, 10, 20, ..., 1230 and the last
        assert_eq!(idx.len(), 125);
        for w in idx.windows(2) {
            let gap = t[w[1]] - t[w[0]];
            assert!(gap <= DRAW_DT_S + 1e-9 && gap > 0.0, "gap {gap}");
        }
    }

    #[test]
    fn energy_sums_held_torque_times_joint_motion() {
        // two links, joint 2 turns 0.1 rad per step under 2 N m then -1 N m
        let q = vec![0.0, 0.0, 0.0, 0.1, 0.0, 0.2];
        let tau = vec![2.0, -1.0, 0.0];
        let (e, w) = energy(&q, &tau, 2, 3);
        assert!((e[2] - (0.2 - 0.1)).abs() < 1e-12);
        assert!((w[2] - 0.2).abs() < 1e-12);
    }
}
