//! Convex problems with known answers, and random OCP-structured QPs against clarabel.

mod common;

use brachia_ocp::*;
use common::*;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn solve(p: &mut LqProblem) -> (OcpSolver, OcpStats) {
    let mut solver = OcpSolver::new(&p.dims.clone()).unwrap();
    let stats = solver.solve(p, &OcpSettings::default());
    (solver, stats)
}

/// Reachability rows of the double integrator: x_K = sum_k A^(K-1-k) B u_k.
fn double_integrator_rows(kk: usize, h: f64) -> Vec<Vec<f64>> {
    let mut e = vec![vec![0.0; kk]; 2];
    for k in 0..kk {
        let steps = (kk - 1 - k) as f64; // A^s B = [h^2/2 + s h^2, h]
        e[0][k] = 0.5 * h * h + steps * h * h;
        e[1][k] = h;
    }
    e
}

#[test]
fn minimum_energy_double_integrator_matches_the_least_norm_solution() {
    let (kk, h) = (40, 0.05);
    let mut p = double_integrator(kk, h);
    let (solver, stats) = solve(&mut p);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    let e = double_integrator_rows(kk, h);
    let u_ref = weighted_least_norm(&e, &vec![h; kk], &[1.0, 0.0]);
    for k in 0..kk {
        let u = solver.primal().u[k][0];
        assert!((u - u_ref[k]).abs() < 1e-7, "u_{k} = {u} vs {}", u_ref[k]);
    }
    let j_ref: f64 = u_ref.iter().map(|u| 0.5 * h * u * u).sum();
    assert!((stats.objective - j_ref).abs() < 1e-8 * j_ref);
    assert!(stats.primal_infeasibility < 1e-9);
    assert!(
        stats.iterations <= 3,
        "an unconstrained QP is one Newton step: {}",
        stats.iterations
    );
    // terminal multipliers: nu = -(E W^-1 E^T)^-1 t (sign of the Lagrangian +nu^T r)
    assert!(solver.multipliers().nu.iter().all(|v| v.is_finite()));
}

#[test]
fn a_cost_concave_only_in_the_directions_the_terminal_rows_fix_needs_no_regularisation() {
    // -c/2 |x_K|^2 with x_K fixed by the terminal rows: the KKT matrix has the inertia of a
    // minimiser (the Hessian is positive definite on the null space of all rows), but the
    // Riccati recursion alone sees R^_{K-1} = h - c |B|^2 < 0. The penalty on the equality rows
    // (docs/ocp.md section 5) passes the test without delta_w: the exact Newton step, which for
    // a QP is the solution, and the minimiser is that of the problem without the concave term.
    let (kk, h, c) = (40, 0.05, 100.0);
    let mut p = double_integrator(kk, h);
    p.stages[kk].h = vec![-c, 0.0, 0.0, -c];
    let (solver, stats) = solve(&mut p);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    assert_eq!(stats.regularizations, 0, "{stats:?}");
    assert!(stats.iterations <= 3, "{stats:?}");
    let e = double_integrator_rows(kk, h);
    let u_ref = weighted_least_norm(&e, &vec![h; kk], &[1.0, 0.0]);
    for k in 0..kk {
        let u = solver.primal().u[k][0];
        assert!((u - u_ref[k]).abs() < 1e-7, "u_{k} = {u} vs {}", u_ref[k]);
    }
    let j_ref: f64 = u_ref.iter().map(|u| 0.5 * h * u * u).sum::<f64>() - 0.5 * c;
    assert!((stats.objective - j_ref).abs() < 1e-8 * j_ref.abs());
}

