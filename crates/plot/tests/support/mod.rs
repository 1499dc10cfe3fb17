//! Synthetic data for the figure tests and the sample renderer: the paper's 4-link robot (Table I)
//! and a smooth swing built from a closed-form pose sequence (no simulation).
#![allow(dead_code)]

use brachia::trajectory::Trajectory;
use brachia::Robot;

/// The paper's robot (Table I).
pub fn paper_robot() -> Robot {
    Robot::paper()
}

/// Start and end poses of the synthetic swing (rad).
pub const Q_START: [f64; 4] = [-2.35, 0.0, -1.55, 0.0];
pub const Q_END: [f64; 4] = [-0.55, -0.6, -1.2, -0.9];

/// A smooth swing from `Q_START` to `Q_END` over `duration` s sampled every `dt` s: quintic blend
/// plus a small wobble, velocities the exact time derivatives, torques a sine per joint.
pub fn swing(duration: f64, dt: f64) -> Trajectory {
    let n = 4;
    let mut tr = Trajectory::new(n);
    let steps = (duration / dt).round() as usize;
    for k in 0..=steps {
        let t = k as f64 * dt;
        let s = t / duration;
        let blend = 10.0 * s.powi(3) - 15.0 * s.powi(4) + 6.0 * s.powi(5);
        let dblend = (30.0 * s.powi(2) - 60.0 * s.powi(3) + 30.0 * s.powi(4)) / duration;
        let w = std::f64::consts::TAU / duration;
        let mut q = [0.0; 4];
        let mut qd = [0.0; 4];
        for i in 0..n {
            let amp = 0.15 * (i as f64 + 1.0) / n as f64;
            q[i] = Q_START[i] + (Q_END[i] - Q_START[i]) * blend + amp * (w * t).sin() * s;
            qd[i] = (Q_END[i] - Q_START[i]) * dblend
                + amp * (w * (w * t).cos() * s + (w * t).sin() / duration);
        }
        let tau: Vec<f64> = (0..3).map(|j| 2.0 * (w * t + j as f64).sin()).collect();
        tr.push(t, &q, &qd, &tau);
    }
    tr
}
