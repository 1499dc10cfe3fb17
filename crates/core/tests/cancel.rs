//! A cancel token stops every backend at its next iteration with `SolveStatus::Cancelled`, and the
//! planner between its strategies; `max_wall_time_s` stops pounce and ripopt within one iteration.

mod nlp_problems;

use brachia::planning::{
    plan, solve, Backend, NlpSettings, PlannerSettings, SolveStatus, SparseNlp, SwingTask,
    SwingTime, Transcription,
};
use brachia::{CancelToken, Robot};
use nlp_problems::{Hs071, RosenbrockDisk};
use std::time::{Duration, Instant};

/// A bound no prompt stop comes near, for a loaded machine (the measured times are printed).
const GENEROUS: Duration = Duration::from_secs(5);

/// A problem whose Hessian takes at least `sleep` (so an iteration does), which sets `token` when
/// its Hessian is asked for the `cancel_at`-th time, and records when each Hessian was asked for.
struct Slow<P> {
    inner: P,
    sleep: Duration,
    token: CancelToken,
    cancel_at: Option<usize>,
    hessians: Vec<Instant>,
}

impl<P: SparseNlp> Slow<P> {
    fn new(inner: P, sleep_ms: u64, cancel_at: Option<usize>) -> Self {
        Slow {
            inner,
            sleep: Duration::from_millis(sleep_ms),
            token: CancelToken::new(),
            cancel_at,
            hessians: Vec::new(),
        }
    }

    /// The longest time between two Hessians (about one iteration), s.
    fn longest_iteration_s(&self) -> f64 {
        self.hessians
            .windows(2)
            .map(|w| (w[1] - w[0]).as_secs_f64())
            .fold(0.0, f64::max)
    }
}

impl<P: SparseNlp> SparseNlp for Slow<P> {
    fn n_vars(&self) -> usize {
        self.inner.n_vars()
    }
    fn n_cons(&self) -> usize {
        self.inner.n_cons()
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64], g_l: &mut [f64], g_u: &mut [f64]) {
        self.inner.bounds(x_l, x_u, g_l, g_u)
    }
    fn initial_guess(&self, x: &mut [f64]) {
        self.inner.initial_guess(x)
    }
    fn objective(&mut self, x: &[f64]) -> f64 {
        self.inner.objective(x)
    }
    fn gradient(&mut self, x: &[f64], grad: &mut [f64]) {
        self.inner.gradient(x, grad)
    }
    fn constraints(&mut self, x: &[f64], g: &mut [f64]) {
        self.inner.constraints(x, g)
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        self.inner.jacobian_structure()
    }
    fn jacobian_values(&mut self, x: &[f64], vals: &mut [f64]) {
        self.inner.jacobian_values(x, vals)
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        self.inner.hessian_structure()
    }
    fn hessian_values(&mut self, x: &[f64], obj_factor: f64, lambda: &[f64], vals: &mut [f64]) {
        self.hessians.push(Instant::now());
        if self.cancel_at == Some(self.hessians.len()) {
            self.token.cancel();
        }
        std::thread::sleep(self.sleep);
        self.inner.hessian_values(x, obj_factor, lambda, vals)
    }
}

const NLP_BACKENDS: [Backend; 2] = [Backend::Pounce, Backend::Ripopt];

#[test]
fn a_token_set_before_the_solve_stops_every_nlp_backend_before_its_first_iteration() {
    for backend in NLP_BACKENDS {
        let mut p = Slow::new(RosenbrockDisk, 0, None);
        p.token.cancel();
        let s = NlpSettings {
            backend,
            cancel: Some(p.token.clone()),
            ..NlpSettings::default()
        };
        let sol = solve(&mut p, &s);
        assert_eq!(sol.status, SolveStatus::Cancelled, "{backend:?}");
        assert_eq!(sol.iterations, 0, "{backend:?}");
        assert!(p.hessians.is_empty(), "{backend:?}");
    }
}

