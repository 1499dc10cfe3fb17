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

/// One disturbance swept over levels `0..=max` (evenly spaced).
#[derive(Debug, Clone, Copy)]
pub struct Sweep {
    /// Name in `runs.csv` and the scorecard.
    pub name: &'static str,
    /// What the level means, with its unit.
    pub level: &'static str,
    /// The largest level.
    pub max: f64,
    /// Sets the disturbance.
    pub apply: ApplyLevel,
}

/// The scenario's per-link factors `base` (empty: 1 each) times `f`: a sweep's factor multiplies
/// the scenario's own mismatch.
fn times(base: &[f64], f: f64, ctx: &SweepContext) -> Vec<f64> {
    (0..ctx.robot.n())
        .map(|i| base.get(i).copied().unwrap_or(1.0) * f)
        .collect()
}

/// Every disturbance the benchmark sweeps, with its range (docs/robustness.md lists them). Each level
/// adds to the scenario's own `[disturbances]` (the `Disturbances` handed to `apply` is the
/// scenario's): a mismatch factor multiplies the scenario's factor, a friction, noise, delay, lag or
/// start offset adds to the scenario's value, the torque limit removes its fraction from the
/// scenario's limit (else the robot's), a push joins the scenario's pushes. Level 0 is the scenario
/// as written.
pub fn sweeps() -> Vec<Sweep> {
    vec![
        Sweep {
            name: "mass",
            level: "relative increase of every link mass",
            max: 0.5,
            apply: |d, l, c| d.mass_scale = times(&d.mass_scale, 1.0 + l, c),
        },
        Sweep {
            name: "com",
            level: "relative increase of every COM distance",
            max: 0.4,
            apply: |d, l, c| d.com_scale = times(&d.com_scale, 1.0 + l, c),
        },
        Sweep {
            name: "inertia",
            level: "relative increase of every link inertia",
            max: 1.0,
            apply: |d, l, c| d.inertia_scale = times(&d.inertia_scale, 1.0 + l, c),
        },
        Sweep {
            name: "length",
            level: "relative increase of every link length",
            max: 0.2,
            apply: |d, l, c| d.length_scale = times(&d.length_scale, 1.0 + l, c),
        },
        Sweep {
            name: "coulomb",
            level: "Coulomb friction, N m",
            max: 0.5,
            apply: |d, l, _| d.coulomb_nm += l,
        },
        Sweep {
            name: "viscous",
            level: "viscous damping, N m s/rad",
            max: 0.2,
            apply: |d, l, _| d.viscous_nm_s += l,
        },
        Sweep {
            name: "noise_q",
            level: "sensor noise on q, rad (std)",
            max: 0.02,
            apply: |d, l, _| d.noise_q_std += l,
        },
        Sweep {
            name: "noise_qd",
            level: "sensor noise on qd, rad/s (std)",
            max: 0.5,
            apply: |d, l, _| d.noise_qd_std += l,
        },
        Sweep {
            name: "measurement_delay",
            level: "measurement delay, s",
            max: 0.02,
            apply: |d, l, _| d.measurement_delay_s += l,
        },
        Sweep {
            name: "actuation_delay",
            level: "actuation delay, s",
            max: 0.02,
            apply: |d, l, _| d.actuation_delay_s += l,
        },
        Sweep {
            name: "torque_noise",
            level: "torque noise, N m (std)",
            max: 2.0,
            apply: |d, l, _| d.torque_noise_std += l,
        },
        Sweep {
            name: "motor_lag",
            level: "motor time constant, s",
            max: 0.05,
            apply: |d, l, _| d.motor_time_constant_s += l,
        },
        Sweep {
            name: "torque_limit",
            level: "fraction of the torque limit removed",
            max: 0.8,
            apply: |d, l, c| {
                let robot = c
                    .robot
                    .tau_max
                    .iter()
                    .chain(c.robot.tau_min.iter())
                    .fold(f64::INFINITY, |m, v| m.min(v.abs()));
                let lim = d.torque_limit_nm.map_or(robot, |s| s.min(robot));
                d.torque_limit_nm = Some((1.0 - l) * lim);
            },
        },
        Sweep {
            name: "start_offset",
            level: "offset of every start angle, rad",
            max: 0.1,
            apply: |d, l, c| {
                let n = c.robot.n();
                let mut o = d.start_offset.clone();
                o.resize(2 * n, 0.0);
                o[..n].iter_mut().for_each(|v| *v += l);
                d.start_offset = o;
            },
        },
        Sweep {
            name: "push",
            level: "downward impulse at mid-swing on the last link's midpoint, N s",
            max: 0.5,
            apply: |d, l, c| {
                let n = c.robot.n();
                if l > 0.0 {
                    d.pushes.push(Push {
                        t_s: 0.5 * c.swing_time_s,
                        link: n,
                        point_m: 0.5 * c.robot.lengths()[n - 1],
                        impulse_n_s: [0.0, -l],
                    });
                }
            },
        },
    ]
}
