//! A ladder traverse on the model plant: plan each swing from the state the last one left, track it with
//! the scenario's controller, capture the bar, switch the grip (re-root the chain), go on.
//!
//! Conventions (as in `brachia`): world frame x right, y up, gravity along -y; within a swing the chain
//! is in its grip frame, link 1 at the current grip (`q[0]` absolute, the rest relative; SI units).
//! **Hands**: hand A is the end of the parameters file's link 1, hand B the end of its link n. Swings 0,
//! 2, 4, ... hang from hand A (the chain as written), swings 1, 3, ... from hand B (the chain re-rooted,
//! [`brachia::model::switch_grip`]). The ladder's sequencing (the grip-switch map, the frames, each
//! swing's task) is the library's [`brachia::ladder`]; this module runs it on a
//! plant and writes the run folder.
//!
//! **Capture rule**: a swing ends after its planned time (plus `tracking.hold_s`), when the gripper
//! closes; the plant's hand captures the bar when it is then within `ladder.capture_radius` of it and
//! no faster than `ladder.capture_speed`: the rule of every run ([`crate::success::CaptureRule`]) with
//! the ladder's two numbers ([`swing_capture`]).
//! The new grip is where the hand closed (within the capture radius of the bar); a remaining hand speed
//! is stopped by the capture impulse (reported as the switch residual and the energy it takes). A miss
//! ends the run with [`TraverseStatus::CaptureMissed`], naming the swing and the miss.
//!
//! `traverse.csv` header: `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y` (the current chain, its grip frame),
//! then `swing,holding_hand,grip_bar,grip_x,grip_y,hand_a_x,hand_a_y,p1_x,p1_y,...,hand_b_x,hand_b_y`:
//! the swing index, the hand that holds (`0` = A, `1` = B), the bar it holds, the grip and every joint
//! of the chain in world coordinates in the parameters file's order (hand A first). Time runs on over
//! the whole traverse; the last row of a swing and the first of the next share their time and positions
//! (velocities differ by the capture impulse, if any).

use crate::ladder::LoadedLadder;
use crate::plan_run::run_plan;
use crate::run_folder::RunFolder;
use crate::scenario::LoadedScenario;
use crate::scenario::PlantKind;
use crate::track_run::{make_controller, PlantWorld};
use brachia::control::Replanning;
use brachia::model::switch_grip;
use brachia::planning::{plan_with_guess, validate_task};
use brachia::sim::{
    run_closed_loop, ClosedLoopLog, Controller, ModelPlant, NoiseSettings, Noisy, Plant,
    RunSettings,
};
use brachia::{Error, Robot};
use brachia_rapier::{ContactBody, ContactEvent, Obstacle, Regrip};
use serde::Serialize;
use serde_json::json;
use std::fmt::Write as _;
pub use world::BallRecord;
use world::{plant_chains, rapier_world, throw_ball};

mod world;

/// One swing of a traverse.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SwingRecord {
    /// Swing index (0 = from bar 0 to bar 1).
    pub swing: usize,
    /// The bar held during the swing.
    pub from_bar: usize,
    /// The bar caught at its end.
    pub to_bar: usize,
    /// The hand that holds: 0 = hand A (link 1 of the parameters file), 1 = hand B.
    pub holding_hand: usize,
    /// The grip, world, m.
    pub grip: [f64; 2],
    /// Start time within the traverse, s.
    pub t_start_s: f64,
    /// Duration of the swing (planned swing time plus hold), s.
    pub duration_s: f64,
    /// The planned swing time T, s.
    pub swing_time_s: f64,
    /// Planner status.
    pub plan_converged: bool,
    /// Where the plan this swing was tracked from came from (`ladder.lookahead`).
    pub plan_source: PlanSource,
    /// Swings in that plan: k when it was the first of a joint plan over k swings, else 1.
    pub planned_jointly: usize,
    /// Planner iterations spent on this swing (all attempts; for a joint plan, its swing-by-swing warm
    /// start's and the joint solve's, also when it did not converge and the swing was planned alone).
    pub plan_iterations: usize,
    /// Planner wall time spent on this swing (the same attempts), s.
    pub plan_time_s: f64,
    /// Energy of the plan, paper eq. 18, J.
    pub planned_energy_j: f64,
    /// Energy of the tracked swing, paper eq. 18 (`sum_k tau_k . (q_{k+1} - q_k)` over the actuated
    /// joints), J.
    pub energy_j: f64,
    /// Positive work of the actuated joints in the tracked swing, J.
    pub positive_work_j: f64,
    /// Largest EE distance from the reference during the swing, m.
    pub ee_error_max_m: f64,
    /// Distance of the hand from the bar at the end of the swing, m.
    pub capture_error_m: f64,
    /// The switch residual: the hand's speed when it closed, m/s.
    pub switch_residual_m_s: f64,
    /// Kinetic energy taken by the capture impulse, J.
    pub capture_impact_j: f64,
    /// True when the hand caught the bar within the capture rule.
    pub captured: bool,
    /// The grip switch in the rapier world at the end of the swing (absent on the model plant, where
    /// the switch is the map alone, and when the bar was missed).
    pub regrip: Option<RegripRecord>,
    /// Contact events of the links in the swing (rapier plant; 0 on the model plant).
    pub contact_events: usize,
    /// Sum of the links' contact impulses in the swing, N s.
    pub contact_impulse_n_s: f64,
    /// Online re-plans in the swing (`[tracking] replan`).
    pub replans: usize,
    /// Each re-plan of the swing (trigger and switch times on the swing's clock, predicted miss,
    /// solver status and iterations, adopted or not).
    pub replan_events: Vec<brachia::control::ReplanEvent>,
    /// Closed-loop wall time of the swing (controller and plant), s.
    pub track_time_s: f64,
}

