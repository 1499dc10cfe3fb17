//! A final pose for the seeds when the obstacle-free swing ends inside an obstacle's margin.
//!
//! The detour seeds tracked backwards start from the obstacle-free swing's final pose, and the
//! configuration-space search ends there; an obstacle near the bar can cover that pose, and then
//! neither seed exists. The last link ends at the bar, but the chain has `n - 2` more degrees of
//! freedom: [`clear_final_pose`] looks for another pose that grasps the bar and clears the obstacles
//! by the margin plus [`super::detour::EXTRA_CLEARANCE`], by inverse kinematics from the final pose
//! with its relative joints moved by every combination of [`GOAL_OFFSETS_RAD`] (at most
//! [`MAX_GOAL_SEEDS`] of them), keeping the clear pose inside the joint bounds closest to the final
//! pose. When no seed gives one, the branch and bound over every pose grasping the bar within the
//! joint bounds ([`crate::planning::grasp::search_grasp_poses`]) looks for one; where it proves
//! that none keeps the margin plus [`EXTRA_CLEARANCE`], it asks less extra in turn
//! ([`FALLBACK_EXTRA_M`], down to 1 mm). [`with_final_pose`] puts it at the end of the obstacle-free swing's knots, where the seeds
//! take their final pose from.
//!
//! Units: rad, m.

use crate::error::Result;
use crate::model::{ik_from_seed, wrap_angle, Circle, ClearanceFn, Robot};
use crate::planning::grasp::{search_grasp_poses, GraspPoses};
use crate::planning::settings::PlannerSettings;
use crate::planning::strategy::cspace::GRID_STEP_RAD;
use crate::planning::strategy::detour::EXTRA_CLEARANCE;
use crate::trajectory::Trajectory;

/// Offsets of the relative joints of the inverse-kinematics seeds around the final pose, rad.
pub const GOAL_OFFSETS_RAD: [f64; 5] = [0.0, -0.6, 0.6, -1.2, 1.2];
/// Most inverse-kinematics seeds tried.
pub const MAX_GOAL_SEEDS: usize = 625;
/// The clearance past the margin the branch and bound asks of a goal pose when no seed gave one,
/// in turn while it proves that no pose keeps that much, m (the first is [`EXTRA_CLEARANCE`]).
pub const FALLBACK_EXTRA_M: [f64; 4] = [EXTRA_CLEARANCE, 0.005, 0.0025, 0.001];

/// A pose within the bounds that puts the end effector at `target` and clears `obstacles` (and,
/// with `settings.self_collision`, the non-adjacent links) by the margin plus
/// [`EXTRA_CLEARANCE`], the closest to `q_final` found (see the module docs); `None` when `q_final`
/// itself clears them (nothing to change) or no seed gave one.
pub fn clear_final_pose(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    q_final: &[f64],
    target: [f64; 2],
) -> Result<Option<Vec<f64>>> {
    clear_final_pose_until(robot, obstacles, settings, q_final, target, &|| false)
}

/// [`clear_final_pose`], asking `stop` before each inverse-kinematics seed: once it says stop, the
/// closest pose found so far.
pub fn clear_final_pose_until(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    q_final: &[f64],
    target: [f64; 2],
    stop: &dyn Fn() -> bool,
) -> Result<Option<Vec<f64>>> {
    let need = settings.obstacle_margin + EXTRA_CLEARANCE;
    let cf = ClearanceFn::new(robot.clone(), obstacles, settings.obstacle_margin)?
        .with_self_collision(settings.self_collision);
    if obstacles.is_empty() || cf.min_clearance(q_final) >= need {
        return Ok(None);
    }
    let poses = clear_final_poses(robot, obstacles, settings, q_final, target, 1, stop)?;
    Ok(poses.into_iter().next())
}

