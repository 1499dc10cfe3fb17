//! The starting point of a solve: cold (the problem's guess pushed inside its bounds, unit bound
//! duals, least-squares multipliers) or warm (the stored iterate and the multipliers the
//! [`WarmDuals`] choice keeps, pushed by `warm_bound_push`), and the filter's limits.

use super::data::{push_inside, Kind};
use super::workspace::OcpSolver;
use crate::problem::{EvalLevel, OcpProblem};
use crate::settings::{OcpSettings, OcpStats, OcpStatus, WarmDuals};
use std::panic::{catch_unwind, AssertUnwindSafe};

impl OcpSolver {
    /// Checks the problem against the solver, reads its bounds and sets the starting point, its
    /// evaluation with first derivatives, the slacks, the multipliers and an empty filter whose
    /// limits come from the violation there. Errs with the status that ends the solve.
    pub(super) fn start(
        &mut self,
        p: &mut dyn OcpProblem,
        st: &OcpSettings,
        stats: &mut OcpStats,
    ) -> Result<(), OcpStatus> {
        if p.dims() != &self.data.dims {
            return Err(OcpStatus::InvalidProblem(
                "the problem's dims differ from the solver's".to_string(),
            ));
        }
        self.data
            .read_bounds(p)
            .map_err(OcpStatus::InvalidProblem)?;
        let warm = st.warm_start && self.it.has_iterate;
        let lay = &self.data.lay;
        if warm {
            let zp = &self.it.zp;
            let shape_ok = zp.x.len() == lay.kk + 1
                && zp.u.len() == lay.kk + 1
                && (0..=lay.kk).all(|k| zp.x[k].len() == lay.nx[k] && zp.u[k].len() == lay.nu[k]);
            if !shape_ok {
                return Err(OcpStatus::InvalidProblem(
                    "the stored iterate was resized through primal_mut".to_string(),
                ));
            }
        }
        if !warm || self.data.fixed_rows.len() != self.it.eta_rows {
            self.it.eta.fill(0.0);
        }
        self.it.eta_rows = self.data.fixed_rows.len();
        self.initialize(p, st, warm);
        self.it.has_iterate = true;
        self.kkt.delta_w_last = 0.0;
        // a warm start keeps the equality-row penalty that last passed the inertia test: the
        // penalty changes neither the step nor the inertia (docs/ocp.md section 5), and starting
        // from 0 again costs the first iteration of every warm solve its failed factorisations
        if !warm {
            self.kkt.rho_eq_last = 0.0;
        }
        self.resto.reset();
        self.filter.reserve(st.max_iter + 2);
        self.resto.filter_orig.reserve(st.max_iter + 2);
        self.filter.clear();
        self.resto.filter_orig.clear();

        // slacks from c(z) at the initial point
        if let Err(e) = self
            .it
            .evaluate(p, &self.data.lay, EvalLevel::FirstOrder, stats)
        {
            self.finish(stats, st.mu_init, None);
            return Err(OcpStatus::EvaluationError(e));
        }
        self.initial_slacks(st, warm);
        // the stored equality multipliers only with `Stored`
        if !warm || st.warm_duals != WarmDuals::Stored {
            self.least_squares_multipliers();
        }
        let (th0, _) = self.theta_current();
        self.filter.set_limits(th0, th0);
        Ok(())
    }

    /// The slacks of the stage rows: `c(z)` (cold) or the stored ones (warm), pushed inside their
    /// bounds; centred duals if asked for.
    fn initial_slacks(&mut self, st: &OcpSettings, warm: bool) {
        let (lay, data, it) = (&self.data.lay, &self.data, &mut self.it);
        for k in 0..=lay.kk {
            for j in 0..lay.nc[k] {
                let jj = lay.oc[k] + j;
                let push = if warm {
                    st.warm_bound_push
                } else {
                    st.bound_push
                };
                let c = if warm { it.s[jj] } else { it.ev[k].c[j] };
                it.s[jj] = push_inside(data.clo[jj], data.chi[jj], c, push);
                if warm && st.warm_duals == WarmDuals::Centered {
                    let (lo, hi) = (data.clo[jj], data.chi[jj]);
                    it.vl[jj] = if lo.is_finite() {
                        st.mu_init / (it.s[jj] - lo)
                    } else {
                        0.0
                    };
                    it.vu[jj] = if hi.is_finite() {
                        st.mu_init / (hi - it.s[jj])
                    } else {
                        0.0
                    };
                }
            }
        }
    }

