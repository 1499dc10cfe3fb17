//! Offline trajectory planning: the sparse NLP seam ([`nlp`]) that the direct-collocation
//! transcription is solved through.
//!
//! Conventions follow the crate docs (SI units; `x = [q, qd]`, `q[0]` absolute, the rest relative;
//! `u = tau` of joints 2..n; gravity along -y).

mod backend_pounce;
mod backend_ripopt;
pub mod nlp;

pub use nlp::{solve, Backend, MuStrategy, NlpSettings, NlpSolution, SolveStatus, SparseNlp};
