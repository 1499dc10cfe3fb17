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
use brachia_rapier::{ContactBody, ContactEvent, Obstacle};
use serde_json::{json, Value};

/// Version of the embedded data's layout.
pub const VIEW_SCHEMA: u32 = 1;

/// Drawing interval, s: the page shows one sample per 10 ms (more for runs longer than
/// [`MAX_DRAW_SAMPLES`] samples at that rate).
pub const DRAW_DT_S: f64 = 0.01;

/// Most samples a page embeds; a longer run is drawn at a coarser interval.
pub const MAX_DRAW_SAMPLES: usize = 6000;

/// Most rows of a run whose every row the page embeds for the plots' tooltips (`full`); a longer run's
/// tooltips show the drawn samples.
pub const MAX_FULL_ROWS: usize = 6000;

/// Add to `data` the plotted series of the rows `idx` (`series` makes them, times `t` among them)
/// and, for a run of at most [`MAX_FULL_ROWS`] rows, the same at every row under `full`, for the
/// plots' tooltips.
pub(super) fn with_full(
    data: &mut Value,
    rows: usize,
    idx: &[usize],
    series: &dyn Fn(&[usize]) -> serde_json::Map<String, Value>,
) {
    let Value::Object(m) = data else { return };
    m.extend(series(idx));
    if rows <= MAX_FULL_ROWS && idx.len() < rows {
        let all: Vec<usize> = (0..rows).collect();
        m.insert("full".into(), Value::Object(series(&all)));
    }
}

/// A contact of the plant's log as the page lists it (links and obstacles named, links from 1).
pub(super) fn contact_json(c: &ContactEvent) -> Value {
    let body = match c.body {
        ContactBody::Obstacle(i) => format!("obstacle {i}"),
        ContactBody::Link(j) => format!("link {}", j + 1),
    };
    json!({ "t": r(c.t), "link": c.link + 1, "body": body, "impulse": r(c.impulse) })
}

/// `x` rounded to 1e-5 (what a page can show), so the embedded JSON stays small.
pub(super) fn r(x: f64) -> f64 {
    (x * 1e5).round() / 1e5
}

