//! Gondzio's multiple centrality correctors (Gondzio 1996) on the Newton step, with the same
//! factorisation.

use super::data::{Kind, ProblemData};
use super::iterate::{Iterate, Step};

/// The workspace of the correctors (allocated once).
pub(super) struct Correctors {
    /// Complementarity target per bound of a step with centrality correctors, in the order
    /// `[z lower (nz), z upper (nz), s lower (nc), s upper (nc)]` (the role mu plays in a plain step),
    /// and its value before the last corrector (to undo one that is not kept).
    pub(super) ctarget: Vec<f64>,
    ctarget_prev: Vec<f64>,
    /// The step before the last corrector (to undo one that is not kept).
    step_saved: Step,
}

impl Correctors {
    /// Allocates for `nz` variables, `nl` dynamics rows and `nc` stage rows.
    pub(super) fn new(nz: usize, nl: usize, nc: usize) -> Self {
        Correctors {
            ctarget: vec![0.0; 2 * (nz + nc)],
            ctarget_prev: vec![0.0; 2 * (nz + nc)],
            step_saved: Step::zeros(nz, nl, nc),
        }
    }

    /// Saves the targets and `step` (to undo the next corrector), then moves each bound's
    /// complementarity product at the trial point (`tp` along the primal, `td` along the dual
    /// step) into `[lo, hi]` by adding the difference to its target.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn raise_targets(
        &mut self,
        data: &ProblemData,
        it: &Iterate,
        step: &Step,
        tp: f64,
        td: f64,
        lo: f64,
        hi: f64,
    ) {
        let nz = it.z.len();
        let nc = it.s.len();
        let os = 2 * nz;
        let correction = |slack: f64, dual: f64| {
            let v = if slack > 0.0 && dual > 0.0 {
                slack * dual
            } else {
                (slack * dual).min(0.0)
            };
            if v < lo {
                lo - v
            } else if v > hi {
                (hi - v).max(-hi)
            } else {
                0.0
            }
        };
        self.ctarget_prev.copy_from_slice(&self.ctarget);
        self.step_saved.copy_from(step);
        for i in 0..nz {
            if data.kind[i] != Kind::Free {
                continue;
            }
            let z = it.z[i] + tp * step.dz[i];
            if data.zlo[i].is_finite() {
                self.ctarget[i] += correction(z - data.zlo[i], it.zl[i] + td * step.dzl[i]);
            }
            if data.zhi[i].is_finite() {
                self.ctarget[nz + i] += correction(data.zhi[i] - z, it.zu[i] + td * step.dzu[i]);
            }
        }
        for j in 0..nc {
            let v = it.s[j] + tp * step.ds[j];
            if data.clo[j].is_finite() {
                self.ctarget[os + j] += correction(v - data.clo[j], it.vl[j] + td * step.dvl[j]);
            }
            if data.chi[j].is_finite() {
                self.ctarget[os + nc + j] +=
                    correction(data.chi[j] - v, it.vu[j] + td * step.dvu[j]);
            }
        }
    }

    /// Undoes the last corrector: the saved step and targets come back.
    pub(super) fn undo(&mut self, step: &mut Step) {
        step.copy_from(&self.step_saved);
        self.ctarget.copy_from_slice(&self.ctarget_prev);
    }
}
