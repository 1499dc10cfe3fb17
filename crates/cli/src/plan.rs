//! `brachia plan`: plan the scenario's swing and write its run folder.

use crate::CliError;
use brachia_experiments::{check_out_dir, run_plan, Scenario, Uses};
use std::path::PathBuf;

/// Arguments of `brachia plan`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML), e.g. scenarios/tracking.toml.
    #[arg(long)]
    scenario: PathBuf,
    /// Output folder: knots.csv, trajectory.csv, scenario.toml, report.json.
    #[arg(long)]
    out: PathBuf,
    /// Write into a non-empty --out folder that is not a brachia run folder (its files are kept).
    #[arg(long)]
    force: bool,
}

/// Run the command.
pub fn run(a: Args) -> Result<(), CliError> {
    let ls = Scenario::load_for(&a.scenario, Uses::Plan)?;
    check_out_dir(&a.out, a.force)?;
    let run = run_plan(&ls)?;
    run.folder.write(&a.out)?;
    let p = &run.plan;
    eprintln!(
        "plan: {:?} after {} iterations in {:.3} s; energy {:.3} J; EE final error {:.2e} m; replay error {:.2e} m",
        p.status,
        p.iterations,
        p.solve_time_s,
        p.energy_j,
        p.violations.ee_position,
        p.replay_ee_error_m
    );
    if p.converged() {
        Ok(())
    } else {
        Err(CliError::Failed(format!(
            "the planner did not converge (status {:?}); the report is in {}",
            p.status,
            a.out.display()
        )))
    }
}
