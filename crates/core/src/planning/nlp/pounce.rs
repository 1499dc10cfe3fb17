//! The pounce-rs 0.14 backend of [`super::solve`] (IPOPT's algorithm, `IpoptApplication` +
//! `TNLP`).
//!
//! `IpoptApplication::optimize_tnlp` takes an `Rc<RefCell<dyn TNLP>>`, i.e. a `'static` problem,
//! while the seam lends the problem as `&mut dyn SparseNlp`. Without `unsafe`, the borrow is
//! bridged with a scoped thread: the solver runs on a helper thread with a `'static` proxy `TNLP`
//! that owns copies of the fixed data (sizes, bounds, start, merged sparsity) and forwards each
//! evaluation over a channel to the calling thread, which evaluates the real problem and sends the
//! values back. Buffers travel back and forth, so no allocation happens per call; the overhead is
//! two thread hand-offs per callback (microseconds, against milliseconds of Hessian work in the
//! collocation problem). The problem never leaves the calling thread, so it need not be `Send`.
//!
//! Options set: `print_level`, `max_iter`, `tol`, `constr_viol_tol`, `acceptable_tol`,
//! `acceptable_iter`, `max_wall_time`, `mu_strategy`, `mu_init` (when set), `warm_start_init_point`,
//! `sb = yes`.

use std::cell::RefCell;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::rc::Rc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{channel, Receiver, Sender};
use std::sync::Arc;

use pounce_rs::pounce_nlp::alg_types::SolverReturn;
use pounce_rs::{
    AlgorithmMode, ApplicationReturnStatus as Ars, BoundsInfo, Index, IndexStyle, IpoptApplication,
    IpoptCq, IpoptData, IterStats, NlpInfo, Solution, SparsityRequest, StartingPoint, TNLP,
};

use super::prepare::{panic_text, BackendOutcome, Evaluator, IterFingerprint, Prepared};
use super::problem::{MuStrategy, NlpSettings, SolveStatus, SparseNlp};
use super::stop::Stop;

/// Stack of the solver thread (pounce's recursion depth is modest; this is generous).
const SOLVER_STACK_BYTES: usize = 64 << 20;

#[derive(Debug, Clone, Copy)]
enum Kind {
    Objective,
    Gradient,
    Constraints,
    Jacobian,
    Hessian {
        obj_factor: f64,
    },
    /// Not an evaluation: the solver reports an iteration (counted by the calling thread's meter,
    /// which tells the passes apart).
    Iteration {
        iter: usize,
        restoration: bool,
        row: IterFingerprint,
    },
}

/// An evaluation request; the buffers come back in the [`Reply`].
struct Request {
    kind: Kind,
    x: Vec<f64>,
    lambda: Vec<f64>,
    out: Vec<f64>,
}

struct Reply {
    ok: bool,
    value: f64,
    x: Vec<f64>,
    lambda: Vec<f64>,
    out: Vec<f64>,
}

/// Final iterate as handed to `finalize_solution`.
#[derive(Default)]
struct Final {
    x: Vec<f64>,
    lambda: Vec<f64>,
    z_l: Vec<f64>,
    z_u: Vec<f64>,
    status: Option<SolverReturn>,
}

/// The `'static` TNLP living on the solver thread.
struct Proxy {
    prep: Prepared,
    tx: Sender<Request>,
    rx: Receiver<Reply>,
    /// Set by the calling thread when a callback panicked: stop as soon as possible.
    abort: Arc<AtomicBool>,
    /// The caller's cancel token and the wall-clock limit, checked at every iteration.
    stop: Stop,
    bufs: (Vec<f64>, Vec<f64>, Vec<f64>),
    fin: Final,
}

impl Proxy {
    /// Forward one evaluation; on success the result is in `self.bufs.2` (and the returned value).
    fn call(&mut self, kind: Kind, x: &[f64], lambda: &[f64], out_len: usize) -> Option<f64> {
        if self.abort.load(Ordering::Relaxed) {
            return None;
        }
        let (mut xb, mut lb, mut ob) = std::mem::take(&mut self.bufs);
        xb.clear();
        xb.extend_from_slice(x);
        lb.clear();
        lb.extend_from_slice(lambda);
        ob.clear();
        ob.resize(out_len, 0.0);
        self.tx
            .send(Request {
                kind,
                x: xb,
                lambda: lb,
                out: ob,
            })
            .ok()?;
        let r = self.rx.recv().ok()?;
        self.bufs = (r.x, r.lambda, r.out);
        r.ok.then_some(r.value)
    }

    fn call_into(&mut self, kind: Kind, x: &[f64], lambda: &[f64], out: &mut [f64]) -> bool {
        if self.call(kind, x, lambda, out.len()).is_none() || self.bufs.2.len() != out.len() {
            return false;
        }
        out.copy_from_slice(&self.bufs.2);
        true
    }
}

