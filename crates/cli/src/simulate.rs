//! `brachia simulate`: the passive chain (zero torque) on the RK4 model plant, 1 ms rows.

use crate::io::parse_list;
use crate::{check_cancel, exp_error, CliError};
use brachia::limits;
use brachia::sim::{ModelPlant, Plant};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use brachia_experiments::view::{
    params_toml, render, simulate, simulate_view, SimulateParts, PARAMS_FILE, VIEW_FILE,
};
use brachia_experiments::{check_out_dir, CancelToken, RunFolder};
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
    /// Output folder: trajectory.csv, report.json, params.toml and view.html.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    folder: crate::io::FolderArgs,
}

/// Run the command.
pub fn run(a: Args, cancel: &CancelToken) -> Result<(), CliError> {
    let robot = Robot::from_toml_file(&a.params)?;
    let n = robot.n();
    let q0 = parse_list("--q0", &a.q0, n)?;
    let qd0 = match &a.qd0 {
        Some(s) => parse_list("--qd0", s, n)?,
        None => vec![0.0; n],
    };
    for (flag, v, max, unit) in [
        ("--q0", &q0, limits::MAX_ANGLE_RAD, "rad"),
        ("--qd0", &qd0, limits::MAX_RATE_RAD_S, "rad/s"),
    ] {
        if let Some((i, x)) = v.iter().enumerate().find(|(_, x)| x.abs() > max) {
            return Err(CliError::Input(format!(
                "{flag}: value {} = {x:e}: must be at most {max:.4} {unit} in magnitude (brachia::limits)",
                i + 1
            )));
        }
    }
    let dmax = limits::MAX_RUN_DURATION_S;
    if !(a.duration.is_finite() && a.duration > 0.0 && a.duration <= dmax) {
        return Err(CliError::Input(format!(
            "--duration = {}: must be in (0, {dmax}] s (brachia::limits::MAX_RUN_DURATION_S)",
            a.duration
        )));
    }
    if !(a.dt.is_finite() && a.dt > 0.0 && a.dt <= a.duration) {
        return Err(CliError::Input(format!(
            "--dt = {}: must be in (0, duration = {}] s",
            a.dt, a.duration
        )));
    }
    let rmax = limits::MAX_SIM_ROWS - 1;
    let Some(steps) = limits::count(a.duration, a.dt, rmax) else {
        return Err(CliError::Input(format!(
            "--dt = {}: {} s at this period would write more than {rmax} rows \
             (brachia::limits::MAX_SIM_ROWS); --dt must be >= {:.3e} s",
            a.dt,
            a.duration,
            a.duration / rmax as f64
        )));
    };
    let kmax = limits::MAX_SUBSTEPS;
    if a.substeps == 0 || a.substeps > kmax {
        return Err(CliError::Input(format!(
            "--substeps = {}: must be 1..={kmax}",
            a.substeps
        )));
    }
    let total = steps as u64 * a.substeps as u64;
    if total > limits::MAX_SIM_STEPS {
        return Err(CliError::Input(format!(
            "--substeps = {}: {steps} periods x {} substeps = {total} RK4 steps; at most {} \
             (brachia::limits::MAX_SIM_STEPS): shorten --duration or raise --dt",
            a.substeps,
            a.substeps,
            limits::MAX_SIM_STEPS
        )));
    }
    check_out_dir(&a.out, a.folder.force)?;
    let mut plant = ModelPlant::new(robot.clone(), &[q0.clone(), qd0.clone()].concat());
    plant.substeps = a.substeps;
    let mut traj = Trajectory::new(n);
    let mut energy = Vec::with_capacity(steps + 1);
    let mut x = vec![0.0; 2 * n];
    let tau = vec![0.0; n - 1];
    for k in 0..=steps {
        if k % 1024 == 0 {
            check_cancel(cancel, &a.out)?;
        }
        plant.state(&mut x);
        if let Some(v) = x.iter().find(|v| !v.is_finite()) {
            return Err(CliError::Failed(format!(
                "the simulation diverged at t = {:.4} s (state value {v}); nothing was written",
                k as f64 * a.dt
            )));
        }
        traj.push(k as f64 * a.dt, &x[..n], &x[n..], &tau);
        energy.push(plant.energy());
        if k < steps {
            plant.step(&tau, a.dt);
        }
    }
    let e0 = energy[0];
    let drift = energy.iter().map(|e| (e - e0).abs()).fold(0.0, f64::max);
    let mut out = RunFolder::default();
    let csv = traj.to_csv(&robot, &[("energy", &energy)]);
    if !a.folder.no_view {
        let page = simulate_view(SimulateParts {
            file: "trajectory.csv",
            csv: &csv,
            robot: &robot,
            subtitle: &simulate::subtitle(a.duration, drift),
        })?;
        out.add(VIEW_FILE, render(&page));
    }
    out.add("trajectory.csv", csv);
    out.add(PARAMS_FILE, params_toml(&robot, &a.params));
    out.add_json(
        "report.json",
        &json!({
            "command": "simulate",
            "params": a.params.display().to_string(),
            "robot": robot.params().name,
            "q0": q0, "qd0": qd0,
            "duration_s": a.duration, "dt_s": a.dt, "substeps": a.substeps,
            "integrator": "rk4",
            "energy_initial_j": e0,
            "energy_final_j": energy[steps],
            "energy_drift_max_abs_j": drift,
            "energy_drift_max_rel": if e0 != 0.0 { drift / e0.abs() } else { drift },
        }),
    );
    check_cancel(cancel, &a.out)?;
    out.write(&a.out).map_err(exp_error(&a.out))?;
    Ok(())
}
