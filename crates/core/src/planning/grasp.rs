//! Whether obstacles near the target bar leave the last link any pose that grasps the bar: a proof
//! over every angle of the last link, which the task check uses to refuse a task no swing can end.
//!
//! A swing ends with the hand on the bar, so the last link (a capsule of radius `r` around the
//! segment from its proximal joint `E` to the bar) ends at the bar at some absolute angle `phi`:
//! `E(phi) = target - L (cos phi, sin phi)`. The angle is **admissible** only if `E` is within reach of
//! the links before it: `E` lies within `R' = L_2 + ... + L_{n-1}` of a point of the arc that joint 2
//! sweeps with link 1 inside the planner's `bounds.q1` (for two links, on that arc). Every reachable
//! `E` satisfies this, so the admissible set holds every final pose the planner can reach (it holds
//! more: the other joints' limits are not used). The task is **infeasible** when at every admissible
//! angle the last link comes closer than the margin to some obstacle (surface distance
//! `dist(c, [E, target]) - R - r < margin`): the clearance rows at the last knot can never hold.
//!
//! The proof is a branch and bound over `phi` in `[0, 2 pi)`, not a sample: on an interval of
//! half-width `h` around `phi_c`, `E` moves by at most `L h`, and both the distance from `E` to the
//! reachable set and the distance from an obstacle's centre to the segment `[E, target]` change by
//! at most `L h` (distances to a set, and to a segment whose end points move by at most `d`, are
//! 1-Lipschitz). An interval is settled when `dist(E(phi_c), reach) - L h > 0` (no angle in it is
//! admissible) or `clearance(phi_c) + L h < margin` for one obstacle (every angle in it is blocked);
//! otherwise it is split, down to [`MIN_HALF_WIDTH`]. An interval still unsettled there ends the proof
//! with no refusal: the check refuses only what it proves. Rounding is covered by [`SLACK_M`].
//!
//! Units: m, rad.

use crate::geometry::point_segment_dist2;
use crate::model::{Circle, Robot};
use std::f64::consts::TAU;

/// Half-width below which an unsettled interval of the last link's angle ends the proof, rad.
pub const MIN_HALF_WIDTH: f64 = 1e-7;
/// Slack on both tests of the proof against rounding, m.
pub const SLACK_M: f64 = 1e-9;
/// Intervals the angle is cut into before the branch and bound.
const FIRST_CUTS: usize = 64;

/// A proof that no pose grasping the bar clears the obstacles by the margin.
#[derive(Debug, Clone, PartialEq)]
pub struct GraspBlocked {
    /// The obstacles (0-based, ascending) that block some admissible angle of the last link: together
    /// they block every one.
    pub obstacles: Vec<usize>,
    /// The one among them whose surface is closest to the bar.
    pub nearest: usize,
    /// Its surface distance from the bar, m (negative: the bar is inside it).
    pub bar_distance_m: f64,
    /// An upper bound on the last link's clearance to the obstacles at any admissible angle, m (below
    /// the margin).
    pub best_clearance_m: f64,
}

/// Distance from `p` to the arc of radius `r` around the origin between the angles `lo` and `hi`
/// (rad, `lo <= hi`; the whole circle when `hi - lo >= 2 pi`).
fn dist_to_arc(p: [f64; 2], r: f64, lo: f64, hi: f64) -> f64 {
    let norm = p[0].hypot(p[1]);
    if hi - lo >= TAU {
        return (norm - r).abs();
    }
    let inside = (p[1].atan2(p[0]) - lo).rem_euclid(TAU) <= hi - lo;
    if inside || norm == 0.0 {
        return (norm - r).abs();
    }
    let end = |a: f64| (p[0] - r * a.cos()).hypot(p[1] - r * a.sin());
    end(lo).min(end(hi))
}

