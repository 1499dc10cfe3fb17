//! The reference workloads of the measurements.
//!
//! The re-planning workload (docs/benchmarks.md, "Re-planning"):
//! the paper's tracking swing ([`SwingTask::paper`](super::SwingTask::paper), params/paper.toml, T
//! automatic) planned by multiple shooting on the Riccati backend with one RK4 step per interval, then
//! re-planned from its planned state at [`REPLAN_T_NOW`] disturbed by uniform `+-`[`REPLAN_DQ_RAD`] on
//! every angle and `+-`[`REPLAN_DQD_RAD_S`] on every rate (seeded draws, those strictly inside the
//! bounds).
//!
//! One place for the workload, so that the criterion bench (`benches/replan.rs`), the instruction-count
//! example (`crates/tools/src/bin/replan_profile.rs`) and the tests re-plan the same draws and their figures compare.
//!
//! The obstacle placements of the placement scan ([`swing_placement`]): obstacles drawn on the
//! unobstructed swing's path, which the scan's tests and the instruction-count tool
//! (`crates/tools/src/bin/plan_check.rs`) plan alike.
//!
//! Units: s, rad, rad/s; `x = [q, qd]`, `q[0]` absolute from +x, the rest relative.

use crate::model::{Circle, ClearanceFn, Robot};
use crate::planning::nlp::{Backend, NlpSettings};
use crate::planning::outcome::Plan;
use crate::planning::settings::{Bounds, PlannerSettings, ShootingSettings, Transcription};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The time of the swing the re-plans start from, s.
pub const REPLAN_T_NOW: f64 = 0.6;

/// Half-width of the uniform disturbance of every angle, rad.
pub const REPLAN_DQ_RAD: f64 = 0.1;

/// Half-width of the uniform disturbance of every rate, rad/s.
pub const REPLAN_DQD_RAD_S: f64 = 0.5;

/// The seed of the bench's 100 draws.
pub const REPLAN_SEED: u64 = 2026;

/// The knot spacing of the benchmark's re-planning mesh, s: 40 ms (K = 56 on the tracking swing), whose
/// cold plan's independent replay misses the bar by 1.4e-4 m and the 100 re-plans' by at most
/// 8.9e-5 m, within the accuracy rule (1 mm); docs/benchmarks.md, "Re-planning".
pub const REPLAN_KNOT_DT: f64 = 0.04;

/// The re-planning mesh: multiple shooting with knots `knot_dt` (s) apart (the bar's is
/// [`REPLAN_KNOT_DT`]: K = 56 on the tracking swing), one RK4 step per interval, on the Riccati (`ocp`)
/// backend with its default settings; everything else the planner's defaults.
pub fn replan_settings(knot_dt: f64) -> (PlannerSettings, NlpSettings) {
    (
        PlannerSettings {
            transcription: Transcription::MultipleShooting,
            knot_dt,
            shooting: ShootingSettings {
                substeps: 1,
                ..Default::default()
            },
            ..Default::default()
        },
        NlpSettings {
            backend: Backend::Ocp,
            ..Default::default()
        },
    )
}

/// `count` seeded draws of `x` (`[q, qd]`, 2n) disturbed by uniform `+-REPLAN_DQ_RAD` on each angle and
/// `+-REPLAN_DQD_RAD_S` on each rate, keeping those strictly inside `bounds` (so possibly fewer than
/// `count`). The same `x`, `count` and `seed` give the same draws.
pub fn disturbed_starts(x: &[f64], bounds: &Bounds, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let n = x.len() / 2;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let mut y = x.to_vec();
            for i in 0..n {
                y[i] += rng.gen_range(-REPLAN_DQ_RAD..REPLAN_DQ_RAD);
                y[n + i] += rng.gen_range(-REPLAN_DQD_RAD_S..REPLAN_DQD_RAD_S);
            }
            y
        })
        .filter(|y| bounds.strictly_contains(y))
        .collect()
}

/// Obstacles drawn on a swing's path ([`swing_placement`]).
#[derive(Debug, Clone, PartialEq)]
pub struct SwingPlacement {
    /// The obstacles.
    pub obstacles: Vec<Circle>,
    /// How each was drawn (`r 0.080 at the tip of link 2 at 1.23 s`, joined by ` + `).
    pub what: String,
}

/// The placement scan's draw for `seed` on `robot`'s unobstructed swing `free` (its 1 ms
/// trajectory): two obstacles for every fifth seed, one for the others, each at the midpoint or the
/// tip of a random link at a random time in 0.7-1.7 s, radius 0.05-0.15 m. `None` when an obstacle
/// overlaps the start pose `q0` (the task would be refused, not planned). The same arguments give
/// the same draw.
pub fn swing_placement(
    robot: &Robot,
    free: &Plan,
    q0: &[f64],
    seed: u64,
) -> Option<SwingPlacement> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let count = if seed.is_multiple_of(5) { 2 } else { 1 };
    let mut segs = vec![([0.0; 2], [0.0; 2]); robot.n()];
    let (mut obstacles, mut what) = (vec![], vec![]);
    for _ in 0..count {
        let t: f64 = rng.gen_range(0.7..1.7);
        let link = rng.gen_range(0..robot.n());
        let tip = rng.gen_bool(0.5);
        let radius: f64 = rng.gen_range(0.05..0.15);
        let (j, _) = free.trajectory.locate(t.min(free.swing_time_s));
        robot.link_segments(free.trajectory.q(j), &mut segs);
        let (a, b) = segs[link];
        let center = if tip {
            b
        } else {
            [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]
        };
        obstacles.push(Circle { center, radius });
        what.push(format!(
            "r {radius:.3} at the {} of link {} at {t:.2} s",
            if tip { "tip" } else { "midpoint" },
            link + 1
        ));
    }
    let cf = ClearanceFn::new(robot.clone(), obstacles.as_slice(), 0.0)
        .ok()?
        .with_self_collision(false);
    (cf.min_clearance(q0) >= 0.0).then(|| SwingPlacement {
        obstacles,
        what: what.join(" + "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_are_seeded_inside_the_bounds_and_within_the_disturbance() {
        let b = Bounds::default();
        let x = [-2.0, 0.3, -1.0, 0.2, 0.5, -0.4, 1.0, 0.0];
        let a = disturbed_starts(&x, &b, 50, 3);
        assert_eq!(a, disturbed_starts(&x, &b, 50, 3));
        assert_ne!(a, disturbed_starts(&x, &b, 50, 4));
        assert!(!a.is_empty() && a.len() <= 50);
        for y in &a {
            assert!(b.strictly_contains(y));
            for i in 0..4 {
                assert!((y[i] - x[i]).abs() < REPLAN_DQ_RAD);
                assert!((y[4 + i] - x[4 + i]).abs() < REPLAN_DQD_RAD_S);
            }
        }
        // a state on a bound is never kept
        let mut edge = x;
        edge[1] = b.q_rel_max;
        let kept = disturbed_starts(&edge, &b, 200, 5);
        assert!(kept.len() < 200);
    }
}
