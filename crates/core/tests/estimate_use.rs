//! When the online mass estimate is handed to the controller (docs/estimation.md, "When the
//! estimate is used"): not on the nominal robot (the estimate is determined but not significantly
//! different from it), on a plant 15 % heavier once every base parameter is determined to 2 %, and
//! not when the measurements do not fit the filter's noise model (sensor noise four times the
//! modelled one). Model plant, the paper's swing tracked by the adaptive MPC.
//!
//! Units: rad, rad/s, s; base parameters in kg m^2 (ZZR) and kg m (MXR).

mod common;

use brachia::control::param_estimator::chi2_quantile;
use brachia::control::{Adaptive, Mpc, ParamEstimatorSettings};
use brachia::model::Robot;
use brachia::trajectory::Trajectory;
use common::estimate::{adaptive_run, scaled};
use std::sync::Arc;

/// The paper's robot with every mass and inertia times `f`.
fn coherent(f: f64) -> Robot {
    scaled(&[f; 4], &[f; 4])
}

/// The adaptive MPC (estimate settings `es`) tracking the swing on the model plant of `plant`
/// with sensor noise `noise_scale` x (0.0015 rad, 0.015 rad/s, seed 7), for `fraction` of the
/// swing.
fn run(
    reference: &Arc<Trajectory>,
    plant: &Robot,
    es: ParamEstimatorSettings,
    noise_scale: f64,
    fraction: f64,
) -> Adaptive<Mpc> {
    adaptive_run(
        reference,
        plant,
        es,
        noise_scale,
        7,
        fraction * reference.duration(),
    )
}

#[test]
fn the_chi_square_quantile_matches_the_table() {
    // chi-square quantiles at 0.999 (z = 3.0902) and 0.99 (z = 2.3263)
    for (k, z, table) in [
        (8, 3.0902, 26.124),
        (4, 2.3263, 13.277),
        (16, 3.0902, 39.252),
        (8, 2.3263, 20.090),
    ] {
        let q = chi2_quantile(k, z);
        assert!(
            (q - table).abs() <= 0.01 * table,
            "k {k}, z {z}: {q} vs {table}"
        );
    }
}

#[test]
fn the_estimate_is_used_only_when_it_is_determined_consistent_and_different() {
    let reference = common::paper_swing();
    let t_end = reference.duration();
    let es = ParamEstimatorSettings::default();

    // the nominal robot: determined by the end, but never different enough to be handed over
    let c = run(&reference, &Robot::paper(), es, 1.0, 1.0);
    let mut est = c.estimator().clone();
    assert!(
        est.max_rel_std() <= es.use_max_rel_std,
        "{}",
        est.max_rel_std()
    );
    assert!(
        est.nis_ratio() <= es.use_max_nis_ratio,
        "{}",
        est.nis_ratio()
    );
    assert!(!est.ready_to_use());
    assert_eq!(c.used_from(), None);
    assert_eq!(c.model_updates(), 0);

    // 15 % heavier: handed over once determined, then updated
    let c = run(&reference, &coherent(1.15), es, 1.0, 1.0);
    let t = c
        .used_from()
        .expect("the estimate of a 15 % heavier plant is used");
    assert!(
        t > 0.25 * t_end && t < 0.75 * t_end,
        "used from {t} s of {t_end} s"
    );
    let report = c.report();
    assert_eq!(report.used_from_s, Some(t));
    assert!(c.model_updates() > 1);
    // a fifth of the swing in: far from the nominal robot already, but not determined
    let c = run(&reference, &coherent(1.15), es, 1.0, 0.2);
    let mut est = c.estimator().clone();
    assert!(
        est.max_rel_std() > es.use_max_rel_std,
        "{}",
        est.max_rel_std()
    );
    assert!(!est.ready_to_use());
    // not even once handed over (no test against the nominal robot then)
    est.mark_used(0.0);
    assert!(!est.ready_to_use());
    assert_eq!(c.used_from(), None);

    // the sensor noise four times the filter's: the measurements do not fit, nothing is used
    let c = run(&reference, &coherent(1.15), es, 4.0, 1.0);
    assert!(c.estimator().nis_ratio() > es.use_max_nis_ratio);
    assert_eq!(c.used_from(), None);
}