/// Up to `k` poses that grasp the bar at `target` and clear `obstacles` as [`clear_final_pose`],
/// one per family (the signs of the relative joints: elbow up or down at each joint), the family
/// of `q_final` first when `q_final` clears them (then `q_final` itself), the others by their
/// distance to `q_final`, each the family's pose closest to `q_final`. `stop` is asked before each
/// inverse-kinematics seed: once it says stop, the poses found so far.
pub fn clear_final_poses(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    q_final: &[f64],
    target: [f64; 2],
    k: usize,
    stop: &dyn Fn() -> bool,
) -> Result<Vec<Vec<f64>>> {
    let need = settings.obstacle_margin + EXTRA_CLEARANCE;
    let cf = ClearanceFn::new(robot.clone(), obstacles, settings.obstacle_margin)?
        .with_self_collision(settings.self_collision);
    let n = robot.n;
    let family = |q: &[f64]| -> Vec<bool> { q[1..].iter().map(|v| *v >= 0.0).collect() };
    // per family, the closest pose found (distance, pose)
    let mut best: Vec<(Vec<bool>, f64, Vec<f64>)> = vec![];
    if cf.min_clearance(q_final) >= need {
        best.push((family(q_final), -1.0, q_final.to_vec()));
    }
    let b = &settings.bounds;
    let m = GOAL_OFFSETS_RAD.len();
    let combos = m.saturating_pow((n - 1) as u32).min(MAX_GOAL_SEEDS);
    let mut seed = q_final.to_vec();
    for c in 0..combos {
        if stop() {
            break;
        }
        let mut r = c;
        for i in 1..n {
            seed[i] = q_final[i] + GOAL_OFFSETS_RAD[r % m];
            r /= m;
        }
        let Some(q) = ik_from_seed(robot, &seed, target) else {
            continue;
        };
        let q: Vec<f64> = q.iter().map(|v| wrap_angle(*v)).collect();
        let inside =
            q[0] >= b.q1[0] && q[0] <= b.q1[1] && q[1..].iter().all(|v| v.abs() <= b.q_rel_max);
        if !inside || cf.min_clearance(&q) < need {
            continue;
        }
        let dist: f64 = q.iter().zip(q_final).map(|(a, s)| (a - s).powi(2)).sum();
        let fam = family(&q);
        match best.iter_mut().find(|(f, _, _)| *f == fam) {
            Some(e) if dist < e.1 => (e.1, e.2) = (dist, q),
            Some(_) => {}
            None => best.push((fam, dist, q)),
        }
    }
    // no seed gave a clear pose: the branch and bound over every pose grasping the bar, asking
    // less extra clearance where it proves none keeps more
    for extra in FALLBACK_EXTRA_M {
        if !best.is_empty() || stop() {
            break;
        }
        let need = settings.obstacle_margin + extra;
        let accept = |q: &[f64]| cf.min_clearance(q) >= need;
        match search_grasp_poses(robot, target, obstacles, need, b, &accept, stop) {
            GraspPoses::Clear(q) => {
                let dist: f64 = q.iter().zip(q_final).map(|(a, s)| (a - s).powi(2)).sum();
                best.push((family(&q), dist, q));
            }
            GraspPoses::Blocked(_) => {}
            GraspPoses::Unsettled => break,
        }
    }
    best.sort_by(|a, b| a.1.total_cmp(&b.1));
    Ok(best.into_iter().take(k).map(|(_, _, q)| q).collect())
}

/// The goal poses of the configuration-space searches: `q_end` (the seeds' final pose) first, then
/// up to `k - 1` other poses of [`clear_final_poses`] that grasp the bar at `target` and clear
/// `obstacles`, each apart from every pose before it by at least [`GRID_STEP_RAD`] in some joint
/// (the searches' grid step: closer poses end in the same grid cell). `stop` as in
/// [`clear_final_poses`]; once it says stop, the poses found so far.
pub fn distinct_goal_poses(
    robot: &Robot,
    obstacles: &[Circle],
    settings: &PlannerSettings,
    q_end: &[f64],
    target: [f64; 2],
    k: usize,
    stop: &dyn Fn() -> bool,
) -> Result<Vec<Vec<f64>>> {
    let mut goals = vec![q_end.to_vec()];
    if k <= 1 || stop() {
        return Ok(goals);
    }
    for q in clear_final_poses(robot, obstacles, settings, q_end, target, k, stop)? {
        let same = goals
            .iter()
            .any(|g| g.iter().zip(&q).all(|(a, b)| (a - b).abs() < GRID_STEP_RAD));
        if !same && goals.len() < k {
            goals.push(q);
        }
    }
    Ok(goals)
}

/// `free` with its last knot's pose replaced by `q` (velocities and torques kept).
pub fn with_final_pose(free: &Trajectory, q: &[f64]) -> Trajectory {
    let n = free.n;
    let mut out = free.clone();
    let last = out.len() - 1;
    out.q[last * n..(last + 1) * n].copy_from_slice(q);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planning::strategy::cspace::cspace_routes;

    fn robot(file: &str) -> Robot {
        Robot::from_repo_params(file)
    }

    /// On the three- and six-link robots of params/, an obstacle on a middle link of a pose at the
    /// bar: the clear goal pose found instead is accepted and searched by the configuration-space
    /// search (its end poses clear, its grid fine enough to search).
    #[test]
    fn a_goal_pose_the_goal_search_returns_is_searched_by_the_cspace_search() {
        let s = PlannerSettings::default();
        let cases = [
            ("three-link.toml", vec![-2.2, 0.0, -1.0], [0.8, 0.0]),
            (
                "six-link.toml",
                vec![-2.35, 0.0, -0.5, 0.0, -0.5, 0.0],
                [0.7, 0.0],
            ),
        ];
        for (file, q0, target) in cases {
            let r = robot(file);
            let n = r.n;
            let mut seed = vec![0.4; n];
            seed[0] = -1.2;
            let q_final = ik_from_seed(&r, &seed, target).expect("the bar is in reach");
            let mut segs = vec![([0.0; 2], [0.0; 2]); n];
            r.link_segments(&q_final, &mut segs);
            let (a, b) = segs[n / 2];
            let obstacles = [Circle {
                center: [(a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0],
                radius: 0.04,
            }];
            let goal = clear_final_pose(&r, &obstacles, &s, &q_final, target)
                .unwrap()
                .unwrap_or_else(|| panic!("{file}: no clear goal pose"));
            let cf = ClearanceFn::new(r.clone(), &obstacles[..], 0.0).unwrap();
            assert!(cf.min_clearance(&goal) >= s.obstacle_margin + EXTRA_CLEARANCE);
            let routes = cspace_routes(&r, &obstacles, &s, &q0, &goal, 1, &|| false).unwrap();
            let rep = &routes[0].0;
            assert!(
                rep.grid_cells > 0 && rep.endpoints_clear && rep.cells_discovered > 0,
                "{file}: {rep:?}"
            );
        }
    }
}
