//! The MPC against an independent finite-horizon LQR, tracking on the model plant, the baselines and
//! the closed-loop runner.
//!
//! Conventions: x = [q, qd] (rad, rad/s; q1 absolute from +x), u = tau of joints 2..n (N m).

mod common;

use brachia::control::{
    Discretization, Linearization, Mpc, MpcSettings, OpenLoop, Pd, PdSettings, Prediction,
    TorqueReference,
};
use brachia::model::{LinearModel, Linearizer, Robot};
use brachia::sim::{run_closed_loop, ClosedLoopLog, Controller, ModelPlant, RunSettings};
use brachia::trajectory::Trajectory;
use common::*;
use nalgebra::{DMatrix, DVector};

fn planned_tau(tr: &Trajectory, t: f64) -> DVector<f64> {
    let (k, r) = tr.locate(t);
    let k1 = (k + 1).min(tr.len() - 1);
    DVector::from_fn(tr.n - 1, |j, _| {
        tr.tau(k)[j] + r * (tr.tau(k1)[j] - tr.tau(k)[j])
    })
}

/// One discrete affine stage for the LQR: x+ = A x + B u + F, y = C x + fy.
struct Stage {
    a: DMatrix<f64>,
    b: DMatrix<f64>,
    f: DVector<f64>,
    c: DMatrix<f64>,
    fy: DVector<f64>,
}

/// First input of the finite-horizon LQR for
/// `sum_{k=1}^N |x_k - xd_k|^2_Qk + |C_k x_k + fy_k - yd_k|^2_Wk + sum_{k<N} |u_k - ur_k|^2_R`,
/// by the backward Riccati recursion with affine terms (value `x^T P x - 2 p^T x + c`).
fn lqr_first_input(
    stages: &[Stage],
    out: &[Stage],
    x0: &DVector<f64>,
    xd: &[DVector<f64>],
    yd: &[DVector<f64>],
    ur: &[DVector<f64>],
    q: &DMatrix<f64>,
    w: &DMatrix<f64>,
    r: &DMatrix<f64>,
    terminal: f64,
) -> DVector<f64> {
    let n_h = stages.len();
    let stage_cost = |k: usize| -> (DMatrix<f64>, DVector<f64>) {
        // Stage k = 1..N: x^T Qt x - 2 qt^T x.
        let fac = if k == n_h { terminal } else { 1.0 };
        let s = &out[k - 1];
        let qk = q * fac;
        let wk = w * fac;
        let qt = &qk + s.c.transpose() * &wk * &s.c;
        let lin = &qk * &xd[k - 1] + s.c.transpose() * &wk * (&yd[k - 1] - &s.fy);
        (qt, lin)
    };
    let (mut p, mut pv) = stage_cost(n_h);
    let mut u0 = DVector::zeros(r.nrows());
    for k in (0..n_h).rev() {
        let st = &stages[k];
        let s = r + st.b.transpose() * &p * &st.b;
        let s_inv = s.clone().try_inverse().expect("S invertible");
        let kk = &s_inv * st.b.transpose() * &p * &st.a;
        let v = &s_inv * (r * &ur[k] - st.b.transpose() * &p * &st.f + st.b.transpose() * &pv);
        if k == 0 {
            u0 = -&kk * x0 + &v;
            break;
        }
        let acl = &st.a - &st.b * &kk;
        let d = &st.b * &v + &st.f;
        let (qt, lin) = stage_cost(k);
        let p_new = &qt + kk.transpose() * r * &kk + acl.transpose() * &p * &acl;
        let pv_new = &lin + kk.transpose() * r * (&v - &ur[k]) + acl.transpose() * (&pv - &p * &d);
        p = p_new;
        pv = pv_new;
    }
    u0
}

fn dm(v: &[f64], r: usize, c: usize) -> DMatrix<f64> {
    DMatrix::from_row_slice(r, c, v)
}

/// Euler discretisation computed here from an independent linearisation.
fn euler_stage(lm: &LinearModel, nx: usize, nu: usize, dt: f64) -> Stage {
    Stage {
        a: DMatrix::identity(nx, nx) + dm(&lm.a, nx, nx) * dt,
        b: dm(&lm.b, nx, nu) * dt,
        f: DVector::from_column_slice(&lm.f) * dt,
        c: dm(&lm.c, 2, nx),
        fy: DVector::from_column_slice(&lm.fy),
    }
}

