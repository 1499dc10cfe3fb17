//! The collocation NLP's exact Jacobian and Hessian against finite differences, for every transcription.

use brachia::fdcheck::{assert_hessian, assert_jacobian};
use brachia::model::DynamicsFn;
use brachia::planning::nlp::SparseNlp;
use brachia::planning::{CollocationNlp, EeTerminalFn, Layout, NoPath, Transcription};
use brachia::Robot;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

type SwingNlp = CollocationNlp<DynamicsFn, EeTerminalFn, NoPath>;

fn swing_nlp(
    robot: &Robot,
    layout: Layout,
    target: [f64; 2],
    nv: usize,
    x: &[f64],
    w: (&[f64], &[f64]),
) -> SwingNlp {
    let robot = std::sync::Arc::new(robot.clone());
    CollocationNlp::new(
        DynamicsFn::new(std::sync::Arc::clone(&robot)),
        EeTerminalFn::new(robot),
        layout,
        vec![target[0], target[1], 0.0, 0.0],
        (vec![-1e3; nv], vec![1e3; nv]),
        x.to_vec(),
        w,
        None,
    )
}

fn dense_from_triplets(
    rows: &[usize],
    cols: &[usize],
    vals: &[f64],
    m: usize,
    n: usize,
    sym: bool,
) -> Vec<f64> {
    let mut d = vec![0.0; m * n];
    for k in 0..vals.len() {
        d[rows[k] * n + cols[k]] += vals[k];
        if sym && rows[k] != cols[k] {
            d[cols[k] * n + rows[k]] += vals[k];
        }
    }
    d
}

#[test]
fn jacobian_and_hessian_match_finite_differences() {
    let robot = Robot::paper();
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    for tr in [
        Transcription::Euler,
        Transcription::Trapezoidal,
        Transcription::HermiteSimpson,
    ] {
        let layout = Layout::new(4, 3, 3, 0.3, tr);
        let nv = layout.n_vars();
        let x: Vec<f64> = (0..nv).map(|_| rng.gen_range(-1.5..1.5)).collect();
        let (q1, r1) = (vec![0.3, 0.2, 0.1, 0.4], vec![1.0, 2.0, 0.5]);
        let mut nlp = swing_nlp(&robot, layout, [0.8, 0.0], nv, &x, (&q1, &r1));
        let m = nlp.n_cons();
        let (jr, jc) = nlp.jacobian_structure();
        let mut jv = vec![0.0; jr.len()];
        nlp.jacobian_values(&x, &mut jv);
        let jac = dense_from_triplets(&jr, &jc, &jv, m, nv, false);
        // no duplicate entries in the structure
        let mut seen = std::collections::HashSet::new();
        assert!(jr.iter().zip(&jc).all(|e| seen.insert(e)));
        let mut nlp2 = swing_nlp(&robot, layout, [0.8, 0.0], nv, &x, (&q1, &r1));
        assert_jacobian(
            &format!("{tr:?} constraint Jacobian"),
            |x, g| nlp2.constraints(x, g),
            &x,
            &jac,
            1e-6,
        );

        // Hessian of the Lagrangian vs FD of its exact gradient
        let lam: Vec<f64> = (0..m).map(|_| rng.gen_range(-1.0..1.0)).collect();
        let sigma = 0.7;
        let (hr, hc) = nlp.hessian_structure();
        assert!(
            hr.iter().zip(&hc).all(|(r, c)| r >= c),
            "lower triangle only"
        );
        let mut hv = vec![0.0; hr.len()];
        nlp.hessian_values(&x, sigma, &lam, &mut hv);
        let hess = dense_from_triplets(&hr, &hc, &hv, nv, nv, true);
        let mut nlp3 = swing_nlp(&robot, layout, [0.8, 0.0], nv, &x, (&q1, &r1));
        let (r3, c3) = nlp3.jacobian_structure();
        let grad_lag = |x: &[f64], g: &mut [f64]| {
            nlp3.gradient(x, g);
            for v in g.iter_mut() {
                *v *= sigma;
            }
            let mut jv = vec![0.0; r3.len()];
            nlp3.jacobian_values(x, &mut jv);
            for k in 0..jv.len() {
                g[c3[k]] += lam[r3[k]] * jv[k];
            }
        };
        assert_hessian(
            &format!("{tr:?} Lagrangian Hessian"),
            grad_lag,
            &x,
            &hess,
            1e-5,
        );
    }
}

#[test]
fn defects_vanish_on_an_exact_polynomial_motion() {
    // An independent path for the defect formulas: for a free particle-like motion with qdd == 0 there is
    // nothing to test, so instead check each rule against its definition on the model's own dynamics: the
    // trapezoidal q-defect and the Hermite-Simpson interpolation rows are exact for cubic q(t) with
    // qd = q'(t) (they do not involve qdd), evaluated through the NLP's constraint function.
    let robot = Robot::paper();
    for tr in [Transcription::Trapezoidal, Transcription::HermiteSimpson] {
        let layout = Layout::new(4, 3, 4, 0.4, tr);
        let nv = layout.n_vars();
        let mut x = vec![0.0; nv];
        let (a, b) = (0.7, -1.3);
        for p in 0..layout.points {
            let t = layout.time(p);
            for i in 0..4 {
                let s = (i + 1) as f64;
                // linear in t for the trapezoidal rule (exact), cubic for Hermite
                let (q, qd) = match tr {
                    Transcription::Trapezoidal => (a * s * t + b, a * s),
                    _ => (a * s * t * t * t + b * t, 3.0 * a * s * t * t + b),
                };
                x[layout.var(p, i)] = q;
                x[layout.var(p, 4 + i)] = qd;
            }
        }
        let mut nlp = swing_nlp(&robot, layout, [0.0, 0.0], nv, &x, (&[0.0; 4], &[1.0; 3]));
        let mut g = vec![0.0; nlp.n_cons()];
        nlp.constraints(&x, &mut g);
        let rows_per_interval = nlp.n_defects() / layout.intervals;
        for k in 0..layout.intervals {
            for i in 0..4 {
                let r = k * rows_per_interval + i; // first block: q rows (trapezoid) / q interpolation (HS)
                assert!(g[r].abs() < 1e-12, "{tr:?} interval {k} row {i}: {}", g[r]);
                if tr == Transcription::HermiteSimpson {
                    let r = k * rows_per_interval + 2 * 4 + i; // Simpson q rows, exact for cubics
                    assert!(g[r].abs() < 1e-12, "{tr:?} Simpson row: {}", g[r]);
                }
            }
        }
    }
}