#[test]
fn a_warm_solve_keeps_the_equality_row_penalty_of_the_last_solve() {
    // The concave terminal cost above needs the equality-row penalty: a cold solve searches it
    // (rho = 0, 1, 100, .. until the inertia test passes). A warm re-solve starts from the penalty
    // that passed last (docs/ocp.md section 5), so its every factorisation passes at once.
    let (kk, h, c) = (40, 0.05, 100.0);
    let mut p = double_integrator(kk, h);
    p.stages[kk].h = vec![-c, 0.0, 0.0, -c];
    let (mut solver, cold) = solve(&mut p);
    assert_eq!(cold.status, OcpStatus::Solved, "{cold:?}");
    assert!(cold.factorizations > cold.iterations, "{cold:?}");
    // a shifted start: the warm solve needs real iterations
    p.stages[0].bounds.x_lo[1] = 0.3;
    p.stages[0].bounds.x_hi[1] = 0.3;
    let warm = solver.solve(
        &mut p,
        &OcpSettings {
            warm_start: true,
            ..OcpSettings::default()
        },
    );
    assert_eq!(warm.status, OcpStatus::Solved, "{warm:?}");
    assert!(warm.iterations >= 1, "{warm:?}");
    assert_eq!(warm.factorizations, warm.iterations, "{warm:?}");
    assert_eq!(warm.regularizations, 0, "{warm:?}");
    let (_, cold2) = solve(&mut p);
    assert!((warm.objective - cold2.objective).abs() < 1e-8 * cold2.objective.abs());
}

/// The double integrator over `kk` steps of `h` with its initial velocity free at the weight `w0`
/// (`1/2 w0 v0^2`): solved, and checked against the weighted least-norm solution (`v0` within
/// `v0_tol`, every input within 1e-7).
fn free_initial_velocity_case(w0: f64, v0_tol: f64) {
    let (kk, h) = (30, 0.05);
    let mut p = double_integrator(kk, h);
    p.stages[0].bounds.x_lo[1] = f64::NEG_INFINITY;
    p.stages[0].bounds.x_hi[1] = f64::INFINITY;
    p.stages[0].h[3 + 1] = w0; // (v0, v0): 1/2 w0 v0^2
    let (solver, stats) = solve(&mut p);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    // unknowns y = [v0, u_0..u_K-1]; x_K = [T v0, v0] + E u
    let mut e = double_integrator_rows(kk, h);
    e[0].insert(0, kk as f64 * h);
    e[1].insert(0, 1.0);
    let mut w = vec![w0];
    w.extend(std::iter::repeat_n(h, kk));
    let y = weighted_least_norm(&e, &w, &[1.0, 0.0]);
    let v0 = solver.primal().x[0][1];
    assert!((v0 - y[0]).abs() < v0_tol, "v0 {v0} vs {}", y[0]);
    for k in 0..kk {
        assert!((solver.primal().u[k][0] - y[k + 1]).abs() < 1e-7);
    }
}

#[test]
fn free_initial_velocity_matches_the_weighted_least_norm_solution() {
    free_initial_velocity_case(2.0, 1e-7);
}

#[test]
fn a_free_initial_state_of_curvature_far_above_the_fixed_states_is_solved() {
    // x_0 fixed (unit entry in P_0), v_0 free with the weight 1e15 (beside the fixed position,
    // P_0's diagonal spans more than the 1e13 of the singularity test): the known answer, no
    // numerical error
    free_initial_velocity_case(1e15, 1e-12);
}

#[test]
fn decay_with_a_free_initial_state_and_no_cost_is_fixed_by_the_terminal_row() {
    // x' = -x, exact discretisation x+ = e^-h x, no input, no cost; x_0 free, x_K = e^-T fixed by
    // the terminal row: the solution is x_k = e^-(k h). The Hessian is zero, P_0 singular, but
    // the KKT matrix is not (the row fixes x_0): the penalty on the equality rows makes P_0
    // positive definite and the step exact, without delta_w.
    let (kk, h) = (25, 0.04_f64);
    let stages = vec![
        StageDims {
            nx: 1,
            nu: 0,
            nc: 0
        };
        kk + 1
    ];
    let mut p = LqProblem::zeros(OcpDims {
        stages,
        n_terminal: 1,
    });
    for k in 0..kk {
        p.stages[k].a = vec![(-h).exp()];
    }
    p.g = vec![1.0];
    p.r0 = vec![-(-(kk as f64) * h).exp()];
    let (solver, stats) = solve(&mut p);
    assert!(stats.status.is_converged(), "{stats:?}");
    for k in 0..=kk {
        let x = solver.primal().x[k][0];
        assert!((x - (-(k as f64) * h).exp()).abs() < 1e-7, "x_{k} = {x}");
    }
    assert_eq!(stats.regularizations, 0, "{stats:?}");
    assert!(stats.iterations <= 2, "a linear problem: {stats:?}");

    // the same with x_0 = 1 fixed: pure simulation, x_K = e^-T
    p.stages[0].bounds.x_lo = vec![1.0];
    p.stages[0].bounds.x_hi = vec![1.0];
    p.dims.n_terminal = 0;
    p.g.clear();
    p.r0.clear();
    let (solver, stats) = solve(&mut p);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    let xk = solver.primal().x[kk][0];
    assert!((xk - (-(kk as f64) * h).exp()).abs() < 1e-12);
}

