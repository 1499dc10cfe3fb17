//! The iterate (primal, slacks, every multiplier, and the problem's evaluation there), the line
//! search's trial point, and the Newton step between them.

use super::data::{Kind, ProblemData};
use super::evaluation;
use crate::problem::{
    EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageEval, TerminalEval,
};
use crate::riccati::Layout;
use crate::settings::{OcpStats, MAX_EQUALITY_ROWS};

/// Safeguard on the bound multipliers after a step (IPOPT's `kappa_sigma`).
const KAPPA_SIGMA: f64 = 1e10;

/// The current iterate of the interior-point method and the evaluation of the problem there.
pub(super) struct Iterate {
    /// Primal variables (nz, stage by stage `[x_k, u_k]`) and the slacks of the stage rows (nc).
    pub(super) z: Vec<f64>,
    pub(super) s: Vec<f64>,
    /// Multipliers of the dynamics (nl), the stage rows (nc), the terminal rows and the fixed-state
    /// rows ([`MAX_EQUALITY_ROWS`], the first `eta_rows` used).
    pub(super) lam: Vec<f64>,
    pub(super) y: Vec<f64>,
    pub(super) nu: Vec<f64>,
    pub(super) eta: Vec<f64>,
    /// Duals of the lower and upper bounds of z (nz) and of the slacks (nc).
    pub(super) zl: Vec<f64>,
    pub(super) zu: Vec<f64>,
    pub(super) vl: Vec<f64>,
    pub(super) vu: Vec<f64>,
    /// Number of fixed-state rows the multipliers `eta` belong to (those of the solve that left
    /// them, or of a warm state put back).
    pub(super) eta_rows: usize,
    /// Whether a solve has left an iterate (a warm start needs one).
    pub(super) has_iterate: bool,
    /// The primal in the problem's shape, the evaluations there and the constraint rows (dynamics,
    /// stage rows `c - s`, terminal, fixed states).
    pub(super) zp: Primal,
    pub(super) ev: Vec<StageEval>,
    pub(super) term: TerminalEval,
    pub(super) cv: Vec<f64>,
    /// The multipliers in the problem's shape (what `hessians` and the user read).
    pub(super) mult: Multipliers,
    /// Gradient of the Lagrangian (dual residual) at the iterate (nz).
    pub(super) rz: Vec<f64>,
    /// Scratch of `OcpSolver::remap_bound_duals` (nz).
    pub(super) remap: Vec<f64>,
}

/// A trial point of the line search and the evaluation of the problem there (values, and first
/// derivatives for the line search's first trial).
pub(super) struct Trial {
    pub(super) z: Vec<f64>,
    pub(super) s: Vec<f64>,
    pub(super) zp: Primal,
    pub(super) ev: Vec<StageEval>,
    pub(super) term: TerminalEval,
    pub(super) cv: Vec<f64>,
    /// Whether `ev` and `term` hold first derivatives at `z` as well.
    pub(super) first_order: bool,
    /// Whether the next line search evaluates its first trial with first derivatives (it does
    /// while the line searches accept their first trial).
    pub(super) speculate: bool,
}

/// A Newton step: the primal and slack steps, the equality multipliers as new values, and the
/// bound-dual steps. The solver holds two: the step of the current iteration and a copy of it taken
/// before a centrality corrector, to undo one that is not kept.
pub(super) struct Step {
    /// Primal step (nz).
    pub(super) dz: Vec<f64>,
    /// Slack step of the stage rows (nc).
    pub(super) ds: Vec<f64>,
    /// New dynamics multipliers (nl).
    pub(super) lam_n: Vec<f64>,
    /// New stage-row multipliers (nc).
    pub(super) y_n: Vec<f64>,
    /// New multipliers of the terminal rows, then of the fixed-state rows
    /// ([`MAX_EQUALITY_ROWS`]; the first `n_terminal + fixed rows` are used).
    pub(super) eqm_n: Vec<f64>,
    /// Steps of the duals of the lower and upper bounds of z (nz).
    pub(super) dzl: Vec<f64>,
    pub(super) dzu: Vec<f64>,
    /// Steps of the duals of the lower and upper bounds of the slacks (nc).
    pub(super) dvl: Vec<f64>,
    pub(super) dvu: Vec<f64>,
}

/// Stage evaluations of the right sizes for `dims`.
fn stage_evals(dims: &OcpDims, lay: &Layout) -> Vec<StageEval> {
    (0..dims.stages.len())
        .map(|k| StageEval::zeros(dims.stages[k], lay.nx1[k]))
        .collect()
}

