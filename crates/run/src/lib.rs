//! # brachia-run
//!
//! The run layer of brachia: a scenario file (robot, task, planner, solver, controller and plant
//! settings) goes into a deterministic runner that fills a run folder (resolved inputs, CSVs, a
//! machine-readable report), and the readers that load run folders back. `brachia plan`, `track`,
//! `traverse`, `simulate` and `view` are thin layers over these functions; the paper's studies and the
//! robustness benchmark (`brachia-experiments`) build on them.
//!
//! Conventions as in `brachia`: SI units; q1 absolute from +x, q2..qn relative; `x = [q, qd]`; torques of
//! joints 2..n. CSV headers: `t,q1..qn,qd1..qdn,tau2..taun,ee_x,ee_y[,extra]`.

pub mod families;
pub mod gym;
pub mod ladder;
pub mod manifest;
pub mod plan_match;
pub mod plan_run;
pub mod progress;
pub mod read;
pub mod run_folder;
pub mod scenario;
pub mod schema;
pub mod settings_use;
pub mod staging;
pub mod success;
pub mod track_folder;
pub mod track_run;
pub mod tracker;
pub mod traverse;
pub mod view;

pub use ladder::{Bar, Ladder, LadderScenario, LoadedLadder};
pub use plan_run::solver_work_text;
pub use plan_run::{
    plan_report, replay_trusted, run_plan, PlanReport, PlanRun, PARAMS_FILE, REPLAY_TRUST_M,
};
pub use progress::{no_progress, CancelToken, Progress, ProgressFn};
pub use read::PlanFolder;
pub use run_folder::{check_out_apart, check_out_dir, RunFolder, MANIFEST};
pub use scenario::{ControllerKind, PlantKind, Scenario, Uses};
pub use settings_use::{check_ladder_settings_apply, check_settings_apply};
pub use success::{
    capture, hand_at_bar, judged_log, Capture, CaptureRule, HandAtBar, CAPTURE_SPEED_M_S,
    SUCCESS_RADIUS_M,
};
pub use track_folder::TrackFolder;
pub use track_run::{
    read_plan_folder, run_track, track_plan, PlantWorld, TrackOutcome, TrackReport, TrackRun,
};
pub use traverse::{
    run_traverse, run_traverse_cancellable, PlanSource, RegripRecord, SwingRecord, Traverse,
    TraverseStatus,
};

/// Errors of the run layer (and of the experiments built on it).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum ExpError {
    /// Invalid input (a scenario, parameters or a task): nothing was computed or written.
    #[error(transparent)]
    Input(#[from] brachia::Error),
    /// An output location that cannot be used (a file, a non-empty folder that is not a brachia run
    /// folder, a read-only place): refused before any work.
    #[error("{path}: {reason}")]
    OutDir {
        /// The output folder or page.
        path: std::path::PathBuf,
        /// Why it cannot be used.
        reason: String,
    },
    /// The work was cancelled ([`CancelToken`], e.g. Ctrl-C) before it finished: nothing was written,
    /// the previous results are as they were.
    #[error("interrupted: nothing was written; the previous results are as they were")]
    Cancelled,
    /// Writing the run folder failed.
    #[error("{path}: {source}")]
    Write {
        /// The file or folder.
        path: std::path::PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl From<brachia::Cancelled> for ExpError {
    fn from(_: brachia::Cancelled) -> Self {
        ExpError::Cancelled
    }
}
