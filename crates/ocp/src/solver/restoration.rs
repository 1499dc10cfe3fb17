//! IPOPT's l1 restoration phase (Waechter & Biegler 2006, section 3.3) as a problem of its own,
//! run by the same main loop:
//! ```text
//! min  rho ||p + n||_1 + zeta/2 ||D (z - z_R)||^2   s.t.  c(z) - p + n = 0,  p, n >= 0
//! ```
//! over every equality row (dynamics, stage rows `c - s`, terminal rows, fixed states), with
//! `zeta = sqrt(mu)` and `D = diag(min(1, 1/|z_R|))` at the point `z_R` where it starts. The
//! relaxation slacks `p, n` and their duals live here; the iteration sees them through the terms
//! this phase adds to the objective, the barrier, the residuals, the row residuals of the Newton
//! system (condensed: a diagonal per row, soft dynamics in the Riccati recursion) and the step.
//! Outside the phase every such term is neutral (nothing added, no bound on the step), so the
//! shared routines read the same for both problems.

use super::data::{Kind, ProblemData};
use super::filter::Filter;
use super::iterate::{safeguard, Iterate, Step};
use crate::settings::{OcpStatus, MAX_EQUALITY_ROWS};

/// Penalty on the l1 relaxation slacks p, n (IPOPT's `resto_penalty_parameter`).
pub(super) const RHO_RESTO: f64 = 1e3;
/// Bound duals above this are reset to 1 when the original problem resumes.
const BOUND_MULT_RESET: f64 = 1e3;

/// What the phase remembers of the original problem.
#[derive(Debug, Clone, Copy)]
struct Origin {
    /// Original violation (l1) where the phase began.
    theta0: f64,
    /// The original barrier parameter.
    mu: f64,
    /// Weight of the proximity term.
    zeta: f64,
    /// Iterations spent in the phase.
    iters: usize,
}

/// The restoration problem: its state (active or not) and its workspace, allocated once.
pub(super) struct Restoration {
    origin: Option<Origin>,
    /// Relaxation slacks per row, their duals, their steps and their trial values.
    p: Vec<f64>,
    n: Vec<f64>,
    zp: Vec<f64>,
    zn: Vec<f64>,
    dp: Vec<f64>,
    dn: Vec<f64>,
    dzp: Vec<f64>,
    dzn: Vec<f64>,
    p_t: Vec<f64>,
    n_t: Vec<f64>,
    /// The reference point z_R and the scaling D of the proximity term.
    z_ref: Vec<f64>,
    dr: Vec<f64>,
    /// The original problem's filter while the phase runs.
    pub(super) filter_orig: Filter,
}

impl Restoration {
    /// Allocates for `nz` variables and at most `rows` equality rows.
    pub(super) fn new(nz: usize, rows: usize) -> Self {
        let rows = rows + MAX_EQUALITY_ROWS;
        Restoration {
            origin: None,
            p: vec![0.0; rows],
            n: vec![0.0; rows],
            zp: vec![0.0; rows],
            zn: vec![0.0; rows],
            dp: vec![0.0; rows],
            dn: vec![0.0; rows],
            dzp: vec![0.0; rows],
            dzn: vec![0.0; rows],
            p_t: vec![0.0; rows],
            n_t: vec![0.0; rows],
            z_ref: vec![0.0; nz],
            dr: vec![0.0; nz],
            filter_orig: Filter::default(),
        }
    }

    /// Whether the phase runs.
    pub(super) fn active(&self) -> bool {
        self.origin.is_some()
    }

    /// Leaves the phase without returning (a new solve).
    pub(super) fn reset(&mut self) {
        self.origin = None;
    }

    /// The relaxation slacks (p, n) at the iterate or at the trial point, if the phase runs.
    pub(super) fn slacks(&self, trial: bool) -> Option<(&[f64], &[f64])> {
        self.active().then(|| {
            if trial {
                (&self.p_t[..], &self.n_t[..])
            } else {
                (&self.p[..], &self.n[..])
            }
        })
    }

    /// The weight of the problem's cost in the phase's objective (0 in restoration, whose
    /// objective is its own).
    pub(super) fn cost_weight(&self) -> f64 {
        if self.active() {
            0.0
        } else {
            1.0
        }
    }

