//! The tail of the stages evaluated on the helper thread: the job, its scratch and the copies of its
//! inputs and outputs.

use super::dynamics::PointDynamics;
use super::stage::{Ctx, StageWork};
use super::worker::Job;
use brachia_ocp::{EvalLevel, StageEval};

/// What the helper thread computes for its stages.
#[derive(Debug, Clone, Copy)]
pub(super) enum TailJob {
    /// [`StageWork::evaluate`] at this level.
    Evaluate(EvalLevel),
    /// [`StageWork::hessian`] with this cost factor.
    Hessian(f64),
}

/// The stages `first..=K` of a [`SwingOcp`] with a helper thread: their scratch, and copies of
/// their inputs and outputs (allocated once; the owner copies in before and out after each job).
pub(super) struct Tail<D> {
    pub(super) first: usize,
    pub(super) ctx: Ctx,
    pub(super) work: Vec<StageWork<D>>,
    pub(super) zx: Vec<Vec<f64>>,
    pub(super) zu: Vec<Vec<f64>>,
    pub(super) lam: Vec<Vec<f64>>,
    pub(super) mu: Vec<Vec<f64>>,
    pub(super) out: Vec<StageEval>,
    pub(super) job: TailJob,
}

impl TailJob {
    /// Run the job on stage k (its scratch `w`, point `x`, `u`, multipliers `lam`, `mu`: read by a
    /// Hessian job only).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run<D: PointDynamics>(
        self,
        w: &mut StageWork<D>,
        ctx: &Ctx,
        k: usize,
        x: &[f64],
        u: &[f64],
        lam: &[f64],
        mu: &[f64],
        ev: &mut StageEval,
    ) {
        match self {
            TailJob::Evaluate(level) => w.evaluate(ctx, k, x, u, level, ev),
            TailJob::Hessian(sigma) => w.hessian(ctx, k, x, u, sigma, lam, mu, &mut ev.hess),
        }
    }
}

/// Entry k of per-stage multipliers, empty where there are none (an evaluation job).
pub(super) fn at(v: &[Vec<f64>], k: usize) -> &[f64] {
    v.get(k).map_or(&[], Vec::as_slice)
}

impl<D: PointDynamics> Job for Tail<D> {
    fn run(&mut self) {
        for (j, w) in self.work.iter_mut().enumerate() {
            let (x, u) = (&self.zx[j], &self.zu[j]);
            let (lam, mu) = (&self.lam[j], &self.mu[j]);
            let ev = &mut self.out[j];
            self.job
                .run(w, &self.ctx, self.first + j, x, u, lam, mu, ev);
        }
    }
}
