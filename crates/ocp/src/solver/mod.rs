//! The interior-point solver (see the crate docs and docs/ocp.md), in parts with one job each:
//!
//! | module | holds |
//! |---|---|
//! | `workspace` | [`OcpSolver`]: the parts below, allocated once |
//! | `api` | construction, the stored solution, feedback gains, `solve` |
//! | `warm` | [`WarmState`] and the warm-start accessors |
//! | `data` | dimensions, layout, bounds, the role of each variable |
//! | `evaluation` | calls into the problem (values, derivatives, Hessians), panics caught |
//! | `iterate` | the iterate, its trial copy and the Newton step |
//! | `start` | the cold or warm starting point |
//! | `residuals` | optimality residuals, barrier error, barrier function, final statistics |
//! | `kkt` | the KKT system: condensing, Riccati factorisation with inertia correction, solves |
//! | `newton` | the step of one iteration, the fraction to the boundary, centrality correctors |
//! | `correctors` | the correctors' targets and saved step |
//! | `barrier` | the barrier-parameter strategies (monotone, adaptive with probing) |
//! | `filter` | the filter |
//! | `line_search` | the filter line search with second-order corrections |
//! | `restoration` | the l1 restoration problem, run by the same main loop |
//! | `algorithm` | the main loop |

mod algorithm;
mod api;
mod barrier;
mod correctors;
mod data;
mod evaluation;
mod filter;
mod iterate;
mod kkt;
mod line_search;
mod newton;
mod residuals;
mod restoration;
mod start;
mod warm;
mod workspace;

pub use warm::WarmState;
pub use workspace::OcpSolver;
