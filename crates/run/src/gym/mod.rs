//! Learning environments on the plants: one swing from a start state to a bar as a sequential
//! decision problem ([`SwingEnv`]), and a batch of them stepped in parallel ([`SwingBatch`]). The
//! Python package wraps them as Gymnasium's `brachia/Swing-v0` and its vector env (docs/rl.md).
//!
//! Conventions as in `brachia`: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute from +x, the
//! rest relative), torques of joints 2..n (N m), grip frame (m), time s.
//!
//! - **Action** (n - 1 values in [-1, 1], clipped): `tau_j = mid_j + half_j a_j` over the robot's
//!   torque range, held for one control period (`control_dt`, default 10 ms) while the plant
//!   integrates at `plant_dt` (default 1 ms) underneath.
//! - **Observation** (2n + 3 values, float32): the measured state (after the sensor disturbances),
//!   the target bar relative to the hand (the hand from the measured angles and the nominal
//!   robot), and the time left (s); each clipped to [`SwingEnvSpec::observation_bounds`].
//! - **Termination**: capture by the rule of every run ([`crate::success::hand_at_bar`]: the
//!   plant's true hand within [`crate::SUCCESS_RADIUS_M`] of the bar and no faster than
//!   [`crate::CAPTURE_SPEED_M_S`], tested after every control period), or the true state leaving
//!   the limits (`max_angle_rad`, `max_rate_rad_s`, or a diverged plant). **Truncation**: at
//!   `time_limit_s`.
//! - **Randomness**: each env owns a ChaCha8 generator seeded by `reset(seed)`; every episode draws
//!   its own seed from it, and the episode's disturbances ([`Randomization`]) are drawn from that.

mod batch;
mod env;
mod randomize;
mod reward;

pub use batch::{Autoreset, BatchOutput, SwingBatch};
pub use env::{StepOutcome, SwingEnv, SwingEnvSpec};
pub use randomize::Randomization;
pub use reward::{RewardTerms, RewardWeights};

use brachia::Error;
use serde::{Deserialize, Serialize};

/// Settings of a swing environment (what the scenario file does not say).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct SwingEnvSettings {
    /// Control period: one action is held this long, s (a whole number of `plant_dt`, at most
    /// 0.1). Default 0.01.
    pub control_dt: f64,
    /// Integration step of the plant under the held action, s (at most 0.01). Default 0.001.
    pub plant_dt: f64,
    /// Episode length: truncation when this much time has passed, s (at most 60). Default 3.
    pub time_limit_s: f64,
    /// Limit on every joint angle, rad: beyond it the episode terminates. Default 6.283185307179586.
    pub max_angle_rad: f64,
    /// Limit on every joint rate, rad/s: beyond it the episode terminates. Default 40.
    pub max_rate_rad_s: f64,
    /// Weights of the reward terms ([`RewardWeights`]).
    pub reward: RewardWeights,
}

impl Default for SwingEnvSettings {
    fn default() -> Self {
        SwingEnvSettings {
            control_dt: 0.01,
            plant_dt: 0.001,
            time_limit_s: 3.0,
            max_angle_rad: std::f64::consts::TAU,
            max_rate_rad_s: 40.0,
            reward: RewardWeights::default(),
        }
    }
}

/// Longest episode, s.
pub const MAX_TIME_LIMIT_S: f64 = 60.0;

impl SwingEnvSettings {
    /// Check every value; errors name `src`, the field, the value and the rule.
    pub fn validate(&self, src: &str) -> Result<(), Error> {
        let range = |field: &str, v: f64, lo: f64, hi: f64, rule: &str| {
            if v.is_finite() && v > lo && v <= hi {
                Ok(())
            } else {
                Err(Error::invalid(src, field, v, rule.to_string()))
            }
        };
        range(
            "plant_dt",
            self.plant_dt,
            0.0,
            0.01,
            "must be in (0, 0.01] s",
        )?;
        range(
            "control_dt",
            self.control_dt,
            0.0,
            0.1,
            "must be in (0, 0.1] s",
        )?;
        let k = self.control_dt / self.plant_dt;
        if k.round() > brachia::limits::MAX_SUBSTEPS as f64 {
            // every control period runs k plant steps: a tiny plant_dt makes one step unbounded
            return Err(Error::invalid(
                src,
                "plant_dt",
                self.plant_dt,
                format!(
                    "control_dt = {} s would take {k:.3e} plant steps per control period; at most \
                     {} (brachia::limits::MAX_SUBSTEPS)",
                    self.control_dt,
                    brachia::limits::MAX_SUBSTEPS
                ),
            ));
        }
        if (k - k.round()).abs() > 1e-9 * k.max(1.0) || k.round() < 1.0 {
            return Err(Error::invalid(
                src,
                "control_dt",
                self.control_dt,
                format!(
                    "must be a whole number of plant steps (plant_dt = {} s)",
                    self.plant_dt
                ),
            ));
        }
        range(
            "time_limit_s",
            self.time_limit_s,
            0.0,
            MAX_TIME_LIMIT_S,
            "must be in (0, 60] s",
        )?;
        if self.time_limit_s < self.control_dt {
            return Err(Error::invalid(
                src,
                "time_limit_s",
                self.time_limit_s,
                format!(
                    "must be at least one control period (control_dt = {} s)",
                    self.control_dt
                ),
            ));
        }
        range(
            "max_angle_rad",
            self.max_angle_rad,
            0.0,
            brachia::limits::MAX_ANGLE_RAD,
            "must be in (0, 4 pi] rad",
        )?;
        range(
            "max_rate_rad_s",
            self.max_rate_rad_s,
            0.0,
            brachia::limits::MAX_RATE_RAD_S,
            "must be in (0, 1000] rad/s",
        )?;
        self.reward.validate(src)
    }

    /// Plant steps per control period.
    pub fn substeps(&self) -> usize {
        (self.control_dt / self.plant_dt).round() as usize
    }

    /// Control periods per episode.
    pub fn episode_steps(&self) -> usize {
        ((self.time_limit_s / self.control_dt) - 1e-9)
            .ceil()
            .max(1.0) as usize
    }
}
