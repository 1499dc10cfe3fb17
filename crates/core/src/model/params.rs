//! Robot parameters: the TOML schema (`RobotParams`) and the validated model (`Robot`).
//!
//! Conventions (repeated from the crate docs): a planar serial chain of `n` links hangs from the grip
//! point at the origin; gravity acts along -y. Lengths in m, masses in kg, inertias in kg m^2 (planar,
//! about the link's centre of mass), torques in N m. `com` is the distance of the centre of mass from the
//! link's proximal joint, measured along the link.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Largest number of links a robot may have (the model code keeps small fixed-size stack buffers).
pub const MAX_LINKS: usize = 12;

/// Largest link length, mass, inertia, radius or torque limit accepted (SI units): beyond it the
/// model's products overflow or lose all precision.
pub const LINK_VALUE_MAX: f64 = 1e6;

/// One link as written in a parameters file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkParams {
    /// Length from proximal to distal joint, m.
    pub length: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Distance of the centre of mass from the proximal joint along the link, m (0 <= com <= length).
    pub com: f64,
    /// Planar rotational inertia about the centre of mass, kg m^2.
    pub inertia: f64,
    /// Capsule radius used for collision checking, m. Default 0.02.
    #[serde(default = "default_radius")]
    pub radius: f64,
}

fn default_radius() -> f64 {
    0.02
}

fn default_gravity() -> f64 {
    9.81
}

/// Torque limits of the actuated joints 2..n.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ActuatorParams {
    /// Lower torque limit per actuated joint, N m (n - 1 values).
    pub tau_min: Vec<f64>,
    /// Upper torque limit per actuated joint, N m (n - 1 values).
    pub tau_max: Vec<f64>,
}

/// A robot as written in a TOML parameters file (see `params/paper.toml`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RobotParams {
    /// A name for reports.
    #[serde(default)]
    pub name: String,
    /// Gravitational acceleration, m/s^2 (acts along -y). Default 9.81.
    #[serde(default = "default_gravity")]
    pub gravity: f64,
    /// Links from the grip (link 1) to the swinging end (link n).
    pub links: Vec<LinkParams>,
    /// Torque limits.
    pub actuators: ActuatorParams,
}

