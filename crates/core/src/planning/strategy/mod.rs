//! The strategies that recover a solve that failed from the default guess, each a chain of solves
//! ([`crate::planning::solve`]) from other guesses or on other limits:
//! - the obstacle chain ([`obstacles`]): detour seeds ([`detour`]), the configuration-space seed
//!   ([`cspace`]) to several goals ([`goal`]) by several routes, ranked ([`homotopy`]), continuation
//!   on the obstacle radii, and the diagnosis of what blocks a swing;
//! - the diagnosis of an obstacle plan no strategy planned, with what it would need ([`diagnosis`]);
//! - the continuation on the torque limits ([`torque_continuation`]);
//! - the search in the swing time ([`swing_time`]) when the task's swing time does not plan.

pub mod candidate;
pub mod cspace;
pub mod detour;
pub mod diagnosis;
pub(crate) mod further;
pub mod goal;
pub mod homotopy;
pub mod obstacles;
mod open_list;
pub mod race;
pub mod swing_time;
#[cfg(test)]
mod test_swing;
pub mod torque_continuation;
pub(crate) mod widened;
