//! The interior-point iteration: initialisation, condensing, inertia correction, filter line search,
//! barrier update, termination and restoration. See the crate docs and docs/ocp.md.

use crate::dense::gemv_t_acc;
use crate::problem::{
    EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageBounds, StageEval, TerminalEval,
};
use crate::riccati::{Layout, Riccati};
use crate::settings::{
    MuStrategy, OcpError, OcpSettings, OcpStats, OcpStatus, OcpTimings, WarmDuals,
    MAX_EQUALITY_ROWS, MAX_STAGE_VARIABLES,
};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

// IPOPT's constants (Waechter & Biegler 2006, Table 1 and the implementation's defaults).
const KAPPA_EPS: f64 = 10.0;
const KAPPA_MU: f64 = 0.2;
const THETA_MU: f64 = 1.5;
const TAU_MIN: f64 = 0.99;
const KAPPA_SIGMA: f64 = 1e10;
const GAMMA_THETA: f64 = 1e-5;
const GAMMA_PHI: f64 = 1e-5;
const DELTA_SW: f64 = 1.0;
const GAMMA_ALPHA: f64 = 0.05;
const S_THETA: f64 = 1.1;
const S_PHI: f64 = 2.3;
const ETA_PHI: f64 = 1e-4;
const S_MAX: f64 = 100.0;
const DW_0: f64 = 1e-4;
const DW_MIN: f64 = 1e-20;
const DW_MAX: f64 = 1e40;
const KW_MINUS: f64 = 1.0 / 3.0;
const KW_PLUS: f64 = 8.0;
const KW_PLUS_BAR: f64 = 100.0;
const BOUND_MULT_RESET: f64 = 1e3;
const KAPPA_SOC: f64 = 0.99;
// Penalty on the equality rows tried before delta_w (section 5 of docs/ocp.md): first value, growth
// factor, largest value.
const RHO_EQ_0: f64 = 1.0;
const RHO_EQ_PLUS: f64 = 100.0;
const RHO_EQ_MAX: f64 = 1e8;
// Adaptive mu (IPOPT's defaults for its free mode)
const KKT_REF_ITERS: usize = 4;
const KKT_REF_FACTOR: f64 = 0.9999;
const MONOTONE_INIT_FACTOR: f64 = 0.8;
const MU_MAX_FACTOR: f64 = 1e3;
const SIGMA_MAX: f64 = 100.0;
/// Penalty on the l1 relaxation slacks p, n in the restoration phase (IPOPT's `resto_penalty_parameter`).
const RHO_RESTO: f64 = 1e3;
// Centrality correctors (Gondzio 1996): the trial step's increase delta, the band
// [beta_min mu, beta_max mu] of the complementarity products, and the fraction gamma of delta by
// which the step to the boundary must grow for a corrector to be kept (docs/ocp.md, "Session 14").
const CC_DELTA: f64 = 0.1;
const CC_BETA_MIN: f64 = 0.1;
const CC_BETA_MAX: f64 = 10.0;
const CC_GAMMA: f64 = 0.1;

/// Role of one entry of z.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// Decision variable (possibly bounded).
    Free,
    /// `lo == hi` in x_0 or in an input: removed from the Newton step.
    Eliminated,
    /// `lo == hi` in a state after stage 0: an equality row of the Schur complement.
    FixedRow,
}

/// Where one evaluation ended.
enum EvalFail {
    Failed(String),
}

/// A stage-structured primal-dual interior-point solver (see the crate docs).
///
/// All memory is allocated by [`OcpSolver::new`] (the filter grows once up to `max_iter` entries,
/// and the Schur responses to the number of equality rows, on the first solve); later solves of a problem with the same dimensions do not allocate unless they
/// fail (status strings).
pub struct OcpSolver {
    dims: OcpDims,
    lay: Layout,
    ric: Riccati,
    bounds: Vec<StageBounds>,
    zlo: Vec<f64>,
    zhi: Vec<f64>,
    clo: Vec<f64>,
    chi: Vec<f64>,
    kind: Vec<Kind>,
    reg: Vec<bool>,
    ev: Vec<StageEval>,
    term: TerminalEval,
    ev_t: Vec<StageEval>,
    term_t: TerminalEval,
    zp: Primal,
    zp_t: Primal,
    mult: Multipliers,
    has_iterate: bool,
    // iterate
    z: Vec<f64>,
    s: Vec<f64>,
    lam: Vec<f64>,
    y: Vec<f64>,
    nu: Vec<f64>,
    eta: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    vl: Vec<f64>,
    vu: Vec<f64>,
    // trial
    z_t: Vec<f64>,
    s_t: Vec<f64>,
    /// The Newton step of the current iteration.
    step: Step,
    // KKT data
    g: Vec<f64>,
    /// The part of the condensed gradient that depends neither on the row residuals nor on mu.
    g_base: Vec<f64>,
    /// The barrier part of the condensed gradient per unit of mu (`-1/(z - lo) + 1/(hi - z)`), so
    /// that one factorisation serves right-hand sides for several mu (adaptive mu).
    g_bar: Vec<f64>,
    bdef: Vec<f64>,
    /// Fixed-state rows (k >= 1): (stage, component).
    fixed_rows: Vec<(usize, usize)>,
    rz: Vec<f64>,
    filter: Vec<(f64, f64)>,
    filter_orig: Vec<(f64, f64)>,
    z_ref: Vec<f64>,
    dr: Vec<f64>,
    /// Scratch of [`OcpSolver::remap_bound_duals`] (nz).
    remap: Vec<f64>,
    delta_w_last: f64,
    /// Number of fixed-state rows the multipliers `eta` belong to (those of the solve that left
    /// them, or of a [`WarmState`] put back).
    eta_rows: usize,
    /// Penalty `rho_eq a_j a_j^T` on the equality rows in the condensed Hessians of the current
    /// factorisation (0 = none), and the one that last passed the inertia test in this solve.
    rho_eq: f64,
    rho_eq_last: f64,
    /// Constraint rows (dynamics, stage rows c - s, terminal, fixed states) at the iterate and trial.
    cv: Vec<f64>,
    cv_t: Vec<f64>,
    /// Restoration slacks: row = p - n relaxation, duals, steps, trial values.
    rp: Vec<f64>,
    rn: Vec<f64>,
    rzp: Vec<f64>,
    rzn: Vec<f64>,
    drp: Vec<f64>,
    drn: Vec<f64>,
    drzp: Vec<f64>,
    drzn: Vec<f64>,
    rp_t: Vec<f64>,
    rn_t: Vec<f64>,
    /// Per row: the (relaxed) residual c^ and the regularisation D of the Newton step.
    chat: Vec<f64>,
    dreg: Vec<f64>,
    /// Complementarity target per bound of a step with centrality correctors, in the order
    /// `[z lower (nz), z upper (nz), s lower (nc), s upper (nc)]` (the role mu plays in a plain step),
    /// and its value before the last corrector (to undo one that is not kept).
    ctarget: Vec<f64>,
    ctarget_prev: Vec<f64>,
    /// The step before the last corrector (to undo one that is not kept).
    step_saved: Step,
}

/// A Newton step: the primal and slack steps, the equality multipliers as new values, and the
/// bound-dual steps. The solver holds two: the step of the current iteration and a copy of it taken
/// before a centrality corrector, to undo one that is not kept.
struct Step {
    /// Primal step (nz).
    dz: Vec<f64>,
    /// Slack step of the stage rows (nc).
    ds: Vec<f64>,
    /// New dynamics multipliers (nl).
    lam_n: Vec<f64>,
    /// New stage-row multipliers (nc).
    y_n: Vec<f64>,
    /// New multipliers of the terminal rows, then of the fixed-state rows
    /// ([`MAX_EQUALITY_ROWS`]; the first `n_terminal + fixed rows` are used).
    eqm_n: Vec<f64>,
    /// Steps of the duals of the lower and upper bounds of z (nz).
    dzl: Vec<f64>,
    dzu: Vec<f64>,
    /// Steps of the duals of the lower and upper bounds of the slacks (nc).
    dvl: Vec<f64>,
    dvu: Vec<f64>,
}

impl Step {
    /// A zero step for `nz` variables, `nl` dynamics rows and `nc` stage rows.
    fn zeros(nz: usize, nl: usize, nc: usize) -> Self {
        Step {
            dz: vec![0.0; nz],
            ds: vec![0.0; nc],
            lam_n: vec![0.0; nl],
            y_n: vec![0.0; nc],
            eqm_n: vec![0.0; MAX_EQUALITY_ROWS],
            dzl: vec![0.0; nz],
            dzu: vec![0.0; nz],
            dvl: vec![0.0; nc],
            dvu: vec![0.0; nc],
        }
    }

    /// Copies `other` into `self` without allocating (both have the same dimensions).
    fn copy_from(&mut self, other: &Step) {
        self.dz.copy_from_slice(&other.dz);
        self.ds.copy_from_slice(&other.ds);
        self.lam_n.copy_from_slice(&other.lam_n);
        self.y_n.copy_from_slice(&other.y_n);
        self.eqm_n.copy_from_slice(&other.eqm_n);
        self.dzl.copy_from_slice(&other.dzl);
        self.dzu.copy_from_slice(&other.dzu);
        self.dvl.copy_from_slice(&other.dvl);
        self.dvu.copy_from_slice(&other.dvu);
    }
}

/// What a warm start takes from the last solve besides its primal ([`OcpSolver::primal`]): the
/// slacks of the stage inequalities, every multiplier (bound duals of the variables and of the
/// slacks, dynamics, stage-row, terminal and fixed-state multipliers) and the equality-row
/// penalty that last passed the inertia test. Read with [`OcpSolver::warm_state`] and put back
/// with [`OcpSolver::set_warm_state`], so that a warm solve from a saved solution starts from the
/// same numbers whatever was solved in between (e.g. a re-planner's checkpoint). Opaque: its
/// layout is the solver's.
#[derive(Debug, Clone, PartialEq)]
pub struct WarmState {
    s: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    vl: Vec<f64>,
    vu: Vec<f64>,
    eta: Vec<f64>,
    eta_rows: usize,
    mult: Multipliers,
    rho_eq_last: f64,
    has_iterate: bool,
}

/// How the complementarity rows of a right-hand side read ([`OcpSolver::solve_rhs`]): the
/// barrier parameter for every bound, or the per-bound targets of the centrality correctors.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Centring {
    Mu(f64),
    Targets,
}

/// State of the restoration phase.
#[derive(Debug, Clone, Copy)]
struct Resto {
    theta0: f64,
    mu_orig: f64,
    zeta: f64,
    iters: usize,
    theta_max_orig: f64,
}

/// The line-search reference values of one iteration.
#[derive(Debug, Clone, Copy)]
struct LineSearch {
    theta0: f64,
    phi0: f64,
    gphi: f64,
    theta_min: f64,
    theta_max: f64,
}

impl LineSearch {
    /// IPOPT's acceptance test of a trial point (theta `tt`, barrier function `phit`) for step
    /// length `alpha`: `Some(h_type)` if accepted (h-type iterations augment the filter).
    fn accepts(&self, filter: &[(f64, f64)], tt: f64, phit: f64, alpha: f64) -> Option<bool> {
        if !(tt < self.theta_max && OcpSolver::filter_acceptable(filter, tt, phit)) {
            return None;
        }
        let switching = self.gphi < 0.0
            && alpha * (-self.gphi).powf(S_PHI) > DELTA_SW * self.theta0.powf(S_THETA);
        if self.theta0 <= self.theta_min && switching {
            (phit <= self.phi0 + ETA_PHI * alpha * self.gphi).then_some(false)
        } else {
            (tt <= (1.0 - GAMMA_THETA) * self.theta0 || phit <= self.phi0 - GAMMA_PHI * self.theta0)
                .then_some(true)
        }
    }
}

/// Residuals of the optimality conditions at the current iterate.
#[derive(Debug, Clone, Copy, Default)]
struct Residuals {
    dual_inf: f64,
    theta_inf: f64,
    theta_1: f64,
    compl_0: f64,
    s_d: f64,
    s_c: f64,
}

impl Residuals {
    fn e0(&self) -> f64 {
        (self.dual_inf / self.s_d)
            .max(self.theta_inf)
            .max(self.compl_0 / self.s_c)
    }
}

fn phase_grad_of(
    ev: &[StageEval],
    z: &[f64],
    z_ref: &[f64],
    dr: &[f64],
    i: usize,
    k: usize,
    li: usize,
    resto: Option<&Resto>,
) -> f64 {
    match resto {
        None => ev[k].grad[li],
        Some(r) => r.zeta * dr[i] * dr[i] * (z[i] - z_ref[i]),
    }
}