    /// The original barrier parameter, if the phase runs.
    pub(super) fn mu_orig(&self) -> Option<f64> {
        self.origin.map(|o| o.mu)
    }

    /// Counts an iteration of the phase; false once more than `max` were spent.
    pub(super) fn count_iteration(&mut self, max: usize) -> bool {
        match self.origin.as_mut() {
            Some(o) => {
                o.iters += 1;
                o.iters <= max
            }
            None => true,
        }
    }

    /// Gradient of the phase's proximity term, entry i, at `z`.
    pub(super) fn gradient(&self, z: &[f64], i: usize) -> f64 {
        let zeta = self.origin.map_or(0.0, |o| o.zeta);
        zeta * self.dr[i] * self.dr[i] * (z[i] - self.z_ref[i])
    }

    /// Hessian of the proximity term, diagonal entry i.
    pub(super) fn hessian(&self, i: usize) -> f64 {
        let zeta = self.origin.map_or(0.0, |o| o.zeta);
        zeta * self.dr[i] * self.dr[i]
    }

    /// The phase's objective at `z` with the slacks of the iterate or of the trial point.
    pub(super) fn objective(&self, z: &[f64], nrows: usize, trial: bool) -> f64 {
        let zeta = self.origin.map_or(0.0, |o| o.zeta);
        let (p, n) = if trial {
            (&self.p_t, &self.n_t)
        } else {
            (&self.p, &self.n)
        };
        let mut v = 0.0;
        for i in 0..z.len() {
            let d = self.dr[i] * (z[i] - self.z_ref[i]);
            v += d * d;
        }
        let mut l1 = 0.0;
        for i in 0..nrows {
            l1 += p[i] + n[i];
        }
        0.5 * zeta * v + RHO_RESTO * l1
    }

    /// Largest dual residual of the slacks' optimality conditions (`rho -+ l - z_p,n`), given the
    /// iterate's row multipliers.
    pub(super) fn dual_inf(&self, it: &Iterate, data: &ProblemData, dual_inf: f64) -> f64 {
        if !self.active() {
            return dual_inf;
        }
        let (nl, nc, nr) = (data.lay.n_l(), data.lay.n_c(), data.dims.n_terminal);
        let mut d = dual_inf;
        for i in 0..data.nrows() {
            let l = it.row_multiplier(i, nl, nc, nr);
            d = d
                .max((RHO_RESTO - l - self.zp[i]).abs())
                .max((RHO_RESTO + l - self.zn[i]).abs());
        }
        d
    }

    /// Adds the slacks' complementarity (largest product, and the sum and number of the duals for
    /// the scaling) to `comp`, `bsum`, `nb`.
    pub(super) fn complementarity(
        &self,
        nrows: usize,
        comp: &mut f64,
        bsum: &mut f64,
        nb: &mut usize,
    ) {
        if !self.active() {
            return;
        }
        for i in 0..nrows {
            *comp = comp
                .max((self.p[i] * self.zp[i]).abs())
                .max((self.n[i] * self.zn[i]).abs());
            *bsum += self.zp[i] + self.zn[i];
            *nb += 2;
        }
    }

    /// Largest deviation of the slacks' complementarity products from `mu`.
    pub(super) fn centrality(&self, nrows: usize, mu: f64) -> f64 {
        let mut comp = 0.0_f64;
        if !self.active() {
            return comp;
        }
        for i in 0..nrows {
            comp = comp
                .max((self.p[i] * self.zp[i] - mu).abs())
                .max((self.n[i] * self.zn[i] - mu).abs());
        }
        comp
    }

    /// Per row: the residual `c^` of the Newton system and its regularisation `D` (the condensed
    /// slacks p, n: `D = 1/S_p + 1/S_n`); outside the phase `c^ = c`, `D = 0`.
    pub(super) fn newton_rows(
        &self,
        nrows: usize,
        cv: &[f64],
        mu: f64,
        chat: &mut [f64],
        dreg: &mut [f64],
    ) {
        for i in 0..nrows {
            if self.active() {
                let (p, n) = (self.p[i], self.n[i]);
                let (sp, sn) = (self.zp[i] / p, self.zn[i] / n);
                dreg[i] = 1.0 / sp + 1.0 / sn;
                chat[i] = cv[i] - p + n + (RHO_RESTO - mu / p) / sp - (RHO_RESTO - mu / n) / sn;
            } else {
                dreg[i] = 0.0;
                chat[i] = cv[i];
            }
        }
    }

