//! Swing times that do not plan: the fallback of the automatic swing time and the continuation in T.
//!
//! A cold plan without obstacles and without a warm-start guess that does not converge at its swing
//! time T (after the continuation on the torque limits, when that is on) is searched for in T:
//!
//! - **Anchors.** The task is planned cold, with a capped iteration count ([`ANCHOR_MAX_ITER`]), at
//!   the swing times `T x` [`ANCHOR_FACTORS`] (alternately longer and shorter), until one converges on
//!   each side of T.
//! - **With `swing_time = "auto"`** the first anchor that converges is the plan: the automatic swing
//!   time is then that anchor's T. When the free-fall rule gives no time at all (the locked chain
//!   released at rest never reaches the midpoint, as from a straight hang, which is an equilibrium),
//!   the anchors are taken around the locked chain's half period of small oscillation about the grip
//!   ([`reference_swing_time`]) instead.
//! - **With T in seconds** each converged anchor is continued in T towards the T asked for, every
//!   plan warm-started from the last converged one; the step starts at the whole distance and is
//!   halved after every failure, down to [`MIN_STEP_S`], at most [`MAX_STEPS`] plans per anchor. The
//!   plan at T is the result when one continuation reaches it.
//!
//! When nothing reaches T the failed plan is returned with a [`SwingTimeSearch`] that lists what was
//! tried: every anchor with its outcome, and how far each continuation came (the swing times that
//! plan nearest T on either side) with the bounds its last plan presses against ([`SwingTimeStop`]:
//! the torque limits, the rate bound, the relative joints' bound). That is evidence, not proof:
//! another family of swings may plan.
//!
//! Units: s.

use crate::error::{Error, Result};
use crate::model::Robot;
use crate::planning::nlp::NlpSettings;
use crate::planning::outcome::Plan;
use crate::planning::outcome::SolveRole;
use crate::planning::report::AT_BOUND;
pub use crate::planning::report::{SwingTimeSearch, SwingTimeStop, TriedSwingTime};
use crate::planning::settings::{PlannerSettings, SwingTime, ValidSettings};
use crate::planning::solve::common::swing_time;
use crate::planning::solve::single::plan_single;
use crate::planning::solve_log::SolveLog;
use crate::planning::task::ValidTask;
use std::time::Instant;

/// Factors on the swing time at which anchors are tried, in order (alternately longer and
/// shorter, moving away from T).
pub const ANCHOR_FACTORS: [f64; 8] = [1.1, 0.9, 1.25, 0.8, 1.5, 0.67, 2.0, 0.5];
/// Iteration limit of an anchor's cold solve (a solve that converges cold takes far fewer).
pub const ANCHOR_MAX_ITER: usize = 150;
/// Most warm plans of one continuation in T.
pub const MAX_STEPS: usize = 12;
/// Smallest step of a continuation in T, s.
pub const MIN_STEP_S: f64 = 0.004;

/// The locked chain's half period of small oscillation about the grip, s: `pi sqrt(I / (m g d))`
/// with `I` the locked chain's inertia about the grip at `q0`'s shape, `m` its mass and `d` the
/// distance from the grip to its centre of mass. `None` without gravity or with the centre of mass
/// at the grip.
pub fn reference_swing_time(robot: &Robot, q0: &[f64]) -> Option<f64> {
    let n = robot.n;
    let inertia = robot.mass_matrix(q0)[0];
    let mut c = vec![[0.0; 2]; n];
    robot.com_positions(q0, &mut c);
    let m = robot.total_mass();
    let (mut x, mut y) = (0.0, 0.0);
    for (p, mi) in c.iter().zip(robot.masses()) {
        x += mi * p[0];
        y += mi * p[1];
    }
    let k = robot.gravity * x.hypot(y);
    (k > 0.0 && m > 0.0).then(|| std::f64::consts::PI * (inertia / k).sqrt())
}

/// A plan of `task` at the swing time `t` (s), from `guess` or cold.
fn plan_at(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    t: f64,
    guess: Option<&crate::trajectory::Trajectory>,
) -> Result<Plan> {
    let s = settings.with_swing_time(t)?.without_recoveries();
    plan_single(robot, task, &s, nlp, guess)
}