    /// Initial point: cold (guess pushed inside the bounds, unit bound duals, zero equality
    /// multipliers) or warm (the stored iterate, pushed by `warm_bound_push`).
    fn initialize(&mut self, p: &mut dyn OcpProblem, st: &OcpSettings, warm: bool) {
        if warm {
            self.it.gather_primal(&self.data.lay);
            let lay = &self.data.lay;
            for k in 0..=lay.kk {
                self.it.lam[lay.ol[k]..lay.ol[k + 1]].copy_from_slice(&self.it.mult.lam[k]);
                self.it.y[lay.oc[k]..lay.oc[k + 1]].copy_from_slice(&self.it.mult.mu[k]);
            }
            self.it.nu.copy_from_slice(&self.it.mult.nu);
            // a failed previous solve may leave non-finite values behind
            for v in self
                .it
                .lam
                .iter_mut()
                .chain(self.it.y.iter_mut())
                .chain(self.it.nu.iter_mut())
                .chain(self.it.eta.iter_mut())
                .chain(self.it.zl.iter_mut())
                .chain(self.it.zu.iter_mut())
                .chain(self.it.vl.iter_mut())
                .chain(self.it.vu.iter_mut())
                .chain(self.it.s.iter_mut())
            {
                if !v.is_finite() {
                    *v = 0.0;
                }
            }
        } else {
            for x in self.it.zp.x.iter_mut().chain(self.it.zp.u.iter_mut()) {
                x.fill(0.0);
            }
            let r = catch_unwind(AssertUnwindSafe(|| p.initial_guess(&mut self.it.zp)));
            if r.is_err() {
                // a panicking guess: start from zeros (the evaluation will tell whether that works)
                for x in self.it.zp.x.iter_mut().chain(self.it.zp.u.iter_mut()) {
                    x.fill(0.0);
                }
            }
            self.it.gather_primal(&self.data.lay);
            self.it.lam.fill(0.0);
            self.it.y.fill(0.0);
            self.it.nu.fill(0.0);
            self.it.eta.fill(0.0);
        }
        let push = if warm {
            st.warm_bound_push
        } else {
            st.bound_push
        };
        for i in 0..self.it.z.len() {
            match self.data.kind[i] {
                Kind::Free => {
                    self.it.z[i] =
                        push_inside(self.data.zlo[i], self.data.zhi[i], self.it.z[i], push);
                    if warm && st.warm_duals == WarmDuals::Centered {
                        self.it.zl[i] = if self.data.zlo[i].is_finite() {
                            st.mu_init / (self.it.z[i] - self.data.zlo[i])
                        } else {
                            0.0
                        };
                        self.it.zu[i] = if self.data.zhi[i].is_finite() {
                            st.mu_init / (self.data.zhi[i] - self.it.z[i])
                        } else {
                            0.0
                        };
                    } else if warm
                        && matches!(st.warm_duals, WarmDuals::Stored | WarmDuals::StoredBounds)
                    {
                        self.it.zl[i] = if self.data.zlo[i].is_finite() {
                            self.it.zl[i].max(1e-20)
                        } else {
                            0.0
                        };
                        self.it.zu[i] = if self.data.zhi[i].is_finite() {
                            self.it.zu[i].max(1e-20)
                        } else {
                            0.0
                        };
                    } else {
                        self.it.zl[i] = if self.data.zlo[i].is_finite() {
                            1.0
                        } else {
                            0.0
                        };
                        self.it.zu[i] = if self.data.zhi[i].is_finite() {
                            1.0
                        } else {
                            0.0
                        };
                    }
                }
                Kind::Eliminated => {
                    self.it.z[i] = self.data.zlo[i];
                    self.it.zl[i] = 0.0;
                    self.it.zu[i] = 0.0;
                }
                Kind::FixedRow => {
                    if !warm || !self.it.z[i].is_finite() {
                        self.it.z[i] = self.data.zlo[i];
                    }
                    self.it.zl[i] = 0.0;
                    self.it.zu[i] = 0.0;
                }
            }
        }
        if !warm || st.warm_duals == WarmDuals::Reset {
            self.it.vl.fill(1.0);
            self.it.vu.fill(1.0);
        }
        for j in 0..self.it.s.len() {
            if warm && matches!(st.warm_duals, WarmDuals::Stored | WarmDuals::StoredBounds) {
                self.it.vl[j] = self.it.vl[j].max(1e-20);
                self.it.vu[j] = self.it.vu[j].max(1e-20);
            }
            if !self.data.clo[j].is_finite() {
                self.it.vl[j] = 0.0;
            }
            if !self.data.chi[j].is_finite() {
                self.it.vu[j] = 0.0;
            }
        }
    }
}
