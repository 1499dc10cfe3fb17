//! The ripopt 0.8 backend of [`super::solve`].
//!
//! ripopt's `NlpProblem` takes `&self` in its callbacks and has no `'static` bound, so the user's
//! problem is borrowed directly (through a `RefCell`) and evaluated on the calling thread.
//! Options set: `print_level`, `max_iter`, `tol`, `constr_viol_tol`, `acceptable_iter`,
//! `max_wall_time`, `mu_strategy_adaptive`, `mu_init` (when set), `warm_start` (+ `warm_start_y/z_l/z_u` via
//! `initial_multipliers`), `nlp_{lower,upper}_bound_inf = -+1e19`. Everything else keeps ripopt's
//! defaults (its acceptable tolerance is fixed at 1e-6).
//!
//! **Stopping.** ripopt polls its clock only every tenth iteration after the tenth, and its l1 retry
//! starts a new clock, so `max_wall_time` alone let a solve run several iterations (seconds, with
//! the dense factorisation) past it. The seam installs ripopt's intermediate callback (per thread,
//! for the duration of the call) and stops the solve at the first iteration after the deadline or
//! after the cancel token was set ([`super::Stop`]).
//!
//! **Linear solver: dense.** ripopt is built without its default `feral` feature, because feral 0.5
//! (ripopt) and feral 0.22 (pounce) export the same `#[no_mangle]` C functions and any binary
//! linking both fails with duplicate symbols. Its remaining sparse path (faer 0.20 `SparseLdl`)
//! reports a constant block of zero pivots whatever the inertia shift (measured: `NumericalError`
//! at iteration 0 on the double integrator for every N >= 25), so the seam sets
//! `sparse_threshold = usize::MAX` and ripopt factors the KKT system densely (Bunch-Kaufman, exact
//! inertia). That is correct at any size but costs O((n + m)^3) per factorization: fine for the
//! cross-check problems (a few hundred unknowns), slow for a full-size transcription.

use std::cell::RefCell;
use std::os::raw::{c_double, c_int, c_void};
use std::panic::{catch_unwind, AssertUnwindSafe};

use ripopt::{NlpProblem, SolveStatus as RipStatus, SolverOptions};

use super::prepare::{panic_text, BackendOutcome, Evaluator, Prepared};
use super::problem::{MuStrategy, NlpSettings, SolveStatus};
use super::stop::Stop;

thread_local! {
    /// The stop rule of the ripopt solve running on this thread (ripopt calls its intermediate
    /// callback on the thread that called `ripopt::solve`).
    static STOP: RefCell<Option<Stop>> = const { RefCell::new(None) };
}

/// ripopt's intermediate callback: 1 to go on, 0 to stop (ripopt then ends with
/// `UserRequestedStop`, which [`Stop::verdict`] turns into the reason).
#[allow(clippy::too_many_arguments)]
extern "C" fn keep_going(
    _alg_mod: c_int,
    iter: c_int,
    _obj_value: c_double,
    _inf_pr: c_double,
    _inf_du: c_double,
    _mu: c_double,
    _d_norm: c_double,
    _regularization_size: c_double,
    _alpha_du: c_double,
    _alpha_pr: c_double,
    _ls_trials: c_int,
    _user_data: *mut c_void,
) -> c_int {
    let iter = usize::try_from(iter).unwrap_or(0);
    let stop = STOP.with(|s| {
        s.borrow().as_ref().is_some_and(|s| {
            s.at_iteration(iter);
            s.now()
        })
    });
    c_int::from(!stop)
}

/// Installs [`keep_going`] with `stop` for this thread; uninstalls both when dropped.
struct StopHook;

impl StopHook {
    fn install(stop: &Stop) -> StopHook {
        STOP.with(|s| *s.borrow_mut() = Some(stop.clone()));
        let cb = keep_going as ripopt::c_api::IntermediateCb;
        ripopt::intermediate::set_intermediate_callback(Some((cb, std::ptr::null_mut())));
        StopHook
    }
}

