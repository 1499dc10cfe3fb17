//! The solver's parts, allocated once by `OcpSolver::new`: the problem data, the iterate and its
//! trial copy, the Newton step, the KKT system, the filter, the restoration problem and the
//! correctors' workspace.

use super::correctors::Correctors;
use super::data::ProblemData;
use super::filter::Filter;
use super::iterate::{Iterate, Step, Trial};
use super::kkt::KktSystem;
use super::restoration::Restoration;

/// A stage-structured primal-dual interior-point solver (see the crate docs).
///
/// All memory is allocated by [`OcpSolver::new`] (the filter grows once up to `max_iter` entries,
/// and the Schur responses to the number of equality rows, on the first solve); later solves of a
/// problem with the same dimensions do not allocate unless they fail (status strings).
pub struct OcpSolver {
    /// Dimensions, layout, bounds and the role of each variable.
    pub(super) data: ProblemData,
    /// The iterate (primal, slacks, multipliers, bound duals, evaluations).
    pub(super) it: Iterate,
    /// The line search's trial point.
    pub(super) trial: Trial,
    /// The Newton step of the current iteration.
    pub(super) step: Step,
    /// The condensed KKT system and its factorisation.
    pub(super) kkt: KktSystem,
    /// The filter of the phase that runs.
    pub(super) filter: Filter,
    /// The restoration problem (inactive outside its phase).
    pub(super) resto: Restoration,
    /// The centrality correctors' targets and saved step.
    pub(super) cc: Correctors,
}
