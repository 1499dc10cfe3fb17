//! The planner's multiple-shooting path (`transcription = "multiple-shooting"`) on the paper's
//! tracking scenario: the stage-structured solver (`backend = "ocp"`) and pounce (through the OCP
//! adapter) solve the same problem to the same optimum; the plan's knots, its held-torque trajectory
//! and the independent open-loop replay; the settings that are refused. Units: m, rad, s, N m.

use brachia::model::{Circle, Robot};
use brachia::planning::{
    plan, plan_with_guess, Backend, NlpSettings, PlannerSettings, SwingTask, Transcription,
};
use brachia::Error;

const Q0: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];

fn tracking_task() -> SwingTask {
    SwingTask {
        q0: Q0.to_vec(),
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    }
}

fn shooting(knot_dt: f64) -> PlannerSettings {
    PlannerSettings {
        transcription: Transcription::MultipleShooting,
        knot_dt,
        shooting: brachia::planning::ShootingSettings {
            substeps: 1,
            ..Default::default()
        },
        ..Default::default()
    }
}

fn backend(b: Backend) -> NlpSettings {
    NlpSettings {
        backend: b,
        ..Default::default()
    }
}

#[test]
fn ocp_backend_plans_the_tracking_swing_and_its_torques_reach_the_bar() {
    let robot = Robot::paper();
    let s = shooting(0.01);
    let p = plan(&robot, &tracking_task(), &s, &backend(Backend::Ocp)).unwrap();
    assert!(p.converged(), "{:?}", p.status);
    let v = p.violations;
    assert!(
        v.dynamics < 1e-8 && v.ee_position < 1e-8 && v.ee_velocity < 1e-8,
        "{v:?}"
    );
    assert!(v.bounds <= 1e-9, "{v:?}");
    // the independent 0.1 ms replay of the held torques ends within 1 mm of the bar
    assert!(p.replay_ee_error_m < 1e-3, "replay {}", p.replay_ee_error_m);
    // K + 1 knots, tau at knot k = u_k, last = u_{K-1}; start state fixed; torque limits
    let k_last = p.layout.intervals;
    assert_eq!(p.points.len(), k_last + 1);
    assert_eq!(p.points.q(0), &Q0);
    assert_eq!(p.points.tau(k_last), p.points.tau(k_last - 1));
    assert!(p.points.tau.iter().all(|t| t.abs() <= 5.0 + 1e-9));
    // the output trajectory: 1 ms samples, the held torques, ending exactly at T
    let tr = &p.trajectory;
    assert!((tr.t[1] - tr.t[0] - 1e-3).abs() < 1e-12);
    assert_eq!(*tr.t.last().unwrap(), p.swing_time_s);
    let h = p.layout.h;
    // sample j holds the mean of the held torques over its period [t_j, t_j+1) (docs/conventions.md)
    let mut straddling = 0;
    for j in 0..tr.len() - 1 {
        let (t0, t1) = (tr.t[j], tr.t[j + 1]);
        let (ka, kb) = (
            ((t0 / h).floor() as usize).min(k_last - 1),
            ((t1 / h).floor() as usize).min(k_last - 1),
        );
        for i in 0..3 {
            let want = if ka == kb {
                p.points.tau(ka)[i]
            } else {
                straddling += 1;
                let tk = kb as f64 * h;
                ((tk - t0) * p.points.tau(ka)[i] + (t1 - tk) * p.points.tau(kb)[i]) / (t1 - t0)
            };
            assert!((tr.tau(j)[i] - want).abs() < 1e-9, "sample {j} at {t0}");
        }
    }
    assert!(straddling > 0);
    // it passes through the knots it starts from and ends at the final knot (to integration error)
    let last = tr.len() - 1;
    for i in 0..4 {
        assert!((tr.q(last)[i] - p.points.q(k_last)[i]).abs() < 1e-7);
    }
    let split = p.time_split;
    assert!(split.linear_algebra_s > 0.0 && split.callbacks_s > 0.0);
    assert!((split.total_s() - p.solve_time_s).abs() <= 1e-9 * p.solve_time_s.max(1.0));
    assert_eq!(p.solves.len(), 1);
    assert_eq!(p.solves[0].passes[0].what, "ocp");
    assert!(p.iterations > 0 && p.energy_j.is_finite());
}

#[test]
fn ocp_and_pounce_reach_the_same_optimum() {
    let robot = Robot::paper();
    let s = shooting(0.02);
    let a = plan(&robot, &tracking_task(), &s, &backend(Backend::Ocp)).unwrap();
    let b = plan(&robot, &tracking_task(), &s, &backend(Backend::Pounce)).unwrap();
    assert!(
        a.converged() && b.converged(),
        "{:?} {:?}",
        a.status,
        b.status
    );
    let rel = (a.objective - b.objective).abs() / b.objective;
    assert!(
        rel < 1e-6,
        "ocp {} vs pounce {} (rel {rel:e})",
        a.objective,
        b.objective
    );
    let dq = a
        .points
        .q
        .iter()
        .zip(&b.points.q)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    assert!(dq < 1e-4, "largest knot angle difference {dq}");
    assert!(b.solves.iter().any(|a| a.adopted));
    assert_eq!(
        b.iterations,
        b.solves.iter().map(|a| a.iterations).sum::<usize>()
    );
}

#[test]
fn a_plan_warm_starts_the_next() {
    let robot = Robot::paper();
    let s = shooting(0.02);
    let cold = plan(&robot, &tracking_task(), &s, &backend(Backend::Ocp)).unwrap();
    let warm = plan_with_guess(
        &robot,
        &tracking_task(),
        &s,
        &backend(Backend::Ocp),
        Some(&cold.points),
    )
    .unwrap();
    assert!(warm.converged(), "{:?}", warm.status);
    assert!(
        warm.iterations < cold.iterations,
        "{} vs {}",
        warm.iterations,
        cold.iterations
    );
    assert!((warm.objective - cold.objective).abs() < 1e-6 * cold.objective);
}

