//! The planner on the paper's scenarios (Section V-B and V-C): convergence, accuracy, obstacle
//! clearance, an independent recomputation of the defects, agreement of the two NLP backends.
//! The collocation tests pin the paper's path (Hermite-Simpson at 10 ms knots on pounce), the
//! cross-check of the default (multiple shooting on `ocp`, tests/planner_shooting.rs); the obstacle
//! and refusal tests run on the defaults. Units: m, rad, s, N m.

use brachia::model::{Circle, Robot};
use brachia::planning::{plan, Backend, NlpSettings, PlannerSettings, SwingTask, Transcription};
use brachia::Error;

const Q0: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];

/// The paper's transcription: Hermite-Simpson at 10 ms knots.
fn hs() -> PlannerSettings {
    PlannerSettings {
        transcription: Transcription::HermiteSimpson,
        knot_dt: 0.01,
        ..Default::default()
    }
}

/// pounce, the collocation backend.
fn pounce() -> NlpSettings {
    NlpSettings {
        backend: Backend::Pounce,
        ..Default::default()
    }
}

fn tracking_task() -> SwingTask {
    SwingTask {
        q0: Q0.to_vec(),
        qd0: vec![],
        target: [0.8, 0.0],
        obstacles: vec![],
    }
}

fn obstacle_task() -> SwingTask {
    SwingTask {
        q0: Q0.to_vec(),
        qd0: vec![],
        target: [0.5, 0.0],
        obstacles: vec![Circle {
            center: [0.55, -0.2],
            radius: 0.1,
        }],
    }
}

#[test]
fn tracking_scenario_converges_to_the_bar() {
    let robot = Robot::paper();
    let p = plan(&robot, &tracking_task(), &hs(), &pounce()).unwrap();
    assert!(p.converged(), "{:?}", p.status);
    assert!(
        p.violations.ee_position < 1e-3,
        "final EE error {}",
        p.violations.ee_position
    );
    assert!(p.violations.dynamics < 1e-6 && p.violations.ee_velocity < 1e-6);
    // T = 2 T_freefall, about the paper's 2.2 s
    let tf = p.freefall_time_s.unwrap();
    assert!((p.swing_time_s - 2.0 * tf).abs() < 1e-12 && (2.0..2.5).contains(&p.swing_time_s));
    // Hermite-Simpson at 10 ms is dynamically consistent: open-loop replay ends within 1 mm
    assert!(
        p.replay_ee_error_m < 1e-3,
        "replay error {}",
        p.replay_ee_error_m
    );
    // final torque zero, torques within limits, start state fixed
    let last = p.points.len() - 1;
    assert!(p.points.tau(last).iter().all(|t| t.abs() < 1e-9));
    assert!(p.points.tau.iter().all(|t| t.abs() <= 5.0 + 1e-9));
    assert_eq!(p.points.q(0), &Q0);
    // the 1 ms trajectory passes through the knots and starts/ends at them
    let (mut q, mut qd, mut tau) = (vec![0.0; 4], vec![0.0; 4], vec![0.0; 3]);
    for k in 0..p.points.len() {
        p.points
            .hermite_at(&p.points_qdd, p.points.t[k], &mut q, &mut qd, &mut tau);
        for i in 0..4 {
            assert!(
                (q[i] - p.points.q(k)[i]).abs() < 1e-12
                    && (qd[i] - p.points.qd(k)[i]).abs() < 1e-12
            );
        }
    }
    let tr = &p.trajectory;
    assert!((tr.t[1] - tr.t[0] - 1e-3).abs() < 1e-12);
    for k in (0..tr.len()).step_by(97) {
        p.points
            .hermite_at(&p.points_qdd, tr.t[k], &mut q, &mut qd, &mut tau);
        for i in 0..4 {
            // equal up to the clamp into the bounds
            assert!((tr.q(k)[i] - q[i]).abs() <= p.resample_clamped.q_rad);
        }
    }
    // the last sample is at T
    assert_eq!(*tr.t.last().unwrap(), p.swing_time_s);
    // energy (eq. 18) is the integral of the actuated joints' power
    assert!(p.energy_j.is_finite() && p.positive_work_j >= p.energy_j);
}

#[test]
fn hermite_simpson_defects_hold_when_recomputed_independently() {
    // Recompute the Simpson and Hermite conditions from the plan's points with the model's forward
    // dynamics, independently of the transcription's row tables.
    let robot = Robot::paper();
    let p = plan(&robot, &tracking_task(), &hs(), &pounce()).unwrap();
    let h = p.layout.h;
    let pts = &p.points;
    let f = |k: usize| robot.forward_dynamics(pts.q(k), pts.qd(k), pts.tau(k));
    let mut worst: f64 = 0.0;
    for k in 0..p.layout.intervals {
        let (a, c, b) = (2 * k, 2 * k + 1, 2 * k + 2);
        let (fa, fc, fb) = (f(a), f(c), f(b));
        for i in 0..4 {
            let simpson_q = pts.q(b)[i]
                - pts.q(a)[i]
                - h / 6.0 * (pts.qd(a)[i] + 4.0 * pts.qd(c)[i] + pts.qd(b)[i]);
            let simpson_v = pts.qd(b)[i] - pts.qd(a)[i] - h / 6.0 * (fa[i] + 4.0 * fc[i] + fb[i]);
            let herm_q = pts.q(c)[i]
                - 0.5 * (pts.q(a)[i] + pts.q(b)[i])
                - h / 8.0 * (pts.qd(a)[i] - pts.qd(b)[i]);
            let herm_v =
                pts.qd(c)[i] - 0.5 * (pts.qd(a)[i] + pts.qd(b)[i]) - h / 8.0 * (fa[i] - fb[i]);
            worst = worst
                .max(simpson_q.abs())
                .max(simpson_v.abs())
                .max(herm_q.abs())
                .max(herm_v.abs());
        }
    }
    assert!(worst < 1e-8, "largest recomputed defect {worst:e}");
}

