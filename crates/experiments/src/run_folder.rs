//! Run folders: every file of a run is queued in memory and written at the end, each under a temporary
//! name and then renamed, so a failed or interrupted run never leaves a half-written file.

use crate::ExpError;
use std::path::Path;

/// The files of one run.
#[derive(Debug, Default, Clone)]
pub struct RunFolder {
    files: Vec<(String, Vec<u8>)>,
}

impl RunFolder {
    /// Queue a file (a name relative to the run folder; may contain `/`).
    pub fn add(&mut self, name: &str, contents: impl Into<Vec<u8>>) {
        self.files.push((name.to_string(), contents.into()));
    }

    /// Queue a pretty-printed JSON file.
    pub fn add_json(&mut self, name: &str, value: &serde_json::Value) {
        let text = serde_json::to_string_pretty(value).unwrap_or_else(|_| "null".into());
        self.add(name, text + "\n");
    }

    /// Names of the queued files.
    pub fn names(&self) -> impl Iterator<Item = &str> {
        self.files.iter().map(|(n, _)| n.as_str())
    }

    /// Contents of a queued file.
    pub fn get(&self, name: &str) -> Option<&[u8]> {
        self.files
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, d)| d.as_slice())
    }

    /// Create `dir` and write every file atomically.
    pub fn write(&self, dir: &Path) -> Result<(), ExpError> {
        let werr = |path: &Path, source| ExpError::Write {
            path: path.to_path_buf(),
            source,
        };
        std::fs::create_dir_all(dir).map_err(|e| werr(dir, e))?;
        for (name, data) in &self.files {
            let path = dir.join(name);
            if let Some(parent) = path.parent() {
                std::fs::create_dir_all(parent).map_err(|e| werr(parent, e))?;
            }
            let file = path
                .file_name()
                .map(|f| f.to_string_lossy().to_string())
                .unwrap_or_default();
            let tmp = path.with_file_name(format!(".{file}.partial"));
            std::fs::write(&tmp, data).map_err(|e| werr(&tmp, e))?;
            std::fs::rename(&tmp, &path).map_err(|e| werr(&path, e))?;
        }
        Ok(())
    }
}
