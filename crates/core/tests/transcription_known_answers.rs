//! The collocation transcriptions and the NLP backends proven on systems with closed-form answers,
//! through the same `CollocationNlp` the robot planner uses.

use brachia::ad::LocalFn;
use brachia::math::Scalar;
use brachia::planning::nlp::SparseNlp;
use brachia::planning::{
    solve, Backend, CollocationNlp, Layout, NlpSettings, NoPath, Transcription,
};

/// `qdd = u`: the double integrator (n = 1, one input).
struct DoubleIntegrator;
impl LocalFn for DoubleIntegrator {
    type Scratch<T: Scalar> = ();
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        1
    }
    fn scratch<T: Scalar>(&self) {}
    fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
        out[0] = z[2];
    }
}

/// `qdd = -qd`: the velocity obeys x' = -x.
struct Decay;
impl LocalFn for Decay {
    type Scratch<T: Scalar> = ();
    fn n_in(&self) -> usize {
        3
    }
    fn n_out(&self) -> usize {
        1
    }
    fn scratch<T: Scalar>(&self) {}
    fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
        out[0] = -z[1];
    }
}

/// Terminal map `[q, qd] -> [q, qd]` (or nothing).
struct StateTerminal(bool);
impl LocalFn for StateTerminal {
    type Scratch<T: Scalar> = ();
    fn n_in(&self) -> usize {
        2
    }
    fn n_out(&self) -> usize {
        if self.0 {
            2
        } else {
            0
        }
    }
    fn scratch<T: Scalar>(&self) {}
    fn eval<T: Scalar>(&self, _: &mut (), z: &[T], out: &mut [T]) {
        if self.0 {
            out.copy_from_slice(z);
        }
    }
}

fn bounds(layout: &Layout, x0: [f64; 2], u_fixed: Option<f64>) -> (Vec<f64>, Vec<f64>) {
    let nv = layout.n_vars();
    let (mut lo, mut hi) = (vec![-100.0; nv], vec![100.0; nv]);
    for k in 0..2 {
        lo[layout.var(0, k)] = x0[k];
        hi[layout.var(0, k)] = x0[k];
    }
    if let Some(u) = u_fixed {
        for p in 0..layout.points {
            lo[layout.var(p, 2)] = u;
            hi[layout.var(p, 2)] = u;
        }
    }
    (lo, hi)
}

fn min_effort(tr: Transcription, backend: Backend, intervals: usize) -> (f64, Vec<(f64, f64)>) {
    let layout = Layout::new(1, 1, intervals, 1.0, tr);
    let mut nlp = CollocationNlp::new(
        DoubleIntegrator,
        StateTerminal(true),
        layout,
        vec![1.0, 0.0],
        bounds(&layout, [0.0, 0.0], None),
        vec![0.0; layout.n_vars()],
        (&[0.0], &[1.0]),
        None::<NoPath>,
    );
    let sol = solve(
        &mut nlp,
        &NlpSettings {
            backend,
            ..Default::default()
        },
    );
    assert!(
        sol.status.is_converged(),
        "{tr:?} {backend:?}: {:?}",
        sol.status
    );
    let u = (0..layout.points)
        .map(|p| (layout.time(p), sol.x[layout.var(p, 2)]))
        .collect();
    (sol.objective, u)
}

#[test]
fn double_integrator_minimum_effort_matches_closed_form() {
    // x(0) = v(0) = 0, x(1) = 1, v(1) = 0, min int u^2: u(t) = 6 - 12 t, cost 12.
    for backend in [Backend::Pounce, Backend::Ripopt] {
        // Hermite-Simpson represents the optimum (cubic x, linear u) exactly.
        let (cost, u) = min_effort(Transcription::HermiteSimpson, backend, 10);
        assert!((cost - 12.0).abs() < 1e-6, "{backend:?} HS cost {cost}");
        for (t, v) in u {
            assert!(
                (v - (6.0 - 12.0 * t)).abs() < 1e-5,
                "{backend:?} HS u({t}) = {v}"
            );
        }
        // The trapezoidal rule converges at second order.
        let (c1, _) = min_effort(Transcription::Trapezoidal, backend, 20);
        let (c2, _) = min_effort(Transcription::Trapezoidal, backend, 40);
        let (e1, e2) = ((c1 - 12.0).abs(), (c2 - 12.0).abs());
        assert!(
            e1 < 0.2 && e2 < e1 / 3.5,
            "{backend:?} trapezoidal errors {e1} {e2}"
        );
        let (c, _) = min_effort(Transcription::Euler, backend, 50);
        assert!((c - 12.0).abs() / 12.0 < 0.1, "{backend:?} Euler cost {c}");
    }
}

#[test]
fn both_backends_agree_on_the_objective() {
    let (a, _) = min_effort(Transcription::Trapezoidal, Backend::Pounce, 30);
    let (b, _) = min_effort(Transcription::Trapezoidal, Backend::Ripopt, 30);
    assert!((a - b).abs() / a.abs() < 1e-6, "pounce {a} vs ripopt {b}");
}

fn decay_final_velocity(tr: Transcription, intervals: usize) -> f64 {
    let layout = Layout::new(1, 1, intervals, 1.0, tr);
    let mut nlp = CollocationNlp::new(
        Decay,
        StateTerminal(false),
        layout,
        vec![],
        bounds(&layout, [0.0, 1.0], Some(0.0)),
        vec![0.0; layout.n_vars()],
        (&[0.0], &[0.0]),
        None::<NoPath>,
    );
    assert_eq!(nlp.n_terminal(), 0);
    let sol = solve(
        &mut nlp,
        &NlpSettings {
            backend: brachia::planning::Backend::Pounce,
            ..NlpSettings::default()
        },
    );
    assert!(sol.status.is_converged(), "{tr:?}: {:?}", sol.status);
    sol.x[layout.var(layout.points - 1, 1)]
}

#[test]
fn exponential_decay_matches_closed_form_at_the_expected_order() {
    // qd' = -qd, qd(0) = 1: qd(1) = e^-1.
    let exact = (-1.0f64).exp();
    let err = |tr, n| (decay_final_velocity(tr, n) - exact).abs();
    let (h1, h2) = (
        err(Transcription::HermiteSimpson, 10),
        err(Transcription::HermiteSimpson, 20),
    );
    assert!(
        h1 < 1e-5 && h2 < h1 / 12.0,
        "Hermite-Simpson errors {h1:e} {h2:e} (4th order)"
    );
    let (t1, t2) = (
        err(Transcription::Trapezoidal, 10),
        err(Transcription::Trapezoidal, 20),
    );
    assert!(
        t1 < 1e-2 && t2 < t1 / 3.5,
        "trapezoidal errors {t1:e} {t2:e} (2nd order)"
    );
    let (e1, e2) = (err(Transcription::Euler, 10), err(Transcription::Euler, 20));
    assert!(
        e1 < 5e-2 && e2 < e1 / 1.8,
        "Euler errors {e1:e} {e2:e} (1st order)"
    );
    // the other two states stay consistent: q(1) = 1 - e^-1
    let layout = Layout::new(1, 1, 10, 1.0, Transcription::HermiteSimpson);
    let nlp: CollocationNlp<Decay, StateTerminal> = CollocationNlp::new(
        Decay,
        StateTerminal(false),
        layout,
        vec![],
        bounds(&layout, [0.0, 1.0], Some(0.0)),
        vec![0.0; layout.n_vars()],
        (&[0.0], &[0.0]),
        None,
    );
    assert_eq!(nlp.n_vars(), 21 * 3);
}
