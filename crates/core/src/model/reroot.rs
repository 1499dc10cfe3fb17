//! The grasp switch as its own map: the chain re-rooted at its swing hand.
//!
//! Conventions (repeated from the crate docs): `q[0]` absolute angle of link 1 from +x (counter-clockwise
//! positive), `q[i]` relative angles; state `x = [q, qd]` (rad, rad/s); torques of joints 2..n (N m);
//! positions in m, world frame x right, y up, gravity along -y.
//!
//! When the swing hand (the EE, distal tip of link n) takes the next bar and the old grip lets go, the same
//! physical chain hangs from the other end. Re-rooted, link `j'` (1-based) is the old link `n + 1 - j'`:
//! - **parameters**: lengths, masses, inertias and radii in reversed order; the centre of mass measured
//!   from the other end (`com' = length - com`); the torque limits of joint `j'` are those of the old
//!   joint `n + 2 - j'` with the sign reversed (`tau' = -tau`, `[tau_min', tau_max'] = [-tau_max,
//!   -tau_min]`), since the relative angle is measured the other way round;
//! - **state**: `th'_j = th_{n+1-j} + pi` (every link points the other way), so `q'_1 = th_n + pi`
//!   (wrapped into (-pi, pi]), `q'_j = -q_{n+2-j}` for j >= 2; velocities `qd'_1 = thd_n = qd_1 + ... +
//!   qd_n`, `qd'_j = -qd_{n+2-j}`. The map is affine with a constant linear part `P` (`q' = P q + (pi, 0..)`,
//!   `qd' = P qd`), and `P P = I`: applied twice it is the identity;
//! - **grip**: the new grip is the old EE in world coordinates.
//!
//! The map keeps every world point of the chain where it is. World velocities agree as well exactly when
//! the EE is at rest (paper eq. 9): then the switch is impulse-free. Otherwise the hand closing on the bar
//! is an inelastic impact; [`switch_grip`] models it with both hands momentarily on their bars (the
//! impulse at the EE that stops it, `qd+ = qd - M^-1 J^T (J M^-1 J^T)^-1 J qd`), reports the EE speed as
//! the switch residual and the kinetic energy the impact takes out, then re-roots.

use super::{ActuatorParams, LinkParams, Robot, RobotParams, P2};
use crate::error::{Error, Result};
use std::f64::consts::PI;

/// Wrap an angle into (-pi, pi].
fn wrap(a: f64) -> f64 {
    let tau = std::f64::consts::TAU;
    let mut v = a % tau;
    if v <= -PI {
        v += tau;
    } else if v > PI {
        v -= tau;
    }
    v
}

impl RobotParams {
    /// The parameters of the same chain re-rooted at its EE (see the module docs): links reversed, each
    /// centre of mass measured from the other end, torque limits reversed in order and sign. The name is
    /// kept. Applied twice it returns the original values (up to the rounding of `length - com`).
    pub fn rerooted(&self) -> RobotParams {
        let n = self.links.len();
        let links = (0..n)
            .rev()
            .map(|i| {
                let l = &self.links[i];
                // the joint at the new proximal end is the old distal joint (none at the new grip)
                let joint = self.links.get(i + 1).filter(|_| i + 1 < n);
                LinkParams {
                    length: l.length,
                    mass: l.mass,
                    com: l.length - l.com,
                    inertia: l.inertia,
                    radius: l.radius,
                    com_across: -l.com_across,
                    joint_offset: joint.map_or(0.0, |j| -j.joint_offset),
                    joint_reversed: joint.is_some_and(|j| !j.joint_reversed),
                    q_min: joint.and_then(|j| j.q_max.map(|v| -v)),
                    q_max: joint.and_then(|j| j.q_min.map(|v| -v)),
                    qd_max: joint.and_then(|j| j.qd_max),
                }
            })
            .collect();
        let a = &self.actuators;
        RobotParams {
            name: self.name.clone(),
            gravity: self.gravity,
            links,
            actuators: ActuatorParams {
                tau_min: a.tau_max.iter().rev().map(|v| -v).collect(),
                tau_max: a.tau_min.iter().rev().map(|v| -v).collect(),
            },
            end_effector: None,
        }
    }
}

impl Robot {
    /// The same chain re-rooted at its EE (see [`RobotParams::rerooted`]).
    /// Refused for a robot whose end effector is not the distal end of its last link (its grip
    /// would not be at a joint of the re-rooted chain).
    pub fn rerooted(&self) -> Result<Robot> {
        if !self.ee_default {
            return Err(Error::invalid(
                "robot",
                "end_effector",
                format!("{:?}", self.ee),
                "a robot whose end effector is not the distal end of its last link cannot switch grips",
            ));
        }
        Robot::from_params(self.params.rerooted(), "re-rooted robot")
    }
}

/// Map a state `x = [q, qd]` of an n-link chain to the re-rooted chain's state (see the module docs):
/// `q'_1 = wrap(q_1 + ... + q_n + pi)`, `q'_j = -q_{n+2-j}`, `qd'_1 = qd_1 + ... + qd_n`,
/// `qd'_j = -qd_{n+2-j}`. `out` holds 2n values.
pub fn reroot_state(x: &[f64], out: &mut [f64]) {
    let n = x.len() / 2;
    let (q, qd) = x.split_at(n);
    out[0] = wrap(q.iter().sum::<f64>() + PI);
    out[n] = qd.iter().sum();
    for j in 1..n {
        out[j] = -q[n - j];
        out[n + j] = -qd[n - j];
    }
}

