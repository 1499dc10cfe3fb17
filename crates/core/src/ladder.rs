//! Ladders in the library: the bars and their reach rule, the order of the swings and the hand that
//! holds on each (the grip-switch map), the maps between a swing's grip frame and the world, and the
//! task of each swing, alone or planned jointly with the swings after it. The traverse
//! (`brachia traverse`) runs these swing by swing on a plant; a library user can run them on theirs.
//!
//! Conventions: **world frame** x right, y up, gravity along -y, metres; bar 0 is where the robot
//! starts (its grip), the last bar is the goal. Swing `k` goes from bar `k` to bar `k + 1`. **Hands**:
//! hand A is the end of the parameters file's link 1, hand B the end of its link n; swings 0, 2, 4, ...
//! hang from hand A (the chain as written), swings 1, 3, ... from hand B (the chain re-rooted,
//! [`Robot::rerooted`]; [`holding_hand`], [`chains`]). Within a swing the chain is in its **grip
//! frame**: link 1 at the current grip, `q[0]` absolute from +x, the rest relative (rad; SI units).
//!
//! **Reach rule** ([`check_bars`]): the distance between consecutive bars must lie in
//! `[MIN_SPACING_OF_SPAN, MAX_SPACING_OF_SPAN]` times the arm span (sum of the link lengths), for the
//! chain as it will hang (the span is the same both ways round). The upper limit keeps the chain away
//! from the stretched, singular pose where the capture impulse is undefined; the lower one refuses
//! swings shorter than a quarter span, which are not brachiation (the hands would collide).

use crate::model::{ik_from_seed, Circle};
use crate::planning::{
    freefall_time, Bounds, JointSwingPlan, JointSwingTask, Plan, PlannerSettings, SwingTask,
    SwingTime,
};
use crate::{Error, Robot};
use serde::{Deserialize, Serialize};

/// Smallest bar spacing, as a fraction of the arm span.
pub const MIN_SPACING_OF_SPAN: f64 = 0.25;
/// Largest bar spacing, as a fraction of the arm span.
pub const MAX_SPACING_OF_SPAN: f64 = 0.95;
/// Most bars of a ladder (bounds the traverse log: every swing is at most
/// [`crate::limits::MAX_RUN_STEPS`] control steps).
pub const MAX_BARS: usize = 16;

/// One bar, world frame, m. Written `{ x = 1.0, y = 0.0 }`, or `[1.0, 0.0]` with exactly two values (a
/// third value is an error, not dropped).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Bar {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
}

impl<'de> Deserialize<'de> for Bar {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        #[derive(Deserialize)]
        #[serde(deny_unknown_fields)]
        struct Xy {
            x: f64,
            y: f64,
        }
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = Bar;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a bar { x = .., y = .. } or [x, y]")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(self, map: A) -> Result<Bar, A::Error> {
                let xy = Xy::deserialize(serde::de::value::MapAccessDeserializer::new(map))?;
                Ok(Bar { x: xy.x, y: xy.y })
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, seq: A) -> Result<Bar, A::Error> {
                let [x, y] =
                    crate::serde_exact::pair(serde::de::value::SeqAccessDeserializer::new(seq))?;
                Ok(Bar { x, y })
            }
        }
        d.deserialize_any(V)
    }
}

impl Bar {
    /// `[x, y]`.
    pub fn p(&self) -> [f64; 2] {
        [self.x, self.y]
    }
}

