//! The swing environments in Rust: seeding, randomised draws within their ranges, refusals naming the
//! field, the batch against single environments in both autoreset modes, capture and truncation.

use brachia::planning::SwingTask;
use brachia::Robot;
use brachia_run::gym::{
    Autoreset, Randomization, SwingBatch, SwingEnv, SwingEnvSettings, SwingEnvSpec,
};
use brachia_run::scenario::PlantSettings;
use brachia_run::{hand_at_bar, PlantKind, CAPTURE_SPEED_M_S, SUCCESS_RADIUS_M};
use std::sync::Arc;

fn spec(
    plant: PlantKind,
    task: SwingTask,
    settings: SwingEnvSettings,
    r: Option<&str>,
) -> Arc<SwingEnvSpec> {
    let robot = Robot::paper();
    let r = r.map(|text| {
        let v: serde_json::Value = serde_json::from_str(text).expect("json");
        Randomization::new(v, "test", 4, settings.control_dt).expect("valid ranges")
    });
    Arc::new(
        SwingEnvSpec::new(
            &robot,
            &task,
            plant,
            &PlantSettings::default(),
            settings,
            r,
            "test",
        )
        .expect("valid spec"),
    )
}

const RANGES: &str = r#"{"mass_scale": [{"uniform": [0.9, 1.1]}, 1.0, 1.0, 1.0],
    "noise_q_std": {"uniform": [0.0, 0.002]}, "actuation_delay_s": 0.01}"#;

/// Observations (as bits) and rewards of `steps` steps of a fixed action pattern.
fn rollout(env: &mut SwingEnv, steps: usize) -> Vec<(Vec<u32>, u64)> {
    let mut obs = vec![0f32; env.spec().observation_dim()];
    let mut out = Vec::new();
    for k in 0..steps {
        let a = [(k as f64 * 0.37).sin(), (k as f64 * 0.11).cos(), -0.5];
        let o = env.step(&a).expect("step");
        env.observe(&mut obs);
        out.push((
            obs.iter().map(|v| v.to_bits()).collect(),
            o.reward.to_bits(),
        ));
        if o.terminated || o.truncated {
            env.reset(None, None).expect("reset");
        }
    }
    out
}

#[test]
fn same_seed_same_episode_and_draws_within_their_ranges() {
    for plant in [PlantKind::Model, PlantKind::Rapier] {
        let s = spec(
            plant,
            SwingTask::paper(),
            SwingEnvSettings::default(),
            Some(RANGES),
        );
        let mut a = SwingEnv::new(s.clone(), 7).expect("env");
        let mut b = SwingEnv::new(s.clone(), 7).expect("env");
        assert_eq!(rollout(&mut a, 40), rollout(&mut b, 40));
        let mut c = SwingEnv::new(s, 8).expect("env");
        assert_ne!(rollout(&mut a, 40), rollout(&mut c, 40));
    }
    let s = spec(
        PlantKind::Model,
        SwingTask::paper(),
        SwingEnvSettings::default(),
        Some(RANGES),
    );
    let mut env = SwingEnv::new(s, 1).expect("env");
    let mut seen = Vec::new();
    for _ in 0..20 {
        env.reset(None, None).expect("reset");
        let d = env.disturbances();
        assert!((0.9..=1.1).contains(&d.mass_scale[0]) && d.mass_scale[1] == 1.0);
        assert!((0.0..=0.002).contains(&d.noise_q_std) && d.actuation_delay_s == 0.01);
        let m = env.plant_robot().params().links[0].mass;
        let m0 = Robot::paper().params().links[0].mass;
        assert!((m / m0 - d.mass_scale[0]).abs() < 1e-12);
        seen.push(d.mass_scale[0].to_bits());
    }
    seen.dedup();
    assert_eq!(seen.len(), 20);
}

