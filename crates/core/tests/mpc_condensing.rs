//! The MPC's condensed QP against a dense construction from its own stage models, for 3, 4 and 5
//! links (the paper's 4 links run the constant-size path of the step, the others the generic one):
//! `H = Gamma^T Qt Gamma + R + D^T Rd D` and `g` = the gradient of the cost at `U = 0`, built here
//! with nalgebra from [`Mpc::stage_model`] and [`Mpc::reference_window`], for both linearisations
//! and both discretisations (rate penalty on). The QP's answer is checked by its KKT residual.
//!
//! Conventions: x = [q, qd] (rad, rad/s; q1 absolute from +x), u = tau of joints 2..n (N m).

use brachia::control::boxqp::kkt_residual;
use brachia::control::{Discretization, Linearization, Mpc, MpcSettings};
mod common;

use brachia::model::{LinkParams, Robot};
use brachia::sim::{Controller, ModelPlant, Plant};
use brachia::trajectory::Trajectory;
use common::chain_robot;
use nalgebra::{DMatrix, DVector};

/// An n-link chain of the paper's proportions (+-5 N m).
fn robot(n: usize) -> Robot {
    let links = (0..n)
        .map(|i| LinkParams {
            length: 0.355 * 4.0 / n as f64,
            mass: if i == 0 || i + 1 == n { 0.35 } else { 0.56 },
            com: 0.18 * 4.0 / n as f64,
            inertia: if i == 0 || i + 1 == n { 0.98 } else { 0.10 },
            radius: 0.02,
            ..Default::default()
        })
        .collect();
    chain_robot(&format!("chain{n}"), links, 5.0)
}

/// 0.8 s of the model plant under small smooth torques from a hanging pose, 1 ms samples.
fn reference(robot: &Robot) -> Trajectory {
    let (n, nu) = (robot.n(), robot.nu());
    let mut x0 = vec![0.0; 2 * n];
    x0[0] = -2.0;
    for (i, v) in x0[1..n].iter_mut().enumerate() {
        *v = 0.3 * (i as f64 + 1.0).sin();
    }
    let mut plant = ModelPlant::new(robot.clone(), &x0);
    let mut tr = Trajectory::new(n);
    let (mut x, mut tau) = (vec![0.0; 2 * n], vec![0.0; nu]);
    for _ in 0..=800 {
        let t = plant.time();
        plant.state(&mut x);
        for (j, v) in tau.iter_mut().enumerate() {
            *v = 0.4 * (3.0 * t + j as f64).sin();
        }
        tr.push(t, &x[..n], &x[n..], &tau);
        plant.step(&tau, 1e-3);
    }
    tr
}

fn dm(v: &[f64], r: usize, c: usize) -> DMatrix<f64> {
    DMatrix::from_row_slice(r, c, v)
}