/// The constant linear part `P` of [`reroot_state`] (the map is `x' = P x + (wrap shift of q'_1)`):
/// `out` holds the `2n x cols` row-major Jacobian `d x' / d x` in its first 2n columns (`cols >= 2n`;
/// the other columns are left as they are). Row 0 and row n are sums (ones over q, over qd), row j
/// and row n + j (j >= 1) pick `-q_{n+1-j}`, `-qd_{n+1-j}` (1-based).
pub fn reroot_jacobian(n: usize, cols: usize, out: &mut [f64]) {
    for r in 0..2 * n {
        out[r * cols..r * cols + 2 * n].fill(0.0);
    }
    for i in 0..n {
        out[i] = 1.0;
        out[n * cols + n + i] = 1.0;
    }
    for j in 1..n {
        out[j * cols + n - j] = -1.0;
        out[(n + j) * cols + 2 * n - j] = -1.0;
    }
}

/// Map torques of joints 2..n to the re-rooted chain's joints: `tau'_j = -tau_{n+2-j}` (the order and
/// sign reversed; the power `tau' . qd'` is unchanged).
pub fn reroot_tau(tau: &[f64], out: &mut [f64]) {
    for (o, t) in out.iter_mut().zip(tau.iter().rev()) {
        *o = -t;
    }
}

/// The outcome of a grasp switch.
#[derive(Debug, Clone, PartialEq)]
pub struct GripSwitch {
    /// The re-rooted chain's state `[q', qd']` at the new grip.
    pub x: Vec<f64>,
    /// The new grip (the old EE) in world coordinates, m.
    pub grip: P2<f64>,
    /// The switch residual: the EE speed just before the hand closed, m/s (0 for an impulse-free switch).
    pub ee_speed: f64,
    /// Kinetic energy taken out by the capture impact, J (0 for an impulse-free switch).
    pub impact_energy_j: f64,
}

/// Switch the grip of `robot`, hanging from `grip` (world, m) in state `x`, to its EE: stop the EE by the
/// capture impulse (both hands on their bars for an instant; nothing changes when the EE is at rest),
/// then re-root ([`reroot_state`]); the new chain is `robot.rerooted()`. Errors when the chain is stretched
/// so straight that the EE Jacobian loses rank (no finite impulse stops the hand).
pub fn switch_grip(robot: &Robot, grip: P2<f64>, x: &[f64]) -> Result<GripSwitch> {
    let n = robot.n;
    if x.len() != 2 * n {
        return Err(Error::Dimension {
            what: "grip switch: state".into(),
            expected: 2 * n,
            got: x.len(),
        });
    }
    let (q, qd) = x.split_at(n);
    let v = robot.ee_velocity(q, qd);
    let ee_speed = v[0].hypot(v[1]);
    let mut xs = x.to_vec();
    let mut impact_energy_j = 0.0;
    if ee_speed > 0.0 {
        // qd+ = qd - M^-1 J^T lambda, (J M^-1 J^T) lambda = J qd
        let mut jac = vec![0.0; 2 * n];
        robot.ee_jacobian(q, &mut jac);
        let m = robot.mass_matrix(q);
        let mut minv_jt = vec![0.0; 2 * n]; // two rows: M^-1 J_x^T, then M^-1 J_y^T
        for r in 0..2 {
            let mut a = m.clone();
            let mut b = jac[r * n..(r + 1) * n].to_vec();
            if brachia_linalg::cholesky_solve_in_place(
                &mut a,
                n,
                &mut b,
                brachia_linalg::Scaling::Reciprocal,
                brachia_linalg::Scaling::Divide,
            )
            .is_err()
            {
                return Err(Error::InfeasibleTask(format!(
                    "grip switch: the mass matrix at this pose is not positive definite ({q:?})"
                )));
            }
            minv_jt[r * n..(r + 1) * n].copy_from_slice(&b);
        }
        let dot = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>();
        let a00 = dot(&jac[..n], &minv_jt[..n]);
        let a01 = dot(&jac[..n], &minv_jt[n..]);
        let a11 = dot(&jac[n..], &minv_jt[n..]);
        let det = a00 * a11 - a01 * a01;
        if !(det.is_finite() && det > 1e-12 * (a00 * a11).max(f64::MIN_POSITIVE)) {
            return Err(Error::InfeasibleTask(format!(
                "grip switch: the chain is stretched straight (det(J M^-1 J^T) = {det:.3e}); the EE \
                 moving at {ee_speed:.3e} m/s cannot be stopped by a finite impulse"
            )));
        }
        let lam = [
            (a11 * v[0] - a01 * v[1]) / det,
            (a00 * v[1] - a01 * v[0]) / det,
        ];
        impact_energy_j = 0.5 * (lam[0] * v[0] + lam[1] * v[1]);
        for i in 0..n {
            xs[n + i] -= minv_jt[i] * lam[0] + minv_jt[n + i] * lam[1];
        }
    }
    let ee = robot.ee_position(q);
    let mut out = vec![0.0; 2 * n];
    reroot_state(&xs, &mut out);
    Ok(GripSwitch {
        x: out,
        grip: [grip[0] + ee[0], grip[1] + ee[1]],
        ee_speed,
        impact_energy_j,
    })
}
