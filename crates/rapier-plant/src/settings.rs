//! Settings of the rapier plant.

use brachia::{Error, Result};
use serde::{Deserialize, Serialize};

/// Largest number of engine steps per plant step accepted by [`RapierSettings::validate`].
const MAX_SUBSTEPS: usize = 1000;

/// How the rapier plant simulates (plain data; check with [`RapierSettings::validate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RapierSettings {
    /// Engine steps per call to `Plant::step`: the engine's time step is `dt / substeps` (at the 1 kHz
    /// control rate, 1 ms / substeps). rapier's integrator is first order, so the plant-model
    /// mismatch roughly halves with each doubling. Default 1; 1..=1000.
    pub substeps: usize,
    /// Whether non-adjacent links collide with each other. Default `false`: the model (and the
    /// planner) ignore self-collision, as the physical links swing in parallel planes. Adjacent links
    /// never collide (their capsules overlap at the shared joint).
    pub self_contacts: bool,
    /// Coulomb friction coefficient of the link capsules (rapier combines it with the other
    /// collider's by averaging). Default 0.5; finite and >= 0.
    pub link_friction: f64,
    /// Restitution of the link capsules. A contact uses the larger of the two colliders'
    /// restitutions. Default 0; in [0, 1].
    pub link_restitution: f64,
}

impl Default for RapierSettings {
    fn default() -> Self {
        RapierSettings {
            substeps: 1,
            self_contacts: false,
            link_friction: 0.5,
            link_restitution: 0.0,
        }
    }
}

impl RapierSettings {
    /// Check every value; errors name the field (`source_name` names the origin, e.g. a file).
    pub fn validate(&self, source_name: &str) -> Result<()> {
        if !(1..=MAX_SUBSTEPS).contains(&self.substeps) {
            return Err(Error::invalid(
                source_name,
                "substeps",
                self.substeps,
                format!("must be between 1 and {MAX_SUBSTEPS}"),
            ));
        }
        if !(self.link_friction.is_finite() && self.link_friction >= 0.0) {
            return Err(Error::invalid(
                source_name,
                "link_friction",
                self.link_friction,
                "must be finite and >= 0",
            ));
        }
        if !(0.0..=1.0).contains(&self.link_restitution) {
            return Err(Error::invalid(
                source_name,
                "link_restitution",
                self.link_restitution,
                "must lie in [0, 1]",
            ));
        }
        Ok(())
    }
}
