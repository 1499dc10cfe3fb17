//! `brachia plan`: plan the scenario's swing and write its run folder.

use crate::CliError;
use brachia_experiments::{run_plan, Scenario};
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
}

/// Run the command.
pub fn run(a: Args) -> Result<(), CliError> {
    let ls = Scenario::load(&a.scenario)?;
    let run = run_plan(&ls)?;
    run.folder
        .write(&a.out)
        .map_err(|e| CliError::Input(e.to_string()))?;
    let p = &run.plan;
    eprintln!(
        "plan: {:?}; {}; energy {:.3} J; EE final error {:.2e} m; replay error {:.2e} m",
        p.status,
        brachia_experiments::solver_work_text(p),
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
