//! `brachia reproduce`: every experiment of the paper's Section V, figures, animations and a report.

use crate::{exp_error, CliError};
use brachia_experiments::reproduce::{reproduce_cancellable, ReproduceOptions};
use brachia_experiments::{CancelToken, Progress};
use std::path::PathBuf;

/// Arguments of `brachia reproduce`.
#[derive(clap::Args)]
pub struct Args {
    /// Output folder: REPORT.md, summary.json, figures/ and one run folder per experiment.
    #[arg(long, default_value = "out/reproduce")]
    out: PathBuf,
    /// A coarse parameter-study grid (the other experiments unchanged): what CI runs.
    #[arg(long)]
    quick: bool,
    /// Folder of the scenario files (tracking.toml, obstacle.toml, obstacle-ignored.toml,
    /// robustness.toml, robustness-paper.toml).
    #[arg(long, default_value = "scenarios")]
    scenarios: PathBuf,
    /// Also write this results page (e.g. docs/results.md) with the figures copied beside it.
    #[arg(long)]
    results_page: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    no_progress: bool,
    /// Write into a non-empty --out folder that is not a brachia run folder (its files are kept).
    #[arg(long)]
    force: bool,
}

/// Run the command.
pub fn run(a: Args, cancel: &CancelToken) -> Result<(), CliError> {
    // --out must not be (or hold) the scenario folder it reads (a run folder's files are replaced)
    brachia_experiments::check_out_apart(&a.out, &a.scenarios, "--scenarios", false)?;
    let opts = ReproduceOptions {
        scenarios: a.scenarios,
        quick: a.quick,
        results_page: a.results_page,
        force: a.force,
    };
    let bar = crate::io::progress_bar(a.no_progress);
    let show = |p: Progress| crate::io::show_progress(&bar, p);
    let rep = reproduce_cancellable(&opts, &a.out, &show, cancel);
    bar.finish_and_clear();
    let rep = rep.map_err(exp_error(&a.out))?;
    eprintln!(
        "reproduce: {} files in {} after {:.0} s; report {}",
        rep.files.len(),
        a.out.display(),
        rep.wall_s,
        a.out.join("REPORT.md").display()
    );
    for w in &rep.warnings {
        eprintln!("reproduce: note: {w}");
    }
    if rep.failures.is_empty() {
        Ok(())
    } else {
        Err(CliError::Failed(format!(
            "{} experiment(s) did not succeed (see REPORT.md):\n  {}",
            rep.failures.len(),
            rep.failures.join("\n  ")
        )))
    }
}
