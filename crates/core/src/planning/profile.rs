//! What a transcription assumes between its collocation points, and what follows from it: the
//! torque profile, the open-loop replay of a plan under that profile, and the fixed-period
//! trajectory handed to a tracker.
//!
//! Each rule of [`Transcription`] assumes its own torque between the points (interval `k` spans
//! `[t_k, t_k+1]`, `h = t_k+1 - t_k`, `r = (t - t_k) / h`):
//! - Euler: `tau(t) = u_k`, held over `[t_k, t_k+1)` (the final knot's torque applies from T on);
//! - trapezoidal: `tau(t) = (1 - r) u_k + r u_k+1`, linear between knots;
//! - Hermite-Simpson: the quadratic through `u_k` (r = 0), the midpoint torque `u_c` (r = 1/2) and
//!   `u_k+1` (r = 1): `2 (r - 1/2)(r - 1) u_k - 4 r (r - 1) u_c + 2 r (r - 1/2) u_k+1`.
//!
//! The state the rules imply between points is cubic Hermite in q with slopes qd and, for the
//! trapezoidal rule and Hermite-Simpson, cubic Hermite in qd with slopes qdd: on a trapezoidal
//! interval the implied state is the quadratic with slopes `f_k`, `f_k+1`, which is that cubic; on a
//! Hermite-Simpson interval it is the cubic through the knots with slopes `f_k`, `f_k+1`, which
//! passes through the midpoint with slope `f_c` (the Hermite and Simpson conditions), so the
//! piecewise cubic through knots and midpoints is that cubic. Euler assumes the acceleration held
//! over the interval: qd is linear between knots (and q, the quadratic, is the cubic Hermite).
//!
//! Units: s, rad, rad/s, N m, m.

use crate::integrate::{self, StepPoint};
use crate::model::{Robot, Scratch};
use crate::planning::settings::{Bounds, Transcription};
use crate::planning::transcription::collocation::Layout;
use crate::trajectory::{hermite_basis, sample_times, Trajectory};
use serde::{Deserialize, Serialize};

/// Largest RK4 step of [`replay_ee_error`], s.
pub const REPLAY_MAX_STEP_S: f64 = 1e-4;

/// The interval holding time `t` (right-continuous: a knot time belongs to the interval it
/// starts; `t >= T` to the last interval).
fn interval_at(points: &Trajectory, layout: &Layout, t: f64) -> usize {
    // binary search for the last knot at or before t
    let (mut lo, mut hi) = (0, layout.intervals);
    while lo < hi {
        let mid = (lo + hi).div_ceil(2);
        if points.t[layout.knot(mid)] <= t {
            lo = mid;
        } else {
            hi = mid - 1;
        }
    }
    lo.min(layout.intervals - 1)
}

/// The torque `rule` assumes at time `t` on interval `k` of `points` (the collocation points of a
/// plan laid out by `layout`), written into `tau` (n - 1). `t` is not clamped: a `t` outside the
/// interval extends its polynomial (and Euler's held value), which is what a solver stage at the
/// interval's end needs.
pub fn torque_in(
    points: &Trajectory,
    layout: &Layout,
    rule: Transcription,
    k: usize,
    t: f64,
    tau: &mut [f64],
) {
    let (a, b) = (layout.knot(k), layout.knot(k + 1));
    let (ta, tb) = (points.t[a], points.t[b]);
    let r = (t - ta) / (tb - ta);
    let (ua, ub) = (points.tau(a), points.tau(b));
    match rule {
        Transcription::Euler | Transcription::MultipleShooting => tau.copy_from_slice(ua),
        Transcription::Trapezoidal => {
            for j in 0..tau.len() {
                tau[j] = (1.0 - r) * ua[j] + r * ub[j];
            }
        }
        Transcription::HermiteSimpson => {
            // The midpoint exists only in a Hermite-Simpson layout; on another layout the rule's
            // quadratic falls back to the mean of the knots (a linear profile).
            let la = 2.0 * (r - 0.5) * (r - 1.0);
            let lc = -4.0 * r * (r - 1.0);
            let lb = 2.0 * r * (r - 0.5);
            for j in 0..tau.len() {
                let uc = if b == a + 2 {
                    points.tau(a + 1)[j]
                } else {
                    0.5 * (ua[j] + ub[j])
                };
                tau[j] = la * ua[j] + lc * uc + lb * ub[j];
            }
        }
    }
}

