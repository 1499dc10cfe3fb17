//! [`solve`]: a sparse NLP on the backend its settings name.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use super::prepare::{panic_text, Prepared};
use super::problem::{
    Backend, NlpSettings, NlpSolution, PassStats, SolveStatus, SparseNlp, TimeSplit,
};
use super::stop::Stop;
use super::{pounce, ripopt};

/// Solve `nlp` with the backend chosen in `settings`. Never panics: every failure is a
/// [`SolveStatus`] (see the module docs). The callbacks of `nlp` run on the calling thread.
pub fn solve(nlp: &mut dyn SparseNlp, settings: &NlpSettings) -> NlpSolution {
    let start = Instant::now();
    let backend = settings.backend;
    let fail = |status: SolveStatus, x: Vec<f64>, lambda_len: usize| NlpSolution {
        status,
        objective: f64::NAN,
        lambda: vec![0.0; lambda_len],
        z_l: vec![0.0; x.len()],
        z_u: vec![0.0; x.len()],
        x,
        iterations: 0,
        solve_time_s: start.elapsed().as_secs_f64(),
        time_split: TimeSplit {
            line_search_and_other_s: start.elapsed().as_secs_f64(),
            ..TimeSplit::default()
        },
        passes: Vec::new(),
        max_constraint_violation: f64::INFINITY,
        backend,
        backend_status: String::new(),
    };
    if let Err(e) = settings.validate() {
        return fail(SolveStatus::InvalidSettings(e.to_string()), Vec::new(), 0);
    }
    let stop = Stop::new(settings, start);
    let prep = match catch_unwind(AssertUnwindSafe(|| Prepared::new(&*nlp, settings))) {
        Ok(Ok(p)) => p,
        Ok(Err(msg)) => return fail(SolveStatus::InvalidProblem(msg), Vec::new(), 0),
        Err(p) => {
            return fail(
                SolveStatus::EvaluationError(format!(
                    "panic while reading the problem: {}",
                    panic_text(&*p)
                )),
                Vec::new(),
                0,
            )
        }
    };
    if stop.cancelled() {
        return fail(SolveStatus::Cancelled, prep.x0.clone(), prep.m);
    }
    let backend_start = Instant::now();
    let mut outcome =
        match backend {
            Backend::Pounce => pounce::run(nlp, &prep, settings, &stop),
            Backend::Ripopt => ripopt::run(nlp, &prep, settings, &stop),
            Backend::Ocp => return fail(
                SolveStatus::InvalidSettings(
                    "backend \"ocp\" solves stage-structured optimal-control problems only (the \
                     planner's transcription = \"multiple-shooting\"); a sparse NLP needs \
                     \"pounce\" or \"ripopt\""
                        .into(),
                ),
                prep.x0.clone(),
                prep.m,
            ),
        };
    outcome.status = stop.verdict(outcome.status);
    if let Some(p) = outcome.passes.iter_mut().find(|p| p.returned) {
        p.status = Some(outcome.status.clone());
    }
    let x = outcome
        .x
        .filter(|x| x.len() == prep.n)
        .unwrap_or_else(|| prep.x0.clone());
    let vec_or_zeros = |v: Option<Vec<f64>>, len: usize| {
        v.filter(|v| v.len() == len)
            .unwrap_or_else(|| vec![0.0; len])
    };
    // Re-evaluate f and g at the returned point: one definition of the objective and of the
    // violation for both backends.
    let (objective, viol) = catch_unwind(AssertUnwindSafe(|| {
        let f = nlp.objective(&x);
        let mut g = vec![0.0; prep.m];
        nlp.constraints(&x, &mut g);
        (f, prep.violation(&x, &g))
    }))
    .unwrap_or((f64::NAN, f64::INFINITY));
    // The passes cover the backend's run; the checks before it go to the first pass and the final
    // re-evaluation (a callback) to the last, so the passes add up to the whole call.
    let before = backend_start.saturating_duration_since(start).as_secs_f64();
    let solve_time_s = start.elapsed().as_secs_f64();
    if outcome.passes.is_empty() {
        outcome.passes.push(PassStats {
            what: backend.name().to_string(),
            iterations: outcome.iterations,
            time_s: 0.0,
            time: TimeSplit::default(),
            status: Some(outcome.status.clone()),
            returned: true,
        });
    }
    outcome.passes[0].time.line_search_and_other_s += before;
    let covered: f64 = outcome.passes.iter().map(|p| p.time.total_s()).sum();
    if let Some(last) = outcome.passes.last_mut() {
        last.time.callbacks_s += (solve_time_s - covered).max(0.0);
    }
    let mut time_split = TimeSplit::default();
    for p in &mut outcome.passes {
        p.time_s = p.time.total_s();
        time_split.add(&p.time);
    }
    NlpSolution {
        status: outcome.status,
        lambda: vec_or_zeros(outcome.lambda, prep.m),
        z_l: vec_or_zeros(outcome.z_l, prep.n),
        z_u: vec_or_zeros(outcome.z_u, prep.n),
        x,
        objective,
        iterations: outcome.passes.iter().map(|p| p.iterations).sum(),
        solve_time_s,
        time_split,
        passes: outcome.passes,
        max_constraint_violation: viol,
        backend,
        backend_status: outcome.backend_status,
    }
}