/// Number of constraint rows the row buffers hold at most.
fn max_rows(lay: &Layout) -> usize {
    lay.n_l() + lay.n_c() + MAX_EQUALITY_ROWS
}

impl Iterate {
    /// Allocates a zero iterate for `dims` laid out by `lay`.
    pub(super) fn new(dims: &OcpDims, lay: &Layout) -> Self {
        let (nz, nl, nc) = (lay.n_z(), lay.n_l(), lay.n_c());
        let nr = dims.n_terminal;
        Iterate {
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
            eta_rows: 0,
            has_iterate: false,
            zp: Primal::zeros(dims),
            ev: stage_evals(dims, lay),
            term: TerminalEval::zeros(nr, lay.nx[lay.kk]),
            cv: vec![0.0; max_rows(lay)],
            mult: Multipliers::zeros(dims),
            rz: vec![0.0; nz],
            remap: vec![0.0; nz],
        }
    }

    /// Evaluates the problem at the iterate (`level`: with first derivatives, or values only).
    pub(super) fn evaluate(
        &mut self,
        p: &mut dyn OcpProblem,
        lay: &Layout,
        level: EvalLevel,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        scatter_primal(&self.z, lay, &mut self.zp);
        evaluation::evaluate(p, &self.zp, level, &mut self.ev, &mut self.term, stats)
    }

    /// The Hessians of the Lagrangian at the iterate, with objective weight `sigma` (0 in the
    /// restoration phase, whose objective has no problem cost).
    pub(super) fn hessians(
        &mut self,
        p: &mut dyn OcpProblem,
        lay: &Layout,
        sigma: f64,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        self.store_multipliers(lay);
        scatter_primal(&self.z, lay, &mut self.zp);
        evaluation::hessians(p, &self.zp, sigma, &self.mult, &mut self.ev, stats)
    }

    /// Takes over the first-order evaluation of the trial point `trial` once that point has become
    /// the iterate (its primal swapped in by [`Self::accept`]): the problem's values and first
    /// derivatives there, swapped in instead of evaluated again (the Hessian buffers stay).
    pub(super) fn take_evaluation(&mut self, trial: &mut Trial) {
        std::mem::swap(&mut self.zp, &mut trial.zp);
        for (a, b) in self.ev.iter_mut().zip(trial.ev.iter_mut()) {
            std::mem::swap(&mut a.cost, &mut b.cost);
            std::mem::swap(&mut a.grad, &mut b.grad);
            std::mem::swap(&mut a.f, &mut b.f);
            std::mem::swap(&mut a.jac_f, &mut b.jac_f);
            std::mem::swap(&mut a.c, &mut b.c);
            std::mem::swap(&mut a.jac_c, &mut b.jac_c);
        }
        std::mem::swap(&mut self.term, &mut trial.term);
    }

    /// Copies the primal of the problem's shape (`zp`) into `z`.
    pub(super) fn gather_primal(&mut self, lay: &Layout) {
        for k in 0..=lay.kk {
            let o = lay.oz[k];
            let nx = lay.nx[k];
            self.z[o..o + nx].copy_from_slice(&self.zp.x[k]);
            self.z[o + nx..lay.oz[k + 1]].copy_from_slice(&self.zp.u[k]);
        }
    }

    /// Copies the equality multipliers into the problem's shape (`mult`).
    pub(super) fn store_multipliers(&mut self, lay: &Layout) {
        for k in 0..=lay.kk {
            self.mult.lam[k].copy_from_slice(&self.lam[lay.ol[k]..lay.ol[k + 1]]);
            self.mult.mu[k].copy_from_slice(&self.y[lay.oc[k]..lay.oc[k + 1]]);
        }
        self.mult.nu.copy_from_slice(&self.nu);
    }

    /// Zero equality multipliers (dynamics, stage rows, terminal and fixed-state rows).
    pub(super) fn clear_equality_multipliers(&mut self) {
        self.lam.fill(0.0);
        self.y.fill(0.0);
        self.nu.fill(0.0);
        self.eta.fill(0.0);
    }

    /// Multiplier of constraint row i (in the order of the rows: dynamics, stage rows, terminal,
    /// fixed states).
    pub(super) fn row_multiplier(&self, i: usize, nl: usize, nc: usize, nr: usize) -> f64 {
        if i < nl {
            self.lam[i]
        } else if i < nl + nc {
            self.y[i - nl]
        } else {
            let j = i - nl - nc;
            if j < nr {
                self.nu[j]
            } else {
                self.eta[j - nr]
            }
        }
    }