/// The double integrator over `kk` steps with |u| <= u_max and the stage row v <= v_max.
fn speed_limited(kk: usize, h: f64, u_max: f64, v_max: f64) -> LqProblem {
    let mut p = double_integrator(kk, h);
    for k in 0..=kk {
        p.dims.stages[k].nc = 1;
        let d = p.dims.stages[k];
        p.stages[k].cm = vec![0.0; d.nz()];
        p.stages[k].cm[1] = 1.0;
        p.stages[k].bounds.c_lo = vec![f64::NEG_INFINITY];
        p.stages[k].bounds.c_hi = vec![v_max];
        if k < kk {
            p.stages[k].bounds.u_lo = vec![-u_max];
            p.stages[k].bounds.u_hi = vec![u_max];
        }
    }
    p
}

#[test]
fn an_unreachable_target_is_locally_infeasible() {
    // 1 m in 2 s with |u| <= 1.2 and v <= 0.6 reaches at most 0.9 m
    let mut p = speed_limited(40, 0.05, 1.2, 0.6);
    let (_, stats) = solve(&mut p);
    assert!(
        matches!(
            stats.status,
            OcpStatus::LocallyInfeasible | OcpStatus::RestorationFailed
        ),
        "{stats:?}"
    );
    assert!(stats.primal_infeasibility > 1e-3, "{stats:?}");
}

#[test]
fn active_bounds_and_stage_inequalities_match_clarabel() {
    // double integrator over 2.5 s (unconstrained: |u| <= 0.96, v <= 0.6) with |u| <= 0.8 and a
    // speed limit v <= 0.58 as a stage row (both active)
    let (kk, h) = (50, 0.05);
    let mut p = speed_limited(kk, h, 0.8, 0.58);
    let (solver, stats) = solve(&mut p);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    let (jc, zc, ok) = p.solve_clarabel();
    assert!(ok);
    assert!(
        (stats.objective - jc).abs() < 1e-6 * jc.abs(),
        "{} vs {jc}",
        stats.objective
    );
    let z = LqProblem::flat(solver.primal());
    let err = z
        .iter()
        .zip(&zc)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err < 1e-4, "solution differs by {err}");
    let umax = solver.primal().u[..kk]
        .iter()
        .map(|u| u[0].abs())
        .fold(0.0, f64::max);
    let vmax = solver
        .primal()
        .x
        .iter()
        .map(|x| x[1])
        .fold(f64::MIN, f64::max);
    assert!(
        umax > 0.8 - 1e-6 && umax <= 0.8 + 1e-9,
        "input bound active: {umax}"
    );
    assert!(
        vmax > 0.58 - 1e-6 && vmax <= 0.58 + 1e-8,
        "speed row active: {vmax}"
    );
    // inequality multipliers are >= 0 on the active upper rows
    assert!(solver.multipliers().mu.iter().all(|m| m[0] > -1e-8));
}

