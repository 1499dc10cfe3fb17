//! The KKT system of one Newton step: condensing the inequalities and bounds into the stage
//! Hessians and gradients, the Riccati factorisation ([`crate::riccati`]) with inertia correction
//! (a penalty on the equality rows, then `delta_w`), the Schur complement of the equality rows,
//! the solves and the recovery of the slack, multiplier and bound-dual steps. Also the
//! least-squares multiplier estimate that starts a solve (the same recursion with `H = I`).

use super::data::{Kind, ProblemData};
use super::evaluation::finite;
use super::iterate::{Iterate, Step};
use super::restoration::{phase_grad, Restoration};
use crate::riccati::{Layout, Riccati};
use crate::settings::{OcpStats, MAX_EQUALITY_ROWS};
use brachia_linalg::gemv_t_acc;
use std::time::Instant;

// Inertia correction (IPOPT's Algorithm IC): first delta_w, smallest and largest, decrease and
// increase factors.
const DW_0: f64 = 1e-4;
const DW_MIN: f64 = 1e-20;
const DW_MAX: f64 = 1e40;
const KW_MINUS: f64 = 1.0 / 3.0;
const KW_PLUS: f64 = 8.0;
const KW_PLUS_BAR: f64 = 100.0;
// Penalty on the equality rows tried before delta_w (section 5 of docs/ocp.md): first value, growth
// factor, largest value.
const RHO_EQ_0: f64 = 1.0;
const RHO_EQ_PLUS: f64 = 100.0;
const RHO_EQ_MAX: f64 = 1e8;

/// How the complementarity rows of a right-hand side read ([`KktSystem::solve`]): the
/// barrier parameter for every bound, or the per-bound targets of the centrality correctors.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Centring {
    /// The barrier parameter for every bound.
    Mu(f64),
    /// The per-bound targets of the centrality correctors.
    Targets,
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

/// The condensed KKT system and its workspace (allocated once).
pub(super) struct KktSystem {
    /// The Riccati recursion: condensed stage Hessians, dynamics Jacobians, equality rows, factors.
    pub(super) ric: Riccati,
    /// The condensed gradient of the current right-hand side (nz).
    g: Vec<f64>,
    /// The part of the condensed gradient that depends neither on the row residuals nor on mu.
    g_base: Vec<f64>,
    /// The barrier part of the condensed gradient per unit of mu (`-1/(z - lo) + 1/(hi - z)`), so
    /// that one factorisation serves right-hand sides for several mu (adaptive mu).
    g_bar: Vec<f64>,
    /// Dynamics defects of the right-hand side (nl).
    bdef: Vec<f64>,
    /// Per row (dynamics, stage rows, terminal, fixed states): the (relaxed) residual c^ and the
    /// regularisation D of the Newton step.
    pub(super) chat: Vec<f64>,
    pub(super) dreg: Vec<f64>,
    /// Penalty `rho_eq a_j a_j^T` on the equality rows in the condensed Hessians of the current
    /// factorisation (0 = none), and the one that last passed the inertia test in this solve.
    rho_eq: f64,
    pub(super) rho_eq_last: f64,
    /// The last `delta_w` that passed the inertia test (0 = none yet in this phase).
    pub(super) delta_w_last: f64,
}

impl KktSystem {
    /// Allocates for the layout `lay`.
    pub(super) fn new(lay: &Layout) -> Self {
        let (nz, nl, nc) = (lay.n_z(), lay.n_l(), lay.n_c());
        KktSystem {
            ric: Riccati::new(lay),
            g: vec![0.0; nz],
            g_base: vec![0.0; nz],
            g_bar: vec![0.0; nz],
            bdef: vec![0.0; nl],
            chat: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            dreg: vec![0.0; nl + nc + MAX_EQUALITY_ROWS],
            rho_eq: 0.0,
            rho_eq_last: 0.0,
            delta_w_last: 0.0,
        }
    }

    /// Per row: the residual of the Newton system `c^` and its regularisation `D` from the rows
    /// `cv` at the iterate (restoration relaxes them by its slacks).
    pub(super) fn set_rows(&mut self, nrows: usize, cv: &[f64], resto: &Restoration, mu: f64) {
        resto.newton_rows(nrows, cv, mu, &mut self.chat, &mut self.dreg);
    }

