//! The capture prediction that decides when [`super::Replanning`] re-plans and whether it adopts a
//! re-plan (docs/replanning.md).
//!
//! A plan's **predicted capture** from the measured state `x` at time `t` is where the closed loop
//! of the tracking controller puts the hand at the swing's end T: a rollout of the **current
//! model** (the planner's robot, or the online estimate of [`super::Adaptive`]) from `x` under
//! TVLQR feedback along the plan (RK4 steps of `predict_dt_s`, the plan's torque at each step's
//! midpoint, clamped to the limits), corrected by the rollout's own discretisation error: the same
//! rollout of the **planner's robot** from the plan's own state at `t` ends off the plan's final
//! hand position by the error of the steps, which is subtracted. The distance of the corrected
//! hand from the bar is the predicted capture error.
//!
//! Units: s, m; state `x = [q (n), qd (n)]`.

use super::{Controller, Tvlqr};
use crate::integrate::Rk4;
use crate::model::Robot;
use crate::trajectory::Trajectory;
use std::sync::Arc;

/// Buffers and models of the capture prediction (allocated once).
#[derive(Debug, Clone)]
pub(crate) struct CapturePredictor {
    rk4: Rk4,
    xr: Vec<f64>,
    xp: Vec<f64>,
    ur: Vec<f64>,
}

/// What is predicted for one plan.
pub(crate) struct PlanUnderTest<'a> {
    /// The plan (absolute times).
    pub reference: &'a Trajectory,
    /// Its TVLQR feedback; `None`: feed-forward only.
    pub lqr: Option<&'a mut Tvlqr>,
}

impl CapturePredictor {
    pub(crate) fn new(robot: &Robot) -> Self {
        CapturePredictor {
            rk4: Rk4::new(robot),
            xr: vec![0.0; robot.nx()],
            xp: vec![0.0; robot.nx()],
            ur: vec![0.0; robot.nu()],
        }
    }

    /// The hand at `t_final` after the rollout of `model` from `x` at `t` along `plan`.
    fn rollout_ee(
        &mut self,
        model: &Robot,
        plan: &mut PlanUnderTest<'_>,
        x: &[f64],
        t: f64,
        t_final: f64,
        dt: f64,
    ) -> [f64; 2] {
        self.xr.copy_from_slice(x);
        let mut s = t;
        while s < t_final - 1e-12 {
            let h = dt.min(t_final - s);
            match plan.lqr.as_deref_mut() {
                Some(l) => l.law(s, s + 0.5 * h, &self.xr, &mut self.ur),
                None => {
                    plan.reference.tau_at(s + 0.5 * h, &mut self.ur);
                    for (j, u) in self.ur.iter_mut().enumerate() {
                        *u = u.clamp(model.tau_min[j], model.tau_max[j]);
                    }
                }
            }
            self.rk4.step(model, &mut self.xr, &self.ur, h);
            s += h;
        }
        let p = model.ee_position(&self.xr[..model.n()]);
        [p[0], p[1]]
    }