#[test]
fn random_convex_qps_match_clarabel() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut pinned = 0;
    for case in 0..40 {
        let kk = rng.gen_range(1..15);
        let nx = rng.gen_range(1..5);
        let nu = rng.gen_range(0..4);
        let nc = rng.gen_range(0..3);
        let nr = rng.gen_range(0..=nx.min(2));
        let free = rng.gen_bool(0.3);
        let mut p = random_qp(&mut rng, kk, nx, nu, nc, nr, free);
        let (mut jc, mut zc, ok) = p.solve_clarabel();
        assert!(ok, "case {case}: clarabel failed");
        if case % 3 == 0 && kk * nu >= nr + 4 {
            // pin one state after stage 0 at its optimal value (an equality row of the Schur
            // complement; the optimum does not move). Only with spare inputs: pinning the last
            // free direction makes the problem degenerate (no strictly feasible direction).
            let k = rng.gen_range(1..=kk);
            let i = rng.gen_range(0..nx);
            let o: usize = p.dims.stages[..k].iter().map(|d| d.nz()).sum();
            p.stages[k].bounds.x_lo[i] = zc[o + i];
            p.stages[k].bounds.x_hi[i] = zc[o + i];
            let (j2, z2, ok) = p.solve_clarabel();
            assert!(
                ok && (j2 - jc).abs() < 1e-7 * jc.abs().max(1.0),
                "case {case}: pinning moved the optimum"
            );
            (jc, zc) = (j2, z2);
            pinned += 1;
        }
        let (solver, stats) = solve(&mut p);
        assert_eq!(
            stats.status,
            OcpStatus::Solved,
            "case {case} (K {kk} nx {nx} nu {nu} nc {nc} nr {nr}): {stats:?}"
        );
        let rel = (stats.objective - jc).abs() / jc.abs().max(1.0);
        assert!(
            rel < 1e-6,
            "case {case}: objective {} vs clarabel {jc}",
            stats.objective
        );
        let z = LqProblem::flat(solver.primal());
        let err = z
            .iter()
            .zip(&zc)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-4, "case {case}: solution differs by {err}");
        assert!((p.objective(&z) - stats.objective).abs() < 1e-9 * (1.0 + jc.abs()));
    }
    assert!(pinned >= 5, "only {pinned} cases with a pinned state");
}

#[test]
fn fixed_states_after_stage_zero_are_exact_equalities() {
    // x_K = [1, 0] through bounds instead of terminal rows: the same least-norm solution
    let (kk, h) = (40, 0.05);
    let mut p = double_integrator(kk, h);
    p.dims.n_terminal = 0;
    p.g.clear();
    p.r0.clear();
    p.stages[kk].bounds.x_lo = vec![1.0, 0.0];
    p.stages[kk].bounds.x_hi = vec![1.0, 0.0];
    let (solver, stats) = solve(&mut p);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    let u_ref = weighted_least_norm(&double_integrator_rows(kk, h), &vec![h; kk], &[1.0, 0.0]);
    for k in 0..kk {
        assert!((solver.primal().u[k][0] - u_ref[k]).abs() < 1e-7);
    }
    let xk = &solver.primal().x[kk];
    assert!((xk[0] - 1.0).abs() < 1e-12 && xk[1].abs() < 1e-12, "{xk:?}");

    // a via point (position fixed halfway) plus terminal rows, with an input bound: clarabel
    let mut p = double_integrator(kk, h);
    p.stages[kk / 2].bounds.x_lo[0] = 0.7;
    p.stages[kk / 2].bounds.x_hi[0] = 0.7;
    for k in 0..kk {
        p.stages[k].bounds.u_lo = vec![-2.5];
        p.stages[k].bounds.u_hi = vec![2.5];
    }
    let (solver, stats) = solve(&mut p);
    assert_eq!(stats.status, OcpStatus::Solved, "{stats:?}");
    let (jc, zc, ok) = p.solve_clarabel();
    assert!(ok);
    assert!(
        (stats.objective - jc).abs() < 1e-6 * jc.abs(),
        "{} vs {jc}",
        stats.objective
    );
    let z = LqProblem::flat(solver.primal());
    let err = z
        .iter()
        .zip(&zc)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(err < 1e-4, "solution differs by {err}");
    assert!((solver.primal().x[kk / 2][0] - 0.7).abs() < 1e-9);
}

