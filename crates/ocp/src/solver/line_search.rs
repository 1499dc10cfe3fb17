//! IPOPT's filter line search (Waechter & Biegler 2006, sections 2.3 to 2.4): the largest step to
//! the boundary (fraction to the boundary), backtracking from it with the filter's acceptance test
//! (switching condition, Armijo on the barrier function), and second-order corrections when a full
//! step raised the constraint violation.

use super::data::Kind;
use super::filter::Filter;
use super::kkt::Centring;
use super::restoration::phase_grad;
use super::workspace::OcpSolver;
use crate::problem::{EvalLevel, OcpProblem};
use crate::settings::{OcpSettings, OcpStats};

// IPOPT's constants (Waechter & Biegler 2006, Table 1 and the implementation's defaults).
const GAMMA_THETA: f64 = 1e-5;
const GAMMA_PHI: f64 = 1e-5;
const DELTA_SW: f64 = 1.0;
const GAMMA_ALPHA: f64 = 0.05;
const S_THETA: f64 = 1.1;
const S_PHI: f64 = 2.3;
const ETA_PHI: f64 = 1e-4;
const KAPPA_SOC: f64 = 0.99;

/// The line-search reference values of one iteration.
#[derive(Debug, Clone, Copy)]
pub(super) struct LineSearch {
    /// Violation (l1) and barrier function at the iterate, and the slope of the barrier function
    /// along the step.
    pub(super) theta0: f64,
    pub(super) phi0: f64,
    gphi: f64,
    theta_min: f64,
    theta_max: f64,
}

/// A step the line search accepted.
#[derive(Debug, Clone, Copy)]
pub(super) struct Accepted {
    /// Primal step length (equality multipliers too) and dual step length (bound duals).
    pub(super) alpha: f64,
    pub(super) adual: f64,
    /// Violation of the original problem at the accepted point.
    pub(super) theta_orig: f64,
    /// An h-type step (it augments the filter).
    pub(super) h_type: bool,
    /// The trial's evaluation has first derivatives at the accepted point: the new iterate takes
    /// it over instead of being evaluated again.
    pub(super) evaluated: bool,
}

