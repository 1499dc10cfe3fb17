//! One seed of the obstacle chain solved coarse to fine: the task on a mesh of knots
//! [`COARSE_KNOT_DT_S`] apart from the seed, capped at [`COARSE_MAX_ITER`] iterations, then on the
//! task's own mesh warm from that plan (also when the coarse solve stopped at its iteration cap),
//! and, for a detour seed or a longer swing (`Again::FromSeed`), when that fine solve ends without
//! a clear plan, once more from the seed itself (a coarse plan that passes through an obstacle
//! between its knots 90 ms apart, or one stopped at its cap, can lead the fine solve into a class it
//! cannot leave: measured on the placement scan, docs/planner-measurements.md); a seed whose coarse
//! solve failed otherwise (locally infeasible, restoration failed) is dropped there
//! (docs/planner.md, "Obstacles on the path"), and after a numerical failure of the coarse mesh (a
//! numerical or an evaluation error) the fine solve starts from the seed. The solve from the seed is
//! [`SolveRole::FromSeed`]; the fine solve warm from the coarse plan keeps the seed's role. The
//! solve again from the seed is a second chance: in the race a later candidate that has converged
//! wins over it ([`super::race`]). A fine solve that stops at its iteration limit is not resumed: on
//! the placement scans no such resume converged (docs/planner-measurements.md).
//!
//! Units: s.

use crate::error::Result;
use crate::model::Robot;
use crate::planning::nlp::{NlpSettings, SolveStatus};
use crate::planning::outcome::{Plan, SolveRole};
use crate::planning::settings::{SwingTime, Transcription, ValidSettings};
use crate::planning::solve::plan_single;
use crate::planning::solve::shooting::yield_to_later;
use crate::planning::strategy::race::{with_first_chance, Plans};
use crate::planning::task::ValidTask;
use crate::trajectory::Trajectory;
use std::time::Instant;

/// Knot spacing of the coarse solve, s (3 times the default 30 ms knots).
pub const COARSE_KNOT_DT_S: f64 = 0.09;
/// Iteration limit of the coarse solve.
pub const COARSE_MAX_ITER: usize = 200;
/// Longest swing the longer-swing candidates may take, as a factor on the automatic swing time; their
/// seeds are timed over that longest swing (measured on the placement scan:
/// docs/planner-measurements.md).
pub const LONGER_SWING_FACTOR: f64 = 2.0;

/// Whether a seed's fine solve warm from the coarse plan that ended without a clear plan is solved
/// once more from the seed itself ([`solve_seed_coarse_to_fine`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Again {
    /// Solved again from the seed (a detour seed: its coarse plan can pass through an obstacle
    /// between its knots 90 ms apart and lead the fine solve into a class it cannot leave).
    FromSeed,
    /// Not solved again (a configuration-space seed at the automatic swing time: on the placement
    /// scans its solve again from the seed never converged where the warm one had not;
    /// docs/planner-measurements.md).
    No,
}

/// The coarse mesh's settings for `settings`: multiple shooting with knots [`COARSE_KNOT_DT_S`]
/// apart and no sub-step refinement (the fine solve keeps the clearance between knots); `None` when
/// the task's own mesh is not finer than half of that, the transcription is a collocation rule, or
/// the swing is too short for the coarse mesh ([`ValidSettings::with_knot_dt`]).
pub(crate) fn coarse_settings(settings: &ValidSettings) -> Option<ValidSettings> {
    if settings.transcription != Transcription::MultipleShooting
        || settings.knot_dt > 0.5 * COARSE_KNOT_DT_S
    {
        return None;
    }
    let s = settings.with_knot_dt(COARSE_KNOT_DT_S).ok()?;
    Some(s.without_substep_clearance())
}

/// Whether a fine solve warm from the coarse plan that ended with `status` is worth solving again
/// from the seed: it stopped for itself (not cancelled, time left), not at a converged clear plan.
fn retry_from_seed(p: &Plan) -> bool {
    !p.converged() && !matches!(p.status, SolveStatus::Cancelled | SolveStatus::MaxWallTime)
}

/// Whether the fine solve starts warm from a coarse plan that ended with `status`: it converged or
/// was still making progress at the cap.
fn coarse_goes_on_warm(status: &SolveStatus) -> bool {
    status.is_converged() || *status == SolveStatus::MaxIterations
}