/// A grip switch on the rapier plant, read from the engine's bodies before and after the chain was
/// rebuilt at the new bar (world frame; joints in the parameters file's order, hand A first).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RegripRecord {
    /// Largest distance of a joint before and after the rebuild, m.
    pub position_residual_m: f64,
    /// Distance of the closing hand from the new root joint before the switch, m.
    pub grip_offset_m: f64,
    /// Speed of the closing hand just before the switch, m/s.
    pub ee_speed_m_s: f64,
    /// Largest change of a joint's world velocity across the switch (the capture impulse), m/s.
    pub velocity_change_m_s: f64,
    /// Every joint's world position before and after, m.
    pub joints_before: Vec<[f64; 2]>,
    /// After.
    pub joints_after: Vec<[f64; 2]>,
    /// Every joint's world velocity before and after, m/s.
    pub velocities_before: Vec<[f64; 2]>,
    /// After.
    pub velocities_after: Vec<[f64; 2]>,
}

impl RegripRecord {
    /// From the plant's account of a switch of a chain holding with hand `hand` (0 = A, 1 = B).
    fn new(r: Regrip, hand: usize) -> Self {
        let order = |mut v: Vec<[f64; 2]>| {
            if hand == 1 {
                v.reverse();
            }
            v
        };
        RegripRecord {
            position_residual_m: r.position_residual_m,
            grip_offset_m: r.grip_offset_m,
            ee_speed_m_s: r.ee_speed_before_m_s,
            velocity_change_m_s: r.velocity_change_m_s,
            joints_before: order(r.joints_before),
            joints_after: order(r.joints_after),
            velocities_before: order(r.velocities_before),
            velocities_after: order(r.velocities_after),
        }
    }
}

/// How a traverse ended.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case")]
pub enum TraverseStatus {
    /// Every bar was caught.
    Completed,
    /// The state a swing starts from is refused by the planner's checks (bounds, reach, obstacles).
    StartRefused {
        /// The swing.
        swing: usize,
        /// Why.
        message: String,
    },
    /// The planner did not converge on a swing.
    PlanFailed {
        /// The swing.
        swing: usize,
        /// The planner's account.
        message: String,
    },
    /// The hand missed the bar.
    CaptureMissed {
        /// The swing.
        swing: usize,
        /// The bar it aimed at.
        bar: usize,
        /// Distance of the hand from the bar, m.
        miss_m: f64,
        /// Speed of the hand, m/s.
        speed_m_s: f64,
        /// The capture radius, m.
        capture_radius_m: f64,
        /// The capture speed, m/s.
        capture_speed_m_s: f64,
    },
    /// The grip switch failed (the chain stretched straight).
    SwitchFailed {
        /// The swing.
        swing: usize,
        /// Why.
        message: String,
    },
    /// The closed loop of a swing diverged (a state beyond [`brachia::sim::DIVERGENCE_BOUND`] or not
    /// finite, or a non-finite torque); the swing's log holds the rows before it.
    Diverged {
        /// The swing.
        swing: usize,
        /// When, s (the plant's time, from the traverse's start).
        t_s: f64,
    },
}

impl TraverseStatus {
    /// True for [`TraverseStatus::Completed`].
    pub fn completed(&self) -> bool {
        matches!(self, TraverseStatus::Completed)
    }
}

impl std::fmt::Display for TraverseStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TraverseStatus::Completed => write!(f, "completed: every bar caught"),
            TraverseStatus::StartRefused { swing, message } => {
                write!(f, "swing {swing}: its start state is refused: {message}")
            }
            TraverseStatus::PlanFailed { swing, message } => write!(f, "swing {swing}: {message}"),
            TraverseStatus::CaptureMissed {
                swing,
                bar,
                miss_m,
                speed_m_s,
                capture_radius_m,
                capture_speed_m_s,
            } => write!(
                f,
                "swing {swing}: the hand missed bar {bar} by {miss_m:.4} m at {speed_m_s:.4} m/s \
                 (capture radius {capture_radius_m} m, capture speed {capture_speed_m_s} m/s)"
            ),
            TraverseStatus::SwitchFailed { swing, message } => {
                write!(f, "swing {swing}: {message}")
            }
            TraverseStatus::Diverged { swing, t_s } => write!(
                f,
                "swing {swing}: the closed loop diverged at t = {t_s:.3} s: the results cannot be trusted"
            ),
        }
    }
}

/// The outcome of [`run_traverse`].
#[derive(Debug, Clone)]
pub struct Traverse {
    /// How it ended.
    pub status: TraverseStatus,
    /// Every swing that was tracked (a failed capture is the last one).
    pub swings: Vec<SwingRecord>,
    /// The closed-loop log of each tracked swing (its chain's grip frame).
    pub logs: Vec<ClosedLoopLog>,
    /// The chain as written and re-rooted (swing k uses `chains[brachia::ladder::holding_hand(k)]`).
    pub chains: [Robot; 2],
    /// The rapier world: its obstacles (the ladder's as fixed circles first, then the plant's),
    /// every contact (links in the parameters file's order) and the obstacle track, stamped with the
    /// traverse time. Empty on the model plant.
    pub world: PlantWorld,
    /// The plant's name (`model`, `rapier`).
    pub plant: &'static str,
    /// The ball of `[disturbances.ball]`, once its swing started.
    pub ball: Option<BallRecord>,
}

