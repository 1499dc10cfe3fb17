//! The stepwise closed loop and re-targetable controllers: `ClosedLoop::step` reproduces
//! `run_closed_loop` exactly, `set_reference` swaps the plan (bit-identical to a controller built on
//! the new plan) and refuses a plan of the wrong size, and `Noisy` corrupts only the measurement.

mod common;

use brachia::control::{Controller, Mpc, MpcSettings, OpenLoop, Pd, PdSettings};
use brachia::sim::{
    run_closed_loop, ClosedLoop, ModelPlant, NoiseSettings, Noisy, Plant, RunSettings,
};
use brachia::trajectory::Trajectory;
use common::*;
use std::sync::Arc;

fn perturbed_start() -> Vec<f64> {
    let mut x0 = start_state();
    x0[1] += 0.05;
    x0
}

/// A second plan: the first with its torques scaled (a different open-loop motion).
fn other_plan(tr: &Trajectory) -> Trajectory {
    let mut b = tr.clone();
    for v in b.tau.iter_mut() {
        *v *= 0.5;
    }
    b
}

#[test]
fn stepping_reproduces_run_closed_loop() {
    let robot = Arc::new(paper_robot(5.0));
    let tr = Arc::new(model_reference(&robot, &start_state(), 0.4));
    let rs = RunSettings {
        duration_s: 0.3,
        ..RunSettings::default()
    };
    let mut plant = ModelPlant::new(Arc::clone(&robot), &perturbed_start());
    let mut mpc = Mpc::new(Arc::clone(&robot), Arc::clone(&tr), MpcSettings::default()).unwrap();
    let a = run_closed_loop(&mut plant, &mut mpc, &tr, &robot, &rs).unwrap();

    let plant = ModelPlant::new(Arc::clone(&robot), &perturbed_start());
    let mpc = Mpc::new(Arc::clone(&robot), Arc::clone(&tr), MpcSettings::default()).unwrap();
    let mut cl = ClosedLoop::new(plant, mpc, Arc::clone(&robot), Arc::clone(&tr), &rs).unwrap();
    let mut k = 0;
    while let Some(info) = cl.step() {
        assert_eq!(info.t, a.t[k]);
        assert_eq!(cl.log().len(), k + 1);
        assert_eq!(cl.last_tau(), a.tau(k));
        k += 1;
    }
    assert_eq!(k, 300);
    assert!(cl.is_done() && cl.step().is_none());
    let b = cl.finish();
    assert_eq!((a.len(), b.len()), (301, 301));
    assert_eq!(a.t, b.t);
    assert_eq!(a.x, b.x);
    assert_eq!(a.tau, b.tau);
    assert_eq!(a.ref_x, b.ref_x);
    assert_eq!(a.iterations, b.iterations);
    // the rows as written, but for the controller's wall time (the last column)
    let rows = |l: &brachia::sim::ClosedLoopLog| -> Vec<String> {
        l.to_csv()
            .lines()
            .map(|r| r.rsplit_once(',').unwrap().0.to_string())
            .collect()
    };
    assert_eq!(rows(&a), rows(&b));
}

