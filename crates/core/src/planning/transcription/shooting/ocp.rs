//! [`SwingOcp`]: the swing by multiple shooting as a [`brachia_ocp::OcpProblem`] (see the module
//! docs of [`super`]).

use super::dynamics::{AnalyticDynamics, PointDynamics};
use super::parallel::{at, Tail, TailJob};
use super::stage::{Ctx, StageWork};
use super::worker::SpinWorker;
use crate::ad::{Diff, LocalFn};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::planning::settings::Bounds;
use crate::planning::transcription::clearance_fn::DistanceClearanceFn;
use crate::planning::transcription::collocation::EeTerminalFn;
use brachia_ocp::{
    EvalError, EvalLevel, Multipliers, OcpDims, OcpProblem, Primal, StageBounds, StageDims,
    StageEval, TerminalEval,
};
use std::sync::Arc;
use std::time::Instant;

/// What defines a [`SwingOcp`] besides the robot and the clearance rows. Units: s, rad, rad/s, m.
#[derive(Debug, Clone, PartialEq)]
pub struct SwingOcpSpec {
    /// Number of shooting intervals K (>= 1); K + 1 stages.
    pub intervals: usize,
    /// Swing time T, s.
    pub swing_time_s: f64,
    /// RK4 steps per interval (>= 1).
    pub substeps: usize,
    /// Diagonal of Q1 (n), the weight on qd.
    pub q1_diag: Vec<f64>,
    /// Diagonal of R1 (n - 1), the weight on tau.
    pub r1_diag: Vec<f64>,
    /// Start state `[q0, qd0]` (2n), fixed.
    pub x_start: Vec<f64>,
    /// Target bar position, m.
    pub target: [f64; 2],
    /// Box bounds on q and qd (torque limits come from the robot).
    pub bounds: Bounds,
    /// Evaluate half the stages on the problem's helper thread when there are at least this many
    /// (module docs); `usize::MAX` never.
    pub parallel_min_stages: usize,
    /// Impose the clearance rows also at the interior RK4 sub-step states of every interval
    /// (module docs).
    pub substep_clearance: bool,
}

/// Wall time spent in the problem's evaluations, s (accumulated over a solve).
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct ShootingTimings {
    /// Value-only evaluations (line search).
    pub values_s: f64,
    /// Evaluations with first derivatives.
    pub first_order_s: f64,
    /// Hessian evaluations.
    pub hessian_s: f64,
    /// Number of evaluations with first derivatives.
    pub first_order_calls: usize,
    /// Number of Hessian evaluations.
    pub hessian_calls: usize,
}

/// The swing as an [`OcpProblem`] by multiple shooting (see the module docs). Generic over the source
/// of the per-point dynamics derivatives.
pub struct SwingOcp<D: PointDynamics = AnalyticDynamics> {
    ctx: Ctx,
    /// The scratch of stages `0..first` ([`Tail::first`]; all stages without a helper thread).
    work: Vec<StageWork<D>>,
    /// The stages `first..=K`, evaluated on the helper thread.
    tail: Option<SpinWorker<Tail<D>>>,
    dims: OcpDims,
    x_start: Vec<f64>,
    target: [f64; 2],
    bounds: Bounds,
    /// A box `[lo, hi]` on each of the 2n state components at the last knot (rad, rad/s),
    /// intersected with that knot's bounds (`None`: those bounds alone).
    end_box: Option<Vec<[f64; 2]>>,
    tau_lo: Vec<f64>,
    tau_hi: Vec<f64>,
    guess: Primal,
    term_fn: EeTerminalFn,
    term: Diff<EeTerminalFn>,
    term_val: Vec<f64>,
    term_jac: Vec<f64>,
    term_hess: Vec<f64>,
    /// The clearance rows at the start pose (the lower bound of stage 0's sub-step rows is
    /// `min(0, start_c)`).
    start_c: Vec<f64>,
    /// Wall time spent in evaluations since construction (or the last reset by the caller).
    pub timings: ShootingTimings,
}

