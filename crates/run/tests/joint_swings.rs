//! The joint multi-swing plan (docs/ladders.md, "The joint multi-swing plan"): two swings of
//! the even ladder (the paper's robot, `scenarios/ladder-even.toml` as written) planned as one problem
//! sharing the switch state, against the same swings planned one by one: the joint solve converges from
//! the swing-by-swing plans put end to end and lowers their summed objective, every capture holds to the
//! solver's tolerance, and the joint plan's torques replayed open loop on the model (with the grasp
//! switch between the swings) reach every bar. The same on a 3-link robot and an asymmetric one.
//!
//! Conventions: world frame x right, y up, m; rad; SI units.

use brachia::model::switch_grip;
use brachia::planning::JointSwingPlan;
use brachia::sim::{ModelPlant, Plant};
use brachia::Robot;
use brachia_run::ladder::joint_swings;
use brachia_run::{LadderScenario, LoadedLadder};
use std::f64::consts::TAU;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn load(name: &str) -> LoadedLadder {
    LadderScenario::load(&root().join("scenarios").join(name)).unwrap()
}

/// Replay the joint plan's held torques open loop on the model plant (RK4 at 1 ms) from the ladder's
/// start, switching the grip at the end of every swing ([`switch_grip`]: the capture impulse, then the
/// re-rooted chain, its q1 taken as the representative the plan uses): the largest distance of the
/// hand from its bar at the end of a swing (m), and the largest state difference from the plan's
/// knots (rad, rad/s).
fn replay(ll: &LoadedLadder, j: &JointSwingPlan) -> (f64, f64) {
    let n = ll.robot.n();
    let chains = [ll.robot.clone(), ll.robot.rerooted().unwrap()];
    let bars = &ll.scenario.ladder.bars;
    let mut x = ll.x0.clone();
    let mut grip = bars[0].p();
    let (mut miss, mut dev) = (0.0f64, 0.0f64);
    for (i, ph) in j.phases.iter().enumerate() {
        let robot: &Robot = &chains[i % 2];
        let pts = &ph.plan.points;
        let k_last = ph.plan.layout.intervals;
        let h = ph.plan.layout.h;
        // the plan's representative of q1 at knot 0 (the map leaves it wrapped)
        let turns = ((pts.q(0)[0] - x[0]) / TAU).round();
        x[0] += TAU * turns;
        let mut plant = ModelPlant::new(robot.clone(), &x);
        plant.substeps = (h / 1e-3).ceil() as usize;
        for k in 0..k_last {
            plant.state(&mut x);
            for (a, b) in x.iter().zip(pts.q(k).iter().chain(pts.qd(k))) {
                dev = dev.max((a - b).abs());
            }
            plant.step(pts.tau(k), h);
        }
        plant.state(&mut x);
        for (a, b) in x.iter().zip(pts.q(k_last).iter().chain(pts.qd(k_last))) {
            dev = dev.max((a - b).abs());
        }
        let ee = robot.ee_position(&x[..n]);
        let bar = bars[i + 1].p();
        miss = miss.max((grip[0] + ee[0] - bar[0]).hypot(grip[1] + ee[1] - bar[1]));
        let s = switch_grip(robot, grip, &x).unwrap();
        x = s.x;
        grip = s.grip;
    }
    (miss, dev)
}

