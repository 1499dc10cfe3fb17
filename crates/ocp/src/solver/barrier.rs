//! The barrier-parameter strategies ([`MuStrategy`]): monotone (Fiacco-McCormick: mu falls by
//! `min(kappa_mu mu, mu^theta_mu)` whenever the barrier problem is solved to `kappa_eps mu`) and
//! adaptive (Mehrotra's probing sets mu every iteration from an affine step with the same
//! factorisation while the optimality error keeps falling, the monotone rule otherwise).

use super::kkt::Centring;
use super::residuals::Residuals;
use super::workspace::OcpSolver;
use crate::settings::{MuStrategy, OcpSettings, OcpStats};

// IPOPT's constants (Waechter & Biegler 2006, Table 1).
const KAPPA_EPS: f64 = 10.0;
const KAPPA_MU: f64 = 0.2;
const THETA_MU: f64 = 1.5;
// Adaptive mu (IPOPT's defaults for its free mode): the optimality errors remembered, the factor
// by which the error must fall below their largest, the monotone mu at the switch as a fraction of
// the average complementarity, the cap on mu as a multiple of the first average, the largest
// centring parameter.
const KKT_REF_ITERS: usize = 4;
const KKT_REF_FACTOR: f64 = 0.9999;
const MONOTONE_INIT_FACTOR: f64 = 0.8;
const MU_MAX_FACTOR: f64 = 1e3;
const SIGMA_MAX: f64 = 100.0;

/// The barrier parameter and the state of its strategy during one solve.
#[derive(Debug, Clone)]
pub(super) struct Barrier {
    /// The barrier parameter.
    pub(super) mu: f64,
    /// Its floor, `tol / 10`.
    mu_min: f64,
    adaptive: bool,
    /// Adaptive strategy: in its free mode (probing), the optimality errors of the last
    /// iterations there, how many were recorded, and the cap on mu (set by the first probe).
    free_mode: bool,
    kkt_ref: [f64; KKT_REF_ITERS],
    kkt_count: usize,
    mu_max: f64,
}

impl Barrier {
    /// The strategy of `st`, from `mu_init`.
    pub(super) fn new(st: &OcpSettings) -> Self {
        let adaptive = st.mu_strategy == MuStrategy::Adaptive;
        Barrier {
            mu: st.mu_init,
            mu_min: st.tol / 10.0,
            adaptive,
            free_mode: adaptive,
            kkt_ref: [0.0; KKT_REF_ITERS],
            kkt_count: 0,
            mu_max: f64::NAN,
        }
    }
}

impl OcpSolver {
    /// Updates the barrier parameter at the iterate with residuals `res`. Returns whether this
    /// iteration probes for mu (adaptive strategy in its free mode, outside restoration), which
    /// then sets mu in [`Self::probing_direction`]. Every change of mu empties the filter.
    pub(super) fn update_barrier(&mut self, b: &mut Barrier, res: &Residuals) -> bool {
        let in_resto = self.resto.active();
        // adaptive mu: free mode while the optimality error keeps falling
        if b.adaptive && !in_resto {
            if b.free_mode {
                let e = res.e0();
                let n = b.kkt_count.min(KKT_REF_ITERS);
                let e_ref = b.kkt_ref[..n].iter().fold(0.0_f64, |a, b| a.max(*b));
                if n == 0 || e <= KKT_REF_FACTOR * e_ref {
                    b.kkt_ref[b.kkt_count % KKT_REF_ITERS] = e;
                    b.kkt_count += 1;
                } else {
                    b.free_mode = false;
                    let (sum, nb) = self.complementarity(0.0, 0.0);
                    if nb > 0 {
                        b.mu = b.mu_min.max(MONOTONE_INIT_FACTOR * sum / nb as f64);
                    }
                    self.filter.clear();
                }
            } else if self.e_mu(res, b.mu) <= KAPPA_EPS * b.mu {
                b.free_mode = true;
                b.kkt_ref[0] = res.e0();
                b.kkt_count = 1;
            }
        }
        let probing = b.adaptive && b.free_mode && !in_resto;
        // monotone barrier update
        if !probing {
            while b.mu > b.mu_min && self.e_mu(res, b.mu) <= KAPPA_EPS * b.mu {
                b.mu = b.mu_min.max((KAPPA_MU * b.mu).min(b.mu.powf(THETA_MU)));
                self.filter.clear();
            }
        }
        probing
    }

    /// The Newton step of the adaptive strategy's free mode: factorise once, take the affine
    /// step (mu = 0), set `mu = sigma mu_avg` with `sigma = (mu_aff / mu_avg)^3` from the
    /// complementarity the affine step reaches (Mehrotra's probing), then the step for that mu.
    pub(super) fn probing_direction(
        &mut self,
        b: &mut Barrier,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        self.factor(0.0, stats)?;
        let (sum, nb) = self.complementarity(0.0, 0.0);
        if nb > 0 {
            let avg = sum / nb as f64;
            if b.mu_max.is_nan() {
                b.mu_max = MU_MAX_FACTOR * avg.max(b.mu);
            }
            self.solve_rhs(Centring::Mu(0.0), stats)?;
            let (ap, ad) = self.max_step(1.0);
            let (sum_aff, _) = self.complementarity(ap, ad);
            let sigma = (sum_aff / sum).max(0.0).powi(3).min(SIGMA_MAX);
            b.mu = (sigma * avg).min(b.mu_max).max(b.mu_min);
        } else {
            b.mu = b.mu_min;
        }
        self.filter.clear();
        self.solve_rhs(Centring::Mu(b.mu), stats)
    }
}