impl SwingOcp {
    /// Build the problem for `robot` with the closed-form per-point derivatives ([`AnalyticDynamics`]; see
    /// [`SwingOcp::with_dynamics`] for the arguments and errors).
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        spec: SwingOcpSpec,
        clearance: Option<DistanceClearanceFn>,
    ) -> Result<Self> {
        Self::with_dynamics(robot, spec, clearance)
    }
}

impl<D: PointDynamics> SwingOcp<D> {
    /// Build the problem for `robot` with per-point derivatives from `D`. `clearance` gives the stage
    /// inequalities (rows on q_k, k >= 1; `None`: none). The initial guess is zero but for the start
    /// state (set it with [`SwingOcp::guess_mut`]). Errors on sizes that do not match the robot,
    /// `intervals` or `substeps` of 0, or a swing time that is not finite and positive.
    pub fn with_dynamics(
        robot: impl Into<Arc<Robot>>,
        spec: SwingOcpSpec,
        clearance: Option<DistanceClearanceFn>,
    ) -> Result<Self> {
        let robot: Arc<Robot> = robot.into();
        let n = robot.n;
        let (nx, nu) = (2 * n, n - 1);
        let src = "<shooting>";
        for (what, expected, got) in [
            ("shooting: x_start", nx, spec.x_start.len()),
            ("shooting: q1_diag", n, spec.q1_diag.len()),
            ("shooting: r1_diag", nu, spec.r1_diag.len()),
        ] {
            if expected != got {
                return Err(Error::Dimension {
                    what: what.into(),
                    expected,
                    got,
                });
            }
        }
        if spec.intervals == 0 {
            return Err(Error::invalid(src, "intervals", 0, "must be >= 1"));
        }
        if spec.substeps == 0 {
            return Err(Error::invalid(src, "substeps", 0, "must be >= 1"));
        }
        if !(spec.swing_time_s.is_finite() && spec.swing_time_s > 0.0) {
            return Err(Error::invalid(
                src,
                "swing_time_s",
                spec.swing_time_s,
                "must be finite and > 0",
            ));
        }
        if let Some(c) = &clearance {
            if c.n_in() != n {
                return Err(Error::Dimension {
                    what: "shooting: clearance inputs".into(),
                    expected: n,
                    got: c.n_in(),
                });
            }
        }
        let k_last = spec.intervals;
        let n_clear = clearance.as_ref().map_or(0, |c| c.n_out());
        let ctx = Ctx {
            n,
            nx,
            nz: nx + nu,
            horizon: k_last,
            h: spec.swing_time_s / k_last as f64,
            substeps: spec.substeps,
            q1: spec.q1_diag.clone(),
            r1: spec.r1_diag.clone(),
            clearance,
            n_clear,
            sub_clear: spec.substep_clearance,
            free: None,
        };
        let stages: Vec<StageDims> = (0..=k_last)
            .map(|k| StageDims {
                nx,
                nu: if k < k_last { nu } else { 0 },
                nc: ctx.stage_rows(k),
            })
            .collect();
        let dims = OcpDims {
            stages,
            n_terminal: 4,
        };
        let parallel = k_last + 1 >= spec.parallel_min_stages
            && rayon::current_num_threads() > 1
            && rayon::current_thread_index().is_none();
        let first = if parallel {
            k_last.div_ceil(2)
        } else {
            k_last + 1
        };
        let work = (0..first).map(|_| StageWork::new(&robot, &ctx)).collect();
        let tail = parallel.then(|| {
            SpinWorker::spawn(Tail {
                first,
                ctx: ctx.clone(),
                work: (first..=k_last)
                    .map(|_| StageWork::new(&robot, &ctx))
                    .collect(),
                zx: Vec::new(),
                zu: Vec::new(),
                lam: Vec::new(),
                mu: Vec::new(),
                out: Vec::new(),
                job: TailJob::Evaluate(EvalLevel::Values),
            })
        });
        let mut guess = Primal::zeros(&dims);
        guess.x[0].copy_from_slice(&spec.x_start);
        let tau_lo = robot.tau_min.clone();
        let tau_hi = robot.tau_max.clone();
        let term_fn = EeTerminalFn::new(robot);
        let mut ocp = SwingOcp {
            ctx,
            work,
            tail,
            x_start: spec.x_start,
            target: spec.target,
            bounds: spec.bounds,
            end_box: None,
            tau_lo,
            tau_hi,
            guess,
            term: Diff::new(&term_fn),
            term_fn,
            term_val: vec![0.0; 4],
            term_jac: vec![0.0; 4 * nx],
            term_hess: vec![0.0; nx * nx],
            dims,
            start_c: vec![0.0; n_clear],
            timings: ShootingTimings::default(),
        };
        ocp.size_tail();
        ocp.update_start_clearance();
        Ok(ocp)
    }

