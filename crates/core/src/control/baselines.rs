//! Baseline controllers to compare the MPC against: open-loop replay of the planned torques and a PD
//! law on the actuated joints around the plan.
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute, the rest relative), torques of
//! joints 2..n in N m, clamped to the robot's limits.

use super::tracking::{TrackerSettings, Tracking};
use super::{ControlInfo, Controller};
use crate::error::{Error, Result};
use crate::model::Robot;
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Replays the planned torques of a reference, ignoring the measured state. Owns shared handles to
/// its robot and reference; [`OpenLoop::set_reference`] swaps the plan.
#[derive(Debug, Clone)]
pub struct OpenLoop {
    robot: Arc<Robot>,
    reference: Arc<Trajectory>,
}

impl OpenLoop {
    /// Replay `reference.tau` (linearly interpolated in time, held after the end). `robot` and
    /// `reference` may be owned values or `Arc`s shared with other users.
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        reference: impl Into<Arc<Trajectory>>,
    ) -> Result<Self> {
        let (robot, reference) = (robot.into(), reference.into());
        reference.check_reference(&robot)?;
        Ok(OpenLoop { robot, reference })
    }

    /// Replay another plan from the next call on (checked like in [`OpenLoop::new`]; on error the
    /// current plan is kept). Passing an `Arc` does not allocate; an owned `Trajectory` is moved into
    /// one new `Arc`.
    pub fn set_reference(&mut self, reference: impl Into<Arc<Trajectory>>) -> Result<()> {
        super::swap_reference(&self.robot, &mut self.reference, reference)
    }

    /// The plan being replayed.
    pub fn reference(&self) -> &Arc<Trajectory> {
        &self.reference
    }

    /// The robot controlled.
    pub fn robot(&self) -> &Arc<Robot> {
        &self.robot
    }
}

impl Controller for OpenLoop {
    fn control(&mut self, t: f64, _x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let nu = self.robot.nu();
        let mut tmp = [0.0; crate::model::MAX_LINKS];
        self.reference.tau_at(t, &mut tmp[..nu]);
        for (j, o) in tau.iter_mut().enumerate().take(nu) {
            *o = tmp[j].clamp(self.robot.tau_min[j], self.robot.tau_max[j]);
        }
        ControlInfo { iterations: 0 }
    }
    fn name(&self) -> &'static str {
        "open-loop"
    }
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        OpenLoop::set_reference(self, reference)
    }
}

/// Gains of the [`Pd`] controller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PdSettings {
    /// Proportional gains on the actuated joint angles q2..qn (n - 1 values), N m/rad. Default empty:
    /// 20 each, filled when the controller is built.
    pub kp: Vec<f64>,
    /// Derivative gains on qd2..qdn (n - 1 values), N m s/rad. Default empty: 1 each, filled when the
    /// controller is built.
    pub kd: Vec<f64>,
    /// Add the planned torque as a feed-forward term. Default true.
    pub feedforward: bool,
}

impl TrackerSettings for PdSettings {
    fn checked(&self, n: usize) -> Result<Self> {
        self.validate(n)?;
        Ok(self.resolved(n))
    }
}

impl Default for PdSettings {
    /// Empty gains: the per-link defaults of [`PdSettings::for_links`], filled in when the controller is
    /// built.
    fn default() -> Self {
        PdSettings {
            kp: Vec::new(),
            kd: Vec::new(),
            feedforward: true,
        }
    }
}

impl PdSettings {
    /// Default gains for an n-link robot.
    pub fn for_links(n: usize) -> Self {
        PdSettings {
            kp: vec![20.0; n.saturating_sub(1)],
            kd: vec![1.0; n.saturating_sub(1)],
            feedforward: true,
        }
    }

    /// These settings with empty gain vectors filled with the per-link defaults.
    pub fn resolved(&self, n: usize) -> Self {
        let d = Self::for_links(n);
        let mut s = self.clone();
        if s.kp.is_empty() {
            s.kp = d.kp;
        }
        if s.kd.is_empty() {
            s.kd = d.kd;
        }
        s
    }

    /// Check sizes and signs for an n-link robot (empty gains stand for the per-link defaults).
    pub fn validate(&self, n: usize) -> Result<()> {
        let s = self.resolved(n);
        for (name, v) in [("kp", &s.kp), ("kd", &s.kd)] {
            if v.len() != n.saturating_sub(1) {
                return Err(Error::invalid(
                    "PdSettings",
                    name,
                    format!("{v:?}"),
                    format!(
                        "needs {} values for the {n}-link robot (one per actuated joint 2..{n}), \
                         or none for the default",
                        n.saturating_sub(1)
                    ),
                ));
            }
            if let Some(x) = v
                .iter()
                .find(|x| !(x.is_finite() && **x >= 0.0 && **x <= 1e9))
            {
                return Err(Error::invalid(
                    "PdSettings",
                    name,
                    x,
                    "gains must be finite, >= 0 and <= 1e9",
                ));
            }
        }
        Ok(())
    }
}

/// `tau_j = tau^d_j + kp_j (q^d_{j+1} - q_{j+1}) + kd_j (qd^d_{j+1} - qd_{j+1})` on the actuated joints
/// (the passive joint 1 is not fed back), clamped to the limits.
/// Owns shared handles to its robot and reference; [`Pd::set_reference`] swaps the plan.
#[derive(Debug, Clone)]
pub struct Pd {
    tr: Tracking<PdSettings>,
}

impl Pd {
    /// A PD tracker of `reference`. `robot` and `reference` may be owned values or shared `Arc`s.
    pub fn new(
        robot: impl Into<Arc<Robot>>,
        reference: impl Into<Arc<Trajectory>>,
        settings: PdSettings,
    ) -> Result<Self> {
        Ok(Pd {
            tr: Tracking::new(robot, reference, &settings)?,
        })
    }

    /// Track another plan from the next call on (checked like in [`Pd::new`]; on error the current
    /// plan is kept). Passing an `Arc` does not allocate; an owned `Trajectory` is moved into one new
    /// `Arc`.
    pub fn set_reference(&mut self, reference: impl Into<Arc<Trajectory>>) -> Result<()> {
        self.tr.set_reference(reference)
    }

    /// The plan being tracked.
    pub fn reference(&self) -> &Arc<Trajectory> {
        &self.tr.reference
    }

    /// The robot controlled.
    pub fn robot(&self) -> &Arc<Robot> {
        &self.tr.robot
    }

    /// The gains in use (empty gains of the settings filled with the per-link defaults).
    pub fn settings(&self) -> &PdSettings {
        &self.tr.settings
    }
}

impl Controller for Pd {
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let tr = &mut self.tr;
        let n = tr.robot.n;
        let nu = n - 1;
        let mut ff = [0.0; crate::model::MAX_LINKS];
        if tr.settings.feedforward {
            tr.reference.tau_at(t, &mut ff[..nu]);
        }
        tr.reference.state_at(t, &mut tr.xref);
        let valid = x.len() == 2 * n;
        for (j, o) in tau.iter_mut().enumerate().take(nu) {
            let mut v = ff[j];
            if valid {
                v += tr.settings.kp[j] * (tr.xref[j + 1] - x[j + 1])
                    + tr.settings.kd[j] * (tr.xref[n + j + 1] - x[n + j + 1]);
            }
            *o = v.clamp(tr.robot.tau_min[j], tr.robot.tau_max[j]);
        }
        ControlInfo { iterations: 0 }
    }
    fn name(&self) -> &'static str {
        "pd"
    }
    fn set_reference(&mut self, reference: Arc<Trajectory>) -> Result<()> {
        Pd::set_reference(self, reference)
    }
}