struct Window {
    xd: Vec<DVector<f64>>,
    yd: Vec<DVector<f64>>,
    ur: Vec<DVector<f64>>,
}

fn window(robot: &Robot, tr: &Trajectory, t: f64, s: &MpcSettings, zero_ref: bool) -> Window {
    let nx = robot.nx();
    let mut xd = Vec::new();
    let mut yd = Vec::new();
    let mut ur = Vec::new();
    for k in 0..s.horizon {
        let mut x = vec![0.0; nx];
        tr.state_at(t + (k + 1) as f64 * s.dt_mpc, &mut x);
        let ee = robot.ee_position(&x[..robot.n()]);
        yd.push(DVector::from_column_slice(&ee));
        xd.push(DVector::from_vec(x));
        ur.push(if zero_ref {
            DVector::zeros(robot.nu())
        } else {
            planned_tau(tr, t + k as f64 * s.dt_mpc)
        });
    }
    Window { xd, yd, ur }
}

fn weights(s: &MpcSettings) -> (DMatrix<f64>, DMatrix<f64>, DMatrix<f64>) {
    let s = &s.resolved(4);
    (
        DMatrix::from_diagonal(&DVector::from_column_slice(&s.q_diag)),
        DMatrix::from_diagonal(&DVector::from_column_slice(&s.w_diag)),
        DMatrix::from_diagonal(&DVector::from_column_slice(&s.r_diag)),
    )
}

fn perturbed(tr: &Trajectory, t: f64) -> Vec<f64> {
    let mut x = vec![0.0; 2 * tr.n];
    tr.state_at(t, &mut x);
    let d = [0.03, -0.04, 0.05, -0.02, 0.2, -0.1, 0.3, 0.1];
    for i in 0..x.len() {
        x[i] += d[i];
    }
    x
}

/// With bounds that never bind, the first MPC input equals the finite-horizon LQR on the same
/// (independently rebuilt) Euler-discretised affine model, measured linearisation, planned-torque
/// reference.
#[test]
fn unconstrained_mpc_equals_lqr_euler() {
    let robot = paper_robot(1e6);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let settings = MpcSettings {
        discretization: Discretization::Euler,
        linearization: Linearization::Measured,
        torque_reference: TorqueReference::Planned,
        prediction: Prediction::Model,
        // The LQR below has no input-rate term.
        rate_diag: vec![0.0; 3],
        ..MpcSettings::default()
    };
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), settings.clone()).unwrap();
    let (nx, nu) = (robot.nx(), robot.nu());
    for &t in &[0.0, 0.41, 1.3] {
        mpc.reset();
        let x0 = perturbed(&tr, t);
        let mut tau = vec![0.0; nu];
        mpc.control(t, &x0, &mut tau);
        let info = mpc.last_qp_info().unwrap();
        assert_eq!(info.status, brachia::control::BoxQpStatus::Solved);
        assert_eq!(info.active, 0, "bounds must not bind in this test");

        // Independent model: linearise at (x0, planned torque at t) as the MPC does on a cold call.
        let mut lin = Linearizer::new(robot.clone());
        let mut lm = LinearModel::zeros(robot.n());
        let u_lin: Vec<f64> = planned_tau(&tr, t).iter().copied().collect();
        lin.linearize_into(&x0, &u_lin, &mut lm);
        let st = || euler_stage(&lm, nx, nu, settings.dt_mpc);
        let stages: Vec<Stage> = (0..settings.horizon).map(|_| st()).collect();
        let outs: Vec<Stage> = (0..settings.horizon).map(|_| st()).collect();
        let w = window(&robot, &tr, t, &settings, false);
        let (q, wm, r) = weights(&settings);
        let u0 = lqr_first_input(
            &stages,
            &outs,
            &DVector::from_column_slice(&x0),
            &w.xd,
            &w.yd,
            &w.ur,
            &q,
            &wm,
            &r,
            settings.terminal_factor,
        );
        for j in 0..nu {
            let err = (tau[j] - u0[j]).abs();
            assert!(
                err < 1e-8 * (1.0 + u0[j].abs()),
                "t={t} joint {j}: mpc {} lqr {} (err {err:e})",
                tau[j],
                u0[j]
            );
        }
    }
}

