//! The diagnosis's detour as a candidate of the obstacle chain: the best-ranked configuration-space
//! seed ([`super::homotopy`]) planned with every actuator limit widened by
//! [`PROBE_TORQUE_SCALE`] (the torque probe of the diagnosis), and from that plan:
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
use super::torque_continuation::with_torque_scale;
use crate::error::Result;
use crate::model::Robot;
use crate::planning::nlp::NlpSettings;
use crate::planning::outcome::{Plan, SolveRole};
use crate::planning::settings::{Transcription, ValidSettings};
use crate::planning::solve::plan_single;
use crate::planning::solve_log::SolveLog;
use crate::planning::task::ValidTask;
use crate::trajectory::Trajectory;
use std::time::Instant;

/// Factor on every actuator limit of the torque probe (the widest scale of the continuation on the
/// torque limits).
pub const PROBE_TORQUE_SCALE: f64 = 8.0;
/// The swing-time probe searches T in `[T, PROBE_SWING_TIME_FACTOR T]`.
pub const PROBE_SWING_TIME_FACTOR: f64 = 2.0;
/// Iteration limit of one probe solve.
pub const PROBE_MAX_ITER: usize = 1000;

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
    /// Whether the task at the real limits was solved warm from `widened` (converged, its torques
    /// within the real limits).
    pub real_limits_tried: bool,
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

/// Whether `w`'s peak torque per actuated joint over its 1 ms trajectory stays within `robot`'s
/// real limit ([`peak_torques`], [`torque_limits`]).
pub(crate) fn within_limits(robot: &Robot, w: &Plan) -> bool {
    peak_torques(w, robot.n - 1)
        .iter()
        .zip(torque_limits(robot))
        .all(|(p, l)| *p <= l)
}

/// Whether a plan of the task with its swing time free from `t_s` (the detour's swing time, s) is
/// the task's plan: the swing time is `"auto"` without a free range and the transcription is
/// multiple shooting ([`longer_swing_settings`]).
pub(crate) fn swing_time_chosen(settings: &ValidSettings, t_s: f64) -> bool {
    longer_swing_settings(settings, t_s, t_s).is_some()
}

/// The task at the real limits warm from the detour `w` (a plan with wider limits whose torques
/// stay within the real ones, [`within_limits`]) within `run`, recorded in `log`.
pub(crate) fn at_real_limits(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    run: &NlpSettings,
    w: &Plan,
    log: &mut SolveLog,
) -> Result<Plan> {
    let mut p = plan_single(robot, task, settings, run, Some(&w.points))?;
    log.record(&mut p, SolveRole::TorqueScale { scale: 1.0 });
    Ok(p)
}

/// The task at the real limits with the swing time free in `[T, PROBE_SWING_TIME_FACTOR T]` (`T`
/// the swing time of the detour `w`) warm from `w` within `run`, recorded in `log`, with that range;
/// `None` when the transcription has no free swing time or the mesh or the swing-time limit cannot
/// hold the range.
pub(crate) fn free_swing_time(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    run: &NlpSettings,
    w: &Plan,
    log: &mut SolveLog,
) -> Result<Option<(Plan, [f64; 2])>> {
    let t = w.swing_time_s;
    let range_s = [t, PROBE_SWING_TIME_FACTOR * t];
    if settings.transcription != Transcription::MultipleShooting {
        return Ok(None);
    }
    let Ok(free_t) = settings.with_free_swing_time(t, range_s) else {
        return Ok(None);
    };
    let mut p = plan_single(robot, task, &free_t, run, Some(&w.points))?;
    log.record(
        &mut p,
        SolveRole::LongerSwing {
            t_max_s: range_s[1],
        },
    );
    Ok(Some((p, range_s)))
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
    log.record(
        &mut w,
        SolveRole::TorqueScale {
            scale: PROBE_TORQUE_SCALE,
        },
    );
    probed.widened = Some(w.clone());
    if !w.converged() {
        return Ok((None, probed));
    }
    if within_limits(robot, &w) {
        let Some(run) = within() else {
            return Ok((None, probed));
        };
        probed.real_limits_tried = true;
        let p = at_real_limits(robot, task, settings, &run, &w, log)?;
        return Ok((p.converged().then_some(p), probed));
    }
    // a swing time the planner may choose: the detour at the real limits with T free
    let (true, Some(run)) = (swing_time_chosen(settings, w.swing_time_s), within()) else {
        return Ok((None, probed));
    };
    let Some((p, _)) = free_swing_time(robot, task, settings, &run, &w, log)? else {
        return Ok((None, probed));
    };
    probed.swing_time = Some(p.clone());
    Ok((p.converged().then_some(p), probed))
}
