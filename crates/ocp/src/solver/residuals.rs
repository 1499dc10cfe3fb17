//! The optimality conditions at the iterate: dual infeasibility, constraint violation and
//! complementarity with IPOPT's scaling, the barrier error, the barrier function and the objective
//! of the phase (the problem's or restoration's), and the final violations of a solve.

use super::data::Kind;
use super::iterate::scatter_primal;
use super::restoration::phase_grad;
use super::workspace::OcpSolver;
use crate::problem::StageEval;
use crate::settings::OcpStats;
use brachia_linalg::gemv_t_acc;

/// Scaling threshold of the optimality error (IPOPT's `s_max`).
const S_MAX: f64 = 100.0;

/// Residuals of the optimality conditions at the current iterate.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct Residuals {
    pub(super) dual_inf: f64,
    pub(super) theta_inf: f64,
    pub(super) theta_1: f64,
    pub(super) compl_0: f64,
    pub(super) s_d: f64,
    pub(super) s_c: f64,
}

impl Residuals {
    /// IPOPT's scaled optimality error `E_0`.
    pub(super) fn e0(&self) -> f64 {
        (self.dual_inf / self.s_d)
            .max(self.theta_inf)
            .max(self.compl_0 / self.s_c)
    }
}

/// The problem's cost at evaluations `ev`.
pub(super) fn cost(ev: &[StageEval]) -> f64 {
    ev.iter().map(|e| e.cost).sum()
}

impl OcpSolver {
    /// (l1, inf) norms of the rows `cv` (relaxed by the restoration slacks if given).
    pub(super) fn theta_of(&self, cv: &[f64], pn: Option<(&[f64], &[f64])>) -> (f64, f64) {
        let (mut t1, mut ti) = (0.0_f64, 0.0_f64);
        for i in 0..self.data.nrows() {
            let v = match pn {
                Some((p, n)) => cv[i] - p[i] + n[i],
                None => cv[i],
            };
            t1 += v.abs();
            ti = ti.max(v.abs());
        }
        (t1, ti)
    }

    /// Refreshes the constraint rows `cv` at the iterate.
    fn refresh_rows(&mut self) {
        let mut cv = std::mem::take(&mut self.it.cv);
        let it = &self.it;
        self.data
            .row_values(&it.z, &it.s, &it.ev, &it.term, &mut cv);
        self.it.cv = cv;
    }

    /// Original constraint violation (l1, inf) at the iterate (refreshes `cv`).
    pub(super) fn theta_current(&mut self) -> (f64, f64) {
        self.refresh_rows();
        self.theta_of(&self.it.cv, None)
    }

    /// Barrier sum `-sum ln(slack)` over all bounded entries at the iterate or the trial point,
    /// the restoration slacks included while that phase runs.
    pub(super) fn barrier(&self, trial: bool) -> f64 {
        let b0 = self.resto.barrier(self.data.nrows(), trial);
        if trial {
            self.data.barrier_from(b0, &self.trial.z, &self.trial.s)
        } else {
            self.data.barrier_from(b0, &self.it.z, &self.it.s)
        }
    }

    /// Objective of the current phase at the iterate or the trial point (the problem's cost, or
    /// restoration's objective).
    pub(super) fn phase_objective(&self, trial: bool) -> f64 {
        let (z, ev) = if trial {
            (&self.trial.z, &self.trial.ev)
        } else {
            (&self.it.z, &self.it.ev)
        };
        if self.resto.active() {
            self.resto.objective(z, self.data.nrows(), trial)
        } else {
            cost(ev)
        }
    }