/// The same with the zero-order-hold discretisation, LTV linearisation along the reference, the
/// error-dynamics affine terms and the absolute-torque penalty. The ZOH model of stage 0 is first checked against nalgebra's matrix
/// exponential of the independently linearised continuous model.
#[test]
fn unconstrained_mpc_equals_lqr_zoh_ltv() {
    let robot = paper_robot(1e6);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let settings = MpcSettings {
        discretization: Discretization::Zoh,
        linearization: Linearization::AlongReference,
        torque_reference: TorqueReference::Zero,
        horizon: 15,
        rate_diag: vec![0.0; 3],
        ..MpcSettings::default()
    };
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), settings.clone()).unwrap();
    let (nx, nu) = (robot.nx(), robot.nu());
    let t = 0.7;
    let x0 = perturbed(&tr, t);
    let mut tau = vec![0.0; nu];
    mpc.control(t, &x0, &mut tau);
    assert_eq!(mpc.last_qp_info().unwrap().active, 0);

    // ZOH check: exp(dt [A B F; 0 0 0]).
    let mut lin = Linearizer::new(robot.clone());
    let mut lm = LinearModel::zeros(robot.n());
    let u_lin: Vec<f64> = planned_tau(&tr, t).iter().copied().collect();
    lin.linearize_into(&x0, &u_lin, &mut lm);
    let me = nx + nu + 1;
    let mut aug = DMatrix::zeros(me, me);
    aug.view_mut((0, 0), (nx, nx)).copy_from(&dm(&lm.a, nx, nx));
    aug.view_mut((0, nx), (nx, nu))
        .copy_from(&dm(&lm.b, nx, nu));
    aug.view_mut((0, nx + nu), (nx, 1))
        .copy_from(&DVector::from_column_slice(&lm.f));
    let e = (aug * settings.dt_mpc).exp();
    let s0 = mpc.stage_model(0);
    let ad = dm(s0.ad, nx, nx);
    let scale = e.abs().max();
    assert!((&ad - e.view((0, 0), (nx, nx))).abs().max() < 1e-12 * scale);
    assert!((dm(s0.bd, nx, nu) - e.view((0, nx), (nx, nu))).abs().max() < 1e-12 * scale);

    // LQR on the MPC's stage models (time-varying).
    let to_stage = |k: usize| {
        let s = mpc.stage_model(k);
        Stage {
            a: dm(s.ad, nx, nx),
            b: dm(s.bd, nx, nu),
            f: DVector::from_column_slice(s.fd),
            c: dm(s.c, 2, nx),
            fy: DVector::from_column_slice(s.fy),
        }
    };
    let stages: Vec<Stage> = (0..settings.horizon).map(to_stage).collect();
    // Output model of stage k = 1..N.
    let outs: Vec<Stage> = (1..=settings.horizon).map(to_stage).collect();
    // The LTV stage-k model must be the linearisation at the reference x^d_k.
    let w = window(&robot, &tr, t, &settings, true);
    let mut lm2 = LinearModel::zeros(robot.n());
    let xd3: Vec<f64> = w.xd[2].iter().copied().collect();
    let u3: Vec<f64> = planned_tau(&tr, t + 3.0 * settings.dt_mpc)
        .iter()
        .copied()
        .collect();
    lin.linearize_into(&xd3, &u3, &mut lm2);
    assert!((dm(&lm2.c, 2, nx) - &outs[2].c).abs().max() < 1e-14);
    let (q, wm, r) = weights(&settings);
    let u0 = lqr_first_input(
        &stages,
        &outs,
        &DVector::from_column_slice(&x0),
        &w.xd,
        &w.yd,
        &w.ur,
        &q,
        &wm,
        &r,
        settings.terminal_factor,
    );
    for j in 0..nu {
        let err = (tau[j] - u0[j]).abs();
        assert!(
            err < 1e-8 * (1.0 + u0[j].abs()),
            "joint {j}: mpc {} lqr {} (err {err:e})",
            tau[j],
            u0[j]
        );
    }
}

