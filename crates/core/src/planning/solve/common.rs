//! What the solves of both transcriptions share: the swing time, the variable bounds, the target
//! pose, the initial guesses, the clearance rows and the solve with its barrier retry.
//!
//! Units: s, m, rad, rad/s, N m. Angles as in the crate docs (q1 absolute from +x, the rest relative).

use crate::error::{Error, Result};
use crate::model::{ik_from_seed, mirrored_pose, wrap_angle, Circle, ClearanceFn, Robot};
use crate::planning::nlp::{solve, MuStrategy, NlpSettings, NlpSolution, SolveStatus, SparseNlp};
use crate::planning::outcome::SolveAttempt;
use crate::planning::settings::{PlannerSettings, SwingTime};
use crate::planning::task::SwingTask;
use crate::planning::transcription::collocation::Layout;
use crate::trajectory::Trajectory;
use std::sync::Arc;

/// RK4 step of [`freefall_time`], s (global error ~1e-11 s on the paper's robot; the crossing itself
/// is searched within the step, not interpolated).
const FREEFALL_DT: f64 = 1e-3;

/// Time for the robot, released at rest from `q0` with every joint locked (one rigid compound pendulum
/// about the grip), until its EE first reaches the x coordinate `x_mid`. Errors when it never does within
/// 20 s. The answers for the last few inputs are remembered for the process (the same number
/// again, without the integration).
pub fn freefall_time(robot: &Robot, q0: &[f64], x_mid: f64) -> Result<f64> {
    super::freefall_cache::remembered(robot, q0, x_mid, || {
        freefall_time_with_step(robot, q0, x_mid, FREEFALL_DT)
    })
}

/// [`freefall_time`] with RK4 steps of `dt` (s, > 0).
fn freefall_time_with_step(robot: &Robot, q0: &[f64], x_mid: f64, dt: f64) -> Result<f64> {
    let n = robot.n;
    if robot.gravity <= 0.0 {
        return Err(Error::invalid(
            "planner",
            "swing_time",
            "\"auto\"",
            format!(
                "needs gravity > 0 (the robot's gravity is {} m/s^2); give swing_time in seconds",
                robot.gravity
            ),
        ));
    }
    let m11 = robot.mass_matrix(q0)[0]; // inertia of the locked chain about the grip
    let mut ws = crate::model::Scratch::new(n);
    let mut g = vec![0.0; n];
    let mut q = q0.to_vec();
    let side = (robot.ee_position(&q)[0] - x_mid).signum();
    if side == 0.0 {
        return Ok(0.0);
    }
    // RK4 on (th, w) in steps of FREEFALL_DT; the step that crosses is then searched for the
    // crossing time tau in (0, dt] by regula falsi (Illinois) on one RK4 step of length tau from
    // the step's start, so the crossing is as accurate as the integration (no interpolation).
    let mut k: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; 2]);
    let mut tmp = [0.0; 2];
    let mut step = |th: f64, w: f64, dt: f64| {
        let mut x = [th, w];
        crate::integrate::rk4_step(&mut x, dt, &mut k, &mut tmp, |_, x, out| {
            out[0] = x[1];
            out[1] = locked_chain_acceleration(robot, m11, x[0], &mut q, &mut ws, &mut g);
        });
        (x[0], x[1])
    };
    let mut qx = q0.to_vec();
    let mut dist = |th: f64| {
        qx[0] = th;
        robot.ee_position(&qx)[0] - x_mid
    };
    let (mut t, mut th, mut w) = (0.0, q0[0], 0.0);
    let mut prev = dist(th);
    while t < 20.0 {
        let (th1, w1) = step(th, w, dt);
        let d = dist(th1);
        if d.signum() != side {
            // bracket [0, dt] of the partial step: f(0) = prev (on `side`), f(dt) = d (past it)
            let (mut a, mut fa, mut b, mut fb) = (0.0, prev, dt, d);
            let mut last_side = 0;
            for _ in 0..60 {
                if b - a <= 1e-14 {
                    break;
                }
                let c = (a * fb - b * fa) / (fb - fa);
                let c = if c > a && c < b { c } else { 0.5 * (a + b) };
                let fc = dist(step(th, w, c).0);
                if fc == 0.0 {
                    return Ok(t + c);
                }
                if fc.signum() == side {
                    (a, fa) = (c, fc);
                    if last_side == 1 {
                        fb *= 0.5;
                    }
                    last_side = 1;
                } else {
                    (b, fb) = (c, fc);
                    if last_side == -1 {
                        fa *= 0.5;
                    }
                    last_side = -1;
                }
            }
            return Ok(t + 0.5 * (a + b));
        }
        (th, w, prev, t) = (th1, w1, d, t + dt);
    }
    Err(Error::InfeasibleTask(format!(
        "the robot released with locked joints never reaches x = {x_mid:.3} m within 20 s"
    )))
}

