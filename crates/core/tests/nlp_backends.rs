//! The NLP seam (`brachia::planning::nlp`) on problems with known answers, on both backends, before
//! the robot's transcription relies on it. Every test problem's derivatives are checked with
//! `brachia::fdcheck` first.

mod nlp_problems;

use brachia::fdcheck;
use brachia::planning::nlp::RIPOPT_MAX_UNKNOWNS;
use brachia::planning::{solve, Backend, NlpSettings, NlpSolution, SolveStatus, SparseNlp};
use nlp_problems::{DoubleIntegrator, Hs071, Infeasible, LogBarrier, RosenbrockDisk};

const BACKENDS: [Backend; 2] = [Backend::Pounce, Backend::Ripopt];

fn settings(backend: Backend) -> NlpSettings {
    NlpSettings {
        backend,
        ..NlpSettings::default()
    }
}

/// Dense row-major `rows x cols` matrix from triplets (duplicates summed).
fn dense(r: &[usize], c: &[usize], v: &[f64], rows: usize, cols: usize) -> Vec<f64> {
    let mut m = vec![0.0; rows * cols];
    for ((&i, &j), &x) in r.iter().zip(c).zip(v) {
        m[i * cols + j] += x;
    }
    m
}

/// Check gradient, Jacobian and the Hessian of the Lagrangian of `nlp` at `x` against central
/// differences (the Hessian via differences of the exact Lagrangian gradient).
fn check_derivatives<P: SparseNlp + Clone>(nlp: &P, x: &[f64], obj_factor: f64, lambda: &[f64]) {
    let (n, m) = (nlp.n_vars(), nlp.n_cons());
    let mut p = nlp.clone();

    let mut grad = vec![0.0; n];
    p.gradient(x, &mut grad);
    let mut pf = nlp.clone();
    fdcheck::assert_jacobian("gradient", |x, f| f[0] = pf.objective(x), x, &grad, 1e-6);

    if m > 0 {
        let (jr, jc) = p.jacobian_structure();
        let mut jv = vec![0.0; jr.len()];
        p.jacobian_values(x, &mut jv);
        let jac = dense(&jr, &jc, &jv, m, n);
        let mut pg = nlp.clone();
        fdcheck::assert_jacobian(
            "constraint Jacobian",
            |x, g| pg.constraints(x, g),
            x,
            &jac,
            1e-6,
        );
    }

    let (hr, hc) = p.hessian_structure();
    assert!(
        hr.iter().zip(&hc).all(|(r, c)| r >= c),
        "Hessian structure must be lower-triangular"
    );
    let mut hv = vec![0.0; hr.len()];
    p.hessian_values(x, obj_factor, lambda, &mut hv);
    let lower = dense(&hr, &hc, &hv, n, n);
    let mut hess = lower.clone();
    for i in 0..n {
        for j in 0..i {
            hess[j * n + i] = lower[i * n + j];
        }
    }
    let mut pl = nlp.clone();
    let (jr, jc) = pl.jacobian_structure();
    let lambda = lambda.to_vec();
    let grad_lagrangian = |x: &[f64], out: &mut [f64]| {
        pl.gradient(x, out);
        for v in out.iter_mut() {
            *v *= obj_factor;
        }
        let mut jv = vec![0.0; jr.len()];
        pl.jacobian_values(x, &mut jv);
        for ((&i, &j), &v) in jr.iter().zip(&jc).zip(&jv) {
            out[j] += lambda[i] * v;
        }
    };
    fdcheck::assert_hessian("Hessian of the Lagrangian", grad_lagrangian, x, &hess, 1e-6);
}

fn assert_converged(sol: &NlpSolution) {
    assert!(
        sol.status.is_converged(),
        "{:?}: status {:?} ({}) after {} iterations",
        sol.backend,
        sol.status,
        sol.backend_status,
        sol.iterations
    );
    assert_eq!(sol.status, SolveStatus::Solved, "{:?}", sol.backend);
}

