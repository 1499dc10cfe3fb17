//! The main loop of the interior-point method (Waechter & Biegler 2006, Algorithm A), the same for
//! the original problem and the restoration phase:
//! optimality test -> barrier update -> Newton step (with correctors) -> filter line search ->
//! accept the step, or enter restoration when no step is acceptable -> leave restoration when the
//! original problem accepts the point.

use super::barrier::Barrier;
use super::kkt::Centring;
use super::line_search::{Accepted, LineSearch};
use super::residuals::{cost, Residuals};
use super::workspace::OcpSolver;
use crate::problem::{EvalLevel, OcpProblem};
use crate::settings::{OcpSettings, OcpStats, OcpStatus};
use std::time::Instant;

/// Smallest fraction to the boundary (`tau = max(tau_min, 1 - mu)`).
const TAU_MIN: f64 = 0.99;

impl OcpSolver {
    /// Runs the iterations from the starting point to a status.
    pub(super) fn run(
        &mut self,
        p: &mut dyn OcpProblem,
        st: &OcpSettings,
        stats: &mut OcpStats,
        t0: Instant,
    ) -> OcpStatus {
        if let Err(status) = self.start(p, st, stats) {
            return status;
        }
        let mut barrier = Barrier::new(st);
        let mut acceptable_count = 0usize;
        let mut iter = 0usize;
        // the residuals of the original problem at the iterate as it stands, if computed (for
        // `finish`): from the top of an iteration until its step is accepted
        let mut current: Option<Residuals>;
        let status = loop {
            let res = self.residuals();
            current = (!self.resto.active()).then_some(res);
            stats.iterations = iter;
            if let Some(m) = &st.iteration_mark {
                m.reached(iter);
            }
            if let Some(status) = self.stop_test(&res, st, &mut acceptable_count, iter, t0) {
                break status;
            }
            let probing = self.update_barrier(&mut barrier, &res);
            let in_resto = self.resto.active();
            // the Newton step (the Hessian of the Lagrangian without the cost in restoration)
            let sigma = self.resto.cost_weight();
            if let Err(e) = self.it.hessians(p, &self.data.lay, sigma, stats) {
                break OcpStatus::EvaluationError(e);
            }
            // the flag is also checked between the phases of an iteration (the iterate is unchanged
            // until a step is accepted), so a long iteration stops at its next phase
            if cancelled(st) {
                break OcpStatus::Cancelled;
            }
            let step = if probing {
                self.probing_direction(&mut barrier, stats)
            } else {
                self.direction(barrier.mu, stats)
            };
            if let Err(e) = step {
                break OcpStatus::NumericalError(e);
            }
            if cancelled(st) {
                break OcpStatus::Cancelled;
            }
            let mu = barrier.mu;
            let tau = TAU_MIN.max(1.0 - mu);
            let centring = if st.centrality_correctors > 0 && !in_resto {
                match self.centrality_correctors(mu, tau, st.centrality_correctors, stats) {
                    Ok(c) => c,
                    Err(e) => break OcpStatus::NumericalError(e),
                }
            } else {
                Centring::Mu(mu)
            };
            // the filter line search
            let tl = Instant::now();
            let eval_before = stats.time.evaluation_s;
            let searched = self.line_search(p, st, res.theta_1, mu, tau, centring, stats);
            let (ls, accepted) = match searched {
                Ok(r) => r,
                Err(e) => break OcpStatus::NumericalError(e),
            };
            let ls_eval = stats.time.evaluation_s - eval_before;
            if cancelled(st) {
                stats.time.line_search_s += tl.elapsed().as_secs_f64() - ls_eval;
                break OcpStatus::Cancelled;
            }
            let Some(acc) = accepted else {
                stats.time.line_search_s += tl.elapsed().as_secs_f64() - ls_eval;
                if in_resto {
                    let (t1, _) = self.theta_current();
                    break self.resto.failure(t1);
                }
                if res.e0() <= st.acceptable_tol
                    && res.theta_inf <= st.acceptable_tol.max(st.constr_viol_tol)
                {
                    break OcpStatus::SolvedToAcceptableLevel;
                }
                self.enter_restoration(&ls, &mut barrier, &res);
                iter += 1;
                continue;
            };
            current = None;
            let phi_orig = self.accept(&ls, &acc, mu);
            stats.time.line_search_s += tl.elapsed().as_secs_f64() - ls_eval;
            if acc.evaluated {
                // the trial's evaluation at this very point, first derivatives included
                self.it.take_evaluation(&mut self.trial);
            } else if let Err(e) = self
                .it
                .evaluate(p, &self.data.lay, EvalLevel::FirstOrder, stats)
            {
                break OcpStatus::EvaluationError(e);
            }
            iter += 1;
            if let Some(phio) = phi_orig {
                if self.resto.may_return(acc.theta_orig, phio) {
                    barrier.mu = self.resto.leave(&mut self.it, &mut self.filter);
                    self.least_squares_multipliers();
                    self.kkt.delta_w_last = 0.0;
                }
            }
        };
        stats.iterations = iter;
        self.resto.reset();
        self.finish(stats, barrier.mu, current);
        status
    }