fn fill_structure(rows: &[usize], cols: &[usize], irow: &mut [Index], jcol: &mut [Index]) -> bool {
    if irow.len() != rows.len() || jcol.len() != cols.len() {
        return false;
    }
    // Sizes were checked to fit in i32 when the problem was prepared.
    for (d, &s) in irow.iter_mut().zip(rows) {
        *d = s as Index;
    }
    for (d, &s) in jcol.iter_mut().zip(cols) {
        *d = s as Index;
    }
    true
}

impl TNLP for Proxy {
    fn get_nlp_info(&mut self) -> Option<NlpInfo> {
        Some(NlpInfo {
            n: self.prep.n as Index,
            m: self.prep.m as Index,
            nnz_jac_g: self.prep.jac.nnz() as Index,
            nnz_h_lag: self.prep.hess.nnz() as Index,
            index_style: IndexStyle::C,
        })
    }

    fn get_bounds_info(&mut self, b: BoundsInfo<'_>) -> bool {
        let p = &self.prep;
        if b.x_l.len() != p.n || b.g_l.len() != p.m {
            return false;
        }
        b.x_l.copy_from_slice(&p.x_l);
        b.x_u.copy_from_slice(&p.x_u);
        b.g_l.copy_from_slice(&p.g_l);
        b.g_u.copy_from_slice(&p.g_u);
        true
    }

    fn get_starting_point(&mut self, sp: StartingPoint<'_>) -> bool {
        if sp.init_x {
            sp.x.copy_from_slice(&self.prep.x0);
        }
        if sp.init_z || sp.init_lambda {
            let Some(w) = &self.prep.warm else {
                return false;
            };
            if sp.init_z {
                sp.z_l.copy_from_slice(&w.z_l);
                sp.z_u.copy_from_slice(&w.z_u);
            }
            if sp.init_lambda {
                sp.lambda.copy_from_slice(&w.lambda);
            }
        }
        true
    }

    fn eval_f(&mut self, x: &[f64], _new_x: bool) -> Option<f64> {
        self.call(Kind::Objective, x, &[], 0)
    }

    fn eval_grad_f(&mut self, x: &[f64], _new_x: bool, grad_f: &mut [f64]) -> bool {
        self.call_into(Kind::Gradient, x, &[], grad_f)
    }

    fn eval_g(&mut self, x: &[f64], _new_x: bool, g: &mut [f64]) -> bool {
        self.call_into(Kind::Constraints, x, &[], g)
    }

    fn eval_jac_g(&mut self, x: Option<&[f64]>, _new_x: bool, mode: SparsityRequest<'_>) -> bool {
        match mode {
            SparsityRequest::Structure { irow, jcol } => {
                fill_structure(&self.prep.jac.rows, &self.prep.jac.cols, irow, jcol)
            }
            SparsityRequest::Values { values } => match x {
                Some(x) => self.call_into(Kind::Jacobian, x, &[], values),
                None => false,
            },
        }
    }

    fn eval_h(
        &mut self,
        x: Option<&[f64]>,
        _new_x: bool,
        obj_factor: f64,
        lambda: Option<&[f64]>,
        _new_lambda: bool,
        mode: SparsityRequest<'_>,
    ) -> bool {
        match mode {
            SparsityRequest::Structure { irow, jcol } => {
                fill_structure(&self.prep.hess.rows, &self.prep.hess.cols, irow, jcol)
            }
            SparsityRequest::Values { values } => {
                let zeros;
                let lambda = match lambda {
                    Some(l) => l,
                    None => {
                        zeros = vec![0.0; self.prep.m];
                        &zeros
                    }
                };
                match x {
                    Some(x) => self.call_into(Kind::Hessian { obj_factor }, x, lambda, values),
                    None => false,
                }
            }
        }
    }

    fn finalize_solution(&mut self, sol: Solution<'_>, _d: &IpoptData, _q: &IpoptCq) {
        self.fin = Final {
            x: sol.x.to_vec(),
            lambda: sol.lambda.to_vec(),
            z_l: sol.z_l.to_vec(),
            z_u: sol.z_u.to_vec(),
            status: Some(sol.status),
        };
    }

    fn wants_intermediate_callback(&self) -> bool {
        true
    }

    fn intermediate_callback(&mut self, s: IterStats, _d: &IpoptData, _q: &IpoptCq) -> bool {
        let iter = usize::try_from(s.iter).unwrap_or(0);
        self.stop.at_iteration(iter);
        let kind = Kind::Iteration {
            iter,
            restoration: s.mode == AlgorithmMode::RestorationPhaseMode,
            row: [
                u64::try_from(s.iter).unwrap_or(0),
                s.obj_value.to_bits(),
                s.inf_pr.to_bits(),
                s.inf_du.to_bits(),
                s.mu.to_bits(),
                s.alpha_pr.to_bits(),
            ],
        };
        self.call(kind, &[], &[], 0).is_some()
            && !self.abort.load(Ordering::Relaxed)
            && !self.stop.now()
    }
}