/// Stationarity of the Lagrangian with the returned multipliers: grad f + J^T lambda - z_l + z_u.
fn stationarity(nlp: &mut dyn SparseNlp, sol: &NlpSolution) -> f64 {
    let n = nlp.n_vars();
    let mut r = vec![0.0; n];
    nlp.gradient(&sol.x, &mut r);
    let (jr, jc) = nlp.jacobian_structure();
    let mut jv = vec![0.0; jr.len()];
    nlp.jacobian_values(&sol.x, &mut jv);
    for ((&i, &j), &v) in jr.iter().zip(&jc).zip(&jv) {
        r[j] += sol.lambda[i] * v;
    }
    (0..n)
        .map(|j| (r[j] - sol.z_l[j] + sol.z_u[j]).abs())
        .fold(0.0, f64::max)
}

#[test]
fn test_problems_have_exact_derivatives() {
    check_derivatives(&Hs071::default(), &[1.3, 4.1, 3.2, 1.7], 0.7, &[-0.4, 1.3]);
    check_derivatives(
        &Hs071 {
            split_hessian: true,
            ..Hs071::default()
        },
        &[1.3, 4.1, 3.2, 1.7],
        0.7,
        &[-0.4, 1.3],
    );
    let di = DoubleIntegrator { n_int: 6 };
    let x: Vec<f64> = (0..di.n_vars()).map(|i| (0.37 * i as f64).sin()).collect();
    let lambda: Vec<f64> = (0..di.n_cons()).map(|i| (0.9 * i as f64).cos()).collect();
    check_derivatives(&di, &x, 1.3, &lambda);
    check_derivatives(&RosenbrockDisk, &[-0.8, 0.45], 1.0, &[0.6]);
    check_derivatives(&RosenbrockDisk, &[0.3, -1.1], 0.2, &[-2.0]);
    check_derivatives(&Infeasible, &[0.3], 0.5, &[1.0, -2.0]);
    check_derivatives(&LogBarrier::default(), &[1.7], 0.9, &[]);
}

#[test]
fn hs071_reaches_the_known_optimum_on_both_backends() {
    let x_star = [1.0, 4.742_999_4, 3.821_150_3, 1.379_408_2];
    for backend in BACKENDS {
        let mut p = Hs071::default();
        let sol = solve(&mut p, &settings(backend));
        assert_converged(&sol);
        assert!(
            (sol.objective - 17.014_017_3).abs() < 1e-6,
            "{backend:?}: f = {}",
            sol.objective
        );
        for (a, b) in sol.x.iter().zip(&x_star) {
            assert!((a - b).abs() < 1e-6, "{backend:?}: x = {:?}", sol.x);
        }
        // pounce relaxes every bound by bound_relax_factor (1e-8) * max(1, |b|): 2.5e-7 on g0 >= 25.
        assert!(
            sol.max_constraint_violation < 1e-6,
            "{backend:?}: {}",
            sol.max_constraint_violation
        );
        assert!(
            stationarity(&mut p, &sol) < 1e-6,
            "{backend:?}: KKT residual"
        );
        assert!(sol.iterations > 0 && sol.iterations < 50);
        assert_eq!(sol.backend, backend);
    }
}

#[test]
fn duplicate_triplets_are_summed() {
    for backend in BACKENDS {
        let plain = solve(&mut Hs071::default(), &settings(backend));
        let split = solve(
            &mut Hs071 {
                split_hessian: true,
                ..Hs071::default()
            },
            &settings(backend),
        );
        assert_converged(&split);
        assert_eq!(plain.iterations, split.iterations, "{backend:?}");
        for (a, b) in plain.x.iter().zip(&split.x) {
            assert!((a - b).abs() < 1e-10, "{backend:?}");
        }
    }
}

#[test]
fn warm_start_from_the_solution_converges_faster() {
    for backend in BACKENDS {
        let cold = solve(&mut Hs071::default(), &settings(backend));
        assert_converged(&cold);
        let x = [cold.x[0], cold.x[1], cold.x[2], cold.x[3]];
        let mut warm_problem = Hs071 {
            warm: Some((cold.lambda.clone(), cold.z_l.clone(), cold.z_u.clone())),
            start: Some(x),
            ..Hs071::default()
        };
        let warm = solve(
            &mut warm_problem,
            &NlpSettings {
                warm_start: true,
                ..settings(backend)
            },
        );
        assert_converged(&warm);
        assert!(
            warm.iterations < cold.iterations,
            "{backend:?}: warm {} vs cold {} iterations",
            warm.iterations,
            cold.iterations
        );
        assert!((warm.objective - cold.objective).abs() < 1e-7);
    }
}