/// `Some(why)` when `settings.swing_time` is `"auto"` and the free-fall rule gives no time (the
/// locked chain never reaches the midpoint); `None` when it gives one or T is in seconds.
fn rule_gives_no_time(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
) -> Result<Option<String>> {
    if !matches!(settings.swing_time, SwingTime::Auto(_)) {
        return Ok(None);
    }
    match swing_time(robot, task, settings) {
        Ok(_) => Ok(None),
        Err(Error::InfeasibleTask(m)) => Ok(Some(m)),
        Err(e) => Err(e),
    }
}

/// What the planner does before its first plan of a task without obstacles (see [`before_plan`]).
pub(crate) enum Before {
    /// The search without a rule time ran: its plan is the result.
    Planned(Box<Plan>),
    /// Plan with these settings (`None`: the caller's).
    Plan(Option<ValidSettings>),
}

/// Before the first plan of a task without obstacles: with `"auto"` and no free-fall time (and the
/// search on, no guess), the search around the locked chain's half period is the plan; with a free
/// swing time as well, the plan starts from the middle of its range.
pub(crate) fn before_plan(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&crate::trajectory::Trajectory>,
    started: Instant,
) -> Result<Before> {
    if guess.is_some() || !settings.swing_time_search {
        return Ok(Before::Plan(None));
    }
    let Some(why) = rule_gives_no_time(robot, task, settings)? else {
        return Ok(Before::Plan(None));
    };
    Ok(match settings.free_swing_time {
        None => Before::Planned(Box::new(plan_without_rule_time(
            robot, task, settings, nlp, why, started,
        )?)),
        Some([lo, hi]) => Before::Plan(Some(settings.with_swing_time(0.5 * (lo + hi))?)),
    })
}

/// After the first plan `p` (and the continuation on the torque limits) of a task without
/// obstacles: when it did not converge, and could by another swing time (not for want of time, nor
/// refused), the search in T (a free swing time's own, or the anchors and continuations); else `p`.
pub(crate) fn after_plan(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    guess: Option<&crate::trajectory::Trajectory>,
    p: Plan,
    started: Instant,
) -> Result<Plan> {
    let wanted = guess.is_none()
        && settings.swing_time_search
        && !p.converged()
        && crate::planning::strategy::torque_continuation::worth_continuing(&p.status);
    if !wanted {
        return Ok(p);
    }
    match (settings.free_swing_time, settings.free_range()) {
        (None, _) => {
            let t = p.swing_time_s;
            plan_by_swing_time_search(robot, task, settings, nlp, p, t, started)
        }
        (Some(_), Some(range)) => {
            plan_free_range_search(robot, task, settings, nlp, p, range, started)
        }
        // a range narrower than MIN_FREE_SWING_TIME_RANGE_S is one fixed T: nothing to search
        (Some(_), None) => Ok(p),
    }
}

/// `swing_time = "auto"` when the free-fall rule gave no time (`why`): the anchors around the
/// locked chain's half period (see the module docs). The first plan that converges is the result;
/// else the plan at the half period, with what was tried. Errors on bad input, and when the chain
/// has no half period either (no gravity torque about the grip).
fn plan_without_rule_time(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    why: String,
    started: Instant,
) -> Result<Plan> {
    let Some(reference) = reference_swing_time(robot, &task.q0) else {
        return Err(Error::InfeasibleTask(format!(
            "{why}, and the locked chain has no period of oscillation about the grip"
        )));
    };
    let rep = SwingTimeSearch {
        requested_s: None,
        rule_failure: Some(why),
        reference_s: Some(reference),
        tried: vec![],
        planned_s: None,
        out_of_time: false,
        stops: vec![],
    };
    search(robot, task, settings, nlp, None, reference, rep, started)
}

/// The search in T after `failed` did not converge at its swing time `requested` (s). See the
/// module docs. `started` is when the planning call began: `nlp.max_wall_time_s` bounds the whole
/// call. Returns the plan found, else `failed` with what was tried.
fn plan_by_swing_time_search(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    failed: Plan,
    requested: f64,
    started: Instant,
) -> Result<Plan> {
    let rep = SwingTimeSearch {
        requested_s: Some(requested),
        rule_failure: None,
        reference_s: None,
        tried: vec![],
        planned_s: None,
        out_of_time: false,
        stops: vec![],
    };
    search(
        robot,
        task,
        settings,
        nlp,
        Some(failed),
        requested,
        rep,
        started,
    )
}