    /// (Re)size the helper's input and output buffers to the problem's dims (construction, and a
    /// change between a fixed and a free swing time).
    fn size_tail(&mut self) {
        let Some(tail) = &self.tail else { return };
        let mut t = tail.state();
        let first = t.first;
        let stages = &self.dims.stages;
        let nx_next = |k: usize| stages.get(k + 1).map_or(0, |d| d.nx);
        t.zx = stages[first..].iter().map(|d| vec![0.0; d.nx]).collect();
        t.zu = stages[first..].iter().map(|d| vec![0.0; d.nu]).collect();
        t.lam = (first..stages.len())
            .map(|k| vec![0.0; nx_next(k)])
            .collect();
        t.mu = stages[first..].iter().map(|d| vec![0.0; d.nc]).collect();
        t.out = (first..stages.len())
            .map(|k| StageEval::zeros(stages[k], nx_next(k)))
            .collect();
    }

    /// Mark every stage's recorded forward pass stale (the interval or the layout changed).
    fn invalidate_records(&mut self) {
        for w in &mut self.work {
            w.rec_valid = false;
        }
        if let Some(tail) = &self.tail {
            for w in &mut tail.state().work {
                w.rec_valid = false;
            }
        }
    }

    /// Whether half the stages are evaluated on the problem's helper thread (module docs).
    pub fn has_helper_thread(&self) -> bool {
        self.tail.as_ref().is_some_and(SpinWorker::has_thread)
    }

    /// The robot (shared).
    pub fn robot(&self) -> &Arc<Robot> {
        &self.term_fn.robot
    }

    /// The initial guess handed to the solver.
    pub fn guess(&self) -> &Primal {
        &self.guess
    }

    /// The initial guess handed to the solver (x_0 should stay the start state).
    pub fn guess_mut(&mut self) -> &mut Primal {
        &mut self.guess
    }

    /// Shooting interval h = T / K, s (with a free swing time, the start's).
    pub fn interval(&self) -> f64 {
        self.ctx.h
    }

    /// Swing time T = K h, s (with a free swing time, the start's: a point's own is
    /// [`Self::swing_time_of`]).
    pub fn swing_time(&self) -> f64 {
        self.ctx.h * self.ctx.horizon as f64
    }

    /// The fixed start state `x_0` (2n).
    pub fn start(&self) -> &[f64] {
        &self.x_start
    }

    /// The target bar position, m.
    pub fn target(&self) -> [f64; 2] {
        self.target
    }

    /// Set the start state `x_0` in place (2n values; the bounds of stage 0 follow). Errors on the
    /// wrong length or a non-finite value.
    pub fn set_start(&mut self, x: &[f64]) -> Result<()> {
        if x.len() != self.x_start.len() {
            return Err(Error::Dimension {
                what: "shooting: x_start".into(),
                expected: self.x_start.len(),
                got: x.len(),
            });
        }
        if let Some(v) = x.iter().find(|v| !v.is_finite()) {
            return Err(Error::invalid(
                "<shooting>",
                "x_start",
                *v,
                "must be finite",
            ));
        }
        self.x_start.copy_from_slice(x);
        self.guess.x[0][..x.len()].copy_from_slice(x);
        self.update_start_clearance();
        Ok(())
    }