/// Angular acceleration of the chain locked at its start shape, turned to grip angle `q1` (rad/s^2):
/// gravity's torque about the grip over the locked chain's inertia `m11` (kg m^2); `q` holds the locked
/// shape and is overwritten at `q[0]`.
fn locked_chain_acceleration(
    robot: &Robot,
    m11: f64,
    q1: f64,
    q: &mut [f64],
    ws: &mut crate::model::Scratch<f64>,
    g: &mut [f64],
) -> f64 {
    q[0] = q1;
    robot.gravity_into(ws, q, g);
    -g[0] / m11
}

/// Wrap an angle to (-pi, pi].
/// Variable bounds for the layout (start state fixed, final torque zero).
pub(crate) fn variable_bounds(
    robot: &Robot,
    layout: &Layout,
    settings: &PlannerSettings,
    q0: &[f64],
    qd0: &[f64],
) -> (Vec<f64>, Vec<f64>) {
    let (n, nv) = (robot.n, layout.n_vars());
    let b = &settings.bounds;
    let (mut lo, mut hi) = (vec![0.0; nv], vec![0.0; nv]);
    for p in 0..layout.points {
        let qd = b.qd_bound(p + 1 == layout.points);
        for i in 0..n {
            let (l, h) = if i == 0 {
                (b.q1[0], b.q1[1])
            } else {
                (-b.q_rel_max, b.q_rel_max)
            };
            lo[layout.var(p, i)] = l;
            hi[layout.var(p, i)] = h;
            lo[layout.var(p, n + i)] = -qd;
            hi[layout.var(p, n + i)] = qd;
        }
        for j in 0..n - 1 {
            lo[layout.var(p, 2 * n + j)] = robot.tau_min[j];
            hi[layout.var(p, 2 * n + j)] = robot.tau_max[j];
        }
    }
    for i in 0..n {
        lo[layout.var(0, i)] = q0[i];
        hi[layout.var(0, i)] = q0[i];
        lo[layout.var(0, n + i)] = qd0[i];
        hi[layout.var(0, n + i)] = qd0[i];
    }
    let last = layout.points - 1;
    for j in 0..n - 1 {
        lo[layout.var(last, 2 * n + j)] = 0.0;
        hi[layout.var(last, 2 * n + j)] = 0.0;
    }
    (lo, hi)
}

