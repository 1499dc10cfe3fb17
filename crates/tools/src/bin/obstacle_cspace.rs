//! Kinematic feasibility of the scan's placements (docs/planner.md, "Why the five placements fail"):
//! breadth-first search on a joint-space grid (q1 in [-pi, 0], the relative joints in
//! [-q_rel_max, q_rel_max], step `--step` rad, default 0.1) for a path of collision-free cells (every
//! link clear of the obstacle and of the non-adjacent links, margin 0) from the start pose's cell to a
//! cell whose EE is within `--tol` m (default 0.06) of the bar. A grid search, so a necessary-condition
//! indicator, not a proof. Time and torque limits are ignored.
//! `cargo run --release -p brachia-tools --bin obstacle_cspace [-- --only 4,7]`. Units: m, rad.
use brachia::model::{Circle, ClearanceFn, Robot};
use brachia::planning::strategy::obstacles::path_placements;
use brachia::planning::{plan, Backend, NlpSettings, PlannerSettings, SwingTask, Transcription};
use std::collections::VecDeque;

fn arg(args: &[String], name: &str) -> Option<String> {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1).cloned())
}

/// Whether a grid path exists; the number of cells visited.
fn reachable(
    robot: &Robot,
    o: &[Circle],
    q0: &[f64],
    target: [f64; 2],
    step: f64,
    tol: f64,
    qr: f64,
) -> (bool, usize) {
    let cf = ClearanceFn::new(robot.clone(), o, 0.0)
        .unwrap()
        .with_self_collision(true);
    let n1 = (std::f64::consts::PI / step).round() as usize + 1;
    let nr = (2.0 * qr / step).round() as usize + 1;
    let dims = [n1, nr, nr, nr];
    let total = dims.iter().product::<usize>();
    let val = |d: usize, i: usize| {
        if d == 0 {
            -std::f64::consts::PI + i as f64 * step
        } else {
            -qr + i as f64 * step
        }
    };
    let idx = |c: [usize; 4]| ((c[0] * nr + c[1]) * nr + c[2]) * nr + c[3];
    let mut seen = vec![false; total];
    let start = [0, 1, 2, 3].map(|d| {
        let lo = if d == 0 { -std::f64::consts::PI } else { -qr };
        (((q0[d] - lo) / step).round() as usize).min(dims[d] - 1)
    });
    let mut queue = VecDeque::new();
    seen[idx(start)] = true;
    queue.push_back(start);
    let mut visited = 0;
    let mut q = [0.0; 4];
    while let Some(c) = queue.pop_front() {
        visited += 1;
        for d in 0..4 {
            q[d] = val(d, c[d]);
        }
        let ee = robot.ee_position(&q);
        if (ee[0] - target[0]).hypot(ee[1] - target[1]) <= tol {
            return (true, visited);
        }
        for d in 0..4 {
            for up in [false, true] {
                let mut nb = c;
                if up {
                    if c[d] + 1 >= dims[d] {
                        continue;
                    }
                    nb[d] += 1;
                } else {
                    if c[d] == 0 {
                        continue;
                    }
                    nb[d] -= 1;
                }
                let k = idx(nb);
                if seen[k] {
                    continue;
                }
                seen[k] = true;
                let mut qn = [0.0; 4];
                for e in 0..4 {
                    qn[e] = val(e, nb[e]);
                }
                if cf.min_clearance(&qn) >= 0.0 {
                    queue.push_back(nb);
                }
            }
        }
    }
    (false, visited)
}

fn main() -> Result<(), brachia::Error> {
    let args: Vec<String> = std::env::args().collect();
    let step: f64 = arg(&args, "--step")
        .map(|v| v.parse().unwrap())
        .unwrap_or(0.1);
    let tol: f64 = arg(&args, "--tol")
        .map(|v| v.parse().unwrap())
        .unwrap_or(0.06);
    let only: Vec<usize> = arg(&args, "--only")
        .map(|v| v.split(',').filter_map(|x| x.parse().ok()).collect())
        .unwrap_or_default();
    let robot = Robot::paper();
    let task = SwingTask::paper();
    let ms = PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt: 0.01,
        ..Default::default()
    };
    let ocp = NlpSettings {
        backend: Backend::Ocp,
        ..Default::default()
    };
    let base = plan(&robot, &task, &ms, &ocp)?;
    let places = path_placements(&robot, &base.points, task.target, 0.08, 0.01, 8)?;
    let (free, v) = reachable(
        &robot,
        &[],
        &task.q0,
        task.target,
        step,
        tol,
        ms.bounds.q_rel_max,
    );
    println!("no obstacle: path {free} ({v} cells)");
    for (i, pl) in places.iter().enumerate() {
        if !only.is_empty() && !only.contains(&(i + 1)) {
            continue;
        }
        let (ok, v) = reachable(
            &robot,
            &[pl.obstacle],
            &task.q0,
            task.target,
            step,
            tol,
            ms.bounds.q_rel_max,
        );
        println!(
            "#{} link {} t {:.3}: path {ok} ({v} cells)",
            i + 1,
            pl.link + 1,
            pl.time_s
        );
    }
    Ok(())
}
