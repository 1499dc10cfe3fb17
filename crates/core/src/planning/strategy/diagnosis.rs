//! What a placement with no detour within the limits would need: the diagnosis of an obstacle plan
//! that no strategy of [`super::obstacles`] planned.
//!
//! After the obstacle chain fails, the planner ([`crate::planning::plan`]) names the obstacle that
//! blocks the swing and the link it blocks, and probes, within what is left of the call's time
//! limit, how far the task is from planning:
//! 1. an obstacle within the margin of the start pose (or obstacles that leave no pose grasping the
//!    target bar clear, which the task check refuses) blocks every motion: no torque or swing time
//!    helps, nothing is probed ([`Verdict::Unreachable`]);
//! 2. the torque probe plans the task with every actuator limit widened by [`PROBE_TORQUE_SCALE`],
//!    from the obstacle chain's best-ranked configuration-space seed (a path of another homotopy
//!    class, [`super::homotopy`]; the configuration-space seed of the obstacle-free swing when the
//!    chain made none), then from the failed attempt, until one converges: its peak torque per
//!    actuated joint over the 1 ms trajectory, against the real limit, is how much more torque the
//!    detour found needs ([`TorqueProbe`]);
//! 3. from that detour, the swing-time probe plans the task at the real limits with a free swing time
//!    in `[T, PROBE_SWING_TIME_FACTOR T]` (multiple shooting only): the swing time the detour needs
//!    within the limits ([`SwingTimeProbe`]);
//! 4. when no probe converged but the chain's plan or a probe solve converged on its knots and only
//!    its 1 ms trajectory passes inside the margin between them, the closest of them is the verdict
//!    ([`Verdict::ShortBetweenKnots`], [`BetweenKnots`]): a miss between the knots (at the real
//!    limits when the closest is the chain's plan or another of its solves, with the limits widened
//!    when it is a probe's).
//!
//! The chain plans the first probe's seed widened itself, and from it the task at the real limits or
//! with a free swing time (its step 6): a detour within the limits, or one a longer swing makes
//! feasible under `swing_time = "auto"`, is then the chain's plan. What those solves found is
//! handed here and read, not solved again.
//!
//! A probe that finds a plan of the task makes it the call's plan, without a diagnosis: a detour
//! within the limits that the chain did not solve at the real limits is solved there warm from it,
//! and the swing-time probe's plan is the plan when the planner may choose the swing time
//! (`swing_time = "auto"`, the rule of the chain's step 6). Such a plan is converged by the same
//! checks as any plan, lists every solve of the chain and of the probe in its `solves` (and their
//! totals), and keeps the chain's guess report.
//!
//! Each probe is a local search from the guesses named, not a proof: a probe that does not converge
//! says that none was found, not that none exists. The probe's solves are counted in the
//! [`Diagnosis`] (`solves`, `iterations`, `solve_time_s`), not in the plan's `solves`. The call's
//! `max_wall_time_s` bounds them (without one, [`PROBE_WALL_S`] does), and the cancel token stops them:
//! with a limit, the obstacle strategies get all but [`PROBE_SHARE`] of it, and the probe what is left
//! of the whole limit after them.
//!
//! Units: m, s, N m.

use super::cspace::{cspace_routes, time_path};
use super::obstacles::diagnose;
use super::torque_continuation::with_torque_scale;
use super::widened::{
    at_real_limits, free_swing_time, peak_torques, swing_time_chosen, torque_limits, within_limits,
    Probed,
};
pub use super::widened::{PROBE_MAX_ITER, PROBE_SWING_TIME_FACTOR, PROBE_TORQUE_SCALE};
use crate::error::Result;
use crate::model::{ClearanceFn, ClearancePair, Robot};
use crate::planning::grasp::grasp_blocked;
use crate::planning::nlp::NlpSettings;
use crate::planning::outcome::{Plan, SolveRole};
use crate::planning::report::{
    BetweenKnots, Diagnosis, GuessReport, ProbeSolve, SwingTimeProbe, TorqueProbe, Verdict,
};
use crate::planning::settings::{PlannerSettings, Transcription, ValidSettings};
use crate::planning::solve::plan_single;
use crate::planning::solve_log::SolveLog;
use crate::planning::task::{SwingTask, ValidTask};
use crate::trajectory::Trajectory;
use std::time::Instant;

/// Time limit of the whole probe when the call has no `max_wall_time_s`, s.
pub const PROBE_WALL_S: f64 = 30.0;
/// Share of the call's `max_wall_time_s` kept for the probe: the obstacle strategies get the rest.
pub const PROBE_SHARE: f64 = 0.25;

/// The probe's solves and their cost, and the log of the call's solves: the chain's, then the
/// probe's (for a plan the probe finds).
struct Cost {
    solves: usize,
    iterations: usize,
    time_s: f64,
    log: SolveLog,
}

impl Cost {
    /// No probe solve yet, after the chain's plan `chain`.
    fn after(chain: &Plan) -> Self {
        Self {
            solves: 0,
            iterations: 0,
            time_s: 0.0,
            log: SolveLog::resume(chain),
        }
    }

    /// Count the probe solve that produced `p`, recorded for `role`.
    fn add(&mut self, p: &mut Plan, role: SolveRole) {
        self.count(p);
        self.log.record(p, role);
    }

