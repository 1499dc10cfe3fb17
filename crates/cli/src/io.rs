//! Run-folder output: every file is written to a temporary name and renamed into place, so an
//! interrupted or failed command never leaves a half-written file behind.

use crate::CliError;
use std::path::Path;

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

/// Files of one run, written together at the end.
#[derive(Default)]
pub struct RunFolder {
    files: Vec<(String, Vec<u8>)>,
}

impl RunFolder {
    /// Queue a file.
    pub fn add(&mut self, name: &str, contents: impl Into<Vec<u8>>) {
        self.files.push((name.to_string(), contents.into()));
    }

    /// Queue a JSON file.
    pub fn add_json(&mut self, name: &str, value: &serde_json::Value) {
        let text = serde_json::to_string_pretty(value).expect("JSON values serialise");
        self.add(name, text + "\n");
    }

    /// Create `dir` and write every file atomically (temporary name, then rename).
    pub fn write(&self, dir: &Path) -> Result<(), CliError> {
        let fail = |what: &str, p: &Path, e: std::io::Error| {
            CliError::Input(format!("{what} {}: {e}", p.display()))
        };
        std::fs::create_dir_all(dir).map_err(|e| fail("cannot create", dir, e))?;
        for (name, data) in &self.files {
            let path = dir.join(name);
            let tmp = dir.join(format!(".{name}.partial"));
            std::fs::write(&tmp, data).map_err(|e| fail("cannot write", &tmp, e))?;
            std::fs::rename(&tmp, &path).map_err(|e| fail("cannot write", &path, e))?;
        }
        Ok(())
    }
}