    /// Recompute the clearance rows at the start pose (no allocation).
    fn update_start_clearance(&mut self) {
        let n = self.ctx.n;
        if let Some(cd) = self.work.first().and_then(|w| w.clear.as_ref()) {
            cd.value(&self.x_start[..n], &mut self.start_c);
        }
    }

    /// Set the swing time T in place, keeping K: the interval becomes h = T / K (the recorded
    /// forward passes are dropped). Errors on a time that is not finite and positive, and with a
    /// free swing time (T is then each point's own; see [`Self::with_fixed_swing_time`]).
    pub fn set_swing_time(&mut self, t: f64) -> Result<()> {
        if self.ctx.free.is_some() {
            return Err(Error::invalid(
                "<shooting>",
                "swing_time_s",
                t,
                "the swing time is free (a decision variable): fix it with with_fixed_swing_time",
            ));
        }
        if !(t.is_finite() && t > 0.0) {
            return Err(Error::invalid(
                "<shooting>",
                "swing_time_s",
                t,
                "must be finite and > 0",
            ));
        }
        self.ctx.h = t / self.ctx.horizon as f64;
        self.invalidate_records();
        Ok(())
    }

    /// Make the swing time a decision variable in `[t_min, t_max]` (s): every state gets T as its
    /// last component (`x_k = [q, qd, T]`, `2n + 1` values, carried unchanged from stage to stage by
    /// the dynamics; stage k's interval is `T_k / K`, so all stages share one T at any feasible
    /// point), bounded by `[t_min, t_max]` at every stage (and, unlike q and qd, not fixed at stage
    /// 0: a decision variable). The cost (a quadrature
    /// in time) and the flow then depend on T, the clearance and terminal rows do not. The guess
    /// keeps its knots and takes the current swing time clamped into the range as its T. K is
    /// unchanged. Errors on a range that is not `0 < t_min <= t_max < inf`. Fixes the problem's
    /// dimensions: call it before building a solver on them.
    pub fn with_free_swing_time(mut self, t_min: f64, t_max: f64) -> Result<Self> {
        if !(t_min.is_finite() && t_max.is_finite() && t_min > 0.0 && t_min <= t_max) {
            return Err(Error::invalid(
                "<shooting>",
                "free_swing_time",
                format!("[{t_min}, {t_max}]"),
                "must be 0 < min <= max, finite",
            ));
        }
        let nx = self.ctx.nx;
        let t0 = self.swing_time().clamp(t_min, t_max);
        self.ctx.h = t0 / self.ctx.horizon as f64;
        self.ctx.free = Some([t_min, t_max]);
        for s in &mut self.dims.stages {
            s.nx = nx + 1;
        }
        let mut guess = Primal::zeros(&self.dims);
        for (dst, src) in guess.x.iter_mut().zip(&self.guess.x) {
            dst[..nx].copy_from_slice(&src[..nx]);
            dst[nx] = t0;
        }
        for (dst, src) in guess.u.iter_mut().zip(&self.guess.u) {
            dst.copy_from_slice(src);
        }
        self.guess = guess;
        self.invalidate_records();
        self.size_tail();
        Ok(self)
    }

    /// Back to a fixed swing time `t` (s): the inverse of [`Self::with_free_swing_time`] (the guess
    /// drops its T; the interval becomes `t / K`). Errors on a time that is not finite and positive.
    pub fn with_fixed_swing_time(mut self, t: f64) -> Result<Self> {
        let nx = self.ctx.nx;
        let free = self.ctx.free.take();
        self.set_swing_time(t)?;
        if free.is_some() {
            for s in &mut self.dims.stages {
                s.nx = nx;
            }
            self.guess = self.strip_swing_time(&self.guess);
            self.size_tail();
        }
        Ok(self)
    }

