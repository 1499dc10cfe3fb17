//! Typed errors of the library. Solver outcomes are *not* errors: see
//! [`crate::planning::SolveStatus`].

use std::path::PathBuf;

/// Everything that can go wrong before or around a computation.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// A file is not valid TOML or does not match the schema.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// What the parser said (names the line and the field).
        message: String,
    },
    /// A value is out of its allowed range.
    #[error("{source_name}: field `{field}` = {value}: {reason}")]
    InvalidValue {
        /// Where the value came from (a file path, or `<memory>`).
        source_name: String,
        /// The field, e.g. `links[2].mass`.
        field: String,
        /// The offending value as written.
        value: String,
        /// What is wrong with it.
        reason: String,
    },
    /// A task that cannot be attempted (target out of reach, start inside an obstacle, ...).
    #[error("infeasible task: {0}")]
    InfeasibleTask(String),
    /// Dimensions that do not agree (a programmer's or a scenario's error).
    #[error("dimension mismatch: {what}: expected {expected}, got {got}")]
    Dimension {
        /// What was being checked.
        what: String,
        /// Expected size.
        expected: usize,
        /// Actual size.
        got: usize,
    },
}

/// A value written as a long plain number (`1e300` prints as 301 digits) in scientific notation.
fn readable_number(v: String) -> String {
    match v.parse::<f64>() {
        Ok(x) if v.len() > 12 && x.is_finite() && x != 0.0 => format!("{x:e}"),
        _ => v,
    }
}

/// Shorthand for results of this crate.
pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An [`Error::InvalidValue`] for `field` of `source_name`.
    pub fn invalid(
        source_name: impl Into<String>,
        field: impl Into<String>,
        value: impl ToString,
        reason: impl Into<String>,
    ) -> Self {
        Error::InvalidValue {
            source_name: source_name.into(),
            field: field.into(),
            value: readable_number(value.to_string()),
            reason: reason.into(),
        }
    }
}
