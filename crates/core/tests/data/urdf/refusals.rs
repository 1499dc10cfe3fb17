//! The table of refused URDF imports (`refusals.toml` beside this file), read by the library's and
//! the command line's tests: each case is hook2.urdf edited, the import's options and the text the
//! refusal must name.

use serde::Deserialize;
use std::path::{Path, PathBuf};

/// The folder of the URDF test files.
pub fn urdf_data() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../core/tests/data/urdf")
        .canonicalize()
        .expect("the URDF test data")
}

/// One refused import.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RefusalCase {
    /// The rule broken.
    pub what: String,
    /// `[from, to]` text replacements applied to hook2.urdf in order.
    #[serde(default)]
    pub replace: Vec<[String; 2]>,
    #[serde(default = "default_grip")]
    pub grip: String,
    #[serde(default = "default_tip")]
    pub tip: String,
    #[serde(default)]
    pub passive: Vec<String>,
    #[serde(default)]
    pub ignore: Vec<String>,
    /// Text the refusal must contain besides the file's name.
    pub names: String,
}

fn default_grip() -> String {
    "hand".into()
}

fn default_tip() -> String {
    "hook".into()
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Table {
    case: Vec<RefusalCase>,
}

impl RefusalCase {
    /// hook2.urdf with this case's edits, each of which must change the text.
    pub fn urdf_text(&self) -> String {
        let mut text = std::fs::read_to_string(urdf_data().join("hook2.urdf")).unwrap();
        for [from, to] in &self.replace {
            assert!(
                text.contains(from.as_str()),
                "{}: {from:?} not in hook2.urdf",
                self.what
            );
            text = text.replace(from.as_str(), to);
        }
        text
    }
}

/// Every case of the table.
pub fn refusal_cases() -> Vec<RefusalCase> {
    let text = std::fs::read_to_string(urdf_data().join("refusals.toml")).unwrap();
    let t: Table = toml::from_str(&text).unwrap();
    assert!(t.case.len() >= 13, "the table holds every refusal");
    t.case
}