/// The torque `rule` assumes at time `t` (clamped to `[0, T]`; Euler's held torque ends at T,
/// where the final knot's torque applies), written into `tau` (n - 1).
pub fn torque_at(
    points: &Trajectory,
    layout: &Layout,
    rule: Transcription,
    t: f64,
    tau: &mut [f64],
) {
    let last = points.len() - 1;
    let t = t.clamp(points.t[0], points.t[last]);
    if rule == Transcription::Euler && t >= points.t[last] {
        tau.copy_from_slice(points.tau(last));
        return;
    }
    let k = interval_at(points, layout, t);
    torque_in(points, layout, rule, k, t, tau);
}

/// The mean over `[t0, t1]` of the torque `rule` assumes (clamped to `[0, T]` like [`torque_at`]),
/// written into `tau` (n - 1): the one constant torque to hold over that period. Exact (Simpson's rule
/// on each polynomial piece between the knots inside the period, degree <= 2). `t1 <= t0` gives
/// [`torque_at`] at `t0`.
pub fn torque_mean(
    points: &Trajectory,
    layout: &Layout,
    rule: Transcription,
    t0: f64,
    t1: f64,
    tau: &mut [f64],
) {
    let last = points.len() - 1;
    let (t_start, t_end) = (points.t[0], points.t[last]);
    if t1 <= t0 || t0 >= t_end || t1 <= t_start {
        torque_at(points, layout, rule, t0, tau);
        return;
    }
    let m = tau.len();
    let mut acc = [0.0; crate::model::MAX_LINKS];
    let (mut fa, mut fm, mut fb) = (
        [0.0; crate::model::MAX_LINKS],
        [0.0; crate::model::MAX_LINKS],
        [0.0; crate::model::MAX_LINKS],
    );
    // the parts of [t0, t1] before the start and after the end hold the end values
    for (t, w) in [(t_start, t_start - t0), (t_end, t1 - t_end)] {
        if w > 0.0 {
            torque_at(points, layout, rule, t, &mut fa[..m]);
            for j in 0..m {
                acc[j] += w * fa[j];
            }
        }
    }
    let (a0, b0) = (t0.max(t_start), t1.min(t_end));
    let mut iv = interval_at(points, layout, a0);
    let mut a = a0;
    while a < b0 {
        let b = b0.min(points.t[layout.knot(iv + 1)]);
        if b > a {
            torque_in(points, layout, rule, iv, a, &mut fa[..m]);
            torque_in(points, layout, rule, iv, 0.5 * (a + b), &mut fm[..m]);
            torque_in(points, layout, rule, iv, b, &mut fb[..m]);
            for j in 0..m {
                acc[j] += (b - a) / 6.0 * (fa[j] + 4.0 * fm[j] + fb[j]);
            }
        }
        a = b;
        if iv + 1 >= layout.intervals {
            break;
        }
        iv += 1;
    }
    for j in 0..m {
        tau[j] = acc[j] / (t1 - t0);
    }
}

/// Replay a plan open loop: integrate the model (RK4, an independent path from the transcription's
/// defects) from the first point's state under the torque profile `rule` assumes between the
/// points, in equal steps of at most [`REPLAY_MAX_STEP_S`] on every interval (so Euler's jumps
/// fall on step boundaries), and return the distance of the final EE position from `target`, m.
/// `rule` is normally the plan's own transcription; another rule replays a profile the plan did not
/// assume.
pub fn replay_ee_error(
    robot: &Robot,
    points: &Trajectory,
    layout: &Layout,
    rule: Transcription,
    target: [f64; 2],
) -> f64 {
    let x = replay_final_state(robot, points, layout, rule);
    let ee = robot.ee_position(&x[..robot.n]);
    (ee[0] - target[0]).hypot(ee[1] - target[1])
}