/// Max |u_k - u(t_k)| over the interior knots and over the two end knots, max |p_k - p(t_k)|.
fn double_integrator_errors(di: &DoubleIntegrator, x: &[f64]) -> (f64, f64, f64) {
    let h = di.h();
    let (mut interior, mut ends, mut pos) = (0.0f64, 0.0f64, 0.0f64);
    for k in 0..=di.n_int {
        let t = k as f64 * h;
        let eu = (x[DoubleIntegrator::iu(k)] - (6.0 - 12.0 * t)).abs();
        if k == 0 || k == di.n_int {
            ends = ends.max(eu);
        } else {
            interior = interior.max(eu);
        }
        pos = pos.max((x[3 * k] - (3.0 * t * t - 2.0 * t.powi(3))).abs());
    }
    (interior, ends, pos)
}

#[test]
fn double_integrator_matches_the_closed_form_on_both_backends() {
    // Closed form: u(t) = 6 - 12 t, p(t) = 3 t^2 - 2 t^3, cost 12. Trapezoidal collocation is second
    // order in the states, the interior controls and the cost; the two end controls carry an O(h)
    // error (they enter the defects only through u_0 + u_1 and u_{N-1} + u_N, and the quadrature
    // gives them half weight). N = 50 is checked against these orders and against N = 100.
    let mut results = Vec::new();
    for backend in BACKENDS {
        let mut per_n = Vec::new();
        for n_int in [50, 100] {
            let di = DoubleIntegrator { n_int };
            let h = di.h();
            let sol = solve(&mut di.clone(), &settings(backend));
            assert_converged(&sol);
            assert!(sol.max_constraint_violation < 1e-10, "{backend:?}");
            let (interior, ends, pos) = double_integrator_errors(&di, &sol.x);
            assert!(
                interior < 30.0 * h * h,
                "{backend:?} N={n_int}: interior |u - u*| = {interior:.3e}"
            );
            assert!(
                ends < 10.0 * h,
                "{backend:?} N={n_int}: end |u - u*| = {ends:.3e}"
            );
            assert!(pos < h * h, "{backend:?} N={n_int}: |p - p*| = {pos:.3e}");
            assert!(
                (sol.objective - 12.0).abs() / 12.0 < 2e-3,
                "{backend:?}: cost {}",
                sol.objective
            );
            per_n.push((sol.objective, interior));
        }
        let ((j50, e50), (j100, e100)) = (per_n[0], per_n[1]);
        // Second order: halving h divides the errors by about 4.
        let cost_ratio = (j50 - 12.0) / (j100 - 12.0);
        assert!(
            (3.5..4.5).contains(&cost_ratio),
            "{backend:?}: cost error ratio {cost_ratio}"
        );
        assert!(
            (3.5..4.5).contains(&(e50 / e100)),
            "{backend:?}: u error ratio {}",
            e50 / e100
        );
        // Richardson extrapolation of the two costs recovers the exact cost.
        let richardson = (4.0 * j100 - j50) / 3.0;
        assert!(
            (richardson - 12.0).abs() < 1e-3,
            "{backend:?}: extrapolated cost {richardson}"
        );
        results.push(j50);
    }
    let rel = (results[0] - results[1]).abs() / results[0].abs();
    assert!(rel < 1e-6, "backends disagree: {results:?}");
}