/// Check the bars: count, finite values, and the reach rule between consecutive bars.
pub fn check_bars(robot: &Robot, bars: &[Bar], src: &str) -> Result<(), Error> {
    if bars.len() < 2 || bars.len() > MAX_BARS {
        return Err(Error::invalid(
            src,
            "ladder.bars",
            format!("{} bars", bars.len()),
            format!("a ladder needs between 2 and {MAX_BARS} bars"),
        ));
    }
    for (i, b) in bars.iter().enumerate() {
        for (name, v) in [("x", b.x), ("y", b.y)] {
            if !(v.is_finite() && v.abs() <= 1e3) {
                return Err(Error::invalid(
                    src,
                    format!("ladder.bars[{i}].{name}"),
                    v,
                    "must be finite and within 1000 m",
                ));
            }
        }
    }
    let span = robot.reach();
    let (lo, hi) = (MIN_SPACING_OF_SPAN * span, MAX_SPACING_OF_SPAN * span);
    for i in 1..bars.len() {
        let d = (bars[i].x - bars[i - 1].x).hypot(bars[i].y - bars[i - 1].y);
        if d > hi {
            return Err(Error::invalid(
                src,
                format!("ladder.bars[{i}]"),
                format!("({}, {})", bars[i].x, bars[i].y),
                format!(
                    "is {d:.3} m from bar {}: out of reach (the arm span is {span:.3} m; bars may be \
                     at most {MAX_SPACING_OF_SPAN} x span = {hi:.3} m apart)",
                    i - 1
                ),
            ));
        }
        if d < lo {
            return Err(Error::invalid(
                src,
                format!("ladder.bars[{i}]"),
                format!("({}, {})", bars[i].x, bars[i].y),
                format!(
                    "is {d:.3} m from bar {}: too close (bars must be at least \
                     {MIN_SPACING_OF_SPAN} x span = {lo:.3} m apart; the arm span is {span:.3} m)",
                    i - 1
                ),
            ));
        }
        // a ladder goes on: a bar at (or about at) an earlier bar other than the one held would have
        // the swinging hand come back to where the chain already hangs from
        for j in 0..i.saturating_sub(1) {
            let d = (bars[i].x - bars[j].x).hypot(bars[i].y - bars[j].y);
            if d < lo {
                return Err(Error::invalid(
                    src,
                    format!("ladder.bars[{i}]"),
                    format!("({}, {})", bars[i].x, bars[i].y),
                    format!(
                        "is {d:.3} m from bar {j}: a ladder may not return to an earlier bar (every \
                         bar at least {MIN_SPACING_OF_SPAN} x span = {lo:.3} m from every bar before \
                         it; the arm span is {span:.3} m)"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The default hang at bar 0: the swing hand on a virtual bar `bar0 - (bar1 - bar0)`, in the grip
/// frame; inverse kinematics from a V-shaped seed (the chain dips below the bars). `None` when no pose
/// within the planner's bounds reaches it.
pub fn default_hang(robot: &Robot, bars: &[Bar], settings: &PlannerSettings) -> Option<Vec<f64>> {
    let n = robot.n();
    let target = [bars[0].x - bars[1].x, bars[0].y - bars[1].y];
    let dir = target[1].atan2(target[0]);
    let sgn = if target[0] < 0.0 { 1.0 } else { -1.0 };
    let alpha = 0.8;
    let mut seed = vec![0.0; n];
    seed[0] = wrap(dir + sgn * alpha);
    seed[n / 2] = -2.0 * sgn * alpha;
    let q = ik_from_seed(robot, &seed, target)?;
    let q: Vec<f64> = q.into_iter().map(wrap).collect();
    let b = &settings.bounds;
    let inside =
        q[0] >= b.q1[0] && q[0] <= b.q1[1] && q[1..].iter().all(|v| v.abs() <= b.q_rel_max);
    inside.then_some(q)
}

/// Wrap an angle into (-pi, pi].
fn wrap(a: f64) -> f64 {
    let (pi, tau) = (std::f64::consts::PI, std::f64::consts::TAU);
    let mut v = a % tau;
    if v <= -pi {
        v += tau;
    } else if v > pi {
        v -= tau;
    }
    v
}

/// The swing time of a swing from `q0` to `target` (grip frame) under `settings`: the given seconds,
/// or 2 T_freefall towards the midpoint between the EE and the target; when the locked chain never
/// reaches that midpoint (a straight hang), twice its half period of small oscillation, the longest
/// swing time the planner's search in T starts from (see [`crate::planning::strategy::swing_time`]).
pub fn swing_time(
    robot: &Robot,
    q0: &[f64],
    target: [f64; 2],
    settings: &PlannerSettings,
) -> Result<f64, Error> {
    match settings.swing_time {
        SwingTime::Seconds(t) => Ok(t),
        SwingTime::Auto(_) => {
            let ee = robot.ee_position(q0);
            match freefall_time(robot, q0, 0.5 * (ee[0] + target[0])) {
                Ok(tf) => Ok(2.0 * tf),
                Err(Error::InfeasibleTask(m)) => crate::planning::reference_swing_time(robot, q0)
                    .map(|r| 2.0 * r)
                    .ok_or(Error::InfeasibleTask(m)),
                Err(e) => Err(e),
            }
        }
    }
}

/// The hand that holds during swing `swing`: `0` (hand A, the chain as written) on swings 0, 2, 4,
/// ..., `1` (hand B, the chain re-rooted) on swings 1, 3, ... The grip-switch map: each capture
/// hands the grip to the other end of the chain.
pub fn holding_hand(swing: usize) -> usize {
    swing % 2
}

/// The two chains of a ladder, indexed by [`holding_hand`]: `robot` as written (hand A at the grip)
/// and re-rooted at hand B.
pub fn chains(robot: &Robot) -> Result<[Robot; 2], Error> {
    Ok([robot.clone(), robot.rerooted()?])
}

/// The task of the swing to bar `to` from the state `(q0, qd0)` (grip frame; `qd0` empty = at rest)
/// of the chain holding `grip` (world): the target bar and the `obstacles` (world frame) moved into
/// the grip frame ([`SwingTask::on_ladder`]).
pub fn swing_task(
    bars: &[Bar],
    obstacles: &[Circle],
    q0: &[f64],
    qd0: &[f64],
    grip: [f64; 2],
    to: usize,
) -> SwingTask {
    SwingTask::on_ladder(q0, qd0, grip, bars[to].p(), obstacles)
}

/// A later swing starts where the last one left the chain: its link 1 (the old link n) may point
/// above the bar, a relative joint may end a little past `bounds.q_rel_max` (the bound is on the plan;
/// a tracked chain follows it within its tracking error), and its joint rates may exceed
/// `bounds.qd_max` a little. Take the start angle's representative (mod 2 pi) nearest `bounds.q1`,
/// then widen the bounds to take the start state ([`Bounds::widened_for_start`], the rule a re-plan
/// from a measured state uses).
pub fn later_swing_start(task: &mut SwingTask, bounds: &mut Bounds) {
    task.q0[0] = bounds.nearest_q1(task.q0[0]);
    let x: Vec<f64> = task.q0.iter().chain(&task.qd0).copied().collect();
    *bounds = bounds.widened_for_start(&x);
}

/// The joint positions of `chain` (the chain that holds, [`chains`]) at `q` (its grip frame) in the
/// world frame, in the parameters file's order (hand A first): n + 1 points, `grip` (world) added and
/// the order reversed when hand B holds.
pub fn world_joints(
    chain: &Robot,
    grip: [f64; 2],
    q: &[f64],
    holding_hand: usize,
) -> Vec<[f64; 2]> {
    let n = chain.n();
    let mut p = vec![[0.0; 2]; n + 1];
    chain.joint_positions(&q[..n], &mut p);
    let mut w: Vec<[f64; 2]> = p.iter().map(|v| [v[0] + grip[0], v[1] + grip[1]]).collect();
    if holding_hand == 1 {
        w.reverse();
    }
    w
}

/// The joint multi-swing task from the state `x0` of the chain holding `grip` (world) through `bars`
/// (world, one per swing), with `obstacles` (world), the rest condition at the last bar (and at every
/// switch with `rest_at_switches`; [`crate::planning::plan_joint_swings`]).
pub fn joint_swing_task(
    x0: Vec<f64>,
    grip: [f64; 2],
    bars: &[Bar],
    obstacles: &[Circle],
    rest_at_switches: bool,
) -> JointSwingTask {
    JointSwingTask {
        x0,
        bars: std::iter::once(grip)
            .chain(bars.iter().map(Bar::p))
            .collect(),
        obstacles: obstacles.to_vec(),
        rest_at_switches,
    }
}

/// How far the online re-plans of a joint-planned swing may end from the joint plan's switch pose,
/// per joint, rad ([`switch_pose_box`]).
pub const SWITCH_POSE_MARGIN_RAD: f64 = 0.1;

/// The end box the online re-plans of the first swing of a joint plan aim at (docs/ladders.md,
/// "Lookahead"): each joint angle within [`SWITCH_POSE_MARGIN_RAD`] of the joint plan's own end pose
/// of that swing (the switch pose it chose for the swings after it), the rates free (the rest
/// condition of the planner's bounds holds there anyway).
pub fn switch_pose_box(plan: &Plan) -> Vec<[f64; 2]> {
    let tr = &plan.trajectory;
    let q = tr.q(tr.len() - 1);
    let m = SWITCH_POSE_MARGIN_RAD;
    q.iter()
        .map(|v| [v - m, v + m])
        .chain(std::iter::repeat_n(
            [f64::NEG_INFINITY, f64::INFINITY],
            q.len(),
        ))
        .collect()
}

/// A joint multi-swing plan and its swing-by-swing reference as JSON (`joint_swings.json` of the
/// reproduction's `ladder/` folder; docs/ladders.md): the status, the totals of both plans (objective,
/// eq. 18 energy, positive work, solver iterations and time) and per swing the same with the capture
/// residuals and the largest joint rate at the swing's end.
pub fn joint_swings_json(j: &JointSwingPlan) -> serde_json::Value {
    use serde_json::json;
    let (pos, vel) = j.capture_residual();
    let end_rate = |p: &Plan| {
        p.points
            .qd(p.layout.intervals)
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let phases: Vec<_> = j
        .phases
        .iter()
        .zip(&j.reference)
        .enumerate()
        .map(|(i, (p, r))| {
            json!({
                "swing": i,
                "holding_hand": p.holding_hand,
                "objective": p.objective,
                "reference_objective": p.reference_objective,
                "energy_j": p.plan.energy_j,
                "reference_energy_j": r.energy_j,
                "positive_work_j": p.plan.positive_work_j,
                "reference_positive_work_j": r.positive_work_j,
                "capture_position_m": p.plan.violations.ee_position,
                "capture_speed_m_s": p.plan.violations.ee_velocity,
                "end_rate_max_rad_s": end_rate(&p.plan),
                "reference_end_rate_max_rad_s": end_rate(r),
            })
        })
        .collect();
    json!({
        "swings": j.reference.len().max(j.phases.len()),
        "converged": j.converged(),
        "status": j.status.to_string(),
        "joint": {
            "objective": j.objective,
            "energy_j": j.energy_j(),
            "positive_work_j": j.phases.iter().map(|p| p.plan.positive_work_j).sum::<f64>(),
            "iterations": j.solve.as_ref().map(|s| s.iterations),
            "solve_time_s": j.solve.as_ref().map(|s| s.time_s),
            "max_defect": j.max_defect,
            "capture_position_m": pos,
            "capture_speed_m_s": vel,
        },
        "swing_by_swing": {
            "objective": j.reference_objective,
            "energy_j": j.reference_energy_j(),
            "positive_work_j": j.reference.iter().map(|p| p.positive_work_j).sum::<f64>(),
            "iterations": j.reference.iter().map(|p| p.iterations).sum::<usize>(),
            "solve_time_s": j.reference.iter().map(|p| p.solve_time_s).sum::<f64>(),
        },
        "phases": phases,
    })
}