impl Drop for StopHook {
    fn drop(&mut self) {
        ripopt::intermediate::set_intermediate_callback(None);
        STOP.with(|s| *s.borrow_mut() = None);
    }
}

struct Adapter<'a> {
    prep: &'a Prepared,
    eval: RefCell<Evaluator<'a>>,
}

impl NlpProblem for Adapter<'_> {
    fn num_variables(&self) -> usize {
        self.prep.n
    }
    fn num_constraints(&self) -> usize {
        self.prep.m
    }
    fn bounds(&self, x_l: &mut [f64], x_u: &mut [f64]) {
        x_l.copy_from_slice(&self.prep.x_l);
        x_u.copy_from_slice(&self.prep.x_u);
    }
    fn constraint_bounds(&self, g_l: &mut [f64], g_u: &mut [f64]) {
        g_l.copy_from_slice(&self.prep.g_l);
        g_u.copy_from_slice(&self.prep.g_u);
    }
    fn initial_point(&self, x0: &mut [f64]) {
        x0.copy_from_slice(&self.prep.x0);
    }
    fn initial_multipliers(&self, lam_g: &mut [f64], z_l: &mut [f64], z_u: &mut [f64]) -> bool {
        match &self.prep.warm {
            Some(w) => {
                lam_g.copy_from_slice(&w.lambda);
                z_l.copy_from_slice(&w.z_l);
                z_u.copy_from_slice(&w.z_u);
                true
            }
            None => false,
        }
    }
    fn objective(&self, x: &[f64], _new_x: bool, obj: &mut f64) -> bool {
        match self.eval.borrow_mut().objective(x) {
            Some(f) => {
                *obj = f;
                true
            }
            None => false,
        }
    }
    fn gradient(&self, x: &[f64], _new_x: bool, grad: &mut [f64]) -> bool {
        self.eval.borrow_mut().gradient(x, grad)
    }
    fn constraints(&self, x: &[f64], _new_x: bool, g: &mut [f64]) -> bool {
        self.eval.borrow_mut().constraints(x, g)
    }
    fn jacobian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (self.prep.jac.rows.clone(), self.prep.jac.cols.clone())
    }
    fn jacobian_values(&self, x: &[f64], _new_x: bool, vals: &mut [f64]) -> bool {
        self.eval.borrow_mut().jacobian(x, vals)
    }
    fn hessian_structure(&self) -> (Vec<usize>, Vec<usize>) {
        (self.prep.hess.rows.clone(), self.prep.hess.cols.clone())
    }
    fn hessian_values(
        &self,
        x: &[f64],
        _new_x: bool,
        obj_factor: f64,
        lambda: &[f64],
        vals: &mut [f64],
    ) -> bool {
        self.eval.borrow_mut().hessian(x, obj_factor, lambda, vals)
    }
}

/// ripopt options for `settings`.
fn options(settings: &NlpSettings, prep: &Prepared) -> SolverOptions {
    let mut o = SolverOptions {
        print_level: settings.print_level,
        max_iter: settings.max_iter,
        tol: settings.tol,
        constr_viol_tol: settings.constr_viol_tol,
        acceptable_iter: settings.acceptable_iter,
        max_wall_time: settings.max_wall_time_s.unwrap_or(0.0),
        mu_strategy_adaptive: settings.mu_strategy == MuStrategy::Adaptive,
        nlp_lower_bound_inf: -1e19,
        nlp_upper_bound_inf: 1e19,
        // Dense LDL^T for every size: see the module docs (the faer sparse path is broken).
        sparse_threshold: usize::MAX,
        ..SolverOptions::default()
    };
    if let Some(mu) = settings.mu_init {
        o.mu_init = mu;
    }
    if let Some(w) = &prep.warm {
        o.warm_start = true;
        o.warm_start_y = Some(w.lambda.clone());
        o.warm_start_z_l = Some(w.z_l.clone());
        o.warm_start_z_u = Some(w.z_u.clone());
    }
    o
}