#[test]
fn set_reference_matches_a_controller_built_on_the_new_plan() {
    let robot = Arc::new(paper_robot(5.0));
    let tr = Arc::new(model_reference(&robot, &start_state(), 0.4));
    let other = Arc::new(other_plan(&tr));
    let x = perturbed_start();
    let (mut ta, mut tb) = (vec![0.0; 3], vec![0.0; 3]);

    let mut fresh = Mpc::new(
        Arc::clone(&robot),
        Arc::clone(&other),
        MpcSettings::default(),
    )
    .unwrap();
    let mut swapped =
        Mpc::new(Arc::clone(&robot), Arc::clone(&tr), MpcSettings::default()).unwrap();
    swapped.set_reference(Arc::clone(&other)).unwrap();
    for k in 0..5 {
        let t = 0.01 * k as f64;
        fresh.control(t, &x, &mut ta);
        swapped.control(t, &x, &mut tb);
        assert_eq!(ta, tb, "mpc step {k}");
    }
    assert!(Arc::ptr_eq(swapped.reference(), &other));

    let mut pd_fresh = Pd::new(
        Arc::clone(&robot),
        Arc::clone(&other),
        PdSettings::default(),
    )
    .unwrap();
    let mut pd = Pd::new(Arc::clone(&robot), Arc::clone(&tr), PdSettings::default()).unwrap();
    pd.set_reference(Arc::clone(&other)).unwrap();
    pd_fresh.control(0.1, &x, &mut ta);
    pd.control(0.1, &x, &mut tb);
    assert_eq!(ta, tb);

    // Open loop replays the new plan's torques, not the old ones.
    let mut ol = OpenLoop::new(Arc::clone(&robot), Arc::clone(&tr)).unwrap();
    ol.control(0.1, &x, &mut ta);
    Controller::set_reference(&mut ol, Arc::clone(&other)).unwrap();
    ol.control(0.1, &x, &mut tb);
    let mut want = vec![0.0; 3];
    other.tau_at(0.1, &mut want);
    assert_eq!(tb, want);
    assert_ne!(ta, tb);
}

#[test]
fn set_reference_refuses_a_plan_of_the_wrong_size_and_keeps_the_old_one() {
    let robot = Arc::new(paper_robot(5.0));
    let tr = Arc::new(model_reference(&robot, &start_state(), 0.2));
    let mut mpc = Mpc::new(Arc::clone(&robot), Arc::clone(&tr), MpcSettings::default()).unwrap();
    let err = mpc
        .set_reference(Trajectory::new(3))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("reference links") && err.contains("expected 4"),
        "{err}"
    );
    let err = mpc
        .set_reference(Trajectory::new(4))
        .unwrap_err()
        .to_string();
    assert!(err.contains("at least one sample"), "{err}");
    let mut bad = (*tr).clone();
    bad.tau.pop();
    let err = mpc.set_reference(bad).unwrap_err().to_string();
    assert!(err.contains("reference tau values"), "{err}");
    assert!(Arc::ptr_eq(mpc.reference(), &tr));
    let mut ol = OpenLoop::new(Arc::clone(&robot), Arc::clone(&tr)).unwrap();
    assert!(ol.set_reference(Trajectory::new(3)).is_err());
    assert!(Arc::ptr_eq(ol.reference(), &tr));
}

#[test]
fn noisy_corrupts_the_measurement_only_and_is_seeded() {
    let robot = Arc::new(paper_robot(5.0));
    let ns = NoiseSettings {
        q_std: 1e-2,
        qd_std: 1e-1,
        seed: 7,
    };
    let mut a = Noisy::new(ModelPlant::new(Arc::clone(&robot), &start_state()), ns).unwrap();
    let mut b = Noisy::new(ModelPlant::new(Arc::clone(&robot), &start_state()), ns).unwrap();
    let mut clean = ModelPlant::new(Arc::clone(&robot), &start_state());
    let (mut xa, mut xb, mut xt, mut xc) = (vec![0.0; 8], vec![0.0; 8], vec![0.0; 8], vec![0.0; 8]);
    let mut sq = 0.0;
    let samples = 400;
    for _ in 0..samples {
        a.state(&mut xa);
        b.state(&mut xb);
        a.true_state(&mut xt);
        clean.state(&mut xc);
        assert_eq!(xa, xb, "same seed, same noise");
        assert_eq!(xt, xc, "the true state is the inner plant's");
        sq += (0..4).map(|i| (xa[i] - xt[i]).powi(2)).sum::<f64>();
        for p in [&mut a as &mut dyn Plant, &mut b, &mut clean] {
            p.step(&[0.1, -0.1, 0.05], 1e-3);
        }
    }
    // The sample standard deviation of the angle noise is q_std within 10 % (1600 draws).
    let std = (sq / (4 * samples) as f64).sqrt();
    assert!((std - 1e-2).abs() < 1e-3, "angle noise std {std}");
    assert!(Noisy::new(clean, NoiseSettings { q_std: -1.0, ..ns }).is_err());
}
