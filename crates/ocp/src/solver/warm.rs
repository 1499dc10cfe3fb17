//! Warm starts: the stored bound duals, their re-indexing for a shifted solution, and the state
//! a warm solve reads besides the primal ([`WarmState`]), to save and put back.

use super::data::Kind;
use super::workspace::OcpSolver;
use crate::problem::Multipliers;
use crate::settings::OcpError;
#[cfg(doc)]
use crate::settings::WarmDuals;

/// What a warm start takes from the last solve besides its primal ([`OcpSolver::primal`]): the
/// slacks of the stage inequalities, every multiplier (bound duals of the variables and of the
/// slacks, dynamics, stage-row, terminal and fixed-state multipliers) and the equality-row
/// penalty that last passed the inertia test. Read with [`OcpSolver::warm_state`] and put back
/// with [`OcpSolver::set_warm_state`], so that a warm solve from a saved solution starts from the
/// same numbers whatever was solved in between (e.g. a re-planner's checkpoint). Opaque: its
/// layout is the solver's.
#[derive(Debug, Clone, PartialEq)]
pub struct WarmState {
    s: Vec<f64>,
    zl: Vec<f64>,
    zu: Vec<f64>,
    vl: Vec<f64>,
    vu: Vec<f64>,
    eta: Vec<f64>,
    eta_rows: usize,
    mult: Multipliers,
    rho_eq_last: f64,
    has_iterate: bool,
}

impl OcpSolver {
    /// The bound duals of stage k stored by the last solve, `(lower, upper)`, `nx_k + nu_k` each
    /// (states, then inputs; 0 for an infinite bound and for fixed components). They start a warm
    /// solve with [`WarmDuals::Stored`] or [`WarmDuals::StoredBounds`]. Panics if `k > K`.
    pub fn bound_duals(&self, k: usize) -> (&[f64], &[f64]) {
        let r = self.data.lay.oz[k]..self.data.lay.oz[k + 1];
        (&self.it.zl[r.clone()], &self.it.zu[r])
    }

    /// Re-indexes the bound duals stored by the last solve ([`OcpSolver::bound_duals`]) for a warm
    /// start whose stage k is the last solve's stage `src(k)`: e.g. a solution shifted in time,
    /// whose primal is shifted through [`OcpSolver::primal_mut`], so that the duals of the bounds
    /// the solution rests on move with it. The states of stage k take those of stage `src(k)` if
    /// both have the same `nx`, the inputs likewise with `nu`; otherwise, and for `src(k) > K`,
    /// stage k keeps its own. The slacks of the stage inequalities, their duals and the
    /// multipliers stay where they are (moving them as well was measured slower on the robot's
    /// warm re-plans; docs/ocp.md). No allocation.
    pub fn remap_bound_duals(&mut self, src: impl Fn(usize) -> usize) {
        let lay = &self.data.lay;
        let parts = |k: usize| {
            let o = lay.oz[k];
            [(o, lay.nx[k]), (o + lay.nx[k], lay.nu[k])]
        };
        for v in [&mut self.it.zl, &mut self.it.zu] {
            self.it.remap.copy_from_slice(v);
            for k in 0..=lay.kk {
                let j = src(k);
                if j > lay.kk {
                    continue;
                }
                for ((od, nd), (os, ns)) in parts(k).into_iter().zip(parts(j)) {
                    if nd == ns {
                        v[od..od + nd].copy_from_slice(&self.it.remap[os..os + ns]);
                    }
                }
            }
        }
    }

    /// A copy of the stored state besides the primal ([`WarmState`]; allocates).
    pub fn warm_state(&self) -> WarmState {
        WarmState {
            s: self.it.s.clone(),
            zl: self.it.zl.clone(),
            zu: self.it.zu.clone(),
            vl: self.it.vl.clone(),
            vu: self.it.vu.clone(),
            eta: self.it.eta.clone(),
            eta_rows: self.it.eta_rows,
            mult: self.it.mult.clone(),
            rho_eq_last: self.kkt.rho_eq_last,
            has_iterate: self.it.has_iterate,
        }
    }

