//! Offline swing planning by direct collocation (paper Section III).

pub mod collocation;
pub mod nlp;
pub mod settings;

pub use collocation::{CollocationNlp, Layout};
pub use settings::{Bounds, PlannerSettings, SwingTime, Transcription};