    /// The slacks' steps from the new row multipliers of the Newton step:
    /// `dp = (l+ - rho + mu/p)/S_p`, `dn = (-l+ - rho + mu/n)/S_n`, and their duals' steps.
    pub(super) fn recover_step(&mut self, step: &Step, data: &ProblemData, mu: f64) {
        if !self.active() {
            return;
        }
        let (nl, ncall) = (data.lay.n_l(), data.lay.n_c());
        for i in 0..data.nrows() {
            let lp = if i < nl {
                step.lam_n[i]
            } else if i < nl + ncall {
                step.y_n[i - nl]
            } else {
                step.eqm_n[i - nl - ncall]
            };
            let (p, n) = (self.p[i], self.n[i]);
            let (sp, sn) = (self.zp[i] / p, self.zn[i] / n);
            self.dp[i] = (lp - RHO_RESTO + mu / p) / sp;
            self.dn[i] = (-lp - RHO_RESTO + mu / n) / sn;
            self.dzp[i] = mu / p - self.zp[i] - sp * self.dp[i];
            self.dzn[i] = mu / n - self.zn[i] - sn * self.dn[i];
        }
    }

    /// The largest primal and dual steps `(ap, ad)` (from 1) that keep the slacks and their duals
    /// a fraction `tau` inside.
    pub(super) fn max_step(&self, nrows: usize, tau: f64) -> (f64, f64) {
        let (mut ap, mut ad) = (1.0_f64, 1.0_f64);
        if !self.active() {
            return (ap, ad);
        }
        for i in 0..nrows {
            for (v, d) in [(self.p[i], self.dp[i]), (self.n[i], self.dn[i])] {
                if d < 0.0 {
                    ap = ap.min(-tau * v / d);
                }
            }
            for (v, d) in [(self.zp[i], self.dzp[i]), (self.zn[i], self.dzn[i])] {
                if d < 0.0 {
                    ad = ad.min(-tau * v / d);
                }
            }
        }
        (ap, ad)
    }

    /// The slacks' barrier `-sum ln p + ln n` at the iterate or the trial point.
    pub(super) fn barrier(&self, nrows: usize, trial: bool) -> f64 {
        let mut b = 0.0;
        let Some((p, n)) = self.slacks(trial) else {
            return b;
        };
        for i in 0..nrows {
            b -= p[i].ln() + n[i].ln();
        }
        b
    }

    /// Directional derivative of the slacks' part of the barrier function along their step.
    pub(super) fn slope(&self, nrows: usize, mu: f64) -> f64 {
        let mut d = 0.0;
        if !self.active() {
            return d;
        }
        for i in 0..nrows {
            d += (RHO_RESTO - mu / self.p[i]) * self.dp[i]
                + (RHO_RESTO - mu / self.n[i]) * self.dn[i];
        }
        d
    }

    /// Sets the slacks' trial point `p + alpha dp`, `n + alpha dn`.
    pub(super) fn set_trial(&mut self, nrows: usize, alpha: f64) {
        if !self.active() {
            return;
        }
        for i in 0..nrows {
            self.p_t[i] = self.p[i] + alpha * self.dp[i];
            self.n_t[i] = self.n[i] + alpha * self.dn[i];
        }
    }

    /// Moves the slacks to their trial point and their duals by `adual` (safeguarded).
    pub(super) fn accept(&mut self, nrows: usize, adual: f64, mu: f64) {
        if !self.active() {
            return;
        }
        std::mem::swap(&mut self.p, &mut self.p_t);
        std::mem::swap(&mut self.n, &mut self.n_t);
        for i in 0..nrows {
            let v = self.zp[i] + adual * self.dzp[i];
            self.zp[i] = safeguard(v, self.p[i], mu);
            let v = self.zn[i] + adual * self.dzn[i];
            self.zn[i] = safeguard(v, self.n[i], mu);
        }
    }