#[test]
fn bad_ranges_are_refused_naming_the_field() {
    let bad = |text: &str| {
        let v: serde_json::Value = serde_json::from_str(text).expect("json");
        Randomization::new(v, "env", 4, 0.01)
            .expect_err("refused")
            .to_string()
    };
    let e = bad(r#"{"mass_scale": [{"uniform": [1.2, 0.8]}, 1, 1, 1]}"#);
    assert!(e.contains("mass_scale[0].uniform"), "{e}");
    let e = bad(r#"{"mass_scale": [{"uniform": [0.5, 20.0]}, 1, 1, 1]}"#);
    assert!(e.contains("mass_scale[0]") && e.contains("20"), "{e}");
    let e = bad(r#"{"noise_q_std": {"uniform": [0.0, 1.0], "extra": 1}}"#);
    assert!(e.contains("noise_q_std.uniform"), "{e}");
    let e = bad(r#"[1, 2]"#);
    assert!(e.contains("disturbances"), "{e}");
    let s = SwingEnvSettings {
        control_dt: 0.0105,
        ..SwingEnvSettings::default()
    };
    let e = SwingEnvSpec::new(
        &Robot::paper(),
        &SwingTask::paper(),
        PlantKind::Model,
        &PlantSettings::default(),
        s,
        None,
        "env",
    )
    .expect_err("refused")
    .to_string();
    assert!(e.contains("control_dt"), "{e}");
}

#[test]
fn batch_equals_single_envs_in_both_autoreset_modes() {
    let settings = SwingEnvSettings {
        time_limit_s: 0.05,
        ..SwingEnvSettings::default()
    };
    for mode in [Autoreset::NextStep, Autoreset::SameStep] {
        let s = spec(
            PlantKind::Model,
            SwingTask::paper(),
            settings.clone(),
            Some(RANGES),
        );
        let m = 3;
        let mut batch = SwingBatch::new(s.clone(), m, 20, mode).expect("batch");
        let mut out = batch.output();
        batch.reset(Some(20), None, &mut out).expect("reset");
        let mut singles: Vec<SwingEnv> = (0..m)
            .map(|i| SwingEnv::new(s.clone(), 20 + i as u64).expect("env"))
            .collect();
        let mut pending = vec![false; m];
        let mut obs = vec![0f32; s.observation_dim()];
        let mut ends = 0;
        for k in 0..14 {
            let actions: Vec<f64> = (0..3 * m).map(|j| ((k * 7 + j) as f64).sin()).collect();
            batch.step(&actions, &mut out).expect("step");
            for (i, env) in singles.iter_mut().enumerate() {
                let (r, te, tr) = if pending[i] {
                    env.reset(None, None).expect("reset");
                    pending[i] = false;
                    (0.0, false, false)
                } else {
                    let o = env.step(&actions[3 * i..3 * i + 3]).expect("step");
                    if o.terminated || o.truncated {
                        ends += 1;
                        match mode {
                            Autoreset::NextStep => pending[i] = true,
                            Autoreset::SameStep => {
                                env.observe(&mut obs);
                                let d = obs.len();
                                assert!(out.ended[i]);
                                assert_eq!(obs, out.final_obs[i * d..(i + 1) * d]);
                                env.reset(None, None).expect("reset");
                            }
                        }
                    }
                    (o.reward, o.terminated, o.truncated)
                };
                env.observe(&mut obs);
                let d = obs.len();
                assert_eq!(
                    obs,
                    out.obs[i * d..(i + 1) * d],
                    "{mode:?} step {k} env {i}"
                );
                assert_eq!(
                    (r.to_bits(), te, tr),
                    (out.reward[i].to_bits(), out.terminated[i], out.truncated[i])
                );
            }
        }
        assert!(ends >= m, "{mode:?}: episodes ended {ends} times");
    }
}

#[test]
fn capture_at_the_bar_and_truncation_at_the_time_limit() {
    let q0 = vec![-2.35, 0.0, -1.55, 0.0];
    let hand = Robot::paper().ee_position(&q0);
    let task = SwingTask {
        q0,
        qd0: vec![],
        target: [hand[0] + 0.01, hand[1]],
        obstacles: vec![],
    };
    let s = spec(PlantKind::Model, task, SwingEnvSettings::default(), None);
    let mut env = SwingEnv::new(s, 0).expect("env");
    let o = env.step(&[0.0; 3]).expect("step");
    assert!(o.terminated && o.captured && !o.truncated && o.terms.capture == 1.0);
    assert!(
        env.step(&[0.0; 3]).is_err(),
        "a step after the end needs a reset"
    );

    let settings = SwingEnvSettings {
        time_limit_s: 0.03,
        ..SwingEnvSettings::default()
    };
    let s = spec(PlantKind::Rapier, SwingTask::paper(), settings, None);
    let mut env = SwingEnv::new(s, 0).expect("env");
    let flags: Vec<(bool, bool)> = (0..3)
        .map(|_| {
            let o = env.step(&[0.0; 3]).expect("step");
            (o.terminated, o.truncated)
        })
        .collect();
    assert_eq!(flags, [(false, false), (false, false), (false, true)]);
}

/// The environment ends an episode by the capture rule of every run (`brachia_run::success`): a hand
/// at the bar but faster than `CAPTURE_SPEED_M_S` is no capture, and every step's `captured` is the
/// rule applied to the plant's true state.
#[test]
fn capture_is_the_rule_of_every_run() {
    let q0 = vec![-2.35, 0.0, -1.55, 0.0];
    let hand = Robot::paper().ee_position(&q0);
    let target = [hand[0] + 0.01, hand[1]];
    // the last joint spins at 3 rad/s: the hand passes the bar at about 1 m/s
    let task = SwingTask {
        q0,
        qd0: vec![0.0, 0.0, 0.0, 3.0],
        target,
        obstacles: vec![],
    };
    let s = spec(PlantKind::Model, task, SwingEnvSettings::default(), None);
    let mut env = SwingEnv::new(s, 0).expect("env");
    let mut near_but_fast = 0;
    for k in 0..300 {
        let a = [(k as f64 * 0.37).sin(), (k as f64 * 0.11).cos(), -0.5];
        let o = env.step(&a).expect("step");
        let h = hand_at_bar(env.plant_robot(), env.true_state(), target);
        assert_eq!(o.captured, h.captures && !o.out_of_limits, "step {k}");
        assert!((o.distance_m - h.distance_m).abs() < 1e-12, "step {k}");
        if h.distance_m <= SUCCESS_RADIUS_M && h.speed_m_s > CAPTURE_SPEED_M_S {
            near_but_fast += 1;
            assert!(
                !o.terminated,
                "step {k}: a fast hand at the bar ends nothing"
            );
        }
        if o.terminated || o.truncated {
            break;
        }
    }
    assert!(
        near_but_fast >= 1,
        "the hand passed the bar fast at least once"
    );
}