    /// A point of the free-swing-time layout without its T (`x_k = [q, qd]`); a point without T
    /// is copied as it is.
    pub fn strip_swing_time(&self, z: &Primal) -> Primal {
        let nx = self.ctx.nx;
        Primal {
            x: z.x.iter().map(|x| x[..nx.min(x.len())].to_vec()).collect(),
            u: z.u.clone(),
        }
    }

    /// [`Self::strip_swing_time`] into `dst`, a point of the fixed-T layout (no allocation).
    /// Panics on a `dst` of other sizes.
    pub fn strip_swing_time_into(&self, z: &Primal, dst: &mut Primal) {
        let nx = self.ctx.nx;
        for (d, s) in dst.x.iter_mut().zip(&z.x) {
            d.copy_from_slice(&s[..nx]);
        }
        for (d, s) in dst.u.iter_mut().zip(&z.u) {
            d.copy_from_slice(s);
        }
    }

    /// The range of a free swing time ([`Self::with_free_swing_time`]), `None` when T is fixed.
    pub fn free_swing_time(&self) -> Option<[f64; 2]> {
        self.ctx.free
    }

    /// The swing time of a point `z` of this problem: its T (stage 0's) with a free swing time, the
    /// fixed T otherwise, s.
    pub fn swing_time_of(&self, z: &Primal) -> f64 {
        match self.ctx.free {
            Some(_) => z.x[0][self.ctx.nx],
            None => self.swing_time(),
        }
    }

    /// The box bounds of knots 1..K on q and qd (knot 0 is the start state).
    pub fn knot_bounds(&self) -> &Bounds {
        &self.bounds
    }

    /// Set the box bounds of knots 1..K in place (no allocation).
    pub fn set_knot_bounds(&mut self, bounds: &Bounds) {
        self.bounds.clone_from(bounds);
    }

    /// A box on the state at the last knot (2n entries `[lo, hi]`: q then qd; rad, rad/s),
    /// intersected with that knot's own bounds (a component whose intersection is empty keeps the
    /// knot's bound), or `None` for the knot's bounds alone. Errors on a wrong length or a range that
    /// is not `lo <= hi` (infinite ends allowed).
    pub fn set_end_box(&mut self, b: Option<&[[f64; 2]]>) -> Result<()> {
        if let Some(r) = b {
            if r.len() != self.ctx.nx {
                return Err(Error::Dimension {
                    what: "shooting: end box".into(),
                    expected: self.ctx.nx,
                    got: r.len(),
                });
            }
            if let Some(v) = r
                .iter()
                .find(|v| v[0].is_nan() || v[1].is_nan() || v[0] > v[1])
            {
                return Err(Error::invalid(
                    "<shooting>",
                    "end box",
                    format!("{v:?}"),
                    "must have lo <= hi",
                ));
            }
        }
        self.end_box = b.map(<[[f64; 2]]>::to_vec);
        Ok(())
    }

    /// The box set by [`SwingOcp::set_end_box`].
    pub fn end_box(&self) -> Option<&[[f64; 2]]> {
        self.end_box.as_deref()
    }

    /// Set the target bar position in place, m.
    pub fn set_target(&mut self, target: [f64; 2]) {
        self.target = target;
    }

    /// RK4 steps per interval.
    pub fn substeps(&self) -> usize {
        self.ctx.substeps
    }

    /// Number of clearance rows per stage (k >= 1).
    pub fn n_clearance(&self) -> usize {
        self.ctx.n_clear
    }