    /// The predicted hand at `t_final` of the closed loop along `plan` from `x` at `t` on `model`
    /// (see the module docs), and its distance to `target`, m (infinite when not finite).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn capture(
        &mut self,
        model: &Robot,
        planner_robot: &Robot,
        mut plan: PlanUnderTest<'_>,
        x: &[f64],
        t: f64,
        t_final: f64,
        dt: f64,
        target: [f64; 2],
    ) -> ([f64; 2], f64) {
        let n = planner_robot.n();
        let ee = self.rollout_ee(model, &mut plan, x, t, t_final, dt);
        let mut xp = std::mem::take(&mut self.xp);
        plan.reference.state_at(t, &mut xp);
        let ee_steps = self.rollout_ee(planner_robot, &mut plan, &xp, t, t_final, dt);
        self.xp = xp;
        let last = plan.reference.len() - 1;
        let end = planner_robot.ee_position(&plan.reference.q(last)[..n]);
        let p = [
            ee[0] - (ee_steps[0] - end[0]),
            ee[1] - (ee_steps[1] - end[1]),
        ];
        let d = (p[0] - target[0]).hypot(p[1] - target[1]);
        (p, if d.is_finite() { d } else { f64::INFINITY })
    }

    /// The distance from `target` of the hand at `t_final` when `ctrl` (a copy of the tracking
    /// controller) drives `model` from `x` at `t`, called every `period` (its torque held, RK4
    /// sub-steps of at most 2 ms); with `switch = Some((t_s, plan))` it is handed `plan` at the
    /// first call at or after `t_s` (a re-plan's latency). Infinite when not finite.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn closed_loop_capture(
        &mut self,
        ctrl: &mut dyn Controller,
        model: &Robot,
        x: &[f64],
        t: f64,
        t_final: f64,
        period: f64,
        switch: Option<(f64, &Arc<Trajectory>)>,
        target: [f64; 2],
    ) -> f64 {
        self.xr.copy_from_slice(x);
        let mut s = t;
        let mut pending = switch;
        while s < t_final - 1e-12 {
            if let Some((ts, plan)) = pending {
                if s >= ts - 1e-9 {
                    let _ = ctrl.set_reference(Arc::clone(plan));
                    pending = None;
                }
            }
            ctrl.control(s, &self.xr, &mut self.ur);
            let h = period.min(t_final - s);
            let m = (h / 2e-3).ceil().max(1.0) as usize;
            for _ in 0..m {
                self.rk4.step(model, &mut self.xr, &self.ur, h / m as f64);
            }
            s += h;
        }
        let p = model.ee_position(&self.xr[..model.n()]);
        let d = (p[0] - target[0]).hypot(p[1] - target[1]);
        if d.is_finite() {
            d
        } else {
            f64::INFINITY
        }
    }
}

/// The measured state averaged over the last control steps, relative to the tracked plan: the
/// mean of `x_k - x^d(t_k)` over the samples kept, added to `x^d(t)` (sensor noise averages out, a
/// hit's deviation stays; the plan's own motion does not lag). Keeps at most `cap` samples, each
/// as its deviation from the plan it was measured against (allocated once).
#[derive(Debug, Clone)]
pub(crate) struct StateAverage {
    cap: usize,
    /// The deviations `x_k - x^d(t_k)`, `cap` rows of nx.
    dev: Vec<f64>,
    next: usize,
    len: usize,
    mean: Vec<f64>,
}

impl StateAverage {
    pub(crate) fn new(nx: usize, cap: usize) -> Self {
        let cap = cap.max(1);
        StateAverage {
            cap,
            dev: vec![0.0; cap * nx],
            next: 0,
            len: 0,
            mean: vec![0.0; nx],
        }
    }

    /// Keep the state `x` measured at `t`, as its deviation from `plan` there (the oldest sample
    /// is dropped when full). Every sample until the next [`Self::clear`] is measured against the
    /// same plan.
    pub(crate) fn push(&mut self, plan: &Trajectory, t: f64, x: &[f64]) {
        let nx = self.mean.len();
        let dev = &mut self.dev[self.next * nx..(self.next + 1) * nx];
        plan.state_at(t, dev);
        for (d, &xi) in dev.iter_mut().zip(x) {
            *d = xi - *d;
        }
        self.next = (self.next + 1) % self.cap;
        self.len = (self.len + 1).min(self.cap);
    }

    /// Drop every sample kept: called when the tracked plan changes, since a deviation from the old
    /// plan does not hold for the new one (which starts from the measured state).
    pub(crate) fn clear(&mut self) {
        self.next = 0;
        self.len = 0;
    }

    /// The averaged state at `t` relative to `plan` (the plan the samples were kept against),
    /// written into `out` (nx values); the samples kept, at least one (`x` itself when none is
    /// kept).
    pub(crate) fn state(&mut self, plan: &Trajectory, t: f64, x: &[f64], out: &mut [f64]) -> usize {
        if self.len <= 1 {
            out.copy_from_slice(x);
            return 1;
        }
        let nx = self.mean.len();
        self.mean.fill(0.0);
        for dk in self.dev.chunks_exact(nx).take(self.len) {
            for (m, &d) in self.mean.iter_mut().zip(dk) {
                *m += d;
            }
        }
        plan.state_at(t, out);
        for i in 0..nx {
            out[i] += self.mean[i] / self.len as f64;
        }
        self.len
    }
}