/// Split a stage's dynamics Jacobian `jac_f` (`nx1 x (nx + nu)`, row-major) into `a` (`nx1 x nx`)
/// and `b` (`nx1 x nu`), the columns of eliminated variables (`kind`, `nx + nu` entries) zero. A
/// stage without eliminated variables (the usual case) is copied row by row, without a test per
/// entry.
fn split_dynamics_jacobian(
    jac_f: &[f64],
    kind: &[Kind],
    nx1: usize,
    nx: usize,
    nu: usize,
    a: &mut [f64],
    b: &mut [f64],
) {
    let nz = nx + nu;
    let any_eliminated = kind[..nz].contains(&Kind::Eliminated);
    for r in 0..nx1 {
        let row = &jac_f[r * nz..(r + 1) * nz];
        let (ar, br) = (&mut a[r * nx..(r + 1) * nx], &mut b[r * nu..(r + 1) * nu]);
        if !any_eliminated {
            ar.copy_from_slice(&row[..nx]);
            br.copy_from_slice(&row[nx..]);
            continue;
        }
        for c in 0..nx {
            ar[c] = if kind[c] == Kind::Eliminated {
                0.0
            } else {
                row[c]
            };
        }
        for c in 0..nu {
            br[c] = if kind[nx + c] == Kind::Eliminated {
                0.0
            } else {
                row[nx + c]
            };
        }
    }
}

fn finite(v: &[f64]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn panic_message(e: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = e.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = e.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".to_string()
    }
}

fn call_evaluate(
    p: &mut dyn OcpProblem,
    z: &Primal,
    level: EvalLevel,
    ev: &mut [StageEval],
    term: &mut TerminalEval,
) -> Result<(), EvalFail> {
    let r = catch_unwind(AssertUnwindSafe(|| p.evaluate(z, level, ev, term)));
    match r {
        Err(e) => {
            return Err(EvalFail::Failed(format!(
                "evaluate panicked: {}",
                panic_message(&*e)
            )))
        }
        Ok(Err(e)) => return Err(EvalFail::Failed(e.to_string())),
        Ok(Ok(())) => {}
    }
    for (k, e) in ev.iter().enumerate() {
        let ok = e.cost.is_finite()
            && finite(&e.f)
            && finite(&e.c)
            && (level == EvalLevel::Values
                || (finite(&e.grad) && finite(&e.jac_f) && finite(&e.jac_c)));
        if !ok {
            return Err(EvalFail::Failed(format!("non-finite value at stage {k}")));
        }
    }
    if !finite(&term.r) || (level == EvalLevel::FirstOrder && !finite(&term.jac_r)) {
        return Err(EvalFail::Failed("non-finite terminal value".to_string()));
    }
    Ok(())
}

impl OcpSolver {
    /// Checks `dims` and allocates the whole workspace.
    ///
    /// Limits: at least 2 stages, `nx_k >= 1`, `nx_k + nu_k <= `[`MAX_STAGE_VARIABLES`],
    /// `n_terminal <= min(nx_K, `[`MAX_EQUALITY_ROWS`]`)`. At solve time the terminal rows plus the
    /// fixed state components after stage 0 must not exceed [`MAX_EQUALITY_ROWS`].
    pub fn new(dims: &OcpDims) -> Result<Self, OcpError> {
        let n = dims.stages.len();
        if n < 2 {
            return Err(OcpError::TooFewStages { stages: n });
        }
        for (k, d) in dims.stages.iter().enumerate() {
            if d.nx == 0 {
                return Err(OcpError::EmptyState { stage: k });
            }
            if d.nz() > MAX_STAGE_VARIABLES {
                return Err(OcpError::StageTooLarge {
                    stage: k,
                    nz: d.nz(),
                    limit: MAX_STAGE_VARIABLES,
                });
            }
        }
        let nx_last = dims.stages[n - 1].nx;
        if dims.n_terminal > nx_last || dims.n_terminal > MAX_EQUALITY_ROWS {
            return Err(OcpError::TooManyTerminalRows {
                n_terminal: dims.n_terminal,
                nx_last,
                limit: MAX_EQUALITY_ROWS,
            });
        }
        let lay = Layout::new(
            dims.stages.iter().map(|d| d.nx).collect(),
            dims.stages.iter().map(|d| d.nu).collect(),
            dims.stages.iter().map(|d| d.nc).collect(),
        );
        let ric = Riccati::new(&lay);
        let (nz, nl, nc) = (lay.n_z(), lay.n_l(), lay.n_c());
        let nr = dims.n_terminal;
        let evs: Vec<StageEval> = (0..n)
            .map(|k| StageEval::zeros(dims.stages[k], lay.nx1[k]))
            .collect();
        Ok(OcpSolver {
            bounds: dims
                .stages
                .iter()
                .map(|d| StageBounds::unbounded(*d))
                .collect(),
            zlo: vec![0.0; nz],
            zhi: vec![0.0; nz],
            clo: vec![0.0; nc],
            chi: vec![0.0; nc],
            kind: vec![Kind::Free; nz],
            reg: vec![true; nz],
            ev_t: evs.clone(),
            ev: evs,
            term: TerminalEval::zeros(nr, nx_last),
            term_t: TerminalEval::zeros(nr, nx_last),
            zp: Primal::zeros(dims),
            zp_t: Primal::zeros(dims),
            mult: Multipliers::zeros(dims),
            has_iterate: false,
            z: vec![0.0; nz],
            s: vec![0.0; nc],
            lam: vec![0.0; nl],
            y: vec![0.0; nc],
            nu: vec![0.0; nr],
            eta: vec![0.0; MAX_EQUALITY_ROWS],
            zl: vec![0.0; nz],
            zu: vec![0.0; nz],
            vl: vec![0.0; nc],
            vu: vec![0.0; nc],
            z_t: vec![0.0; nz],
            s_t: vec![0.0; nc],
            step: Step::zeros(nz, nl, nc),
            g: vec![0.0; nz],
            g_base: vec![0.0; nz],
            g_bar: vec![0.0; nz],
            bdef: vec![0.0; nl],
            fixed_rows: Vec::with_capacity(MAX_EQUALITY_ROWS),
            rz: vec![0.0; nz],
            filter: Vec::new(),
            filter_orig: Vec::new(),
            z_ref: vec![0.0; nz],
            dr: vec![0.0; nz],
            remap: vec![0.0; nz],
            delta_w_last: 0.0,
            eta_rows: 0,
            rho_eq: 0.0,
            rho_eq_last: 0.0,
            cv: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            cv_t: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            rp: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            rn: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            rzp: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            rzn: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            drp: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            drn: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            drzp: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            drzn: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            rp_t: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            rn_t: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            chat: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            dreg: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            ctarget: vec![0.0; 2 * (nz + nc)],
            ctarget_prev: vec![0.0; 2 * (nz + nc)],
            step_saved: Step::zeros(nz, nl, nc),
            dims: dims.clone(),
            lay,
            ric,
        })
    }

    /// The stored iterate (the last solve's result; edit it through [`OcpSolver::primal_mut`] before
    /// a warm solve).
    pub fn primal(&self) -> &Primal {
        &self.zp
    }

    /// Mutable access to the stored iterate, e.g. to shift a solution in time before a warm solve.
    pub fn primal_mut(&mut self) -> &mut Primal {
        &mut self.zp
    }

    /// Multipliers of the stored iterate (see [`crate::problem`] for the signs).
    pub fn multipliers(&self) -> &Multipliers {
        &self.mult
    }

    /// The bound duals of stage k stored by the last solve, `(lower, upper)`, `nx_k + nu_k` each
    /// (states, then inputs; 0 for an infinite bound and for fixed components). They start a warm
    /// solve with [`WarmDuals::Stored`] or [`WarmDuals::StoredBounds`]. Panics if `k > K`.
    pub fn bound_duals(&self, k: usize) -> (&[f64], &[f64]) {
        let r = self.lay.oz[k]..self.lay.oz[k + 1];
        (&self.zl[r.clone()], &self.zu[r])
    }

    /// Re-indexes the bound duals stored by the last solve ([`OcpSolver::bound_duals`]) for a warm
    /// start whose stage k is the last solve's stage `src(k)`: e.g. a solution shifted in time,
    /// whose primal is shifted through [`OcpSolver::primal_mut`], so that the duals of the bounds
    /// the solution rests on move with it. The states of stage k take those of stage `src(k)` if
    /// both have the same `nx`, the inputs likewise with `nu`; otherwise, and for `src(k) > K`,
    /// stage k keeps its own. The slacks of the stage inequalities, their duals and the
    /// multipliers stay where they are (docs/ocp.md, "Session 12": moving them as well was
    /// measured slower on the robot's warm re-plans). No allocation.
    pub fn remap_bound_duals(&mut self, src: impl Fn(usize) -> usize) {
        let lay = &self.lay;
        let parts = |k: usize| {
            let o = lay.oz[k];
            [(o, lay.nx[k]), (o + lay.nx[k], lay.nu[k])]
        };
        for v in [&mut self.zl, &mut self.zu] {
            self.remap.copy_from_slice(v);
            for k in 0..=lay.kk {
                let j = src(k);
                if j > lay.kk {
                    continue;
                }
                for ((od, nd), (os, ns)) in parts(k).into_iter().zip(parts(j)) {
                    if nd == ns {
                        v[od..od + nd].copy_from_slice(&self.remap[os..os + ns]);
                    }
                }
            }
        }
    }

    /// A copy of the stored state besides the primal ([`WarmState`]; allocates).
    pub fn warm_state(&self) -> WarmState {
        WarmState {
            s: self.s.clone(),
            zl: self.zl.clone(),
            zu: self.zu.clone(),
            vl: self.vl.clone(),
            vu: self.vu.clone(),
            eta: self.eta.clone(),
            eta_rows: self.eta_rows,
            mult: self.mult.clone(),
            rho_eq_last: self.rho_eq_last,
            has_iterate: self.has_iterate,
        }
    }

    /// [`OcpSolver::warm_state`] for the same problem with state component `i` removed from every
    /// stage: a parameter carried as a constant state (e.g. a free final time) once it is fixed.
    /// The component's bound duals and the dynamics multipliers of its rows are dropped; the
    /// slacks, the stage-row and terminal multipliers and the equality-row penalty are kept. So a
    /// solver of the reduced problem, given this state and the primal without the component, starts
    /// at the same point. Allocates. Errors if some stage has no component `i`, if the reduced stage
    /// would have no state, or if the component is an equality row (`lo == hi` after stage 0) in the
    /// last solve (its rows would remain in the Schur complement).
    pub fn warm_state_without_state(&self, i: usize) -> Result<WarmState, OcpError> {
        let lay = &self.lay;
        for k in 0..=lay.kk {
            if i >= lay.nx[k] || lay.nx[k] == 1 {
                return Err(OcpError::StateComponent {
                    component: i,
                    stage: k,
                    reason: "not a state component of this stage, or its only one",
                });
            }
            if self.kind[lay.oz[k] + i] == Kind::FixedRow {
                return Err(OcpError::StateComponent {
                    component: i,
                    stage: k,
                    reason: "fixed (an equality row of the last solve)",
                });
            }
        }
        let drop_z = |v: &[f64]| -> Vec<f64> {
            (0..=lay.kk)
                .flat_map(|k| {
                    let blk = &v[lay.oz[k]..lay.oz[k + 1]];
                    blk.iter()
                        .enumerate()
                        .filter(|&(j, _)| j != i)
                        .map(|(_, &x)| x)
                })
                .collect()
        };
        let mut mult = self.mult.clone();
        for lam in mult.lam.iter_mut().filter(|l| l.len() > i) {
            lam.remove(i);
        }
        Ok(WarmState {
            s: self.s.clone(),
            zl: drop_z(&self.zl),
            zu: drop_z(&self.zu),
            vl: self.vl.clone(),
            vu: self.vu.clone(),
            eta: self.eta.clone(),
            eta_rows: self.eta_rows,
            mult,
            rho_eq_last: self.rho_eq_last,
            has_iterate: self.has_iterate,
        })
    }

    /// Puts back a state read by [`OcpSolver::warm_state`] of a solver of the same dimensions
    /// (the primal goes back through [`OcpSolver::primal_mut`]). No allocation. Errors (and
    /// changes nothing) if the sizes differ.
    pub fn set_warm_state(&mut self, w: &WarmState) -> Result<(), OcpError> {
        let shape = |m: &Multipliers| {
            m.lam
                .iter()
                .map(Vec::len)
                .eq(self.mult.lam.iter().map(Vec::len))
                && m.mu
                    .iter()
                    .map(Vec::len)
                    .eq(self.mult.mu.iter().map(Vec::len))
                && m.nu.len() == self.mult.nu.len()
        };
        let same = [
            (&self.s, &w.s),
            (&self.zl, &w.zl),
            (&self.zu, &w.zu),
            (&self.vl, &w.vl),
            (&self.vu, &w.vu),
            (&self.eta, &w.eta),
        ]
        .iter()
        .all(|(a, b)| a.len() == b.len())
            && shape(&w.mult);
        if !same {
            return Err(OcpError::WarmStateMismatch {
                state_variables: w.zl.len(),
                state_slacks: w.s.len(),
                solver_variables: self.zl.len(),
                solver_slacks: self.s.len(),
            });
        }
        for (d, s) in [
            (&mut self.s, &w.s),
            (&mut self.zl, &w.zl),
            (&mut self.zu, &w.zu),
            (&mut self.vl, &w.vl),
            (&mut self.vu, &w.vu),
            (&mut self.eta, &w.eta),
        ] {
            d.copy_from_slice(s);
        }
        self.mult.copy_from(&w.mult);
        self.eta_rows = w.eta_rows;
        self.rho_eq_last = w.rho_eq_last;
        self.has_iterate = w.has_iterate;
        Ok(())
    }