/// Positive work of the actuated joints in a log, J (held torques: `sum_k max(0, tau_k,j dq_j)`).
fn positive_work(log: &ClosedLoopLog) -> f64 {
    let n = log.n;
    (0..log.len().saturating_sub(1))
        .map(|k| {
            (0..n - 1)
                .map(|j| (log.tau(k)[j] * (log.x(k + 1)[j + 1] - log.x(k)[j + 1])).max(0.0))
                .sum::<f64>()
        })
        .sum()
}

/// Frame rate of `traverse.gif`, frames per second.
const GIF_FPS: f64 = 20.0;

/// Margin by which the q1 range (and `q_rel_max`) of a later swing is widened past its start angle, rad
/// (the planner's [`brachia::planning::START_WIDEN_MARGIN`]).
pub const Q1_WIDEN_MARGIN: f64 = brachia::planning::START_WIDEN_MARGIN;

/// A later swing starts where the last one left the chain: the start angle's representative and the
/// bounds widened to take the start state ([`brachia::ladder::later_swing_start`]).
fn widen_start_bounds(sc: &mut crate::scenario::Scenario) {
    brachia::ladder::later_swing_start(&mut sc.task, &mut sc.planner.bounds);
}

/// Run the traverse of `ll` on its plant (`[plant] kind`). Errors only on bad input found at run time that no
/// status describes; planning failures, refused start states and missed captures are statuses.
pub fn run_traverse(ll: &LoadedLadder) -> Result<Traverse, Error> {
    let never = || false;
    // `never` is never set, so the traverse always finishes
    traverse(ll, &never)?.ok_or_else(|| Error::InfeasibleTask("the traverse was cancelled".into()))
}

/// [`run_traverse`] that can be cancelled: `cancel` is checked before every swing and by every solve
/// at every iteration; once it is set the traverse ends with [`crate::ExpError::Cancelled`] and
/// nothing of it is returned.
pub fn run_traverse_cancellable(
    ll: &LoadedLadder,
    cancel: &crate::CancelToken,
) -> Result<Traverse, crate::ExpError> {
    let mut ll = ll.clone();
    ll.scenario.solver.cancel = Some(cancel.clone());
    let stop = || cancel.is_cancelled();
    let done = traverse(&ll, &stop);
    cancel.check()?;
    done?.ok_or(crate::ExpError::Cancelled)
}

/// Where the plan a swing was tracked from came from (`ladder.lookahead`; docs/ladders.md,
/// "Lookahead").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PlanSource {
    /// Planned alone from the state the switch left, as `brachia plan` would.
    Alone,
    /// Planned alone from that state, with the last joint plan's swing as the initial guess.
    JointGuess,
    /// The first swing of a joint plan over [`SwingRecord::planned_jointly`] swings from that state.
    Joint,
    /// The last joint plan's swing itself, not re-planned: no plan from the state the switch left
    /// converged. It starts at the switch state the joint plan predicted, not at the state the switch
    /// left (nothing checks how far apart they are: the controller starts with that error, and the
    /// capture rule judges the swing).
    JointPrevious,
}

/// A swing's plan, where it came from, and, when it is the first of a joint plan, the joint plan's
/// second swing (for the next swing) and the number of swings planned together.
struct SwingPlan {
    plan: brachia::planning::Plan,
    source: PlanSource,
    next: Option<(brachia::planning::Plan, usize)>,
}

/// Swing `ls` planned alone from the state the switch left: with `planned` (the swing as the last
/// joint plan planned it) as the initial guess when there is one and that converges, else as `brachia
/// plan` would (`run_plan`); when neither converges, `planned` itself. The plan returned carries the
/// iterations and time of every attempt made for this swing, `spent` (those of a joint plan that did
/// not converge) included, not those of the joint plan that made `planned`.
fn plan_alone(
    ls: &LoadedScenario,
    planned: Option<&brachia::planning::Plan>,
    mut spent: (usize, f64),
) -> Result<SwingPlan, Error> {
    let sc = &ls.scenario;
    let alone = |mut plan: brachia::planning::Plan, source, spent: (usize, f64)| {
        plan.iterations = spent.0;
        plan.solve_time_s = spent.1;
        SwingPlan {
            plan,
            source,
            next: None,
        }
    };
    if let Some(g) = planned {
        let p = plan_with_guess(
            &ls.robot,
            &sc.task,
            &sc.planner,
            &sc.solver,
            Some(&g.points),
        )?;
        spent = (spent.0 + p.iterations, spent.1 + p.solve_time_s);
        if p.converged() {
            return Ok(alone(p, PlanSource::JointGuess, spent));
        }
    }
    let p = run_plan(ls)?.plan;
    spent = (spent.0 + p.iterations, spent.1 + p.solve_time_s);
    Ok(match planned {
        Some(g) if !p.converged() => alone(g.clone(), PlanSource::JointPrevious, spent),
        _ => alone(p, PlanSource::Alone, spent),
    })
}