    /// [`OcpSolver::warm_state`] for the same problem with state component `i` removed from every
    /// stage: a parameter carried as a constant state (e.g. a free final time) once it is fixed.
    /// The component's bound duals and the dynamics multipliers of its rows are dropped; the
    /// slacks, the stage-row and terminal multipliers and the equality-row penalty are kept. So a
    /// solver of the reduced problem, given this state and the primal without the component, starts
    /// at the same point. Allocates. Errors if some stage has no component `i`, if the reduced stage
    /// would have no state, or if the component is an equality row (`lo == hi` after stage 0) in the
    /// last solve (its rows would remain in the Schur complement).
    pub fn warm_state_without_state(&self, i: usize) -> Result<WarmState, OcpError> {
        let lay = &self.data.lay;
        for k in 0..=lay.kk {
            if i >= lay.nx[k] || lay.nx[k] == 1 {
                return Err(OcpError::StateComponent {
                    component: i,
                    stage: k,
                    reason: "not a state component of this stage, or its only one",
                });
            }
            if self.data.kind[lay.oz[k] + i] == Kind::FixedRow {
                return Err(OcpError::StateComponent {
                    component: i,
                    stage: k,
                    reason: "fixed (an equality row of the last solve)",
                });
            }
        }
        let drop_z = |v: &[f64]| -> Vec<f64> {
            (0..=lay.kk)
                .flat_map(|k| {
                    let blk = &v[lay.oz[k]..lay.oz[k + 1]];
                    blk.iter()
                        .enumerate()
                        .filter(|&(j, _)| j != i)
                        .map(|(_, &x)| x)
                })
                .collect()
        };
        let mut mult = self.it.mult.clone();
        for lam in mult.lam.iter_mut().filter(|l| l.len() > i) {
            lam.remove(i);
        }
        Ok(WarmState {
            s: self.it.s.clone(),
            zl: drop_z(&self.it.zl),
            zu: drop_z(&self.it.zu),
            vl: self.it.vl.clone(),
            vu: self.it.vu.clone(),
            eta: self.it.eta.clone(),
            eta_rows: self.it.eta_rows,
            mult,
            rho_eq_last: self.kkt.rho_eq_last,
            has_iterate: self.it.has_iterate,
        })
    }

    /// Puts back a state read by [`OcpSolver::warm_state`] of a solver of the same dimensions
    /// (the primal goes back through [`OcpSolver::primal_mut`]). No allocation. Errors (and
    /// changes nothing) if the sizes differ.
    pub fn set_warm_state(&mut self, w: &WarmState) -> Result<(), OcpError> {
        let shape = |m: &Multipliers| {
            m.lam
                .iter()
                .map(Vec::len)
                .eq(self.it.mult.lam.iter().map(Vec::len))
                && m.mu
                    .iter()
                    .map(Vec::len)
                    .eq(self.it.mult.mu.iter().map(Vec::len))
                && m.nu.len() == self.it.mult.nu.len()
        };
        let same = [
            (&self.it.s, &w.s),
            (&self.it.zl, &w.zl),
            (&self.it.zu, &w.zu),
            (&self.it.vl, &w.vl),
            (&self.it.vu, &w.vu),
            (&self.it.eta, &w.eta),
        ]
        .iter()
        .all(|(a, b)| a.len() == b.len())
            && shape(&w.mult);
        if !same {
            return Err(OcpError::WarmStateMismatch {
                state_variables: w.zl.len(),
                state_slacks: w.s.len(),
                solver_variables: self.it.zl.len(),
                solver_slacks: self.it.s.len(),
            });
        }
        for (d, s) in [
            (&mut self.it.s, &w.s),
            (&mut self.it.zl, &w.zl),
            (&mut self.it.zu, &w.zu),
            (&mut self.it.vl, &w.vl),
            (&mut self.it.vu, &w.vu),
            (&mut self.it.eta, &w.eta),
        ] {
            d.copy_from_slice(s);
        }
        self.it.mult.copy_from(&w.mult);
        self.it.eta_rows = w.eta_rows;
        self.kkt.rho_eq_last = w.rho_eq_last;
        self.it.has_iterate = w.has_iterate;
        Ok(())
    }
}