    /// The feedback gain `K_k` (`nu_k x nx_k`, row-major) of the last Riccati factorisation: the
    /// Newton step's inputs are `du_k = K_k dx_k + k_k` (docs/ocp.md section 3). After a converged
    /// solve it is the gain of the last iteration's Newton step, near the solution: the condensed
    /// barrier terms hold inputs and states at active bounds, and the equality-row penalty steers
    /// towards the terminal rows. Columns of fixed components of `x_0` and rows of fixed inputs are
    /// zero; all zero before the first factorisation. Panics if `k > K`.
    pub fn feedback_gain(&self, k: usize) -> &[f64] {
        &self.ric.kgain[self.lay.ok[k]..self.lay.ok[k + 1]]
    }

    /// Benchmark hook (not part of the API): recomputes the Newton step at the stored iterate of the
    /// last solve with barrier `mu` (condensing, Riccati factorisation with inertia correction,
    /// Schur complement, solves, step recovery). Returns false if there is no iterate or it failed.
    #[doc(hidden)]
    pub fn bench_newton_step(&mut self, mu: f64) -> bool {
        if !self.has_iterate {
            return false;
        }
        let mut stats = OcpStats {
            status: OcpStatus::Solved,
            iterations: 0,
            objective: 0.0,
            primal_infeasibility: 0.0,
            dual_infeasibility: 0.0,
            final_mu: mu,
            regularizations: 0,
            factorizations: 0,
            centrality_correctors: 0,
            time: OcpTimings::default(),
        };
        self.theta_current();
        self.direction(mu, None, &mut stats).is_ok()
    }

    /// Solves `p` (see the crate docs). Never panics: a panicking callback ends in
    /// [`OcpStatus::EvaluationError`], an internal failure in [`OcpStatus::NumericalError`].
    pub fn solve(&mut self, p: &mut dyn OcpProblem, s: &OcpSettings) -> OcpStats {
        let t0 = Instant::now();
        let mut stats = OcpStats {
            status: OcpStatus::MaxIterations,
            iterations: 0,
            objective: f64::NAN,
            primal_infeasibility: f64::NAN,
            dual_infeasibility: f64::NAN,
            final_mu: s.mu_init,
            regularizations: 0,
            factorizations: 0,
            centrality_correctors: 0,
            time: OcpTimings::default(),
        };
        if let Err(e) = s.validate() {
            stats.status = OcpStatus::InvalidSettings(e.to_string());
            stats.time.total_s = t0.elapsed().as_secs_f64();
            return stats;
        }
        let r = catch_unwind(AssertUnwindSafe(|| self.run(p, s, &mut stats, t0)));
        match r {
            Ok(status) => stats.status = status,
            Err(e) => {
                stats.status =
                    OcpStatus::NumericalError(format!("internal panic: {}", panic_message(&*e)))
            }
        }
        stats.time.total_s = t0.elapsed().as_secs_f64();
        stats
    }

    fn scatter_primal(z: &[f64], lay: &Layout, zp: &mut Primal) {
        for k in 0..=lay.kk {
            let o = lay.oz[k];
            let nx = lay.nx[k];
            zp.x[k].copy_from_slice(&z[o..o + nx]);
            zp.u[k].copy_from_slice(&z[o + nx..lay.oz[k + 1]]);
        }
    }

    fn gather_primal(&mut self) {
        for k in 0..=self.lay.kk {
            let o = self.lay.oz[k];
            let nx = self.lay.nx[k];
            self.z[o..o + nx].copy_from_slice(&self.zp.x[k]);
            self.z[o + nx..self.lay.oz[k + 1]].copy_from_slice(&self.zp.u[k]);
        }
    }

    fn store_multipliers(&mut self) {
        let lay = &self.lay;
        for k in 0..=lay.kk {
            self.mult.lam[k].copy_from_slice(&self.lam[lay.ol[k]..lay.ol[k + 1]]);
            self.mult.mu[k].copy_from_slice(&self.y[lay.oc[k]..lay.oc[k + 1]]);
        }
        self.mult.nu.copy_from_slice(&self.nu);
    }

    /// Reads and checks the bounds; classifies the entries of z.
    fn read_bounds(&mut self, p: &mut dyn OcpProblem) -> Result<(), String> {
        self.fixed_rows.clear();
        for k in 0..=self.lay.kk {
            let b = &mut self.bounds[k];
            for v in [&mut b.x_lo, &mut b.u_lo, &mut b.c_lo] {
                v.fill(f64::NEG_INFINITY);
            }
            for v in [&mut b.x_hi, &mut b.u_hi, &mut b.c_hi] {
                v.fill(f64::INFINITY);
            }
            let r = catch_unwind(AssertUnwindSafe(|| p.bounds(k, b)));
            if let Err(e) = r {
                return Err(format!("bounds({k}) panicked: {}", panic_message(&*e)));
            }
            let d = self.dims.stages[k];
            if b.x_lo.len() != d.nx
                || b.x_hi.len() != d.nx
                || b.u_lo.len() != d.nu
                || b.u_hi.len() != d.nu
                || b.c_lo.len() != d.nc
                || b.c_hi.len() != d.nc
            {
                return Err(format!("bounds({k}) resized its buffers"));
            }
            let o = self.lay.oz[k];
            for i in 0..d.nz() {
                let (lo, hi) = if i < d.nx {
                    (b.x_lo[i], b.x_hi[i])
                } else {
                    (b.u_lo[i - d.nx], b.u_hi[i - d.nx])
                };
                if lo.is_nan()
                    || hi.is_nan()
                    || lo > hi
                    || lo == f64::INFINITY
                    || hi == f64::NEG_INFINITY
                {
                    return Err(format!("stage {k}, variable {i}: bounds [{lo}, {hi}]"));
                }
                self.zlo[o + i] = lo;
                self.zhi[o + i] = hi;
                self.kind[o + i] = if lo < hi {
                    Kind::Free
                } else if k == 0 || i >= d.nx {
                    Kind::Eliminated
                } else {
                    if self.fixed_rows.len() + self.dims.n_terminal >= MAX_EQUALITY_ROWS {
                        return Err(format!(
                            "more than {MAX_EQUALITY_ROWS} equality rows (terminal rows plus fixed states after stage 0)"
                        ));
                    }
                    self.fixed_rows.push((k, i));
                    Kind::FixedRow
                };
                self.reg[o + i] = self.kind[o + i] != Kind::Eliminated;
            }
            let oc = self.lay.oc[k];
            for j in 0..d.nc {
                let (lo, hi) = (b.c_lo[j], b.c_hi[j]);
                if lo.is_nan()
                    || hi.is_nan()
                    || lo >= hi
                    || lo == f64::INFINITY
                    || hi == f64::NEG_INFINITY
                {
                    return Err(format!(
                        "stage {k}, inequality row {j}: bounds [{lo}, {hi}] (c_lo < c_hi required)"
                    ));
                }
                self.clo[oc + j] = lo;
                self.chi[oc + j] = hi;
            }
        }
        Ok(())
    }

    fn push_inside(lo: f64, hi: f64, v: f64, push: f64) -> f64 {
        let mut v = v;
        if !v.is_finite() {
            v = 0.0;
        }
        let width = hi - lo;
        if lo.is_finite() {
            let pl = (push * lo.abs().max(1.0)).min(if width.is_finite() {
                push * width
            } else {
                f64::INFINITY
            });
            v = v.max(lo + pl);
        }
        if hi.is_finite() {
            let pu = (push * hi.abs().max(1.0)).min(if width.is_finite() {
                push * width
            } else {
                f64::INFINITY
            });
            v = v.min(hi - pu);
        }
        v
    }

    fn evaluate(
        &mut self,
        p: &mut dyn OcpProblem,
        trial: bool,
        level: EvalLevel,
        stats: &mut OcpStats,
    ) -> Result<(), EvalFail> {
        let t = Instant::now();
        let r = if trial {
            Self::scatter_primal(&self.z_t, &self.lay, &mut self.zp_t);
            call_evaluate(p, &self.zp_t, level, &mut self.ev_t, &mut self.term_t)
        } else {
            Self::scatter_primal(&self.z, &self.lay, &mut self.zp);
            call_evaluate(p, &self.zp, level, &mut self.ev, &mut self.term)
        };
        stats.time.evaluation_s += t.elapsed().as_secs_f64();
        r
    }

    /// Number of constraint rows: dynamics, stage rows, terminal rows, fixed states.
    fn nrows(&self) -> usize {
        self.lay.n_l() + self.lay.n_c() + self.dims.n_terminal + self.fixed_rows.len()
    }

    /// Constraint rows at (z, s) with evaluations `ev`, `term` into `out`.
    fn row_values(
        &self,
        z: &[f64],
        s: &[f64],
        ev: &[StageEval],
        term: &TerminalEval,
        out: &mut [f64],
    ) {
        let lay = &self.lay;
        for k in 0..lay.kk {
            let o1 = lay.oz[k + 1];
            for i in 0..lay.nx1[k] {
                out[lay.ol[k] + i] = ev[k].f[i] - z[o1 + i];
            }
        }
        let nl = lay.n_l();
        for k in 0..=lay.kk {
            let oc = lay.oc[k];
            for j in 0..lay.nc[k] {
                out[nl + oc + j] = ev[k].c[j] - s[oc + j];
            }
        }
        let base = nl + lay.n_c();
        out[base..base + term.r.len()].copy_from_slice(&term.r);
        let base = base + term.r.len();
        for (j, &(k, i)) in self.fixed_rows.iter().enumerate() {
            let o = lay.oz[k] + i;
            out[base + j] = z[o] - self.zlo[o];
        }
    }

    /// (l1, inf) norms of the rows `cv` (relaxed by the restoration slacks if given).
    fn theta_of(&self, cv: &[f64], pn: Option<(&[f64], &[f64])>) -> (f64, f64) {
        let (mut t1, mut ti) = (0.0_f64, 0.0_f64);
        for i in 0..self.nrows() {
            let v = match pn {
                Some((p, n)) => cv[i] - p[i] + n[i],
                None => cv[i],
            };
            t1 += v.abs();
            ti = ti.max(v.abs());
        }
        (t1, ti)
    }

    /// Original constraint violation (l1, inf) at the iterate (refreshes `cv`).
    fn theta_current(&mut self) -> (f64, f64) {
        let mut cv = std::mem::take(&mut self.cv);
        self.row_values(&self.z, &self.s, &self.ev, &self.term, &mut cv);
        let r = self.theta_of(&cv, None);
        self.cv = cv;
        r
    }

    /// Barrier sum -sum ln(slack) over all bounded entries at (z, s).
    fn barrier(&self, z: &[f64], s: &[f64], pn: Option<(&[f64], &[f64])>) -> f64 {
        let mut b = 0.0;
        if let Some((p, n)) = pn {
            for i in 0..self.nrows() {
                b -= p[i].ln() + n[i].ln();
            }
        }
        for i in 0..z.len() {
            if self.kind[i] == Kind::Free {
                if self.zlo[i].is_finite() {
                    b -= (z[i] - self.zlo[i]).ln();
                }
                if self.zhi[i].is_finite() {
                    b -= (self.zhi[i] - z[i]).ln();
                }
            }
        }
        for j in 0..s.len() {
            if self.clo[j].is_finite() {
                b -= (s[j] - self.clo[j]).ln();
            }
            if self.chi[j].is_finite() {
                b -= (self.chi[j] - s[j]).ln();
            }
        }
        b
    }

    fn cost(ev: &[StageEval]) -> f64 {
        ev.iter().map(|e| e.cost).sum()
    }

    /// Objective of the current phase at z (cost or the restoration proximity term).
    fn phase_objective(
        &self,
        z: &[f64],
        ev: &[StageEval],
        resto: Option<&Resto>,
        pn: (&[f64], &[f64]),
    ) -> f64 {
        match resto {
            None => Self::cost(ev),
            Some(r) => {
                let mut v = 0.0;
                for i in 0..z.len() {
                    let d = self.dr[i] * (z[i] - self.z_ref[i]);
                    v += d * d;
                }
                let mut l1 = 0.0;
                for i in 0..self.nrows() {
                    l1 += pn.0[i] + pn.1[i];
                }
                0.5 * r.zeta * v + RHO_RESTO * l1
            }
        }
    }