/// The plan of swing `ls` (the chain that holds `grip`, its start state `x` in that grip frame) as the
/// first swing of a joint plan through `bars` (world frame; `ladder.lookahead`; the switch states
/// free but for the capture, the rest condition at the last bar only; with `rest_at_switches`,
/// `ladder.lookahead_switch = "rest"`, at every bar), with its iterations and time
/// those of the whole joint plan (its swing-by-swing warm start included). When the joint solve does
/// not converge, the swing is planned alone ([`plan_alone`] with `previous`, the last joint plan's
/// swing, the iterations and time of the failed joint plan counted in), so the traverse goes on as it
/// would without the lookahead.
fn plan_ahead(
    ls: &LoadedScenario,
    x: &[f64],
    grip: [f64; 2],
    bars: &[crate::ladder::Bar],
    obstacles: &[brachia::model::Circle],
    previous: Option<&brachia::planning::Plan>,
    rest_at_switches: bool,
) -> Result<SwingPlan, Error> {
    let sc = &ls.scenario;
    let n = ls.robot.n();
    let task = brachia::ladder::joint_swing_task(
        [&sc.task.q0[..], &x[n..]].concat(),
        grip,
        bars,
        obstacles,
        rest_at_switches,
    );
    let j = brachia::planning::plan_joint_swings(&ls.robot, &task, &sc.planner, &sc.solver)?;
    let iterations = j.reference.iter().map(|p| p.iterations).sum::<usize>()
        + j.solve.as_ref().map_or(0, |s| s.iterations);
    let time_s = j.reference.iter().map(|p| p.solve_time_s).sum::<f64>()
        + j.solve.as_ref().map_or(0.0, |s| s.time_s);
    if !j.converged() || j.phases.len() < 2 {
        return plan_alone(ls, previous, (iterations, time_s));
    }
    let swings = j.phases.len();
    let mut phases = j.phases.into_iter().map(|ph| ph.plan);
    let (Some(mut plan), Some(second)) = (phases.next(), phases.next()) else {
        return Err(Error::InfeasibleTask(
            "a converged joint plan without two swings".into(),
        ));
    };
    plan.iterations = iterations;
    plan.solve_time_s = time_s;
    Ok(SwingPlan {
        plan,
        source: PlanSource::Joint,
        next: Some((second, swings)),
    })
}

pub use brachia::ladder::SWITCH_POSE_MARGIN_RAD;
use brachia::ladder::{holding_hand, switch_pose_box};

/// How the swinging hand of `chain` (the plant's chain, holding `grip`, world) meets `bar` (world)
/// at the last row of the swing's `log`, where the gripper closes: the capture rule of every run
/// ([`crate::success::CaptureRule`]) with the ladder's `capture_radius` and `capture_speed`.
pub fn swing_capture(
    ladder: &crate::ladder::Ladder,
    chain: &Robot,
    grip: [f64; 2],
    log: &ClosedLoopLog,
    bar: [f64; 2],
) -> Option<crate::success::HandAtBar> {
    let x = log.x(log.len().checked_sub(1)?);
    let target = [bar[0] - grip[0], bar[1] - grip[1]];
    Some(ladder.capture_rule().hand_at_bar(chain, x, target))
}