#[test]
fn rosenbrock_on_the_disk_is_solved_with_kkt_conditions_met() {
    let mut xs = Vec::new();
    for backend in BACKENDS {
        let mut p = RosenbrockDisk;
        let sol = solve(&mut p, &settings(backend));
        assert_converged(&sol);
        // Literature values (4 digits), then first-order optimality from the returned multiplier.
        assert!(
            (sol.x[0] - 0.7864).abs() < 1e-4 && (sol.x[1] - 0.6177).abs() < 1e-4,
            "{:?}",
            sol.x
        );
        assert!((sol.objective - 0.04567).abs() < 1e-5, "{}", sol.objective);
        let r2 = sol.x[0].powi(2) + sol.x[1].powi(2);
        assert!((r2 - 1.0).abs() < 1e-8, "constraint must be active: {r2}");
        assert!(
            sol.lambda[0] > 0.0,
            "an active upper constraint has lambda > 0"
        );
        assert!(
            stationarity(&mut p, &sol) < 1e-7,
            "{backend:?}: KKT residual"
        );
        xs.push(sol.x);
    }
    assert!((xs[0][0] - xs[1][0]).abs() < 1e-8 && (xs[0][1] - xs[1][1]).abs() < 1e-8);
}

#[test]
fn iteration_limit_is_a_status_with_the_last_iterate() {
    for backend in BACKENDS {
        let sol = solve(
            &mut Hs071::default(),
            &NlpSettings {
                max_iter: 2,
                ..settings(backend)
            },
        );
        assert_eq!(
            sol.status,
            SolveStatus::MaxIterations,
            "{backend:?} ({})",
            sol.backend_status
        );
        assert!(!sol.status.is_converged());
        // pounce counts 2; ripopt reaches the same iterate but reports 1 (it counts differently).
        assert!(
            (1..=2).contains(&sol.iterations),
            "{backend:?}: {}",
            sol.iterations
        );
        assert_eq!(sol.x.len(), 4);
        assert!(
            sol.x.iter().all(|v| (1.0..=5.0).contains(v)),
            "{backend:?}: {:?}",
            sol.x
        );
        assert_ne!(
            sol.x,
            vec![1.0, 5.0, 5.0, 1.0],
            "{backend:?}: the iterate must have moved"
        );
        // The objective is re-evaluated at the returned point.
        assert_eq!(sol.objective, Hs071::default().objective(&sol.x));
    }
}

