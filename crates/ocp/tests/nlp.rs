//! A nonlinear problem (pendulum swing-up with RK4), warm starts and failure paths.

mod common;

use brachia_ocp::*;
use common::*;

fn pendulum() -> Pendulum {
    Pendulum::new(100, 0.05, 4.0)
}

#[test]
fn pendulum_derivatives_match_central_differences() {
    let p = pendulum();
    for (x, tau) in [([0.3, -0.7], 1.1), ([2.9, 3.0], -2.5), ([-1.0, 0.2], 0.0)] {
        let z = [x[0], x[1], tau];
        let f = p.step(x, tau);
        let jac: Vec<f64> = f.iter().flat_map(|j| j.g).collect();
        let val = |z: &[f64]| {
            p.step([z[0], z[1]], z[2])
                .iter()
                .map(|j| j.v)
                .collect::<Vec<_>>()
        };
        assert!(fd_jacobian_error(val, &z, &jac) < 1e-7);
        for r in 0..2 {
            let hess: Vec<f64> = f[r].h.iter().flatten().copied().collect();
            let grad = |z: &[f64]| p.step([z[0], z[1]], z[2])[r].g.to_vec();
            assert!(fd_jacobian_error(grad, &z, &hess) < 1e-6, "row {r}");
        }
    }
}

/// Largest KKT residual at the solver's solution, recomputed from the problem alone: stationarity
/// of the Lagrangian w.r.t. every free variable (with the sign the active torque bound allows),
/// the dynamics, the terminal rows, and complementarity of the stage rows.
fn pendulum_kkt_residual(p: &mut Pendulum, z: &Primal, m: &Multipliers) -> f64 {
    let dims = p.dims.clone();
    let kk = dims.horizon();
    let mut ev: Vec<StageEval> = (0..=kk)
        .map(|k| StageEval::zeros(dims.stages[k], if k < kk { 2 } else { 0 }))
        .collect();
    let mut term = TerminalEval::zeros(2, 2);
    p.evaluate(z, EvalLevel::FirstOrder, &mut ev, &mut term)
        .unwrap();
    let mut res = 0.0_f64;
    for k in 0..=kk {
        let nz = dims.stages[k].nz();
        let mut g = ev[k].grad.clone();
        for i in 0..nz {
            if k < kk {
                for r in 0..2 {
                    g[i] += ev[k].jac_f[r * nz + i] * m.lam[k][r];
                }
            }
            g[i] += ev[k].jac_c[i] * m.mu[k][0];
        }
        for i in 0..2 {
            if k > 0 {
                g[i] -= m.lam[k - 1][i];
            }
            if k == kk {
                g[i] += term.jac_r[i] * m.nu[0] + term.jac_r[2 + i] * m.nu[1];
            }
        }
        if k > 0 {
            res = res.max(g[0].abs()).max(g[1].abs());
        }
        if k < kk {
            // d/dtau L + z_U - z_L = 0 with z_U = max(-g, 0), z_L = max(g, 0) >= 0: complementarity
            // z_U (tau_max - tau) = 0 and z_L (tau + tau_max) = 0, and tau inside its bounds
            let tau = z.u[k][0];
            let gu = g[2];
            let r = ((-gu).max(0.0) * (p.tau_max - tau))
                .abs()
                .max((gu.max(0.0) * (tau + p.tau_max)).abs());
            res = res.max(r).max(tau.abs() - p.tau_max);
            res = res
                .max((ev[k].f[0] - z.x[k + 1][0]).abs())
                .max((ev[k].f[1] - z.x[k + 1][1]).abs());
        }
        let slack = p.omega_max * p.omega_max - ev[k].c[0];
        res = res
            .max((-slack).max(0.0))
            .max((-m.mu[k][0]).max(0.0))
            .max((m.mu[k][0] * slack).abs());
    }
    res.max(term.r[0].abs()).max(term.r[1].abs())
}