/// The anchors around `centre` (s), then (T in seconds) the continuations towards it.
#[allow(clippy::too_many_arguments)]
fn search(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    failed: Option<Plan>,
    centre: f64,
    mut rep: SwingTimeSearch,
    started: Instant,
) -> Result<Plan> {
    // "auto" takes the first anchor that plans; seconds continue the anchors towards T
    let take_first = matches!(settings.swing_time, SwingTime::Auto(_));
    let mut log = SolveLog::default();
    let mut failed = failed;
    if let Some(p) = failed.as_mut() {
        log.record(p, SolveRole::Task);
    }
    let factors: Vec<f64> = match rep.requested_s {
        // without a rule time the reference itself first
        None => std::iter::once(1.0).chain(ANCHOR_FACTORS).collect(),
        Some(_) => ANCHOR_FACTORS.to_vec(),
    };
    let mut anchors: Vec<Plan> = vec![];
    let mut sides = [false, false];
    let mut reached: Option<Plan> = None;
    for k in factors {
        let side = usize::from(k > 1.0);
        if sides[side] {
            continue;
        }
        // the first anchor of a search without a failed plan always runs (a plan is returned)
        let run = match nlp.remaining(started) {
            Some(r) => r,
            None if failed.is_none() => NlpSettings {
                max_wall_time_s: Some(1e-3),
                ..nlp.clone()
            },
            None => {
                rep.out_of_time = true;
                break;
            }
        };
        let t = centre * k;
        let mut p = plan_at(robot, task, settings, &run.capped(ANCHOR_MAX_ITER), t, None)?;
        log.record(&mut p, SolveRole::SwingTimeAnchor { t_s: t });
        rep.tried.push(TriedSwingTime {
            swing_time_s: t,
            warm: false,
            status: p.status.clone(),
            converged: p.converged(),
        });
        if p.converged() {
            if take_first {
                reached = Some(p);
                break;
            }
            sides[side] = true;
            anchors.push(p);
            if sides[0] && sides[1] {
                break;
            }
        } else if failed.is_none() {
            failed = Some(p);
        }
    }
    if let (None, Some(t), false) = (&reached, rep.requested_s, take_first) {
        for anchor in anchors {
            let p = continue_in_t(
                robot, task, settings, nlp, anchor, t, started, &mut rep, &mut log,
            )?;
            if p.is_some() {
                reached = p;
                break;
            }
        }
    }
    let mut p = match (reached, failed) {
        (Some(p), _) => {
            rep.planned_s = Some(p.swing_time_s);
            p
        }
        (None, Some(p)) => p,
        (None, None) => unreachable!("the first anchor always runs and is kept when it fails"),
    };
    log.finish(&mut p);
    p.swing_time_search = Some(rep);
    Ok(p)
}

/// Fixed swing times tried inside a free swing time's range whose solve did not converge: the
/// centres of this many equal parts of the range.
pub const FREE_RANGE_ANCHORS: usize = 5;