/// The coarse solve of a seed: `task` on the coarse mesh `cs` from `g`, at most [`COARSE_MAX_ITER`]
/// iterations, pushed to `out`. Whether the fine solve goes on: the coarse plan converged or was
/// still making progress at the cap, it failed numerically (the fine solve then starts from the
/// seed), or the coarse mesh refused the swing (too short for it: solved
/// on the task's mesh only, nothing pushed).
fn coarse_solve(
    robot: &Robot,
    task: &ValidTask,
    cs: &ValidSettings,
    run: &NlpSettings,
    g: &Trajectory,
    out: &mut Plans,
) -> bool {
    let capped = run.clone().capped(COARSE_MAX_ITER);
    let Ok(p) = plan_single(robot, task, cs, &capped, Some(g)) else {
        return true;
    };
    // a numerical failure of the coarse mesh says nothing of the seed: the fine solve starts
    // from the seed
    let ok = coarse_goes_on_warm(&p.status)
        || matches!(
            p.status,
            SolveStatus::NumericalError | SolveStatus::EvaluationError(_)
        );
    out.push((
        SolveRole::CoarseMesh {
            knot_dt_s: COARSE_KNOT_DT_S,
        },
        p,
    ));
    ok
}

/// The fine solve `p` (of the seed's `role`) warm from a coarse plan, and, when it ended without a
/// clear plan ([`retry_from_seed`]) and time is left of `run` counted from `started`, the task
/// solved once more from the seed `g` with `from_seed` (pushing the warm solve to `out` first).
/// The last of these solves with its role ([`SolveRole::FromSeed`] when solved again).
#[allow(clippy::too_many_arguments)]
fn or_from_seed(
    robot: &Robot,
    task: &ValidTask,
    from_seed: &ValidSettings,
    run: &NlpSettings,
    started: Instant,
    g: &Trajectory,
    role: SolveRole,
    p: Plan,
    out: &mut Plans,
) -> Result<(SolveRole, Plan)> {
    if !retry_from_seed(&p) {
        return Ok((role, p));
    }
    let Some(again) = run.remaining(started) else {
        return Ok((role, p));
    };
    // a second chance: a later candidate of the race that has converged wins over it
    yield_to_later();
    let last = plan_single(robot, task, from_seed, &again, Some(g))?;
    out.push((role, p));
    Ok((SolveRole::FromSeed, last))
}

/// Plan `task` from the seed `g` (the solve's `role`) coarse to fine (see the module docs) within
/// `run` (its time limit counted from now for all the solves); solved once more from the seed when
/// the fine solve warm from the coarse plan ended without a clear plan and `again` is
/// [`Again::FromSeed`]. The plans in the order solved.
pub(crate) fn solve_seed_coarse_to_fine(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    run: &NlpSettings,
    g: &Trajectory,
    role: SolveRole,
    again: Again,
) -> Result<Plans> {
    let started = Instant::now();
    let mut out: Plans = vec![];
    if let Some(cs) = coarse_settings(settings) {
        if !coarse_solve(robot, task, &cs, run, g, &mut out) {
            return Ok(out);
        }
    }
    let Some(fine) = run.remaining(started) else {
        return Ok(out);
    };
    // warm from a coarse plan that converged or stopped at its cap; after a numerical failure of
    // the coarse mesh, from the seed
    let warm = out.last().filter(|(_, p)| coarse_goes_on_warm(&p.status));
    let from_coarse = warm.is_some();
    let guess = warm.map_or(g, |(_, p)| &p.points);
    let first = with_first_chance(&fine, settings.knot_dt, guess.duration());
    let p = plan_single(robot, task, settings, &first, Some(guess))?;
    // warm from a coarse plan that passes through an obstacle between its knots, or that stopped at
    // its cap, the fine solve can end locally infeasible where the seed itself plans
    let last = if from_coarse && again == Again::FromSeed {
        or_from_seed(robot, task, settings, run, started, g, role, p, &mut out)?
    } else {
        (role, p)
    };
    out.push(last);
    Ok(out)
}

/// The settings of a swing free to take from `t_s` (the automatic swing time, s) to
/// [`LONGER_SWING_FACTOR`] times it, starting at `t0_s` (an error when its mesh does not fit the
/// grid, [`ValidSettings::with_free_swing_time`]); `None` unless the task's swing time is `"auto"`
/// without a free range and the transcription is multiple shooting (a free swing time's).
pub(crate) fn longer_swing_settings(
    settings: &ValidSettings,
    t_s: f64,
    t0_s: f64,
) -> Option<Result<ValidSettings>> {
    let auto = matches!(settings.swing_time, SwingTime::Auto(_));
    if !auto
        || settings.free_swing_time.is_some()
        || settings.transcription != Transcription::MultipleShooting
    {
        return None;
    }
    Some(settings.with_free_swing_time(t0_s, [t_s, LONGER_SWING_FACTOR * t_s]))
}