#[test]
fn a_token_set_during_the_solve_stops_every_nlp_backend_at_its_next_iteration() {
    for backend in NLP_BACKENDS {
        // the problem alone takes more iterations than where the token is set
        let mut free = Slow::new(RosenbrockDisk, 0, None);
        let full = solve(
            &mut free,
            &NlpSettings {
                backend,
                ..NlpSettings::default()
            },
        );
        assert!(full.status.is_converged(), "{backend:?}: {:?}", full.status);
        let at = 3;
        assert!(full.iterations > at + 2, "{backend:?}: {}", full.iterations);
        let mut p = Slow::new(RosenbrockDisk, 0, Some(at));
        let s = NlpSettings {
            backend,
            cancel: Some(p.token.clone()),
            ..NlpSettings::default()
        };
        let sol = solve(&mut p, &s);
        assert_eq!(sol.status, SolveStatus::Cancelled, "{backend:?}");
        // the iteration that asked for the at-th Hessian finishes, the next one does not start
        assert!(
            p.hessians.len() <= at + 1,
            "{backend:?}: {} Hessians after the token was set at the {at}-th",
            p.hessians.len()
        );
        assert!(!sol.x.is_empty() && sol.x.iter().all(|v| v.is_finite()));
        let returned = sol.passes.iter().find(|p| p.returned).unwrap();
        assert_eq!(returned.status, Some(SolveStatus::Cancelled));
    }
}

#[test]
fn pounce_and_ripopt_stop_within_one_iteration_of_the_time_limit() {
    for backend in NLP_BACKENDS {
        // 40 ms per iteration at least; the problem needs many more than the limit allows
        let mut p = Slow::new(Hs071::default(), 40, None);
        let limit = 0.15;
        let s = NlpSettings {
            backend,
            max_wall_time_s: Some(limit),
            ..NlpSettings::default()
        };
        let sol = solve(&mut p, &s);
        let it = p.longest_iteration_s();
        eprintln!(
            "{backend:?}: max_wall_time_s = {limit}: returned after {:.3} s, {} iterations, \
             longest iteration {it:.3} s",
            sol.solve_time_s, sol.iterations
        );
        assert_eq!(sol.status, SolveStatus::MaxWallTime, "{backend:?}");
        assert!(
            sol.solve_time_s <= limit + it + 0.1,
            "{backend:?}: {:.3} s with a limit of {limit} s and iterations of {it:.3} s",
            sol.solve_time_s
        );
    }
}

fn paper() -> Robot {
    Robot::paper()
}

fn task() -> SwingTask {
    SwingTask {
        q0: vec![-2.35, 0.0, -1.55, 0.0],
        qd0: vec![0.0; 4],
        target: [0.8, 0.0],
        obstacles: vec![],
    }
}

#[test]
fn a_cancelled_plan_is_a_status_on_every_backend_and_runs_no_strategy() {
    for (backend, transcription, knot_dt) in [
        (Backend::Ocp, Transcription::MultipleShooting, 0.03),
        (Backend::Pounce, Transcription::HermiteSimpson, 0.05),
        (Backend::Ripopt, Transcription::Trapezoidal, 0.15),
    ] {
        let settings = PlannerSettings {
            swing_time: SwingTime::Seconds(2.2),
            knot_dt,
            transcription,
            ..PlannerSettings::default()
        };
        let token = CancelToken::new();
        token.cancel();
        let nlp = NlpSettings {
            backend,
            cancel: Some(token),
            ..NlpSettings::default()
        };
        let t0 = Instant::now();
        let p = plan(&paper(), &task(), &settings, &nlp).unwrap();
        assert_eq!(p.status, SolveStatus::Cancelled, "{backend:?}");
        assert_eq!(p.iterations, 0, "{backend:?}");
        // no retry, no torque continuation
        assert_eq!(p.attempts, 1, "{backend:?}");
        assert!(p.torque_continuation.is_none(), "{backend:?}");
        assert!(t0.elapsed() < GENEROUS, "{backend:?}");
    }
}

#[test]
fn a_token_set_from_another_thread_stops_a_long_plan_promptly() {
    // a 20 s swing takes far longer to plan than the test waits
    let settings = PlannerSettings {
        swing_time: SwingTime::Seconds(20.0),
        knot_dt: 0.01,
        transcription: Transcription::MultipleShooting,
        ..PlannerSettings::default()
    };
    let token = CancelToken::new();
    let nlp = NlpSettings {
        cancel: Some(token.clone()),
        ..NlpSettings::default()
    };
    let setter = token.clone();
    let timer = std::thread::spawn(move || {
        std::thread::sleep(Duration::from_millis(100));
        setter.cancel();
        Instant::now()
    });
    let p = plan(&paper(), &task(), &settings, &nlp).unwrap();
    let returned = Instant::now();
    let set = timer.join().unwrap();
    let took = returned.saturating_duration_since(set);
    eprintln!(
        "20 s swing (ocp): returned {:.3} s after the token was set",
        took.as_secs_f64()
    );
    assert_eq!(p.status, SolveStatus::Cancelled);
    assert!(took < GENEROUS, "{took:?}");
}
