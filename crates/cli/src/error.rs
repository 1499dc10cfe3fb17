//! The error of a command and its exit code (docs/limits.md), and the checks every command shares for
//! Ctrl-C before it writes its results.

use brachia_experiments::{CancelToken, ExpError};

/// An error of a command: bad input (exit 2), a failure after the inputs were accepted (exit 1) or an
/// I/O failure (exit 3).
#[derive(Debug)]
pub enum CliError {
    /// Invalid or missing input: exit code 2, nothing written.
    Input(String),
    /// A computation did not succeed: exit code 1.
    Failed(String),
    /// A file could not be written after the work was done: exit code 3.
    Io(String),
    /// Stopped by Ctrl-C before the results were written: exit code 130, nothing written.
    Interrupted(String),
}

/// Exit code of a run stopped by Ctrl-C (SIGINT): 128 + 2, as a shell reports a process it killed.
pub const EXIT_INTERRUPTED: u8 = 130;

/// Exit code of a run stopped by SIGTERM (`kill PID`): 128 + 15. The run stops as on Ctrl-C.
pub const EXIT_TERMINATED: u8 = 143;

/// `Err(CliError::Interrupted)` naming `out` once Ctrl-C was pressed: called before a result is
/// written, so an interrupted command leaves `out` as it was.
pub fn check_cancel(cancel: &CancelToken, out: &std::path::Path) -> Result<(), CliError> {
    if cancel.is_cancelled() {
        Err(interrupted(out))
    } else {
        Ok(())
    }
}

/// The error of a command stopped by Ctrl-C before it wrote `out`.
pub fn interrupted(out: &std::path::Path) -> CliError {
    CliError::Interrupted(format!(
        "interrupted (Ctrl-C): nothing was written; {} is as it was",
        out.display()
    ))
}

/// Map a library error of a command writing to `out`: a cancelled run and a write failure name `out`.
pub fn exp_error(out: &std::path::Path) -> impl Fn(ExpError) -> CliError + '_ {
    move |e| match e {
        ExpError::Cancelled => interrupted(out),
        ExpError::Write { .. } => CliError::Io(format!(
            "could not write the results into {}: {e}",
            out.display()
        )),
        other => other.into(),
    }
}

impl From<brachia::Error> for CliError {
    fn from(e: brachia::Error) -> Self {
        CliError::Input(e.to_string())
    }
}

impl From<brachia_experiments::ExpError> for CliError {
    fn from(e: brachia_experiments::ExpError) -> Self {
        match e {
            ExpError::Cancelled => CliError::Interrupted(e.to_string()),
            ExpError::Write { .. } => CliError::Io(format!("could not write the results: {e}")),
            other => CliError::Input(other.to_string()),
        }
    }
}