#[test]
fn pendulum_swing_up_is_solved_and_satisfies_kkt() {
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let stats = solver.solve(&mut p, &OcpSettings::default());
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    assert!(stats.primal_infeasibility < 1e-8);
    let z = solver.primal().clone();
    let m = solver.multipliers().clone();
    let kkt = pendulum_kkt_residual(&mut p, &z, &m);
    assert!(kkt < 1e-6, "KKT residual {kkt}");
    // the torque limit is what makes this a swing: it is active somewhere
    let tmax = z.u[..100].iter().map(|u| u[0].abs()).fold(0.0, f64::max);
    assert!(tmax > 4.0 - 1e-5, "max |tau| = {tmax}");
    assert!(stats.time.total_s >= stats.time.linear_algebra_s);
}

#[test]
fn warm_start_from_a_solution_takes_few_iterations() {
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let cold = solver.solve(&mut p, &OcpSettings::default());
    assert_eq!(cold.status, OcpStatus::Solved);
    // the same problem with the stored multipliers: the stored point passes at once
    let again = solver.solve(
        &mut p,
        &OcpSettings {
            warm_start: true,
            warm_duals: WarmDuals::Stored,
            mu_init: 1e-6,
            warm_bound_push: 1e-9,
            ..OcpSettings::default()
        },
    );
    assert_eq!(again.status, OcpStatus::Solved, "{again:?}");
    assert!(
        again.iterations <= 3,
        "warm re-solve took {} iterations",
        again.iterations
    );
    assert!((again.objective - cold.objective).abs() < 1e-7 * cold.objective);
}

#[test]
fn stored_bound_duals_with_least_squares_multipliers_restart_at_the_solution() {
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let cold = solver.solve(&mut p, &OcpSettings::default());
    assert_eq!(cold.status, OcpStatus::Solved);
    let lam: Vec<f64> = solver.multipliers().lam.concat();
    // the stored bound duals, the equality multipliers by least squares at the stored point: at a
    // solution they are the solution's (stationarity holds), so the re-solve ends at once
    let again = solver.solve(
        &mut p,
        &OcpSettings {
            warm_start: true,
            warm_duals: WarmDuals::StoredBounds,
            mu_init: 1e-6,
            warm_bound_push: 1e-9,
            ..OcpSettings::default()
        },
    );
    assert_eq!(again.status, OcpStatus::Solved, "{again:?}");
    assert!(again.iterations <= 3, "{} iterations", again.iterations);
    assert!((again.objective - cold.objective).abs() < 1e-7 * cold.objective);
    let scale = lam.iter().fold(1.0_f64, |a, v| a.max(v.abs()));
    let diff = lam
        .iter()
        .zip(solver.multipliers().lam.concat())
        .fold(0.0_f64, |a, (x, y)| a.max((x - y).abs()));
    assert!(
        diff < 1e-4 * scale,
        "multipliers moved by {diff} (scale {scale})"
    );
}

#[test]
fn warm_starts_after_a_shifted_initial_state_beat_cold_starts() {
    // the default warm start (stored primal, duals reset) from the unshifted solution
    let warm_settings = OcpSettings {
        warm_start: true,
        ..OcpSettings::default()
    };
    // summed over the shifts: one shift may take longer warm than cold (0.05 rad: the torques are
    // bang-bang, and the warm start's small steps move the switching times slowly; docs/ocp.md
    // section 8), but on the whole the warm start must pay
    let (mut warm_total, mut cold_total) = (0, 0);
    for shift in [0.01, 0.05, 0.1] {
        let mut p = pendulum();
        let mut solver = OcpSolver::new(&p.dims).unwrap();
        assert_eq!(
            solver.solve(&mut p, &OcpSettings::default()).status,
            OcpStatus::Solved
        );
        p.x0 = [shift, 0.0];
        let warm = solver.solve(&mut p, &warm_settings);
        let mut fresh = OcpSolver::new(&p.dims).unwrap();
        let cold = fresh.solve(&mut p, &OcpSettings::default());
        assert_eq!(warm.status, OcpStatus::Solved, "{shift}: {warm:?}");
        assert_eq!(cold.status, OcpStatus::Solved, "{shift}: {cold:?}");
        warm_total += warm.iterations;
        cold_total += cold.iterations;
        assert!(
            (warm.objective - cold.objective).abs() < 1e-6 * cold.objective,
            "{shift}: another local optimum"
        );
    }
    assert!(
        warm_total < cold_total,
        "warm {warm_total} vs cold {cold_total} iterations over the three shifts"
    );
}

