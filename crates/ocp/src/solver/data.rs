//! The problem as the solver sees it: the stage layout, the bounds read from the problem and the
//! role of every entry of z (free, eliminated, or an equality row).

use super::evaluation::panic_message;
use crate::problem::{OcpDims, OcpProblem, StageBounds, StageEval, TerminalEval};
use crate::riccati::Layout;
use crate::settings::MAX_EQUALITY_ROWS;
use std::panic::{catch_unwind, AssertUnwindSafe};

/// Role of one entry of z.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Kind {
    /// Decision variable (possibly bounded).
    Free,
    /// `lo == hi` in x_0 or in an input: removed from the Newton step.
    Eliminated,
    /// `lo == hi` in a state after stage 0: an equality row of the Schur complement.
    FixedRow,
}

/// The dimensions, the layout of the flat arrays and the bounds of one solve.
pub(super) struct ProblemData {
    pub(super) dims: OcpDims,
    pub(super) lay: Layout,
    /// The bounds as the problem wrote them (per stage).
    bounds: Vec<StageBounds>,
    /// Bounds of z (nz) and of the stage rows (nc).
    pub(super) zlo: Vec<f64>,
    pub(super) zhi: Vec<f64>,
    pub(super) clo: Vec<f64>,
    pub(super) chi: Vec<f64>,
    /// Role of each entry of z, and whether the inertia correction regularises it.
    pub(super) kind: Vec<Kind>,
    pub(super) reg: Vec<bool>,
    /// Fixed-state rows (k >= 1): (stage, component).
    pub(super) fixed_rows: Vec<(usize, usize)>,
}

impl ProblemData {
    /// Allocates for `dims` (already checked) and its layout.
    pub(super) fn new(dims: &OcpDims, lay: Layout) -> Self {
        let (nz, nc) = (lay.n_z(), lay.n_c());
        ProblemData {
            bounds: dims
                .stages
                .iter()
                .map(|d| StageBounds::unbounded(*d))
                .collect(),
            zlo: vec![0.0; nz],
            zhi: vec![0.0; nz],
            clo: vec![0.0; nc],
            chi: vec![0.0; nc],
            kind: vec![Kind::Free; nz],
            reg: vec![true; nz],
            fixed_rows: Vec::with_capacity(MAX_EQUALITY_ROWS),
            dims: dims.clone(),
            lay,
        }
    }

    /// Number of constraint rows: dynamics, stage rows, terminal rows, fixed states.
    pub(super) fn nrows(&self) -> usize {
        self.lay.n_l() + self.lay.n_c() + self.dims.n_terminal + self.fixed_rows.len()
    }

    /// Reads and checks the bounds; classifies the entries of z.
    pub(super) fn read_bounds(&mut self, p: &mut dyn OcpProblem) -> Result<(), String> {
        self.fixed_rows.clear();
        for k in 0..=self.lay.kk {
            let b = &mut self.bounds[k];
            for v in [&mut b.x_lo, &mut b.u_lo, &mut b.c_lo] {
                v.fill(f64::NEG_INFINITY);
            }
            for v in [&mut b.x_hi, &mut b.u_hi, &mut b.c_hi] {
                v.fill(f64::INFINITY);
            }
            let r = catch_unwind(AssertUnwindSafe(|| p.bounds(k, b)));
            if let Err(e) = r {
                return Err(format!("bounds({k}) panicked: {}", panic_message(&*e)));
            }
            let d = self.dims.stages[k];
            if b.x_lo.len() != d.nx
                || b.x_hi.len() != d.nx
                || b.u_lo.len() != d.nu
                || b.u_hi.len() != d.nu
                || b.c_lo.len() != d.nc
                || b.c_hi.len() != d.nc
            {
                return Err(format!("bounds({k}) resized its buffers"));
            }
            let o = self.lay.oz[k];
            for i in 0..d.nz() {
                let (lo, hi) = if i < d.nx {
                    (b.x_lo[i], b.x_hi[i])
                } else {
                    (b.u_lo[i - d.nx], b.u_hi[i - d.nx])
                };
                if lo.is_nan()
                    || hi.is_nan()
                    || lo > hi
                    || lo == f64::INFINITY
                    || hi == f64::NEG_INFINITY
                {
                    return Err(format!("stage {k}, variable {i}: bounds [{lo}, {hi}]"));
                }
                self.zlo[o + i] = lo;
                self.zhi[o + i] = hi;
                self.kind[o + i] = if lo < hi {
                    Kind::Free
                } else if k == 0 || i >= d.nx {
                    Kind::Eliminated
                } else {
                    if self.fixed_rows.len() + self.dims.n_terminal >= MAX_EQUALITY_ROWS {
                        return Err(format!(
                            "more than {MAX_EQUALITY_ROWS} equality rows (terminal rows plus fixed states after stage 0)"
                        ));
                    }
                    self.fixed_rows.push((k, i));
                    Kind::FixedRow
                };
                self.reg[o + i] = self.kind[o + i] != Kind::Eliminated;
            }
            let oc = self.lay.oc[k];
            for j in 0..d.nc {
                let (lo, hi) = (b.c_lo[j], b.c_hi[j]);
                if lo.is_nan()
                    || hi.is_nan()
                    || lo >= hi
                    || lo == f64::INFINITY
                    || hi == f64::NEG_INFINITY
                {
                    return Err(format!(
                        "stage {k}, inequality row {j}: bounds [{lo}, {hi}] (c_lo < c_hi required)"
                    ));
                }
                self.clo[oc + j] = lo;
                self.chi[oc + j] = hi;
            }
        }
        Ok(())
    }