#[test]
fn obstacle_is_avoided_and_ignoring_it_collides() {
    let robot = Robot::paper();
    let p = plan(
        &robot,
        &obstacle_task(),
        &PlannerSettings::default(),
        &NlpSettings::default(),
    )
    .unwrap();
    assert!(p.converged(), "{:?}", p.status);
    assert!(p.violations.ee_position < 1e-3);
    let c = p.min_obstacle_clearance_m.unwrap();
    assert!(c >= 0.0, "clearance over the 1 ms trajectory {c}");
    let ignore = PlannerSettings {
        avoid_obstacles: false,
        ..Default::default()
    };
    let q = plan(&robot, &obstacle_task(), &ignore, &NlpSettings::default()).unwrap();
    assert!(q.converged(), "{:?}", q.status);
    let c = q.min_obstacle_clearance_m.unwrap();
    assert!(
        c < 0.0,
        "without avoidance the swing should hit the obstacle, clearance {c}"
    );
}

#[test]
fn both_backends_agree_on_the_tracking_plan() {
    let robot = Robot::paper();
    // ripopt runs with a dense linear solver (docs/nlp.md; at most RIPOPT_MAX_UNKNOWNS variables +
    // constraints; its factorisation's cost grows as their cube), so the cross-check uses a coarse
    // swing: trapezoidal rule at 100 ms knots (23 points, 253 variables; about 6 s, where 80 ms
    // knots took ripopt 34 iterations and over 100 s)
    let s = PlannerSettings {
        knot_dt: 0.10,
        transcription: Transcription::Trapezoidal,
        ..Default::default()
    };
    let a = plan(&robot, &tracking_task(), &s, &pounce()).unwrap();
    let b = plan(
        &robot,
        &tracking_task(),
        &s,
        &NlpSettings {
            backend: Backend::Ripopt,
            ..Default::default()
        },
    )
    .unwrap();
    assert!(
        a.converged() && b.converged(),
        "{:?} {:?}",
        a.status,
        b.status
    );
    let rel = (a.objective - b.objective).abs() / a.objective.abs();
    assert!(
        rel < 1e-6,
        "pounce {} vs ripopt {} (rel {rel:e})",
        a.objective,
        b.objective
    );
}

#[test]
fn transcriptions_rank_by_dynamic_consistency() {
    let robot = Robot::paper();
    let mut errs = vec![];
    for tr in [
        Transcription::Euler,
        Transcription::Trapezoidal,
        Transcription::HermiteSimpson,
    ] {
        let s = PlannerSettings {
            transcription: tr,
            ..hs()
        };
        let p = plan(&robot, &tracking_task(), &s, &pounce()).unwrap();
        assert!(p.converged(), "{tr:?}: {:?}", p.status);
        errs.push(p.replay_ee_error_m);
    }
    // Hermite-Simpson is the most consistent; Euler (first order) the least
    assert!(
        errs[2] < errs[1] && errs[1] < errs[0],
        "replay EE errors euler/trap/HS {errs:?}"
    );
    assert!(errs[2] < 1e-3 && errs[0] > 1e-2, "{errs:?}");
}

#[test]
fn impossible_tasks_are_refused_before_solving() {
    let robot = Robot::paper();
    let far = SwingTask {
        target: [1.5, 0.0],
        ..tracking_task()
    };
    let e = plan(
        &robot,
        &far,
        &PlannerSettings::default(),
        &NlpSettings::default(),
    )
    .unwrap_err();
    assert!(
        matches!(e, Error::InvalidValue { ref field, .. } if field == "target")
            && e.to_string().contains("reaches at most"),
        "{e}"
    );
    let blocked = SwingTask {
        obstacles: vec![Circle {
            center: [-0.5, -0.5],
            radius: 0.1,
        }],
        ..tracking_task()
    };
    let e = plan(
        &robot,
        &blocked,
        &PlannerSettings::default(),
        &NlpSettings::default(),
    )
    .unwrap_err();
    assert!(e.to_string().contains("start pose overlaps"), "{e}");
    let bad = SwingTask {
        q0: vec![0.0; 3],
        ..tracking_task()
    };
    assert!(matches!(
        plan(
            &robot,
            &bad,
            &PlannerSettings::default(),
            &NlpSettings::default()
        ),
        Err(Error::InvalidValue { .. })
    ));
}
