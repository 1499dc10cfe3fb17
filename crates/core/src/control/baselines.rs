//! Baseline controllers to compare the MPC against: open-loop replay of the planned torques and a PD
//! law on the actuated joints around the plan.
//!
//! Conventions: state `x = [q (n), qd (n)]` (rad, rad/s; q1 absolute, the rest relative), torques of
//! joints 2..n in N m, clamped to the robot's limits.

use crate::error::{Error, Result};
use crate::model::Robot;
use crate::sim::{ControlInfo, Controller};
use crate::trajectory::Trajectory;
use serde::{Deserialize, Serialize};

/// Planned torque of `reference` at time `t` (linear interpolation, held past the ends) into `out`.
fn planned_tau(reference: &Trajectory, t: f64, out: &mut [f64]) {
    let nu = reference.n - 1;
    let (k, r) = reference.locate(t);
    let k1 = (k + 1).min(reference.len() - 1);
    for j in 0..nu {
        let a = reference.tau[k * nu + j];
        let b = reference.tau[k1 * nu + j];
        out[j] = a + r * (b - a);
    }
}

fn check_reference(robot: &Robot, reference: &Trajectory) -> Result<()> {
    if reference.n != robot.n {
        return Err(Error::Dimension {
            what: "reference links".into(),
            expected: robot.n,
            got: reference.n,
        });
    }
    if reference.is_empty() {
        return Err(Error::invalid(
            "reference",
            "len",
            0,
            "the reference needs at least one sample",
        ));
    }
    Ok(())
}

/// Replays the planned torques of a reference, ignoring the measured state.
#[derive(Debug, Clone)]
pub struct OpenLoop<'a> {
    robot: &'a Robot,
    reference: &'a Trajectory,
}

impl<'a> OpenLoop<'a> {
    /// Replay `reference.tau` (linearly interpolated in time, held after the end).
    pub fn new(robot: &'a Robot, reference: &'a Trajectory) -> Result<Self> {
        check_reference(robot, reference)?;
        Ok(OpenLoop { robot, reference })
    }
}

impl Controller for OpenLoop<'_> {
    fn control(&mut self, t: f64, _x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let nu = self.robot.nu();
        let mut tmp = [0.0; crate::model::MAX_LINKS];
        planned_tau(self.reference, t, &mut tmp[..nu]);
        for (j, o) in tau.iter_mut().enumerate().take(nu) {
            *o = tmp[j].clamp(self.robot.tau_min[j], self.robot.tau_max[j]);
        }
        ControlInfo { iterations: 0 }
    }
    fn name(&self) -> &'static str {
        "open-loop"
    }
}

/// Gains of the [`Pd`] controller.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PdSettings {
    /// Proportional gains on the actuated joint angles q2..qn (n - 1 values), N m/rad. Default 20.
    pub kp: Vec<f64>,
    /// Derivative gains on qd2..qdn (n - 1 values), N m s/rad. Default 1.
    pub kd: Vec<f64>,
    /// Add the planned torque as a feed-forward term. Default true.
    pub feedforward: bool,
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
#[derive(Debug, Clone)]
pub struct Pd<'a> {
    robot: &'a Robot,
    reference: &'a Trajectory,
    settings: PdSettings,
    xref: Vec<f64>,
}

impl<'a> Pd<'a> {
    /// A PD tracker of `reference`.
    pub fn new(robot: &'a Robot, reference: &'a Trajectory, settings: PdSettings) -> Result<Self> {
        check_reference(robot, reference)?;
        settings.validate(robot.n)?;
        Ok(Pd {
            robot,
            reference,
            settings: settings.resolved(robot.n),
            xref: vec![0.0; robot.nx()],
        })
    }
}

impl Controller for Pd<'_> {
    fn control(&mut self, t: f64, x: &[f64], tau: &mut [f64]) -> ControlInfo {
        let n = self.robot.n;
        let nu = n - 1;
        let mut ff = [0.0; crate::model::MAX_LINKS];
        if self.settings.feedforward {
            planned_tau(self.reference, t, &mut ff[..nu]);
        }
        self.reference.state_at(t, &mut self.xref);
        let valid = x.len() == 2 * n;
        for (j, o) in tau.iter_mut().enumerate().take(nu) {
            let mut v = ff[j];
            if valid {
                v += self.settings.kp[j] * (self.xref[j + 1] - x[j + 1])
                    + self.settings.kd[j] * (self.xref[n + j + 1] - x[n + j + 1]);
            }
            *o = v.clamp(self.robot.tau_min[j], self.robot.tau_max[j]);
        }
        ControlInfo { iterations: 0 }
    }
    fn name(&self) -> &'static str {
        "pd"
    }
}
