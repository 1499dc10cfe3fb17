//! `brachia simulate`: the passive chain (zero torque) on the RK4 model plant, 1 ms rows.

use crate::io::parse_list;
use crate::CliError;
use brachia::sim::{ModelPlant, Plant};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use brachia_experiments::RunFolder;
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `brachia simulate`.
#[derive(clap::Args)]
pub struct Args {
    /// Robot parameters (TOML), e.g. params/paper.toml.
    #[arg(long)]
    params: PathBuf,
    /// Initial joint angles q1..qn in rad (q1 absolute from +x, the rest relative), comma-separated.
    #[arg(long, allow_hyphen_values = true)]
    q0: String,
    /// Initial joint velocities in rad/s, comma-separated (default: at rest).
    #[arg(long, allow_hyphen_values = true)]
    qd0: Option<String>,
    /// Simulated time in s.
    #[arg(long, default_value_t = 2.0, allow_negative_numbers = true)]
    duration: f64,
    /// Output period in s (the integrator takes `substeps` RK4 steps per period).
    #[arg(long, default_value_t = 0.001, allow_negative_numbers = true)]
    dt: f64,
    /// RK4 steps per output period.
    #[arg(long, default_value_t = 1)]
    substeps: usize,
    /// Output folder: trajectory.csv and report.json.
    #[arg(long)]
    out: PathBuf,
}

/// Run the command.
pub fn run(a: Args) -> Result<(), CliError> {
    let robot = Robot::from_toml_file(&a.params)?;
    let n = robot.n;
    let q0 = parse_list("--q0", &a.q0, n)?;
    let qd0 = match &a.qd0 {
        Some(s) => parse_list("--qd0", s, n)?,
        None => vec![0.0; n],
    };
    if !(a.duration.is_finite() && a.duration > 0.0 && a.duration <= 3600.0) {
        return Err(CliError::Input(format!(
            "--duration = {}: must be in (0, 3600] s",
            a.duration
        )));
    }
    if !(a.dt.is_finite() && a.dt > 0.0 && a.dt <= a.duration) {
        return Err(CliError::Input(format!(
            "--dt = {}: must be in (0, duration] s",
            a.dt
        )));
    }
    if a.substeps == 0 || a.substeps > 1000 {
        return Err(CliError::Input(format!(
            "--substeps = {}: must be 1..=1000",
            a.substeps
        )));
    }
    let mut plant = ModelPlant::new(robot.clone(), &[q0.clone(), qd0.clone()].concat());
    plant.substeps = a.substeps;
    let steps = (a.duration / a.dt).round() as usize;
    let mut traj = Trajectory::new(n);
    let mut energy = Vec::with_capacity(steps + 1);
    let mut x = vec![0.0; 2 * n];
    let tau = vec![0.0; n - 1];
    for k in 0..=steps {
        plant.state(&mut x);
        traj.push(k as f64 * a.dt, &x[..n], &x[n..], &tau);
        energy.push(plant.energy());
        if k < steps {
            plant.step(&tau, a.dt);
        }
    }
    let e0 = energy[0];
    let drift = energy.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max);
    let mut out = RunFolder::default();
    out.add(
        "trajectory.csv",
        traj.to_csv(&robot, &[("energy", &energy)]),
    );
    out.add_json(
        "report.json",
        &json!({
            "command": "simulate",
            "params": a.params.display().to_string(),
            "robot": robot.params.name,
            "q0": q0, "qd0": qd0,
            "duration_s": a.duration, "dt_s": a.dt, "substeps": a.substeps,
            "integrator": "rk4",
            "energy_initial_j": e0,
            "energy_final_j": energy[steps],
            "energy_drift_max_abs_j": drift,
            "energy_drift_max_rel": if e0 != 0.0 { drift / e0.abs() } else { drift },
        }),
    );
    out.write(&a.out)
        .map_err(|e| CliError::Input(e.to_string()))
}