/// Wraps a problem and injects failures.
struct Faulty<P> {
    inner: P,
    mode: Fault,
    calls: usize,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Fault {
    /// evaluate returns Err from the start.
    ErrAlways,
    /// NaN cost at the first line-search trial only.
    NanOnce,
    /// evaluate panics.
    PanicEvaluate,
    /// hessians panics.
    PanicHessian,
    /// hessians returns NaN.
    NanHessian,
}

impl<P: OcpProblem> OcpProblem for Faulty<P> {
    fn dims(&self) -> &OcpDims {
        self.inner.dims()
    }
    fn bounds(&self, k: usize, b: &mut StageBounds) {
        self.inner.bounds(k, b)
    }
    fn initial_guess(&self, z: &mut Primal) {
        self.inner.initial_guess(z)
    }
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        s: &mut [StageEval],
        t: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        self.calls += 1;
        match self.mode {
            Fault::ErrAlways => {
                return Err(EvalError {
                    stage: 3,
                    reason: "model error".into(),
                })
            }
            Fault::PanicEvaluate => panic!("boom"),
            _ => {}
        }
        self.inner.evaluate(z, level, s, t)?;
        if self.mode == Fault::NanOnce && self.calls == 2 {
            s[5].cost = f64::NAN;
        }
        Ok(())
    }
    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        m: &Multipliers,
        s: &mut [StageEval],
    ) -> Result<(), EvalError> {
        match self.mode {
            Fault::PanicHessian => panic!("hessian boom"),
            Fault::NanHessian => {
                self.inner.hessians(z, sigma, m, s)?;
                s[0].hess[0] = f64::NAN;
                Ok(())
            }
            _ => self.inner.hessians(z, sigma, m, s),
        }
    }
}

#[test]
fn failing_callbacks_end_in_evaluation_errors_or_shorter_steps() {
    for mode in [
        Fault::ErrAlways,
        Fault::PanicEvaluate,
        Fault::PanicHessian,
        Fault::NanHessian,
    ] {
        let mut p = Faulty {
            inner: pendulum(),
            mode,
            calls: 0,
        };
        let mut solver = OcpSolver::new(&p.inner.dims).unwrap();
        let stats = solver.solve(&mut p, &OcpSettings::default());
        assert!(
            matches!(stats.status, OcpStatus::EvaluationError(_)),
            "{stats:?}"
        );
        assert!(!stats.status.is_converged());
        // the solver stays usable: a warm start from whatever the failure left behind
        let mut healthy = pendulum();
        let warm = OcpSettings {
            warm_start: true,
            ..OcpSettings::default()
        };
        let again = solver.solve(&mut healthy, &warm);
        assert_eq!(again.status, OcpStatus::Solved, "after {mode:?}: {again:?}");
    }
    let mut p = Faulty {
        inner: pendulum(),
        mode: Fault::NanOnce,
        calls: 0,
    };
    let mut solver = OcpSolver::new(&p.inner.dims).unwrap();
    let stats = solver.solve(&mut p, &OcpSettings::default());
    assert_eq!(
        stats.status,
        OcpStatus::Solved,
        "a NaN trial point only shortens the step: {stats:?}"
    );
}

