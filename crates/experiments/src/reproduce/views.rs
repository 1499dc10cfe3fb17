//! The interactive pages of a reproduction: one `views/<experiment>.html` per experiment folder (the
//! page `brachia view` makes of that folder), linked from REPORT.md.

use crate::ExpError;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The pages written: name and what each shows.
pub(crate) type Pages = Vec<(&'static str, &'static str)>;

/// The folder holding the pages, beside REPORT.md.
pub(crate) const VIEWS_DIR: &str = "views";

/// The experiment folders that have a page, with the page's name and what it shows.
const EXPERIMENTS: [(&str, &str, &str); 10] = [
    (
        "parameter-study",
        "parameter-study",
        "V-A: the parameter study's grid (energy over r2 and swing time)",
    ),
    (
        "tracking",
        "tracking",
        "V-B: MPC tracking on the rapier plant",
    ),
    (
        "tracking-model",
        "tracking-model",
        "V-B: MPC tracking on the model plant",
    ),
    (
        "obstacle/avoid",
        "obstacle-avoid",
        "V-C: the plan around the obstacle",
    ),
    (
        "obstacle/ignored",
        "obstacle-ignored",
        "V-C: the plan that ignores it",
    ),
    ("robustness/mpc", "robustness-mpc", "V-D: MPC with the ball"),
    ("robustness/pd", "robustness-pd", "V-D: PD with the ball"),
    (
        "robustness/open-loop",
        "robustness-open-loop",
        "V-D: open loop with the ball",
    ),
    (
        "robustness-paper",
        "robustness-paper",
        "V-D: MPC, the paper's ball placement",
    ),
    ("ladder", "ladder", "the even ladder traversed"),
];

/// Write the page of every experiment folder of the reproduction `src` that holds a `report.json`
/// into `dest/views/`. Returns the pages written (name, what) and the files; a folder whose page
/// cannot be made is a failure entry (the report lists it), not an error.
pub(crate) fn write_pages(
    src: &Path,
    dest: &Path,
    failures: &mut Vec<String>,
) -> Result<(Pages, Vec<PathBuf>), ExpError> {
    let dir = dest.join(VIEWS_DIR);
    std::fs::create_dir_all(&dir).map_err(|source| ExpError::Write {
        path: dir.clone(),
        source,
    })?;
    let (mut pages, mut files) = (Vec::new(), Vec::new());
    for (folder, name, what) in EXPERIMENTS {
        let run = src.join(folder);
        if !run.join("report.json").is_file() {
            continue;
        }
        match crate::view::view_html(&run) {
            Ok(html) => {
                let path = dir.join(format!("{name}.html"));
                std::fs::write(&path, html).map_err(|source| ExpError::Write {
                    path: path.clone(),
                    source,
                })?;
                pages.push((name, what));
                files.push(path);
            }
            Err(e) => failures.push(format!("page {VIEWS_DIR}/{name}.html: {e}")),
        }
    }
    Ok((pages, files))
}

/// The section of REPORT.md that links the pages.
pub(crate) fn markdown(pages: &[(&str, &str)]) -> String {
    if pages.is_empty() {
        return String::new();
    }
    let mut s = String::from(
        "\n## Interactive pages\n\nEach experiment as one self-contained page (the robot, the plan as a \
         ghost, plots with one time cursor; docs/viewer.md), opened from disk in any browser:\n\n",
    );
    for (name, what) in pages {
        let _ = writeln!(s, "- [{what}]({VIEWS_DIR}/{name}.html)");
    }
    s
}