/// Whether the obstacles block every pose of `robot` that grasps `target` (see the module docs):
/// `q1` is the range of link 1's absolute angle (`bounds.q1`), `margin` the clearance required (m).
/// `None` when some admissible angle of the last link was not proven blocked, or when no angle is
/// admissible (then no obstacle is to blame).
pub fn grasp_blocked(
    robot: &Robot,
    target: [f64; 2],
    obstacles: &[Circle],
    margin: f64,
    q1: [f64; 2],
) -> Option<GraspBlocked> {
    if obstacles.is_empty() {
        return None;
    }
    let n = robot.n();
    let len = robot.lengths();
    let (l, r) = (len[n - 1], robot.radii()[n - 1]);
    let rest: f64 = len[1..n - 1].iter().sum();
    let elbow = |phi: f64| [target[0] - l * phi.cos(), target[1] - l * phi.sin()];
    let clearance =
        |e: [f64; 2], o: &Circle| point_segment_dist2(o.center, e, target).sqrt() - o.radius - r;
    let bar_distance = |k: usize| {
        let o = &obstacles[k];
        (target[0] - o.center[0]).hypot(target[1] - o.center[1]) - o.radius
    };
    // an obstacle within the link's radius plus the margin of the bar, where the link ends, blocks
    // every angle alone
    if let Some(k) = (0..obstacles.len())
        .filter(|&k| bar_distance(k) - r < margin - SLACK_M)
        .min_by(|&a, &b| bar_distance(a).total_cmp(&bar_distance(b)))
    {
        return Some(GraspBlocked {
            obstacles: vec![k],
            nearest: k,
            bar_distance_m: bar_distance(k),
            best_clearance_m: bar_distance(k) - r,
        });
    }
    let mut used = vec![false; obstacles.len()];
    let mut best = f64::NEG_INFINITY;
    let h0 = TAU / (2 * FIRST_CUTS) as f64;
    let mut stack: Vec<(f64, f64)> = (0..FIRST_CUTS)
        .map(|k| ((2 * k + 1) as f64 * h0, h0))
        .collect();
    while let Some((phi, h)) = stack.pop() {
        let e = elbow(phi);
        let spread = l * h;
        if dist_to_arc(e, len[0], q1[0], q1[1]) - rest - spread > SLACK_M {
            continue;
        }
        let (k, c) = obstacles
            .iter()
            .map(|o| clearance(e, o))
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .expect("at least one obstacle");
        if c + spread < margin - SLACK_M {
            used[k] = true;
            best = best.max(c + spread);
            continue;
        }
        if h < MIN_HALF_WIDTH {
            return None;
        }
        stack.push((phi - h / 2.0, h / 2.0));
        stack.push((phi + h / 2.0, h / 2.0));
    }
    let blocking: Vec<usize> = (0..obstacles.len()).filter(|&k| used[k]).collect();
    // no admissible angle at all (the links cannot reach the bar with link 1 inside `q1`): no
    // obstacle is to blame
    let nearest = blocking
        .iter()
        .copied()
        .min_by(|&a, &b| bar_distance(a).total_cmp(&bar_distance(b)))?;
    Some(GraspBlocked {
        obstacles: blocking,
        nearest,
        bar_distance_m: bar_distance(nearest),
        best_clearance_m: best,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const BELOW: [f64; 2] = [-std::f64::consts::PI, 0.0];

    fn circle(center: [f64; 2], radius: f64) -> Circle {
        Circle { center, radius }
    }

    #[test]
    fn the_distance_to_an_arc_is_the_radial_gap_inside_its_angles_and_to_an_end_outside() {
        let r = 0.5;
        // straight below the grip, inside the lower half
        assert!((dist_to_arc([0.0, -0.2], r, -3.0, 0.0) - 0.3).abs() < 1e-15);
        // above: the nearest end of the lower half circle is (0.5, 0) or (-0.5, 0)
        let d = dist_to_arc([0.3, 0.4], r, -std::f64::consts::PI, 0.0);
        assert!((d - (0.2f64).hypot(0.4)).abs() < 1e-15, "{d}");
        // the whole circle
        assert!((dist_to_arc([0.3, 0.4], r, -4.0, 4.0)).abs() < 1e-15);
        // the origin is r from every point of the arc
        assert!((dist_to_arc([0.0, 0.0], r, -1.0, -0.5) - r).abs() < 1e-15);
    }

    /// An obstacle whose surface is closer to the bar than the last link's radius plus the margin
    /// blocks every angle; the bound on the best clearance is below the margin and above the bar's
    /// own distance less the radius.
    #[test]
    fn an_obstacle_at_the_bar_blocks_every_angle() {
        let robot = Robot::paper();
        let o = circle([0.8, -0.09], 0.08);
        let b = grasp_blocked(&robot, [0.8, 0.0], &[o], 0.01, BELOW).expect("blocked");
        assert_eq!((b.obstacles.clone(), b.nearest), (vec![0], 0));
        assert!((b.bar_distance_m - 0.01).abs() < 1e-12, "{b:?}");
        assert!(b.best_clearance_m < 0.01, "{b:?}");
        // the same circle far below the bar leaves the link room
        let far = circle([0.8, -0.5], 0.08);
        assert_eq!(grasp_blocked(&robot, [0.8, 0.0], &[far], 0.01, BELOW), None);
    }

    /// The proof agrees with a dense sample of the last link's angles where the sample is decisive:
    /// a blocked task has no sampled admissible angle clear of the obstacle, and an unblocked one has
    /// such an angle (or one within the proof's resolution of clearing).
    #[test]
    fn the_proof_agrees_with_a_dense_sample_of_the_angle() {
        let robot = Robot::paper();
        let (n, len, r) = (robot.n(), robot.lengths(), robot.radii()[robot.n() - 1]);
        let (l, rest) = (len[n - 1], len[1..n - 1].iter().sum::<f64>());
        let target = [0.8, 0.0];
        let margin = 0.01;
        let mut seen = [0, 0];
        for i in 0..40 {
            let a = -std::f64::consts::PI + 0.15 * i as f64;
            for gap in [0.015, 0.03, 0.05, 0.08] {
                let rad = 0.1;
                let d = rad + gap;
                let o = circle([target[0] + d * a.cos(), target[1] + d * a.sin()], rad);
                let proof = grasp_blocked(&robot, target, &[o], margin, BELOW);
                let best = (0..20_000)
                    .map(|k| k as f64 * TAU / 20_000.0)
                    .filter_map(|phi| {
                        let e = [target[0] - l * phi.cos(), target[1] - l * phi.sin()];
                        (dist_to_arc(e, len[0], BELOW[0], BELOW[1]) <= rest)
                            .then(|| point_segment_dist2(o.center, e, target).sqrt() - o.radius - r)
                    })
                    .fold(f64::NEG_INFINITY, f64::max);
                match proof {
                    Some(b) => {
                        seen[0] += 1;
                        assert!(best < margin, "{a} {gap}: sampled {best}, proof {b:?}");
                        assert!(best <= b.best_clearance_m + 1e-12, "{best} {b:?}");
                    }
                    None => {
                        seen[1] += 1;
                        assert!(best > margin - 1e-3, "{a} {gap}: sampled {best}");
                    }
                }
            }
        }
        assert!(seen[0] > 0 && seen[1] > 0, "{seen:?}");
    }

    /// On the three-link robot (links 0.4 m, bar at 0.8 m) the last link's admissible angles put its
    /// far joint left of the bar, from below it to above it. Two 0.1 m circles 0.08 m from the bar,
    /// one up-left and one down-left, each leave 0.06 m of clearance at some angle; together they
    /// block every angle.
    #[test]
    fn two_obstacles_can_block_together_what_neither_blocks_alone() {
        let robot = params_three_link();
        let target = [0.8, 0.0];
        let place = |deg: f64| {
            let (a, d) = (deg.to_radians(), 0.18);
            circle([target[0] + d * a.cos(), target[1] + d * a.sin()], 0.1)
        };
        let (up, down) = (place(150.0), place(225.0));
        for o in [up, down] {
            assert_eq!(grasp_blocked(&robot, target, &[o], 0.01, BELOW), None);
            // a margin past the room it leaves (0.06 m) blocks it alone
            assert!(grasp_blocked(&robot, target, &[o], 0.065, BELOW).is_some());
        }
        let b = grasp_blocked(&robot, target, &[up, down], 0.01, BELOW).expect("blocked");
        assert_eq!(b.obstacles, vec![0, 1]);
        assert!((b.bar_distance_m - 0.08).abs() < 1e-12, "{b:?}");
        assert!(b.best_clearance_m < 0.01, "{b:?}");
    }

    fn params_three_link() -> Robot {
        let p =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../params/three-link.toml");
        Robot::from_toml_file(&p).unwrap()
    }
}