/// The final state `[q, qd]` of the replay of [`replay_ee_error`].
pub fn replay_final_state(
    robot: &Robot,
    points: &Trajectory,
    layout: &Layout,
    rule: Transcription,
) -> Vec<f64> {
    let (n, nx) = (robot.n, robot.nx());
    let mut x = [points.q(0), points.qd(0)].concat();
    let mut ws = Scratch::new(n);
    let mut k = [vec![0.0; nx], vec![0.0; nx], vec![0.0; nx], vec![0.0; nx]];
    let mut tmp = vec![0.0; nx];
    let (mut u0, mut um, mut u1) = (vec![0.0; n - 1], vec![0.0; n - 1], vec![0.0; n - 1]);
    for iv in 0..layout.intervals {
        let (ta, tb) = (points.t[layout.knot(iv)], points.t[layout.knot(iv + 1)]);
        let steps = ((tb - ta) / REPLAY_MAX_STEP_S).ceil().max(1.0) as usize;
        let dt = (tb - ta) / steps as f64;
        for s in 0..steps {
            let t = ta + s as f64 * dt;
            torque_in(points, layout, rule, iv, t, &mut u0);
            torque_in(points, layout, rule, iv, t + 0.5 * dt, &mut um);
            torque_in(points, layout, rule, iv, t + dt, &mut u1);
            integrate::rk4_step(&mut x, dt, &mut k, &mut tmp, |at, x, out| {
                let u = match at {
                    StepPoint::Start => &u0,
                    StepPoint::Middle => &um,
                    StepPoint::End => &u1,
                };
                integrate::deriv(robot, &mut ws, x, u, out)
            });
        }
    }
    x
}

/// How far [`resample`] moved samples to keep them inside the bounds: the largest amount per kind
/// of variable (0 when nothing was clamped).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Clamped {
    /// Joint angles (q1 range and q_rel_max), rad.
    pub q_rad: f64,
    /// Joint velocities (qd_max), rad/s.
    pub qd_rad_s: f64,
    /// Torques (the robot's limits), N m.
    pub tau_nm: f64,
}

