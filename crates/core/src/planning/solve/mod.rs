//! One swing solved from one initial guess: the settings checked, the problem built in its
//! transcription, solved by its backend and the [`crate::planning::Plan`] made from the solution.
//! - [`common`]: what both transcriptions share (swing time, bounds, target pose, initial guesses,
//!   the clearance rows, the solve with its barrier retry).
//! - [`single`]: one plan from one guess; the collocation path.
//! - [`shooting`]: the multiple-shooting path (the stage-structured solver or an NLP backend).
//! - `freefall_cache`: the remembered answers of [`freefall_time`].

pub(crate) mod common;
mod freefall_cache;
pub(crate) mod shooting;
pub(crate) mod single;

pub use common::{freefall_time, WARM_START_MU_INIT};
pub(crate) use single::plan_single;