    /// The flow of stage `k < K` over the current interval, `x_{k+1} = Phi(x, u)` (the dynamics row
    /// of [`OcpProblem::evaluate`], values only), into `out`; `x` and `out` in the problem's layout
    /// (2n, or 2n + 1 with a free swing time: then over `x`'s own T, carried into `out`). Uses
    /// stage k's scratch (no allocation; the recorded forward pass of the Hessian stays valid).
    /// Panics on `k >= K` or wrong sizes.
    pub fn flow(&mut self, k: usize, x: &[f64], u: &[f64], out: &mut [f64]) {
        assert!(
            k < self.ctx.horizon,
            "flow of stage {k}: the last is {}",
            self.ctx.horizon - 1
        );
        let nxp = self.ctx.nx_problem();
        assert!(
            x.len() == nxp && out.len() == nxp,
            "flow: x and out need {nxp} values, got {} and {}",
            x.len(),
            out.len()
        );
        let h = self.ctx.stage_h(x);
        let nx = self.ctx.nx;
        if k < self.work.len() {
            let w = &mut self.work[k];
            w.forward(&self.ctx, x, u, false, h);
            out[..nx].copy_from_slice(&w.xs);
        } else if let Some(tail) = &self.tail {
            let mut t = tail.state();
            let j = k - t.first;
            let w = &mut t.work[j];
            w.forward(&self.ctx, x, u, false, h);
            out[..nx].copy_from_slice(&w.xs);
        }
        if self.ctx.free.is_some() {
            out[self.ctx.nx] = x[self.ctx.nx];
        }
    }

    /// Evaluate the stages: the first half on the calling thread while the helper thread runs
    /// `job` on the second (its inputs copied in, its results copied out), or all of them on the
    /// calling thread (no helper, or called from inside a rayon worker, where the cores are taken).
    /// The multipliers `lam`, `mu` (one entry per stage) are read by a Hessian job only.
    fn for_stages(
        &mut self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        lam: &[Vec<f64>],
        mu: &[Vec<f64>],
        job: TailJob,
        stages: &mut [StageEval],
    ) -> std::result::Result<(), EvalError> {
        let ctx = &self.ctx;
        let own = self.work.len();
        let here = |w: &mut StageWork<D>, k: usize, ev: &mut StageEval| {
            job.run(w, ctx, k, &zx[k], &zu[k], at(lam, k), at(mu, k), ev)
        };
        let threaded = self
            .tail
            .as_ref()
            .is_some_and(|t| t.has_thread() && rayon::current_thread_index().is_none());
        let Some(tail) = self.tail.as_mut().filter(|_| threaded) else {
            // every stage here: the first ones, then the helper's (if any) in its scratch
            for (k, (w, ev)) in self.work.iter_mut().zip(stages.iter_mut()).enumerate() {
                here(w, k, ev);
            }
            if let Some(tail) = &self.tail {
                for (j, w) in tail.state().work.iter_mut().enumerate() {
                    here(w, own + j, &mut stages[own + j]);
                }
            }
            return Ok(());
        };
        {
            let mut t = tail.state();
            let t = &mut *t;
            t.ctx.h = ctx.h;
            t.ctx.free = ctx.free;
            t.job = job;
            for (j, (dx, du)) in t.zx.iter_mut().zip(t.zu.iter_mut()).enumerate() {
                dx.copy_from_slice(&zx[own + j]);
                du.copy_from_slice(&zu[own + j]);
            }
            if let TailJob::Hessian(_) = job {
                // lam at the last stage is not read (and may have any size)
                let k_last = ctx.horizon;
                for (j, (dl, dm)) in t.lam.iter_mut().zip(t.mu.iter_mut()).enumerate() {
                    if own + j < k_last {
                        dl.copy_from_slice(&lam[own + j]);
                    }
                    dm.copy_from_slice(&mu[own + j]);
                }
            }
        }
        tail.post();
        for (k, (w, ev)) in self.work.iter_mut().zip(stages.iter_mut()).enumerate() {
            here(w, k, ev);
        }
        if let Err(msg) = tail.wait() {
            return Err(EvalError {
                stage: own,
                reason: format!(
                    "a stage evaluation on the helper thread (stages {own}..) failed: {msg}"
                ),
            });
        }
        let t = tail.state();
        let k_last = ctx.horizon;
        for (k, (src, dst)) in (own..).zip(t.out.iter().zip(&mut stages[own..])) {
            match job {
                TailJob::Evaluate(level) => {
                    // stage K's f and jac_f are not the problem's (they may have any size)
                    dst.cost = src.cost;
                    dst.c.copy_from_slice(&src.c);
                    if k < k_last {
                        dst.f.copy_from_slice(&src.f);
                    }
                    if level == EvalLevel::FirstOrder {
                        dst.grad.copy_from_slice(&src.grad);
                        dst.jac_c.copy_from_slice(&src.jac_c);
                        if k < k_last {
                            dst.jac_f.copy_from_slice(&src.jac_f);
                        }
                    }
                }
                TailJob::Hessian(_) => dst.hess.copy_from_slice(&src.hess),
            }
        }
        Ok(())
    }