    /// Gradient of the phase objective at the current z, entry i (stage k, local index li).
    fn phase_grad(&self, i: usize, k: usize, li: usize, resto: Option<&Resto>) -> f64 {
        phase_grad_of(&self.ev, &self.z, &self.z_ref, &self.dr, i, k, li, resto)
    }

    /// Dual infeasibility, constraint violation and complementarity at the current iterate.
    fn residuals(&mut self, resto: Option<&Resto>) -> Residuals {
        let lay = &self.lay;
        let mut rz = std::mem::take(&mut self.rz);
        for k in 0..=lay.kk {
            let (o, nz, nx1, nc) = (lay.oz[k], lay.nz(k), lay.nx1[k], lay.nc[k]);
            let r = &mut rz[o..o + nz];
            for li in 0..nz {
                r[li] = self.phase_grad(o + li, k, li, resto) - self.zl[o + li] + self.zu[o + li];
            }
            let e = &self.ev[k];
            if k < lay.kk {
                gemv_t_acc(&e.jac_f, &self.lam[lay.ol[k]..lay.ol[k + 1]], r, nx1, nz);
            }
            if k > 0 {
                for i in 0..lay.nx[k] {
                    r[i] -= self.lam[lay.ol[k - 1] + i];
                }
            }
            gemv_t_acc(&e.jac_c, &self.y[lay.oc[k]..lay.oc[k] + nc], r, nc, nz);
            if k == lay.kk {
                gemv_t_acc(
                    &self.term.jac_r,
                    &self.nu,
                    &mut r[..lay.nx[k]],
                    self.dims.n_terminal,
                    lay.nx[k],
                );
            }
        }
        for (j, &(k, i)) in self.fixed_rows.iter().enumerate() {
            rz[lay.oz[k] + i] += self.eta[j];
        }
        let mut res = Residuals::default();
        for i in 0..rz.len() {
            if self.kind[i] != Kind::Eliminated {
                res.dual_inf = res.dual_inf.max(rz[i].abs());
            }
        }
        for j in 0..self.s.len() {
            res.dual_inf = res
                .dual_inf
                .max((-self.y[j] - self.vl[j] + self.vu[j]).abs());
        }
        self.rz = rz;
        let (mut t1, mut ti) = self.theta_current();
        if resto.is_some() {
            (t1, ti) = self.theta_of(&self.cv, Some((&self.rp, &self.rn)));
            let nl = self.lay.n_l();
            let nc = self.lay.n_c();
            for i in 0..self.nrows() {
                let l = self.row_multiplier(i, nl, nc);
                res.dual_inf = res
                    .dual_inf
                    .max((RHO_RESTO - l - self.rzp[i]).abs())
                    .max((RHO_RESTO + l - self.rzn[i]).abs());
            }
        }
        res.theta_1 = t1;
        res.theta_inf = ti;
        // complementarity and scaling
        let (mut bsum, mut nb) = (0.0, 0usize);
        let mut comp = 0.0_f64;
        for i in 0..self.z.len() {
            if self.kind[i] != Kind::Free {
                continue;
            }
            if self.zlo[i].is_finite() {
                comp = comp.max(((self.z[i] - self.zlo[i]) * self.zl[i]).abs());
                bsum += self.zl[i];
                nb += 1;
            }
            if self.zhi[i].is_finite() {
                comp = comp.max(((self.zhi[i] - self.z[i]) * self.zu[i]).abs());
                bsum += self.zu[i];
                nb += 1;
            }
        }
        for j in 0..self.s.len() {
            if self.clo[j].is_finite() {
                comp = comp.max(((self.s[j] - self.clo[j]) * self.vl[j]).abs());
                bsum += self.vl[j];
                nb += 1;
            }
            if self.chi[j].is_finite() {
                comp = comp.max(((self.chi[j] - self.s[j]) * self.vu[j]).abs());
                bsum += self.vu[j];
                nb += 1;
            }
        }
        if resto.is_some() {
            for i in 0..self.nrows() {
                comp = comp
                    .max((self.rp[i] * self.rzp[i]).abs())
                    .max((self.rn[i] * self.rzn[i]).abs());
                bsum += self.rzp[i] + self.rzn[i];
                nb += 2;
            }
        }
        let esum: f64 = self
            .lam
            .iter()
            .chain(&self.y)
            .chain(&self.nu)
            .map(|v| v.abs())
            .sum::<f64>()
            + self.eta[..self.fixed_rows.len()]
                .iter()
                .map(|v| v.abs())
                .sum::<f64>();
        let ne = self.lam.len() + self.y.len() + self.nu.len() + self.fixed_rows.len();
        res.compl_0 = comp;
        res.s_d = if ne + nb > 0 {
            ((esum + bsum) / (ne + nb) as f64).max(S_MAX) / S_MAX
        } else {
            1.0
        };
        res.s_c = if nb > 0 {
            (bsum / nb as f64).max(S_MAX) / S_MAX
        } else {
            1.0
        };
        res
    }

    /// Multiplier of constraint row i (current iterate).
    fn row_multiplier(&self, i: usize, nl: usize, nc: usize) -> f64 {
        if i < nl {
            self.lam[i]
        } else if i < nl + nc {
            self.y[i - nl]
        } else {
            let j = i - nl - nc;
            let nr = self.dims.n_terminal;
            if j < nr {
                self.nu[j]
            } else {
                self.eta[j - nr]
            }
        }
    }

    /// Barrier error E_mu: complementarity measured against mu.
    fn e_mu(&self, res: &Residuals, mu: f64, resto: bool) -> f64 {
        let mut comp = 0.0_f64;
        if resto {
            for i in 0..self.nrows() {
                comp = comp
                    .max((self.rp[i] * self.rzp[i] - mu).abs())
                    .max((self.rn[i] * self.rzn[i] - mu).abs());
            }
        }
        for i in 0..self.z.len() {
            if self.kind[i] != Kind::Free {
                continue;
            }
            if self.zlo[i].is_finite() {
                comp = comp.max(((self.z[i] - self.zlo[i]) * self.zl[i] - mu).abs());
            }
            if self.zhi[i].is_finite() {
                comp = comp.max(((self.zhi[i] - self.z[i]) * self.zu[i] - mu).abs());
            }
        }
        for j in 0..self.s.len() {
            if self.clo[j].is_finite() {
                comp = comp.max(((self.s[j] - self.clo[j]) * self.vl[j] - mu).abs());
            }
            if self.chi[j].is_finite() {
                comp = comp.max(((self.chi[j] - self.s[j]) * self.vu[j] - mu).abs());
            }
        }
        (res.dual_inf / res.s_d)
            .max(res.theta_inf)
            .max(comp / res.s_c)
    }

    /// Builds the condensed KKT data, factors it with inertia correction and solves for the step.
    fn direction(
        &mut self,
        mu: f64,
        resto: Option<&Resto>,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        self.prepare_rows(mu, resto);
        self.build_and_factor(resto, stats)?;
        self.solve_rhs(Centring::Mu(mu), resto, stats)
    }

    /// The Newton step of the adaptive strategy's free mode: factorise once, take the affine
    /// step (mu = 0), set `mu = sigma mu_avg` with `sigma = (mu_aff / mu_avg)^3` from the
    /// complementarity the affine step reaches (Mehrotra's probing), then the step for that mu.
    fn probing_direction(
        &mut self,
        mu: &mut f64,
        mu_min: f64,
        mu_max: &mut f64,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        self.prepare_rows(0.0, None);
        self.build_and_factor(None, stats)?;
        let (sum, nb) = self.complementarity(0.0, 0.0);
        if nb > 0 {
            let avg = sum / nb as f64;
            if mu_max.is_nan() {
                *mu_max = MU_MAX_FACTOR * avg.max(*mu);
            }
            self.solve_rhs(Centring::Mu(0.0), None, stats)?;
            let (ap, ad) = self.max_step(1.0, false);
            let (sum_aff, _) = self.complementarity(ap, ad);
            let sigma = (sum_aff / sum).max(0.0).powi(3).min(SIGMA_MAX);
            *mu = (sigma * avg).min(*mu_max).max(mu_min);
        } else {
            *mu = mu_min;
        }
        self.filter.clear();
        self.solve_rhs(Centring::Mu(*mu), None, stats)
    }

    /// Gondzio's multiple centrality correctors (Gondzio 1996) on the step just computed (outside
    /// the restoration phase): while the largest step to the boundary `alpha_p` (primal) or
    /// `alpha_d` (dual) is below 1, take the trial point `alpha_p + delta`, `alpha_d + delta` along the step,
    /// move each bound's complementarity product there into `[beta_min mu, beta_max mu]` (products
    /// below the band, negative ones of bounds the step passes included, are raised to its floor; those
    /// above it are lowered by at most `beta_max mu`), add the difference to that bound's target
    /// (`ctarget`, mu for every bound at first) and re-solve with the same factorisation. The bound
    /// duals follow from the same targets ([`Self::solve_rhs`]), so they stay consistent with the
    /// primal step. A corrector is kept if the shorter of the two steps to the boundary grows by at
    /// least `gamma delta`; otherwise the step before it is restored and the correctors stop.
    /// Returns the centring of the step kept.
    fn centrality_correctors(
        &mut self,
        mu: f64,
        tau: f64,
        max: usize,
        stats: &mut OcpStats,
    ) -> Result<Centring, String> {
        let (mut ap, mut ad) = self.max_step(tau, false);
        let mut centring = Centring::Mu(mu);
        if ap >= 1.0 && ad >= 1.0 {
            return Ok(centring);
        }
        let nz = self.z.len();
        let nc = self.s.len();
        let os = 2 * nz;
        self.ctarget.fill(mu);
        let (lo, hi) = (CC_BETA_MIN * mu, CC_BETA_MAX * mu);
        let correction = |slack: f64, dual: f64| {
            let v = if slack > 0.0 && dual > 0.0 {
                slack * dual
            } else {
                (slack * dual).min(0.0)
            };
            if v < lo {
                lo - v
            } else if v > hi {
                (hi - v).max(-hi)
            } else {
                0.0
            }
        };
        for _ in 0..max {
            let (tp, td) = ((ap + CC_DELTA).min(1.0), (ad + CC_DELTA).min(1.0));
            self.ctarget_prev.copy_from_slice(&self.ctarget);
            self.step_saved.copy_from(&self.step);
            for i in 0..nz {
                if self.kind[i] != Kind::Free {
                    continue;
                }
                let z = self.z[i] + tp * self.step.dz[i];
                if self.zlo[i].is_finite() {
                    self.ctarget[i] +=
                        correction(z - self.zlo[i], self.zl[i] + td * self.step.dzl[i]);
                }
                if self.zhi[i].is_finite() {
                    self.ctarget[nz + i] +=
                        correction(self.zhi[i] - z, self.zu[i] + td * self.step.dzu[i]);
                }
            }
            for j in 0..nc {
                let v = self.s[j] + tp * self.step.ds[j];
                if self.clo[j].is_finite() {
                    self.ctarget[os + j] +=
                        correction(v - self.clo[j], self.vl[j] + td * self.step.dvl[j]);
                }
                if self.chi[j].is_finite() {
                    self.ctarget[os + nc + j] +=
                        correction(self.chi[j] - v, self.vu[j] + td * self.step.dvu[j]);
                }
            }
            self.solve_rhs(Centring::Targets, None, stats)?;
            let (np, nd) = self.max_step(tau, false);
            if np.min(nd) >= ap.min(ad) + CC_GAMMA * CC_DELTA {
                ap = np;
                ad = nd;
                centring = Centring::Targets;
                stats.centrality_correctors += 1;
                if ap >= 1.0 && ad >= 1.0 {
                    break;
                }
            } else {
                self.step.copy_from(&self.step_saved);
                self.ctarget.copy_from_slice(&self.ctarget_prev);
                break;
            }
        }
        Ok(centring)
    }