pub(super) fn rv(v: &[f64]) -> Vec<f64> {
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
pub(super) fn row(v: &[f64], w: usize, k: usize) -> &[f64] {
    &v[k * w..(k + 1) * w]
}

/// Energy of eq. 18 accumulated over the samples: `sum tau_k . (q_{k+1} - q_k)` over the actuated
/// joints (the torque held over each interval), J, with the positive work beside it.
pub(super) fn energy(q: &[f64], tau: &[f64], n: usize, rows: usize) -> (Vec<f64>, Vec<f64>) {
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
pub(super) fn robot_json(robot: &Robot) -> Value {
    json!({
        "n": robot.n(),
        "lengths": rv(robot.lengths()),
        "radii": rv(robot.radii()),
        "tau_min": rv(robot.tau_min()),
        "tau_max": rv(robot.tau_max()),
    })
}

pub(super) fn circle(x: [f64; 2], radius: f64, kind: &str) -> Value {
    json!({ "x": r(x[0]), "y": r(x[1]), "r": r(radius), "kind": kind })
}

/// Columns `cols` of the rows `idx` of a row-major matrix of width `w`, rounded.
pub(super) fn pick(
    v: &[f64],
    w: usize,
    idx: &[usize],
    cols: std::ops::Range<usize>,
) -> Vec<Vec<f64>> {
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
    /// The plan's robot (geometry and limits); `None` when the folder holds no plan: the link lengths
    /// are then found from the log's hand positions ([`lengths_from_log`]) and the page says so.
    pub robot: Option<&'a Robot>,
}

/// Capsule radius of a link drawn without the robot's parameters, m.
pub const DEFAULT_RADIUS_M: f64 = 0.02;

/// The link lengths that put the hand where the log recorded it: the least-squares solution of
/// `ee_k = sum_i l_i (cos th_i, sin th_i)` (`th_i = q_1 + ... + q_i`, grip frame) over every row; exact
/// up to the file's rounding for a log of a chain hanging from the grip. `None` when the rows do not
/// determine them (a chain that never bends, fewer rows than links).
pub fn lengths_from_log(log: &ClosedLoopLog) -> Option<Vec<f64>> {
    let n = log.n;
    // normal equations A^T A l = A^T b, n x n
    let (mut m, mut rhs) = (vec![0.0; n * n], vec![0.0; n]);
    for k in 0..log.t.len() {
        let q = &row(&log.x, 2 * n, k)[..n];
        let mut th = 0.0;
        let dirs: Vec<[f64; 2]> = q
            .iter()
            .map(|qi| {
                th += qi;
                [th.cos(), th.sin()]
            })
            .collect();
        for i in 0..n {
            for j in 0..n {
                m[i * n + j] += dirs[i][0] * dirs[j][0] + dirs[i][1] * dirs[j][1];
            }
            rhs[i] += dirs[i][0] * log.ee[k][0] + dirs[i][1] * log.ee[k][1];
        }
    }
    // Gaussian elimination with partial pivoting
    for c in 0..n {
        let p = (c..n).max_by(|&a, &b| m[a * n + c].abs().total_cmp(&m[b * n + c].abs()))?;
        if m[p * n + c].abs() < 1e-9 * (1.0 + m[c * n + c].abs()) {
            return None;
        }
        for j in 0..n {
            m.swap(c * n + j, p * n + j);
        }
        rhs.swap(c, p);
        for r2 in c + 1..n {
            let f = m[r2 * n + c] / m[c * n + c];
            for j in c..n {
                m[r2 * n + j] -= f * m[c * n + j];
            }
            rhs[r2] -= f * rhs[c];
        }
    }
    let mut l = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|j| m[i * n + j] * l[j]).sum();
        l[i] = (rhs[i] - s) / m[i * n + i];
    }
    l.iter().all(|x| x.is_finite() && *x > 0.0).then_some(l)
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
    let mut data = json!({
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
    });
    let series = |idx: &[usize]| {
        let m = json!({
            "t": idx.iter().map(|&k| r(tr.t[k])).collect::<Vec<_>>(),
            "q": pick(&tr.q, n, idx, 0..n),
            "qd": pick(&tr.qd, n, idx, 0..n),
            "tau": pick(&tr.tau, n - 1, idx, 0..n - 1),
            "energy": idx.iter().map(|&k| r(e[k])).collect::<Vec<_>>(),
            "work": idx.iter().map(|&k| r(w[k])).collect::<Vec<_>>(),
        });
        m.as_object().cloned().unwrap_or_default()
    };
    with_full(&mut data, tr.len(), &idx, &series);
    data
}

