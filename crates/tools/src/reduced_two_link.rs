//! A planar two-link robot hanging from its grip with the elbow angle as a kinematic input.
//!
//! The grip joint is passive and `q1` (the absolute angle of link 1) is cyclic in the kinetic energy,
//! so the momentum conjugate to it, `H = dL/dq1dot = M11(q2) q1dot + M12(q2) q2dot` (the angular
//! momentum about the grip, kg m^2/s), changes only under gravity: `Hdot = -dV/dq1 (q1, q2)`. Dropping
//! the elbow's torque limit makes the elbow rate `u = q2dot` a free input, and the state shrinks to
//! `(q1, H, q2)`:
//!
//! ```text
//! q1dot = (H - M12(q2) u) / M11(q2),   Hdot = -dV/dq1 (q1, q2),   q2dot = u.
//! ```
//!
//! Every motion of the torque-limited robot is a motion of this system, so what this system cannot
//! reach, the robot cannot either. `M11`, `M12` and `dV/dq1` are read from the project's model
//! ([`Robot::mass_matrix`], [`Robot::gravity_into`]) as the few coefficients of their exact
//! trigonometric forms, and checked against it at construction. Units: rad, s, kg m^2/s.
use brachia::model::Scratch;
use brachia::Robot;
use std::f64::consts::{FRAC_PI_2, PI};

/// Why a robot has no reduced model here.
#[derive(Debug, Clone, PartialEq)]
pub enum ReducedModelError {
    /// The robot does not have two links.
    LinkCount(usize),
    /// The model's mass matrix or gravity does not have the two-link forms (largest misfit given).
    Misfit { what: &'static str, misfit: f64 },
}

impl std::fmt::Display for ReducedModelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::LinkCount(n) => {
                write!(f, "the reduced model needs a two-link robot, not {n} links")
            }
            Self::Misfit { what, misfit } => write!(
                f,
                "the model's {what} does not have the two-link form (misfit {misfit:.3e})"
            ),
        }
    }
}

impl std::error::Error for ReducedModelError {}

/// The reduced two-link model: `M11`, `M12` and `dV/dq1` of the robot as trigonometric forms.
#[derive(Debug, Clone)]
pub struct ReducedTwoLink {
    robot: Robot,
    /// `M11(q2) = a0 + a1 cos q2 + a2 sin q2`.
    m11: [f64; 3],
    /// `M12(q2) = b0 + b1 cos q2 + b2 sin q2`.
    m12: [f64; 3],
    /// `dV/dq1 = g0 cos q1 - g1 sin q1 + g2 cos(q1 + q2) - g3 sin(q1 + q2)`.
    dv: [f64; 4],
}

impl ReducedTwoLink {
    /// The reduced model of `robot`, checked against the full model at 64 poses (relative misfit at most
    /// 1e-10).
    pub fn new(robot: &Robot) -> Result<Self, ReducedModelError> {
        if robot.n() != 2 {
            return Err(ReducedModelError::LinkCount(robot.n()));
        }
        let m = |q2: f64| robot.mass_matrix(&[0.0, q2]);
        let (m0, mpi, mh) = (m(0.0), m(PI), m(FRAC_PI_2));
        let fit3 = |a: f64, b: f64, c: f64| [(a + b) / 2.0, (a - b) / 2.0, c - (a + b) / 2.0];
        let m11 = fit3(m0[0], mpi[0], mh[0]);
        let m12 = fit3(m0[1], mpi[1], mh[1]);
        let mut ws = Scratch::new(2);
        let mut g = [0.0; 2];
        let mut grav = |q1: f64, q2: f64| {
            robot.gravity_into(&mut ws, &[q1, q2], &mut g);
            g[0]
        };
        // (0, 0): g0 + g2; (0, pi): g0 - g2; (pi/2, 0): -g1 - g3; (pi/2, pi): -g1 + g3
        let (a, b, c, d) = (
            grav(0.0, 0.0),
            grav(0.0, PI),
            grav(FRAC_PI_2, 0.0),
            grav(FRAC_PI_2, PI),
        );
        let dv = [(a + b) / 2.0, -(c + d) / 2.0, (a - b) / 2.0, (d - c) / 2.0];
        let red = Self {
            robot: robot.clone(),
            m11,
            m12,
            dv,
        };
        red.check()?;
        Ok(red)
    }