impl RobotParams {
    /// Parse a TOML string; `source_name` names the origin in error messages.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self> {
        toml::from_str(text).map_err(|e| Error::Parse {
            path: source_name.into(),
            message: e.to_string().trim_end().replace('\n', " "),
        })
    }

    /// Read and parse a TOML file (not yet validated: see [`Robot::from_params`]).
    pub fn from_toml_file(path: &Path) -> Result<Self> {
        let text = crate::limits::read_text_capped(
            path,
            crate::limits::MAX_TOML_BYTES,
            "parameters file",
        )?;
        Self::from_toml_str(&text, &path.display().to_string())
    }

    /// Scale every link mass and inertia by `factor` (a model mismatch for robustness studies).
    pub fn with_mass_scale(mut self, factor: f64) -> Self {
        for l in &mut self.links {
            l.mass *= factor;
            l.inertia *= factor;
        }
        self
    }

    /// Check every value; `source_name` names the origin in error messages.
    pub fn validate(&self, source_name: &str) -> Result<()> {
        let bad = |field: String, value: f64, reason: &str| {
            Err(Error::invalid(source_name, field, value, reason))
        };
        let gmax = crate::limits::MAX_GRAVITY;
        if !(self.gravity.is_finite() && self.gravity >= 0.0 && self.gravity <= gmax) {
            return bad(
                "gravity".into(),
                self.gravity,
                &format!("must be in [0, {gmax}] m/s^2"),
            );
        }
        let n = self.links.len();
        if !(2..=MAX_LINKS).contains(&n) {
            return Err(Error::invalid(
                source_name,
                "links",
                format!("{n} links"),
                format!("a robot needs between 2 and {MAX_LINKS} links"),
            ));
        }
        for (i, l) in self.links.iter().enumerate() {
            let f = |name: &str| format!("links[{i}].{name}");
            for (name, v) in [
                ("length", l.length),
                ("mass", l.mass),
                ("inertia", l.inertia),
                ("radius", l.radius),
            ] {
                if !v.is_finite() || v <= 0.0 {
                    return bad(f(name), v, "must be a finite number > 0");
                }
                if v > LINK_VALUE_MAX {
                    return bad(
                        f(name),
                        v,
                        &format!("must be at most {LINK_VALUE_MAX:e} (SI units)"),
                    );
                }
            }
            if !l.com.is_finite() || l.com < 0.0 || l.com > l.length {
                return bad(f("com"), l.com, "must lie on the link: 0 <= com <= length");
            }
        }
        let a = &self.actuators;
        for (name, v) in [
            ("actuators.tau_min", &a.tau_min),
            ("actuators.tau_max", &a.tau_max),
        ] {
            if v.len() != n - 1 {
                return Err(Error::invalid(
                    source_name,
                    name,
                    format!("{v:?}"),
                    format!("needs {} values, one per actuated joint 2..{n}", n - 1),
                ));
            }
            if let Some(x) = v
                .iter()
                .find(|x| !x.is_finite() || x.abs() > LINK_VALUE_MAX)
            {
                return bad(
                    name.into(),
                    *x,
                    &format!("must be finite and at most {LINK_VALUE_MAX:e} N m in magnitude"),
                );
            }
        }
        for j in 0..n - 1 {
            if a.tau_min[j] > 0.0 || a.tau_max[j] < 0.0 || a.tau_min[j] >= a.tau_max[j] {
                return Err(Error::invalid(
                    source_name,
                    format!("actuators.tau_min[{j}], actuators.tau_max[{j}]"),
                    format!("[{}, {}]", a.tau_min[j], a.tau_max[j]),
                    "limits must satisfy tau_min <= 0 <= tau_max and tau_min < tau_max",
                ));
            }
        }
        Ok(())
    }
}

/// A validated robot: the data every model function trusts, with constant coefficients precomputed.
///
/// The fields are read through accessors ([`Robot::n`], [`Robot::lengths`], ...) so that they cannot
/// go stale against the precomputed coefficients: a different robot is built from changed
/// [`RobotParams`] with [`Robot::from_params`].
#[derive(Debug, Clone, PartialEq)]
pub struct Robot {
    /// The parameters it was built from.
    pub(crate) params: RobotParams,
    /// Number of links (= joints) n.
    pub(crate) n: usize,
    /// Link lengths, m.
    pub(crate) len: Vec<f64>,
    /// Link masses, kg.
    pub(crate) mass: Vec<f64>,
    /// Centre-of-mass distances from the proximal joints, m.
    pub(crate) com: Vec<f64>,
    /// Planar inertias about the centres of mass, kg m^2.
    pub(crate) inertia: Vec<f64>,
    /// Capsule radii, m.
    pub(crate) radius: Vec<f64>,
    /// Gravitational acceleration, m/s^2.
    pub gravity: f64,
    /// Lower torque limits of joints 2..n, N m.
    pub tau_min: Vec<f64>,
    /// Upper torque limits of joints 2..n, N m.
    pub tau_max: Vec<f64>,
    /// Mass-matrix coefficients in absolute angles, row-major n x n:
    /// `M_abs[j][k] = d[j][k] cos(th_j - th_k)` (plus nothing: the inertia is in `d[j][j]`).
    pub(crate) d: Vec<f64>,
    /// Gravity coefficients in absolute angles: `dV/dth_j = gcoef[j] cos(th_j)`.
    pub(crate) gcoef: Vec<f64>,
    /// Potential coefficients per link: `V = sum_j gcoef[j] sin(th_j)` (same numbers as `gcoef`).
    pub(crate) total_mass: f64,
}

/// The text of the paper's parameter file, bundled inside the crate so that it packages on its own.
pub const PAPER_TOML: &str = include_str!("../../params/paper.toml");

