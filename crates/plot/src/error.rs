//! The single error type of the figures crate: every variant names the file it was about.

use std::path::PathBuf;

/// Why a figure or animation could not be written. Nothing is left at `path` when this is returned
/// (files are rendered in memory, written to a temporary file beside the target and renamed).
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    /// The figure data cannot be drawn (empty, NaN/inf, mismatched lengths, bad options).
    #[error("{path}: invalid figure data: {reason}")]
    InvalidData {
        /// The figure that was requested.
        path: PathBuf,
        /// What is wrong, with the offending values.
        reason: String,
    },
    /// The target path is unusable (wrong extension, no file name).
    #[error("{path}: invalid output path: {reason}")]
    InvalidPath {
        /// The path given.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
    /// Writing or renaming the file failed.
    #[error("{path}: cannot write: {source}")]
    Io {
        /// The file being written.
        path: PathBuf,
        /// The operating-system error.
        #[source]
        source: std::io::Error,
    },
    /// The drawing backend failed (font, geometry).
    #[error("{path}: drawing failed: {message}")]
    Render {
        /// The figure being drawn.
        path: PathBuf,
        /// The backend's message.
        message: String,
    },
    /// The caller's cancel token was set while an animation was being drawn (checked before every
    /// frame); nothing was written.
    #[error("{path}: cancelled before it was written")]
    Cancelled {
        /// The file that was being drawn.
        path: PathBuf,
    },
    /// Encoding the image (PNG or GIF) failed.
    #[error("{path}: encoding failed: {message}")]
    Encode {
        /// The file being encoded.
        path: PathBuf,
        /// The encoder's message.
        message: String,
    },
}

impl PlotError {
    /// The path this error is about.
    pub fn path(&self) -> &std::path::Path {
        match self {
            PlotError::InvalidData { path, .. }
            | PlotError::InvalidPath { path, .. }
            | PlotError::Io { path, .. }
            | PlotError::Render { path, .. }
            | PlotError::Cancelled { path }
            | PlotError::Encode { path, .. } => path,
        }
    }
}
