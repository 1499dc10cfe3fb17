//! The public face of the solver: construction (which allocates everything), the stored
//! solution, the feedback gains and `solve`.

use super::correctors::Correctors;
use super::data::ProblemData;
use super::evaluation::panic_message;
use super::filter::Filter;
use super::iterate::{Iterate, Step, Trial};
use super::kkt::KktSystem;
use super::restoration::Restoration;
use super::workspace::OcpSolver;
use crate::problem::{Multipliers, OcpDims, OcpProblem, Primal};
use crate::riccati::Layout;
use crate::settings::{
    OcpError, OcpSettings, OcpStats, OcpStatus, OcpTimings, MAX_EQUALITY_ROWS, MAX_STAGE_VARIABLES,
};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

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
        let (nz, nl, nc) = (lay.n_z(), lay.n_l(), lay.n_c());
        Ok(OcpSolver {
            it: Iterate::new(dims, &lay),
            trial: Trial::new(dims, &lay),
            step: Step::zeros(nz, nl, nc),
            kkt: KktSystem::new(&lay),
            filter: Filter::default(),
            resto: Restoration::new(nz, nl + nc),
            cc: Correctors::new(nz, nl, nc),
            data: ProblemData::new(dims, lay),
        })
    }

    /// The stored iterate (the last solve's result; edit it through [`OcpSolver::primal_mut`] before
    /// a warm solve).
    pub fn primal(&self) -> &Primal {
        &self.it.zp
    }

    /// Mutable access to the stored iterate, e.g. to shift a solution in time before a warm solve.
    pub fn primal_mut(&mut self) -> &mut Primal {
        &mut self.it.zp
    }

    /// Multipliers of the stored iterate (see [`crate::problem`] for the signs).
    pub fn multipliers(&self) -> &Multipliers {
        &self.it.mult
    }

    /// The feedback gain `K_k` (`nu_k x nx_k`, row-major) of the last Riccati factorisation: the
    /// Newton step's inputs are `du_k = K_k dx_k + k_k` (docs/ocp.md section 3). After a converged
    /// solve it is the gain of the last iteration's Newton step, near the solution: the condensed
    /// barrier terms hold inputs and states at active bounds, and the equality-row penalty steers
    /// towards the terminal rows. Columns of fixed components of `x_0` and rows of fixed inputs are
    /// zero; all zero before the first factorisation. Panics if `k > K`.
    pub fn feedback_gain(&self, k: usize) -> &[f64] {
        &self.kkt.ric.kgain[self.data.lay.ok[k]..self.data.lay.ok[k + 1]]
    }

    /// Benchmark hook (not part of the API): recomputes the Newton step at the stored iterate of the
    /// last solve with barrier `mu` (condensing, Riccati factorisation with inertia correction,
    /// Schur complement, solves, step recovery). Returns false if there is no iterate or it failed.
    #[cfg(feature = "testing")]
    #[doc(hidden)]
    pub fn bench_newton_step(&mut self, mu: f64) -> bool {
        if !self.it.has_iterate {
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
        self.direction(mu, &mut stats).is_ok()
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
}
