//! The reference re-planning workload of the fast-planner bars (docs/benchmarks.md, "Re-planning"):
//! the paper's tracking swing ([`SwingTask::paper`](super::SwingTask::paper), params/paper.toml, T
//! automatic) planned by multiple shooting on the Riccati backend with one RK4 step per interval, then
//! re-planned from its planned state at [`REPLAN_T_NOW`] disturbed by uniform `+-`[`REPLAN_DQ_RAD`] on
//! every angle and `+-`[`REPLAN_DQD_RAD_S`] on every rate (seeded draws, those strictly inside the
//! bounds).
//!
//! One place for the workload, so that the criterion bench (`benches/replan.rs`), the instruction-count
//! example (`crates/tools/src/bin/replan_profile.rs`) and the tests re-plan the same draws and their figures compare.
//!
//! Units: s, rad, rad/s; `x = [q, qd]`, `q[0]` absolute from +x, the rest relative.

use crate::planning::nlp::{Backend, NlpSettings};
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