    /// The tests at the top of an iteration with residuals `res`: convergence (tol and
    /// constr_viol_tol, or the acceptable test for `acceptable_iter` iterations in a row, counted
    /// in `acceptable_count`), a restoration phase that converged (locally infeasible), the
    /// iteration and time limits, and the restoration phase's iteration limit.
    fn stop_test(
        &mut self,
        res: &Residuals,
        st: &OcpSettings,
        acceptable_count: &mut usize,
        iter: usize,
        t0: Instant,
    ) -> Option<OcpStatus> {
        if !self.resto.active() {
            let e0 = res.e0();
            if e0 <= st.tol && res.theta_inf <= st.constr_viol_tol {
                return Some(OcpStatus::Solved);
            }
            if st.acceptable_iter > 0
                && e0 <= st.acceptable_tol
                && res.theta_inf <= st.acceptable_tol.max(st.constr_viol_tol)
            {
                *acceptable_count += 1;
                if *acceptable_count >= st.acceptable_iter {
                    return Some(OcpStatus::SolvedToAcceptableLevel);
                }
            } else {
                *acceptable_count = 0;
            }
        } else if res.e0() <= st.tol.max(1e-10) {
            // the restoration problem converged without reaching a point the filter accepts:
            // a stationary point of the constraint violation
            return Some(OcpStatus::LocallyInfeasible);
        }
        if iter >= st.max_iter {
            return Some(OcpStatus::MaxIterations);
        }
        if let Some(tmax) = st.max_wall_time_s {
            if t0.elapsed().as_secs_f64() > tmax {
                return Some(OcpStatus::MaxWallTime);
            }
        }
        if cancelled(st) {
            return Some(OcpStatus::Cancelled);
        }
        if !self.resto.count_iteration(st.max_restoration_iter) {
            let (t1, _) = self.theta_current();
            return Some(self.resto.failure(t1));
        }
        None
    }

    /// Accepts the step `acc` of the line search `ls` (h-type steps augment the filter): the
    /// iterate moves to the trial point, multipliers and bound duals (and restoration's slacks)
    /// follow. Returns, in restoration, the original barrier function at the new point (for the
    /// test that ends the phase).
    fn accept(&mut self, ls: &LineSearch, acc: &Accepted, mu: f64) -> Option<f64> {
        if acc.h_type {
            ls.augment(&mut self.filter);
        }
        self.it.accept(
            &mut self.trial,
            &self.step,
            &self.data,
            acc.alpha,
            acc.adual,
            mu,
        );
        self.resto.accept(self.data.nrows(), acc.adual, mu);
        let (data, it) = (&self.data, &self.it);
        self.resto
            .mu_orig()
            .map(|mu_orig| cost(&self.trial.ev) + mu_orig * data.barrier_from(0.0, &it.z, &it.s))
    }

    /// Enters the restoration phase (IPOPT section 3.3) from the iterate where the line search
    /// `ls` failed: the filter is augmented by the iterate and kept as the original one, the
    /// phase starts with its own barrier parameter, an empty filter whose limits come from the
    /// relaxed violation, and a fresh inertia correction.
    fn enter_restoration(&mut self, ls: &LineSearch, barrier: &mut Barrier, res: &Residuals) {
        ls.augment(&mut self.filter);
        let theta0 = ls.theta0;
        barrier.mu = self.resto.enter(
            &mut self.it,
            &self.data,
            &mut self.filter,
            theta0,
            barrier.mu,
            res.theta_inf,
        );
        let (tr, _) = self.theta_of(&self.it.cv, self.resto.slacks(false));
        self.filter.set_limits(tr.max(theta0), tr);
        self.kkt.delta_w_last = 0.0;
    }
}

/// True once the cancel flag of `st` ([`OcpSettings::cancel`]) is set.
fn cancelled(st: &OcpSettings) -> bool {
    st.cancel.as_ref().is_some_and(|c| c.is_cancelled())
}