/// Pick the target pose for the initial guess: IK seeded by the mirrored start pose and variants,
/// keeping poses inside the bounds, preferring obstacle-free ones, then the one closest to its seed.
pub(crate) fn target_pose(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
    cf: Option<&ClearanceFn>,
) -> Result<Vec<f64>> {
    let n = robot.n;
    let m = mirrored_pose(&task.q0);
    let flipped: Vec<f64> = m
        .iter()
        .enumerate()
        .map(|(i, v)| if i == 0 { *v } else { -v })
        .collect();
    let mut straight = vec![0.0; n];
    straight[0] = task.target[1].atan2(task.target[0]);
    // fallback: the chain dipping below the line to the target (a start pose that points above the
    // bar, as a re-rooted chain on a ladder may, mirrors to seeds above it)
    let mut vee = straight.clone();
    let sgn = if task.target[0] < 0.0 { 1.0 } else { -1.0 };
    vee[0] = wrap_angle(straight[0] + 0.8 * sgn);
    vee[n / 2] = -1.6 * sgn;
    let b = &settings.bounds;
    let mut best: Option<(bool, f64, Vec<f64>)> = None;
    for (i, seed) in [m, flipped, task.q0.clone(), straight, vee]
        .into_iter()
        .enumerate()
    {
        if i == 4 && best.is_some() {
            break;
        }
        let Some(q) = ik_from_seed(robot, &seed, task.target) else {
            continue;
        };
        let q: Vec<f64> = q.iter().map(|v| wrap_angle(*v)).collect();
        let inside =
            q[0] >= b.q1[0] && q[0] <= b.q1[1] && q[1..].iter().all(|v| v.abs() <= b.q_rel_max);
        if !inside {
            continue;
        }
        let free = cf.is_none_or(|c| c.min_clearance(&q) >= 0.0);
        let dist: f64 = q.iter().zip(&seed).map(|(a, s)| (a - s).powi(2)).sum();
        let better = match &best {
            None => true,
            Some((bf, bd, _)) => (free && !bf) || (free == *bf && dist < *bd),
        };
        if better {
            best = Some((free, dist, q));
        }
    }
    best.map(|b| b.2).ok_or_else(|| {
        Error::InfeasibleTask(format!(
            "no joint configuration within the bounds reaches the target ({:.3}, {:.3})",
            task.target[0], task.target[1]
        ))
    })
}

/// Check a warm-start trajectory: n links, at least two samples, finite values, strictly increasing
/// times.
pub(crate) fn check_guess(robot: &Robot, g: &Trajectory) -> Result<()> {
    let (n, src) = (robot.n, "guess");
    if g.n != n {
        return Err(Error::Dimension {
            what: "guess: links".into(),
            expected: n,
            got: g.n,
        });
    }
    let len = g.len();
    if len < 2 {
        return Err(Error::invalid(
            src,
            "t",
            format!("{len} samples"),
            "a guess needs at least 2 samples",
        ));
    }
    for (what, have, per) in [
        ("guess: q", g.q.len(), n),
        ("guess: qd", g.qd.len(), n),
        ("guess: tau", g.tau.len(), n - 1),
    ] {
        if have != len * per {
            return Err(Error::Dimension {
                what: what.into(),
                expected: len * per,
                got: have,
            });
        }
    }
    if let Some(x) =
        g.t.iter()
            .chain(&g.q)
            .chain(&g.qd)
            .chain(&g.tau)
            .find(|x| !x.is_finite())
    {
        return Err(Error::invalid(src, "values", x, "must be finite"));
    }
    if let Some(k) = (1..len).find(|&k| g.t[k] <= g.t[k - 1]) {
        return Err(Error::invalid(
            src,
            format!("t[{k}]"),
            g.t[k],
            "times must increase strictly",
        ));
    }
    Ok(())
}

/// Fill `x0` from a guess trajectory: its time axis is mapped linearly onto `[0, T]`, each collocation
/// point takes q, qd (scaled by `T_guess / T`) and tau interpolated linearly from it, clamped to the
/// variable bounds (so the start state and the zero final torque hold exactly).
pub(crate) fn guess_from_trajectory(
    g: &Trajectory,
    layout: &Layout,
    t_final: f64,
    bounds: &(Vec<f64>, Vec<f64>),
    x0: &mut [f64],
) {
    let (n, m) = (g.n, g.n - 1);
    let t0 = g.t[0];
    let dur = g.duration();
    let speed = dur / t_final; // d t_guess / d t
    for p in 0..layout.points {
        let (k, r) = g.locate(t0 + layout.time(p) / t_final * dur);
        let k1 = (k + 1).min(g.len() - 1);
        let lerp =
            |v: &[f64], w: usize, i: usize| v[k * w + i] + r * (v[k1 * w + i] - v[k * w + i]);
        for i in 0..n {
            x0[layout.var(p, i)] = lerp(&g.q, n, i);
            x0[layout.var(p, n + i)] = speed * lerp(&g.qd, n, i);
        }
        for j in 0..m {
            x0[layout.var(p, 2 * n + j)] = lerp(&g.tau, m, j);
        }
    }
    for (v, (lo, hi)) in x0.iter_mut().zip(bounds.0.iter().zip(&bounds.1)) {
        *v = v.clamp(*lo, *hi);
    }
}