/// The page data of a track run: the tracked swing, the plan it followed as a ghost, the EE error,
/// contacts, moving obstacles and re-plans.
pub fn track_view(f: TrackParts<'_>) -> Value {
    let log = f.log;
    let n = log.n;
    let mut notes: Vec<String> = Vec::new();
    let robot = match f.robot {
        Some(robot) => robot_json(robot),
        None => {
            let lengths = lengths_from_log(log).unwrap_or_else(|| vec![0.3; n]);
            notes.push(format!(
                "This run's folder holds no plan (plan/): the links are drawn with the lengths that \
                 put the hand where closed_loop.csv recorded it ({} m), {DEFAULT_RADIUS_M} m thick, \
                 without torque limits or the obstacles the plan avoided; the ghost is the reference \
                 closed_loop.csv holds.",
                lengths.iter().map(|l| format!("{l:.4}")).collect::<Vec<_>>().join(", ")
            ));
            json!({ "n": n, "lengths": rv(&lengths), "radii": vec![DEFAULT_RADIUS_M; n],
                    "tau_min": [], "tau_max": [] })
        }
    };
    let rows = log.t.len();
    let idx = draw_indices(&log.t);
    let q: Vec<f64> = (0..rows)
        .flat_map(|k| row(&log.x, 2 * n, k)[..n].to_vec())
        .collect();
    let (e, w) = energy(&q, &log.tau, n, rows);
    let ee_err = |idx: &[usize]| -> Vec<f64> {
        idx.iter()
            .map(|&k| {
                let (a, b) = (log.ee[k], log.ref_ee[k]);
                r(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt())
            })
            .collect()
    };
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
    let contacts: Vec<Value> = f.world.contacts.iter().map(contact_json).collect();
    let replans: Vec<Value> = f
        .report
        .replans
        .iter()
        .map(|e| json!({ "t": r(e.t_trigger_s), "switch": e.t_switch_s.map(r), "adopted": e.adopted }))
        .collect();
    // the controller's step times (closed_loop.csv holds them from schema 2 on)
    let control_us = |idx: &[usize]| {
        (log.control_us.len() == rows).then(|| {
            idx.iter()
                .map(|&k| r(log.control_us[k]))
                .collect::<Vec<_>>()
        })
    };
    let s = &f.report.summary;
    let mut data = json!({
        "schema": VIEW_SCHEMA,
        "kind": "track",
        "title": f.report.scenario,
        "subtitle": format!(
            "{} on the {} plant: EE final error {:.2e} m (max {:.2e} m), energy {:.3} J",
            f.report.controller, f.report.plant, s.ee_final_error_m, s.ee_error_max_m, s.energy_j
        ),
        "notes": notes,
        "robot": robot,
        "grip": [0.0, 0.0],
        "target": rv(&f.report.target),
        "obstacles": obstacles,
        "obstacle_track": obstacle_track,
        "ghost": pick(&log.ref_x, 2 * n, &idx, 0..n),
        "contacts": contacts,
        "replans": replans,
        "diverged_at": log.diverged_at_s.map(r),
    });
    let series = |idx: &[usize]| {
        let m = json!({
            "t": idx.iter().map(|&k| r(log.t[k])).collect::<Vec<_>>(),
            "q": pick(&log.x, 2 * n, idx, 0..n),
            "qd": pick(&log.x, 2 * n, idx, n..2 * n),
            "tau": pick(&log.tau, n - 1, idx, 0..n - 1),
            "ee_error": ee_err(idx),
            "energy": idx.iter().map(|&k| r(e[k])).collect::<Vec<_>>(),
            "work": idx.iter().map(|&k| r(w[k])).collect::<Vec<_>>(),
            "control_us": control_us(idx),
        });
        m.as_object().cloned().unwrap_or_default()
    };
    with_full(&mut data, rows, &idx, &series);
    data
}

/// Text safe inside HTML element content.
pub fn html_escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('{', "&#123;")
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
    fn link_lengths_come_back_from_the_hand_positions() {
        let lengths = [0.355, 0.3, 0.25];
        let mut log = ClosedLoopLog {
            n: 3,
            ..ClosedLoopLog::default()
        };
        for k in 0..50 {
            let s = k as f64 * 0.1;
            let q = [-1.2 + 0.3 * s.sin(), 0.4 * s.cos(), -0.2 + 0.5 * s];
            let (mut th, mut ee) = (0.0, [0.0, 0.0]);
            for (qi, l) in q.iter().zip(lengths) {
                th += qi;
                ee[0] += l * th.cos();
                ee[1] += l * th.sin();
            }
            log.t.push(k as f64 * 1e-3);
            log.x.extend(q.iter().chain([0.0; 3].iter()));
            log.ee.push(ee);
        }
        let l = lengths_from_log(&log).unwrap();
        for (a, b) in l.iter().zip(lengths) {
            assert!((a - b).abs() < 1e-9, "{l:?}");
        }
        // a chain that never bends does not tell its lengths apart
        let mut straight = log.clone();
        for k in 0..50 {
            straight.x[6 * k + 1] = 0.0;
            straight.x[6 * k + 2] = 0.0;
        }
        assert!(lengths_from_log(&straight).is_none());
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