#[test]
fn obstacle_is_avoided_by_multiple_shooting() {
    let robot = Robot::paper();
    let task = SwingTask {
        target: [0.5, 0.0],
        obstacles: vec![Circle {
            center: [0.55, -0.2],
            radius: 0.1,
        }],
        ..tracking_task()
    };
    let p = plan(&robot, &task, &shooting(0.01), &backend(Backend::Ocp)).unwrap();
    assert!(p.converged(), "{:?}", p.status);
    assert!(p.violations.clearance <= 1e-8, "{:?}", p.violations);
    // clearance is imposed at the knots; between them (1 ms samples) it may dip by a fraction of a mm
    let c = p.min_obstacle_clearance_m.unwrap();
    assert!(c > -1e-3, "clearance over the 1 ms trajectory {c}");
    // pounce (IPOPT's algorithm) on the identical problem from the same guess: the same optimum
    let q = plan(&robot, &task, &shooting(0.01), &backend(Backend::Pounce)).unwrap();
    assert!(q.converged(), "{:?}", q.status);
    assert!(
        (p.objective - q.objective).abs() <= 1e-6 * q.objective.abs(),
        "ocp {} vs pounce {}",
        p.objective,
        q.objective
    );
}

#[test]
fn ocp_with_a_collocation_rule_is_refused_naming_both_fields() {
    let robot = Robot::paper();
    let s = PlannerSettings {
        transcription: Transcription::HermiteSimpson,
        ..Default::default()
    };
    // the default backend is ocp: a collocation rule alone is refused before any work
    let e = plan(&robot, &tracking_task(), &s, &NlpSettings::default()).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, Error::InvalidValue { .. }), "{e}");
    assert!(
        msg.contains("solver.backend") && msg.contains("planner.transcription"),
        "{msg}"
    );
    assert!(
        msg.contains("hermite-simpson") && msg.contains("multiple-shooting"),
        "{msg}"
    );
}

/// The interval count follows from input (`T / knot_dt`): every multiple-shooting entry point checks it
/// against `brachia::limits::MAX_INTERVALS` / `MIN_INTERVALS` before allocating anything of that size
/// (a knot_dt of 1e-9 s once asked for 196 GB and aborted the process).
#[test]
fn interval_counts_outside_the_limits_are_refused_before_any_allocation() {
    use brachia::planning::{plan_joint_swings, JointSwingTask, SwingPlanner};
    let robot = Robot::paper();
    let nlp = NlpSettings::default();
    for knot_dt in [1e-9, 1e-5, 0.5] {
        let s = shooting(knot_dt);
        let check = |e: Error| {
            let msg = e.to_string();
            assert!(matches!(e, Error::InvalidValue { .. }), "{msg}");
            assert!(
                msg.contains("knot_dt") && msg.contains("intervals"),
                "{msg}"
            );
        };
        check(plan(&robot, &tracking_task(), &s, &nlp).unwrap_err());
        check(
            SwingPlanner::new(robot.clone(), tracking_task(), &s, &nlp)
                .err()
                .unwrap(),
        );
        let task = JointSwingTask {
            x0: [Q0.as_slice(), &[0.0; 4]].concat(),
            bars: vec![[0.0, 0.0], [0.8, 0.0]],
            obstacles: vec![],
            rest_at_switches: false,
        };
        check(plan_joint_swings(&robot, &task, &s, &nlp).unwrap_err());
    }
}

#[test]
fn the_defaults_plan_by_multiple_shooting_on_ocp_within_the_replay_bar() {
    let (s, n) = (PlannerSettings::default(), NlpSettings::default());
    assert_eq!(s.transcription, Transcription::MultipleShooting);
    assert_eq!(n.backend, Backend::Ocp);
    assert_eq!(s.knot_dt, brachia::planning::DEFAULT_KNOT_DT_S);
    // an empty settings file gives the same defaults
    let e: PlannerSettings = toml::from_str("").unwrap();
    assert_eq!(e, s);
    let robot = Robot::paper();
    let p = plan(&robot, &tracking_task(), &s, &n).unwrap();
    assert!(p.converged(), "{:?}", p.status);
    assert_eq!(p.backend, Backend::Ocp);
    assert_eq!(
        p.layout.intervals,
        (p.swing_time_s / s.knot_dt).round() as usize
    );
    // the accuracy rule of the default mesh: the independent replay of the plan's torques misses the
    // bar by at most 1 mm (measured 5e-7 m, docs/benchmarks.md)
    assert!(p.replay_ee_error_m < 1e-4, "replay {}", p.replay_ee_error_m);
}

#[test]
fn settings_names_round_trip() {
    let s: PlannerSettings =
        toml::from_str("transcription = \"multiple-shooting\"\n[shooting]\nsubsteps = 2").unwrap();
    assert_eq!(s.transcription, Transcription::MultipleShooting);
    assert_eq!(s.shooting.substeps, 2);
    let n: NlpSettings = toml::from_str("backend = \"ocp\"").unwrap();
    assert_eq!(n.backend, Backend::Ocp);
    let bad = PlannerSettings {
        shooting: brachia::planning::ShootingSettings {
            substeps: 0,
            ..Default::default()
        },
        ..shooting(0.01)
    };
    assert!(bad
        .validate(4, "t")
        .unwrap_err()
        .to_string()
        .contains("shooting.substeps"));
}
