//! A cancel token ends a solve at the next iteration with `OcpStatus::Cancelled`; an iteration mark
//! is raised once its iterations have run and changes nothing of the solve.

mod common;

use brachia_ocp::*;
use common::*;

/// The pendulum swing-up, which sets `token` when its Hessians are asked for the `at`-th time
/// (once per iteration): a cancellation that arrives in the middle of a solve.
struct CancelAt {
    inner: Pendulum,
    token: CancelToken,
    hessian_calls: usize,
    at: usize,
}

impl OcpProblem for CancelAt {
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
        st: &mut [StageEval],
        t: &mut TerminalEval,
    ) -> Result<(), EvalError> {
        self.inner.evaluate(z, level, st, t)
    }
    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        m: &Multipliers,
        st: &mut [StageEval],
    ) -> Result<(), EvalError> {
        self.hessian_calls += 1;
        if self.hessian_calls == self.at {
            self.token.cancel();
        }
        self.inner.hessians(z, sigma, m, st)
    }
}

fn pendulum() -> Pendulum {
    Pendulum::new(100, 0.05, 4.0)
}

#[test]
fn a_token_set_before_the_solve_stops_it_before_the_first_step() {
    let mut p = pendulum();
    let mut solver = OcpSolver::new(&p.dims).unwrap();
    let token = CancelToken::new();
    token.cancel();
    let st = OcpSettings {
        cancel: Some(token),
        ..OcpSettings::default()
    };
    let stats = solver.solve(&mut p, &st);
    assert_eq!(stats.status, OcpStatus::Cancelled);
    assert_eq!(stats.iterations, 0);
    assert!(!stats.status.is_converged());
}

#[test]
fn a_token_set_during_an_iteration_stops_it_before_its_step() {
    let mut solver = OcpSolver::new(&pendulum().dims).unwrap();
    // the uncancelled solve takes many more iterations than where the token is set
    let full = solver.solve(&mut pendulum(), &OcpSettings::default());
    assert!(full.status.is_converged(), "{:?}", full.status);
    let at = 4;
    assert!(full.iterations > at + 2, "{} iterations", full.iterations);
    let token = CancelToken::new();
    let mut p = CancelAt {
        inner: pendulum(),
        token: token.clone(),
        hessian_calls: 0,
        at,
    };
    let st = OcpSettings {
        cancel: Some(token.clone()),
        ..OcpSettings::default()
    };
    let stats = solver.solve(&mut p, &st);
    assert_eq!(stats.status, OcpStatus::Cancelled);
    // the iteration that asked for the `at`-th Hessians stops right after them, before its step:
    // `at - 1` iterations were completed
    assert_eq!(stats.iterations, at - 1, "{stats:?}");
    assert!(stats.objective.is_finite());
}

#[test]
fn an_unset_token_changes_nothing_and_is_not_a_setting_of_a_file() {
    let mut solver = OcpSolver::new(&pendulum().dims).unwrap();
    let plain = solver.solve(&mut pendulum(), &OcpSettings::default());
    let token = CancelToken::new();
    let st = OcpSettings {
        cancel: Some(token.clone()),
        ..OcpSettings::default()
    };
    let with = solver.solve(&mut pendulum(), &st);
    assert_eq!(with.status, plain.status);
    assert_eq!(with.iterations, plain.iterations);
    assert_eq!(with.objective, plain.objective);
    // serde skips the token: a settings file cannot hold one, and a round trip drops it
    let json = serde_json::to_string(&st).unwrap();
    assert!(!json.contains("cancel"), "{json}");
    let back: OcpSettings = serde_json::from_str(&json).unwrap();
    assert_eq!(back.cancel, None);
    assert!(serde_json::from_str::<OcpSettings>(r#"{"cancel": true}"#).is_err());
    // tokens compare equal only when they share the flag
    assert_eq!(token, token.clone());
    assert_ne!(token, CancelToken::new());
}

/// A solve of the pendulum with a mark raised after `after` iterations: its statistics and
/// whether the flag was raised.
fn marked(after: usize) -> (OcpStats, bool) {
    let mut solver = OcpSolver::new(&pendulum().dims).unwrap();
    let mark = IterationMark::new(after);
    let st = OcpSettings {
        iteration_mark: Some(mark.clone()),
        ..OcpSettings::default()
    };
    let stats = solver.solve(&mut pendulum(), &st);
    (stats, mark.is_raised())
}

#[test]
fn an_iteration_mark_is_raised_once_its_iterations_have_run_and_changes_nothing_else() {
    let mut solver = OcpSolver::new(&pendulum().dims).unwrap();
    let plain = solver.solve(&mut pendulum(), &OcpSettings::default());
    assert!(plain.status.is_converged(), "{:?}", plain.status);
    let k = plain.iterations;
    assert!(k > 3, "{k} iterations");
    // raised at the top of the iteration `after`: reached by a solve of k iterations for any
    // `after <= k` (the top of iteration k is where the converged solve stops)
    for (after, raised) in [
        (0, true),
        (2, true),
        (k, true),
        (k + 1, false),
        (10 * k, false),
    ] {
        let (stats, r) = marked(after);
        assert_eq!(r, raised, "after {after} of {k} iterations");
        assert_eq!(stats.status, plain.status);
        assert_eq!(stats.iterations, plain.iterations);
        assert_eq!(stats.objective, plain.objective);
    }
    // not a setting of a file
    let st = OcpSettings {
        iteration_mark: Some(IterationMark::new(3)),
        ..OcpSettings::default()
    };
    let json = serde_json::to_string(&st).unwrap();
    assert!(!json.contains("iteration_mark"), "{json}");
    let back: OcpSettings = serde_json::from_str(&json).unwrap();
    assert_eq!(back.iteration_mark, None);
}