/// The largest KKT system (`n + m` unknowns) given to ripopt: its dense factorisation grows as
/// `(n + m)^3` (measured on the tracking swing: 331 unknowns 29 ms per iteration, 650 0.2 s, 1085 1.3 s,
/// 2170 30 s for the first iteration alone), and it checks its time limit only between iterations, so
/// larger problems are refused before any work rather than left to run for minutes.
pub const RIPOPT_MAX_UNKNOWNS: usize = 1200;

fn map_status(s: RipStatus) -> SolveStatus {
    match s {
        RipStatus::Optimal => SolveStatus::Solved,
        RipStatus::Acceptable => SolveStatus::SolvedToAcceptableLevel,
        RipStatus::Infeasible | RipStatus::LocalInfeasibility => SolveStatus::LocallyInfeasible,
        RipStatus::MaxIterations => SolveStatus::MaxIterations,
        RipStatus::MaxTimeExceeded => SolveStatus::MaxWallTime,
        RipStatus::NumericalError => SolveStatus::NumericalError,
        RipStatus::DivergingIterates => SolveStatus::Diverging,
        RipStatus::RestorationFailed => SolveStatus::RestorationFailed,
        RipStatus::EvaluationError => SolveStatus::EvaluationError(
            "a callback failed or returned a non-finite value at the current iterate".into(),
        ),
        RipStatus::StopAtTinyStep => SolveStatus::TinyStep,
        RipStatus::UserRequestedStop => SolveStatus::Other("user requested stop".into()),
        RipStatus::InternalError => SolveStatus::Other("ripopt internal error".into()),
    }
}

/// Run ripopt on the prepared problem. Panics (in ripopt or in the callbacks) become a status.
pub(crate) fn run(
    nlp: &mut dyn super::SparseNlp,
    prep: &Prepared,
    settings: &NlpSettings,
    stop: &Stop,
) -> BackendOutcome {
    if prep.n + prep.m > RIPOPT_MAX_UNKNOWNS {
        let status = SolveStatus::InvalidProblem(format!(
            "backend \"ripopt\" factors the KKT system densely and takes at most \
             {RIPOPT_MAX_UNKNOWNS} unknowns (variables + constraints); this problem has {} + {} = {} \
             (use backend \"ocp\" or \"pounce\", or coarser knots)",
            prep.n,
            prep.m,
            prep.n + prep.m
        ));
        let mut eval = Evaluator::new(nlp, prep);
        let passes = eval.passes("ripopt", "ripopt", 0, &status);
        return BackendOutcome {
            backend_status: "refused (size)".into(),
            ..BackendOutcome::panicked(status, passes)
        };
    }
    let opts = options(settings, prep);
    let adapter = Adapter {
        prep,
        eval: RefCell::new(Evaluator::new(nlp, prep)),
    };
    let result = {
        let _hook = StopHook::install(stop);
        catch_unwind(AssertUnwindSafe(|| ripopt::solve(&adapter, &opts)))
    };
    // ripopt runs one pass as far as an observer can tell (no per-iteration events here); a
    // fallback it used is named in the pass.
    let mut eval = adapter.eval.into_inner();
    match result {
        Ok(r) => {
            let status = map_status(r.status);
            let what = match &r.diagnostics.fallback_used {
                Some(f) => format!("ripopt (fallback: {f})"),
                None => "ripopt".to_string(),
            };
            let passes = eval.passes(&what, &what, r.iterations, &status);
            BackendOutcome {
                status,
                backend_status: format!("{:?}", r.status),
                x: Some(r.x),
                lambda: Some(r.constraint_multipliers),
                z_l: Some(r.bound_multipliers_lower),
                z_u: Some(r.bound_multipliers_upper),
                iterations: r.iterations,
                passes,
            }
        }
        Err(p) => {
            let status = SolveStatus::Other(format!("ripopt panicked: {}", panic_text(&*p)));
            let passes = eval.passes("ripopt", "ripopt", 0, &status);
            BackendOutcome::panicked(status, passes)
        }
    }
}