/// The traverse; `None` when `stop` said so before it finished.
fn traverse(ll: &LoadedLadder, stop: &dyn Fn() -> bool) -> Result<Option<Traverse>, Error> {
    let sc = &ll.scenario;
    let bars = &sc.ladder.bars;
    let n = ll.robot.n();
    let chains = brachia::ladder::chains(&ll.robot)?;
    let pchains = plant_chains(ll)?;
    let src = ll.path.display().to_string();
    let mut x = ll.x0.clone();
    let mut grip = bars[0].p();
    let mut world = PlantWorld::default();
    let mut rapier = match sc.plant.kind {
        PlantKind::Model => None,
        PlantKind::Rapier => {
            let (p, obstacles) = rapier_world(ll, &pchains[0], &x)?;
            world.obstacles = obstacles;
            Some(p)
        }
    };
    let mut t_start = 0.0;
    let mut swings = Vec::new();
    let mut logs = Vec::new();
    let mut status = TraverseStatus::Completed;
    let mut ball = None;
    // the next swing of the last joint plan, the initial guess of the next swing when it is planned
    // alone (or when its joint plan fails)
    let mut next_guess: Option<brachia::planning::Plan> = None;
    for k in 0..bars.len() - 1 {
        if stop() {
            return Ok(None);
        }
        let robot = &chains[holding_hand(k)];
        let mut swing_sc = crate::ladder::swing_scenario(sc, &x[..n], &x[n..], grip, k + 1);
        if k > 0 {
            // the plant starts where the plan does: q1 as the representative (mod 2 pi) the plan uses
            // (chosen at the switch, so the rapier chain is rebuilt with it), or the controller would
            // see a 2 pi error
            widen_start_bounds(&mut swing_sc);
            x[0] = swing_sc.task.q0[0];
        }
        let ls = LoadedScenario {
            scenario: swing_sc,
            robot: robot.clone(),
            path: ll.path.clone(),
        };
        let refused = |e: Error| TraverseStatus::StartRefused {
            swing: k,
            message: e.to_string(),
        };
        if let Err(e) = validate_task(
            robot,
            &ls.scenario.task,
            &ls.scenario.planner,
            &src,
            "swing.",
        ) {
            status = refused(e);
            break;
        }
        let last_bar = (k + sc.ladder.lookahead).min(bars.len() - 1);
        let planned = if last_bar > k + 1 {
            plan_ahead(
                &ls,
                &x,
                grip,
                &bars[k + 1..=last_bar],
                &sc.ladder.obstacles,
                next_guess.as_ref(),
                sc.ladder.lookahead_switch == crate::ladder::LookaheadSwitch::Rest,
            )
        } else {
            plan_alone(&ls, next_guess.as_ref(), (0, 0.0))
        };
        let SwingPlan {
            plan: p,
            source: plan_source,
            next,
        } = match planned {
            Ok(p) => p,
            Err(e) => {
                status = refused(e);
                break;
            }
        };
        let planned_jointly = next.as_ref().map_or(1, |(_, swings)| *swings);
        // kept for the next swing only while this one is the first of a joint plan
        next_guess = next.map(|(g, _)| g);
        let p = &p;
        if !p.converged() {
            status = TraverseStatus::PlanFailed {
                swing: k,
                message: p.failure_message().unwrap_or_default(),
            };
            break;
        }
        if let Err(e) = ls.check_tracking(p.swing_time_s) {
            status = refused(e);
            break;
        }
        let reference = &p.trajectory;
        if let Some(b) = sc.disturbances.ball.as_ref().filter(|b| b.swing == k) {
            let rec = throw_ball(b, reference, robot, grip, t_start, rapier.as_mut(), &src)?;
            if rec.obstacle_id.is_some() {
                world.obstacles.push(Obstacle::Ball(rec.ball.clone()));
            }
            ball = Some(rec);
        }
        let contacts_before = rapier.as_ref().map_or(0, |r| r.contacts().len());
        let tracked = track_swing(
            ll,
            &ls,
            &pchains[holding_hand(k)],
            &x,
            p,
            plan_source,
            rapier.as_mut(),
            k,
        )?;
        let (log, track_time_s, replan_events) =
            (tracked.log, tracked.track_time_s, tracked.replan_events);
        let replans = replan_events.len();
        let diverged_at = log.diverged_at_s;
        if log.is_empty() {
            // diverged at its first step (a non-finite torque): nothing to record of this swing
            status = TraverseStatus::Diverged {
                swing: k,
                t_s: diverged_at.unwrap_or(t_start),
            };
            break;
        }
        let summary = log.summary();
        let xe = log.x(log.len() - 1).to_vec();
        let pchain = &pchains[holding_hand(k)];
        let hand = swing_capture(&sc.ladder, pchain, grip, &log, bars[k + 1].p())
            .ok_or_else(|| Error::InfeasibleTask("an empty swing log".into()))?;
        let (miss, speed) = (hand.distance_m, hand.speed_m_s);
        let captured = diverged_at.is_none() && hand.captures;
        let duration = log.t[log.len() - 1] - log.t[0];
        let mut rec = SwingRecord {
            swing: k,
            from_bar: k,
            to_bar: k + 1,
            holding_hand: holding_hand(k),
            grip,
            t_start_s: t_start,
            duration_s: duration,
            swing_time_s: p.swing_time_s,
            plan_converged: true,
            plan_source,
            planned_jointly,
            plan_iterations: p.iterations,
            plan_time_s: p.solve_time_s,
            planned_energy_j: p.energy_j,
            energy_j: summary.energy_j,
            positive_work_j: positive_work(&log),
            ee_error_max_m: summary.ee_error_max_m,
            capture_error_m: miss,
            switch_residual_m_s: speed,
            capture_impact_j: 0.0,
            captured,
            regrip: None,
            contact_events: 0,
            contact_impulse_n_s: 0.0,
            replans,
            replan_events,
            track_time_s,
        };
        if let Some(r) = &rapier {
            record_contacts(&r.contacts()[contacts_before..], k, n, &mut rec, &mut world);
        }
        logs.push(log);
        if let Some(t_s) = diverged_at {
            swings.push(rec);
            status = TraverseStatus::Diverged { swing: k, t_s };
            break;
        }
        if !captured {
            swings.push(rec);
            status = TraverseStatus::CaptureMissed {
                swing: k,
                bar: k + 1,
                miss_m: miss,
                speed_m_s: speed,
                capture_radius_m: sc.ladder.capture_radius,
                capture_speed_m_s: sc.ladder.capture_speed,
            };
            break;
        }
        // the capture impulse with the plant's masses (the true robot stops the hand)
        match switch_grip(&pchains[holding_hand(k)], grip, &xe) {
            Ok(s) => {
                rec.capture_impact_j = s.impact_energy_j;
                x = s.x;
                x[0] = sc.planner.bounds.nearest_q1(x[0]);
                grip = s.grip;
                if let Some(r) = rapier.as_mut() {
                    match r.regrip(&pchains[holding_hand(k + 1)], grip, &x) {
                        Ok(g) => rec.regrip = Some(RegripRecord::new(g, holding_hand(k))),
                        Err(e) => {
                            swings.push(rec);
                            status = TraverseStatus::SwitchFailed {
                                swing: k,
                                message: e.to_string(),
                            };
                            break;
                        }
                    }
                }
            }
            Err(e) => {
                swings.push(rec);
                status = TraverseStatus::SwitchFailed {
                    swing: k,
                    message: e.to_string(),
                };
                break;
            }
        }
        swings.push(rec);
        t_start += duration;
    }
    if stop() {
        return Ok(None);
    }
    if let Some(r) = &rapier {
        world.track = r.obstacle_track().map(<[f64]>::to_vec).collect();
    }
    Ok(Some(Traverse {
        status,
        swings,
        logs,
        chains,
        world,
        plant: if rapier.is_some() { "rapier" } else { "model" },
        ball,
    }))
}

