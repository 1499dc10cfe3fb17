//! The benchmark's scorecard (`scorecard.json`) as the benchmark page reads it.

use serde::Deserialize;
use std::collections::BTreeMap;

#[derive(Debug, Deserialize)]
pub(super) struct Scorecard {
    pub(super) scenario: String,
    pub(super) success_radius_m: f64,
    /// The capture speed of the success rule, m/s (schema 2 on; absent in a schema 1 scorecard,
    /// whose rule judged the hand at the end of the swing).
    #[serde(default)]
    pub(super) capture_speed_m_s: Option<f64>,
    pub(super) sweeps: Vec<SweepDef>,
    pub(super) controllers: Vec<ControllerCard>,
}

#[derive(Debug, Deserialize)]
pub(super) struct SweepDef {
    pub(super) name: String,
    pub(super) level: String,
    pub(super) levels: Vec<f64>,
}

#[derive(Debug, Deserialize)]
pub(super) struct ControllerCard {
    pub(super) controller: String,
    pub(super) robustness_score: f64,
    pub(super) overall: Score,
    pub(super) per_disturbance: BTreeMap<String, Score>,
}

#[derive(Debug, Deserialize)]
pub(super) struct Score {
    pub(super) runs: usize,
    pub(super) success_pct: f64,
    pub(super) energy_j: f64,
    pub(super) peak_torque_nm: f64,
    pub(super) smoothness_nm: f64,
    pub(super) final_error_m: f64,
}