    /// [`OcpProblem::evaluate`] on the knots `zx`, `zu` (K + 1 each) given as slices, so that a
    /// problem made of several swings ([`super::multi_swing::MultiSwingOcp`]) evaluates its phases
    /// in place, without copying them into a [`Primal`]. `stages` holds the K + 1 stages' buffers
    /// (stage K's `f` and `jac_f` are not touched, whatever their size).
    pub(crate) fn evaluate_parts(
        &mut self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> std::result::Result<(), EvalError> {
        self.check_sizes(zx, zu, stages.len())?;
        let t0 = Instant::now();
        self.for_stages(zx, zu, &[], &[], TailJob::Evaluate(level), stages)?;
        let nx = self.ctx.nx;
        let xl = &zx[self.ctx.horizon][..nx];
        if level == EvalLevel::FirstOrder {
            if self.ctx.free.is_some() {
                // the rows do not depend on T: its column stays zero
                self.term
                    .jacobian(&self.term_fn, xl, &mut self.term_val, &mut self.term_jac);
                terminal.jac_r.fill(0.0);
                for r in 0..4 {
                    terminal.jac_r[r * (nx + 1)..r * (nx + 1) + nx]
                        .copy_from_slice(&self.term_jac[r * nx..(r + 1) * nx]);
                }
            } else {
                self.term.jacobian(
                    &self.term_fn,
                    xl,
                    &mut self.term_val,
                    &mut terminal.jac_r[..4 * nx],
                );
            }
        } else {
            self.term.value(&self.term_fn, xl, &mut self.term_val);
        }
        terminal.r[0] = self.term_val[0] - self.target[0];
        terminal.r[1] = self.term_val[1] - self.target[1];
        terminal.r[2] = self.term_val[2];
        terminal.r[3] = self.term_val[3];
        let dt = t0.elapsed().as_secs_f64();
        if level == EvalLevel::FirstOrder {
            self.timings.first_order_s += dt;
            self.timings.first_order_calls += 1;
        } else {
            self.timings.values_s += dt;
        }
        Ok(())
    }

    /// [`OcpProblem::hessians`] on slices (see [`Self::evaluate_parts`]): `lam`, `mu` one entry per
    /// stage (`lam[K]` is not read), `nu` the 4 multipliers of the terminal rows, whose Hessian is
    /// added to stage K's.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn hessians_parts(
        &mut self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        sigma: f64,
        lam: &[Vec<f64>],
        mu: &[Vec<f64>],
        nu: &[f64],
        stages: &mut [StageEval],
    ) -> std::result::Result<(), EvalError> {
        self.check_sizes(zx, zu, stages.len())?;
        if lam.len() != stages.len() || mu.len() != stages.len() || nu.len() != 4 {
            return Err(EvalError {
                stage: 0,
                reason: "multipliers not shaped like the problem's dims".into(),
            });
        }
        let t0 = Instant::now();
        self.for_stages(zx, zu, lam, mu, TailJob::Hessian(sigma), stages)?;
        let k_last = self.ctx.horizon;
        let nx = self.ctx.nx;
        self.term
            .hessian_weighted(&self.term_fn, &zx[k_last][..nx], nu, &mut self.term_hess);
        let nxp = self.ctx.nx_problem();
        let hk = &mut stages[k_last].hess;
        for a in 0..nx {
            for (dst, src) in hk[a * nxp..a * nxp + nx]
                .iter_mut()
                .zip(&self.term_hess[a * nx..(a + 1) * nx])
            {
                *dst += src;
            }
        }
        self.timings.hessian_s += t0.elapsed().as_secs_f64();
        self.timings.hessian_calls += 1;
        Ok(())
    }

