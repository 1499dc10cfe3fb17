//! The problem an [`crate::OcpSolver`] solves, and the buffers through which it is evaluated.
//!
//! ## The problem
//! Stages `k = 0..=K` (`K` = [`OcpDims::horizon`]), each with a state `x_k` (`nx_k`) and an input `u_k`
//! (`nu_k`, may be 0; usually 0 at the last stage). Stage variables are ordered `z_k = [x_k, u_k]`.
//! ```text
//! min   sum_{k=0..=K} l_k(x_k, u_k)
//! s.t.  x_{k+1} = f_k(x_k, u_k)                 k = 0..K-1   (dynamics, nx_{k+1} rows)
//!       c_lo_k <= c_k(x_k, u_k) <= c_hi_k       k = 0..=K    (stage inequalities, nc_k rows)
//!       x_lo_k <= x_k <= x_hi_k,  u_lo_k <= u_k <= u_hi_k    (simple bounds; +-inf = none)
//!       r(x_K) = 0                                          (terminal equalities, nr rows)
//! ```
//! A component with `lo == hi` is fixed (typically the whole start state `x_0`). Bounds may be
//! infinite. `c_lo == c_hi` rows are not allowed (equalities belong in `r`).
//!
//! ## Multiplier convention
//! The Lagrangian is `L = sum_k sigma l_k + sum_k lam_k^T (f_k - x_{k+1}) + sum_k mu_k^T c_k + nu^T r`
//! (plus bound terms); `lam_k` (nx_{k+1}) multiplies the dynamics of stage k, `mu_k` (nc_k) the stage
//! inequalities, `nu` (nr) the terminal equalities.
//!
//! ## Matrix layout
//! Every matrix is dense and row-major. Jacobians have one row per output and one column per entry of
//! `z_k = [x_k, u_k]`; the terminal Jacobian has `nx_K` columns. Stage Hessians are full symmetric
//! `(nx_k + nu_k) x (nx_k + nu_k)` matrices (both triangles written).

/// Sizes of one stage.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StageDims {
    /// State dimension nx_k.
    pub nx: usize,
    /// Input dimension nu_k (0 allowed).
    pub nu: usize,
    /// Number of stage inequality rows nc_k.
    pub nc: usize,
}

impl StageDims {
    /// nx + nu.
    pub fn nz(&self) -> usize {
        self.nx + self.nu
    }
}

/// Sizes of the whole problem.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct OcpDims {
    /// One entry per stage, `K + 1` entries (at least 2).
    pub stages: Vec<StageDims>,
    /// Number of terminal equality rows nr (on `x_K`).
    pub n_terminal: usize,
}

impl OcpDims {
    /// K: the index of the last stage (number of dynamics transitions).
    pub fn horizon(&self) -> usize {
        self.stages.len().saturating_sub(1)
    }

    /// Zeroed evaluation buffers for these sizes: one [`StageEval`] per stage (stage k's transition
    /// into the next stage's state, none at the last), as [`OcpProblem::evaluate`] takes them.
    pub fn stage_evals(&self) -> Vec<StageEval> {
        let k_last = self.horizon();
        (0..self.stages.len())
            .map(|k| {
                let next = if k < k_last { self.stages[k + 1].nx } else { 0 };
                StageEval::zeros(self.stages[k], next)
            })
            .collect()
    }

    /// A zeroed [`TerminalEval`] for these sizes (the terminal rows on the last stage's state).
    pub fn terminal_eval(&self) -> TerminalEval {
        let nx_last = self.stages.last().map_or(0, |s| s.nx);
        TerminalEval::zeros(self.n_terminal, nx_last)
    }
}

/// Bounds of one stage; arrive filled with `-inf` / `+inf`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StageBounds {
    /// Lower state bounds (nx).
    pub x_lo: Vec<f64>,
    /// Upper state bounds (nx).
    pub x_hi: Vec<f64>,
    /// Lower input bounds (nu).
    pub u_lo: Vec<f64>,
    /// Upper input bounds (nu).
    pub u_hi: Vec<f64>,
    /// Lower bounds of the stage inequalities (nc).
    pub c_lo: Vec<f64>,
    /// Upper bounds of the stage inequalities (nc).
    pub c_hi: Vec<f64>,
}