    /// Sum of the complementarity products (slack times bound dual) over all bounds of z and s
    /// at the iterate moved by `ap` times the primal and `ad` times the dual step, and their number.
    fn complementarity(&self, ap: f64, ad: f64) -> (f64, usize) {
        let (mut sum, mut nb) = (0.0, 0usize);
        for i in 0..self.z.len() {
            if self.kind[i] != Kind::Free {
                continue;
            }
            let z = self.z[i] + ap * self.step.dz[i];
            if self.zlo[i].is_finite() {
                sum += (z - self.zlo[i]) * (self.zl[i] + ad * self.step.dzl[i]);
                nb += 1;
            }
            if self.zhi[i].is_finite() {
                sum += (self.zhi[i] - z) * (self.zu[i] + ad * self.step.dzu[i]);
                nb += 1;
            }
        }
        for j in 0..self.s.len() {
            let v = self.s[j] + ap * self.step.ds[j];
            if self.clo[j].is_finite() {
                sum += (v - self.clo[j]) * (self.vl[j] + ad * self.step.dvl[j]);
                nb += 1;
            }
            if self.chi[j].is_finite() {
                sum += (self.chi[j] - v) * (self.vu[j] + ad * self.step.dvu[j]);
                nb += 1;
            }
        }
        (sum, nb)
    }

    /// Per row: the residual of the Newton system `c^` and its regularisation `D` (restoration: the
    /// condensed slacks p, n; otherwise `c^ = c`, `D = 0`).
    fn prepare_rows(&mut self, mu: f64, resto: Option<&Resto>) {
        // per row: relaxed residual and regularisation (restoration: the condensed slacks p, n)
        let nrows = self.nrows();
        for i in 0..nrows {
            if resto.is_some() {
                let (p, n) = (self.rp[i], self.rn[i]);
                let (sp, sn) = (self.rzp[i] / p, self.rzn[i] / n);
                self.dreg[i] = 1.0 / sp + 1.0 / sn;
                self.chat[i] =
                    self.cv[i] - p + n + (RHO_RESTO - mu / p) / sp - (RHO_RESTO - mu / n) / sn;
            } else {
                self.dreg[i] = 0.0;
                self.chat[i] = self.cv[i];
            }
        }
    }

    /// Condensed stage Hessians, dynamics Jacobians and equality rows; factorisation with inertia
    /// correction.
    fn build_and_factor(
        &mut self,
        resto: Option<&Resto>,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        let t = Instant::now();
        let lay = &self.lay;
        let kk = lay.kk;
        let (nl, ncall) = (lay.n_l(), lay.n_c());
        self.ric.soft = resto.is_some();
        self.ric.dsoft.copy_from_slice(&self.dreg[..nl]);
        for k in 0..=kk {
            let (o, nx, nz, nx1, nc) = (lay.oz[k], lay.nx[k], lay.nz(k), lay.nx1[k], lay.nc[k]);
            let e = &self.ev[k];
            let h = &mut self.ric.h[lay.oh[k]..lay.oh[k + 1]];
            h.copy_from_slice(&e.hess);
            for li in 0..nz {
                let i = o + li;
                let gi = phase_grad_of(&self.ev, &self.z, &self.z_ref, &self.dr, i, k, li, resto);
                if let Some(r) = resto {
                    h[li * nz + li] += r.zeta * self.dr[i] * self.dr[i];
                }
                let mut gb = 0.0;
                if self.kind[i] == Kind::Free {
                    if self.zlo[i].is_finite() {
                        let sl = self.z[i] - self.zlo[i];
                        h[li * nz + li] += self.zl[i] / sl;
                        gb -= 1.0 / sl;
                    }
                    if self.zhi[i].is_finite() {
                        let su = self.zhi[i] - self.z[i];
                        h[li * nz + li] += self.zu[i] / su;
                        gb += 1.0 / su;
                    }
                }
                self.g_base[i] = gi;
                self.g_bar[i] = gb;
            }
            let oc = lay.oc[k];
            for j in 0..nc {
                let jj = oc + j;
                let mut sig = 0.0;
                if self.clo[jj].is_finite() {
                    sig += self.vl[jj] / (self.s[jj] - self.clo[jj]);
                }
                if self.chi[jj].is_finite() {
                    sig += self.vu[jj] / (self.chi[jj] - self.s[jj]);
                }
                sig /= 1.0 + sig * self.dreg[nl + jj];
                let row = &e.jac_c[j * nz..(j + 1) * nz];
                for a in 0..nz {
                    if row[a] == 0.0 {
                        continue;
                    }
                    let ra = row[a] * sig;
                    for b in 0..nz {
                        h[a * nz + b] += ra * row[b];
                    }
                }
            }
            for li in 0..nz {
                if self.kind[o + li] == Kind::Eliminated {
                    for b in 0..nz {
                        h[li * nz + b] = 0.0;
                        h[b * nz + li] = 0.0;
                    }
                    h[li * nz + li] = 1.0;
                    self.g_base[o + li] = 0.0;
                    self.g_bar[o + li] = 0.0;
                }
            }
            if k < kk {
                let a = &mut self.ric.a[lay.oa[k]..lay.oa[k + 1]];
                let b = &mut self.ric.b[lay.ob[k]..lay.ob[k + 1]];
                let nu = lay.nu[k];
                split_dynamics_jacobian(&e.jac_f, &self.kind[o..o + nz], nx1, nx, nu, a, b);
            }
        }
        // equality rows: terminal rows, then fixed states
        let nr = self.dims.n_terminal;
        let nxm = lay.nx_max;
        let nxk = lay.nx[kk];
        for j in 0..nr {
            self.ric.eq_stage[j] = kk;
            self.ric.eq_a[j * nxm..j * nxm + nxk]
                .copy_from_slice(&self.term.jac_r[j * nxk..(j + 1) * nxk]);
            self.ric.eq_reg[j] = self.dreg[nl + ncall + j];
        }
        for (jf, &(k, i)) in self.fixed_rows.iter().enumerate() {
            let j = nr + jf;
            self.ric.eq_stage[j] = k;
            self.ric.eq_a[j * nxm..(j + 1) * nxm].fill(0.0);
            self.ric.eq_a[j * nxm + i] = 1.0;
            self.ric.eq_reg[j] = self.dreg[nl + ncall + j];
        }
        self.ric.m = nr + self.fixed_rows.len();
        // inertia correction (IPOPT Algorithm IC), first by a penalty on the equality rows (exact:
        // the same step and the same inertia, see docs/ocp.md section 5), then by delta_w
        self.rho_eq = 0.0;
        let use_penalty = resto.is_none() && self.ric.m > 0;
        if use_penalty && self.rho_eq_last > 0.0 {
            self.add_eq_penalty(self.rho_eq_last);
        }
        let lay = &self.lay;
        let mut ok = self.ric.factor_with_inertia(lay, 0.0, &self.reg);
        stats.factorizations += 1;
        if !ok && use_penalty {
            let mut rho = if self.rho_eq_last == 0.0 {
                RHO_EQ_0
            } else {
                RHO_EQ_PLUS * self.rho_eq_last
            };
            while !ok && rho <= RHO_EQ_MAX {
                self.add_eq_penalty(rho - self.rho_eq);
                ok = self.ric.factor_with_inertia(&self.lay, 0.0, &self.reg);
                stats.factorizations += 1;
                if ok {
                    self.rho_eq_last = rho;
                } else {
                    rho *= RHO_EQ_PLUS;
                }
            }
        }
        let lay = &self.lay;
        if !ok {
            let mut delta_w = if self.delta_w_last == 0.0 {
                DW_0
            } else {
                (KW_MINUS * self.delta_w_last).max(DW_MIN)
            };
            loop {
                ok = self.ric.factor_with_inertia(lay, delta_w, &self.reg);
                stats.factorizations += 1;
                if ok {
                    break;
                }
                delta_w *= if self.delta_w_last == 0.0 {
                    KW_PLUS_BAR
                } else {
                    KW_PLUS
                };
                if delta_w > DW_MAX {
                    break;
                }
            }
            if ok {
                self.delta_w_last = delta_w;
                stats.regularizations += 1;
            }
        }
        if !ok {
            stats.time.linear_algebra_s += t.elapsed().as_secs_f64();
            return Err("the Hessian could not be regularised (delta_w > 1e40)".to_string());
        }
        stats.time.linear_algebra_s += t.elapsed().as_secs_f64();
        Ok(())
    }

    /// Adds `d a_j a_j^T` to the state block of the condensed Hessian of stage `k_j` for every
    /// equality row j (terminal rows, fixed states), and `d` to `rho_eq`. With the gradient term
    /// `rho_eq a_j c^_j` of [`Self::solve_rhs`] this changes neither the Newton step nor the
    /// multipliers nor the inertia of the KKT matrix (the rows hold exactly), but it makes the
    /// Riccati recursion's test (`R^_k` positive definite) pass where the Hessian is convex only
    /// on the null space of the rows, e.g. `nu^T r''(x_K)` of a nonlinear terminal constraint.
    fn add_eq_penalty(&mut self, d: f64) {
        let lay = &self.lay;
        let nxm = lay.nx_max;
        for j in 0..self.ric.m {
            let k = self.ric.eq_stage[j];
            let (nx, nz) = (lay.nx[k], lay.nz(k));
            let h = &mut self.ric.h[lay.oh[k]..lay.oh[k + 1]];
            let a = &self.ric.eq_a[j * nxm..j * nxm + nx];
            for r in 0..nx {
                if a[r] == 0.0 {
                    continue;
                }
                let da = d * a[r];
                for c in 0..nx {
                    h[r * nz + c] += da * a[c];
                }
            }
        }
        self.rho_eq += d;
    }