fn ee_error(log: &ClosedLoopLog) -> f64 {
    log.summary().ee_final_error_m
}

fn run_mpc(robot: &Robot, tr: &Trajectory, x0: &[f64], settings: MpcSettings) -> ClosedLoopLog {
    let mut plant = ModelPlant::new(robot.clone(), x0);
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), settings).unwrap();
    let rs = RunSettings {
        duration_s: 1.5,
        ..RunSettings::default()
    };
    run_closed_loop(&mut plant, &mut mpc, tr, robot, &rs).unwrap()
}

/// MPC with default settings tracks a feasible model-plant reference from the paper's start and from
/// a perturbed start: final EE error of a few mm, torques within the limits.
#[test]
fn mpc_tracks_a_feasible_reference() {
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let log = run_mpc(&robot, &tr, &start_state(), MpcSettings::default());
    let s = log.summary();
    eprintln!("nominal start: {s:?}");
    assert!(s.ee_final_error_m < 2e-3, "{s:?}");
    assert!(s.ee_error_max_m < 5e-3, "{s:?}");
    assert!(s.tau_min >= -5.0 && s.tau_max <= 5.0);

    let mut x0 = start_state();
    for (i, d) in [0.04, -0.05, 0.05, -0.04].iter().enumerate() {
        x0[i] += d;
    }
    let log_p = run_mpc(&robot, &tr, &x0, MpcSettings::default());
    let sp = log_p.summary();
    eprintln!("perturbed start: {sp:?}");
    assert!(sp.ee_final_error_m < 5e-3, "{sp:?}");
    assert!(sp.tau_min >= -5.0 && sp.tau_max <= 5.0);
    // The perturbation is corrected: the EE error peaks near 2 cm and ends several times smaller.
    assert!(sp.ee_error_max_m > 4.0 * sp.ee_final_error_m);

    // Open loop from the perturbed start drifts much further.
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut ol = OpenLoop::new(robot.clone(), tr.clone()).unwrap();
    let log_ol =
        run_closed_loop(&mut plant, &mut ol, &tr, &robot, &RunSettings::default()).unwrap();
    assert!(ee_error(&log_ol) > 5.0 * sp.ee_final_error_m);
}

/// Open-loop replay of a model-plant reference on the same model plant reproduces it.
#[test]
fn open_loop_replay_reproduces_the_reference() {
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let mut plant = ModelPlant::new(robot.clone(), &start_state());
    let mut ol = OpenLoop::new(robot.clone(), tr.clone()).unwrap();
    let log = run_closed_loop(&mut plant, &mut ol, &tr, &robot, &RunSettings::default()).unwrap();
    assert_eq!(log.len(), tr.len());
    let mut worst: f64 = 0.0;
    for k in 0..log.len() {
        assert!((log.t[k] - tr.t[k]).abs() < 1e-12);
        for i in 0..robot.n() {
            worst = worst.max((log.x(k)[i] - tr.q(k)[i]).abs());
            worst = worst.max((log.x(k)[robot.n() + i] - tr.qd(k)[i]).abs());
        }
        if k + 1 < log.len() {
            for j in 0..robot.nu() {
                assert!((log.tau(k)[j] - tr.tau(k)[j]).abs() < 1e-12);
            }
        }
    }
    assert!(worst < 1e-9, "replay deviates by {worst:e}");
    let s = log.summary();
    assert!(s.ee_final_error_m < 1e-9 && s.joint_rms_error_rad < 1e-9);
    // Energy (eq. 18) agrees with the trapezoidal work of the reference to discretisation accuracy.
    let (work, _) = tr.work();
    assert!(
        (s.energy_j - work).abs() < 1e-3 * (1.0 + work.abs()),
        "{} vs {}",
        s.energy_j,
        work
    );
}

