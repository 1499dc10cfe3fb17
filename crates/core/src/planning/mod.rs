//! Offline swing planning by direct collocation (paper Section III).

mod backend_pounce;
mod backend_ripopt;
pub mod collocation;
pub mod nlp;
pub mod settings;

pub use collocation::{CallbackTimings, CollocationNlp, EeTerminalFn, Layout, NoPath};
pub use settings::{Bounds, PlannerSettings, SwingTime, Transcription};
pub mod planner;

pub use nlp::{solve, Backend, NlpSettings, NlpSolution, SolveStatus};
pub use planner::{freefall_time, plan, Plan, SwingTask, Violations};