    /// Right-hand side from the row residuals `c^`, the solves, and the recovery of the slack,
    /// multiplier and bound-dual steps (after [`Self::build_and_factor`]). The complementarity rows
    /// aim at `centring`: mu for every bound, or the per-bound targets `ctarget` (centrality
    /// correctors; not in the restoration phase, whose own rows read mu).
    fn solve_rhs(
        &mut self,
        centring: Centring,
        resto: Option<&Resto>,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        let t = Instant::now();
        let lay = &self.lay;
        let kk = lay.kk;
        let (nl, ncall) = (lay.n_l(), lay.n_c());
        let nrows = self.nrows();
        let nz = self.z.len();
        let os = 2 * nz;
        let mu = match centring {
            Centring::Mu(mu) => {
                for ((g, gb), gm) in self.g.iter_mut().zip(&self.g_base).zip(&self.g_bar) {
                    *g = gb + mu * gm;
                }
                mu
            }
            Centring::Targets => {
                debug_assert!(resto.is_none());
                for i in 0..nz {
                    let mut gi = self.g_base[i];
                    if self.kind[i] == Kind::Free {
                        if self.zlo[i].is_finite() {
                            gi -= self.ctarget[i] / (self.z[i] - self.zlo[i]);
                        }
                        if self.zhi[i].is_finite() {
                            gi += self.ctarget[nz + i] / (self.zhi[i] - self.z[i]);
                        }
                    }
                    self.g[i] = gi;
                }
                f64::NAN
            }
        };
        let per_bound = centring == Centring::Targets;
        let nc_all = self.s.len();
        // the targets of the lower and upper bound of slack jj
        let s_targets = |ct: &[f64], jj: usize| {
            if per_bound {
                (ct[os + jj], ct[os + nc_all + jj])
            } else {
                (mu, mu)
            }
        };
        for k in 0..=kk {
            let (o, nz, oc) = (lay.oz[k], lay.nz(k), lay.oc[k]);
            let e = &self.ev[k];
            for j in 0..lay.nc[k] {
                let jj = oc + j;
                let (tl, tu) = s_targets(&self.ctarget, jj);
                let (mut sig, mut rbar) = (0.0, 0.0);
                if self.clo[jj].is_finite() {
                    let sl = self.s[jj] - self.clo[jj];
                    sig += self.vl[jj] / sl;
                    rbar -= tl / sl;
                }
                if self.chi[jj].is_finite() {
                    let su = self.chi[jj] - self.s[jj];
                    sig += self.vu[jj] / su;
                    rbar += tu / su;
                }
                let rhs = (rbar + sig * self.chat[nl + jj]) / (1.0 + sig * self.dreg[nl + jj]);
                let row = &e.jac_c[j * nz..(j + 1) * nz];
                for a in 0..nz {
                    self.g[o + a] += row[a] * rhs;
                }
            }
            for li in 0..nz {
                if self.kind[o + li] == Kind::Eliminated {
                    self.g[o + li] = 0.0;
                }
            }
        }
        let m = self.ric.m;
        if self.rho_eq > 0.0 {
            let nxm = lay.nx_max;
            for j in 0..m {
                let k = self.ric.eq_stage[j];
                let o = lay.oz[k];
                let w = self.rho_eq * self.chat[nl + ncall + j];
                for i in 0..lay.nx[k] {
                    self.g[o + i] += w * self.ric.eq_a[j * nxm + i];
                }
            }
        }
        self.bdef.copy_from_slice(&self.chat[..nl]);
        self.ric.eq_rho[..m].copy_from_slice(&self.chat[nl + ncall..nl + ncall + m]);
        self.ric.solve(
            lay,
            &self.g,
            &self.bdef,
            &mut self.step.dz,
            &mut self.step.lam_n,
            &mut self.step.eqm_n[..m],
        );
        // slack, inequality multiplier and bound-dual steps
        for k in 0..=kk {
            let (o, nz, oc) = (lay.oz[k], lay.nz(k), lay.oc[k]);
            let e = &self.ev[k];
            for j in 0..lay.nc[k] {
                let jj = oc + j;
                let row = &e.jac_c[j * nz..(j + 1) * nz];
                // y+ = (Sigma (J dz + c^) + rbar) / (1 + Sigma D), ds = J dz + c^ - D y+
                let mut lin = self.chat[nl + jj];
                for a in 0..nz {
                    lin += row[a] * self.step.dz[o + a];
                }
                let (tl, tu) = s_targets(&self.ctarget, jj);
                let (mut sig, mut rbar) = (0.0, 0.0);
                if self.clo[jj].is_finite() {
                    let sl = self.s[jj] - self.clo[jj];
                    sig += self.vl[jj] / sl;
                    rbar -= tl / sl;
                }
                if self.chi[jj].is_finite() {
                    let su = self.chi[jj] - self.s[jj];
                    sig += self.vu[jj] / su;
                    rbar += tu / su;
                }
                let yn = (sig * lin + rbar) / (1.0 + sig * self.dreg[nl + jj]);
                let ds = lin - self.dreg[nl + jj] * yn;
                self.step.ds[jj] = ds;
                self.step.dvl[jj] = 0.0;
                self.step.dvu[jj] = 0.0;
                if self.clo[jj].is_finite() {
                    let sl = self.s[jj] - self.clo[jj];
                    self.step.dvl[jj] = tl / sl - self.vl[jj] - (self.vl[jj] / sl) * ds;
                }
                if self.chi[jj].is_finite() {
                    let su = self.chi[jj] - self.s[jj];
                    self.step.dvu[jj] = tu / su - self.vu[jj] + (self.vu[jj] / su) * ds;
                }
                self.step.y_n[jj] = yn;
            }
        }
        for i in 0..self.z.len() {
            self.step.dzl[i] = 0.0;
            self.step.dzu[i] = 0.0;
            if self.kind[i] != Kind::Free {
                continue;
            }
            let (tl, tu) = if per_bound {
                (self.ctarget[i], self.ctarget[nz + i])
            } else {
                (mu, mu)
            };
            if self.zlo[i].is_finite() {
                let sl = self.z[i] - self.zlo[i];
                self.step.dzl[i] = tl / sl - self.zl[i] - (self.zl[i] / sl) * self.step.dz[i];
            }
            if self.zhi[i].is_finite() {
                let su = self.zhi[i] - self.z[i];
                self.step.dzu[i] = tu / su - self.zu[i] + (self.zu[i] / su) * self.step.dz[i];
            }
        }
        // restoration slacks: dp = (l+ - rho + mu/p)/Sp, dn = (-l+ - rho + mu/n)/Sn
        if resto.is_some() {
            for i in 0..nrows {
                let lp = if i < nl {
                    self.step.lam_n[i]
                } else if i < nl + ncall {
                    self.step.y_n[i - nl]
                } else {
                    self.step.eqm_n[i - nl - ncall]
                };
                let (p, n) = (self.rp[i], self.rn[i]);
                let (sp, sn) = (self.rzp[i] / p, self.rzn[i] / n);
                self.drp[i] = (lp - RHO_RESTO + mu / p) / sp;
                self.drn[i] = (-lp - RHO_RESTO + mu / n) / sn;
                self.drzp[i] = mu / p - self.rzp[i] - sp * self.drp[i];
                self.drzn[i] = mu / n - self.rzn[i] - sn * self.drn[i];
            }
        }
        stats.time.linear_algebra_s += t.elapsed().as_secs_f64();
        if !(finite(&self.step.dz)
            && finite(&self.step.ds)
            && finite(&self.step.lam_n)
            && finite(&self.step.eqm_n[..m]))
        {
            return Err("non-finite Newton step".to_string());
        }
        Ok(())
    }

    /// Least-squares estimate of the equality multipliers (IPOPT's initialisation):
    /// `min ||grad l + J^T lam - z_L + z_U||^2`, i.e. the chain QP with `H = I` and zero residuals,
    /// solved by the same Riccati recursion. Stage-row multipliers come from their slack duals.
    /// Estimates larger than 1e3 are discarded (zeros).
    fn least_squares_multipliers(&mut self) {
        let lay = &self.lay;
        let kk = lay.kk;
        for j in 0..self.s.len() {
            self.y[j] = self.vu[j] - self.vl[j];
        }
        for k in 0..=kk {
            let (o, nx, nz, nx1, nu) = (lay.oz[k], lay.nx[k], lay.nz(k), lay.nx1[k], lay.nu[k]);
            let e = &self.ev[k];
            let h = &mut self.ric.h[lay.oh[k]..lay.oh[k + 1]];
            h.fill(0.0);
            for li in 0..nz {
                h[li * nz + li] = 1.0;
                let i = o + li;
                self.g[i] = if self.kind[i] == Kind::Eliminated {
                    0.0
                } else {
                    e.grad[li] - self.zl[i] + self.zu[i]
                };
            }
            let gk = &mut self.g[o..o + nz];
            gemv_t_acc(
                &e.jac_c,
                &self.y[lay.oc[k]..lay.oc[k + 1]],
                gk,
                lay.nc[k],
                nz,
            );
            for li in 0..nz {
                if self.kind[o + li] == Kind::Eliminated {
                    gk[li] = 0.0;
                }
            }
            if k < kk {
                let a = &mut self.ric.a[lay.oa[k]..lay.oa[k + 1]];
                let b = &mut self.ric.b[lay.ob[k]..lay.ob[k + 1]];
                split_dynamics_jacobian(&e.jac_f, &self.kind[o..o + nz], nx1, nx, nu, a, b);
            }
        }
        self.bdef.fill(0.0);
        let nr = self.dims.n_terminal;
        let nxm = lay.nx_max;
        let nxk = lay.nx[kk];
        for j in 0..nr {
            self.ric.eq_stage[j] = kk;
            self.ric.eq_a[j * nxm..j * nxm + nxk]
                .copy_from_slice(&self.term.jac_r[j * nxk..(j + 1) * nxk]);
        }
        for (jf, &(k, i)) in self.fixed_rows.iter().enumerate() {
            let j = nr + jf;
            self.ric.eq_stage[j] = k;
            self.ric.eq_a[j * nxm..(j + 1) * nxm].fill(0.0);
            self.ric.eq_a[j * nxm + i] = 1.0;
        }
        let m = nr + self.fixed_rows.len();
        self.ric.m = m;
        self.ric.eq_rho[..m].fill(0.0);
        self.ric.eq_reg[..m].fill(0.0);
        self.ric.soft = false;
        let ok = self.ric.factor_with_inertia(lay, 0.0, &self.reg);
        if ok {
            self.ric.solve(
                lay,
                &self.g,
                &self.bdef,
                &mut self.step.dz,
                &mut self.step.lam_n,
                &mut self.step.eqm_n[..m],
            );
        }
        let big = |v: &[f64]| v.iter().any(|x| x.is_nan() || x.abs() > 1e3);
        if ok && !big(&self.step.lam_n) && !big(&self.step.eqm_n[..m]) {
            self.lam.copy_from_slice(&self.step.lam_n);
            self.nu.copy_from_slice(&self.step.eqm_n[..nr]);
            self.eta[..m - nr].copy_from_slice(&self.step.eqm_n[nr..m]);
        } else {
            self.lam.fill(0.0);
            self.nu.fill(0.0);
            self.eta.fill(0.0);
            self.y.fill(0.0);
        }
    }

    /// Largest step in (0, 1] keeping the primal (`primal`) or dual variables a fraction tau inside.
    fn max_step(&self, tau: f64, resto: bool) -> (f64, f64) {
        let (mut ap, mut ad) = (1.0_f64, 1.0_f64);
        if resto {
            for i in 0..self.nrows() {
                for (v, d) in [(self.rp[i], self.drp[i]), (self.rn[i], self.drn[i])] {
                    if d < 0.0 {
                        ap = ap.min(-tau * v / d);
                    }
                }
                for (v, d) in [(self.rzp[i], self.drzp[i]), (self.rzn[i], self.drzn[i])] {
                    if d < 0.0 {
                        ad = ad.min(-tau * v / d);
                    }
                }
            }
        }
        for i in 0..self.z.len() {
            if self.kind[i] != Kind::Free {
                continue;
            }
            let d = self.step.dz[i];
            if self.zlo[i].is_finite() {
                if d < 0.0 {
                    ap = ap.min(-tau * (self.z[i] - self.zlo[i]) / d);
                }
                if self.step.dzl[i] < 0.0 {
                    ad = ad.min(-tau * self.zl[i] / self.step.dzl[i]);
                }
            }
            if self.zhi[i].is_finite() {
                if d > 0.0 {
                    ap = ap.min(tau * (self.zhi[i] - self.z[i]) / d);
                }
                if self.step.dzu[i] < 0.0 {
                    ad = ad.min(-tau * self.zu[i] / self.step.dzu[i]);
                }
            }
        }
        for j in 0..self.s.len() {
            let d = self.step.ds[j];
            if self.clo[j].is_finite() {
                if d < 0.0 {
                    ap = ap.min(-tau * (self.s[j] - self.clo[j]) / d);
                }
                if self.step.dvl[j] < 0.0 {
                    ad = ad.min(-tau * self.vl[j] / self.step.dvl[j]);
                }
            }
            if self.chi[j].is_finite() {
                if d > 0.0 {
                    ap = ap.min(tau * (self.chi[j] - self.s[j]) / d);
                }
                if self.step.dvu[j] < 0.0 {
                    ad = ad.min(-tau * self.vu[j] / self.step.dvu[j]);
                }
            }
        }
        (ap, ad)
    }

    /// Directional derivative of the barrier function of the current phase along (dz, ds).
    fn barrier_slope(&self, mu: f64, resto: Option<&Resto>) -> f64 {
        let lay = &self.lay;
        let mut d = 0.0;
        if resto.is_some() {
            for i in 0..self.nrows() {
                d += (RHO_RESTO - mu / self.rp[i]) * self.drp[i]
                    + (RHO_RESTO - mu / self.rn[i]) * self.drn[i];
            }
        }
        for k in 0..=lay.kk {
            let o = lay.oz[k];
            for li in 0..lay.nz(k) {
                let i = o + li;
                if self.kind[i] == Kind::Eliminated {
                    continue;
                }
                let mut gi = self.phase_grad(i, k, li, resto);
                if self.kind[i] == Kind::Free {
                    if self.zlo[i].is_finite() {
                        gi -= mu / (self.z[i] - self.zlo[i]);
                    }
                    if self.zhi[i].is_finite() {
                        gi += mu / (self.zhi[i] - self.z[i]);
                    }
                }
                d += gi * self.step.dz[i];
            }
        }
        for j in 0..self.s.len() {
            let mut gj = 0.0;
            if self.clo[j].is_finite() {
                gj -= mu / (self.s[j] - self.clo[j]);
            }
            if self.chi[j].is_finite() {
                gj += mu / (self.chi[j] - self.s[j]);
            }
            d += gj * self.step.ds[j];
        }
        d
    }

    fn filter_acceptable(filter: &[(f64, f64)], theta: f64, phi: f64) -> bool {
        filter.iter().all(|&(ft, fp)| theta < ft || phi < fp)
    }

    fn filter_add(filter: &mut Vec<(f64, f64)>, theta: f64, phi: f64) {
        filter.retain(|&(ft, fp)| !(ft >= theta && fp >= phi));
        if filter.len() == filter.capacity() {
            // keep memory bounded: drop the entry with the largest theta
            if let Some((imax, _)) = filter
                .iter()
                .enumerate()
                .max_by(|a, b| a.1 .0.total_cmp(&b.1 .0))
            {
                filter.swap_remove(imax);
            }
        }
        filter.push((theta, phi));
    }