/// PD on the actuated joints reduces the actuated-joint error of a perturbed start compared with open
/// loop.
#[test]
fn pd_corrects_actuated_joint_errors() {
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let mut x0 = start_state();
    x0[1] += 0.1;
    x0[2] -= 0.1;
    let rs = RunSettings::default();
    let act_err = |log: &ClosedLoopLog| {
        let k = log.len() - 1;
        (1..robot.n())
            .map(|i| (log.x(k)[i] - log.ref_x(k)[i]).abs())
            .fold(0.0, f64::max)
    };
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut ol = OpenLoop::new(robot.clone(), tr.clone()).unwrap();
    let log_ol = run_closed_loop(&mut plant, &mut ol, &tr, &robot, &rs).unwrap();
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut pd = Pd::new(robot.clone(), tr.clone(), PdSettings::default()).unwrap();
    let log_pd = run_closed_loop(&mut plant, &mut pd, &tr, &robot, &rs).unwrap();
    assert!(act_err(&log_pd) < 0.5 * act_err(&log_ol));
    assert!(pd.name() == "pd" && log_pd.controller == "pd");
}

/// Summary metrics on a hand-made log with known answers, and the CSV layout.
#[test]
fn summary_and_csv_of_a_small_log() {
    let robot = paper_robot(5.0);
    let n = 4;
    let mut log = ClosedLoopLog {
        n,
        ..Default::default()
    };
    // Three rows: q2 moves 0 -> 0.1 -> 0.3 under tau2 = 2 then 1: work = 0.2 + 0.2 = 0.4 J.
    let qs = [
        [0.0, 0.0, 0.0, 0.0],
        [0.0, 0.1, 0.0, 0.0],
        [0.0, 0.3, 0.0, 0.0],
    ];
    let taus = [[2.0, 0.0, 0.0], [1.0, -3.0, 0.0], [1.0, -3.0, 0.0]];
    for k in 0..3 {
        log.t.push(k as f64 * 1e-3);
        log.x.extend(qs[k]);
        log.x.extend([0.0; 4]);
        log.tau.extend(taus[k]);
        log.ee.push(robot.ee_position(&qs[k]));
        log.ref_x.extend([0.0; 8]);
        log.ref_ee.push(robot.ee_position(&[0.0; 4]));
        log.control_us.push([10.0, 30.0, 0.0][k]);
        log.iterations.push([2, 4, 0][k]);
    }
    let s = log.summary();
    assert!((s.energy_j - 0.4).abs() < 1e-15);
    assert_eq!((s.tau_min, s.tau_max), (-3.0, 2.0));
    assert_eq!(s.qp_iterations_mean, 3.0);
    assert_eq!(s.control_step_us_max, 30.0);
    // ee of q = [0, 0.3, 0, 0] vs straight arm: chord of the rotated last three links.
    let ee = robot.ee_position(&qs[2]);
    let want = (ee[0] - 4.0 * 0.355).hypot(ee[1]);
    assert!((s.ee_final_error_m - want).abs() < 1e-15);
    let rms = ((0.01 + 0.09) / 12.0f64).sqrt();
    assert!((s.joint_rms_error_rad - rms).abs() < 1e-15);
    let csv = log.to_csv();
    let header = csv.lines().next().unwrap();
    assert_eq!(
        header,
        "t,q1,q2,q3,q4,qd1,qd2,qd3,qd4,tau2,tau3,tau4,ee_x,ee_y,ref_q1,ref_q2,ref_q3,ref_q4,\
         ref_qd1,ref_qd2,ref_qd3,ref_qd4,ref_ee_x,ref_ee_y,control_us"
    );
    assert_eq!(csv.lines().count(), 4);
    let row: Vec<f64> = csv
        .lines()
        .nth(3)
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(row.len(), 25);
    // the controller's step time of each row is the last column, and reads back
    let back = ClosedLoopLog::from_csv(&csv, "closed_loop.csv").unwrap();
    assert_eq!(back.control_us, log.control_us);
    assert_eq!(back.x, log.x);
    // a file without the column (schema 1) reads back without step times
    let old: String = csv
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n")
        .collect();
    let back = ClosedLoopLog::from_csv(&old, "closed_loop.csv").unwrap();
    assert!(back.control_us.is_empty());
    assert_eq!(back.x, log.x);
    assert!((row[2] - 0.3).abs() < 1e-12 && (row[9] - 1.0).abs() < 1e-12);
    // the executed motion as a trajectory: the same rows
    let tr = log.trajectory();
    assert_eq!(tr.len(), 3);
    for k in 0..3 {
        assert_eq!(tr.t[k], log.t[k]);
        assert_eq!(tr.q(k), &qs[k][..]);
        assert_eq!(tr.qd(k), log.x(k)[n..].to_vec().as_slice());
        assert_eq!(tr.tau(k), &taus[k][..]);
    }
}

