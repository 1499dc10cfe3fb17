//! Controllers the caller adds to the benchmark (e.g. Python policies), scored beside the built-in
//! ones on the same draws ([`super::run_benchmark_with`]).

use super::controllers::{controllers, BenchController, ControllerEntry};
use crate::scenario::LoadedScenario;
use brachia::sim::Controller;
use brachia::trajectory::Trajectory;
use brachia::Error;
use std::sync::Arc;

/// Builds a caller's controller for one run (e.g. a Python policy): the scenario and the plan.
pub type BuildExtra =
    dyn Fn(&LoadedScenario, &Arc<Trajectory>) -> Result<Box<dyn Controller>, Error> + Send + Sync;

/// A controller the caller adds to the benchmark ([`super::run_benchmark_with`]), scored like the built-in
/// ones on the same draws.
pub struct ExtraController {
    /// Name in `runs.csv` and the scorecard (not one of [`controllers`]).
    pub name: String,
    /// Builds a fresh controller for one run.
    pub build: Box<BuildExtra>,
}

/// A controller of one benchmark: built in, or the caller's.
pub(super) enum Entry<'a> {
    Builtin(ControllerEntry),
    Extra(&'a ExtraController),
}

impl Entry<'_> {
    pub(super) fn name(&self) -> &str {
        match self {
            Entry::Builtin(e) => e.name,
            Entry::Extra(e) => &e.name,
        }
    }

    pub(super) fn build(
        &self,
        ls: &LoadedScenario,
        r: &Arc<Trajectory>,
    ) -> Result<BenchController, Error> {
        match self {
            Entry::Builtin(e) => (e.build)(ls, r),
            Entry::Extra(e) => Ok(BenchController::Plain((e.build)(ls, r)?)),
        }
    }
}

/// Refuse an empty name, a built-in controller's name or a repeated one.
pub(super) fn check_names(extra: &[ExtraController]) -> Result<(), Error> {
    for (i, e) in extra.iter().enumerate() {
        let taken = controllers().iter().any(|c| c.name == e.name)
            || extra[..i].iter().any(|o| o.name == e.name);
        if e.name.is_empty() || taken {
            return Err(Error::invalid(
                "benchmark",
                "controllers",
                format!("{:?}", e.name),
                "a controller's name must be non-empty and not taken (mpc, pd, ... or another)",
            ));
        }
    }
    Ok(())
}