    /// Count the probe solve that produced `p`, recorded in the log already.
    fn count(&mut self, p: &Plan) {
        self.solves += 1;
        self.iterations += p.iterations;
        self.time_s += p.solve_time_s;
    }

    /// `p`, a converged plan of a probe solve, as the call's plan: every solve of the chain and the
    /// probe in its `solves` and totals, the chain's guess report `guess`, no diagnosis.
    fn adopt(self, mut p: Plan, guess: Option<GuessReport>) -> Plan {
        self.log.finish(&mut p);
        p.guess = guess;
        (p.blockage, p.diagnosis) = (None, None);
        p
    }
}

/// What the probes gave: the diagnosis of the failure, or a plan of the task they found.
enum Probe {
    Diagnosis(Box<Option<Diagnosis>>),
    Plan(Box<Plan>),
}

/// The settings of the obstacle strategies of a call with `nlp`: its time limit less the share
/// [`PROBE_SHARE`] kept for the probe; a copy without a limit.
pub(crate) fn strategies_share(nlp: &NlpSettings) -> NlpSettings {
    NlpSettings {
        max_wall_time_s: nlp.max_wall_time_s.map(|w| w * (1.0 - PROBE_SHARE)),
        ..nlp.clone()
    }
}

/// Attach a [`Diagnosis`] to `p`, the result of the obstacle chain for a call that began at
/// `started`, when it did not converge and the call was not cancelled (see the module docs).
pub(crate) fn diagnose_failure(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    mut p: Plan,
    started: Instant,
    probed: &Probed,
) -> Result<Plan> {
    if p.converged() || nlp.is_cancelled() || task.obstacles.is_empty() {
        return Ok(p);
    }
    p.diagnosis = match probe(robot, task, settings, nlp, &p, started, probed)? {
        Probe::Diagnosis(d) => *d,
        Probe::Plan(q) => return Ok(*q),
    };
    // the chain's searches: every one exhausted without a path
    let routes = p.guess.as_ref().map_or(&[][..], |g| &g.cspace_routes[..]);
    let exhausted = !routes.is_empty() && routes.iter().all(|r| r.exhausted && !r.found);
    if let Some(d) = p.diagnosis.as_mut() {
        d.paths_exhausted = exhausted && d.verdict != Verdict::Unreachable;
    }
    Ok(p)
}

