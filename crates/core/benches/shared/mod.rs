//! What the benches' manual passes share: order statistics of timings, and a plan's knots as the
//! primal of its problem.
#![allow(dead_code)]

use brachia::planning::Plan;
use brachia_ocp::{OcpDims, Primal};

/// The `q` quantile of `v` by nearest rank: the smallest value with at least a fraction `q` of
/// the values at or below it (`q = 0.5`: the median, `1.0`: the largest).
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let i = ((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    v[i]
}

/// The median of `v` ([`quantile`] at 0.5).
pub fn median(v: &[f64]) -> f64 {
    quantile(v, 0.5)
}

/// The plan's knots as the primal of a problem of `dims` (its states at every knot, its torques
/// on every interval).
pub fn plan_primal(dims: &OcpDims, p: &Plan) -> Primal {
    let k_last = p.layout.intervals;
    let mut z = Primal::zeros(dims);
    for k in 0..=k_last {
        z.x[k] = [p.points.q(k), p.points.qd(k)].concat();
        if k < k_last {
            z.u[k] = p.points.tau(k).to_vec();
        }
    }
    z
}
