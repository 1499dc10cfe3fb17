//! `brachia report DIR`: redraw every figure and REPORT.md of a reproduction folder from its run folders,
//! without planning or simulating.

use crate::{exp_error, CliError};
use brachia_experiments::reproduce::redraw_cancellable;
use brachia_experiments::CancelToken;
use std::path::PathBuf;

/// Arguments of `brachia report`.
#[derive(clap::Args)]
pub struct Args {
    /// A folder written by `brachia reproduce` (REPORT.md, summary.json, figures/, run folders).
    dir: PathBuf,
}

/// Run the command.
pub fn run(a: Args, cancel: &CancelToken) -> Result<(), CliError> {
    let r = redraw_cancellable(&a.dir, cancel).map_err(|e| match e {
        brachia_experiments::ExpError::Cancelled => exp_error(&a.dir)(e),
        other => other.into(),
    })?;
    eprintln!(
        "report: {} files redrawn in {}; report {}",
        r.files.len(),
        a.dir.display(),
        a.dir.join("REPORT.md").display()
    );
    if r.failures.is_empty() {
        Ok(())
    } else {
        Err(CliError::Failed(format!(
            "{} experiment(s) or figure(s) did not succeed (see REPORT.md):\n  {}",
            r.failures.len(),
            r.failures.join("\n  ")
        )))
    }
}