/// The obstacle and link that block `task` when no motion can clear them: obstacles that block every
/// pose grasping the bar ([`crate::planning::grasp::grasp_blocked`]: the link that comes closest to
/// an obstacle in the poses that keep the most clearance, and that obstacle; the task check refuses
/// such a task, so this holds only for a task checked with other bounds or margin), or one within
/// the margin of the start pose (its closest link there).
fn unreachable(
    robot: &Robot,
    task: &SwingTask,
    settings: &PlannerSettings,
) -> Result<Option<(usize, usize)>> {
    let margin = settings.obstacle_margin;
    if let Some(b) = grasp_blocked(
        robot,
        task.target,
        &task.obstacles,
        margin,
        &settings.bounds,
    ) {
        return Ok(Some((b.link_obstacle, b.link)));
    }
    for (i, o) in task.obstacles.iter().enumerate() {
        let one = [*o];
        let cf = ClearanceFn::new(robot.clone(), &one[..], 0.0)?.with_self_collision(false);
        let mut d = vec![0.0; cf.pairs().len()];
        cf.surface_distances(&task.q0, &mut d);
        let closest = cf
            .pairs()
            .iter()
            .zip(&d)
            .filter_map(|(pair, &v)| match *pair {
                ClearancePair::LinkObstacle { link, .. } if v < margin => Some((link, v)),
                _ => None,
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((link, _)) = closest {
            return Ok(Some((i, link)));
        }
    }
    Ok(None)
}

/// The diagnosis of the failed plan `p` (see the module docs), `None` when no clearance row names
/// an obstacle; or the plan a probe found (see the module docs).
fn probe(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    p: &Plan,
    started: Instant,
    probed: &Probed,
) -> Result<Probe> {
    let mut d = Diagnosis {
        obstacle: 0,
        link: 0,
        verdict: Verdict::NoDetourFound,
        swing_time_s: p.swing_time_s,
        torque_probe: None,
        swing_time_probe: None,
        out_of_time: false,
        solves: 0,
        iterations: 0,
        solve_time_s: 0.0,
        paths_exhausted: false,
        between_knots: None,
    };
    if let Some((o, l)) = unreachable(robot, task, settings)? {
        (d.obstacle, d.link, d.verdict) = (o, l, Verdict::Unreachable);
        return Ok(Probe::Diagnosis(Box::new(Some(d))));
    }
    let named = match &p.blockage {
        Some(b) => Some((b.obstacle, b.link)),
        None => diagnose(robot, task, settings, &p.points, None)?.map(|b| (b.obstacle, b.link)),
    };
    // the probe's own limit when the call has none
    let (limit, t0) = match nlp.max_wall_time_s {
        Some(_) => (nlp.clone(), started),
        None => (
            NlpSettings {
                max_wall_time_s: Some(PROBE_WALL_S),
                ..nlp.clone()
            },
            Instant::now(),
        ),
    };
    let within = || limit.remaining(t0).map(|n| n.capped(PROBE_MAX_ITER));
    let mut cost = Cost::after(p);
    // a probe solve the library refuses (it is no failure of the task) leaves that probe out
    let (tp, detour) =
        torque_probe(robot, task, settings, p, &within, &mut cost, probed).unwrap_or((None, None));
    // a detour within the limits that the chain did not solve at the real limits: solved there
    if let (Some(w), Some(run)) = (&detour, within()) {
        if !probed.real_limits_tried && within_limits(robot, w) {
            let q = at_real_limits(robot, task, settings, &run, w, &mut cost.log);
            if let Ok(q) = q {
                cost.count(&q);
                if q.converged() {
                    return Ok(Probe::Plan(Box::new(cost.adopt(q, p.guess.clone()))));
                }
            }
        }
    }
    // the detour found names the obstacle it goes around when the failed attempt named none
    let named = named.or(match &detour {
        Some(w) => diagnose(robot, task, settings, &w.points, None)?.map(|b| (b.obstacle, b.link)),
        None => None,
    });
    let Some((obstacle, link)) = named else {
        return Ok(Probe::Diagnosis(Box::new(None)));
    };
    (d.obstacle, d.link) = (obstacle, link);
    if let Some(tp) = &tp {
        if tp.converged {
            d.verdict = if tp.ratio.iter().all(|&r| r <= 1.0) {
                Verdict::DetourWithinLimits
            } else {
                Verdict::NeedsTorque
            };
        }
    }
    if let (Some(w), Verdict::NeedsTorque) = (&detour, d.verdict) {
        d.swing_time_probe = match &probed.swing_time {
            // the chain planned it from the same detour
            Some(q) => Some(SwingTimeProbe {
                range_s: [w.swing_time_s, PROBE_SWING_TIME_FACTOR * w.swing_time_s],
                converged: q.converged(),
                swing_time_s: q.converged().then_some(q.swing_time_s),
            }),
            None => match swing_time_probe(robot, task, settings, w, &within, &mut cost) {
                // a swing time the planner may choose: the probe's plan is the plan
                Ok(Some((sp, Some(q))))
                    if sp.converged && swing_time_chosen(settings, sp.range_s[0]) =>
                {
                    return Ok(Probe::Plan(Box::new(cost.adopt(q, p.guess.clone()))));
                }
                Ok(Some((sp, _))) => Some(sp),
                _ => None,
            },
        };
        if d.swing_time_probe.as_ref().is_some_and(|s| s.converged) {
            d.verdict = Verdict::NeedsSwingTime;
        }
    }
    d.between_knots = between_knots_for(d.verdict, p, tp.as_ref());
    if d.between_knots.is_some() {
        d.verdict = Verdict::ShortBetweenKnots;
    }
    d.torque_probe = tp;
    d.out_of_time = limit.remaining(t0).is_none();
    (d.solves, d.iterations, d.solve_time_s) = (cost.solves, cost.iterations, cost.time_s);
    Ok(Probe::Diagnosis(Box::new(Some(d))))
}

/// Of the strategies' plan `p` (at the real limits), its other solves at the real limits on the
/// task's own mesh (each attempt's [`crate::planning::SolveAttempt::between_knots`]: a detour or
/// C-space seed's solve on the knots whose solve with the rows at the sub-steps then stopped, say)
/// and the torque probe's solves `tp`, the one that converged on its knots with the smallest
/// shortfall of clearance between them (the real limits first at equal shortfall, `p` itself first
/// of those); `None` when none converged on its knots.
fn closest_between_knots(p: &Plan, tp: Option<&TorqueProbe>) -> Option<BetweenKnots> {
    let own = p
        .status
        .is_converged()
        .then_some(p.clearance_violation)
        .flatten()
        .map(|v| BetweenKnots {
            solve: "plan".to_string(),
            torque_scale: 1.0,
            violation: v,
        });
    let probed = tp.into_iter().flat_map(|t| {
        t.tried.iter().filter_map(|s| {
            s.between_knots.map(|v| BetweenKnots {
                solve: s.guess.clone(),
                torque_scale: t.scale,
                violation: v,
            })
        })
    });
    let solves = p
        .solves
        .iter()
        .filter(|a| {
            a.status.is_converged() && of_the_task(a.role) && a.within.is_none_or(of_the_task)
        })
        .filter_map(|a| {
            a.between_knots.map(|v| BetweenKnots {
                solve: a.within.unwrap_or(a.role).to_string(),
                torque_scale: 1.0,
                violation: v,
            })
        });
    own.into_iter().chain(solves).chain(probed).min_by(|a, b| {
        let key = |x: &BetweenKnots| (x.violation.shortfall_m(), x.torque_scale);
        key(a)
            .partial_cmp(&key(b))
            .unwrap_or(std::cmp::Ordering::Equal)
    })
}

/// The solve that turns `verdict` into [`Verdict::ShortBetweenKnots`]: where no detour was found,
/// the closest of every solve that converged on its knots ([`closest_between_knots`]); where the
/// widened probe's detour needs more torque, the closest at the real limits only (a detour within
/// the limits nearly exists, which says more than the torque the widened one takes; the probe's
/// finding stays in the diagnosis); `None` for the other verdicts.
fn between_knots_for(verdict: Verdict, p: &Plan, tp: Option<&TorqueProbe>) -> Option<BetweenKnots> {
    match verdict {
        Verdict::NoDetourFound => closest_between_knots(p, tp),
        Verdict::NeedsTorque => closest_between_knots(p, None),
        _ => None,
    }
}

/// Whether a solve of `role` solves the task itself on its own mesh at the real limits: not a
/// coarse mesh, scaled obstacle radii, widened limits or the task without its obstacles.
fn of_the_task(role: SolveRole) -> bool {
    match role {
        SolveRole::CoarseMesh { .. }
        | SolveRole::ObstacleScale { .. }
        | SolveRole::ObstacleFree => false,
        SolveRole::TorqueScale { scale } => scale == 1.0,
        _ => true,
    }
}

/// The guess of the torque probe before the failed attempt: the configuration-space seed of the
/// obstacle-free swing (planned here), named; empty when the obstacle-free swing does not plan, the
/// search finds no path or the time is spent.
fn seeds(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    within: &dyn Fn() -> Option<NlpSettings>,
    cost: &mut Cost,
) -> Result<Vec<(String, Trajectory)>> {
    let Some(run) = within() else {
        return Ok(vec![]);
    };
    let no_obstacles = task.without_obstacles();
    let mut free = plan_single(robot, &no_obstacles, settings, &run, None)?;
    cost.add(&mut free, SolveRole::ObstacleFree);
    if !free.converged() {
        return Ok(vec![]);
    }
    if within().is_none() {
        return Ok(vec![]);
    }
    // the C-space seed: its path leaves the obstacle-free swing's homotopy class, which is what a
    // swept obstacle needs, and what widened limits make dynamically feasible (the detour seeds,
    // which stay in that class, are not tried: widened, they end locally infeasible where the
    // strategies' solves did)
    let stop = || within().is_none();
    let pts = &free.points;
    let (q0, q1) = (pts.q(0), pts.q(pts.len() - 1));
    let mut routes = cspace_routes(robot, &task.obstacles, settings, q0, q1, 1, &stop)?;
    Ok(match routes.pop() {
        Some((mut rep, Some(path))) => {
            vec![(
                "cspace-seed".to_string(),
                time_path(robot, &path, pts, &mut rep),
            )]
        }
        _ => vec![],
    })
}

/// The torque probe (see the module docs) and the plan it converged to; `(None, None)` when no
/// time was left for its first solve.
fn torque_probe(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    failed: &Plan,
    within: &dyn Fn() -> Option<NlpSettings>,
    cost: &mut Cost,
    probed: &Probed,
) -> Result<(Option<TorqueProbe>, Option<Plan>)> {
    let m = robot.n - 1;
    let limit_nm = torque_limits(robot);
    let wide = with_torque_scale(robot, PROBE_TORQUE_SCALE)?;
    let mut rep = TorqueProbe {
        scale: PROBE_TORQUE_SCALE,
        converged: false,
        guess: String::new(),
        peak_torque_nm: vec![],
        limit_nm,
        ratio: vec![],
        tried: vec![],
    };
    // the collision-free seeds first, the failed attempt (through the obstacle) last; the chain's
    // widened plan from its best C-space seed is that seed's probe, read, not solved again
    // (a guess of `None`: the chain's plan)
    let mut guesses: Vec<(String, Option<Trajectory>)> = match (&probed.widened, &probed.seed) {
        (Some(_), _) => vec![("cspace-seed".to_string(), None)],
        (None, Some(g)) => vec![("cspace-seed".to_string(), Some(g.clone()))],
        (None, None) => seeds(robot, task, settings, within, cost)?
            .into_iter()
            .map(|(n, g)| (n, Some(g)))
            .collect(),
    };
    guesses.push(("failed-attempt".to_string(), Some(failed.points.clone())));
    let mut tried = false;
    for (name, g) in guesses {
        let w = match (g, &probed.widened) {
            (Some(g), _) => {
                let Some(run) = within() else {
                    break;
                };
                let mut w = plan_single(&wide, task, settings, &run, Some(&g))?;
                cost.add(
                    &mut w,
                    SolveRole::TorqueScale {
                        scale: PROBE_TORQUE_SCALE,
                    },
                );
                w
            }
            (None, Some(w)) => w.clone(),
            (None, None) => continue,
        };
        tried = true;
        rep.tried.push(ProbeSolve {
            guess: name.clone(),
            status: w.status.clone(),
            between_knots: w
                .status
                .is_converged()
                .then_some(w.clearance_violation)
                .flatten(),
        });
        rep.guess = name;
        if w.converged() {
            rep.converged = true;
            rep.peak_torque_nm = peak_torques(&w, m);
            rep.ratio = rep
                .peak_torque_nm
                .iter()
                .zip(&rep.limit_nm)
                .map(|(p, l)| p / l)
                .collect();
            return Ok((Some(rep), Some(w)));
        }
    }
    Ok((tried.then_some(rep), None))
}

/// The swing-time probe from the widened detour `w` (see the module docs), with its plan when it
/// converged; `None` when the transcription has no free swing time or no time is left.
fn swing_time_probe(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    w: &Plan,
    within: &dyn Fn() -> Option<NlpSettings>,
    cost: &mut Cost,
) -> Result<Option<(SwingTimeProbe, Option<Plan>)>> {
    if settings.transcription != Transcription::MultipleShooting {
        return Ok(None);
    }
    let Some(run) = within() else {
        return Ok(None);
    };
    let Some((p, range_s)) = free_swing_time(robot, task, settings, &run, w, &mut cost.log)? else {
        return Ok(None);
    };
    cost.count(&p);
    let rep = SwingTimeProbe {
        range_s,
        converged: p.converged(),
        swing_time_s: p.converged().then_some(p.swing_time_s),
    };
    Ok(Some((rep, p.converged().then_some(p))))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::Circle;
    use crate::CancelToken;

    /// The paper's task with an obstacle on the swing's path, and a failed plan of it: one solve
    /// cut at 3 iterations.
    fn failed() -> (Robot, ValidTask, ValidSettings, Plan) {
        let robot = Robot::paper();
        let task = SwingTask {
            obstacles: vec![Circle {
                center: [0.2, -0.9],
                radius: 0.1,
            }],
            ..SwingTask::paper()
        };
        let s = ValidSettings::new(PlannerSettings::default(), robot.n, "test").unwrap();
        let task = ValidTask::new(&robot, task, &s, "task", "").unwrap();
        let nlp = NlpSettings {
            max_iter: 3,
            ..Default::default()
        };
        let p = plan_single(&robot, &task, &s, &nlp, None).unwrap();
        assert!(!p.converged());
        (robot, task, s, p)
    }

    #[test]
    fn a_cancelled_call_gets_no_diagnosis() {
        let (robot, task, s, p) = failed();
        let cancel = CancelToken::new();
        cancel.cancel();
        let nlp = NlpSettings {
            cancel: Some(cancel),
            ..Default::default()
        };
        let p = diagnose_failure(
            &robot,
            &task,
            &s,
            &nlp,
            p,
            Instant::now(),
            &Probed::default(),
        )
        .unwrap();
        assert!(p.diagnosis.is_none());
    }

    /// The role of attempt `a`'s solve.
    fn role(a: &crate::planning::outcome::SolveAttempt) -> SolveRole {
        a.within.unwrap_or(a.role)
    }

    #[test]
    fn a_detour_within_the_limits_that_the_probe_finds_is_the_plan() {
        let (robot, task, s, mut p) = failed();
        let guess = empty_guess(&p);
        p.guess = Some(guess.clone());
        let chain = p.solves.clone();
        let q = diagnose_failure(
            &robot,
            &task,
            &s,
            &NlpSettings::default(),
            p,
            Instant::now(),
            &Probed::default(),
        )
        .unwrap();
        assert!(q.converged(), "{:?} {:?}", q.status, q.diagnosis);
        assert!(q.diagnosis.is_none() && q.blockage.is_none());
        assert_eq!(q.guess, Some(guess));
        assert!(crate::planning::solve_log::audit(&q).is_empty());
        // the chain's solve first, then the probe's: the obstacle-free swing, the widened detour and
        // the task at the real limits from it, which is the plan
        assert_eq!(q.solves[0].status, chain[0].status);
        assert!(!q.solves[0].adopted);
        let roles: Vec<SolveRole> = q.solves.iter().map(role).collect();
        for r in [
            SolveRole::ObstacleFree,
            SolveRole::TorqueScale {
                scale: PROBE_TORQUE_SCALE,
            },
            SolveRole::TorqueScale { scale: 1.0 },
        ] {
            assert!(roles.contains(&r), "{roles:?}");
        }
        let adopted = q.solves.iter().find(|a| a.adopted).unwrap();
        assert_eq!(role(adopted), SolveRole::TorqueScale { scale: 1.0 });
        assert!(q.solves.iter().any(|a| a.solve > chain[0].solve));
    }

    #[test]
    fn a_detour_the_chain_solved_at_the_real_limits_is_not_solved_again() {
        let (robot, task, s, p) = failed();
        let nlp = NlpSettings::default();
        let diagnosed = |p: Plan, probed: &Probed| {
            diagnose_failure(&robot, &task, &s, &nlp, p, Instant::now(), probed).unwrap()
        };
        // a detour within the limits: a plan at the real limits
        let w = diagnosed(p.clone(), &Probed::default());
        assert!(w.converged() && within_limits(&robot, &w));
        let probed = Probed {
            seed: Some(p.points.clone()),
            widened: Some(w),
            swing_time: None,
            real_limits_tried: true,
        };
        let q = diagnosed(p, &probed);
        assert!(!q.converged());
        let d = q.diagnosis.expect("a diagnosis");
        assert_eq!(d.verdict, Verdict::DetourWithinLimits);
        assert_eq!(d.solves, 0, "{d:?}");
        assert_eq!(q.solves.len(), 1);
    }

    /// With every actuator limit at 0.35 of the paper's, the detour at the real limits needs a longer
    /// swing than the automatic one.
    #[test]
    fn the_swing_time_probes_plan_is_the_plan_only_when_the_swing_time_may_be_chosen() {
        use crate::planning::settings::SwingTime;
        let (robot, task, _, _) = failed();
        let weak = with_torque_scale(&robot, 0.35).unwrap();
        let plan = |swing_time: SwingTime| {
            let ps = PlannerSettings {
                swing_time,
                ..PlannerSettings::default()
            };
            let s = ValidSettings::new(ps, robot.n, "test").unwrap();
            let cut = NlpSettings {
                max_iter: 3,
                ..Default::default()
            };
            let p = plan_single(&weak, &task, &s, &cut, None).unwrap();
            let t = p.swing_time_s;
            let nlp = NlpSettings::default();
            let q = diagnose_failure(
                &weak,
                &task,
                &s,
                &nlp,
                p,
                Instant::now(),
                &Probed::default(),
            );
            (q.unwrap(), t)
        };
        let (q, t) = plan(PlannerSettings::default().swing_time);
        assert!(q.converged(), "{:?} {:?}", q.status, q.diagnosis);
        assert!(
            q.diagnosis.is_none() && q.swing_time_s > t,
            "{} {t}",
            q.swing_time_s
        );
        assert!(crate::planning::solve_log::audit(&q).is_empty());
        let adopted = q.solves.iter().find(|a| a.adopted).unwrap();
        assert!(matches!(role(adopted), SolveRole::LongerSwing { .. }));
        // a swing time the user fixed: the diagnosis says what it would need
        let (q, _) = plan(SwingTime::Seconds(2.0));
        assert!(!q.converged() && q.swing_time_s == 2.0);
        let d = q.diagnosis.expect("a diagnosis");
        assert_eq!(d.verdict, Verdict::NeedsSwingTime);
    }

    #[test]
    fn a_spent_time_limit_names_the_obstacle_and_runs_no_probe() {
        let (robot, task, s, p) = failed();
        let nlp = NlpSettings {
            max_wall_time_s: Some(1e-9),
            ..Default::default()
        };
        let d = probe(
            &robot,
            &task,
            &s,
            &nlp,
            &p,
            Instant::now(),
            &Probed::default(),
        )
        .unwrap();
        let Probe::Diagnosis(d) = d else {
            panic!("a diagnosis");
        };
        let d = d.expect("a diagnosis");
        assert_eq!(d.obstacle, 0);
        assert!(d.link < robot.n);
        assert_eq!(d.verdict, Verdict::NoDetourFound);
        assert!(
            d.torque_probe.is_none() && d.swing_time_probe.is_none(),
            "{d:?}"
        );
        assert!(d.out_of_time && d.solves == 0, "{d:?}");
        assert!(d.to_string().contains("no time was left"), "{d}");
    }

    #[test]
    fn the_strategies_get_all_but_the_probes_share_of_the_limit() {
        let nlp = NlpSettings {
            max_wall_time_s: Some(10.0),
            ..Default::default()
        };
        let w = strategies_share(&nlp).max_wall_time_s.unwrap();
        assert!((w - 10.0 * (1.0 - PROBE_SHARE)).abs() < 1e-12, "{w}");
        assert_eq!(
            strategies_share(&NlpSettings::default()).max_wall_time_s,
            None
        );
    }

    #[test]
    fn exhausted_path_searches_are_in_the_message() {
        let mut d = Diagnosis {
            obstacle: 0,
            link: 1,
            verdict: Verdict::NoDetourFound,
            swing_time_s: 2.0,
            torque_probe: None,
            swing_time_probe: None,
            out_of_time: false,
            solves: 0,
            iterations: 0,
            solve_time_s: 0.0,
            paths_exhausted: false,
            between_knots: None,
        };
        assert!(!d.to_string().contains("no collision-free path"), "{d}");
        d.paths_exhausted = true;
        let msg = d.to_string();
        assert!(
            msg.starts_with("obstacle 0 blocks link 2") && msg.contains("no collision-free path"),
            "{msg}"
        );
    }

    /// A diagnosis of link 3 and obstacle 0 on a 2 s swing with `verdict`, the torque probe `tp`
    /// and the solve short between its knots `b`.
    fn diagnosis_of(
        verdict: Verdict,
        tp: Option<TorqueProbe>,
        b: Option<BetweenKnots>,
    ) -> Diagnosis {
        Diagnosis {
            obstacle: 0,
            link: 2,
            verdict,
            swing_time_s: 2.0,
            torque_probe: tp,
            swing_time_probe: None,
            out_of_time: false,
            solves: 1,
            iterations: 10,
            solve_time_s: 0.1,
            paths_exhausted: false,
            between_knots: b,
        }
    }

    /// A violation of the 10 mm margin by `short` m, link 3 and obstacle 0 at 1.2 s.
    fn short_by(short: f64) -> crate::planning::ClearanceViolation {
        crate::planning::ClearanceViolation {
            subject: crate::planning::ClearanceSubject::Obstacle {
                obstacle: 0,
                link: 2,
            },
            time_s: 1.2,
            clearance_m: 0.01 - short,
            required_m: 0.01,
            tolerance_m: 0.001,
        }
    }

    /// A torque probe at 8x that found no detour: its C-space seed's solve converged on its knots
    /// 2.1 mm short between them, its failed attempt's ended locally infeasible.
    fn failed_probe() -> TorqueProbe {
        TorqueProbe {
            scale: 8.0,
            converged: false,
            guess: "failed-attempt".into(),
            peak_torque_nm: vec![],
            limit_nm: vec![5.0; 3],
            ratio: vec![],
            tried: vec![
                ProbeSolve {
                    guess: "cspace-seed".into(),
                    status: crate::planning::nlp::SolveStatus::Solved,
                    between_knots: Some(short_by(0.0021)),
                },
                ProbeSolve {
                    guess: "failed-attempt".into(),
                    status: crate::planning::nlp::SolveStatus::LocallyInfeasible,
                    between_knots: None,
                },
            ],
        }
    }

    /// A failure whose solves converge on their knots but pass inside the margin between them gets
    /// its own verdict: the closest of them (the strategies' plan at the real limits, or a widened
    /// probe solve) with its shortfall in mm and where, and no claim about widened torque limits; a
    /// failure where nothing converged keeps "no detour was found".
    #[test]
    fn a_detour_short_only_between_its_knots_is_told_apart_from_no_detour() {
        let (_, _, _, mut p) = failed();
        let tp = failed_probe();
        // the strategies' plan did not converge: the probe's solve is the closest
        assert!(!p.status.is_converged());
        let b = closest_between_knots(&p, Some(&tp)).expect("one converged on its knots");
        assert_eq!((b.solve.as_str(), b.torque_scale), ("cspace-seed", 8.0));
        // a plan at the real limits 1.3 mm short is closer
        p.status = crate::planning::nlp::SolveStatus::Solved;
        p.clearance_violation = Some(short_by(0.0013));
        let b = closest_between_knots(&p, Some(&tp)).expect("one converged on its knots");
        assert_eq!((b.solve.as_str(), b.torque_scale), ("plan", 1.0));
        let mut d = diagnosis_of(Verdict::ShortBetweenKnots, Some(tp.clone()), Some(b));
        let msg = d.to_string();
        for want in [
            "obstacle 0 blocks link 3",
            "converged on its knots (the strategies' best plan, at the real limits)",
            "1.3 mm inside the margin between them",
            "link 3 and obstacle 0 at t = 1.200 s",
        ] {
            assert!(msg.contains(want), "{want}: {msg}");
        }
        assert!(!msg.contains("widened 8x either"), "{msg}");
        // nothing converged on its knots: no detour was found
        p.status = crate::planning::nlp::SolveStatus::LocallyInfeasible;
        let mut none = tp;
        none.tried.truncate(0);
        assert_eq!(closest_between_knots(&p, Some(&none)), None);
        d.verdict = Verdict::NoDetourFound;
        d.between_knots = None;
        d.torque_probe = Some(none);
        assert!(d.to_string().contains("no detour was found"), "{d}");
        let json = serde_json::to_string(&d).unwrap();
        assert!(!json.contains("between_knots"), "{json}");
    }

    /// The strategies' other solves at the real limits on the task's own mesh that converged on
    /// their knots (each attempt's `between_knots`) are weighed with the plan and the probe: the
    /// closest is named by its role; a coarse-mesh solve, one with widened limits or scaled radii,
    /// or one that did not converge is not weighed.
    #[test]
    fn a_solve_of_the_strategies_short_only_between_its_knots_is_named() {
        let (_, _, _, mut p) = failed();
        let mut tp = failed_probe();
        tp.tried.truncate(1);
        let base = p.solves[0].clone();
        let attempt = |role: SolveRole, within: Option<SolveRole>, short: f64, converged: bool| {
            let mut a = base.clone();
            a.role = role;
            a.within = within;
            a.between_knots = Some(short_by(short));
            if converged {
                a.status = crate::planning::nlp::SolveStatus::Solved;
            }
            a
        };
        // closer than the probe, but not weighed: a coarse mesh, widened limits, scaled radii, a
        // solve that did not converge
        let longer = SolveRole::LongerSwing { t_max_s: 4.0 };
        p.solves.extend([
            attempt(
                SolveRole::CoarseMesh { knot_dt_s: 0.09 },
                None,
                0.0001,
                true,
            ),
            attempt(SolveRole::TorqueScale { scale: 2.0 }, None, 0.0001, true),
            attempt(SolveRole::ObstacleScale { scale: 0.5 }, None, 0.0001, true),
            attempt(SolveRole::FromSeed, None, 0.0001, false),
            attempt(
                SolveRole::FreeTimeStart { t0_s: 2.0 },
                Some(SolveRole::TorqueScale { scale: 8.0 }),
                0.0001,
                true,
            ),
        ]);
        let b = closest_between_knots(&p, Some(&tp)).expect("one converged on its knots");
        assert_eq!((b.solve.as_str(), b.torque_scale), ("cspace-seed", 8.0));
        // a start of the longer swing at the real limits 0.8 mm short is the closest, named by the
        // solve it is a start of
        let start = SolveRole::FreeTimeStart { t0_s: 4.0 };
        p.solves.push(attempt(start, Some(longer), 0.0008, true));
        let b = closest_between_knots(&p, Some(&tp)).expect("one converged on its knots");
        assert_eq!(b.solve, "swing time free up to 4.0000 s");
        assert_eq!((b.torque_scale, b.violation), (1.0, short_by(0.0008)));
        let d = diagnosis_of(Verdict::ShortBetweenKnots, Some(tp.clone()), Some(b));
        let msg = d.to_string();
        for want in [
            "(the strategies' solve \"swing time free up to 4.0000 s\", at the real limits)",
            "0.8 mm inside the margin between them",
        ] {
            assert!(msg.contains(want), "{want}: {msg}");
        }
        // the probe's solve is closer than a solve 3 mm short
        p.solves.last_mut().unwrap().between_knots = Some(short_by(0.003));
        let b = closest_between_knots(&p, Some(&tp)).expect("one converged on its knots");
        assert_eq!((b.solve.as_str(), b.torque_scale), ("cspace-seed", 8.0));
    }

    /// A solve at the real limits short only between its knots turns `needs_torque` into
    /// `short_between_knots`; a widened probe's solve does that for `no_detour_found` only, and no
    /// solve changes the other verdicts.
    #[test]
    fn a_solve_at_the_real_limits_short_between_its_knots_outweighs_the_torque_need() {
        let (_, _, _, mut p) = failed();
        let tp = TorqueProbe {
            scale: 8.0,
            converged: true,
            guess: "cspace-seed".into(),
            peak_torque_nm: vec![0.0, 20.0, 0.0],
            limit_nm: vec![5.0; 3],
            ratio: vec![0.0, 4.0, 0.0],
            tried: vec![ProbeSolve {
                guess: "cspace-seed".into(),
                status: crate::planning::nlp::SolveStatus::Solved,
                between_knots: Some(short_by(0.0021)),
            }],
        };
        // only the widened probe's solve fell short between its knots
        assert_eq!(between_knots_for(Verdict::NeedsTorque, &p, Some(&tp)), None);
        let b = between_knots_for(Verdict::NoDetourFound, &p, Some(&tp)).expect("the probe's");
        assert_eq!(b.torque_scale, 8.0);
        // a solve at the real limits did too
        let mut a = p.solves[0].clone();
        a.status = crate::planning::nlp::SolveStatus::Solved;
        a.role = SolveRole::LongerSwing { t_max_s: 4.0 };
        a.between_knots = Some(short_by(0.004));
        p.solves.push(a);
        let b = between_knots_for(Verdict::NeedsTorque, &p, Some(&tp)).expect("at the real limits");
        assert_eq!((b.torque_scale, b.violation), (1.0, short_by(0.004)));
        for v in [
            Verdict::NeedsSwingTime,
            Verdict::DetourWithinLimits,
            Verdict::Unreachable,
        ] {
            assert_eq!(between_knots_for(v, &p, Some(&tp)), None, "{v:?}");
        }
    }

    /// The guess report of a chain that made the one solve of `p`.
    fn empty_guess(p: &Plan) -> GuessReport {
        GuessReport {
            strategy: crate::planning::report::GuessStrategy::SmoothStep,
            smooth_step_clear: false,
            solves: 1,
            iterations: p.iterations,
            solve_time_s: p.solve_time_s,
            scales: vec![],
            seeds: vec![],
            cspace: None,
            cspace_routes: vec![],
            out_of_time: false,
        }
    }

    /// A widened probe's plan whose peak torque sits on the widened limit says so: its ratio is the
    /// bound searched, not a measured need; one below the widened limit does not.
    #[test]
    fn a_peak_torque_on_the_widened_limit_is_not_read_as_a_need() {
        let msg = |ratio: f64| {
            diagnosis_of(
                Verdict::NeedsTorque,
                Some(TorqueProbe {
                    scale: 8.0,
                    converged: true,
                    guess: "cspace-seed".into(),
                    peak_torque_nm: vec![0.0, 5.0 * ratio, 0.0],
                    limit_nm: vec![5.0; 3],
                    ratio: vec![0.1, ratio, 0.1],
                    tried: vec![],
                }),
                None,
            )
            .to_string()
        };
        let on = msg(8.0);
        assert!(
            on.contains("needs peak |tau| 40.00 N m at joint 3, 8.00x"),
            "{on}"
        );
        assert!(on.contains("on the widened limit itself"), "{on}");
        let below = msg(2.4);
        assert!(below.contains("2.40x its limit 5 N m"), "{below}");
        assert!(!below.contains("on the widened limit"), "{below}");
    }

    #[test]
    fn the_worst_joint_is_the_largest_ratio() {
        let tp = TorqueProbe {
            scale: 8.0,
            converged: true,
            guess: "failed-attempt".into(),
            peak_torque_nm: vec![1.0, 12.0, 3.0],
            limit_nm: vec![5.0, 5.0, 5.0],
            ratio: vec![0.2, 2.4, 0.6],
            tried: vec![],
        };
        assert_eq!(tp.worst_joint(), Some((1, 2.4)));
    }

    /// Three-link robot, bar at 0.8 m: a circle near the bar and a second one nearer the grip
    /// together block every pose grasping the bar, and in the poses that keep the most clearance
    /// the link that comes closest comes closest to the second circle, not to the one nearest the
    /// bar. The diagnosis names that pair, in either order of the circles.
    #[test]
    fn an_unreachable_task_names_the_obstacle_its_blocking_link_comes_closest_to() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../params/three-link.toml");
        let robot = Robot::from_toml_file(&path).unwrap();
        let near = Circle {
            center: [0.69909, -0.18199],
            radius: 0.12817,
        };
        let inner = Circle {
            center: [0.24771, -0.11846],
            radius: 0.11539,
        };
        let s = PlannerSettings::default();
        let task = |obstacles: Vec<Circle>| SwingTask {
            q0: vec![-1.2, 0.4, 0.4],
            qd0: vec![],
            target: [0.8, 0.0],
            obstacles,
        };
        let b = grasp_blocked(&robot, [0.8, 0.0], &[near, inner], 0.01, &s.bounds).unwrap();
        assert_eq!((b.nearest, b.link_obstacle), (0, 1), "{b:?}");
        let named = unreachable(&robot, &task(vec![near, inner]), &s).unwrap();
        assert_eq!(named, Some((1, b.link)));
        let named = unreachable(&robot, &task(vec![inner, near]), &s).unwrap();
        assert_eq!(named, Some((0, b.link)));
    }
}
