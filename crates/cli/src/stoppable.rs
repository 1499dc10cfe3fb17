//! Work that only computes in memory (a plan, a tracking run), run so that Ctrl-C ends the command at
//! once: the work runs on a worker thread while the main thread waits for it or for the cancel flag.
//! Once the flag is set the command returns [`crate::interrupted`] without waiting for the work to
//! reach its next check; nothing has been written (the work writes no file), and the worker ends with
//! the process.

use crate::{interrupted, CliError};
use brachia_experiments::CancelToken;
use std::path::Path;
use std::time::Duration;

/// How often the main thread looks at the flag and the worker.
const POLL: Duration = Duration::from_millis(5);

/// Run `work` on a worker thread; its result, or [`crate::interrupted`] naming `out` as soon as
/// `cancel` is set. `work` must write nothing: it may be abandoned at any point.
pub fn in_memory<T: Send + 'static>(
    cancel: &CancelToken,
    out: &Path,
    work: impl FnOnce() -> T + Send + 'static,
) -> Result<T, CliError> {
    let worker = std::thread::Builder::new()
        .name("brachia-work".into())
        .spawn(work)
        .map_err(|e| CliError::Failed(format!("could not start the work: {e}")))?;
    loop {
        if cancel.is_cancelled() {
            return Err(interrupted(out));
        }
        if worker.is_finished() {
            return match worker.join() {
                Ok(v) => Ok(v),
                Err(panic) => std::panic::resume_unwind(panic),
            };
        }
        std::thread::sleep(POLL);
    }
}