/// Plan `task` from the seed `g` with the swing time free between the automatic swing time `t_s`
/// and [`LONGER_SWING_FACTOR`] times it (an obstacle a path must go round may need a slower swing
/// than the torque limits allow at `t_s`), coarse to fine as [`solve_seed_coarse_to_fine`]. `g` is
/// a route timed over the longest swing ([`LONGER_SWING_FACTOR`] `t_s`, where its torques are
/// lowest) and the coarse solve starts there; the fine solve starts at the coarse plan's swing time,
/// warm from it, and, when that ends without a clear plan, once more from `g` at the longest swing.
/// Nothing when the settings do not allow it ([`longer_swing_settings`]).
pub(crate) fn solve_seed_longer_swing(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    run: &NlpSettings,
    g: &Trajectory,
    t_s: f64,
) -> Result<Plans> {
    let started = Instant::now();
    let t_long = LONGER_SWING_FACTOR * t_s;
    // a range the mesh or the swing-time limit cannot hold: not a candidate here
    let Some(Ok(from_seed)) = longer_swing_settings(settings, t_s, t_long) else {
        return Ok(vec![]);
    };
    let role = SolveRole::LongerSwing { t_max_s: t_long };
    let mut out: Plans = vec![];
    // a coarse mesh the longer swing does not fit is skipped
    let coarse =
        coarse_settings(settings).and_then(|cs| longer_swing_settings(&cs, t_s, t_long)?.ok());
    if let Some(cs) = coarse {
        if !coarse_solve(robot, task, &cs, run, g, &mut out) {
            return Ok(out);
        }
    }
    let Some(fine) = run.remaining(started) else {
        return Ok(out);
    };
    // no coarse plan to go on from (none solved, or it failed numerically): from the seed
    let first = with_first_chance(&fine, settings.knot_dt, t_long);
    let Some((_, coarse_plan)) = out.last().filter(|(_, p)| coarse_goes_on_warm(&p.status)) else {
        let p = plan_single(robot, task, &from_seed, &first, Some(g))?;
        out.push((role, p));
        return Ok(out);
    };
    let Some(Ok(warm)) = longer_swing_settings(settings, t_s, coarse_plan.swing_time_s) else {
        // no settings warm at the coarse plan's swing time: the seed at the longer swing time
        let p = plan_single(robot, task, &from_seed, &first, Some(g))?;
        out.push((role, p));
        return Ok(out);
    };
    let warm_points = coarse_plan.points.clone();
    let first_warm = with_first_chance(&fine, settings.knot_dt, coarse_plan.swing_time_s);
    let p = plan_single(robot, task, &warm, &first_warm, Some(&warm_points))?;
    let last = or_from_seed(robot, task, &from_seed, run, started, g, role, p, &mut out)?;
    out.push(last);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The roles of a seed solved coarse to fine with `again`, every solve stopped after 3
    /// iterations (the coarse solve at its cap goes on warm, the fine solve ends without a plan),
    /// from the paper's unobstructed plan as the seed.
    fn roles(again: Again) -> Vec<SolveRole> {
        let (robot, s, task, seed) = crate::planning::strategy::test_swing::paper_swing();
        let short = NlpSettings::default().capped(3);
        let role = SolveRole::CspaceSeed;
        let plans = solve_seed_coarse_to_fine(&robot, &task, &s, &short, &seed.points, role, again)
            .unwrap();
        assert!(plans
            .iter()
            .all(|(_, p)| p.status == SolveStatus::MaxIterations));
        plans.into_iter().map(|(r, _)| r).collect()
    }

    #[test]
    fn a_seed_that_stops_at_its_limit_is_solved_again_from_the_seed_only_when_asked_and_not_resumed(
    ) {
        let coarse = SolveRole::CoarseMesh {
            knot_dt_s: COARSE_KNOT_DT_S,
        };
        assert_eq!(
            roles(Again::FromSeed),
            [coarse, SolveRole::CspaceSeed, SolveRole::FromSeed]
        );
        assert_eq!(roles(Again::No), [coarse, SolveRole::CspaceSeed]);
    }
}
