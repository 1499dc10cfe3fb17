//! Disturbances as data: one value (a scenario's `[disturbances]` section) that says what differs
//! between the planner's world and the plant's, and builds the plant-wrapper stack and the plant's
//! robot from it. Units and defaults: docs/robustness.md.
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the rest relative),
//! torques of joints 2..n (N m), time s, links numbered 1..n in files and 0..n-1 in code.

use super::{
    delay_steps, validate_pushes, ActuationDelay, JointFriction, MeasurementDelay, MotorLag,
    NoiseSettings, Noisy, Plant, Push, Pushes, TorqueLimit, TorqueNoise,
};
use crate::error::{Error, Result};
use crate::model::RobotParams;
use serde::{Deserialize, Serialize};

/// Largest factor of a model mismatch (`mass_scale`, `com_scale`, `inertia_scale`, `length_scale`);
/// the smallest is its inverse.
pub const MAX_MISMATCH_FACTOR: f64 = 10.0;

/// Largest start offset on an angle, rad (on a rate: 10 times this, rad/s).
pub const MAX_START_OFFSET_RAD: f64 = 1.0;

/// The one body of [`Disturbances::wrap`] and [`Disturbances::wrap_send`]: the wrapper stack, from
/// the plant outward (the boxed type is the caller's).
macro_rules! wrap_stack {
    ($d:expr, $plant:expr, $control_dt:expr) => {{
        let d: &Disturbances = $d;
        let control_dt: f64 = $control_dt;
        let mut p = $plant;
        if !d.pushes.is_empty() {
            p = Box::new(Pushes::new(p, &d.pushes)?);
        }
        if d.coulomb_nm > 0.0 || d.viscous_nm_s > 0.0 {
            p = Box::new(JointFriction::new(p, d.coulomb_nm, d.viscous_nm_s)?);
        }
        if let Some(l) = d.torque_limit_nm {
            p = Box::new(TorqueLimit::new(p, l)?);
        }
        if d.torque_noise_std > 0.0 {
            p = Box::new(TorqueNoise::new(
                p,
                d.torque_noise_std,
                d.seed.wrapping_add(1),
            )?);
        }
        if d.motor_time_constant_s > 0.0 {
            p = Box::new(MotorLag::new(p, d.motor_time_constant_s)?);
        }
        let k = delay_steps("disturbances", d.actuation_delay_s, control_dt)?;
        if k > 0 {
            p = Box::new(ActuationDelay::new(p, k)?);
        }
        let noise = NoiseSettings {
            q_std: d.noise_q_std,
            qd_std: d.noise_qd_std,
            seed: d.seed,
        };
        if !noise.is_zero() {
            p = Box::new(Noisy::new(p, noise)?);
        }
        let k = delay_steps("disturbances", d.measurement_delay_s, control_dt)?;
        if k > 0 {
            p = Box::new(MeasurementDelay::new(p, k)?);
        }
        Ok(p)
    }};
}

/// What differs between the planner's world and the plant's. Every field defaults to "nothing".
///
/// The plant wrappers are stacked, from the controller to the plant: measurement delay, sensor noise
/// (on what the controller sees); actuation delay, motor lag, torque noise, torque limit, joint
/// friction, pushes (on what the torque does); the plant's robot carries the model mismatch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(default, deny_unknown_fields)]
pub struct Disturbances {
    /// Factor on each link's mass (n values, link 1 first; empty: 1). Default none.
    pub mass_scale: Vec<f64>,
    /// Factor on each link's centre-of-mass distance from its proximal joint. Default none.
    pub com_scale: Vec<f64>,
    /// Factor on each link's inertia about its centre of mass. Default none.
    pub inertia_scale: Vec<f64>,
    /// Factor on each link's length (the centre of mass keeps its distance unless `com_scale` says
    /// otherwise). Default none.
    pub length_scale: Vec<f64>,
    /// Coulomb friction on the actuated joints, N m ([`JointFriction`]). Default 0.
    pub coulomb_nm: f64,
    /// Viscous damping on the actuated joints, N m s/rad. Default 0.
    pub viscous_nm_s: f64,
    /// Sensor noise on measured q, standard deviation, rad ([`Noisy`]). Default 0.
    pub noise_q_std: f64,
    /// Sensor noise on measured qd, standard deviation, rad/s. Default 0.
    pub noise_qd_std: f64,
    /// Measurement delay, s (rounded to control periods; [`MeasurementDelay`]). Default 0.
    pub measurement_delay_s: f64,
    /// Actuation delay, s (rounded to control periods; [`ActuationDelay`]). Default 0.
    pub actuation_delay_s: f64,
    /// Torque noise, standard deviation per joint and control period, N m ([`TorqueNoise`]). Default 0.
    pub torque_noise_std: f64,
    /// First-order motor time constant, s ([`MotorLag`]). Default 0 (none).
    pub motor_time_constant_s: f64,
    /// Symmetric torque limit of the plant's motors, N m, below the planner's ([`TorqueLimit`]).
    /// Default none.
    pub torque_limit_nm: Option<f64>,
    /// Offset of the plant's start state from the plan's, `[dq (n), dqd (n)]` (rad, rad/s; empty:
    /// none). Default none.
    pub start_offset: Vec<f64>,
    /// Impulsive pushes ([`Push`]: `t_s`, `link` 1..n, `point_m`, `impulse_n_s`). Default none.
    pub pushes: Vec<Push>,
    /// Seed of the sensor and torque noise (ChaCha8; the torque noise uses `seed + 1`). Default 0.
    pub seed: u64,
}

