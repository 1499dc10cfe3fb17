//! `brachia traverse`: plan and track a whole ladder traverse (grip switching at every bar) on the
//! scenario's plant (`[plant] kind`: the model, or rapier with the grip rebuilt at every bar), into a staged run folder (see `brachia_experiments::traverse`).

use crate::{check_cancel, exp_error, CliError};
use brachia_experiments::view::{params_toml, traverse_run_page, PARAMS_FILE, VIEW_FILE};
use brachia_experiments::{
    check_ladder_settings_apply, check_out_dir, run_traverse_cancellable, CancelToken,
    LadderScenario,
};
use std::path::PathBuf;

/// Arguments of `brachia traverse`.
#[derive(clap::Args)]
pub struct Args {
    /// Traverse scenario file (TOML with a [ladder] section), e.g. scenarios/ladder-even.toml.
    #[arg(long)]
    scenario: PathBuf,
    /// Output folder: traverse.csv, report.json, scenario.toml, params.toml, view.html,
    /// traverse_stick.png/.svg, energy_per_swing.png/.svg, traverse.gif (rapier: also contacts.csv,
    /// obstacles.csv).
    #[arg(long)]
    out: PathBuf,
    #[command(flatten)]
    folder: crate::io::FolderArgs,
}

/// Run the command: exit 2 on bad input (nothing planned or written), 1 when the traverse did not
/// complete (its folder is still written), 3 on a write failure.
pub fn run(a: Args, cancel: &CancelToken) -> Result<(), CliError> {
    let mut ll = LadderScenario::load(&a.scenario)?;
    // a setting that would have no effect on the ladder's controller and plant is refused, not ignored
    check_ladder_settings_apply(&ll)?;
    // the figures' animation stops on Ctrl-C too
    ll.scenario.solver.cancel = Some(cancel.clone());
    check_out_dir(&a.out, a.folder.force)?;
    let tr = run_traverse_cancellable(&ll, cancel).map_err(exp_error(&a.out))?;
    let mut folder = tr.folder(&ll).map_err(exp_error(&a.out))?;
    folder.add(PARAMS_FILE, params_toml(&ll.robot, &ll.scenario.params));
    // a page plays the rows of the traverse: one that stopped at its first row has none to play
    let rows: usize = tr.logs.iter().map(|l| l.len()).sum();
    if !a.folder.no_view && rows >= 2 {
        folder.add(VIEW_FILE, traverse_run_page(&ll, &tr)?);
    }
    check_cancel(cancel, &a.out)?;
    folder.write(&a.out).map_err(exp_error(&a.out))?;
    for s in &tr.swings {
        eprintln!(
            "traverse: swing {} (bar {} -> {}): energy {:.3} J, positive work {:.3} J, {:.3} s, \
             capture error {:.2e} m, switch residual {:.2e} m/s",
            s.swing,
            s.from_bar,
            s.to_bar,
            s.energy_j,
            s.positive_work_j,
            s.duration_s,
            s.capture_error_m,
            s.switch_residual_m_s
        );
    }
    if tr.status.completed() {
        eprintln!("traverse: {}", tr.status);
        Ok(())
    } else {
        Err(CliError::Failed(format!(
            "{}; the run folder is in {}",
            tr.status,
            a.out.display()
        )))
    }
}
