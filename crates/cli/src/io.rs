//! Parsing of command-line values. (Run folders are `brachia_experiments::RunFolder`: every file is
//! written to a temporary name and renamed into place.)

use crate::CliError;

/// Parse a comma-separated list of numbers, e.g. `-2.35,0,-1.55,0`.
pub fn parse_list(flag: &str, text: &str, expected: usize) -> Result<Vec<f64>, CliError> {
    let vals: Result<Vec<f64>, _> = text.split(',').map(|s| s.trim().parse::<f64>()).collect();
    let vals = vals.map_err(|e| CliError::Input(format!("{flag} = {text:?}: {e}")))?;
    if vals.len() != expected {
        return Err(CliError::Input(format!(
            "{flag} = {text:?}: expected {expected} comma-separated values, got {}",
            vals.len()
        )));
    }
    if let Some(v) = vals.iter().find(|v| !v.is_finite()) {
        return Err(CliError::Input(format!(
            "{flag} = {text:?}: {v} is not finite"
        )));
    }
    Ok(vals)
}