    /// Condensed stage Hessians, dynamics Jacobians and equality rows; factorisation with inertia
    /// correction.
    pub(super) fn factor(
        &mut self,
        data: &ProblemData,
        it: &Iterate,
        resto: &Restoration,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        let t = Instant::now();
        let lay = &data.lay;
        let kk = lay.kk;
        let (nl, ncall) = (lay.n_l(), lay.n_c());
        self.ric.soft = resto.active();
        self.ric.dsoft.copy_from_slice(&self.dreg[..nl]);
        for k in 0..=kk {
            let (o, nx, nz, nx1, nc) = (lay.oz[k], lay.nx[k], lay.nz(k), lay.nx1[k], lay.nc[k]);
            let e = &it.ev[k];
            let h = &mut self.ric.h[lay.oh[k]..lay.oh[k + 1]];
            h.copy_from_slice(&e.hess);
            for li in 0..nz {
                let i = o + li;
                let gi = phase_grad(resto, it, i, k, li);
                if resto.active() {
                    h[li * nz + li] += resto.hessian(i);
                }
                let mut gb = 0.0;
                if data.kind[i] == Kind::Free {
                    if data.zlo[i].is_finite() {
                        let sl = it.z[i] - data.zlo[i];
                        h[li * nz + li] += it.zl[i] / sl;
                        gb -= 1.0 / sl;
                    }
                    if data.zhi[i].is_finite() {
                        let su = data.zhi[i] - it.z[i];
                        h[li * nz + li] += it.zu[i] / su;
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
                if data.clo[jj].is_finite() {
                    sig += it.vl[jj] / (it.s[jj] - data.clo[jj]);
                }
                if data.chi[jj].is_finite() {
                    sig += it.vu[jj] / (data.chi[jj] - it.s[jj]);
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
                if data.kind[o + li] == Kind::Eliminated {
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
                split_dynamics_jacobian(&e.jac_f, &data.kind[o..o + nz], nx1, nx, nu, a, b);
            }
        }
        // equality rows: terminal rows, then fixed states
        let nr = data.dims.n_terminal;
        let nxm = lay.nx_max;
        let nxk = lay.nx[kk];
        for j in 0..nr {
            self.ric.eq_stage[j] = kk;
            self.ric.eq_a[j * nxm..j * nxm + nxk]
                .copy_from_slice(&it.term.jac_r[j * nxk..(j + 1) * nxk]);
            self.ric.eq_reg[j] = self.dreg[nl + ncall + j];
        }
        for (jf, &(k, i)) in data.fixed_rows.iter().enumerate() {
            let j = nr + jf;
            self.ric.eq_stage[j] = k;
            self.ric.eq_a[j * nxm..(j + 1) * nxm].fill(0.0);
            self.ric.eq_a[j * nxm + i] = 1.0;
            self.ric.eq_reg[j] = self.dreg[nl + ncall + j];
        }
        self.ric.m = nr + data.fixed_rows.len();
        // inertia correction (IPOPT Algorithm IC), first by a penalty on the equality rows (exact:
        // the same step and the same inertia, see docs/ocp.md section 5), then by delta_w
        self.rho_eq = 0.0;
        let use_penalty = !resto.active() && self.ric.m > 0;
        if use_penalty && self.rho_eq_last > 0.0 {
            self.add_eq_penalty(lay, self.rho_eq_last);
        }
        let lay = &data.lay;
        let mut ok = self.ric.factor_with_inertia(lay, 0.0, &data.reg);
        stats.factorizations += 1;
        if !ok && use_penalty {
            let mut rho = if self.rho_eq_last == 0.0 {
                RHO_EQ_0
            } else {
                RHO_EQ_PLUS * self.rho_eq_last
            };
            while !ok && rho <= RHO_EQ_MAX {
                self.add_eq_penalty(&data.lay, rho - self.rho_eq);
                ok = self.ric.factor_with_inertia(&data.lay, 0.0, &data.reg);
                stats.factorizations += 1;
                if ok {
                    self.rho_eq_last = rho;
                } else {
                    rho *= RHO_EQ_PLUS;
                }
            }
        }
        let lay = &data.lay;
        if !ok {
            let mut delta_w = if self.delta_w_last == 0.0 {
                DW_0
            } else {
                (KW_MINUS * self.delta_w_last).max(DW_MIN)
            };
            loop {
                ok = self.ric.factor_with_inertia(lay, delta_w, &data.reg);
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
    /// `rho_eq a_j c^_j` of [`Self::solve`] this changes neither the Newton step nor the
    /// multipliers nor the inertia of the KKT matrix (the rows hold exactly), but it makes the
    /// Riccati recursion's test (`R^_k` positive definite) pass where the Hessian is convex only
    /// on the null space of the rows, e.g. `nu^T r''(x_K)` of a nonlinear terminal constraint.
    fn add_eq_penalty(&mut self, lay: &Layout, d: f64) {
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
    /// multiplier and bound-dual steps (after [`Self::factor`]). The complementarity rows
    /// aim at `centring`: mu for every bound, or the per-bound targets `ctarget` (centrality
    /// correctors; not in the restoration phase, whose own rows read mu).
    pub(super) fn solve(
        &mut self,
        data: &ProblemData,
        it: &Iterate,
        centring: Centring,
        ctarget: &[f64],
        step: &mut Step,
        stats: &mut OcpStats,
    ) -> Result<(), String> {
        let t = Instant::now();
        let lay = &data.lay;
        let kk = lay.kk;
        let (nl, ncall) = (lay.n_l(), lay.n_c());
        let nz = it.z.len();
        let os = 2 * nz;
        let mu = match centring {
            Centring::Mu(mu) => {
                for ((g, gb), gm) in self.g.iter_mut().zip(&self.g_base).zip(&self.g_bar) {
                    *g = gb + mu * gm;
                }
                mu
            }
            Centring::Targets => {
                for i in 0..nz {
                    let mut gi = self.g_base[i];
                    if data.kind[i] == Kind::Free {
                        if data.zlo[i].is_finite() {
                            gi -= ctarget[i] / (it.z[i] - data.zlo[i]);
                        }
                        if data.zhi[i].is_finite() {
                            gi += ctarget[nz + i] / (data.zhi[i] - it.z[i]);
                        }
                    }
                    self.g[i] = gi;
                }
                f64::NAN
            }
        };
        let per_bound = centring == Centring::Targets;
        let nc_all = it.s.len();
        // the targets of the lower and upper bound of slack jj
        let s_targets = |ct: &[f64], jj: usize| {
            if per_bound {
                (ct[os + jj], ct[os + nc_all + jj])
            } else {
                (mu, mu)
            }
        };
        // the condensed weight Sigma and right-hand side rbar of slack jj's finite bounds
        let slack_terms = |jj: usize| {
            let (tl, tu) = s_targets(ctarget, jj);
            let (mut sig, mut rbar) = (0.0, 0.0);
            if data.clo[jj].is_finite() {
                let sl = it.s[jj] - data.clo[jj];
                sig += it.vl[jj] / sl;
                rbar -= tl / sl;
            }
            if data.chi[jj].is_finite() {
                let su = data.chi[jj] - it.s[jj];
                sig += it.vu[jj] / su;
                rbar += tu / su;
            }
            (sig, rbar)
        };
        for k in 0..=kk {
            let (o, nz, oc) = (lay.oz[k], lay.nz(k), lay.oc[k]);
            let e = &it.ev[k];
            for j in 0..lay.nc[k] {
                let jj = oc + j;
                let (sig, rbar) = slack_terms(jj);
                let rhs = (rbar + sig * self.chat[nl + jj]) / (1.0 + sig * self.dreg[nl + jj]);
                let row = &e.jac_c[j * nz..(j + 1) * nz];
                for a in 0..nz {
                    self.g[o + a] += row[a] * rhs;
                }
            }
            for li in 0..nz {
                if data.kind[o + li] == Kind::Eliminated {
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
            &mut step.dz,
            &mut step.lam_n,
            &mut step.eqm_n[..m],
        );
        // slack, inequality multiplier and bound-dual steps
        for k in 0..=kk {
            let (o, nz, oc) = (lay.oz[k], lay.nz(k), lay.oc[k]);
            let e = &it.ev[k];
            for j in 0..lay.nc[k] {
                let jj = oc + j;
                let row = &e.jac_c[j * nz..(j + 1) * nz];
                // y+ = (Sigma (J dz + c^) + rbar) / (1 + Sigma D), ds = J dz + c^ - D y+
                let mut lin = self.chat[nl + jj];
                for a in 0..nz {
                    lin += row[a] * step.dz[o + a];
                }
                let (tl, tu) = s_targets(ctarget, jj);
                let (sig, rbar) = slack_terms(jj);
                let yn = (sig * lin + rbar) / (1.0 + sig * self.dreg[nl + jj]);
                let ds = lin - self.dreg[nl + jj] * yn;
                step.ds[jj] = ds;
                step.dvl[jj] = 0.0;
                step.dvu[jj] = 0.0;
                if data.clo[jj].is_finite() {
                    let sl = it.s[jj] - data.clo[jj];
                    step.dvl[jj] = tl / sl - it.vl[jj] - (it.vl[jj] / sl) * ds;
                }
                if data.chi[jj].is_finite() {
                    let su = data.chi[jj] - it.s[jj];
                    step.dvu[jj] = tu / su - it.vu[jj] + (it.vu[jj] / su) * ds;
                }
                step.y_n[jj] = yn;
            }
        }
        for i in 0..it.z.len() {
            step.dzl[i] = 0.0;
            step.dzu[i] = 0.0;
            if data.kind[i] != Kind::Free {
                continue;
            }
            let (tl, tu) = if per_bound {
                (ctarget[i], ctarget[nz + i])
            } else {
                (mu, mu)
            };
            if data.zlo[i].is_finite() {
                let sl = it.z[i] - data.zlo[i];
                step.dzl[i] = tl / sl - it.zl[i] - (it.zl[i] / sl) * step.dz[i];
            }
            if data.zhi[i].is_finite() {
                let su = data.zhi[i] - it.z[i];
                step.dzu[i] = tu / su - it.zu[i] + (it.zu[i] / su) * step.dz[i];
            }
        }
        stats.time.linear_algebra_s += t.elapsed().as_secs_f64();
        if !(finite(&step.dz)
            && finite(&step.ds)
            && finite(&step.lam_n)
            && finite(&step.eqm_n[..m]))
        {
            return Err("non-finite Newton step".to_string());
        }
        Ok(())
    }

    /// Least-squares estimate of the equality multipliers (IPOPT's initialisation):
    /// `min ||grad l + J^T lam - z_L + z_U||^2`, i.e. the chain QP with `H = I` and zero residuals,
    /// solved by the same Riccati recursion. Stage-row multipliers come from their slack duals.
    /// Estimates larger than 1e3 are discarded (zeros).
    pub(super) fn least_squares(&mut self, data: &ProblemData, it: &mut Iterate, step: &mut Step) {
        let lay = &data.lay;
        let kk = lay.kk;
        for j in 0..it.s.len() {
            it.y[j] = it.vu[j] - it.vl[j];
        }
        for k in 0..=kk {
            let (o, nx, nz, nx1, nu) = (lay.oz[k], lay.nx[k], lay.nz(k), lay.nx1[k], lay.nu[k]);
            let e = &it.ev[k];
            let h = &mut self.ric.h[lay.oh[k]..lay.oh[k + 1]];
            h.fill(0.0);
            for li in 0..nz {
                h[li * nz + li] = 1.0;
                let i = o + li;
                self.g[i] = if data.kind[i] == Kind::Eliminated {
                    0.0
                } else {
                    e.grad[li] - it.zl[i] + it.zu[i]
                };
            }
            let gk = &mut self.g[o..o + nz];
            gemv_t_acc(&e.jac_c, &it.y[lay.oc[k]..lay.oc[k + 1]], gk, lay.nc[k], nz);
            for li in 0..nz {
                if data.kind[o + li] == Kind::Eliminated {
                    gk[li] = 0.0;
                }
            }
            if k < kk {
                let a = &mut self.ric.a[lay.oa[k]..lay.oa[k + 1]];
                let b = &mut self.ric.b[lay.ob[k]..lay.ob[k + 1]];
                split_dynamics_jacobian(&e.jac_f, &data.kind[o..o + nz], nx1, nx, nu, a, b);
            }
        }
        self.bdef.fill(0.0);
        let nr = data.dims.n_terminal;
        let nxm = lay.nx_max;
        let nxk = lay.nx[kk];
        for j in 0..nr {
            self.ric.eq_stage[j] = kk;
            self.ric.eq_a[j * nxm..j * nxm + nxk]
                .copy_from_slice(&it.term.jac_r[j * nxk..(j + 1) * nxk]);
        }
        for (jf, &(k, i)) in data.fixed_rows.iter().enumerate() {
            let j = nr + jf;
            self.ric.eq_stage[j] = k;
            self.ric.eq_a[j * nxm..(j + 1) * nxm].fill(0.0);
            self.ric.eq_a[j * nxm + i] = 1.0;
        }
        let m = nr + data.fixed_rows.len();
        self.ric.m = m;
        self.ric.eq_rho[..m].fill(0.0);
        self.ric.eq_reg[..m].fill(0.0);
        self.ric.soft = false;
        let ok = self.ric.factor_with_inertia(lay, 0.0, &data.reg);
        if ok {
            self.ric.solve(
                lay,
                &self.g,
                &self.bdef,
                &mut step.dz,
                &mut step.lam_n,
                &mut step.eqm_n[..m],
            );
        }
        let big = |v: &[f64]| v.iter().any(|x| x.is_nan() || x.abs() > 1e3);
        if ok && !big(&step.lam_n) && !big(&step.eqm_n[..m]) {
            it.lam.copy_from_slice(&step.lam_n);
            it.nu.copy_from_slice(&step.eqm_n[..nr]);
            it.eta[..m - nr].copy_from_slice(&step.eqm_n[nr..m]);
        } else {
            it.lam.fill(0.0);
            it.nu.fill(0.0);
            it.eta.fill(0.0);
            it.y.fill(0.0);
        }
    }
}
