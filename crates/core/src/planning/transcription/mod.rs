//! The transcriptions of a swing into a finite optimisation problem: direct collocation
//! ([`collocation`], a sparse NLP for the [`crate::planning::nlp`] backends) and multiple shooting
//! ([`shooting`], a stage-structured optimal-control problem), and the clearance rows both impose
//! ([`clearance_fn`]).

pub mod clearance_fn;
pub mod collocation;
pub mod shooting;

pub use clearance_fn::DistanceClearanceFn;