/// One swing tracked on the plant: the log, the wall time of the closed loop, s, and the re-plans.
struct TrackedSwing {
    log: ClosedLoopLog,
    track_time_s: f64,
    replan_events: Vec<brachia::control::ReplanEvent>,
}

/// Track swing `k`'s plan `p` (`ls` the swing's scenario, `pchain` the plant's chain that holds, `x`
/// the start state) with the ladder's controller, re-planning when `[tracking] replan` asks for it,
/// on the rapier plant when there is one, else on a model plant of `pchain`.
#[allow(clippy::too_many_arguments)]
fn track_swing(
    ll: &LoadedLadder,
    ls: &LoadedScenario,
    pchain: &Robot,
    x: &[f64],
    p: &brachia::planning::Plan,
    plan_source: PlanSource,
    rapier: Option<&mut brachia_rapier::RapierPlant>,
    k: usize,
) -> Result<TrackedSwing, Error> {
    let sc = &ll.scenario;
    let robot = &ls.robot;
    let reference = &p.trajectory;
    let mut model = None;
    let mut plain: Option<Box<dyn Controller>> = None;
    let plant: &mut dyn Plant = match rapier {
        Some(r) => r,
        None => {
            let mut m = ModelPlant::new(pchain.clone(), x);
            m.substeps = sc.plant.substeps;
            model.insert(m)
        }
    };
    let base = make_controller(sc.tracking.controller, ls, reference)?;
    let mut replanning = match (&sc.tracking.replan, sc.tracking.controller) {
        (Some(rs), crate::scenario::ControllerKind::Mpc) => {
            let (task, planner, solver) =
                (&ls.scenario.task, &ls.scenario.planner, &ls.scenario.solver);
            let aim = (plan_source == PlanSource::Joint
                && sc.ladder.lookahead_switch == crate::ladder::LookaheadSwitch::Rest)
                .then(|| switch_pose_box(p));
            // with an aim, re-plans go for the joint plan's switch pose, not the swing's own optimum
            Some(Replanning::build_toward_end_box(
                base,
                robot.clone(),
                task,
                planner,
                solver,
                reference.clone(),
                rs.clone(),
                aim.as_deref(),
            )?)
        }
        _ => {
            plain = Some(base);
            None
        }
    };
    let ctrl: &mut dyn Controller = match (replanning.as_mut(), plain.as_mut()) {
        (Some(r), _) => r,
        (None, Some(c)) => c.as_mut(),
        (None, None) => {
            return Err(Error::InfeasibleTask("no controller was built".into()));
        }
    };
    let settings = RunSettings {
        duration_s: reference.duration() + sc.tracking.hold_s,
        control_dt: sc.tracking.control_dt,
        cancel: sc.solver.cancel.clone(),
    };
    let noise = NoiseSettings {
        q_std: sc.tracking.noise_q_std,
        qd_std: sc.tracking.noise_qd_std,
        seed: sc.tracking.seed.wrapping_add(k as u64),
    };
    let clock = std::time::Instant::now();
    let log = if noise.is_zero() {
        run_closed_loop(&mut *plant, &mut *ctrl, reference, robot, &settings)?
    } else {
        let mut noisy = Noisy::new(&mut *plant, noise)?;
        run_closed_loop(&mut noisy, &mut *ctrl, reference, robot, &settings)?
    };
    let track_time_s = clock.elapsed().as_secs_f64();
    let replan_events = replanning
        .as_ref()
        .map_or_else(Vec::new, |r| r.events().to_vec());
    Ok(TrackedSwing {
        log,
        track_time_s,
        replan_events,
    })
}

/// Record a swing's rapier contacts `contacts` in `rec` and in `world`, links renumbered to the
/// parameters file's order (swing `k` of an `n`-link chain: odd swings hang from hand B).
fn record_contacts(
    contacts: &[ContactEvent],
    k: usize,
    n: usize,
    rec: &mut SwingRecord,
    world: &mut PlantWorld,
) {
    for c in contacts {
        let flip = |j: usize| if holding_hand(k) == 1 { n - 1 - j } else { j };
        let body = match c.body {
            ContactBody::Link(j) => ContactBody::Link(flip(j)),
            other => other,
        };
        rec.contact_events += 1;
        rec.contact_impulse_n_s += c.impulse;
        world.contacts.push(ContactEvent {
            link: flip(c.link),
            body,
            ..*c
        });
    }
}

/// The header of `traverse.csv` for an `n`-link chain (see the module docs), without its newline.
pub(crate) fn csv_header(n: usize) -> String {
    let mut s = crate::schema::state_columns(n);
    s.push_str(",swing,holding_hand,grip_bar,grip_x,grip_y,hand_a_x,hand_a_y");
    for i in 1..n {
        let _ = write!(s, ",p{i}_x,p{i}_y");
    }
    s + ",hand_b_x,hand_b_y"
}

impl Traverse {
    /// The links' contacts with the ball of `[disturbances.ball]` (none without a ball, or on the
    /// model plant).
    pub fn ball_contacts(&self) -> impl Iterator<Item = &ContactEvent> {
        let body = self
            .ball
            .as_ref()
            .and_then(|b| b.obstacle_id)
            .map(ContactBody::Obstacle);
        self.world
            .contacts
            .iter()
            .filter(move |c| Some(c.body) == body)
    }