/// Smallest surface distance between a link and an obstacle over `trajectory`, m (no margin, no
/// self-collision); `None` without obstacles.
pub(crate) fn min_obstacle_clearance(
    robot: &Robot,
    obstacles: &[Circle],
    trajectory: &Trajectory,
) -> Result<Option<f64>> {
    if obstacles.is_empty() {
        return Ok(None);
    }
    let cf = ClearanceFn::new(robot.clone(), obstacles, 0.0)?.with_self_collision(false);
    Ok(Some(
        (0..trajectory.len())
            .map(|k| cf.min_clearance(trajectory.q(k)))
            .fold(f64::INFINITY, f64::min),
    ))
}

/// The cold initial guess on `layout`'s points: a smooth step (3 r^2 - 2 r^3 of the time fraction r) of
/// every joint from `q0` to the target pose `q_t`, its velocities the step's derivative, zero torque, the
/// start velocity `qd0` at point 0. `x0` is stacked `[q, qd, tau]` per point as in [`Layout::var`].
pub(crate) fn smooth_step_guess(
    layout: &Layout,
    t_final: f64,
    q0: &[f64],
    q_t: &[f64],
    qd0: &[f64],
    x0: &mut [f64],
) {
    let n = layout.n;
    for p in 0..layout.points {
        let r = layout.time(p) / t_final;
        let s = r * r * (3.0 - 2.0 * r);
        let sd = 6.0 * r * (1.0 - r) / t_final;
        for i in 0..n {
            x0[layout.var(p, i)] = q0[i] + s * (q_t[i] - q0[i]);
            x0[layout.var(p, n + i)] = sd * (q_t[i] - q0[i]);
        }
    }
    for i in 0..n {
        x0[layout.var(0, n + i)] = qd0[i];
    }
}

/// Initial barrier parameter of a warm-started solve when [`NlpSettings::mu_init`] is not set. IPOPT's
/// default (0.1) pushes a good guess back towards the centre of the feasible region; on the tracking
/// scenario (20 ms knots) its own solution as the guess then takes 13 iterations against 16 cold, with
/// 1e-4 it takes 6 (and a swing 0.2 s longer 13 instead of 21); measured in docs/planner.md.
pub const WARM_START_MU_INIT: f64 = 1e-4;

/// Solve `problem` with the seam's backend; when that does not converge (and the barrier strategy was
/// not already adaptive), a second attempt with the adaptive barrier update, which recovers from initial
/// guesses that cut through obstacles (measured on the paper's obstacle scenario; docs/planner.md). The
/// second is adopted when it converged or ended less infeasible. `max_wall_time_s` bounds both together:
/// the second gets what the first left, and does not run when nothing is left. Returns the adopted
/// solution and every attempt (exactly one marked adopted).
pub(crate) fn solve_with_retry(
    problem: &mut dyn SparseNlp,
    nlp: &NlpSettings,
) -> (NlpSolution, Vec<SolveAttempt>) {
    let start = std::time::Instant::now();
    let mut sol = solve(problem, nlp);
    let mut solves = vec![SolveAttempt::new(&sol, nlp.mu_strategy)];
    let mut adopted = 0;
    // a refusal (settings, problem) is the same under another barrier strategy
    let refused = matches!(
        sol.status,
        SolveStatus::InvalidProblem(_) | SolveStatus::InvalidSettings(_)
    );
    let retry_wanted =
        !sol.status.is_converged() && !refused && nlp.mu_strategy != MuStrategy::Adaptive;
    // the wall-time limit is the whole call's: the retry gets what is left, and none once it is spent
    if let Some(left) = nlp.remaining(start).filter(|_| retry_wanted) {
        let retry = NlpSettings {
            mu_strategy: MuStrategy::Adaptive,
            ..left
        };
        let second = solve(problem, &retry);
        solves.push(SolveAttempt::new(&second, MuStrategy::Adaptive));
        if second.status.is_converged()
            || second.max_constraint_violation < sol.max_constraint_violation
        {
            sol = second;
            adopted = 1;
        }
    }
    solves[adopted].adopted = true;
    (sol, solves)
}

