//! The benchmark's sweeps: one disturbance raised level by level, each with the rule that sets it for
//! the robot and swing at hand.

use brachia::sim::{Disturbances, Push};
use brachia::Robot;

/// Sets a disturbance at `level` (in the sweep's unit) for the robot and swing of `ctx`.
pub type ApplyLevel = fn(&mut Disturbances, f64, &SweepContext);

/// What a sweep may need to set its disturbance.
#[derive(Debug, Clone)]
pub struct SweepContext {
    /// The planner's robot.
    pub robot: Robot,
    /// Duration of the planned swing, s.
    pub swing_time_s: f64,
}

/// What a level does to the scenario's disturbances.
#[derive(Debug, Clone, Copy)]
pub enum Rule {
    /// Multiplies the per-link factors selected (the scenario's, empty: 1 each) by `1 + level`.
    Factor(fn(&mut Disturbances) -> &mut Vec<f64>),
    /// Adds the level to the value selected.
    Add(fn(&mut Disturbances) -> &mut f64),
    /// A rule of its own.
    Custom(ApplyLevel),
}

/// One disturbance swept over levels `0..=max` (evenly spaced).
#[derive(Debug, Clone, Copy)]
pub struct Sweep {
    /// Name in `runs.csv` and the scorecard.
    pub name: &'static str,
    /// What the level means, with its unit.
    pub level: &'static str,
    /// The largest level.
    pub max: f64,
    /// How a level sets the disturbance.
    pub rule: Rule,
}

impl Sweep {
    /// Set the disturbance at `level` (in the sweep's unit) on `d` for the robot and swing of `ctx`.
    pub fn apply(&self, d: &mut Disturbances, level: f64, ctx: &SweepContext) {
        match self.rule {
            Rule::Factor(field) => {
                let v = field(d);
                *v = times(v, 1.0 + level, ctx);
            }
            Rule::Add(field) => *field(d) += level,
            Rule::Custom(f) => f(d, level, ctx),
        }
    }
}

/// The scenario's per-link factors `base` (empty: 1 each) times `f`: a sweep's factor multiplies
/// the scenario's own mismatch.
fn times(base: &[f64], f: f64, ctx: &SweepContext) -> Vec<f64> {
    (0..ctx.robot.n())
        .map(|i| base.get(i).copied().unwrap_or(1.0) * f)
        .collect()
}

/// The torque limit sweep: removes the level's fraction of the scenario's limit (else the robot's).
fn torque_limit(d: &mut Disturbances, l: f64, c: &SweepContext) {
    let robot = c
        .robot
        .tau_max
        .iter()
        .chain(c.robot.tau_min.iter())
        .fold(f64::INFINITY, |m, v| m.min(v.abs()));
    let lim = d.torque_limit_nm.map_or(robot, |s| s.min(robot));
    d.torque_limit_nm = Some((1.0 - l) * lim);
}

/// The start offset sweep: adds the level to every start angle.
fn start_offset(d: &mut Disturbances, l: f64, c: &SweepContext) {
    let n = c.robot.n();
    let mut o = d.start_offset.clone();
    o.resize(2 * n, 0.0);
    o[..n].iter_mut().for_each(|v| *v += l);
    d.start_offset = o;
}

/// The push sweep: a downward impulse of the level at mid-swing on the last link's midpoint.
fn push(d: &mut Disturbances, l: f64, c: &SweepContext) {
    let n = c.robot.n();
    if l > 0.0 {
        d.pushes.push(Push {
            t_s: 0.5 * c.swing_time_s,
            link: n,
            point_m: 0.5 * c.robot.lengths()[n - 1],
            impulse_n_s: [0.0, -l],
        });
    }
}

/// Every disturbance the benchmark sweeps, with its range (docs/robustness.md lists them). Each level
/// adds to the scenario's own `[disturbances]` (the `Disturbances` handed to `apply` is the
/// scenario's): a mismatch factor multiplies the scenario's factor, a friction, noise, delay, lag or
/// start offset adds to the scenario's value, the torque limit removes its fraction from the
/// scenario's limit (else the robot's), a push joins the scenario's pushes. Level 0 is the scenario
/// as written.
pub fn sweeps() -> Vec<Sweep> {
    use Rule::{Add, Custom, Factor};
    let table: [(&'static str, &'static str, f64, Rule); 15] = [
        (
            "mass",
            "relative increase of every link mass",
            0.5,
            Factor(|d| &mut d.mass_scale),
        ),
        (
            "com",
            "relative increase of every COM distance",
            0.4,
            Factor(|d| &mut d.com_scale),
        ),
        (
            "inertia",
            "relative increase of every link inertia",
            1.0,
            Factor(|d| &mut d.inertia_scale),
        ),
        (
            "length",
            "relative increase of every link length",
            0.2,
            Factor(|d| &mut d.length_scale),
        ),
        (
            "coulomb",
            "Coulomb friction, N m",
            0.5,
            Add(|d| &mut d.coulomb_nm),
        ),
        (
            "viscous",
            "viscous damping, N m s/rad",
            0.2,
            Add(|d| &mut d.viscous_nm_s),
        ),
        (
            "noise_q",
            "sensor noise on q, rad (std)",
            0.02,
            Add(|d| &mut d.noise_q_std),
        ),
        (
            "noise_qd",
            "sensor noise on qd, rad/s (std)",
            0.5,
            Add(|d| &mut d.noise_qd_std),
        ),
        (
            "measurement_delay",
            "measurement delay, s",
            0.02,
            Add(|d| &mut d.measurement_delay_s),
        ),
        (
            "actuation_delay",
            "actuation delay, s",
            0.02,
            Add(|d| &mut d.actuation_delay_s),
        ),
        (
            "torque_noise",
            "torque noise, N m (std)",
            2.0,
            Add(|d| &mut d.torque_noise_std),
        ),
        (
            "motor_lag",
            "motor time constant, s",
            0.05,
            Add(|d| &mut d.motor_time_constant_s),
        ),
        (
            "torque_limit",
            "fraction of the torque limit removed",
            0.8,
            Custom(torque_limit),
        ),
        (
            "start_offset",
            "offset of every start angle, rad",
            0.1,
            Custom(start_offset),
        ),
        (
            "push",
            "downward impulse at mid-swing on the last link's midpoint, N s",
            0.5,
            Custom(push),
        ),
    ];
    table
        .into_iter()
        .map(|(name, level, max, rule)| Sweep {
            name,
            level,
            max,
            rule,
        })
        .collect()
}