impl StageBounds {
    /// Unbounded buffers for `d`.
    pub fn unbounded(d: StageDims) -> Self {
        let lo = |n| vec![f64::NEG_INFINITY; n];
        let hi = |n| vec![f64::INFINITY; n];
        StageBounds {
            x_lo: lo(d.nx),
            x_hi: hi(d.nx),
            u_lo: lo(d.nu),
            u_hi: hi(d.nu),
            c_lo: lo(d.nc),
            c_hi: hi(d.nc),
        }
    }
}

/// What [`OcpProblem::evaluate`] must fill.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EvalLevel {
    /// Values only: `cost`, `f`, `c` (and `r`).
    Values,
    /// Values and first derivatives: also `grad`, `jac_f`, `jac_c` (and `jac_r`).
    FirstOrder,
}

/// Evaluation buffers of one stage, owned by the solver and sized from [`OcpDims`] once.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StageEval {
    /// l_k(x_k, u_k).
    pub cost: f64,
    /// Gradient of l_k w.r.t. z_k (nz).
    pub grad: Vec<f64>,
    /// f_k(x_k, u_k) (nx_{k+1}; empty at the last stage).
    pub f: Vec<f64>,
    /// Jacobian of f_k, nx_{k+1} x nz.
    pub jac_f: Vec<f64>,
    /// c_k(x_k, u_k) (nc).
    pub c: Vec<f64>,
    /// Jacobian of c_k, nc x nz.
    pub jac_c: Vec<f64>,
    /// Hessian of the stage Lagrangian, nz x nz (see [`OcpProblem::hessians`]).
    pub hess: Vec<f64>,
}

impl StageEval {
    /// Zeroed buffers for stage `d` whose successor has `nx_next` states (0 at the last stage).
    pub fn zeros(d: StageDims, nx_next: usize) -> Self {
        let nz = d.nz();
        StageEval {
            cost: 0.0,
            grad: vec![0.0; nz],
            f: vec![0.0; nx_next],
            jac_f: vec![0.0; nx_next * nz],
            c: vec![0.0; d.nc],
            jac_c: vec![0.0; d.nc * nz],
            hess: vec![0.0; nz * nz],
        }
    }
}

/// Evaluation buffers of the terminal equalities.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TerminalEval {
    /// r(x_K) (nr).
    pub r: Vec<f64>,
    /// Jacobian of r, nr x nx_K.
    pub jac_r: Vec<f64>,
}

impl TerminalEval {
    /// Zeroed buffers.
    pub fn zeros(nr: usize, nx_last: usize) -> Self {
        TerminalEval {
            r: vec![0.0; nr],
            jac_r: vec![0.0; nr * nx_last],
        }
    }
}

/// A primal point: one state and one input vector per stage.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Primal {
    /// x_k per stage.
    pub x: Vec<Vec<f64>>,
    /// u_k per stage.
    pub u: Vec<Vec<f64>>,
}

impl Primal {
    /// Zeros shaped like `dims`.
    pub fn zeros(dims: &OcpDims) -> Self {
        Primal {
            x: dims.stages.iter().map(|d| vec![0.0; d.nx]).collect(),
            u: dims.stages.iter().map(|d| vec![0.0; d.nu]).collect(),
        }
    }

    /// Copy `src`, shaped like `self`, into `self` (no allocation). Panics on another shape.
    pub fn copy_from(&mut self, src: &Primal) {
        for (dst, s) in self.x.iter_mut().zip(&src.x) {
            dst.copy_from_slice(s);
        }
        for (dst, s) in self.u.iter_mut().zip(&src.u) {
            dst.copy_from_slice(s);
        }
    }
}

