//! The Newton step of one iteration on the current phase's problem: factorisation of the KKT
//! system with inertia correction, the solves and the recovery of the whole step (restoration's
//! slacks included while it runs), the largest step to the boundary, and Gondzio's centrality
//! correctors with the same factorisation.

use super::data::Kind;
use super::kkt::Centring;
use super::workspace::OcpSolver;
use crate::settings::OcpStats;

// The trial step's increase delta, the band [beta_min mu, beta_max mu] of the complementarity
// products, and the fraction gamma of delta by which the step to the boundary must grow for a
// corrector to be kept (docs/ocp.md).
const CC_DELTA: f64 = 0.1;
const CC_BETA_MIN: f64 = 0.1;
const CC_BETA_MAX: f64 = 10.0;
const CC_GAMMA: f64 = 0.1;

impl OcpSolver {
    /// Condenses and factorises the KKT system at the iterate for barrier parameter `mu` (the row
    /// residuals of restoration read it), with inertia correction.
    pub(super) fn factor(&mut self, mu: f64, stats: &mut OcpStats) -> Result<(), String> {
        let nrows = self.data.nrows();
        self.kkt.set_rows(nrows, &self.it.cv, &self.resto, mu);
        self.kkt.factor(&self.data, &self.it, &self.resto, stats)
    }

    /// The Newton step for barrier parameter `mu`: factorisation and solve.
    pub(super) fn direction(&mut self, mu: f64, stats: &mut OcpStats) -> Result<(), String> {
        self.factor(mu, stats)?;
        self.solve_rhs(Centring::Mu(mu), stats)
    }

    /// Solves with the current factorisation for the current row residuals and `centring`, and
    /// recovers the whole step (restoration's slacks included while it runs).
    pub(super) fn solve_rhs(
        &mut self,
        centring: Centring,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        let (data, it) = (&self.data, &self.it);
        self.kkt
            .solve(data, it, centring, &self.cc.ctarget, &mut self.step, stats)?;
        let mu = match centring {
            Centring::Mu(mu) => mu,
            Centring::Targets => f64::NAN,
        };
        self.resto.recover_step(&self.step, data, mu);
        Ok(())
    }

    /// Least-squares estimate of the equality multipliers at the iterate (see
    /// `KktSystem::least_squares`).
    pub(super) fn least_squares_multipliers(&mut self) {
        self.kkt
            .least_squares(&self.data, &mut self.it, &mut self.step);
    }

    /// Largest step in (0, 1] keeping the primal and the dual variables a fraction tau inside:
    /// `(alpha_primal, alpha_dual)` (restoration's slacks included while it runs).
    pub(super) fn max_step(&self, tau: f64) -> (f64, f64) {
        let (mut ap, mut ad) = self.resto.max_step(self.data.nrows(), tau);
        let (data, it, step) = (&self.data, &self.it, &self.step);
        for i in 0..it.z.len() {
            if data.kind[i] != Kind::Free {
                continue;
            }
            let d = step.dz[i];
            if data.zlo[i].is_finite() {
                if d < 0.0 {
                    ap = ap.min(-tau * (it.z[i] - data.zlo[i]) / d);
                }
                if step.dzl[i] < 0.0 {
                    ad = ad.min(-tau * it.zl[i] / step.dzl[i]);
                }
            }
            if data.zhi[i].is_finite() {
                if d > 0.0 {
                    ap = ap.min(tau * (data.zhi[i] - it.z[i]) / d);
                }
                if step.dzu[i] < 0.0 {
                    ad = ad.min(-tau * it.zu[i] / step.dzu[i]);
                }
            }
        }
        for j in 0..it.s.len() {
            let d = step.ds[j];
            if data.clo[j].is_finite() {
                if d < 0.0 {
                    ap = ap.min(-tau * (it.s[j] - data.clo[j]) / d);
                }
                if step.dvl[j] < 0.0 {
                    ad = ad.min(-tau * it.vl[j] / step.dvl[j]);
                }
            }
            if data.chi[j].is_finite() {
                if d > 0.0 {
                    ap = ap.min(tau * (data.chi[j] - it.s[j]) / d);
                }
                if step.dvu[j] < 0.0 {
                    ad = ad.min(-tau * it.vu[j] / step.dvu[j]);
                }
            }
        }
        (ap, ad)
    }

    /// Gondzio's multiple centrality correctors on the step just computed (outside the
    /// restoration phase): while the largest step to the boundary `alpha_p` (primal) or `alpha_d`
    /// (dual) is below 1, take the trial point `alpha_p + delta`, `alpha_d + delta` along the step,
    /// move each bound's complementarity product there into `[beta_min mu, beta_max mu]` (products
    /// below the band, negative ones of bounds the step passes included, are raised to its floor;
    /// those above it are lowered by at most `beta_max mu`), add the difference to that bound's
    /// target (`ctarget`, mu for every bound at first) and re-solve with the same factorisation.
    /// The bound duals follow from the same targets ([`Self::solve_rhs`]), so they stay consistent
    /// with the primal step. A corrector is kept if the shorter of the two steps to the boundary
    /// grows by at least `gamma delta`; otherwise the step before it is restored and the
    /// correctors stop. Returns the centring of the step kept.
    pub(super) fn centrality_correctors(
        &mut self,
        mu: f64,
        tau: f64,
        max: usize,
        stats: &mut OcpStats,
    ) -> Result<Centring, String> {
        let (mut ap, mut ad) = self.max_step(tau);
        let mut centring = Centring::Mu(mu);
        if ap >= 1.0 && ad >= 1.0 {
            return Ok(centring);
        }
        self.cc.ctarget.fill(mu);
        let (lo, hi) = (CC_BETA_MIN * mu, CC_BETA_MAX * mu);
        for _ in 0..max {
            let (tp, td) = ((ap + CC_DELTA).min(1.0), (ad + CC_DELTA).min(1.0));
            self.cc
                .raise_targets(&self.data, &self.it, &self.step, tp, td, lo, hi);
            self.solve_rhs(Centring::Targets, stats)?;
            let (np, nd) = self.max_step(tau);
            if np.min(nd) >= ap.min(ad) + CC_GAMMA * CC_DELTA {
                ap = np;
                ad = nd;
                centring = Centring::Targets;
                stats.centrality_correctors += 1;
                if ap >= 1.0 && ad >= 1.0 {
                    break;
                }
            } else {
                self.cc.undo(&mut self.step);
                break;
            }
        }
        Ok(centring)
    }
}