#[cfg(test)]
mod tests {
    use super::StateAverage;
    use crate::trajectory::Trajectory;

    /// A plan of one link moving at 1 rad/s: q = t, qd = 1 (n = 1, no torque).
    fn ramp() -> Trajectory {
        let mut tr = Trajectory::new(1);
        for k in 0..=100 {
            let t = k as f64 * 0.01;
            tr.push(t, &[t], &[1.0], &[]);
        }
        tr
    }

    #[test]
    fn a_constant_offset_from_the_plan_is_kept_and_a_glitch_is_diluted() {
        let plan = ramp();
        let mut avg = StateAverage::new(2, 4);
        let mut out = [0.0; 2];
        // nothing kept yet: the measured state itself
        assert_eq!(avg.state(&plan, 0.5, &[9.0, 9.0], &mut out), 1);
        assert_eq!(out, [9.0, 9.0]);
        // on the plan + (0.1, -0.2): the average is the plan at t + the offset, whatever t
        for k in 0..6 {
            let t = 0.3 + k as f64 * 0.001;
            avg.push(&plan, t, &[t + 0.1, 1.0 - 0.2]);
        }
        let t = 0.305;
        assert_eq!(avg.state(&plan, t, &[0.0, 0.0], &mut out), 4);
        assert!((out[0] - (t + 0.1)).abs() < 1e-12, "{out:?}");
        assert!((out[1] - 0.8).abs() < 1e-12, "{out:?}");
        // one sample off by 0.4 rad/s moves the average by a quarter of it
        avg.push(&plan, 0.306, &[0.406, 1.0 + 0.4]);
        avg.state(&plan, 0.306, &[0.0, 0.0], &mut out);
        let expect = (3.0 * -0.2 + 0.4) / 4.0;
        assert!((out[1] - (1.0 + expect)).abs() < 1e-12, "{out:?}");
    }

    /// The ramp started at `t0`: q = t - t0, qd = 1 from `t0` on.
    fn ramp_from(t0: f64) -> Trajectory {
        let mut tr = Trajectory::new(1);
        for k in 0..=100 {
            let t = t0 + k as f64 * 0.01;
            tr.push(t, &[t - t0], &[1.0], &[]);
        }
        tr
    }

    #[test]
    fn samples_from_before_a_new_plan_are_dropped_when_the_plan_changes() {
        // 0.05 rad ahead of the old plan for 0.2 s (a hit's deviation), then a new plan from the
        // state measured at 0.2 s and one sample on it
        let old = ramp_from(0.0);
        let new = ramp_from(0.2);
        let mut avg = StateAverage::new(2, 200);
        for k in 0..200 {
            let t = k as f64 * 0.001;
            avg.push(&old, t, &[t + 0.05, 1.0]);
        }
        let t = 0.2;
        let mut out = [0.0; 2];
        // relative to the old plan the samples average to it plus the deviation
        avg.state(&old, 0.199, &[0.249, 1.0], &mut out);
        assert!(
            (out[0] - 0.249).abs() < 1e-12 && (out[1] - 1.0).abs() < 1e-12,
            "{out:?}"
        );
        let on_new = [0.0, 1.0];
        // kept, the old samples' deviation is added to the new plan, which starts at the measured
        // state already: biased
        let mut biased = avg.clone();
        biased.push(&new, t, &on_new);
        biased.state(&new, t, &on_new, &mut out);
        assert!(out[0] > 0.04, "{out:?}");
        // cleared, the average is the state on the new plan
        avg.clear();
        assert_eq!(avg.state(&new, t, &on_new, &mut out), 1);
        assert_eq!(out, on_new);
        avg.push(&new, t, &on_new);
        avg.push(&new, t + 0.001, &[0.001, 1.0]);
        assert_eq!(avg.state(&new, t + 0.001, &[0.001, 1.0], &mut out), 2);
        assert!(
            (out[0] - 0.001).abs() < 1e-12 && (out[1] - 1.0).abs() < 1e-12,
            "{out:?}"
        );
    }
}