    /// Moves to the trial point `trial` (swapping the primal and the slacks) and updates the
    /// equality multipliers by `alpha` towards the step's new values and the bound duals by
    /// `adual` along their steps, safeguarded against drifting from `mu / slack` (`kappa_sigma`).
    pub(super) fn accept(
        &mut self,
        trial: &mut Trial,
        step: &Step,
        data: &ProblemData,
        alpha: f64,
        adual: f64,
        mu: f64,
    ) {
        std::mem::swap(&mut self.z, &mut trial.z);
        std::mem::swap(&mut self.s, &mut trial.s);
        for (l, ln) in self.lam.iter_mut().zip(&step.lam_n) {
            *l += alpha * (ln - *l);
        }
        for (y, yn) in self.y.iter_mut().zip(&step.y_n) {
            *y += alpha * (yn - *y);
        }
        let nr = data.dims.n_terminal;
        for j in 0..nr {
            self.nu[j] += alpha * (step.eqm_n[j] - self.nu[j]);
        }
        for j in 0..data.fixed_rows.len() {
            self.eta[j] += alpha * (step.eqm_n[nr + j] - self.eta[j]);
        }
        for i in 0..self.z.len() {
            if data.kind[i] != Kind::Free {
                continue;
            }
            if data.zlo[i].is_finite() {
                let v = self.zl[i] + adual * step.dzl[i];
                self.zl[i] = safeguard(v, self.z[i] - data.zlo[i], mu);
            }
            if data.zhi[i].is_finite() {
                let v = self.zu[i] + adual * step.dzu[i];
                self.zu[i] = safeguard(v, data.zhi[i] - self.z[i], mu);
            }
        }
        for j in 0..self.s.len() {
            if data.clo[j].is_finite() {
                let v = self.vl[j] + adual * step.dvl[j];
                self.vl[j] = safeguard(v, self.s[j] - data.clo[j], mu);
            }
            if data.chi[j].is_finite() {
                let v = self.vu[j] + adual * step.dvu[j];
                self.vu[j] = safeguard(v, data.chi[j] - self.s[j], mu);
            }
        }
    }
}

/// A bound dual `v` kept within `[mu / (kappa_sigma slack), kappa_sigma mu / slack]`.
pub(super) fn safeguard(v: f64, slack: f64, mu: f64) -> f64 {
    v.min(KAPPA_SIGMA * mu / slack)
        .max(mu / (KAPPA_SIGMA * slack))
}

impl Trial {
    /// Allocates a trial point for `dims` laid out by `lay`.
    pub(super) fn new(dims: &OcpDims, lay: &Layout) -> Self {
        Trial {
            z: vec![0.0; lay.n_z()],
            s: vec![0.0; lay.n_c()],
            zp: Primal::zeros(dims),
            ev: stage_evals(dims, lay),
            term: TerminalEval::zeros(dims.n_terminal, lay.nx[lay.kk]),
            cv: vec![0.0; max_rows(lay)],
            first_order: false,
            speculate: true,
        }
    }

    /// Evaluates the problem at the trial point (`level`: values only, or with first derivatives
    /// as well, for a trial point that becomes the iterate without another evaluation).
    pub(super) fn evaluate(
        &mut self,
        p: &mut dyn OcpProblem,
        lay: &Layout,
        level: EvalLevel,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        scatter_primal(&self.z, lay, &mut self.zp);
        evaluation::evaluate(p, &self.zp, level, &mut self.ev, &mut self.term, stats)
    }

    /// Sets the trial point `z + alpha dz`, `s + alpha ds`.
    pub(super) fn set(&mut self, it: &Iterate, step: &Step, alpha: f64) {
        for i in 0..it.z.len() {
            self.z[i] = it.z[i] + alpha * step.dz[i];
        }
        for j in 0..it.s.len() {
            self.s[j] = it.s[j] + alpha * step.ds[j];
        }
    }
}

impl Step {
    /// A zero step for `nz` variables, `nl` dynamics rows and `nc` stage rows.
    pub(super) fn zeros(nz: usize, nl: usize, nc: usize) -> Self {
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
    pub(super) fn copy_from(&mut self, other: &Step) {
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

/// Copies `z` into the problem's shape `zp`.
pub(super) fn scatter_primal(z: &[f64], lay: &Layout, zp: &mut Primal) {
    for k in 0..=lay.kk {
        let o = lay.oz[k];
        let nx = lay.nx[k];
        zp.x[k].copy_from_slice(&z[o..o + nx]);
        zp.u[k].copy_from_slice(&z[o + nx..lay.oz[k + 1]]);
    }
}