    /// Compare the forms with the full model at 64 poses spread over the plane of angles.
    fn check(&self) -> Result<(), ReducedModelError> {
        let mut ws = Scratch::new(2);
        let mut g = [0.0; 2];
        let (mut mis_m, mut mis_g) = (0.0f64, 0.0f64);
        let scale_m = self.m11[0].abs().max(1e-300);
        let scale_g = (self.dv.iter().map(|v| v.abs()).sum::<f64>()).max(1e-300);
        for k in 0..64 {
            let q1 = -PI + 2.0 * PI * ((k * 37 % 64) as f64 + 0.5) / 64.0;
            let q2 = -PI + 2.0 * PI * (k as f64 + 0.25) / 64.0;
            let m = self.robot.mass_matrix(&[q1, q2]);
            mis_m = mis_m
                .max((m[0] - self.m11(q2)).abs() / scale_m)
                .max((m[1] - self.m12(q2)).abs() / scale_m);
            self.robot.gravity_into(&mut ws, &[q1, q2], &mut g);
            mis_g = mis_g.max((g[0] - self.dv_dq1(q1, q2)).abs() / scale_g);
        }
        if mis_m > 1e-10 {
            return Err(ReducedModelError::Misfit {
                what: "mass matrix",
                misfit: mis_m,
            });
        }
        if mis_g > 1e-10 {
            return Err(ReducedModelError::Misfit {
                what: "gravity",
                misfit: mis_g,
            });
        }
        Ok(())
    }

    /// The coefficients of the forms: `M11` (`a0, a1, a2`), `M12` (`b0, b1, b2`) and `dV/dq1`
    /// (`g0 .. g3`), as in the field docs.
    pub fn coefficients(&self) -> ([f64; 3], [f64; 3], [f64; 4]) {
        (self.m11, self.m12, self.dv)
    }

    /// The full robot this model reduces.
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// `M11(q2)`, kg m^2.
    #[inline]
    pub fn m11(&self, q2: f64) -> f64 {
        let (s, c) = q2.sin_cos();
        self.m11[0] + self.m11[1] * c + self.m11[2] * s
    }

    /// `M12(q2)`, kg m^2.
    #[inline]
    pub fn m12(&self, q2: f64) -> f64 {
        let (s, c) = q2.sin_cos();
        self.m12[0] + self.m12[1] * c + self.m12[2] * s
    }

    /// `dV/dq1 (q1, q2)`, N m.
    #[inline]
    pub fn dv_dq1(&self, q1: f64, q2: f64) -> f64 {
        let (s1, c1) = q1.sin_cos();
        let (s12, c12) = (q1 + q2).sin_cos();
        self.dv[0] * c1 - self.dv[1] * s1 + self.dv[2] * c12 - self.dv[3] * s12
    }

    /// An upper bound on `|dV/dq1|` over all poses, N m: `|H|` changes at most this fast.
    pub fn max_dv_dq1(&self) -> f64 {
        self.dv[0].hypot(self.dv[1]) + self.dv[2].hypot(self.dv[3])
    }

    /// `H = M11 q1dot + M12 q2dot` of the full state.
    pub fn momentum(&self, q: [f64; 2], qd: [f64; 2]) -> f64 {
        self.m11(q[1]) * qd[0] + self.m12(q[1]) * qd[1]
    }

    /// `(q1dot, Hdot)` at `(q1, H, q2)` with elbow rate `u`.
    #[inline]
    pub fn rates(&self, q1: f64, h: f64, q2: f64, u: f64) -> (f64, f64) {
        let (s, c) = q2.sin_cos();
        let m11 = self.m11[0] + self.m11[1] * c + self.m11[2] * s;
        let m12 = self.m12[0] + self.m12[1] * c + self.m12[2] * s;
        ((h - m12 * u) / m11, -self.dv_dq1(q1, q2))
    }

    /// The state `[q1, H, q2]` after `dt` s at constant elbow rate `u` (RK4 in `substeps` steps;
    /// `q2` moves exactly, `q2 + u dt`).
    #[inline]
    pub fn step(&self, x: [f64; 3], u: f64, dt: f64, substeps: usize) -> [f64; 3] {
        let [mut q1, mut h, q2s] = x;
        let hs = dt / substeps as f64;
        for k in 0..substeps {
            let q2a = q2s + u * hs * k as f64;
            let q2m = q2a + 0.5 * u * hs;
            let q2b = q2a + u * hs;
            let (k1q, k1h) = self.rates(q1, h, q2a, u);
            let (k2q, k2h) = self.rates(q1 + 0.5 * hs * k1q, h + 0.5 * hs * k1h, q2m, u);
            let (k3q, k3h) = self.rates(q1 + 0.5 * hs * k2q, h + 0.5 * hs * k2h, q2m, u);
            let (k4q, k4h) = self.rates(q1 + hs * k3q, h + hs * k3h, q2b, u);
            q1 += hs / 6.0 * (k1q + 2.0 * k2q + 2.0 * k3q + k4q);
            h += hs / 6.0 * (k1h + 2.0 * k2h + 2.0 * k3h + k4h);
        }
        [q1, h, q2s + u * dt]
    }

    /// The end effector's position at `(q1, q2)`, m.
    pub fn hand(&self, q1: f64, q2: f64) -> [f64; 2] {
        self.robot.ee_position(&[q1, q2])
    }
}