#[test]
fn stage_sizes_that_vary_along_the_horizon_match_clarabel() {
    // nx_k, nu_k and nc_k change from stage to stage (e.g. a grasp switch that drops states)
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for case in 0..10 {
        let kk = rng.gen_range(2..8);
        let stages: Vec<StageDims> = (0..=kk)
            .map(|_| StageDims {
                nx: rng.gen_range(1..5),
                nu: rng.gen_range(0..3),
                nc: rng.gen_range(0..2),
            })
            .collect();
        let nr = rng.gen_range(0..=stages[kk].nx.min(2));
        let mut p = LqProblem::zeros(OcpDims {
            stages: stages.clone(),
            n_terminal: nr,
        });
        let mut x: Vec<f64> = (0..stages[0].nx)
            .map(|_| rng.gen_range(-1.0..1.0))
            .collect();
        for k in 0..=kk {
            let d = stages[k];
            let nz = d.nz();
            let u: Vec<f64> = (0..d.nu).map(|_| rng.gen_range(-1.0..1.0)).collect();
            let zbar: Vec<f64> = x.iter().chain(&u).copied().collect();
            let st = &mut p.stages[k];
            let mm: Vec<f64> = (0..nz * nz).map(|_| rng.gen_range(-1.0..1.0)).collect();
            for a in 0..nz {
                for b in 0..nz {
                    st.h[a * nz + b] = (0..nz)
                        .map(|r| mm[r * nz + a] * mm[r * nz + b])
                        .sum::<f64>()
                        + if a == b { 0.2 } else { 0.0 };
                }
                st.q[a] = rng.gen_range(-1.0..1.0);
            }
            if k == 0 {
                st.bounds.x_lo.copy_from_slice(&x);
                st.bounds.x_hi.copy_from_slice(&x);
            }
            for i in 0..d.nu {
                st.bounds.u_lo[i] = u[i] - rng.gen_range(0.0..0.3);
                st.bounds.u_hi[i] = u[i] + rng.gen_range(0.0..0.3);
            }
            for j in 0..d.nc {
                let row: Vec<f64> = (0..nz).map(|_| rng.gen_range(-1.0..1.0)).collect();
                let cv: f64 = row.iter().zip(&zbar).map(|(a, b)| a * b).sum();
                st.cm[j * nz..(j + 1) * nz].copy_from_slice(&row);
                st.bounds.c_hi[j] = cv + rng.gen_range(0.0..0.2);
            }
            if k < kk {
                let nx1 = stages[k + 1].nx;
                let mut xn = vec![0.0; nx1];
                for r in 0..nx1 {
                    for c in 0..d.nx {
                        st.a[r * d.nx + c] = rng.gen_range(-1.0..1.0);
                    }
                    for c in 0..d.nu {
                        st.b[r * d.nu + c] = rng.gen_range(-1.0..1.0);
                    }
                    xn[r] = (0..d.nx).map(|c| st.a[r * d.nx + c] * x[c]).sum::<f64>()
                        + (0..d.nu).map(|c| st.b[r * d.nu + c] * u[c]).sum::<f64>();
                }
                x = xn;
            }
        }
        let nxk = stages[kk].nx;
        for r in 0..nr {
            for c in 0..nxk {
                p.g[r * nxk + c] = rng.gen_range(-1.0..1.0);
            }
            p.r0[r] = -(0..nxk).map(|c| p.g[r * nxk + c] * x[c]).sum::<f64>();
        }
        let (jc, zc, ok) = p.solve_clarabel();
        assert!(ok, "case {case}: clarabel failed");
        let (solver, stats) = solve(&mut p);
        assert_eq!(
            stats.status,
            OcpStatus::Solved,
            "case {case} {stages:?}: {stats:?}"
        );
        let rel = (stats.objective - jc).abs() / jc.abs().max(1.0);
        assert!(
            rel < 1e-6,
            "case {case}: objective {} vs clarabel {jc}",
            stats.objective
        );
        let z = LqProblem::flat(solver.primal());
        let err = z
            .iter()
            .zip(&zc)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        assert!(err < 1e-4, "case {case}: solution differs by {err}");
    }
}

