//! `brachia view`: write the interactive page `view.html` of a run folder.

use crate::CliError;
use brachia_experiments::view::write_view;
use brachia_experiments::ExpError;
use std::path::PathBuf;

/// Arguments of `brachia view`.
#[derive(clap::Args)]
pub struct Args {
    /// A run folder written by `brachia plan`, `track`, `traverse`, `simulate` or `benchmark`, or an
    /// experiment folder of a reproduction (its parameter-study/ too); the page is written as
    /// DIR/view.html.
    dir: PathBuf,
}

/// Run the command.
pub fn run(a: Args) -> Result<(), CliError> {
    let path = write_view(&a.dir).map_err(|e| match e {
        ExpError::Write { .. } => CliError::Io(format!("could not write the page: {e}")),
        other => other.into(),
    })?;
    eprintln!("view: {}", path.display());
    Ok(())
}