/// What every converged joint plan must show against its swing-by-swing reference.
fn check(ll: &LoadedLadder, j: &JointSwingPlan, swings: usize) {
    let tol = ll.scenario.solver.constr_viol_tol;
    assert!(j.converged(), "{:?}", j.status);
    assert_eq!(j.phases.len(), swings);
    assert_eq!(j.reference.len(), swings);
    // the reference objective is the joint problem's cost at the swing-by-swing plans: the same sum as
    // the planner reported for each swing
    let planned: f64 = j.reference.iter().map(|p| p.objective).sum();
    assert!(
        (j.reference_objective - planned).abs() <= 1e-9 * planned.abs(),
        "reference objective {} vs planned {planned}",
        j.reference_objective
    );
    let phases: f64 = j.phases.iter().map(|p| p.objective).sum();
    assert!((j.objective - phases).abs() <= 1e-9 * phases.abs());
    assert!(
        j.objective <= j.reference_objective,
        "joint objective {} above swing by swing {}",
        j.objective,
        j.reference_objective
    );
    // every capture (the inner switches and the last bar) to the solver's tolerance, every transition
    // (shooting, capture, switch map) without a defect above it
    for (i, p) in j.phases.iter().enumerate() {
        let v = &p.plan.violations;
        assert!(
            v.ee_position <= tol && v.ee_velocity <= tol,
            "swing {i}: capture residual {} m, {} m/s",
            v.ee_position,
            v.ee_velocity
        );
        assert!(v.bounds <= tol && v.dynamics <= tol, "swing {i}: {v:?}");
        assert_eq!(p.holding_hand, i % 2);
    }
    assert!(j.max_defect <= tol, "max defect {}", j.max_defect);
    // the rest condition at the last knot of the last swing
    let last = &j.phases[swings - 1].plan;
    let qd_end = ll.scenario.planner.bounds.qd_end_max.unwrap();
    assert!(last
        .points
        .qd(last.layout.intervals)
        .iter()
        .all(|v| v.abs() <= qd_end + tol));
    let (miss, dev) = replay(ll, j);
    assert!(miss < 1e-4, "replayed hand {miss} m from a bar");
    assert!(dev < 1e-3, "replay {dev} from the plan's knots");
}

#[test]
fn two_swings_of_the_even_ladder_planned_jointly_cost_less_than_swing_by_swing() {
    let ll = load("ladder-even.toml");
    let j = joint_swings(&ll, 2, false).unwrap();
    check(&ll, &j, 2);
    // with the rest condition kept at the switch, the first swing ends at rest as well
    let rest = joint_swings(&ll, 2, true).unwrap();
    check(&ll, &rest, 2);
    let first = &rest.phases[0].plan;
    let qd_end = ll.scenario.planner.bounds.qd_end_max.unwrap();
    assert!(first
        .points
        .qd(first.layout.intervals)
        .iter()
        .all(|v| v.abs() <= qd_end + 1e-6));
}

#[test]
fn two_swings_of_a_three_link_robot_planned_jointly_cost_less_than_swing_by_swing() {
    let ll = load("ladder-even-three-link.toml");
    assert_eq!(ll.robot.n(), 3);
    let j = joint_swings(&ll, 2, false).unwrap();
    check(&ll, &j, 2);
}

/// An asymmetric 3-link robot (link 1 heavier than link 3, its centre of mass nearer the grip, link 3
/// stiffer to turn), so the re-rooted chain of swing 1 differs from the chain of swing 0.
#[test]
fn two_swings_of_an_asymmetric_three_link_robot_planned_jointly_cost_less_than_swing_by_swing() {
    let mut ll = load("ladder-even-three-link.toml");
    let mut p = ll.robot.params().clone();
    p.links[0].mass *= 1.4;
    p.links[0].com *= 0.8;
    p.links[2].inertia *= 1.5;
    p.links[1].mass *= 0.9;
    ll.robot = Robot::from_params(p, "asymmetric three-link").unwrap();
    let rr = ll.robot.rerooted().unwrap();
    assert_ne!(rr.params().links[0], ll.robot.params().links[0]);
    let j = joint_swings(&ll, 2, false).unwrap();
    check(&ll, &j, 2);
}

#[test]
fn a_joint_plan_is_refused_past_the_ladder_or_on_another_backend() {
    let ll = load("ladder-even.toml");
    assert!(joint_swings(&ll, 0, false).is_err());
    assert!(joint_swings(&ll, 6, false).is_err());
    let mut other = load("ladder-even.toml");
    other.scenario.solver.backend = brachia::planning::Backend::Pounce;
    let e = joint_swings(&other, 2, false).unwrap_err().to_string();
    assert!(e.contains("solver.backend"), "{e}");
}