fn map_status(s: Ars) -> SolveStatus {
    match s {
        Ars::SolveSucceeded => SolveStatus::Solved,
        Ars::SolvedToAcceptableLevel => SolveStatus::SolvedToAcceptableLevel,
        Ars::InfeasibleProblemDetected => SolveStatus::LocallyInfeasible,
        Ars::SearchDirectionBecomesTooSmall => SolveStatus::TinyStep,
        Ars::DivergingIterates => SolveStatus::Diverging,
        Ars::MaximumIterationsExceeded => SolveStatus::MaxIterations,
        Ars::RestorationFailed => SolveStatus::RestorationFailed,
        Ars::ErrorInStepComputation => SolveStatus::NumericalError,
        Ars::MaximumCpuTimeExceeded | Ars::MaximumWallTimeExceeded => SolveStatus::MaxWallTime,
        Ars::NotEnoughDegreesOfFreedom => {
            SolveStatus::InvalidProblem("not enough degrees of freedom".into())
        }
        Ars::InvalidProblemDefinition => {
            SolveStatus::InvalidProblem("pounce: invalid problem definition".into())
        }
        Ars::InvalidOption => SolveStatus::InvalidSettings("pounce rejected an option".into()),
        Ars::InvalidNumberDetected => SolveStatus::EvaluationError(
            "a callback returned a non-finite value at the current iterate".into(),
        ),
        other => SolveStatus::Other(other.upstream_name().to_string()),
    }
}

/// Set the pounce options for `settings`; the error names the rejected option.
fn set_options(
    app: &mut IpoptApplication,
    settings: &NlpSettings,
    warm: bool,
) -> Result<(), String> {
    let o = app.options_mut();
    let int = |o: &mut pounce_rs::pounce_common::options_list::OptionsList, k: &str, v: usize| {
        o.set_integer_value(k, v as Index, true, true)
            .map(|_| ())
            .map_err(|e| format!("{k} = {v}: {}", e.message))
    };
    int(o, "print_level", usize::from(settings.print_level))?;
    int(o, "max_iter", settings.max_iter)?;
    int(o, "acceptable_iter", settings.acceptable_iter)?;
    let mut num = |k: &str, v: f64| {
        o.set_numeric_value(k, v, true, true)
            .map(|_| ())
            .map_err(|e| format!("{k} = {v}: {}", e.message))
    };
    num("tol", settings.tol)?;
    num("constr_viol_tol", settings.constr_viol_tol)?;
    num("acceptable_tol", settings.acceptable_tol)?;
    if let Some(t) = settings.max_wall_time_s {
        num("max_wall_time", t)?;
    }
    if let Some(mu) = settings.mu_init {
        num("mu_init", mu)?;
    }
    let mut string = |k: &str, v: &str| {
        o.set_string_value(k, v, true, true)
            .map(|_| ())
            .map_err(|e| format!("{k} = {v}: {}", e.message))
    };
    string("sb", "yes")?;
    string(
        "mu_strategy",
        match settings.mu_strategy {
            MuStrategy::Monotone => "monotone",
            MuStrategy::Adaptive => "adaptive",
        },
    )?;
    if warm {
        string("warm_start_init_point", "yes")?;
    }
    Ok(())
}

/// What the solver thread reports.
struct ThreadResult {
    status: SolveStatus,
    backend_status: String,
    fin: Final,
    iterations: usize,
}

fn solver_thread(
    prep: Prepared,
    settings: NlpSettings,
    tx: Sender<Request>,
    rx: Receiver<Reply>,
    abort: Arc<AtomicBool>,
    stop: Stop,
) -> ThreadResult {
    let mut app = IpoptApplication::new();
    if let Err(e) = app.initialize() {
        return ThreadResult {
            status: SolveStatus::Other(format!("pounce initialisation failed: {}", e.message)),
            backend_status: "initialize".into(),
            fin: Final::default(),
            iterations: 0,
        };
    }
    let warm = prep.warm.is_some();
    if let Err(e) = set_options(&mut app, &settings, warm) {
        return ThreadResult {
            status: SolveStatus::InvalidSettings(format!("pounce rejected option {e}")),
            backend_status: "Invalid_Option".into(),
            fin: Final::default(),
            iterations: 0,
        };
    }
    let proxy = Rc::new(RefCell::new(Proxy {
        prep,
        tx,
        rx,
        abort: abort.clone(),
        stop,
        bufs: Default::default(),
        fin: Final::default(),
    }));
    let status = app.optimize_tnlp(proxy.clone() as Rc<RefCell<dyn TNLP>>);
    let iterations = usize::try_from(app.statistics().iteration_count).unwrap_or(0);
    drop(app);
    let fin = std::mem::take(&mut proxy.borrow_mut().fin);
    let mapped = if abort.load(Ordering::Relaxed) {
        SolveStatus::EvaluationError("a callback panicked; the solve was stopped".into())
    } else {
        map_status(status)
    };
    ThreadResult {
        status: mapped,
        backend_status: status.upstream_name().to_string(),
        fin,
        iterations,
    }
}