impl LineSearch {
    /// IPOPT's acceptance test of a trial point (theta `tt`, barrier function `phit`) for step
    /// length `alpha`: `Some(h_type)` if accepted (h-type iterations augment the filter).
    fn accepts(&self, filter: &Filter, tt: f64, phit: f64, alpha: f64) -> Option<bool> {
        if !(tt < self.theta_max && filter.acceptable(tt, phit)) {
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

    /// The smallest step length tried before the line search gives up.
    fn alpha_min(&self) -> f64 {
        if self.gphi < 0.0 {
            let mut a = GAMMA_THETA.min(GAMMA_PHI * self.theta0 / -self.gphi);
            if self.theta0 <= self.theta_min {
                a = a.min(DELTA_SW * self.theta0.powf(S_THETA) / (-self.gphi).powf(S_PHI));
            }
            GAMMA_ALPHA * a
        } else {
            GAMMA_ALPHA * GAMMA_THETA
        }
        .max(1e-14)
    }

    /// Adds the iterate's margin `((1 - gamma_theta) theta0, phi0 - gamma_phi theta0)` to `filter`
    /// (after an h-type step, and before the restoration phase).
    pub(super) fn augment(&self, filter: &mut Filter) {
        filter.add(
            (1.0 - GAMMA_THETA) * self.theta0,
            self.phi0 - GAMMA_PHI * self.theta0,
        );
    }
}

impl OcpSolver {
    /// Directional derivative of the barrier function of the current phase along the step.
    fn barrier_slope(&self, mu: f64) -> f64 {
        let lay = &self.data.lay;
        let mut d = self.resto.slope(self.data.nrows(), mu);
        let (data, it, step) = (&self.data, &self.it, &self.step);
        for k in 0..=lay.kk {
            let o = lay.oz[k];
            for li in 0..lay.nz(k) {
                let i = o + li;
                if data.kind[i] == Kind::Eliminated {
                    continue;
                }
                let mut gi = phase_grad(&self.resto, it, i, k, li);
                if data.kind[i] == Kind::Free {
                    if data.zlo[i].is_finite() {
                        gi -= mu / (it.z[i] - data.zlo[i]);
                    }
                    if data.zhi[i].is_finite() {
                        gi += mu / (data.zhi[i] - it.z[i]);
                    }
                }
                d += gi * step.dz[i];
            }
        }
        for j in 0..it.s.len() {
            let mut gj = 0.0;
            if data.clo[j].is_finite() {
                gj -= mu / (it.s[j] - data.clo[j]);
            }
            if data.chi[j].is_finite() {
                gj += mu / (data.chi[j] - it.s[j]);
            }
            d += gj * step.ds[j];
        }
        d
    }

    /// Evaluates the trial point `z + alpha dz` (slacks and restoration slacks likewise) at
    /// `level`: returns (theta of the phase, original theta, barrier function of the phase), or
    /// None if the evaluation failed or is not finite. A first-order evaluation that fails is
    /// repeated with values only (only the values decide about a trial point).
    fn trial(
        &mut self,
        p: &mut dyn OcpProblem,
        alpha: f64,
        mu: f64,
        level: EvalLevel,
        stats: &mut OcpStats,
    ) -> Option<(f64, f64, f64)> {
        self.trial.set(&self.it, &self.step, alpha);
        self.resto.set_trial(self.data.nrows(), alpha);
        let lay = &self.data.lay;
        if self.trial.evaluate(p, lay, level, stats).is_err() {
            if level == EvalLevel::Values {
                return None;
            }
            self.trial.evaluate(p, lay, EvalLevel::Values, stats).ok()?;
            self.trial.first_order = false;
        } else {
            self.trial.first_order = level == EvalLevel::FirstOrder;
        }
        let mut cv = std::mem::take(&mut self.trial.cv);
        let t = &self.trial;
        self.data.row_values(&t.z, &t.s, &t.ev, &t.term, &mut cv);
        let (to, _) = self.theta_of(&cv, None);
        // the phase's violation: relaxed by restoration's slacks while that phase runs
        let tt = match self.resto.slacks(true) {
            Some(pn) => self.theta_of(&cv, Some(pn)).0,
            None => to,
        };
        self.trial.cv = cv;
        let bt = self.barrier(true);
        let phit = self.phase_objective(true) + mu * bt;
        (tt.is_finite() && phit.is_finite()).then_some((tt, to, phit))
    }

    /// The filter line search along the step of this iteration, from the violation `theta0` at
    /// the iterate, for barrier parameter `mu` and fraction to the boundary `tau`; `centring` is
    /// how the step was computed (for the second-order corrections, which re-solve with the same
    /// factorisation). Returns the reference values and the accepted step, if any; an error if the
    /// step could not be restored after the corrections.
    pub(super) fn line_search(
        &mut self,
        p: &mut dyn OcpProblem,
        st: &OcpSettings,
        theta0: f64,
        mu: f64,
        tau: f64,
        centring: Centring,
        stats: &mut OcpStats,
    ) -> Result<(LineSearch, Option<Accepted>), String> {
        let in_resto = self.resto.active();
        let (amax, adual) = self.max_step(tau);
        let b0 = self.barrier(false);
        let phi0 = self.phase_objective(false) + mu * b0;
        let gphi = self.barrier_slope(mu);
        let tiny = self
            .it
            .z
            .iter()
            .zip(&self.step.dz)
            .all(|(z, d)| d.abs() <= 10.0 * f64::EPSILON * (1.0 + z.abs()));
        let ls = LineSearch {
            theta0,
            phi0,
            gphi,
            theta_min: self.filter.theta_min,
            theta_max: self.filter.theta_max,
        };
        let alpha_min = ls.alpha_min();
        let mut alpha = amax;
        let nrows = self.data.nrows();
        let mut first = true;
        loop {
            // the first trial point (the full step to the boundary) is usually accepted once the
            // iterates converge: while the last iteration's was, it is evaluated with first
            // derivatives, and becomes the next iterate without another evaluation
            let level = if first && self.trial.speculate {
                EvalLevel::FirstOrder
            } else {
                EvalLevel::Values
            };
            if let Some((tt, to, phit)) = self.trial(p, alpha, mu, level, stats) {
                let evaluated = self.trial.first_order;
                let accepted = |alpha, h_type| Accepted {
                    alpha,
                    adual,
                    theta_orig: to,
                    h_type,
                    evaluated,
                };
                if tiny {
                    self.trial.speculate = first;
                    return Ok((ls, Some(accepted(alpha, false))));
                }
                if let Some(h) = ls.accepts(&self.filter, tt, phit, alpha) {
                    self.trial.speculate = first;
                    return Ok((ls, Some(accepted(alpha, h))));
                }
                self.trial.speculate = false;
                // second-order correction (IPOPT section 2.4) when the full step raised theta
                // (from the trial's values as a value-only evaluation gives them: the same numbers
                // whatever the level, for any problem)
                let soc = first && !in_resto && st.max_soc > 0 && tt >= theta0;
                if soc
                    && (!self.trial.first_order
                        || self.trial(p, alpha, mu, EvalLevel::Values, stats).is_some())
                {
                    if let Some(a) = self.second_order_corrections(
                        p, &ls, alpha, mu, tau, centring, st.max_soc, stats,
                    ) {
                        return Ok((ls, Some(a)));
                    }
                    // back to the original direction
                    self.kkt.chat[..nrows].copy_from_slice(&self.it.cv[..nrows]);
                    self.solve_rhs(centring, stats)?;
                }
            }
            first = false;
            self.trial.speculate = false;
            alpha *= 0.5;
            // a cancelled solve stops between trials (the caller sees the flag and stops; the
            // iterate is unchanged)
            if alpha < alpha_min || st.cancel.as_ref().is_some_and(|c| c.is_cancelled()) {
                return Ok((ls, None));
            }
        }
    }

    /// Up to `max_soc` second-order corrections of the full step `alpha` (IPOPT section 2.4): the
    /// row residuals of the right-hand side become `a c^ + c(trial)`, re-solved with the same
    /// factorisation, while the violation falls by `kappa_soc`. Returns the accepted corrected
    /// step, if any (the step is left corrected either way).
    #[allow(clippy::too_many_arguments)]
    fn second_order_corrections(
        &mut self,
        p: &mut dyn OcpProblem,
        ls: &LineSearch,
        alpha: f64,
        mu: f64,
        tau: f64,
        centring: Centring,
        max_soc: usize,
        stats: &mut OcpStats,
    ) -> Option<Accepted> {
        let nrows = self.data.nrows();
        let mut a_soc = alpha;
        let mut th_old = ls.theta0;
        for _ in 0..max_soc {
            for i in 0..nrows {
                self.kkt.chat[i] = a_soc * self.kkt.chat[i] + self.trial.cv[i];
            }
            if self.solve_rhs(centring, stats).is_err() {
                return None;
            }
            let (ap, ad) = self.max_step(tau);
            let (ts, _, phis) = self.trial(p, ap, mu, EvalLevel::Values, stats)?;
            // Armijo and switching tests with the original step length (IPOPT)
            if let Some(h) = ls.accepts(&self.filter, ts, phis, alpha) {
                return Some(Accepted {
                    alpha: ap,
                    adual: ad,
                    theta_orig: ts,
                    h_type: h,
                    evaluated: false,
                });
            }
            if ts > KAPPA_SOC * th_old {
                return None;
            }
            th_old = ts;
            a_soc = ap;
        }
        None
    }
}
