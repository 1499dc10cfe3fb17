//! Robot parameters: the TOML schema (`RobotParams`) and the validated model (`Robot`).
//!
//! Conventions (repeated from the crate docs): a planar serial chain of `n` links hangs from the grip
//! point at the origin; gravity acts along -y. Lengths in m, masses in kg, inertias in kg m^2 (planar,
//! about the link's centre of mass), torques in N m. Each link has its own frame: origin at its proximal
//! joint, x axis towards its distal joint (along the link), y axis 90 degrees counter-clockwise from it.
//! `com` and `com_across` are the centre of mass in that frame (along and across the link); the end
//! effector is the point `end_effector` of the last link's frame (default: its distal end).
//!
//! The optional fields (`com_across`, `end_effector`, `joint_offset`, `joint_reversed`, `q_min`,
//! `q_max`, `qd_max`) describe robots imported from other formats; where they are absent the model is
//! the ideal chain of the paper, computed with exactly the same arithmetic.

use crate::error::{Error, Result};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Largest number of links a robot may have (the model code keeps small fixed-size stack buffers).
pub const MAX_LINKS: usize = 12;

/// Largest link length, mass, inertia, radius or torque limit accepted (SI units): beyond it the
/// model's products overflow or lose all precision.
pub const LINK_VALUE_MAX: f64 = 1e6;

/// One link (and the joint at its proximal end) as written in a parameters file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LinkParams {
    /// Length from proximal to distal joint, m (>= 0: a link of zero length is a body turning about
    /// its joint).
    pub length: f64,
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass along the link (x in the link frame), m.
    pub com: f64,
    /// Planar rotational inertia about the centre of mass, kg m^2.
    pub inertia: f64,
    /// Capsule radius used for collision checking, m. Default 0.02.
    #[serde(default = "default_radius")]
    pub radius: f64,
    /// Centre of mass across the link (y in the link frame, counter-clockwise side positive), m.
    /// Default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub com_across: f64,
    /// Offset between this joint's angle in the robot's own convention and brachia's angle, rad:
    /// `q = s phi + joint_offset` with `phi` the robot's joint angle and `s` = -1 when
    /// `joint_reversed`, else 1. Default 0.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub joint_offset: f64,
    /// True when the robot's joint angle turns clockwise in brachia's plane (its axis points the
    /// other way). Default false.
    #[serde(default, skip_serializing_if = "is_false")]
    pub joint_reversed: bool,
    /// Lower position limit of this joint in brachia's angle `q`, rad. Default none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_min: Option<f64>,
    /// Upper position limit of this joint in brachia's angle `q`, rad. Default none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub q_max: Option<f64>,
    /// Velocity limit of this joint, |qd| <= qd_max, rad/s. Default none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub qd_max: Option<f64>,
}

impl Default for LinkParams {
    /// A link of zero length and zero mass (not valid on its own): the base of struct-update syntax,
    /// `LinkParams { length: 0.3, mass: 0.5, .. }`.
    fn default() -> Self {
        LinkParams {
            length: 0.0,
            mass: 0.0,
            com: 0.0,
            inertia: 0.0,
            radius: default_radius(),
            com_across: 0.0,
            joint_offset: 0.0,
            joint_reversed: false,
            q_min: None,
            q_max: None,
            qd_max: None,
        }
    }
}

fn is_zero(v: &f64) -> bool {
    *v == 0.0
}

fn is_false(v: &bool) -> bool {
    !*v
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
    /// The end effector as a point `[x, y]` in the last link's frame, m. Default: the distal end of
    /// the last link, `[length, 0]`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub end_effector: Option<[f64; 2]>,
}