/// Multipliers of the equality and inequality constraints (see the module docs for the signs).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Multipliers {
    /// lam_k (nx_{k+1}) for k = 0..K-1; empty at k = K.
    pub lam: Vec<Vec<f64>>,
    /// mu_k (nc_k) for the stage inequalities.
    pub mu: Vec<Vec<f64>>,
    /// nu (nr) for the terminal equalities.
    pub nu: Vec<f64>,
}

impl Multipliers {
    /// Zeros shaped like `dims`.
    pub fn zeros(dims: &OcpDims) -> Self {
        let k_last = dims.horizon();
        Multipliers {
            lam: (0..dims.stages.len())
                .map(|k| {
                    if k < k_last {
                        vec![0.0; dims.stages[k + 1].nx]
                    } else {
                        Vec::new()
                    }
                })
                .collect(),
            mu: dims.stages.iter().map(|d| vec![0.0; d.nc]).collect(),
            nu: vec![0.0; dims.n_terminal],
        }
    }

    /// Copy `src`, shaped like `self`, into `self` (no allocation). Panics on another shape.
    pub fn copy_from(&mut self, src: &Multipliers) {
        for (dst, s) in self.lam.iter_mut().zip(&src.lam) {
            dst.copy_from_slice(s);
        }
        for (dst, s) in self.mu.iter_mut().zip(&src.mu) {
            dst.copy_from_slice(s);
        }
        self.nu.copy_from_slice(&src.nu);
    }
}

/// Why an evaluation failed (non-finite values, a model error); the solver shortens its step or stops.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("evaluation failed at stage {stage}: {reason}")]
pub struct EvalError {
    /// The stage (K + 1 for the terminal equalities).
    pub stage: usize,
    /// What went wrong.
    pub reason: String,
}

/// A discrete-time optimal-control problem with exact first and second derivatives.
///
/// Evaluation methods take `&mut self` so that an implementation may keep per-stage scratch and
/// evaluate its stages in parallel (e.g. with rayon over `stages.iter_mut()`). They are called from the
/// thread that called [`crate::OcpSolver::solve`]. The solver checks every value it receives for
/// finiteness, so implementations need not.
pub trait OcpProblem {
    /// Sizes; must not change between calls during a solve.
    fn dims(&self) -> &OcpDims;
    /// Bounds of stage `k` into `b` (arrives unbounded and correctly sized).
    fn bounds(&self, k: usize, b: &mut StageBounds);
    /// Initial guess (arrives zeroed and correctly sized). Need not satisfy the bounds: the solver
    /// projects it into their interior.
    fn initial_guess(&self, z: &mut Primal);
    /// Cost, dynamics, inequalities and terminal values at `z` (and first derivatives for
    /// [`EvalLevel::FirstOrder`]) into `stages` (K + 1 entries) and `terminal`.
    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> Result<(), EvalError>;
    /// Into `stages[k].hess`, the Hessian w.r.t. `z_k` of
    /// `sigma l_k + lam_k^T f_k + mu_k^T c_k` (`+ nu^T r(x_K)` at k = K).
    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        mult: &Multipliers,
        stages: &mut [StageEval],
    ) -> Result<(), EvalError>;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn evaluation_buffers_follow_stage_varying_sizes() {
        let dims = OcpDims {
            stages: vec![
                StageDims {
                    nx: 2,
                    nu: 1,
                    nc: 1,
                },
                StageDims {
                    nx: 3,
                    nu: 0,
                    nc: 0,
                },
                StageDims {
                    nx: 4,
                    nu: 2,
                    nc: 3,
                },
            ],
            n_terminal: 2,
        };
        let st = dims.stage_evals();
        assert_eq!(st.len(), 3);
        assert_eq!(
            (st[0].f.len(), st[0].jac_f.len(), st[0].grad.len()),
            (3, 9, 3)
        );
        assert_eq!(
            (st[1].f.len(), st[1].jac_f.len(), st[1].hess.len()),
            (4, 12, 9)
        );
        assert_eq!(
            (st[2].f.len(), st[2].c.len(), st[2].jac_c.len()),
            (0, 3, 18)
        );
        let term = dims.terminal_eval();
        assert_eq!((term.r.len(), term.jac_r.len()), (2, 8));
    }
}
