//! Parsing of command-line values, and the options every command that writes a run folder with a
//! page takes. (Run folders are `brachia_experiments::RunFolder`: every file is
//! written to a temporary name and renamed into place.)

use crate::CliError;
use brachia_experiments::Progress;
use indicatif::{ProgressBar, ProgressStyle};

/// How `plan`, `track`, `traverse` and `simulate` write their run folder (flattened into their
/// arguments).
#[derive(clap::Args)]
pub struct FolderArgs {
    /// Write into a non-empty --out folder that is not a brachia run folder (its files are kept).
    #[arg(long)]
    pub force: bool,
    /// Do not write the interactive page view.html into the run folder.
    #[arg(long)]
    pub no_view: bool,
}

/// The terminal progress bar of the long commands (reproduce, benchmark), hidden under
/// `--no-progress`. The library reports [`Progress`]; [`show_progress`] draws it.
pub fn progress_bar(hidden: bool) -> ProgressBar {
    let bar = if hidden {
        ProgressBar::hidden()
    } else {
        ProgressBar::new(0)
    };
    if let Ok(style) =
        ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} {msg} (eta {eta})")
    {
        bar.set_style(style.progress_chars("=> "));
    }
    bar
}

/// Draw one progress report on `bar` (the position never moves back).
pub fn show_progress(bar: &ProgressBar, p: Progress) {
    bar.set_length(p.total);
    bar.set_message(p.what);
    bar.set_position(bar.position().max(p.done));
}

/// Parse a comma-separated list of numbers, e.g. `-2.35,0,-1.55,0`.
pub fn parse_list(flag: &str, text: &str, expected: usize) -> Result<Vec<f64>, CliError> {
    let vals: Result<Vec<f64>, _> = text.split(',').map(|s| s.trim().parse::<f64>()).collect();
    let vals = vals.map_err(|e| CliError::Input(format!("{flag} = {text:?}: {e}")))?;
    if vals.len() != expected {
        return Err(CliError::Input(format!(
            "{flag} = {text:?}: expected {expected} comma-separated values, got {}",
            vals.len()
        )));
    }
    if let Some(v) = vals.iter().find(|v| !v.is_finite()) {
        return Err(CliError::Input(format!(
            "{flag} = {text:?}: {v} is not finite"
        )));
    }
    Ok(vals)
}