/// The swing time T of `task` (s) and, when `settings.swing_time` is `"auto"`, the free-fall time
/// `T_freefall` it is twice of (the locked chain falling until the EE passes the midpoint between its
/// start and the target).
pub(crate) fn swing_time(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
) -> Result<(f64, Option<f64>)> {
    Ok(match settings.swing_time {
        SwingTime::Seconds(t) => (t, None),
        SwingTime::Auto(_) => {
            let start_ee = robot.ee_position(&task.q0);
            let tf = freefall_time(robot, &task.q0, 0.5 * (start_ee[0] + task.target[0]))?;
            (2.0 * tf, Some(tf))
        }
    })
}

/// The clearance rows the planner imposes on `task` (its obstacles when `settings.avoid_obstacles`,
/// the non-adjacent link pairs when `settings.self_collision`, margin `settings.obstacle_margin`);
/// `None` when there are none.
pub(crate) fn clearance_rows(
    robot: &Arc<Robot>,
    task: &SwingTask,
    settings: &PlannerSettings,
) -> Result<Option<ClearanceFn>> {
    let obstacles = if settings.avoid_obstacles {
        covering_obstacles(&task.obstacles)
    } else {
        vec![]
    };
    if obstacles.is_empty() && !settings.self_collision {
        return Ok(None);
    }
    Ok(Some(
        ClearanceFn::new(Arc::clone(robot), obstacles, settings.obstacle_margin)?
            .with_self_collision(settings.self_collision),
    ))
}

/// Slack of [`covering_obstacles`]' containment test, m.
const CONTAINED_TOL_M: f64 = 1e-12;