    /// World joint positions of row `row` of swing `k`'s log, in the parameters file's order (hand A
    /// first): n + 1 points.
    pub fn world_joints(&self, k: usize, row: usize) -> Vec<[f64; 2]> {
        let hand = holding_hand(k);
        let robot = &self.chains[hand];
        brachia::ladder::world_joints(robot, self.swings[k].grip, self.logs[k].x(row), hand)
    }

    /// `obstacles.csv` of a rapier traverse: `t,obstacle_0_x,obstacle_0_y,...` (traverse time s, world m).
    pub fn obstacles_csv(&self) -> String {
        let mut s = String::from("t");
        for i in 0..self.world.obstacles.len() {
            let _ = write!(s, ",obstacle_{i}_x,obstacle_{i}_y");
        }
        s.push('\n');
        for row in &self.world.track {
            let _ = write!(s, "{:.6}", row[0]);
            for v in &row[1..] {
                let _ = write!(s, ",{v:.9}");
            }
            s.push('\n');
        }
        s
    }

    /// `traverse.csv` (see the module docs for the header).
    pub fn to_csv(&self) -> String {
        let n = self.chains[0].n();
        let mut s = csv_header(n);
        s.push('\n');
        for (k, log) in self.logs.iter().enumerate() {
            let rec = &self.swings[k];
            let t0 = rec.t_start_s - log.t[0];
            for row in 0..log.len() {
                let _ = write!(s, "{:.6}", t0 + log.t[row]);
                for v in log.x(row).iter().chain(log.tau(row)) {
                    let _ = write!(s, ",{v:.9}");
                }
                let ee = log.ee[row];
                let _ = write!(
                    s,
                    ",{:.9},{:.9},{k},{},{},{:.9},{:.9}",
                    ee[0], ee[1], rec.holding_hand, rec.from_bar, rec.grip[0], rec.grip[1]
                );
                for p in self.world_joints(k, row) {
                    let _ = write!(s, ",{:.9},{:.9}", p[0], p[1]);
                }
                s.push('\n');
            }
        }
        s
    }

    /// The machine-readable report: per swing (energy by eq. 18, positive work, duration, capture error,
    /// switch residual, ...) and totals.
    pub fn report(&self, ll: &LoadedLadder) -> serde_json::Value {
        let sum = |f: fn(&SwingRecord) -> f64| self.swings.iter().map(f).sum::<f64>();
        let max = |f: fn(&SwingRecord) -> f64| self.swings.iter().map(f).fold(0.0, f64::max);
        let sim_s = sum(|s| s.duration_s);
        let wall_s = sum(|s| s.plan_time_s + s.track_time_s);
        json!({
            "scenario": ll.scenario.name,
            "robot": ll.robot.params().name,
            "links": ll.robot.n(),
            "plant": self.plant,
            "plant_substeps": ll.scenario.plant.substeps,
            "plant_mass_scale": ll.scenario.plant.mass_scale,
            "disturbances": ll.scenario.disturbances,
            "plant_obstacles": self.world.obstacles,
            "ball": self.ball,
            "ball_contact_events": self.ball_contacts().count(),
            "first_contact_s": self.world.first_contact_s(),
            "controller": ll.scenario.tracking.controller,
            "status": self.status,
            "message": self.status.to_string(),
            "completed": self.status.completed(),
            "bars": ll.scenario.ladder.bars,
            "capture_radius_m": ll.scenario.ladder.capture_radius,
            "capture_speed_m_s": ll.scenario.ladder.capture_speed,
            "obstacles": ll.scenario.ladder.obstacles,
            "start_state": ll.x0,
            "swings": self.swings,
            "totals": {
                "swings_tracked": self.swings.len(),
                "bars_caught": self.swings.iter().filter(|s| s.captured).count(),
                "energy_j": sum(|s| s.energy_j),
                "planned_energy_j": sum(|s| s.planned_energy_j),
                "positive_work_j": sum(|s| s.positive_work_j),
                "duration_s": sim_s,
                "capture_error_max_m": max(|s| s.capture_error_m),
                "switch_residual_max_m_s": max(|s| s.switch_residual_m_s),
                "capture_impact_j": sum(|s| s.capture_impact_j),
                "regrip_position_residual_max_m": self.swings.iter().filter_map(|s| s.regrip.as_ref()).map(|r| r.position_residual_m).fold(0.0, f64::max),
                "contact_events": self.world.contacts.len(),
                "contact_impulse_n_s": self.world.contacts.iter().map(|c| c.impulse).sum::<f64>(),
                "replans": self.swings.iter().map(|s| s.replans).sum::<usize>(),
                "plan_time_s": sum(|s| s.plan_time_s),
                "track_time_s": sum(|s| s.track_time_s),
                "wall_time_s": wall_s,
                "real_time_factor": if wall_s > 0.0 { sim_s / wall_s } else { 0.0 },
            },
        })
    }