/// Measurements for docs/mpc.md (run with `--ignored --nocapture`): tracking of MPC variants and
/// baselines from the perturbed start.
#[test]
#[ignore]
fn report_mpc_variants() {
    let robot = paper_robot(5.0);
    let tr = model_reference(&robot, &start_state(), 1.5);
    let mut x0 = start_state();
    for (i, d) in [0.04, -0.05, 0.05, -0.04].iter().enumerate() {
        x0[i] += d;
    }
    let base = MpcSettings::default();
    let mut variants: Vec<(String, MpcSettings)> = vec![("default".into(), base.clone())];
    for disc in [Discretization::Euler, Discretization::Zoh] {
        for (hn, dt) in [
            (10, 0.01),
            (20, 0.01),
            (10, 0.02),
            (20, 0.02),
            (20, 0.04),
            (40, 0.01),
        ] {
            variants.push((
                format!("{disc:?} N={hn} dt={dt}"),
                MpcSettings {
                    discretization: disc,
                    horizon: hn,
                    dt_mpc: dt,
                    ..base.clone()
                },
            ));
        }
    }
    variants.push((
        "torque ref zero".into(),
        MpcSettings {
            torque_reference: TorqueReference::Zero,
            ..base.clone()
        },
    ));
    variants.push((
        "LTV along reference".into(),
        MpcSettings {
            linearization: Linearization::AlongReference,
            ..base.clone()
        },
    ));
    variants.push((
        "paper affine terms (Model)".into(),
        MpcSettings {
            prediction: Prediction::Model,
            ..base.clone()
        },
    ));
    variants.push((
        "no EE weight".into(),
        MpcSettings {
            w_diag: vec![0.0, 0.0],
            ..base.clone()
        },
    ));
    for start in ["nominal", "perturbed"] {
        let xs = if start == "nominal" {
            start_state()
        } else {
            x0.clone()
        };
        for (name, s) in &variants {
            let log = run_mpc(&robot, &tr, &xs, s.clone());
            let m = log.summary();
            eprintln!(
                "{start:9} {name:28} ee_final {:.2e} ee_max {:.2e} rms {:.2e} E {:.4} tau [{:.2},{:.2}] us p50 {:.0} p99 {:.0} it {:.2}",
                m.ee_final_error_m, m.ee_error_max_m, m.joint_rms_error_rad, m.energy_j, m.tau_min,
                m.tau_max, m.control_step_us_p50, m.control_step_us_p99, m.qp_iterations_mean
            );
        }
        let mut plant = ModelPlant::new(robot.clone(), &xs);
        let mut pd = Pd::new(robot.clone(), tr.clone(), PdSettings::default()).unwrap();
        let m = run_closed_loop(&mut plant, &mut pd, &tr, &robot, &RunSettings::default())
            .unwrap()
            .summary();
        eprintln!(
            "{start:9} PD   ee_final {:.2e} ee_max {:.2e} rms {:.2e}",
            m.ee_final_error_m, m.ee_error_max_m, m.joint_rms_error_rad
        );
        let mut plant = ModelPlant::new(robot.clone(), &xs);
        let mut ol = OpenLoop::new(robot.clone(), tr.clone()).unwrap();
        let m = run_closed_loop(&mut plant, &mut ol, &tr, &robot, &RunSettings::default())
            .unwrap()
            .summary();
        eprintln!(
            "{start:9} OL   ee_final {:.2e} ee_max {:.2e} rms {:.2e}",
            m.ee_final_error_m, m.ee_error_max_m, m.joint_rms_error_rad
        );
    }
}