impl RobotParams {
    /// Parse a TOML string; `source_name` names the origin in error messages.
    pub fn from_toml_str(text: &str, source_name: &str) -> Result<Self> {
        toml::from_str(text).map_err(|e| crate::toml_path::toml_error(&e, text, source_name))
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
            if !l.length.is_finite() || l.length < 0.0 {
                return bad(f("length"), l.length, "must be a finite number >= 0");
            }
            for (name, v) in [
                ("mass", l.mass),
                ("inertia", l.inertia),
                ("radius", l.radius),
            ] {
                if !v.is_finite() || v <= 0.0 {
                    return bad(f(name), v, "must be a finite number > 0");
                }
            }
            for (name, v) in [
                ("length", l.length),
                ("mass", l.mass),
                ("inertia", l.inertia),
                ("radius", l.radius),
                ("com", l.com.abs()),
                ("com_across", l.com_across.abs()),
            ] {
                if v > LINK_VALUE_MAX {
                    return bad(
                        f(name),
                        v,
                        &format!("must be at most {LINK_VALUE_MAX:e} in magnitude (SI units)"),
                    );
                }
            }
            if !l.com.is_finite() {
                return bad(f("com"), l.com, "must be finite");
            }
            if !l.com_across.is_finite() {
                return bad(f("com_across"), l.com_across, "must be finite");
            }
            let ideal = l.com_across == 0.0;
            if ideal && (l.com < 0.0 || l.com > l.length) {
                return bad(
                    f("com"),
                    l.com,
                    "must lie on the link, 0 <= com <= length, unless com_across places the centre of mass off the link",
                );
            }
            if !l.joint_offset.is_finite() || l.joint_offset.abs() > 4.0 * std::f64::consts::PI {
                return bad(
                    f("joint_offset"),
                    l.joint_offset,
                    "must be finite and at most 4 pi rad in magnitude",
                );
            }
            validate_joint_limits(l, i, source_name)?;
        }
        if n > 0 && self.links.iter().all(|l| l.length == 0.0) {
            return bad(
                "links[*].length".into(),
                0.0,
                "at least one link needs a length > 0",
            );
        }
        if let Some(e) = self.end_effector {
            if e.iter().any(|v| !v.is_finite() || v.abs() > LINK_VALUE_MAX) {
                return Err(Error::invalid(
                    source_name,
                    "end_effector",
                    format!("{e:?}"),
                    format!("must be two finite numbers of at most {LINK_VALUE_MAX:e} m"),
                ));
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

/// Check the optional position and velocity limits of link `i`'s joint.
fn validate_joint_limits(l: &LinkParams, i: usize, source_name: &str) -> Result<()> {
    let f = |name: &str| format!("links[{i}].{name}");
    for (name, v) in [("q_min", l.q_min), ("q_max", l.q_max)] {
        if let Some(v) = v {
            if !v.is_finite() || v.abs() > 4.0 * std::f64::consts::PI {
                return Err(Error::invalid(
                    source_name,
                    f(name),
                    v,
                    "must be finite and at most 4 pi rad in magnitude",
                ));
            }
        }
    }
    if let (Some(lo), Some(hi)) = (l.q_min, l.q_max) {
        if lo >= hi {
            return Err(Error::invalid(
                source_name,
                format!("{}, {}", f("q_min"), f("q_max")),
                format!("[{lo}, {hi}]"),
                "the lower position limit must be below the upper one",
            ));
        }
    }
    if let Some(v) = l.qd_max {
        if !v.is_finite() || v <= 0.0 {
            return Err(Error::invalid(
                source_name,
                f("qd_max"),
                v,
                "must be a finite number > 0",
            ));
        }
    }
    Ok(())
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
    /// Total mass, kg.
    pub(crate) total_mass: f64,
    /// True when some centre of mass lies off its link's axis: the model then carries the terms
    /// `e`, `gsin`, `rho`, `cb` and `sb` (all zero and unused otherwise).
    pub(crate) off_axis: bool,
    /// Centres of mass across the links, m.
    pub(crate) com_across: Vec<f64>,
    /// Antisymmetric mass-matrix coefficients (row-major n x n):
    /// `M_abs[j][k] = d[j][k] cos(th_j - th_k) + e[j][k] sin(th_j - th_k)`.
    pub(crate) e: Vec<f64>,
    /// Gravity coefficients of the centres of mass across the links:
    /// `V = sum_j gcoef[j] sin(th_j) + gsin[j] cos(th_j)`.
    pub(crate) gsin: Vec<f64>,
    /// `d + i e = rho e^(i beta)` per pair (row-major n x n): `rho`, `cos beta` and `sin beta`, so that
    /// `M_abs[j][k] = rho[j][k] cos(th_j - th_k - beta[j][k])`.
    pub(crate) rho: Vec<f64>,
    pub(crate) cb: Vec<f64>,
    pub(crate) sb: Vec<f64>,
    /// The end effector in the last link's frame, m, and whether it is the default `[length, 0]`.
    pub(crate) ee: [f64; 2],
    pub(crate) ee_default: bool,
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
        // (the ideal chain's coefficients, then the terms of centres of mass off the links' axes)
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
        let com_across: Vec<f64> = params.links.iter().map(|l| l.com_across).collect();
        let off_axis = com_across.iter().any(|&v| v != 0.0);
        let mut e = vec![0.0; n * n];
        let (mut rho, mut cb, mut sb) = (d.clone(), vec![1.0; n * n], vec![0.0; n * n]);
        let mut gsin = vec![0.0; n];
        if off_axis {
            for j in 0..n {
                d[j * n + j] += mass[j] * com_across[j] * com_across[j];
                rho[j * n + j] = d[j * n + j];
                gsin[j] = params.gravity * mass[j] * com_across[j];
                for k in j + 1..n {
                    let v = len[j] * mass[k] * com_across[k];
                    e[j * n + k] = v;
                    e[k * n + j] = -v;
                    for (a, b, s) in [(j, k, 1.0), (k, j, -1.0)] {
                        let (dv, ev) = (d[a * n + b], s * v);
                        let r = dv.hypot(ev);
                        rho[a * n + b] = r;
                        if r > 0.0 {
                            cb[a * n + b] = dv / r;
                            sb[a * n + b] = ev / r;
                        }
                    }
                }
            }
        }
        let last = &params.links[n - 1];
        let ee = params.end_effector.unwrap_or([last.length, 0.0]);
        let ee_default = ee == [last.length, 0.0];
        Ok(Robot {
            off_axis,
            com_across,
            e,
            gsin,
            rho,
            cb,
            sb,
            ee,
            ee_default,
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

    /// The robot of the repository's `params/{file}` (the crate's unit tests).
    #[cfg(test)]
    pub(crate) fn from_repo_params(file: &str) -> Self {
        let p = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../params")
            .join(file);
        Self::from_toml_file(&p).unwrap()
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

    /// Total arm length, m: the largest reach of the end effector from the grip (the sum of the
    /// link lengths up to the last joint plus the distance of the end effector from it).
    pub fn reach(&self) -> f64 {
        if self.ee_default {
            self.len.iter().sum()
        } else {
            self.len[..self.n - 1].iter().sum::<f64>() + self.ee[0].hypot(self.ee[1])
        }
    }

    /// Centres of mass across the links (y in each link's frame), m.
    pub fn coms_across(&self) -> &[f64] {
        &self.com_across
    }

    /// The end effector as a point in the last link's frame, m.
    pub fn end_effector(&self) -> [f64; 2] {
        self.ee
    }

    /// True when the end effector is the distal end of the last link and every centre of mass lies
    /// on its link's axis (the ideal chain of the paper).
    pub fn is_ideal_chain(&self) -> bool {
        self.ee_default && !self.off_axis
    }

    /// The joint angles in the robot's own convention from brachia's `q`:
    /// `phi_i = s_i (q_i - joint_offset_i)` (see [`LinkParams::joint_offset`]).
    pub fn q_to_joint_angles(&self, q: &[f64]) -> Vec<f64> {
        self.params
            .links
            .iter()
            .zip(q)
            .map(|(l, qi)| {
                let s = if l.joint_reversed { -1.0 } else { 1.0 };
                s * (qi - l.joint_offset)
            })
            .collect()
    }

    /// Brachia's `q` from the joint angles in the robot's own convention:
    /// `q_i = s_i phi_i + joint_offset_i` (the inverse of [`Self::q_to_joint_angles`]).
    pub fn q_from_joint_angles(&self, phi: &[f64]) -> Vec<f64> {
        self.params
            .links
            .iter()
            .zip(phi)
            .map(|(l, p)| {
                let s = if l.joint_reversed { -1.0 } else { 1.0 };
                s * p + l.joint_offset
            })
            .collect()
    }

    /// Joint velocities in the robot's own convention from brachia's `qd` (`s_i qd_i`).
    pub fn qd_to_joint_rates(&self, qd: &[f64]) -> Vec<f64> {
        self.params
            .links
            .iter()
            .zip(qd)
            .map(|(l, v)| if l.joint_reversed { -v } else { *v })
            .collect()
    }

    /// Total mass, kg.
    pub fn total_mass(&self) -> f64 {
        self.total_mass
    }

    /// True when some link's centre of mass lies off its axis (`com_across` not zero).
    pub fn off_axis(&self) -> bool {
        self.off_axis
    }
}