    fn check_sizes(
        &self,
        zx: &[Vec<f64>],
        zu: &[Vec<f64>],
        n_stages: usize,
    ) -> std::result::Result<(), EvalError> {
        let n = self.ctx.horizon + 1;
        let ok = n_stages == n
            && zx.len() == n
            && zu.len() == n
            && zx
                .iter()
                .zip(zu)
                .zip(&self.dims.stages)
                .all(|((x, u), d)| x.len() == d.nx && u.len() == d.nu);
        if ok {
            Ok(())
        } else {
            Err(EvalError {
                stage: 0,
                reason: "primal point or buffers not shaped like the problem's dims".into(),
            })
        }
    }
}

impl<D: PointDynamics> OcpProblem for SwingOcp<D> {
    fn dims(&self) -> &OcpDims {
        &self.dims
    }

    fn bounds(&self, k: usize, b: &mut StageBounds) {
        let (n, nx) = (self.ctx.n, self.ctx.nx);
        if let Some([t_lo, t_hi]) = self.ctx.free {
            b.x_lo[nx] = t_lo;
            b.x_hi[nx] = t_hi;
        }
        if k == 0 {
            b.x_lo[..nx].copy_from_slice(&self.x_start);
            b.x_hi[..nx].copy_from_slice(&self.x_start);
        } else {
            let bd = &self.bounds;
            b.x_lo[0] = bd.q1[0];
            b.x_hi[0] = bd.q1[1];
            for i in 1..n {
                b.x_lo[i] = -bd.q_rel_max;
                b.x_hi[i] = bd.q_rel_max;
            }
            let qd = bd.qd_bound(k == self.ctx.horizon);
            for i in 0..n {
                b.x_lo[n + i] = -qd;
                b.x_hi[n + i] = qd;
            }
            if let (Some(e), true) = (&self.end_box, k == self.ctx.horizon) {
                for (i, r) in e.iter().enumerate() {
                    let (lo, hi) = (b.x_lo[i].max(r[0]), b.x_hi[i].min(r[1]));
                    if lo <= hi {
                        b.x_lo[i] = lo;
                        b.x_hi[i] = hi;
                    }
                }
            }
        }
        if k < self.ctx.horizon {
            b.u_lo.copy_from_slice(&self.tau_lo);
            b.u_hi.copy_from_slice(&self.tau_hi);
        }
        b.c_lo.fill(0.0);
        b.c_hi.fill(f64::INFINITY);
        if k == 0 {
            // the sub-step rows of the first interval: no worse than the start pose, which is given
            for (i, lo) in b.c_lo.iter_mut().enumerate() {
                *lo = self.start_c[i % self.ctx.n_clear.max(1)].min(0.0);
            }
        }
    }

    fn initial_guess(&self, z: &mut Primal) {
        z.copy_from(&self.guess);
    }

    fn evaluate(
        &mut self,
        z: &Primal,
        level: EvalLevel,
        stages: &mut [StageEval],
        terminal: &mut TerminalEval,
    ) -> std::result::Result<(), EvalError> {
        self.evaluate_parts(&z.x, &z.u, level, stages, terminal)
    }

    fn hessians(
        &mut self,
        z: &Primal,
        sigma: f64,
        mult: &Multipliers,
        stages: &mut [StageEval],
    ) -> std::result::Result<(), EvalError> {
        if mult.lam.len() != stages.len() || mult.mu.len() != stages.len() {
            return Err(EvalError {
                stage: 0,
                reason: "multipliers not shaped like the problem's dims".into(),
            });
        }
        self.hessians_parts(&z.x, &z.u, sigma, &mult.lam, &mult.mu, &mult.nu, stages)
    }
}
