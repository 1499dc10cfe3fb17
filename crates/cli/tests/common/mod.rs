//! Helpers shared by the CLI tests: the repository root, the binary, a run folder's report, and
//! running commands and reading their folders ([`run`]).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

mod run;
#[allow(unused_imports)]
pub use run::*;

/// The repository root (scenarios/ and params/ live there).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The `brachia` binary, run from the repository root.
pub fn brachia() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_brachia"));
    c.current_dir(root());
    c
}

/// `DIR/report.json`, parsed.
pub fn report(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(dir.join("report.json")).unwrap()).unwrap()
}