impl Robot {
    /// Validate `params` and precompute the model coefficients.
    pub fn from_params(params: RobotParams, source_name: &str) -> Result<Self> {
        params.validate(source_name)?;
        let n = params.links.len();
        let len: Vec<f64> = params.links.iter().map(|l| l.length).collect();
        let mass: Vec<f64> = params.links.iter().map(|l| l.mass).collect();
        let com: Vec<f64> = params.links.iter().map(|l| l.com).collect();
        let inertia: Vec<f64> = params.links.iter().map(|l| l.inertia).collect();
        let radius: Vec<f64> = params.links.iter().map(|l| l.radius).collect();
        // mass distal to link j (links j+1..n)
        let distal: Vec<f64> = (0..n).map(|j| mass[j + 1..].iter().sum()).collect();
        let mut d = vec![0.0; n * n];
        for j in 0..n {
            d[j * n + j] = mass[j] * com[j] * com[j] + len[j] * len[j] * distal[j] + inertia[j];
            for k in j + 1..n {
                let v = len[j] * (mass[k] * com[k] + len[k] * distal[k]);
                d[j * n + k] = v;
                d[k * n + j] = v;
            }
        }
        let gcoef = (0..n)
            .map(|j| params.gravity * (mass[j] * com[j] + len[j] * distal[j]))
            .collect();
        Ok(Robot {
            n,
            gravity: params.gravity,
            tau_min: params.actuators.tau_min.clone(),
            tau_max: params.actuators.tau_max.clone(),
            total_mass: mass.iter().sum(),
            params,
            len,
            mass,
            com,
            inertia,
            radius,
            d,
            gcoef,
        })
    }

    /// Load and validate a TOML parameters file.
    pub fn from_toml_file(path: &Path) -> Result<Self> {
        let p = RobotParams::from_toml_file(path)?;
        Self::from_params(p, &path.display().to_string())
    }

    /// The paper's robot (Table I), from the copy of `params/paper.toml` bundled in the crate
    /// (`crates/core/params/paper.toml`; a test checks both copies are identical).
    pub fn paper() -> Self {
        let text = PAPER_TOML;
        let p =
            RobotParams::from_toml_str(text, "params/paper.toml").expect("bundled params parse");
        Self::from_params(p, "params/paper.toml").expect("bundled params are valid")
    }

    /// Number of links (= joints) n.
    pub fn n(&self) -> usize {
        self.n
    }

    /// The parameters it was built from.
    pub fn params(&self) -> &RobotParams {
        &self.params
    }

    /// Link lengths, m (link 1 at the grip first).
    pub fn lengths(&self) -> &[f64] {
        &self.len
    }

    /// Link masses, kg.
    pub fn masses(&self) -> &[f64] {
        &self.mass
    }

    /// Centre-of-mass distances from the proximal joints, m.
    pub fn coms(&self) -> &[f64] {
        &self.com
    }

    /// Planar inertias about the centres of mass, kg m^2.
    pub fn inertias(&self) -> &[f64] {
        &self.inertia
    }

    /// Capsule radii, m.
    pub fn radii(&self) -> &[f64] {
        &self.radius
    }

    /// Gravitational acceleration, m/s^2 (acts along -y).
    pub fn gravity(&self) -> f64 {
        self.gravity
    }

    /// Lower torque limits of joints 2..n, N m.
    pub fn tau_min(&self) -> &[f64] {
        &self.tau_min
    }

    /// Upper torque limits of joints 2..n, N m.
    pub fn tau_max(&self) -> &[f64] {
        &self.tau_max
    }

    /// Number of actuated joints (n - 1).
    pub fn nu(&self) -> usize {
        self.n - 1
    }

    /// State dimension 2n (x = [q, qd]).
    pub fn nx(&self) -> usize {
        2 * self.n
    }

    /// Total arm length (sum of link lengths), m: the largest reach from the grip.
    pub fn reach(&self) -> f64 {
        self.len.iter().sum()
    }

    /// Total mass, kg.
    pub fn total_mass(&self) -> f64 {
        self.total_mass
    }
}