    /// The run folder: `traverse.csv`, `report.json`, `scenario.toml` (the resolved inputs) and the
    /// figures `traverse_stick.png/.svg` (every 0.25 s, world frame), `traverse.gif` (the whole
    /// traverse in the world at 20 frames per second) and `energy_per_swing.png/.svg`.
    /// Figures are rendered into a private temporary folder and queued like every other file. The
    /// animation checks `ll.scenario.solver.cancel` before every frame: once it is set this returns
    /// [`crate::ExpError::Cancelled`].
    pub fn folder(&self, ll: &LoadedLadder) -> Result<RunFolder, crate::ExpError> {
        let mut folder = RunFolder::default();
        folder.add("traverse.csv", self.to_csv());
        folder.add_json("report.json", &self.report(ll));
        if self.plant == "rapier" {
            folder.add("contacts.csv", self.world.contacts_csv());
            folder.add("obstacles.csv", self.obstacles_csv());
        }
        let mut resolved = ll.scenario.clone();
        let n = ll.robot.n();
        resolved.ladder.q0 = ll.x0[..n].to_vec();
        resolved.ladder.qd0 = ll.x0[n..].to_vec();
        folder.add(
            "scenario.toml",
            format!(
                "# Resolved inputs of this traverse (start state filled in).\n{}",
                toml::to_string(&resolved).unwrap_or_default()
            ),
        );
        if self.logs.is_empty() {
            return Ok(folder);
        }
        let tmp = std::env::temp_dir().join(format!(
            "{}{}-{}",
            crate::staging::DRAW_STAGE_PREFIX,
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0)
        ));
        let werr = |e: std::io::Error| crate::ExpError::Write {
            path: tmp.clone(),
            source: e,
        };
        crate::staging::clear_stale(&std::env::temp_dir(), crate::staging::DRAW_STAGE_PREFIX);
        crate::staging::create(&tmp).map_err(werr)?;
        let drawn = self.draw(ll, &tmp);
        let mut result = Ok(());
        if drawn.is_ok() {
            for name in [
                "traverse_stick.png",
                "traverse_stick.svg",
                "energy_per_swing.png",
                "energy_per_swing.svg",
                "traverse.gif",
            ] {
                match std::fs::read(tmp.join(name)) {
                    Ok(data) => folder.add(name, data),
                    Err(e) => {
                        result = Err(werr(e));
                        break;
                    }
                }
            }
        }
        crate::staging::remove(&tmp);
        drawn.map_err(|e| match e {
            brachia_plot::PlotError::Cancelled { .. } => crate::ExpError::Cancelled,
            e => crate::ExpError::Write {
                path: e.path().to_path_buf(),
                source: std::io::Error::other(e.to_string()),
            },
        })?;
        result.map(|()| folder)
    }

    fn draw(
        &self,
        ll: &LoadedLadder,
        dir: &std::path::Path,
    ) -> Result<(), brachia_plot::PlotError> {
        use brachia_plot::{
            animate_poses_gif, line_plot, pose_diagram, AnimOptions, LinePlot, Obstacle,
            PoseFigure, Series,
        };
        let bars: Vec<[f64; 2]> = ll.scenario.ladder.bars.iter().map(|b| b.p()).collect();
        let mut fig = PoseFigure {
            title: format!("{}: traverse, every 0.25 s", ll.scenario.name),
            target: bars.last().copied(),
            bars,
            obstacles: ll
                .scenario
                .ladder
                .obstacles
                .iter()
                .map(|o| Obstacle {
                    center: o.center,
                    radius: o.radius.max(1e-3),
                })
                .collect(),
            ..PoseFigure::default()
        };
        let mut next = 0.0;
        let (mut frames, mut hands, mut next_frame) = (Vec::new(), Vec::new(), 0.0);
        for (k, log) in self.logs.iter().enumerate() {
            let t0 = self.swings[k].t_start_s - log.t[0];
            for row in 0..log.len() {
                let t = t0 + log.t[row];
                let joints = self.world_joints(k, row);
                // the swinging hand: hand B on even swings, hand A on odd ones
                let hand = if holding_hand(k) == 0 {
                    joints[joints.len() - 1]
                } else {
                    joints[0]
                };
                if row % 10 == 0 {
                    fig.trail.push(hand);
                }
                let last = k + 1 == self.logs.len() && row + 1 == log.len();
                if t >= next_frame - 1e-9 || last {
                    frames.push((t, joints.clone()));
                    hands.push(hand);
                    next_frame = t + 1.0 / GIF_FPS;
                }
                if t >= next - 1e-9 || last {
                    fig.poses.push((t, joints));
                    next = t + 0.25;
                }
            }
        }
        animate_poses_gif(
            dir.join("traverse.gif"),
            &frames,
            &hands,
            &AnimOptions {
                fps: GIF_FPS,
                size: (800, 400),
                title: format!("{}: traverse", ll.scenario.name),
                bars: fig.bars.clone(),
                target: fig.target,
                obstacles: fig.obstacles.clone(),
                cancel: ll.scenario.solver.cancel.clone(),
                ..AnimOptions::default()
            },
        )?;
        pose_diagram(dir.join("traverse_stick.png"), &fig)?;
        let idx: Vec<f64> = self.swings.iter().map(|s| s.swing as f64).collect();
        line_plot(
            dir.join("energy_per_swing.png"),
            &LinePlot {
                title: format!("{}: energy per swing", ll.scenario.name),
                x_label: "swing".into(),
                y_label: "energy (J)".into(),
                series: vec![
                    Series::new(
                        "tracked, eq. 18",
                        idx.clone(),
                        self.swings.iter().map(|s| s.energy_j).collect(),
                    ),
                    Series::new(
                        "planned, eq. 18",
                        idx.clone(),
                        self.swings.iter().map(|s| s.planned_energy_j).collect(),
                    )
                    .dashed(),
                    Series::new(
                        "positive work",
                        idx,
                        self.swings.iter().map(|s| s.positive_work_j).collect(),
                    ),
                ],
                size: None,
            },
        )
    }
}