/// Runs a few closed-loop calls from a perturbed start, then checks the last call's QP.
fn check(n: usize, discretization: Discretization, linearization: Linearization) {
    let robot = robot(n);
    let tr = reference(&robot);
    let (nx, nu) = (2 * n, n - 1);
    let settings = MpcSettings {
        horizon: 12,
        discretization,
        linearization,
        ..MpcSettings::for_links(n)
    };
    let hn = settings.horizon;
    let mut mpc = Mpc::new(robot.clone(), tr.clone(), settings.clone()).unwrap();
    let mut x = vec![0.0; nx];
    tr.state_at(0.0, &mut x);
    for (i, v) in x.iter_mut().enumerate() {
        *v += 0.03 * (1.7 * i as f64).cos();
    }
    let mut plant = ModelPlant::new(robot.clone(), &x);
    let mut tau = vec![0.0; nu];
    let mut tau_prev = tau.clone();
    for _ in 0..7 {
        tau_prev.copy_from_slice(&tau);
        plant.state(&mut x);
        mpc.control(plant.time(), &x, &mut tau);
        plant.step(&tau, 1e-3);
    }
    let (h, g, lb, ub) = mpc.qp_data();
    let (xref, yref, tauref) = mpc.reference_window();

    // Prediction X = Gamma U + xi over the stage models.
    let nall = hn * nu;
    let mut gamma = DMatrix::zeros(hn * nx, nall);
    let mut xi = DVector::zeros(hn * nx);
    let mut xk = DVector::from_column_slice(&x);
    let mut dxk = DMatrix::zeros(nx, nall);
    for k in 0..hn {
        let s = mpc.stage_model(k);
        let (a, b) = (dm(s.ad, nx, nx), dm(s.bd, nx, nu));
        xk = &a * &xk + DVector::from_column_slice(s.fd);
        dxk = &a * &dxk;
        dxk.view_mut((0, k * nu), (nx, nu)).copy_from(&b);
        gamma.view_mut((k * nx, 0), (nx, nall)).copy_from(&dxk);
        xi.rows_mut(k * nx, nx).copy_from(&xk);
    }
    // Cost 1/2 sum_k |x_k - xd_k|^2_Q + |C_k x_k + fy_k - yd_k|^2_W (x terminal_factor at k = N).
    let q = DMatrix::from_diagonal(&DVector::from_column_slice(&settings.q_diag));
    let w = DMatrix::from_diagonal(&DVector::from_column_slice(&settings.w_diag));
    let mut qt = DMatrix::zeros(hn * nx, hn * nx);
    let mut grad_x = DVector::zeros(hn * nx);
    for k in 1..=hn {
        let fac = if k == hn {
            settings.terminal_factor
        } else {
            1.0
        };
        let s = mpc.stage_model(k);
        let c = dm(s.c, 2, nx);
        let qk = &q * fac + c.transpose() * &w * &c * fac;
        qt.view_mut(((k - 1) * nx, (k - 1) * nx), (nx, nx))
            .copy_from(&qk);
        let x_k = xi.rows((k - 1) * nx, nx);
        let xd = DVector::from_column_slice(&xref[(k - 1) * nx..k * nx]);
        let yd = DVector::from_column_slice(&yref[2 * (k - 1)..2 * k]);
        let ry = &c * x_k + DVector::from_column_slice(s.fy) - yd;
        let gk = (&q * (x_k - xd) + c.transpose() * &w * ry) * fac;
        grad_x.rows_mut((k - 1) * nx, nx).copy_from(&gk);
    }
    // 1/2 |U - U^d|^2_R + 1/2 sum_k |u_k - u_{k-1}|^2_Rd with u_{-1} the torque applied last.
    let mut hr = DMatrix::zeros(nall, nall);
    let mut gr = DVector::zeros(nall);
    for k in 0..hn {
        for a in 0..nu {
            let d = k * nu + a;
            hr[(d, d)] += settings.r_diag[a];
            gr[d] -= settings.r_diag[a] * tauref[d];
            let rd = settings.rate_diag[a];
            hr[(d, d)] += rd;
            if k == 0 {
                gr[d] -= rd * tau_prev[a];
            } else {
                hr[(d - nu, d - nu)] += rd;
                hr[(d, d - nu)] -= rd;
                hr[(d - nu, d)] -= rd;
            }
        }
    }
    let h_ref = gamma.transpose() * &qt * &gamma + hr;
    let g_ref = gamma.transpose() * grad_x + gr;
    let hs = h_ref.abs().max();
    let gs = g_ref.abs().max().max(1.0);
    for i in 0..nall {
        for j in 0..nall {
            let d = (h[i * nall + j] - h_ref[(i, j)]).abs();
            assert!(
                d <= 1e-10 * hs,
                "n={n} {discretization:?} {linearization:?}: H[{i}][{j}] {} vs {} (scale {hs:e})",
                h[i * nall + j],
                h_ref[(i, j)]
            );
        }
        let d = (g[i] - g_ref[i]).abs();
        assert!(
            d <= 1e-10 * gs * hs.max(1.0),
            "n={n} {discretization:?} {linearization:?}: g[{i}] {} vs {}",
            g[i],
            g_ref[i]
        );
    }
    let kkt = kkt_residual(h, g, lb, ub, mpc.solution());
    assert!(kkt < 1e-9, "n={n}: KKT residual {kkt:e}");
    assert_eq!(&tau[..], &mpc.solution()[..nu]);
}

#[test]
fn condensed_qp_matches_a_dense_construction_for_any_link_count() {
    for n in [3, 4, 5] {
        for disc in [Discretization::Zoh, Discretization::Euler] {
            for lin in [Linearization::Measured, Linearization::AlongReference] {
                check(n, disc, lin);
            }
        }
    }
}
