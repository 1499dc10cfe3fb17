//! The reward of a swing environment: named terms, each reported every step, and their weights.
//!
//! `reward = capture [captured] + progress (d_prev - d) - energy E_k - positive_work W_k -
//! out_of_limits [left the limits]`, with `d` the distance of the plant's hand to the bar (m), `E_k`
//! the paper's eq. (18) over the control period (the signed work of the actuated joints,
//! `sum_j tau_j qd_j dt`, J) and `W_k` its positive part per joint (J). The rates are taken by the
//! trapezoid of the period's end points; the torque is the commanded one clamped to the robot's
//! limits.

use brachia::Error;
use serde::{Deserialize, Serialize};

/// Weights of the reward terms (each >= 0).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct RewardWeights {
    /// Bonus on the step that captures the bar. Default 10.
    pub capture: f64,
    /// Per metre the hand came closer to the bar during the step (potential-based shaping).
    /// Default 5.
    pub progress: f64,
    /// Per joule of the paper's eq. (18) energy (signed work of the actuated joints). Default 0.
    pub energy: f64,
    /// Per joule of positive work of the actuated joints. Default 0.1.
    pub positive_work: f64,
    /// Penalty on the step that leaves the limits (or diverges). Default 5.
    pub out_of_limits: f64,
}

impl Default for RewardWeights {
    fn default() -> Self {
        RewardWeights {
            capture: 10.0,
            progress: 5.0,
            energy: 0.0,
            positive_work: 0.1,
            out_of_limits: 5.0,
        }
    }
}

impl RewardWeights {
    /// Check every weight is finite and >= 0; errors name `src` and `reward.<field>`.
    pub fn validate(&self, src: &str) -> Result<(), Error> {
        for (name, v) in [
            ("capture", self.capture),
            ("progress", self.progress),
            ("energy", self.energy),
            ("positive_work", self.positive_work),
            ("out_of_limits", self.out_of_limits),
        ] {
            if !(v.is_finite() && (0.0..=1e6).contains(&v)) {
                return Err(Error::invalid(
                    src,
                    format!("reward.{name}"),
                    v,
                    "a weight must be finite and in [0, 1e6]",
                ));
            }
        }
        Ok(())
    }

    /// The weighted sum of `terms`.
    pub fn reward(&self, t: &RewardTerms) -> f64 {
        self.capture * t.capture + self.progress * t.progress_m
            - self.energy * t.energy_j
            - self.positive_work * t.positive_work_j
            - self.out_of_limits * t.out_of_limits
    }
}

/// The unweighted terms of one step.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct RewardTerms {
    /// 1 on the step that captures the bar, else 0.
    pub capture: f64,
    /// How much closer the hand came to the bar, m (negative when it moved away).
    pub progress_m: f64,
    /// The paper's eq. (18) over the step: signed work of the actuated joints, J.
    pub energy_j: f64,
    /// Positive work of the actuated joints over the step, J.
    pub positive_work_j: f64,
    /// 1 on the step that leaves the limits (or diverges), else 0.
    pub out_of_limits: f64,
}