    /// Starts the phase at the iterate `it` (rows `it.cv`, original violation `theta0`, barrier
    /// parameter `mu`, largest row violation `theta_inf`): the reference point and its scaling,
    /// slacks that satisfy the rows with complementarity `mu_r = min(max(mu, theta_inf), 100)`,
    /// bound duals capped at rho and zero equality multipliers; `filter` (already augmented)
    /// is kept as the original filter and emptied for the phase. Returns the phase's `mu_r`.
    pub(super) fn enter(
        &mut self,
        it: &mut Iterate,
        data: &ProblemData,
        filter: &mut Filter,
        theta0: f64,
        mu: f64,
        theta_inf: f64,
    ) -> f64 {
        self.filter_orig.copy_from(filter);
        let mu_r = mu.max(theta_inf).min(1e2);
        for i in 0..it.z.len() {
            self.z_ref[i] = it.z[i];
            self.dr[i] = if data.kind[i] == Kind::Eliminated {
                0.0
            } else {
                1.0_f64.min(1.0 / it.z[i].abs())
            };
        }
        for i in 0..data.nrows() {
            let c = it.cv[i];
            let q = (mu_r - RHO_RESTO * c) / (2.0 * RHO_RESTO);
            let n = q + (q * q + mu_r * c / (2.0 * RHO_RESTO)).sqrt();
            let n = n.max(1e-12 * mu_r);
            self.n[i] = n;
            self.p[i] = (c + n).max(1e-12 * mu_r);
            self.zp[i] = mu_r / self.p[i];
            self.zn[i] = mu_r / self.n[i];
        }
        for v in it.zl.iter_mut().chain(it.zu.iter_mut()) {
            *v = v.min(RHO_RESTO);
        }
        for v in it.vl.iter_mut().chain(it.vu.iter_mut()) {
            *v = v.min(RHO_RESTO);
        }
        self.origin = Some(Origin {
            theta0,
            mu,
            zeta: mu_r.sqrt(),
            iters: 0,
        });
        it.clear_equality_multipliers();
        filter.clear();
        mu_r
    }

    /// Whether the accepted point (original violation `theta`, original barrier function `phi`)
    /// ends the phase: the violation fell to 0.9 of its value at entry and the original filter
    /// accepts the point.
    pub(super) fn may_return(&self, theta: f64, phi: f64) -> bool {
        self.origin
            .is_some_and(|o| theta <= 0.9 * o.theta0 && self.filter_orig.acceptable(theta, phi))
    }

    /// Ends the phase: the original filter and its limits come back into `filter`, the
    /// equality multipliers are zeroed (to be re-estimated) and large bound duals reset. Returns
    /// the original barrier parameter.
    pub(super) fn leave(&mut self, it: &mut Iterate, filter: &mut Filter) -> f64 {
        let o = self
            .origin
            .take()
            .expect("leave outside the restoration phase");
        std::mem::swap(filter, &mut self.filter_orig);
        filter.theta_min = 1e-4 * (filter.theta_max / 1e4);
        it.clear_equality_multipliers();
        for v in it
            .zl
            .iter_mut()
            .chain(it.zu.iter_mut())
            .chain(it.vl.iter_mut())
            .chain(it.vu.iter_mut())
        {
            if *v > BOUND_MULT_RESET {
                *v = 1.0;
            }
        }
        o.mu
    }

    /// The status when the phase ends without returning: locally infeasible if the original
    /// violation `theta` is still at least half of its value at entry, else restoration failed.
    pub(super) fn failure(&self, theta: f64) -> OcpStatus {
        match self.origin {
            Some(o) if theta >= 0.5 * o.theta0 => OcpStatus::LocallyInfeasible,
            Some(_) => OcpStatus::RestorationFailed,
            None => OcpStatus::LocallyInfeasible,
        }
    }
}

/// Gradient of the objective of the current phase at the iterate, entry i (stage k, local index
/// li): the problem's cost, or restoration's proximity term.
pub(super) fn phase_grad(resto: &Restoration, it: &Iterate, i: usize, k: usize, li: usize) -> f64 {
    if resto.active() {
        resto.gradient(&it.z, i)
    } else {
        it.ev[k].grad[li]
    }
}