#[test]
fn invalid_dims_problems_and_settings_are_refused() {
    let one = OcpDims {
        stages: vec![StageDims {
            nx: 2,
            nu: 1,
            nc: 0,
        }],
        n_terminal: 0,
    };
    assert_eq!(
        OcpSolver::new(&one).err(),
        Some(OcpError::TooFewStages { stages: 1 })
    );
    let empty = OcpDims {
        stages: vec![
            StageDims {
                nx: 2,
                nu: 1,
                nc: 0,
            },
            StageDims::default(),
        ],
        n_terminal: 0,
    };
    assert_eq!(
        OcpSolver::new(&empty).err(),
        Some(OcpError::EmptyState { stage: 1 })
    );
    let rows = OcpDims {
        stages: vec![
            StageDims {
                nx: 2,
                nu: 1,
                nc: 0
            };
            3
        ],
        n_terminal: 3,
    };
    assert!(matches!(
        OcpSolver::new(&rows),
        Err(OcpError::TooManyTerminalRows { n_terminal: 3, .. })
    ));
    let big = OcpDims {
        stages: vec![
            StageDims {
                nx: 400,
                nu: 200,
                nc: 0
            };
            2
        ],
        n_terminal: 0,
    };
    assert!(matches!(
        OcpSolver::new(&big),
        Err(OcpError::StageTooLarge {
            stage: 0,
            nz: 600,
            ..
        })
    ));

    // a problem of other dims
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&Pendulum::new(10, 0.05, 3.0).dims).unwrap();
    let stats = solver.solve(&mut p, &OcpSettings::default());
    assert!(
        matches!(stats.status, OcpStatus::InvalidProblem(_)),
        "{stats:?}"
    );
    // inconsistent bounds
    let mut p = pendulum();
    p.tau_max = -1.0;
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let stats = solver.solve(&mut p, &OcpSettings::default());
    assert!(
        matches!(stats.status, OcpStatus::InvalidProblem(ref s) if s.contains("stage 0")),
        "{stats:?}"
    );

    // a stored iterate resized by the user before a warm start
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let _ = solver.solve(
        &mut p,
        &OcpSettings {
            max_iter: 2,
            ..OcpSettings::default()
        },
    );
    solver.primal_mut().x[3].push(1.0);
    let warm = OcpSettings {
        warm_start: true,
        ..OcpSettings::default()
    };
    let stats = solver.solve(&mut p, &warm);
    assert!(
        matches!(stats.status, OcpStatus::InvalidProblem(_)),
        "{stats:?}"
    );

    // settings
    let bad = OcpSettings {
        tol: -1.0,
        ..OcpSettings::default()
    };
    let err = bad.validate().unwrap_err();
    assert!(
        err.to_string().contains("tol") && err.to_string().contains("-1"),
        "{err}"
    );
    let mut p = pendulum();
    let stats = solver.solve(&mut p, &bad);
    assert!(matches!(stats.status, OcpStatus::InvalidSettings(_)));
    for s in [
        OcpSettings {
            mu_init: 0.0,
            ..OcpSettings::default()
        },
        OcpSettings {
            acceptable_tol: 1e-12,
            ..OcpSettings::default()
        },
        OcpSettings {
            max_wall_time_s: Some(f64::NAN),
            ..OcpSettings::default()
        },
        OcpSettings {
            bound_push: 0.7,
            ..OcpSettings::default()
        },
    ] {
        assert!(s.validate().is_err(), "{s:?}");
    }
    assert!(OcpSettings::default().validate().is_ok());
    // serde: unknown fields refused, missing fields defaulted
    let s: OcpSettings = serde_json::from_str(r#"{"max_iter": 7}"#).unwrap();
    assert_eq!(s.max_iter, 7);
    assert_eq!(s.tol, 1e-8);
    assert!(serde_json::from_str::<OcpSettings>(r#"{"max_itr": 7}"#).is_err());
}

#[test]
fn iteration_and_time_limits_end_the_solve() {
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let stats = solver.solve(
        &mut p,
        &OcpSettings {
            max_iter: 3,
            ..OcpSettings::default()
        },
    );
    assert_eq!(stats.status, OcpStatus::MaxIterations);
    assert_eq!(stats.iterations, 3);
    let stats = solver.solve(
        &mut p,
        &OcpSettings {
            max_wall_time_s: Some(1e-9),
            ..OcpSettings::default()
        },
    );
    assert_eq!(stats.status, OcpStatus::MaxWallTime);
    let json = serde_json::to_string(&stats).unwrap();
    assert!(json.contains("MaxWallTime"));
}

#[test]
fn free_final_time_as_a_free_initial_state_matches_a_one_dimensional_search() {
    let (kk, w) = (40, 0.5);
    // reference: golden-section search of E(T) + w T with the closed-form least-norm energy E(T)
    let f = |t: f64| min_energy_for_time(kk, t) + w * t;
    let (mut a, mut b) = (0.5, 5.0);
    let g = 0.5 * (5.0_f64.sqrt() - 1.0);
    for _ in 0..200 {
        let (c, d) = (b - g * (b - a), a + g * (b - a));
        if f(c) < f(d) {
            b = d;
        } else {
            a = c;
        }
    }
    let t_ref = 0.5 * (a + b);
    let mut p = FreeTime::new(kk, w);
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let stats = solver.solve(&mut p, &OcpSettings::default());
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    let t = solver.primal().x[0][2];
    assert!((t - t_ref).abs() < 1e-6, "T = {t} vs {t_ref}");
    assert!((stats.objective - f(t_ref)).abs() < 1e-9);
    // the reduced Hessian is indefinite along T on the dynamics alone but positive definite with
    // the terminal rows: the inertia test of the whole KKT matrix needs no regularisation
    assert_eq!(stats.regularizations, 0, "{stats:?}");
    assert!(stats.iterations <= 12, "{stats:?}");
}

#[test]
fn a_warm_state_without_the_free_time_restarts_the_fixed_time_problem_at_its_solution() {
    // Solve for T, then hand the solution to the problem with T fixed at T* and removed from the
    // state: with the reduced warm state (stored duals) it is already solved, at the closed-form
    // minimum energy for that time.
    let (kk, w) = (40, 0.5);
    let mut free = FreeTime::new(kk, w);
    let mut solver = OcpSolver::new(&free.dims).unwrap();
    let stats = solver.solve(&mut free, &OcpSettings::default());
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    let t_star = solver.primal().x[0][2];
    let ws = solver.warm_state_without_state(2).unwrap();
    let mut fixed = FixedTime::new(kk, t_star);
    let mut fs = OcpSolver::new(&fixed.dims).unwrap();
    // the unreduced state does not fit
    assert!(matches!(
        fs.set_warm_state(&solver.warm_state()),
        Err(OcpError::WarmStateMismatch { .. })
    ));
    fs.set_warm_state(&ws).unwrap();
    // stage by stage the bound duals of [p, v, u]: the free problem's without those of T
    for k in 0..=kk {
        let drop2 = |v: &[f64]| -> Vec<f64> {
            v.iter()
                .enumerate()
                .filter(|&(j, _)| j != 2)
                .map(|(_, &x)| x)
                .collect()
        };
        let (a, b) = (solver.bound_duals(k), fs.bound_duals(k));
        assert_eq!(drop2(a.0), b.0, "stage {k} lower");
        assert_eq!(drop2(a.1), b.1, "stage {k} upper");
    }
    let z = solver.primal().clone();
    for (d, s) in fs.primal_mut().x.iter_mut().zip(&z.x) {
        d.copy_from_slice(&s[..2]);
    }
    for (d, s) in fs.primal_mut().u.iter_mut().zip(&z.u) {
        d.copy_from_slice(s);
    }
    let warm = OcpSettings {
        warm_start: true,
        warm_duals: WarmDuals::Stored,
        warm_bound_push: 1e-9,
        mu_init: stats.final_mu,
        ..OcpSettings::default()
    };
    let st = fs.solve(&mut fixed, &warm);
    assert_eq!(st.status, OcpStatus::Solved, "{st:?}");
    assert!(st.iterations <= 1, "{st:?}");
    let e = min_energy_for_time(kk, t_star);
    assert!((st.objective - e).abs() < 1e-9, "{} vs {e}", st.objective);
    assert!((stats.objective - w * t_star - e).abs() < 1e-9);
    // and the dynamics multipliers of p and v are the free problem's
    for k in 0..kk {
        for i in 0..2 {
            let (a, b) = (solver.multipliers().lam[k][i], fs.multipliers().lam[k][i]);
            assert!(
                (a - b).abs() <= 1e-8 * a.abs().max(1.0),
                "lam[{k}][{i}]: {a} vs {b}"
            );
        }
    }
    // components that cannot be removed
    for i in [3, 7] {
        assert!(matches!(
            solver.warm_state_without_state(i),
            Err(OcpError::StateComponent { component, .. }) if component == i
        ));
    }
}

#[test]
fn free_time_lagrangian_hessian_matches_central_differences() {
    let mut p = FreeTime::new(3, 0.5);
    let dims = p.dims.clone();
    let mut z = Primal::zeros(&dims);
    for k in 0..=3 {
        z.x[k] = vec![0.1 * k as f64, -0.2 + 0.05 * k as f64, 1.3];
        if k < 3 {
            z.u[k] = vec![0.7 - 0.4 * k as f64];
        }
    }
    let mut m = Multipliers::zeros(&dims);
    for k in 0..3 {
        m.lam[k] = vec![0.9 - 0.3 * k as f64, -0.4 + 0.2 * k as f64, 0.1];
    }
    let sigma = 1.3;
    let mut ev: Vec<StageEval> = (0..=3)
        .map(|k| StageEval::zeros(dims.stages[k], if k < 3 { 3 } else { 0 }))
        .collect();
    let mut term = TerminalEval::zeros(2, 3);
    p.hessians(&z, sigma, &m, &mut ev).unwrap();
    for k in 0..3 {
        let hess = ev[k].hess.clone();
        let zk: Vec<f64> = z.x[k].iter().chain(&z.u[k]).copied().collect();
        let grad_l = |zz: &[f64]| {
            let mut zc = z.clone();
            zc.x[k].copy_from_slice(&zz[..3]);
            zc.u[k].copy_from_slice(&zz[3..]);
            let mut ev2 = ev.clone();
            let mut p2 = p.clone();
            p2.evaluate(&zc, EvalLevel::FirstOrder, &mut ev2, &mut term.clone())
                .unwrap();
            (0..4)
                .map(|i| {
                    sigma * ev2[k].grad[i]
                        + (0..3)
                            .map(|r| m.lam[k][r] * ev2[k].jac_f[r * 4 + i])
                            .sum::<f64>()
                })
                .collect::<Vec<_>>()
        };
        let err = fd_jacobian_error(grad_l, &zk, &hess);
        assert!(err < 1e-6, "stage {k}: Hessian error {err}");
    }
    let _ = &mut term;
}

#[test]
fn solver_settings_and_stats_can_cross_threads() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<OcpSolver>();
    send_sync::<OcpSettings>();
    send_sync::<OcpStats>();
    send_sync::<OcpError>();
}

#[test]
fn adaptive_mu_solves_the_swing_up_in_fewer_iterations() {
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let mono = solver.solve(&mut p, &OcpSettings::default());
    let adaptive = solver.solve(
        &mut p,
        &OcpSettings {
            mu_strategy: MuStrategy::Adaptive,
            ..OcpSettings::default()
        },
    );
    assert_eq!(mono.status, OcpStatus::Solved, "{mono:?}");
    assert_eq!(adaptive.status, OcpStatus::Solved, "{adaptive:?}");
    assert!(
        adaptive.iterations < mono.iterations,
        "adaptive {} vs monotone {}",
        adaptive.iterations,
        mono.iterations
    );
    assert!((adaptive.objective - mono.objective).abs() < 1e-6 * mono.objective);
    let z = solver.primal().clone();
    let m = solver.multipliers().clone();
    assert!(pendulum_kkt_residual(&mut p, &z, &m) < 1e-6);
}

#[test]
fn remapped_bound_duals_move_stage_by_stage_where_the_sizes_agree() {
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let cold = solver.solve(&mut p, &OcpSettings::default());
    assert_eq!(cold.status, OcpStatus::Solved);
    let kk = p.dims.horizon();
    let before: Vec<(Vec<f64>, Vec<f64>)> = (0..=kk)
        .map(|k| {
            let (l, u) = solver.bound_duals(k);
            (l.to_vec(), u.to_vec())
        })
        .collect();
    // the bang-bang torques rest on their bounds: some input duals are far from zero
    assert!(before.iter().any(|(l, u)| l[2] > 1e-3 || u[2] > 1e-3));
    // stage k takes stage k + 1's (the last one its own), stage 3 names a stage past K and keeps
    // its own
    let src = |k: usize| if k == 3 { kk + 7 } else { (k + 1).min(kk) };
    solver.remap_bound_duals(src);
    let nx = 2;
    for k in 0..=kk {
        let (l, u) = solver.bound_duals(k);
        let j = src(k);
        if j > kk {
            assert_eq!((l, u), (&before[k].0[..], &before[k].1[..]), "stage {k}");
            continue;
        }
        // states always agree in size; inputs only where both stages have one (not into or out
        // of stage K)
        assert_eq!(&l[..nx], &before[j].0[..nx], "stage {k}");
        assert_eq!(&u[..nx], &before[j].1[..nx], "stage {k}");
        let n_in = l.len() - nx;
        if n_in == before[j].0.len() - nx {
            assert_eq!(&l[nx..], &before[j].0[nx..], "stage {k}");
            assert_eq!(&u[nx..], &before[j].1[nx..], "stage {k}");
        } else {
            assert_eq!(&l[nx..], &before[k].0[nx..], "stage {k}");
        }
    }
}

/// A warm state read after a solve and put back later makes the next warm solve the same, bit for
/// bit, whatever was solved in between; a state of other dimensions is refused and changes nothing.
#[test]
fn a_saved_warm_state_restarts_exactly_whatever_was_solved_in_between() {
    let warm = OcpSettings {
        warm_start: true,
        warm_duals: WarmDuals::StoredBounds,
        warm_bound_push: 1e-9,
        mu_init: 1e-4,
        mu_strategy: MuStrategy::Adaptive,
        ..OcpSettings::default()
    };
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    assert_eq!(
        solver.solve(&mut p, &OcpSettings::default()).status,
        OcpStatus::Solved
    );
    let (z0, w0) = (solver.primal().clone(), solver.warm_state());
    p.x0 = [0.05, 0.0];
    let first = solver.solve(&mut p, &warm);
    assert_eq!(first.status, OcpStatus::Solved, "{first:?}");
    let z1 = solver.primal().clone();
    // other solves in between: another start, cold and warm
    p.x0 = [-0.1, 0.3];
    assert!(solver
        .solve(&mut p, &OcpSettings::default())
        .status
        .is_converged());
    assert!(solver.solve(&mut p, &warm).status.is_converged());
    assert_ne!(
        solver.warm_state(),
        w0,
        "the solves in between moved the state"
    );
    // the state alone is not enough: the primal goes back too
    solver.primal_mut().copy_from(&z0);
    solver.set_warm_state(&w0).unwrap();
    p.x0 = [0.05, 0.0];
    let again = solver.solve(&mut p, &warm);
    assert_eq!(again.iterations, first.iterations);
    assert_eq!(again.objective.to_bits(), first.objective.to_bits());
    assert_eq!(*solver.primal(), z1);

    let q = Pendulum::new(60, 0.05, 5.0);
    let other = OcpSolver::new(&q.dims).unwrap();
    let before = solver.warm_state();
    let err = solver.set_warm_state(&other.warm_state()).unwrap_err();
    assert!(matches!(err, OcpError::WarmStateMismatch { .. }), "{err}");
    assert_eq!(solver.warm_state(), before);
}