#[test]
fn centrality_correctors_shorten_convex_solves_to_the_same_optimum() {
    // Gondzio's correctors (OcpSettings::centrality_correctors) lengthen the steps cut by the
    // fraction to the boundary; on convex QPs with active bounds they save iterations (docs/ocp.md,
    // sections 6 and 12). The robot-sized random QP of examples/iterations.rs (K = 223, nx = 8, nu = 3,
    // two stage rows, four terminal rows) and the random suite, against clarabel.
    let solve_with = |p: &mut LqProblem, k: usize| {
        let mut solver = OcpSolver::new(&p.dims.clone()).unwrap();
        let s = OcpSettings {
            centrality_correctors: k,
            ..OcpSettings::default()
        };
        let stats = solver.solve(p, &s);
        assert_eq!(stats.status, OcpStatus::Solved, "{k} correctors: {stats:?}");
        (LqProblem::flat(solver.primal()), stats)
    };
    let check = |name: &str, p: &mut LqProblem| {
        let (jc, zc, ok) = p.solve_clarabel();
        assert!(ok, "{name}: clarabel failed");
        let (z0, s0) = solve_with(p, 0);
        let (z3, s3) = solve_with(p, 3);
        assert_eq!(s0.centrality_correctors, 0);
        for (z, s) in [(&z0, &s0), (&z3, &s3)] {
            let rel = (s.objective - jc).abs() / jc.abs().max(1.0);
            assert!(
                rel < 1e-6,
                "{name}: objective {} vs clarabel {jc}",
                s.objective
            );
            let err = z
                .iter()
                .zip(&zc)
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f64::max);
            assert!(
                err < 1e-4,
                "{name}: solution differs from clarabel's by {err}"
            );
        }
        let rel = (s3.objective - s0.objective).abs() / s0.objective.abs().max(1.0);
        assert!(
            rel < 1e-8,
            "{name}: objectives {} and {}",
            s0.objective,
            s3.objective
        );
        (s0, s3)
    };
    let mut rng = ChaCha8Rng::seed_from_u64(2026);
    let mut big = random_qp_with(&mut rng, 223, 8, 3, 2, 4, false, 0.9, 0.05);
    let (s0, s3) = check("K223", &mut big);
    assert!(s3.centrality_correctors > 0, "{s3:?}");
    assert!(
        s3.iterations < s0.iterations,
        "K223: {} iterations with correctors, {} without",
        s3.iterations,
        s0.iterations
    );
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    let (mut n0, mut n3) = (0, 0);
    for case in 0..40 {
        let kk = rng.gen_range(1..15);
        let nx = rng.gen_range(1..5);
        let nu = rng.gen_range(0..4);
        let nc = rng.gen_range(0..3);
        let nr = rng.gen_range(0..=nx.min(2));
        let free = rng.gen_bool(0.3);
        let mut p = random_qp(&mut rng, kk, nx, nu, nc, nr, free);
        let (s0, s3) = check(&format!("case {case}"), &mut p);
        n0 += s0.iterations;
        n3 += s3.iterations;
    }
    assert!(
        n3 < n0,
        "random QPs: {n3} iterations with correctors, {n0} without"
    );
}

#[test]
fn too_many_centrality_correctors_are_refused() {
    let s = OcpSettings {
        centrality_correctors: MAX_CENTRALITY_CORRECTORS + 1,
        ..OcpSettings::default()
    };
    let e = s.validate().unwrap_err();
    assert!(
        matches!(
            e,
            OcpError::InvalidSetting {
                field: "centrality_correctors",
                ..
            }
        ),
        "{e}"
    );
    let ok = OcpSettings {
        centrality_correctors: MAX_CENTRALITY_CORRECTORS,
        ..OcpSettings::default()
    };
    assert!(ok.validate().is_ok());
}