    /// Constraint rows at (z, s) with evaluations `ev`, `term` into `out`: dynamics defects, stage
    /// rows `c - s`, terminal rows, fixed states.
    pub(super) fn row_values(
        &self,
        z: &[f64],
        s: &[f64],
        ev: &[StageEval],
        term: &TerminalEval,
        out: &mut [f64],
    ) {
        let lay = &self.lay;
        for k in 0..lay.kk {
            let o1 = lay.oz[k + 1];
            for i in 0..lay.nx1[k] {
                out[lay.ol[k] + i] = ev[k].f[i] - z[o1 + i];
            }
        }
        let nl = lay.n_l();
        for k in 0..=lay.kk {
            let oc = lay.oc[k];
            for j in 0..lay.nc[k] {
                out[nl + oc + j] = ev[k].c[j] - s[oc + j];
            }
        }
        let base = nl + lay.n_c();
        out[base..base + term.r.len()].copy_from_slice(&term.r);
        let base = base + term.r.len();
        for (j, &(k, i)) in self.fixed_rows.iter().enumerate() {
            let o = lay.oz[k] + i;
            out[base + j] = z[o] - self.zlo[o];
        }
    }

    /// Barrier sum `-sum ln(slack)` over all bounded entries of z and s (the relaxation slacks of
    /// the restoration phase are added by its caller, first).
    pub(super) fn barrier_from(&self, b0: f64, z: &[f64], s: &[f64]) -> f64 {
        let mut b = b0;
        for i in 0..z.len() {
            if self.kind[i] == Kind::Free {
                if self.zlo[i].is_finite() {
                    b -= (z[i] - self.zlo[i]).ln();
                }
                if self.zhi[i].is_finite() {
                    b -= (self.zhi[i] - z[i]).ln();
                }
            }
        }
        for j in 0..s.len() {
            if self.clo[j].is_finite() {
                b -= (s[j] - self.clo[j]).ln();
            }
            if self.chi[j].is_finite() {
                b -= (self.chi[j] - s[j]).ln();
            }
        }
        b
    }
}

/// `v` moved a fraction `push` inside `[lo, hi]` (IPOPT's `bound_push`, relative to the bound's
/// size and capped by the width); a non-finite `v` starts at 0.
pub(super) fn push_inside(lo: f64, hi: f64, v: f64, push: f64) -> f64 {
    let mut v = v;
    if !v.is_finite() {
        v = 0.0;
    }
    let width = hi - lo;
    if lo.is_finite() {
        let pl = (push * lo.abs().max(1.0)).min(if width.is_finite() {
            push * width
        } else {
            f64::INFINITY
        });
        v = v.max(lo + pl);
    }
    if hi.is_finite() {
        let pu = (push * hi.abs().max(1.0)).min(if width.is_finite() {
            push * width
        } else {
            f64::INFINITY
        });
        v = v.min(hi - pu);
    }
    v
}