impl Disturbances {
    /// Check every value for an n-link robot at control period `control_dt`; errors name the field
    /// (`mass_scale[2]`, `pushes[0].link`), the value and the rule; `src` names the source.
    pub fn validate(&self, n: usize, control_dt: f64, src: &str) -> Result<()> {
        let fmax = MAX_MISMATCH_FACTOR;
        for (name, v) in [
            ("mass_scale", &self.mass_scale),
            ("com_scale", &self.com_scale),
            ("inertia_scale", &self.inertia_scale),
            ("length_scale", &self.length_scale),
        ] {
            if !v.is_empty() && v.len() != n {
                return Err(Error::invalid(
                    src,
                    name,
                    format!("{} values", v.len()),
                    format!("needs {n} values (one per link 1..{n}) or none"),
                ));
            }
            for (i, f) in v.iter().enumerate() {
                if !(f.is_finite() && (1.0 / fmax..=fmax).contains(f)) {
                    return Err(Error::invalid(
                        src,
                        format!("{name}[{i}]"),
                        f,
                        format!("a factor must be finite and in [{}, {fmax}]", 1.0 / fmax),
                    ));
                }
            }
        }
        let nonneg = |name: &str, v: f64, max: f64| -> Result<()> {
            if v.is_finite() && (0.0..=max).contains(&v) {
                Ok(())
            } else {
                Err(Error::invalid(
                    src,
                    name,
                    v,
                    format!("must be finite and in [0, {max}]"),
                ))
            }
        };
        let lim = crate::limits::MAX_FRICTION;
        nonneg("coulomb_nm", self.coulomb_nm, lim)?;
        nonneg("viscous_nm_s", self.viscous_nm_s, lim)?;
        let lim = crate::limits::MAX_NOISE_STD;
        nonneg("noise_q_std", self.noise_q_std, lim)?;
        nonneg("noise_qd_std", self.noise_qd_std, lim)?;
        nonneg(
            "torque_noise_std",
            self.torque_noise_std,
            crate::limits::MAX_TORQUE_NOISE_NM,
        )?;
        nonneg(
            "motor_time_constant_s",
            self.motor_time_constant_s,
            crate::limits::MAX_MOTOR_TAU_S,
        )?;
        let rename = |e: Error, field: &str| match e {
            Error::InvalidValue { value, reason, .. } => Error::InvalidValue {
                source_name: src.to_string(),
                field: field.to_string(),
                value,
                reason,
            },
            other => other,
        };
        delay_steps(src, self.measurement_delay_s, control_dt)
            .map_err(|e| rename(e, "measurement_delay_s"))?;
        delay_steps(src, self.actuation_delay_s, control_dt)
            .map_err(|e| rename(e, "actuation_delay_s"))?;
        if let Some(l) = self.torque_limit_nm {
            if !(l.is_finite() && l > 0.0 && l <= 1e6) {
                return Err(Error::invalid(
                    src,
                    "torque_limit_nm",
                    l,
                    "must be finite and > 0 N m",
                ));
            }
        }
        if !self.start_offset.is_empty() && self.start_offset.len() != 2 * n {
            return Err(Error::invalid(
                src,
                "start_offset",
                format!("{} values", self.start_offset.len()),
                format!("needs {} values [dq (n), dqd (n)] or none", 2 * n),
            ));
        }
        for (i, v) in self.start_offset.iter().enumerate() {
            let max = if i < n {
                MAX_START_OFFSET_RAD
            } else {
                10.0 * MAX_START_OFFSET_RAD
            };
            if !(v.is_finite() && v.abs() <= max) {
                return Err(Error::invalid(
                    src,
                    format!("start_offset[{i}]"),
                    v,
                    format!("must be finite with |value| <= {max} (rad for q, rad/s for qd)"),
                ));
            }
        }
        validate_pushes(src, n, &self.pushes)
    }

    /// True when nothing is disturbed.
    pub fn is_none(&self) -> bool {
        *self
            == Disturbances {
                seed: self.seed,
                ..Disturbances::default()
            }
    }

    /// The plant's robot parameters: `params` with the model mismatch applied (call after
    /// [`Disturbances::validate`]; the result is checked by `Robot::from_params`).
    pub fn plant_params(&self, params: &RobotParams) -> RobotParams {
        let mut p = params.clone();
        let f = |v: &Vec<f64>, i: usize| v.get(i).copied().unwrap_or(1.0);
        for (i, l) in p.links.iter_mut().enumerate() {
            l.mass *= f(&self.mass_scale, i);
            l.com *= f(&self.com_scale, i);
            l.inertia *= f(&self.inertia_scale, i);
            l.length *= f(&self.length_scale, i);
        }
        p
    }

    /// The plant's start state: `x0` plus the start offset.
    pub fn start_state(&self, x0: &[f64]) -> Vec<f64> {
        let mut x = x0.to_vec();
        for (v, d) in x.iter_mut().zip(&self.start_offset) {
            *v += d;
        }
        x
    }

    /// Wrap `plant` in the disturbances' wrappers (only those that change something), for control
    /// period `control_dt` (call after [`Disturbances::validate`]).
    pub fn wrap<'a>(
        &self,
        plant: Box<dyn Plant + 'a>,
        control_dt: f64,
    ) -> Result<Box<dyn Plant + 'a>> {
        wrap_stack!(self, plant, control_dt)
    }

    /// [`Disturbances::wrap`] for a plant that can move between threads (a batch of plants stepped
    /// in parallel): the same wrappers in the same order.
    pub fn wrap_send<'a>(
        &self,
        plant: Box<dyn Plant + Send + 'a>,
        control_dt: f64,
    ) -> Result<Box<dyn Plant + Send + 'a>> {
        wrap_stack!(self, plant, control_dt)
    }
}