    /// Dual infeasibility, constraint violation and complementarity at the current iterate, for
    /// the current phase.
    pub(super) fn residuals(&mut self) -> Residuals {
        let lay = &self.data.lay;
        let mut rz = std::mem::take(&mut self.it.rz);
        let it = &self.it;
        for k in 0..=lay.kk {
            let (o, nz, nx1, nc) = (lay.oz[k], lay.nz(k), lay.nx1[k], lay.nc[k]);
            let r = &mut rz[o..o + nz];
            for li in 0..nz {
                r[li] = phase_grad(&self.resto, it, o + li, k, li) - it.zl[o + li] + it.zu[o + li];
            }
            let e = &it.ev[k];
            if k < lay.kk {
                gemv_t_acc(&e.jac_f, &it.lam[lay.ol[k]..lay.ol[k + 1]], r, nx1, nz);
            }
            if k > 0 {
                for i in 0..lay.nx[k] {
                    r[i] -= it.lam[lay.ol[k - 1] + i];
                }
            }
            gemv_t_acc(&e.jac_c, &it.y[lay.oc[k]..lay.oc[k] + nc], r, nc, nz);
            if k == lay.kk {
                gemv_t_acc(
                    &it.term.jac_r,
                    &it.nu,
                    &mut r[..lay.nx[k]],
                    self.data.dims.n_terminal,
                    lay.nx[k],
                );
            }
        }
        for (j, &(k, i)) in self.data.fixed_rows.iter().enumerate() {
            rz[lay.oz[k] + i] += it.eta[j];
        }
        let mut res = Residuals::default();
        for i in 0..rz.len() {
            if self.data.kind[i] != Kind::Eliminated {
                res.dual_inf = res.dual_inf.max(rz[i].abs());
            }
        }
        for j in 0..it.s.len() {
            res.dual_inf = res.dual_inf.max((-it.y[j] - it.vl[j] + it.vu[j]).abs());
        }
        self.it.rz = rz;
        self.refresh_rows();
        let (t1, ti) = self.theta_of(&self.it.cv, self.resto.slacks(false));
        res.dual_inf = self.resto.dual_inf(&self.it, &self.data, res.dual_inf);
        res.theta_1 = t1;
        res.theta_inf = ti;
        let (data, it) = (&self.data, &self.it);
        // complementarity and scaling
        let (mut bsum, mut nb) = (0.0, 0usize);
        let mut comp = 0.0_f64;
        for i in 0..it.z.len() {
            if data.kind[i] != Kind::Free {
                continue;
            }
            if data.zlo[i].is_finite() {
                comp = comp.max(((it.z[i] - data.zlo[i]) * it.zl[i]).abs());
                bsum += it.zl[i];
                nb += 1;
            }
            if data.zhi[i].is_finite() {
                comp = comp.max(((data.zhi[i] - it.z[i]) * it.zu[i]).abs());
                bsum += it.zu[i];
                nb += 1;
            }
        }
        for j in 0..it.s.len() {
            if data.clo[j].is_finite() {
                comp = comp.max(((it.s[j] - data.clo[j]) * it.vl[j]).abs());
                bsum += it.vl[j];
                nb += 1;
            }
            if data.chi[j].is_finite() {
                comp = comp.max(((data.chi[j] - it.s[j]) * it.vu[j]).abs());
                bsum += it.vu[j];
                nb += 1;
            }
        }
        self.resto
            .complementarity(data.nrows(), &mut comp, &mut bsum, &mut nb);
        let nfix = data.fixed_rows.len();
        let esum: f64 = it
            .lam
            .iter()
            .chain(&it.y)
            .chain(&it.nu)
            .map(|v| v.abs())
            .sum::<f64>()
            + it.eta[..nfix].iter().map(|v| v.abs()).sum::<f64>();
        let ne = it.lam.len() + it.y.len() + it.nu.len() + nfix;
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

    /// Barrier error E_mu: complementarity measured against mu (for the current phase).
    pub(super) fn e_mu(&self, res: &Residuals, mu: f64) -> f64 {
        let (data, it) = (&self.data, &self.it);
        let mut comp = self.resto.centrality(data.nrows(), mu);
        for i in 0..it.z.len() {
            if data.kind[i] != Kind::Free {
                continue;
            }
            if data.zlo[i].is_finite() {
                comp = comp.max(((it.z[i] - data.zlo[i]) * it.zl[i] - mu).abs());
            }
            if data.zhi[i].is_finite() {
                comp = comp.max(((data.zhi[i] - it.z[i]) * it.zu[i] - mu).abs());
            }
        }
        for j in 0..it.s.len() {
            if data.clo[j].is_finite() {
                comp = comp.max(((it.s[j] - data.clo[j]) * it.vl[j] - mu).abs());
            }
            if data.chi[j].is_finite() {
                comp = comp.max(((data.chi[j] - it.s[j]) * it.vu[j] - mu).abs());
            }
        }
        (res.dual_inf / res.s_d)
            .max(res.theta_inf)
            .max(comp / res.s_c)
    }

    /// Sum of the complementarity products (slack times bound dual) over all bounds of z and s
    /// at the iterate moved by `ap` times the primal and `ad` times the dual step, and their number.
    pub(super) fn complementarity(&self, ap: f64, ad: f64) -> (f64, usize) {
        let (data, it, step) = (&self.data, &self.it, &self.step);
        let (mut sum, mut nb) = (0.0, 0usize);
        for i in 0..it.z.len() {
            if data.kind[i] != Kind::Free {
                continue;
            }
            let z = it.z[i] + ap * step.dz[i];
            if data.zlo[i].is_finite() {
                sum += (z - data.zlo[i]) * (it.zl[i] + ad * step.dzl[i]);
                nb += 1;
            }
            if data.zhi[i].is_finite() {
                sum += (data.zhi[i] - z) * (it.zu[i] + ad * step.dzu[i]);
                nb += 1;
            }
        }
        for j in 0..it.s.len() {
            let v = it.s[j] + ap * step.ds[j];
            if data.clo[j].is_finite() {
                sum += (v - data.clo[j]) * (it.vl[j] + ad * step.dvl[j]);
                nb += 1;
            }
            if data.chi[j].is_finite() {
                sum += (data.chi[j] - v) * (it.vu[j] + ad * step.dvu[j]);
                nb += 1;
            }
        }
        (sum, nb)
    }

    /// The largest violation of the original problem at the iterate: dynamics, terminal rows,
    /// `c(z)` against its bounds and the simple bounds.
    pub(super) fn primal_violation(&self) -> f64 {
        let (lay, data, it) = (&self.data.lay, &self.data, &self.it);
        let mut v = 0.0_f64;
        for k in 0..=lay.kk {
            if k < lay.kk {
                for i in 0..lay.nx1[k] {
                    v = v.max((it.ev[k].f[i] - it.z[lay.oz[k + 1] + i]).abs());
                }
            }
            for j in 0..lay.nc[k] {
                let c = it.ev[k].c[j];
                let jj = lay.oc[k] + j;
                v = v.max(data.clo[jj] - c).max(c - data.chi[jj]);
            }
        }
        for r in &it.term.r {
            v = v.max(r.abs());
        }
        for i in 0..it.z.len() {
            v = v.max(data.zlo[i] - it.z[i]).max(it.z[i] - data.zhi[i]);
        }
        v
    }

    /// Final statistics and the public copies of the iterate. `res`: the residuals of the original
    /// problem at the final iterate if the iterations computed them (a solve that stops on its
    /// convergence test), else `None` (computed here).
    pub(super) fn finish(&mut self, stats: &mut OcpStats, mu: f64, res: Option<Residuals>) {
        scatter_primal(&self.it.z, &self.data.lay, &mut self.it.zp);
        self.it.store_multipliers(&self.data.lay);
        stats.final_mu = mu;
        stats.objective = cost(&self.it.ev);
        let res = res.unwrap_or_else(|| self.residuals());
        stats.dual_infeasibility = res.dual_inf;
        stats.primal_infeasibility = self.primal_violation();
    }
}
