//! The benchmark's figure of the Monte Carlo families: success rate per family and controller, each
//! family with its run count (`success_by_family.png/.svg`).

use super::Benchmark;
use crate::ExpError;
use std::path::Path;

/// File name of the figure (PNG; the SVG beside it has the same stem).
pub const FAMILY_FIGURE: &str = "success_by_family.png";

impl Benchmark {
    /// The Monte Carlo families that ran, in the order of [`crate::families::families`], each with
    /// its runs per controller (the same for every controller).
    pub fn families_run(&self) -> Vec<(String, usize)> {
        crate::families::families()
            .iter()
            .filter_map(|f| {
                self.scores
                    .iter()
                    .flat_map(|c| c.per_disturbance.iter())
                    .find(|(n, s)| n == f.name && s.runs > 0)
                    .map(|(n, s)| (n.clone(), s.runs))
            })
            .collect()
    }

    /// Draw [`FAMILY_FIGURE`] into `dir`: a bar per controller in every family that ran, its
    /// success rate in %, the family's run count under its name. Nothing is drawn when no family ran.
    pub fn draw_family_figure(&self, dir: &Path) -> Result<(), ExpError> {
        let fams = self.families_run();
        if fams.is_empty() {
            return Ok(());
        }
        let series = self
            .scores
            .iter()
            .map(|c| brachia_plot::BarSeries {
                name: c.controller.clone(),
                values: fams
                    .iter()
                    .map(|(name, _)| {
                        c.per_disturbance
                            .iter()
                            .find(|(n, _)| n == name)
                            .map(|(_, s)| s.success_pct)
                    })
                    .collect(),
            })
            .collect();
        let fig = brachia_plot::BarChart {
            title: format!("{}: success by Monte Carlo family", self.scenario),
            y_label: "success (%)".into(),
            categories: fams.iter().map(|(n, _)| n.clone()).collect(),
            notes: fams
                .iter()
                .map(|(_, k)| format!("{k} run{}", if *k == 1 { "" } else { "s" }))
                .collect(),
            series,
            y_max: 100.0,
            size: None,
        };
        let path = dir.join(FAMILY_FIGURE);
        brachia_plot::bar_chart(&path, &fig).map_err(|e| ExpError::Write {
            path: path.clone(),
            source: std::io::Error::other(e.to_string()),
        })
    }
}
