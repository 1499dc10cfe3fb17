//! Regression (hostile-input sweep, F3): a closed loop whose plant state blew up ran to its end, logging
//! NaN rows, and its summary held NaN metrics (`"ee_final_error_m": null` in report.json, which
//! `brachia report` then refused); `brachia track` exited 0 with `EE final error NaN m`. Now the loop
//! stops at the first state beyond `DIVERGENCE_BOUND` (or NaN, or infinite) and at the first non-finite
//! torque (not applied), records the time, and keeps a log of finite rows that reads back; a start state
//! beyond the bound is refused.

mod common;

use brachia::control::{ControlInfo, Controller};
use brachia::sim::{run_closed_loop, ClosedLoop, ClosedLoopLog, ModelPlant, RunSettings};
use common::*;
use std::sync::Arc;

/// Zero torque until `t_bad`, NaN from then on (a controller whose solver broke down).
struct NanAfter {
    t_bad: f64,
}

impl Controller for NanAfter {
    fn control(&mut self, t: f64, _x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let v = if t >= self.t_bad { f64::NAN } else { 0.0 };
        tau.iter_mut().for_each(|x| *x = v);
        ControlInfo { iterations: 1 }
    }
    fn name(&self) -> &'static str {
        "nan-after"
    }
}

#[test]
fn a_non_finite_torque_stops_the_loop_with_a_finite_log() {
    let robot = Arc::new(paper_robot(5.0));
    let tr = Arc::new(model_reference(&robot, &start_state(), 0.4));
    let rs = RunSettings {
        duration_s: 0.3,
        ..RunSettings::default()
    };
    let mut plant = ModelPlant::new(Arc::clone(&robot), &start_state());
    let mut ctrl = NanAfter { t_bad: 0.0495 };
    let log = run_closed_loop(&mut plant, &mut ctrl, &tr, &robot, &rs).unwrap();
    let t = log.diverged_at_s.expect("the divergence is recorded");
    assert!((t - 0.05).abs() < 1e-9, "diverged at {t}");
    // the rows before it (t = 0 .. 0.049) and the row of t = 0.05 with its torque not applied (zero),
    // every value finite
    assert_eq!(log.len(), 51);
    assert!(log.tau(50).iter().all(|&v| v == 0.0));
    assert!(log.x.iter().chain(&log.tau).all(|v| v.is_finite()));
    let s = log.summary();
    assert_eq!(s.diverged_at_s, Some(t));
    for v in [
        s.ee_final_error_m,
        s.ee_error_max_m,
        s.joint_rms_error_rad,
        s.energy_j,
        s.tau_min,
        s.tau_max,
    ] {
        assert!(v.is_finite(), "{s:?}");
    }
    // the summary records the divergence in JSON, and the CSV reads back
    let json = serde_json::to_value(s).unwrap();
    assert_eq!(json["diverged_at_s"].as_f64(), Some(t));
    let back = ClosedLoopLog::from_csv(&log.to_csv(), "closed_loop.csv").unwrap();
    assert_eq!(back.len(), log.len());
}

#[test]
fn a_state_that_blows_up_stops_the_stepped_loop() {
    // a robot a billion times lighter under the same torques: the state leaves any bound in one step
    let robot = Arc::new(paper_robot(5.0));
    let light = paper_robot(5.0).params().clone().with_mass_scale(1e-9);
    let light = brachia::Robot::from_params(light, "<test>").unwrap();
    let tr = Arc::new(model_reference(&robot, &start_state(), 0.4));
    let rs = RunSettings {
        duration_s: 0.3,
        ..RunSettings::default()
    };
    struct Full;
    impl Controller for Full {
        fn control(&mut self, _t: f64, _x: &[f64], tau: &mut [f64]) -> ControlInfo {
            tau.iter_mut().for_each(|x| *x = 5.0);
            ControlInfo { iterations: 0 }
        }
        fn name(&self) -> &'static str {
            "full"
        }
    }
    let plant = ModelPlant::new(Arc::new(light), &start_state());
    let mut cl = ClosedLoop::new(plant, Full, Arc::clone(&robot), tr, &rs).unwrap();
    let mut steps = 0;
    while cl.step().is_some() {
        steps += 1;
    }
    assert!(steps < 300, "the loop ran to its end");
    assert!(cl.is_done() && cl.diverged_at().is_some());
    let log = cl.finish();
    assert!(log
        .x
        .iter()
        .all(|v| v.abs() <= brachia::sim::DIVERGENCE_BOUND));
    assert!(log.summary().ee_final_error_m.is_finite());
}

#[test]
fn a_start_state_beyond_the_bound_is_refused() {
    let robot = Arc::new(paper_robot(5.0));
    let tr = Arc::new(model_reference(&robot, &start_state(), 0.4));
    let mut x0 = start_state();
    x0[5] = f64::NAN;
    let plant = ModelPlant::new(Arc::clone(&robot), &x0);
    let e = ClosedLoop::new(
        plant,
        NanAfter { t_bad: 1.0 },
        robot,
        tr,
        &RunSettings::default(),
    )
    .err()
    .expect("refused")
    .to_string();
    assert!(e.contains("start state"), "{e}");
}