/// The plan's trajectory at the fixed period `dt`: samples at [`sample_times`] over `[0, T]` (the
/// last exactly at T), states interpolated as `rule` implies (see the module docs) from the points
/// and their accelerations `qdd` (row-major `points x n`), torques as the torque to hold over each
/// sample period: sample k's torque is the mean of the profile `rule` assumes over `[t_k, t_k+1)`
/// ([`torque_mean`]; the last sample's, the torque at T), so a zero-order hold of the samples, as the
/// closed-loop runner applies them (docs/conventions.md), carries the plan's impulse; then clamped
/// into the planner's bounds and the robot's torque limits. The points satisfy those bounds (the
/// transcription imposes them there), but a polynomial between two points inside a bound can leave
/// it: a cubic Hermite piece on `[t_a, t_b]` by at most `4/27 h (|s_a| + |s_b|)` (its slopes
/// `s_a`, `s_b`, `h = t_b - t_a`: the largest value of the slope basis functions is 4/27), the
/// Hermite-Simpson torque quadratic by at most 1/8 of the spread of its three values, and a linear
/// or held piece not at all. That is the largest error the clamp can introduce; the amounts it
/// did introduce are returned.
pub fn resample(
    robot: &Robot,
    points: &Trajectory,
    qdd: &[f64],
    layout: &Layout,
    rule: Transcription,
    bounds: &Bounds,
    dt: f64,
) -> (Trajectory, Clamped) {
    let (n, m) = (points.n, points.n - 1);
    let last = points.len() - 1;
    let times = sample_times(points.t[0], points.t[last], dt);
    let mut out = Trajectory::new(n);
    let mut clamped = Clamped::default();
    let (mut q, mut qd, mut tau) = (vec![0.0; n], vec![0.0; n], vec![0.0; m]);
    for (si, &t) in times.iter().enumerate() {
        // the piece of the point sequence holding t
        let seg = (points.t.partition_point(|&s| s <= t).max(1) - 1).min(last - 1);
        let (ta, tb) = (points.t[seg], points.t[seg + 1]);
        let h = tb - ta;
        let r = ((t - ta) / h).clamp(0.0, 1.0);
        let (h00, h10, h01, h11) = hermite_basis(r);
        for i in 0..n {
            let (qa, qb) = (points.q(seg)[i], points.q(seg + 1)[i]);
            let (va, vb) = (points.qd(seg)[i], points.qd(seg + 1)[i]);
            q[i] = h00 * qa + h10 * h * va + h01 * qb + h11 * h * vb;
            qd[i] = match rule {
                Transcription::Euler => va + r * (vb - va),
                _ => {
                    let (aa, ab) = (qdd[seg * n + i], qdd[(seg + 1) * n + i]);
                    h00 * va + h10 * h * aa + h01 * vb + h11 * h * ab
                }
            };
        }
        match times.get(si + 1) {
            Some(&t1) => torque_mean(points, layout, rule, t, t1, &mut tau),
            None => torque_at(points, layout, rule, t, &mut tau),
        }
        for i in 0..n {
            let (lo, hi) = if i == 0 {
                (bounds.q1[0], bounds.q1[1])
            } else {
                (-bounds.q_rel_max, bounds.q_rel_max)
            };
            let c = q[i].clamp(lo, hi);
            clamped.q_rad = clamped.q_rad.max((c - q[i]).abs());
            q[i] = c;
            let c = qd[i].clamp(-bounds.qd_max, bounds.qd_max);
            clamped.qd_rad_s = clamped.qd_rad_s.max((c - qd[i]).abs());
            qd[i] = c;
        }
        for j in 0..m {
            let c = tau[j].clamp(robot.tau_min[j], robot.tau_max[j]);
            clamped.tau_nm = clamped.tau_nm.max((c - tau[j]).abs());
            tau[j] = c;
        }
        out.push(t, &q, &qd, &tau);
    }
    (out, clamped)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points of a 2-link chain (one torque) on `layout` over `[0, T]` with torque `u(t)` and a
    /// state of no consequence.
    fn points(layout: &Layout, u: impl Fn(f64) -> f64) -> Trajectory {
        let mut p = Trajectory::new(2);
        for k in 0..layout.points {
            let t = layout.time(k);
            p.push(t, &[-1.0, 0.0], &[0.0, 0.0], &[u(t)]);
        }
        p
    }

    /// Largest |torque_at - u| over a fine grid.
    fn worst(p: &Trajectory, layout: &Layout, rule: Transcription, u: impl Fn(f64) -> f64) -> f64 {
        let t_final = layout.h * layout.intervals as f64;
        let mut tau = [0.0];
        (0..=997)
            .map(|s| {
                let t = t_final * s as f64 / 997.0;
                torque_at(p, layout, rule, t, &mut tau);
                (tau[0] - u(t)).abs()
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn each_rule_is_exact_on_its_polynomial_and_not_on_the_next() {
        let (t_final, intervals) = (1.3, 7);
        let quad = |t: f64| 0.7 - 2.0 * t + 1.5 * t * t;
        let lin = |t: f64| 0.7 - 2.0 * t;
        // Hermite-Simpson: the quadratic through knot, midpoint and knot
        let hs = Layout::new(2, 1, intervals, t_final, Transcription::HermiteSimpson);
        let p = points(&hs, quad);
        assert!(worst(&p, &hs, Transcription::HermiteSimpson, quad) < 1e-12);
        assert!(worst(&p, &hs, Transcription::Trapezoidal, quad) > 1e-3);
        // trapezoidal: linear between knots
        let tr = Layout::new(2, 1, intervals, t_final, Transcription::Trapezoidal);
        let p = points(&tr, lin);
        assert!(worst(&p, &tr, Transcription::Trapezoidal, lin) < 1e-12);
        assert!(worst(&p, &tr, Transcription::Euler, lin) > 1e-2);
        let p = points(&tr, quad);
        assert!(worst(&p, &tr, Transcription::Trapezoidal, quad) > 1e-3);
        // Euler: held over each interval, the final knot's torque from T on
        let eu = Layout::new(2, 1, intervals, t_final, Transcription::Euler);
        let h = eu.h;
        let step = |t: f64| ((t / h + 1e-9).floor().min(intervals as f64 - 1.0) * 0.3).sin();
        let mut p = points(&eu, step);
        let last = p.len() - 1;
        p.tau[last] = 0.0;
        let mut tau = [0.0];
        for k in 0..intervals {
            for r in [0.0, 0.25, 0.999] {
                let t = (k as f64 + r) * h;
                torque_at(&p, &eu, Transcription::Euler, t, &mut tau);
                assert_eq!(tau[0], p.tau(k)[0], "interval {k}, r {r}");
            }
        }
        torque_at(&p, &eu, Transcription::Euler, t_final, &mut tau);
        assert_eq!(tau[0], 0.0);
    }

    #[test]
    fn sample_times_end_exactly_at_the_end_with_a_shorter_last_step() {
        let t = sample_times(0.0, 2.22976, 1e-3);
        assert_eq!(t.len(), 2231);
        assert_eq!(*t.last().unwrap(), 2.22976);
        assert!((t[2229] - 2.229).abs() < 1e-12);
        let t = sample_times(0.0, 2.2293, 1e-3);
        assert_eq!((t.len(), *t.last().unwrap()), (2231, 2.2293));
        // a whole number of periods (up to rounding) has no extra sample
        let t = sample_times(0.0, 0.003 + 1e-15, 1e-3);
        assert_eq!(t.len(), 4);
        assert!(t
            .windows(2)
            .all(|w| w[1] - w[0] > 0.999e-3 && w[1] - w[0] < 1.001e-3));
    }
}
