//! The diagnosis's detour as a candidate of the obstacle chain: the best-ranked configuration-space
//! seed ([`super::homotopy`]) planned with every actuator limit widened by
//! [`PROBE_TORQUE_SCALE`] (the torque probe of [`super::diagnosis`]), and from that plan:
//! - when its torques stay within the real limits (the probe's `detour_within_limits`): the task at
//!   the real limits, warm from it;
//! - otherwise, when the swing time is `"auto"` (multiple shooting, no `free_swing_time`): the task
//!   at the real limits with the swing time free in `[T, PROBE_SWING_TIME_FACTOR T]` (the probe's
//!   `needs_swing_time`), warm from it.
//!
//! A plan from either that converges is the chain's plan. The solves are the chain's (in the plan's
//! `solves`); what they found is handed to the diagnosis ([`Probed`]), which reads it instead of
//! solving the same problems again. Units: s, N m.

use super::candidate::longer_swing_settings;
use super::diagnosis::{PROBE_MAX_ITER, PROBE_SWING_TIME_FACTOR, PROBE_TORQUE_SCALE};
use super::torque_continuation::with_torque_scale;
use crate::error::Result;
use crate::model::Robot;
use crate::planning::nlp::NlpSettings;
use crate::planning::outcome::{Plan, SolveRole};
use crate::planning::settings::ValidSettings;
use crate::planning::solve::plan_single;
use crate::planning::solve_log::SolveLog;
use crate::planning::task::ValidTask;
use crate::trajectory::Trajectory;
use std::time::Instant;

/// What the chain solved that the diagnosis's probes would solve again.
#[derive(Debug, Default, Clone)]
pub(crate) struct Probed {
    /// The configuration-space seed the torque probe starts from (the best-ranked one).
    pub seed: Option<Trajectory>,
    /// The plan from `seed` with every limit widened by [`PROBE_TORQUE_SCALE`].
    pub widened: Option<Plan>,
    /// The plan at the real limits with the swing time free in `[T, PROBE_SWING_TIME_FACTOR T]`,
    /// from `widened`.
    pub swing_time: Option<Plan>,
}

/// The largest |tau| per actuated joint over `p`'s 1 ms trajectory, N m.
pub(crate) fn peak_torques(p: &Plan, m: usize) -> Vec<f64> {
    let mut peak = vec![0.0f64; m];
    for k in 0..p.trajectory.len() {
        for (pk, t) in peak.iter_mut().zip(p.trajectory.tau(k)) {
            *pk = pk.max(t.abs());
        }
    }
    peak
}

/// Each actuated joint's limit (the larger of |tau_min| and |tau_max|), N m.
pub(crate) fn torque_limits(robot: &Robot) -> Vec<f64> {
    let a = &robot.params().actuators;
    (0..robot.n - 1)
        .map(|j| a.tau_min[j].abs().max(a.tau_max[j].abs()))
        .collect()
}

/// The candidate of the module docs from the seed `g`, for a call that began at `started` with
/// `nlp`; every solve recorded in `log`. The plan when one converged, and what was solved.
#[allow(clippy::too_many_arguments)]
pub(crate) fn widened_detour(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    started: Instant,
    g: &Trajectory,
    log: &mut SolveLog,
) -> Result<(Option<Plan>, Probed)> {
    let mut probed = Probed {
        seed: Some(g.clone()),
        ..Probed::default()
    };
    let within = || nlp.remaining(started).map(|n| n.capped(PROBE_MAX_ITER));
    let Some(run) = within() else {
        return Ok((None, probed));
    };
    let wide = with_torque_scale(robot, PROBE_TORQUE_SCALE)?;
    let mut w = plan_single(&wide, task, settings, &run, Some(g))?;
    let kept = w.clone();
    log.record(
        &mut w,
        SolveRole::TorqueScale {
            scale: PROBE_TORQUE_SCALE,
        },
    );
    probed.widened = Some(kept);
    if !w.converged() {
        return Ok((None, probed));
    }
    let within_limits = peak_torques(&w, robot.n - 1)
        .iter()
        .zip(torque_limits(robot))
        .all(|(p, l)| *p <= l);
    if within_limits {
        let Some(run) = within() else {
            return Ok((None, probed));
        };
        let mut p = plan_single(robot, task, settings, &run, Some(&w.points))?;
        log.record(&mut p, SolveRole::TorqueScale { scale: 1.0 });
        if p.converged() {
            return Ok((Some(p), probed));
        }
        return Ok((None, probed));
    }
    // a swing time the planner may choose: the detour at the real limits with T free
    let t = w.swing_time_s;
    let (Some(_), Some(run)) = (longer_swing_settings(settings, t, t), within()) else {
        return Ok((None, probed));
    };
    let free_t = settings.with_free_swing_time(t, [t, PROBE_SWING_TIME_FACTOR * t])?;
    let mut p = plan_single(robot, task, &free_t, &run, Some(&w.points))?;
    let kept = p.clone();
    log.record(
        &mut p,
        SolveRole::LongerSwing {
            t_max_s: PROBE_SWING_TIME_FACTOR * t,
        },
    );
    probed.swing_time = Some(kept);
    Ok((p.converged().then_some(p), probed))
}