    /// Initial point: cold (guess pushed inside the bounds, unit bound duals, zero equality
    /// multipliers) or warm (the stored iterate, pushed by `warm_bound_push`).
    fn initialize(&mut self, p: &mut dyn OcpProblem, st: &OcpSettings, warm: bool) {
        if warm {
            self.gather_primal();
            let lay = &self.lay;
            for k in 0..=lay.kk {
                self.lam[lay.ol[k]..lay.ol[k + 1]].copy_from_slice(&self.mult.lam[k]);
                self.y[lay.oc[k]..lay.oc[k + 1]].copy_from_slice(&self.mult.mu[k]);
            }
            self.nu.copy_from_slice(&self.mult.nu);
            // a failed previous solve may leave non-finite values behind
            for v in self
                .lam
                .iter_mut()
                .chain(self.y.iter_mut())
                .chain(self.nu.iter_mut())
                .chain(self.eta.iter_mut())
                .chain(self.zl.iter_mut())
                .chain(self.zu.iter_mut())
                .chain(self.vl.iter_mut())
                .chain(self.vu.iter_mut())
                .chain(self.s.iter_mut())
            {
                if !v.is_finite() {
                    *v = 0.0;
                }
            }
        } else {
            for x in self.zp.x.iter_mut().chain(self.zp.u.iter_mut()) {
                x.fill(0.0);
            }
            let r = catch_unwind(AssertUnwindSafe(|| p.initial_guess(&mut self.zp)));
            if r.is_err() {
                // a panicking guess: start from zeros (the evaluation will tell whether that works)
                for x in self.zp.x.iter_mut().chain(self.zp.u.iter_mut()) {
                    x.fill(0.0);
                }
            }
            self.gather_primal();
            self.lam.fill(0.0);
            self.y.fill(0.0);
            self.nu.fill(0.0);
            self.eta.fill(0.0);
        }
        let push = if warm {
            st.warm_bound_push
        } else {
            st.bound_push
        };
        for i in 0..self.z.len() {
            match self.kind[i] {
                Kind::Free => {
                    self.z[i] = Self::push_inside(self.zlo[i], self.zhi[i], self.z[i], push);
                    if warm && st.warm_duals == WarmDuals::Centered {
                        self.zl[i] = if self.zlo[i].is_finite() {
                            st.mu_init / (self.z[i] - self.zlo[i])
                        } else {
                            0.0
                        };
                        self.zu[i] = if self.zhi[i].is_finite() {
                            st.mu_init / (self.zhi[i] - self.z[i])
                        } else {
                            0.0
                        };
                    } else if warm
                        && matches!(st.warm_duals, WarmDuals::Stored | WarmDuals::StoredBounds)
                    {
                        self.zl[i] = if self.zlo[i].is_finite() {
                            self.zl[i].max(1e-20)
                        } else {
                            0.0
                        };
                        self.zu[i] = if self.zhi[i].is_finite() {
                            self.zu[i].max(1e-20)
                        } else {
                            0.0
                        };
                    } else {
                        self.zl[i] = if self.zlo[i].is_finite() { 1.0 } else { 0.0 };
                        self.zu[i] = if self.zhi[i].is_finite() { 1.0 } else { 0.0 };
                    }
                }
                Kind::Eliminated => {
                    self.z[i] = self.zlo[i];
                    self.zl[i] = 0.0;
                    self.zu[i] = 0.0;
                }
                Kind::FixedRow => {
                    if !warm || !self.z[i].is_finite() {
                        self.z[i] = self.zlo[i];
                    }
                    self.zl[i] = 0.0;
                    self.zu[i] = 0.0;
                }
            }
        }
        if !warm || st.warm_duals == WarmDuals::Reset {
            self.vl.fill(1.0);
            self.vu.fill(1.0);
        }
        for j in 0..self.s.len() {
            if warm && matches!(st.warm_duals, WarmDuals::Stored | WarmDuals::StoredBounds) {
                self.vl[j] = self.vl[j].max(1e-20);
                self.vu[j] = self.vu[j].max(1e-20);
            }
            if !self.clo[j].is_finite() {
                self.vl[j] = 0.0;
            }
            if !self.chi[j].is_finite() {
                self.vu[j] = 0.0;
            }
        }
    }

