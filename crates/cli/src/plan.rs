//! `brachia plan`: plan the scenario's swing and write its run folder.

use crate::{check_cancel, exp_error, CliError};
use brachia_experiments::view::{plan_run_page, VIEW_FILE};
use brachia_experiments::{
    check_out_dir, replay_trusted, run_plan, CancelToken, Scenario, Uses, REPLAY_TRUST_M,
};
use std::path::PathBuf;

/// Arguments of `brachia plan`.
#[derive(clap::Args)]
pub struct Args {
    /// Scenario file (TOML), e.g. scenarios/tracking.toml.
    #[arg(long)]
    scenario: PathBuf,
    /// Output folder: knots.csv, trajectory.csv, scenario.toml, params.toml, report.json, view.html.
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    folder: crate::io::FolderArgs,
}

/// Run the command.
pub fn run(a: Args, cancel: &CancelToken) -> Result<(), CliError> {
    let mut ls = Scenario::load_for(&a.scenario, Uses::Plan)?;
    check_out_dir(&a.out, a.folder.force)?;
    // every solve checks the token between its iterations, every strategy before its solves
    ls.scenario.solver.cancel = Some(cancel.clone());
    let run = {
        let ls = ls.clone();
        crate::stoppable::in_memory(cancel, &a.out, move || run_plan(&ls))?
    };
    check_cancel(cancel, &a.out)?;
    let mut run = run?;
    if !a.folder.no_view {
        let page = plan_run_page(&ls, &run);
        run.folder.add(VIEW_FILE, page);
    }
    run.folder.write(&a.out).map_err(exp_error(&a.out))?;
    let p = &run.plan;
    eprintln!(
        "plan: {:?}; {}; energy {:.3} J; EE final error {:.2e} m; replay error {:.2e} m",
        p.status,
        brachia_experiments::solver_work_text(p),
        p.energy_j,
        p.violations.ee_position,
        p.replay_ee_error_m
    );
    if p.converged() && !replay_trusted(p.replay_ee_error_m) {
        Err(CliError::Failed(format!(
            "the planner converged, but replaying its torques open loop misses the bar by {:.3} m \
             (more than {REPLAY_TRUST_M} m): the collocation grid is too coarse to trust (use a smaller \
             planner.knot_dt, more planner.shooting.substeps or hermite-simpson); the report is in {}",
            p.replay_ee_error_m,
            a.out.display()
        )))
    } else if p.converged() {
        Ok(())
    } else {
        if let Some(b) = &p.blockage {
            for c in b.clearances.iter().filter(|c| c.violated) {
                eprintln!("plan: {c}");
            }
        }
        let msg = p
            .failure_message()
            .unwrap_or_else(|| format!("the planner did not converge ({:?})", p.status));
        let fields: Vec<&str> = [
            p.blockage.is_some().then_some("blockage"),
            p.diagnosis.is_some().then_some("diagnosis"),
            p.torque_continuation
                .is_some()
                .then_some("torque_continuation"),
        ]
        .into_iter()
        .flatten()
        .collect();
        let what = if fields.is_empty() {
            String::new()
        } else {
            format!(" ({} in report.json)", fields.join(", "))
        };
        Err(CliError::Failed(format!(
            "{msg}; the report{what} is in {}",
            a.out.display()
        )))
    }
}