/// A free swing time `[lo, hi]` whose solve `failed`: the task planned cold at fixed swing times
/// inside the range ([`FREE_RANGE_ANCHORS`], from the middle outwards); the first that converges
/// starts the free solve again, warm. Returns that plan when it converged (else the anchor's, at
/// its fixed T, which lies in the range), or `failed` with what was tried.
fn plan_free_range_search(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    failed: Plan,
    [lo, hi]: [f64; 2],
    started: Instant,
) -> Result<Plan> {
    let mut rep = SwingTimeSearch {
        requested_s: None,
        rule_failure: None,
        reference_s: None,
        tried: vec![],
        planned_s: None,
        out_of_time: false,
        stops: vec![],
    };
    let mut log = SolveLog::default();
    let mut failed = failed;
    log.record(&mut failed, SolveRole::Task);
    let k = FREE_RANGE_ANCHORS;
    let mut ts: Vec<f64> = (0..k)
        .map(|i| lo + (i as f64 + 0.5) * (hi - lo) / k as f64)
        .collect();
    let mid = 0.5 * (lo + hi);
    ts.sort_by(|a, b| (a - mid).abs().total_cmp(&(b - mid).abs()));
    let fixed = settings.without_free_swing_time();
    let mut reached = None;
    for t in ts {
        let Some(run) = nlp.remaining(started) else {
            rep.out_of_time = true;
            break;
        };
        let mut p = plan_at(robot, task, &fixed, &run.capped(ANCHOR_MAX_ITER), t, None)?;
        log.record(&mut p, SolveRole::SwingTimeAnchor { t_s: t });
        rep.tried.push(TriedSwingTime {
            swing_time_s: t,
            warm: false,
            status: p.status.clone(),
            converged: p.converged(),
        });
        if !p.converged() {
            continue;
        }
        let q = match nlp.remaining(started) {
            Some(run) => {
                let free = settings.with_swing_time(t)?.with_one_start();
                Some(plan_single(robot, task, &free, &run, Some(&p.points))?)
            }
            None => None,
        };
        match q {
            Some(mut q) if q.converged() => {
                let t_s = q.swing_time_s;
                log.record(&mut q, SolveRole::SwingTimeStep { t_s });
                reached = Some(q);
            }
            other => {
                if let Some(mut q) = other {
                    let t_s = q.swing_time_s;
                    log.record(&mut q, SolveRole::SwingTimeStep { t_s });
                }
                reached = Some(p);
            }
        }
        break;
    }
    let mut p = match reached {
        Some(p) => {
            rep.planned_s = Some(p.swing_time_s);
            p
        }
        None => failed,
    };
    log.finish(&mut p);
    p.swing_time_search = Some(rep);
    Ok(p)
}

/// Continue the converged `anchor` in T towards `t` (s); the plan at `t` when reached.
#[allow(clippy::too_many_arguments)]
fn continue_in_t(
    robot: &Robot,
    task: &ValidTask,
    settings: &ValidSettings,
    nlp: &NlpSettings,
    anchor: Plan,
    t: f64,
    started: Instant,
    rep: &mut SwingTimeSearch,
    log: &mut SolveLog,
) -> Result<Option<Plan>> {
    let mut ok = anchor;
    let mut step = t - ok.swing_time_s;
    for _ in 0..MAX_STEPS {
        let Some(run) = nlp.remaining(started) else {
            rep.out_of_time = true;
            return Ok(None);
        };
        let next = if (t - ok.swing_time_s).abs() <= step.abs() {
            t
        } else {
            ok.swing_time_s + step
        };
        let mut p = plan_at(
            robot,
            task,
            settings,
            &run.capped(ANCHOR_MAX_ITER),
            next,
            Some(&ok.points),
        )?;
        log.record(&mut p, SolveRole::SwingTimeStep { t_s: next });
        rep.tried.push(TriedSwingTime {
            swing_time_s: next,
            warm: true,
            status: p.status.clone(),
            converged: p.converged(),
        });
        if p.converged() {
            if next == t {
                return Ok(Some(p));
            }
            ok = p;
        } else {
            step *= 0.5;
            if step.abs() < MIN_STEP_S {
                break;
            }
        }
    }
    rep.stops.push(stop_of(robot, settings, &ok));
    Ok(None)
}

/// What the converged plan `p` presses against (see [`SwingTimeStop`]).
fn stop_of(robot: &Robot, settings: &PlannerSettings, p: &Plan) -> SwingTimeStop {
    let (n, m) = (robot.n, robot.n - 1);
    let b = &settings.bounds;
    let mut torque_use = 0.0f64;
    for row in p.points.tau.chunks(m.max(1)) {
        for (j, &u) in row.iter().enumerate() {
            let lim = if u >= 0.0 {
                robot.tau_max()[j]
            } else {
                -robot.tau_min()[j]
            };
            if lim > 0.0 {
                torque_use = torque_use.max(u.abs() / lim);
            }
        }
    }
    let peak_rate_rad_s = p.points.qd.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let joints_at_bound = (1..n)
        .filter(|&j| {
            p.points
                .q
                .chunks(n)
                .any(|q| q[j].abs() >= (1.0 - AT_BOUND) * b.q_rel_max)
        })
        .map(|j| j + 1)
        .collect();
    SwingTimeStop {
        swing_time_s: p.swing_time_s,
        torque_use,
        peak_rate_rad_s,
        rate_bound_rad_s: b.qd_max,
        joints_at_bound,
        joint_bound_rad: b.q_rel_max,
    }
}