    fn run(
        &mut self,
        p: &mut dyn OcpProblem,
        st: &OcpSettings,
        stats: &mut OcpStats,
        t0: Instant,
    ) -> OcpStatus {
        if p.dims() != &self.dims {
            return OcpStatus::InvalidProblem(
                "the problem's dims differ from the solver's".to_string(),
            );
        }
        if let Err(e) = self.read_bounds(p) {
            return OcpStatus::InvalidProblem(e);
        }
        let warm = st.warm_start && self.has_iterate;
        if warm {
            let shape_ok = self.zp.x.len() == self.lay.kk + 1
                && self.zp.u.len() == self.lay.kk + 1
                && (0..=self.lay.kk).all(|k| {
                    self.zp.x[k].len() == self.lay.nx[k] && self.zp.u[k].len() == self.lay.nu[k]
                });
            if !shape_ok {
                return OcpStatus::InvalidProblem(
                    "the stored iterate was resized through primal_mut".to_string(),
                );
            }
        }
        if !warm || self.fixed_rows.len() != self.eta_rows {
            self.eta.fill(0.0);
        }
        self.eta_rows = self.fixed_rows.len();
        self.initialize(p, st, warm);
        self.has_iterate = true;
        self.delta_w_last = 0.0;
        // a warm start keeps the equality-row penalty that last passed the inertia test: the
        // penalty changes neither the step nor the inertia (docs/ocp.md section 5), and starting
        // from 0 again costs the first iteration of every warm solve its failed factorisations
        if !warm {
            self.rho_eq_last = 0.0;
        }
        if self.filter.capacity() < st.max_iter + 2 {
            self.filter.reserve(st.max_iter + 2);
            self.filter_orig.reserve(st.max_iter + 2);
        }
        self.filter.clear();
        self.filter_orig.clear();

        // slacks from c(z) at the initial point
        if let Err(EvalFail::Failed(e)) = self.evaluate(p, false, EvalLevel::FirstOrder, stats) {
            self.finish(stats, st.mu_init, None);
            return OcpStatus::EvaluationError(e);
        }
        {
            let lay = &self.lay;
            for k in 0..=lay.kk {
                for j in 0..lay.nc[k] {
                    let jj = lay.oc[k] + j;
                    let push = if warm {
                        st.warm_bound_push
                    } else {
                        st.bound_push
                    };
                    let c = if warm { self.s[jj] } else { self.ev[k].c[j] };
                    self.s[jj] = Self::push_inside(self.clo[jj], self.chi[jj], c, push);
                    if warm && st.warm_duals == WarmDuals::Centered {
                        let (lo, hi) = (self.clo[jj], self.chi[jj]);
                        self.vl[jj] = if lo.is_finite() {
                            st.mu_init / (self.s[jj] - lo)
                        } else {
                            0.0
                        };
                        self.vu[jj] = if hi.is_finite() {
                            st.mu_init / (hi - self.s[jj])
                        } else {
                            0.0
                        };
                    }
                }
            }
        }
        // the stored equality multipliers only with `Stored`
        if !warm || st.warm_duals != WarmDuals::Stored {
            self.least_squares_multipliers();
        }
        let mut mu = st.mu_init;
        let (th0, _) = self.theta_current();
        let mut theta_max = 1e4 * th0.max(1.0);
        let mut theta_min = 1e-4 * th0.max(1.0);
        let mut resto: Option<Resto> = None;
        let mut acceptable_count = 0usize;
        let mut iter = 0usize;
        let adaptive = st.mu_strategy == MuStrategy::Adaptive;
        let mut free_mode = adaptive;
        let mut kkt_ref = [0.0_f64; KKT_REF_ITERS];
        let mut kkt_count = 0usize;
        let mut mu_max = f64::NAN;
        // the residuals of the original problem at the iterate as it stands, if computed (for
        // `finish`): from the top of an iteration until its step is accepted
        let mut current: Option<Residuals>;
        let status = 'iterations: loop {
            let res = self.residuals(resto.as_ref());
            current = resto.is_none().then_some(res);
            stats.iterations = iter;
            if resto.is_none() {
                let e0 = res.e0();
                if e0 <= st.tol && res.theta_inf <= st.constr_viol_tol {
                    break OcpStatus::Solved;
                }
                if st.acceptable_iter > 0
                    && e0 <= st.acceptable_tol
                    && res.theta_inf <= st.acceptable_tol.max(st.constr_viol_tol)
                {
                    acceptable_count += 1;
                    if acceptable_count >= st.acceptable_iter {
                        break OcpStatus::SolvedToAcceptableLevel;
                    }
                } else {
                    acceptable_count = 0;
                }
            } else if res.e0() <= st.tol.max(1e-10) {
                // the restoration problem converged without reaching a point the filter accepts:
                // a stationary point of the constraint violation
                break OcpStatus::LocallyInfeasible;
            }
            if iter >= st.max_iter {
                break OcpStatus::MaxIterations;
            }
            if let Some(tmax) = st.max_wall_time_s {
                if t0.elapsed().as_secs_f64() > tmax {
                    break OcpStatus::MaxWallTime;
                }
            }
            if st.cancel.as_ref().is_some_and(|c| c.is_cancelled()) {
                break OcpStatus::Cancelled;
            }
            if let Some(r) = resto.as_mut() {
                r.iters += 1;
                if r.iters > st.max_restoration_iter {
                    break self.resto_failure(r);
                }
            }
            let mu_min = st.tol / 10.0;
            // adaptive mu: free mode while the optimality error keeps falling
            if adaptive && resto.is_none() {
                if free_mode {
                    let e = res.e0();
                    let n = kkt_count.min(KKT_REF_ITERS);
                    let e_ref = kkt_ref[..n].iter().fold(0.0_f64, |a, b| a.max(*b));
                    if n == 0 || e <= KKT_REF_FACTOR * e_ref {
                        kkt_ref[kkt_count % KKT_REF_ITERS] = e;
                        kkt_count += 1;
                    } else {
                        free_mode = false;
                        let (sum, nb) = self.complementarity(0.0, 0.0);
                        if nb > 0 {
                            mu = mu_min.max(MONOTONE_INIT_FACTOR * sum / nb as f64);
                        }
                        self.filter.clear();
                    }
                } else if self.e_mu(&res, mu, false) <= KAPPA_EPS * mu {
                    free_mode = true;
                    kkt_ref[0] = res.e0();
                    kkt_count = 1;
                }
            }
            let probing = adaptive && free_mode && resto.is_none();
            // monotone barrier update
            if !probing {
                while mu > mu_min && self.e_mu(&res, mu, resto.is_some()) <= KAPPA_EPS * mu {
                    mu = mu_min.max((KAPPA_MU * mu).min(mu.powf(THETA_MU)));
                    self.filter.clear();
                }
            }
            // Hessian of the Lagrangian (sigma = 0 in restoration)
            {
                let t = Instant::now();
                self.store_multipliers();
                let sigma = if resto.is_some() { 0.0 } else { 1.0 };
                Self::scatter_primal(&self.z, &self.lay, &mut self.zp);
                let (zp, mult, ev) = (&self.zp, &self.mult, &mut self.ev);
                let r = catch_unwind(AssertUnwindSafe(|| p.hessians(zp, sigma, mult, ev)));
                stats.time.hessian_s += t.elapsed().as_secs_f64();
                let err = match r {
                    Err(e) => Some(format!("hessians panicked: {}", panic_message(&*e))),
                    Ok(Err(e)) => Some(e.to_string()),
                    Ok(Ok(())) => self
                        .ev
                        .iter()
                        .position(|e| !finite(&e.hess))
                        .map(|k| format!("non-finite Hessian at stage {k}")),
                };
                if let Some(e) = err {
                    break OcpStatus::EvaluationError(e);
                }
            }
            let step = if probing {
                self.probing_direction(&mut mu, mu_min, &mut mu_max, stats)
            } else {
                self.direction(mu, resto.as_ref(), stats)
            };
            if let Err(e) = step {
                break OcpStatus::NumericalError(e);
            }
            let in_resto = resto.is_some();
            let tau = TAU_MIN.max(1.0 - mu);
            let centring = if st.centrality_correctors > 0 && !in_resto {
                match self.centrality_correctors(mu, tau, st.centrality_correctors, stats) {
                    Ok(c) => c,
                    Err(e) => break OcpStatus::NumericalError(e),
                }
            } else {
                Centring::Mu(mu)
            };
            // filter line search
            let tl = Instant::now();
            let eval_before = stats.time.evaluation_s;
            let (amax, adual) = self.max_step(tau, in_resto);
            let pn0 = if in_resto {
                Some((&self.rp[..], &self.rn[..]))
            } else {
                None
            };
            let b0 = self.barrier(&self.z, &self.s, pn0);
            let phi0 =
                self.phase_objective(&self.z, &self.ev, resto.as_ref(), (&self.rp, &self.rn))
                    + mu * b0;
            let theta0 = res.theta_1;
            let gphi = self.barrier_slope(mu, resto.as_ref());
            let tiny = self
                .z
                .iter()
                .zip(&self.step.dz)
                .all(|(z, d)| d.abs() <= 10.0 * f64::EPSILON * (1.0 + z.abs()));
            let alpha_min = if gphi < 0.0 {
                let mut a = GAMMA_THETA.min(GAMMA_PHI * theta0 / -gphi);
                if theta0 <= theta_min {
                    a = a.min(DELTA_SW * theta0.powf(S_THETA) / (-gphi).powf(S_PHI));
                }
                GAMMA_ALPHA * a
            } else {
                GAMMA_ALPHA * GAMMA_THETA
            }
            .max(1e-14);
            let mut alpha = amax;
            let mut adual = adual;
            // (alpha, original theta at the trial, h-type)
            let mut accepted: Option<(f64, f64, bool)> = None;
            let nrows = self.nrows();
            let mut first = true;
            loop {
                let trial = self.trial(p, alpha, in_resto, mu, resto.as_ref(), stats);
                if let Some((tt, to, phit)) = trial {
                    if tiny {
                        accepted = Some((alpha, to, false));
                        break;
                    }
                    let ls = LineSearch {
                        theta0,
                        phi0,
                        gphi,
                        theta_min,
                        theta_max,
                    };
                    if let Some(h) = ls.accepts(&self.filter, tt, phit, alpha) {
                        accepted = Some((alpha, to, h));
                        break;
                    }
                    // second-order correction (IPOPT section 2.4) when the full step raised theta
                    if first && !in_resto && st.max_soc > 0 && tt >= theta0 {
                        let mut a_soc = alpha;
                        let mut th_old = theta0;
                        for _ in 0..st.max_soc {
                            for i in 0..nrows {
                                self.chat[i] = a_soc * self.chat[i] + self.cv_t[i];
                            }
                            if self.solve_rhs(centring, None, stats).is_err() {
                                break;
                            }
                            let (ap, ad) = self.max_step(tau, false);
                            let Some((ts, _, phis)) = self.trial(p, ap, false, mu, None, stats)
                            else {
                                break;
                            };
                            // Armijo and switching tests with the original step length (IPOPT)
                            let acc = ls.accepts(&self.filter, ts, phis, alpha);
                            if let Some(h) = acc {
                                accepted = Some((ap, ts, h));
                                adual = ad;
                                break;
                            }
                            if ts > KAPPA_SOC * th_old {
                                break;
                            }
                            th_old = ts;
                            a_soc = ap;
                        }
                        if accepted.is_some() {
                            break;
                        }
                        // back to the original direction
                        self.chat[..nrows].copy_from_slice(&self.cv[..nrows]);
                        if let Err(e) = self.solve_rhs(centring, None, stats) {
                            break 'iterations OcpStatus::NumericalError(e);
                        }
                    }
                }
                first = false;
                alpha *= 0.5;
                if alpha < alpha_min {
                    break;
                }
            }
            let ls_eval = stats.time.evaluation_s - eval_before;
            let Some((alpha, theta_orig_t, h_type)) = accepted else {
                stats.time.line_search_s += tl.elapsed().as_secs_f64() - ls_eval;
                if let Some(r) = resto.as_ref() {
                    break self.resto_failure(r);
                }
                if res.e0() <= st.acceptable_tol
                    && res.theta_inf <= st.acceptable_tol.max(st.constr_viol_tol)
                {
                    break OcpStatus::SolvedToAcceptableLevel;
                }
                // enter the restoration phase (IPOPT section 3.3): min rho ||p + n||_1 + proximity
                // s.t. c(z) - p + n = 0 from the current point
                Self::filter_add(
                    &mut self.filter,
                    (1.0 - GAMMA_THETA) * theta0,
                    phi0 - GAMMA_PHI * theta0,
                );
                self.filter_orig.clear();
                let (fo, fr) = (&mut self.filter_orig, &self.filter);
                fo.extend_from_slice(fr);
                let mu_r = mu.max(res.theta_inf).min(1e2);
                for i in 0..self.z.len() {
                    self.z_ref[i] = self.z[i];
                    self.dr[i] = if self.kind[i] == Kind::Eliminated {
                        0.0
                    } else {
                        1.0_f64.min(1.0 / self.z[i].abs())
                    };
                }
                for i in 0..nrows {
                    let c = self.cv[i];
                    let q = (mu_r - RHO_RESTO * c) / (2.0 * RHO_RESTO);
                    let n = q + (q * q + mu_r * c / (2.0 * RHO_RESTO)).sqrt();
                    let n = n.max(1e-12 * mu_r);
                    self.rn[i] = n;
                    self.rp[i] = (c + n).max(1e-12 * mu_r);
                    self.rzp[i] = mu_r / self.rp[i];
                    self.rzn[i] = mu_r / self.rn[i];
                }
                for v in self.zl.iter_mut().chain(self.zu.iter_mut()) {
                    *v = v.min(RHO_RESTO);
                }
                for v in self.vl.iter_mut().chain(self.vu.iter_mut()) {
                    *v = v.min(RHO_RESTO);
                }
                resto = Some(Resto {
                    theta0,
                    mu_orig: mu,
                    zeta: mu_r.sqrt(),
                    iters: 0,
                    theta_max_orig: theta_max,
                });
                mu = mu_r;
                self.lam.fill(0.0);
                self.y.fill(0.0);
                self.nu.fill(0.0);
                self.eta.fill(0.0);
                self.filter.clear();
                let (tr, _) = self.theta_of(&self.cv, Some((&self.rp, &self.rn)));
                theta_max = 1e4 * tr.max(theta0).max(1.0);
                theta_min = 1e-4 * tr.max(1.0);
                self.delta_w_last = 0.0;
                iter += 1;
                continue;
            };
            if h_type {
                Self::filter_add(
                    &mut self.filter,
                    (1.0 - GAMMA_THETA) * theta0,
                    phi0 - GAMMA_PHI * theta0,
                );
            }
            // accept: primal with alpha, equality multipliers with alpha, bound duals with alpha_dual
            current = None;
            std::mem::swap(&mut self.z, &mut self.z_t);
            std::mem::swap(&mut self.s, &mut self.s_t);
            for (l, ln) in self.lam.iter_mut().zip(&self.step.lam_n) {
                *l += alpha * (ln - *l);
            }
            for (y, yn) in self.y.iter_mut().zip(&self.step.y_n) {
                *y += alpha * (yn - *y);
            }
            let nr = self.dims.n_terminal;
            for j in 0..nr {
                self.nu[j] += alpha * (self.step.eqm_n[j] - self.nu[j]);
            }
            for j in 0..self.fixed_rows.len() {
                self.eta[j] += alpha * (self.step.eqm_n[nr + j] - self.eta[j]);
            }
            let safeguard = |v: f64, slack: f64| {
                v.min(KAPPA_SIGMA * mu / slack)
                    .max(mu / (KAPPA_SIGMA * slack))
            };
            for i in 0..self.z.len() {
                if self.kind[i] != Kind::Free {
                    continue;
                }
                if self.zlo[i].is_finite() {
                    let v = self.zl[i] + adual * self.step.dzl[i];
                    self.zl[i] = safeguard(v, self.z[i] - self.zlo[i]);
                }
                if self.zhi[i].is_finite() {
                    let v = self.zu[i] + adual * self.step.dzu[i];
                    self.zu[i] = safeguard(v, self.zhi[i] - self.z[i]);
                }
            }
            for j in 0..self.s.len() {
                if self.clo[j].is_finite() {
                    let v = self.vl[j] + adual * self.step.dvl[j];
                    self.vl[j] = safeguard(v, self.s[j] - self.clo[j]);
                }
                if self.chi[j].is_finite() {
                    let v = self.vu[j] + adual * self.step.dvu[j];
                    self.vu[j] = safeguard(v, self.chi[j] - self.s[j]);
                }
            }
            if in_resto {
                std::mem::swap(&mut self.rp, &mut self.rp_t);
                std::mem::swap(&mut self.rn, &mut self.rn_t);
                for i in 0..nrows {
                    let v = self.rzp[i] + adual * self.drzp[i];
                    self.rzp[i] = safeguard(v, self.rp[i]);
                    let v = self.rzn[i] + adual * self.drzn[i];
                    self.rzn[i] = safeguard(v, self.rn[i]);
                }
            }
            // the original barrier objective at the accepted point (restoration exit test)
            let phi_orig_t = resto
                .map(|r| Self::cost(&self.ev_t) + r.mu_orig * self.barrier(&self.z, &self.s, None));
            stats.time.line_search_s += tl.elapsed().as_secs_f64() - ls_eval;
            if let Err(EvalFail::Failed(e)) = self.evaluate(p, false, EvalLevel::FirstOrder, stats)
            {
                break OcpStatus::EvaluationError(e);
            }
            iter += 1;
            if let (Some(r), Some(phio)) = (resto, phi_orig_t) {
                if theta_orig_t <= 0.9 * r.theta0
                    && Self::filter_acceptable(&self.filter_orig, theta_orig_t, phio)
                {
                    // back to the original problem
                    mu = r.mu_orig;
                    theta_max = r.theta_max_orig;
                    theta_min = 1e-4 * (theta_max / 1e4);
                    std::mem::swap(&mut self.filter, &mut self.filter_orig);
                    self.lam.fill(0.0);
                    self.y.fill(0.0);
                    self.nu.fill(0.0);
                    self.eta.fill(0.0);
                    for v in self
                        .zl
                        .iter_mut()
                        .chain(self.zu.iter_mut())
                        .chain(self.vl.iter_mut())
                        .chain(self.vu.iter_mut())
                    {
                        if *v > BOUND_MULT_RESET {
                            *v = 1.0;
                        }
                    }
                    self.least_squares_multipliers();
                    self.delta_w_last = 0.0;
                    resto = None;
                }
            }
        };
        stats.iterations = iter;
        self.finish(stats, mu, current);
        status
    }

    /// Evaluates the trial point `z + alpha dz` (slacks and restoration slacks likewise): returns
    /// (theta of the phase, original theta, barrier function of the phase), or None if the
    /// evaluation failed or is not finite.
    fn trial(
        &mut self,
        p: &mut dyn OcpProblem,
        alpha: f64,
        in_resto: bool,
        mu: f64,
        resto: Option<&Resto>,
        stats: &mut OcpStats,
    ) -> Option<(f64, f64, f64)> {
        for i in 0..self.z.len() {
            self.z_t[i] = self.z[i] + alpha * self.step.dz[i];
        }
        for j in 0..self.s.len() {
            self.s_t[j] = self.s[j] + alpha * self.step.ds[j];
        }
        let nrows = self.nrows();
        if in_resto {
            for i in 0..nrows {
                self.rp_t[i] = self.rp[i] + alpha * self.drp[i];
                self.rn_t[i] = self.rn[i] + alpha * self.drn[i];
            }
        }
        self.evaluate(p, true, EvalLevel::Values, stats).ok()?;
        let mut cv = std::mem::take(&mut self.cv_t);
        self.row_values(&self.z_t, &self.s_t, &self.ev_t, &self.term_t, &mut cv);
        let (to, _) = self.theta_of(&cv, None);
        let pnt = if in_resto {
            Some((&self.rp_t[..], &self.rn_t[..]))
        } else {
            None
        };
        let tt = if in_resto {
            self.theta_of(&cv, pnt).0
        } else {
            to
        };
        self.cv_t = cv;
        let bt = self.barrier(&self.z_t, &self.s_t, pnt);
        let phit =
            self.phase_objective(&self.z_t, &self.ev_t, resto, (&self.rp_t, &self.rn_t)) + mu * bt;
        (tt.is_finite() && phit.is_finite()).then_some((tt, to, phit))
    }

    fn resto_failure(&mut self, r: &Resto) -> OcpStatus {
        let (t1, _) = self.theta_current();
        if t1 >= 0.5 * r.theta0 {
            OcpStatus::LocallyInfeasible
        } else {
            OcpStatus::RestorationFailed
        }
    }

    /// Final statistics and the public copies of the iterate. `res`: the residuals of the original
    /// problem at the final iterate if the iterations computed them (a solve that stops on its
    /// convergence test), else `None` (computed here).
    fn finish(&mut self, stats: &mut OcpStats, mu: f64, res: Option<Residuals>) {
        Self::scatter_primal(&self.z, &self.lay, &mut self.zp);
        self.store_multipliers();
        stats.final_mu = mu;
        stats.objective = Self::cost(&self.ev);
        let res = res.unwrap_or_else(|| self.residuals(None));
        stats.dual_infeasibility = res.dual_inf;
        // true violations: dynamics, terminal, fixed, c(z) against its bounds, simple bounds
        let lay = &self.lay;
        let mut v = 0.0_f64;
        for k in 0..=lay.kk {
            if k < lay.kk {
                for i in 0..lay.nx1[k] {
                    v = v.max((self.ev[k].f[i] - self.z[lay.oz[k + 1] + i]).abs());
                }
            }
            for j in 0..lay.nc[k] {
                let c = self.ev[k].c[j];
                let jj = lay.oc[k] + j;
                v = v.max(self.clo[jj] - c).max(c - self.chi[jj]);
            }
        }
        for r in &self.term.r {
            v = v.max(r.abs());
        }
        for i in 0..self.z.len() {
            v = v.max(self.zlo[i] - self.z[i]).max(self.z[i] - self.zhi[i]);
        }
        stats.primal_infeasibility = v;
    }
}