/// `obstacles` without those inside another (`|c_i - c_j| + r_i <= r_j`, within
/// [`CONTAINED_TOL_M`]), in their order; of identical circles the first is kept. A link that clears
/// a circle clears every circle inside it, so the rows of a contained obstacle add nothing to the
/// feasible set; a duplicated one would only repeat rows (a rank-deficient Jacobian where they are
/// active).
pub(crate) fn covering_obstacles(obstacles: &[Circle]) -> Vec<Circle> {
    let inside = |a: &Circle, b: &Circle| {
        (a.center[0] - b.center[0]).hypot(a.center[1] - b.center[1]) + a.radius
            <= b.radius + CONTAINED_TOL_M
    };
    obstacles
        .iter()
        .enumerate()
        .filter(|&(i, a)| {
            !obstacles
                .iter()
                .enumerate()
                .any(|(j, b)| j != i && inside(a, b) && (j < i || !inside(b, a)))
        })
        .map(|(_, a)| *a)
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A duplicated circle is kept once, a circle inside another dropped, overlapping ones kept.
    #[test]
    fn covering_obstacles_drop_duplicates_and_contained_circles() {
        let c = |x: f64, y: f64, r: f64| Circle {
            center: [x, y],
            radius: r,
        };
        let (a, inner, over) = (c(0.3, -0.5, 0.1), c(0.33, -0.48, 0.05), c(0.42, -0.5, 0.05));
        assert_eq!(covering_obstacles(&[a, a]), vec![a]);
        assert_eq!(covering_obstacles(&[inner, a, a, over]), vec![a, over]);
        // touching from inside counts as inside; poking out by 1e-9 m does not
        let touching = c(0.35, -0.5, 0.05);
        let out = c(0.35 + 1e-9, -0.5, 0.05);
        assert_eq!(covering_obstacles(&[touching, a]), vec![a]);
        assert_eq!(covering_obstacles(&[out, a]), vec![out, a]);
        assert!(covering_obstacles(&[]).is_empty());
    }

    /// The bracketed crossing at 1 ms steps agrees with a ten times finer integration, for the
    /// paper's start pose and three crossings.
    #[test]
    fn freefall_crossing_is_converged_in_the_step() {
        let robot = Robot::paper();
        let q0 = [-2.35, 0.0, -1.55, 0.0];
        let ee = robot.ee_position(&q0)[0];
        for x_mid in [0.5 * (ee + 0.8), 0.0, 0.3] {
            let coarse = freefall_time(&robot, &q0, x_mid).unwrap();
            let fine = freefall_time_with_step(&robot, &q0, x_mid, 1e-4).unwrap();
            assert!(coarse > 0.1, "x_mid {x_mid}: {coarse}");
            assert!((coarse - fine).abs() < 1e-10, "{coarse} vs {fine}");
            // the EE is at x_mid at the time found (one more integration, to the time found)
            let m11 = robot.mass_matrix(&q0)[0];
            let steps = (coarse / 1e-5).ceil() as usize;
            let dt = coarse / steps as f64;
            let mut ws = crate::model::Scratch::new(4);
            let mut g = vec![0.0; 4];
            let mut q = q0.to_vec();
            let mut x = [q0[0], 0.0];
            let mut k: [Vec<f64>; 4] = std::array::from_fn(|_| vec![0.0; 2]);
            let mut tmp = [0.0; 2];
            for _ in 0..steps {
                crate::integrate::rk4_step(&mut x, dt, &mut k, &mut tmp, |_, x, out| {
                    out[0] = x[1];
                    out[1] = locked_chain_acceleration(&robot, m11, x[0], &mut q, &mut ws, &mut g);
                });
            }
            let th = x[0];
            let mut qf = q0.to_vec();
            qf[0] = th;
            assert!((robot.ee_position(&qf)[0] - x_mid).abs() < 1e-9);
        }
    }

    /// A remembered free-fall time is the integration's number bit for bit, for each of several
    /// robots, poses and crossings asked in turn and again (more than the memo keeps), and a
    /// crossing never reached is the same error each time.
    #[test]
    fn remembered_freefall_times_are_the_integrations() {
        let paper = Robot::paper();
        let mut params = paper.params().clone();
        params.gravity *= 1.5;
        params.links[3].mass *= 2.0;
        let heavy = Robot::from_params(params, "test").unwrap();
        let cases: Vec<(&Robot, [f64; 4], f64)> = (0..12)
            .map(|i| {
                let robot = if i % 2 == 0 { &paper } else { &heavy };
                let q0 = [-2.35 + 0.01 * i as f64, 0.0, -1.55, 0.0];
                (robot, q0, 0.05 * (i % 3) as f64)
            })
            .collect();
        let q0 = [-2.35, 0.0, -1.55, 0.0];
        assert_ne!(
            freefall_time(&paper, &q0, 0.0).unwrap(),
            freefall_time(&heavy, &q0, 0.0).unwrap()
        );
        for _ in 0..2 {
            for (robot, q0, x_mid) in &cases {
                let fresh = freefall_time_with_step(robot, q0, *x_mid, FREEFALL_DT).unwrap();
                let asked = freefall_time(robot, q0, *x_mid).unwrap();
                assert_eq!(asked.to_bits(), fresh.to_bits(), "{q0:?} {x_mid}");
                assert_eq!(
                    freefall_time(robot, q0, *x_mid).unwrap().to_bits(),
                    fresh.to_bits()
                );
            }
        }
        // released to the left of x = 5 m it never gets there
        for _ in 0..2 {
            let e = freefall_time(&paper, &[-2.35, 0.0, -1.55, 0.0], 5.0).unwrap_err();
            assert!(
                matches!(&e, Error::InfeasibleTask(m) if m.contains("never reaches")),
                "{e}"
            );
        }
    }
}
