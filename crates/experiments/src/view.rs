//! The run pages of every folder brachia writes: the run layer's pages ([`brachia_run::view`]: plan,
//! track, traverse, simulate and benchmark folders), and the parameter study's page (a reproduction's
//! `parameter-study/` folder: `cells.csv` and `freefall.csv`), which belongs to the paper layer.

pub use brachia_run::view::*;

use crate::ExpError;
use brachia::Error;
use std::path::{Path, PathBuf};

/// True when `dir` holds a parameter study (`cells.csv` and `freefall.csv`) and no run of the run
/// layer (whose files take precedence, as in [`brachia_run::view::view_html`]).
fn is_study(dir: &Path) -> bool {
    let has = |f: &str| dir.join(f).exists();
    has("cells.csv")
        && has("freefall.csv")
        && ![
            "closed_loop.csv",
            "traverse.csv",
            "trajectory.csv",
            "scorecard.json",
        ]
        .iter()
        .any(|f| has(f))
}

/// The page of the folder `dir`: a parameter study's page, else the run layer's
/// ([`brachia_run::view::view_html`]).
pub fn view_html(dir: &Path) -> Result<String, Error> {
    if dir.is_dir() && is_study(dir) {
        crate::study_view::study_folder_html(dir)
    } else {
        brachia_run::view::view_html(dir)
    }
}

/// Write `dir/view.html` for any folder [`view_html`] reads (as [`brachia_run::view::write_view`]).
pub fn write_view(dir: &Path) -> Result<PathBuf, ExpError> {
    write_page(dir, &view_html(dir)?)
}