#[test]
fn ripopt_refuses_a_kkt_system_too_large_for_its_dense_factorisation() {
    // 3 * 401 variables and 2 * 400 + 2 dynamics and end rows: past RIPOPT_MAX_UNKNOWNS
    let t = std::time::Instant::now();
    let sol = solve(
        &mut DoubleIntegrator { n_int: 400 },
        &settings(Backend::Ripopt),
    );
    match &sol.status {
        SolveStatus::InvalidProblem(msg) => {
            assert!(
                msg.contains(&format!("at most {RIPOPT_MAX_UNKNOWNS} unknowns")),
                "{msg}"
            );
            assert!(msg.contains("1203 + "), "{msg}");
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(sol.iterations, 0);
    assert!(t.elapsed().as_secs_f64() < 5.0, "{:?}", t.elapsed());
    // the same size is no problem for pounce
    let sol = solve(
        &mut DoubleIntegrator { n_int: 400 },
        &settings(Backend::Pounce),
    );
    assert_converged(&sol);
}

#[test]
fn wall_time_limit_is_a_status() {
    for backend in BACKENDS {
        let sol = solve(
            &mut DoubleIntegrator { n_int: 50 },
            &NlpSettings {
                max_wall_time_s: Some(1e-9),
                ..settings(backend)
            },
        );
        assert_eq!(
            sol.status,
            SolveStatus::MaxWallTime,
            "{backend:?} ({})",
            sol.backend_status
        );
        assert_eq!(sol.x.len(), 153);
    }
}

#[test]
fn infeasible_constraints_give_an_infeasibility_status() {
    for backend in BACKENDS {
        let sol = solve(&mut Infeasible, &settings(backend));
        // ripopt detects local infeasibility; pounce's restoration phase cannot reduce the
        // violation on this one-variable problem and gives up (Restoration_Failed). Both are
        // infeasibility verdicts, neither is convergence.
        let expected = match backend {
            Backend::Pounce => SolveStatus::RestorationFailed,
            Backend::Ripopt => SolveStatus::LocallyInfeasible,
            Backend::Ocp => unreachable!("not a sparse-NLP backend"),
        };
        assert_eq!(sol.status, expected, "{backend:?} ({})", sol.backend_status);
        assert!(!sol.status.is_converged());
        // Whatever x is, one of x >= 1, x <= 0 is violated by at least 1/2.
        assert!(
            sol.max_constraint_violation >= 0.5 - 1e-9,
            "{}",
            sol.max_constraint_violation
        );
    }
}

#[test]
fn nan_in_the_line_search_is_recovered_from() {
    for backend in BACKENDS {
        let sol = solve(&mut LogBarrier::default(), &settings(backend));
        assert_converged(&sol);
        assert!(
            (sol.x[0] - 1.0).abs() < 1e-7,
            "{backend:?}: x = {}",
            sol.x[0]
        );
        assert!((sol.objective - 1.0).abs() < 1e-12);
    }
}

#[test]
fn nan_at_the_start_is_an_evaluation_error() {
    for backend in BACKENDS {
        let sol = solve(
            &mut LogBarrier {
                nan_at_start: true,
                ..LogBarrier::default()
            },
            &settings(backend),
        );
        assert!(
            matches!(sol.status, SolveStatus::EvaluationError(_)),
            "{backend:?}: {:?} ({})",
            sol.status,
            sol.backend_status
        );
        assert!(sol.objective.is_nan());
    }
}

#[test]
fn a_panicking_callback_is_a_status() {
    for backend in BACKENDS {
        let sol = solve(
            &mut LogBarrier {
                panic_in_hessian: true,
                ..LogBarrier::default()
            },
            &settings(backend),
        );
        assert!(!sol.status.is_converged(), "{backend:?}");
        let text = format!("{:?}", sol.status);
        assert!(text.contains("deliberate panic"), "{backend:?}: {text}");
    }
}

#[test]
fn malformed_problems_and_settings_are_statuses() {
    /// HS071 with an upper-triangle Hessian entry.
    #[derive(Clone, Default)]
    struct Upper(Hs071);
    impl SparseNlp for Upper {
        fn n_vars(&self) -> usize {
            4
        }
        fn n_cons(&self) -> usize {
            2
        }
        fn bounds(&self, a: &mut [f64], b: &mut [f64], c: &mut [f64], d: &mut [f64]) {
            self.0.bounds(a, b, c, d)
        }
        fn initial_guess(&self, x: &mut [f64]) {
            self.0.initial_guess(x)
        }
        fn objective(&mut self, x: &[f64]) -> f64 {
            self.0.objective(x)
        }
        fn gradient(&mut self, x: &[f64], g: &mut [f64]) {
            self.0.gradient(x, g)
        }
        fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
            self.0.constraints(x, g)
        }
        fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
            self.0.jacobian_structure()
        }
        fn jacobian_values(&mut self, x: &[f64], v: &mut [f64]) {
            self.0.jacobian_values(x, v)
        }
        fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
            (vec![0], vec![3])
        }
        fn hessian_values(&mut self, _x: &[f64], _of: f64, _l: &[f64], v: &mut [f64]) {
            v[0] = 0.0;
        }
    }
    for backend in BACKENDS {
        let sol = solve(&mut Upper::default(), &settings(backend));
        assert!(
            matches!(sol.status, SolveStatus::InvalidProblem(_)),
            "{:?}",
            sol.status
        );
        let sol = solve(
            &mut Hs071::default(),
            &NlpSettings {
                tol: -1.0,
                ..settings(backend)
            },
        );
        assert!(
            matches!(sol.status, SolveStatus::InvalidSettings(_)),
            "{:?}",
            sol.status
        );
    }
}

#[test]
fn an_iteration_mark_is_raised_by_every_backend_and_changes_nothing_else() {
    use brachia::IterationMark;
    for backend in BACKENDS {
        let plain = solve(&mut Hs071::default(), &settings(backend));
        assert_converged(&plain);
        for (after, raised) in [(1, true), (10_000, false)] {
            let mark = IterationMark::new(after);
            let s = NlpSettings {
                iteration_mark: Some(mark.clone()),
                ..settings(backend)
            };
            let sol = solve(&mut Hs071::default(), &s);
            assert_eq!(mark.is_raised(), raised, "{backend:?}, after {after}");
            assert_eq!(sol.status, plain.status, "{backend:?}");
            assert_eq!(sol.iterations, plain.iterations, "{backend:?}");
            assert_eq!(sol.x, plain.x, "{backend:?}");
        }
    }
}