/// Serve evaluation requests on the calling thread until the solver thread hangs up. A panic in a
/// callback sets `abort`, is recorded and ends the service (the solver then sees failed calls).
fn serve(
    eval: &mut Evaluator<'_>,
    rx: Receiver<Request>,
    tx: Sender<Reply>,
    abort: &AtomicBool,
) -> Option<String> {
    for mut req in rx {
        let res = catch_unwind(AssertUnwindSafe(|| match req.kind {
            Kind::Objective => match eval.objective(&req.x) {
                Some(f) => (true, f),
                None => (false, f64::NAN),
            },
            Kind::Gradient => (eval.gradient(&req.x, &mut req.out), 0.0),
            Kind::Constraints => (eval.constraints(&req.x, &mut req.out), 0.0),
            Kind::Jacobian => (eval.jacobian(&req.x, &mut req.out), 0.0),
            Kind::Hessian { obj_factor } => (
                eval.hessian(&req.x, obj_factor, &req.lambda, &mut req.out),
                0.0,
            ),
            Kind::Iteration {
                iter,
                restoration,
                row,
            } => {
                eval.meter.iteration(iter, restoration, row);
                (true, 0.0)
            }
        }));
        match res {
            Ok((ok, value)) => {
                let reply = Reply {
                    ok,
                    value,
                    x: req.x,
                    lambda: req.lambda,
                    out: req.out,
                };
                if tx.send(reply).is_err() {
                    return None;
                }
            }
            Err(p) => {
                abort.store(true, Ordering::Relaxed);
                return Some(panic_text(&*p));
            }
        }
    }
    None
}

/// Run pounce on the prepared problem (see the module docs for the thread bridge).
pub(crate) fn run(
    nlp: &mut dyn SparseNlp,
    prep: &Prepared,
    settings: &NlpSettings,
    stop: &Stop,
) -> BackendOutcome {
    let (req_tx, req_rx) = channel::<Request>();
    let (rep_tx, rep_rx) = channel::<Reply>();
    let abort = Arc::new(AtomicBool::new(false));
    let mut eval = Evaluator::new(nlp, prep);
    let (thread_prep, thread_settings, thread_abort, thread_stop) =
        (prep.clone(), settings.clone(), abort.clone(), stop.clone());
    let joined = std::thread::scope(|s| {
        let handle = std::thread::Builder::new()
            .name("brachia-pounce".into())
            .stack_size(SOLVER_STACK_BYTES)
            .spawn_scoped(s, move || {
                solver_thread(
                    thread_prep,
                    thread_settings,
                    req_tx,
                    rep_rx,
                    thread_abort,
                    thread_stop,
                )
            });
        let handle = match handle {
            Ok(h) => h,
            Err(e) => return Err(format!("could not start the solver thread: {e}")),
        };
        let callback_panic = serve(&mut eval, req_rx, rep_tx, &abort);
        // Dropping the channel ends (done by `serve`) unblocks the solver thread if it still waits.
        match handle.join() {
            Ok(r) => Ok((r, callback_panic)),
            Err(p) => Err(format!("pounce panicked: {}", panic_text(&*p))),
        }
    });
    match joined {
        Ok((r, callback_panic)) => {
            let status = match callback_panic {
                Some(msg) => SolveStatus::EvaluationError(format!("a callback panicked: {msg}")),
                None => r.status,
            };
            let finalized = r.fin.status.is_some();
            let some = |v: Vec<f64>| finalized.then_some(v);
            let passes = eval.passes("pounce", "pounce re-solve", r.iterations, &status);
            BackendOutcome {
                status,
                backend_status: r.backend_status,
                x: some(r.fin.x),
                lambda: some(r.fin.lambda),
                z_l: some(r.fin.z_l),
                z_u: some(r.fin.z_u),
                iterations: passes.iter().map(|p| p.iterations).sum(),
                passes,
            }
        }
        Err(msg) => {
            let status = SolveStatus::Other(msg);
            let passes = eval.passes("pounce", "pounce re-solve", 0, &status);
            BackendOutcome::panicked(status, passes)
        }
    }
}
