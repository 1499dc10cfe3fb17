//! Curves y(x): multi-panel time series (states, velocities, torques) and simple line plots.

use crate::axes::{self, Axes, LegendEntry, LegendMark};
use crate::error::PlotError;
use crate::output::{write_static, Drawable, OrMsg};
use crate::style::{min_max, padded, series_colour};
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// How a curve is stroked.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LineStyle {
    /// Continuous line (e.g. the tracked/measured signal).
    #[default]
    Solid,
    /// Dashed line (e.g. the desired/reference signal).
    Dashed,
}

/// One curve: `y[k]` against `x[k]`, both finite and of equal, non-zero length.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend text (an empty name keeps the curve out of the legend).
    pub name: String,
    /// Abscissae, in the unit of the figure's x label.
    pub x: Vec<f64>,
    /// Ordinates, in the unit of the panel's y label.
    pub y: Vec<f64>,
    /// Stroke.
    pub style: LineStyle,
    /// Colour index into the shared ten-colour palette; `None` = the series' position in its panel.
    /// Give the desired and tracked curves of one joint the same index.
    pub colour: Option<usize>,
}

impl Series {
    /// A solid curve with automatic colour.
    pub fn new(name: impl Into<String>, x: Vec<f64>, y: Vec<f64>) -> Self {
        Series {
            name: name.into(),
            x,
            y,
            style: LineStyle::Solid,
            colour: None,
        }
    }

    /// The same curve, dashed.
    pub fn dashed(mut self) -> Self {
        self.style = LineStyle::Dashed;
        self
    }

    /// The same curve with palette colour `i`.
    pub fn colour(mut self, i: usize) -> Self {
        self.colour = Some(i);
        self
    }
}

/// One stacked panel of a [`TimeSeriesFigure`]; all panels share the x axis.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Panel {
    /// Y-axis label with its unit, e.g. `"q (rad)"`.
    pub y_label: String,
    /// Curves of this panel (at least one).
    pub series: Vec<Series>,
}

/// A figure of one or more panels stacked vertically over a shared x axis (usually time).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct TimeSeriesFigure {
    /// Title above the first panel.
    pub title: String,
    /// X-axis label with its unit, e.g. `"t (s)"` (shown under the last panel).
    pub x_label: String,
    /// Panels from top to bottom (at least one).
    pub panels: Vec<Panel>,
    /// Image size in pixels (width, height); `None` = 1100 wide, 70 + 270 per panel high.
    pub size: Option<(u32, u32)>,
}

impl TimeSeriesFigure {
    /// A single-panel figure.
    pub fn single(
        title: impl Into<String>,
        x_label: impl Into<String>,
        y_label: impl Into<String>,
        series: Vec<Series>,
    ) -> Self {
        TimeSeriesFigure {
            title: title.into(),
            x_label: x_label.into(),
            panels: vec![Panel {
                y_label: y_label.into(),
                series,
            }],
            size: None,
        }
    }
}

/// A single-panel plot of y(x) curves with a marker at every data point (for sweeps such as the
/// free-fall time against a link length).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LinePlot {
    /// Title.
    pub title: String,
    /// X-axis label with its unit.
    pub x_label: String,
    /// Y-axis label with its unit.
    pub y_label: String,
    /// Curves (at least one).
    pub series: Vec<Series>,
    /// Image size in pixels; `None` = 900 x 600.
    pub size: Option<(u32, u32)>,
}

/// Write a multi-panel time-series figure to `path` (PNG) and beside it the same name with `.svg`.
///
/// Errors: [`PlotError::InvalidData`] for no panels, an empty panel, a series with no points,
/// mismatched `x`/`y` lengths or a non-finite value; I/O errors name the file.
pub fn time_series(path: impl AsRef<Path>, fig: &TimeSeriesFigure) -> Result<(), PlotError> {
    let path = path.as_ref();
    check_panels(path, &fig.panels)?;
    let size = fig
        .size
        .unwrap_or((1100, 70 + 270 * fig.panels.len() as u32));
    let drawing = CurvesDrawing {
        title: &fig.title,
        x_label: &fig.x_label,
        panels: fig
            .panels
            .iter()
            .map(|p| (p.y_label.as_str(), p.series.as_slice()))
            .collect(),
        markers: false,
    };
    write_static(path, size, &drawing)
}

/// Write a single-panel y(x) plot with markers to `path` (PNG) and beside it `.svg`.
///
/// Errors as for [`time_series`].
pub fn line_plot(path: impl AsRef<Path>, fig: &LinePlot) -> Result<(), PlotError> {
    let path = path.as_ref();
    let panel = Panel {
        y_label: fig.y_label.clone(),
        series: fig.series.clone(),
    };
    check_panels(path, std::slice::from_ref(&panel))?;
    let drawing = CurvesDrawing {
        title: &fig.title,
        x_label: &fig.x_label,
        panels: vec![(fig.y_label.as_str(), fig.series.as_slice())],
        markers: true,
    };
    write_static(path, fig.size.unwrap_or((900, 600)), &drawing)
}

/// Validate the curves of every panel.
fn check_panels(path: &Path, panels: &[Panel]) -> Result<(), PlotError> {
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    if panels.is_empty() {
        return Err(bad("the figure has no panels".into()));
    }
    for (pi, p) in panels.iter().enumerate() {
        if p.series.is_empty() {
            return Err(bad(format!("panel {pi} ('{}') has no series", p.y_label)));
        }
        for s in &p.series {
            check_curve(&s.name, &s.x, &s.y).map_err(|r| bad(format!("panel {pi}: {r}")))?;
        }
    }
    Ok(())
}

/// A curve must be non-empty, of matching lengths and finite.
pub(crate) fn check_curve(name: &str, x: &[f64], y: &[f64]) -> Result<(), String> {
    if x.is_empty() {
        return Err(format!("series '{name}' has no points"));
    }
    if x.len() != y.len() {
        return Err(format!(
            "series '{name}' has {} x values but {} y values",
            x.len(),
            y.len()
        ));
    }
    if let Some(k) = (0..x.len()).find(|&k| !x[k].is_finite() || !y[k].is_finite()) {
        return Err(format!(
            "series '{name}' has a non-finite point at index {k}: ({}, {})",
            x[k], y[k]
        ));
    }
    Ok(())
}

/// Shared drawing of stacked panels of curves.
struct CurvesDrawing<'a> {
    title: &'a str,
    x_label: &'a str,
    panels: Vec<(&'a str, &'a [Series])>,
    markers: bool,
}

impl Drawable for CurvesDrawing<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let body = axes::title(root, self.title)?;
        let (w, _) = body.dim_in_pixel();
        let legend_w = axes::legend_width(
            root,
            self.panels
                .iter()
                .flat_map(|(_, s)| s.iter().map(|s| s.name.as_str())),
        );
        let (plots, legend) = body.split_horizontally(w.saturating_sub(legend_w));
        let x_range = min_max(
            self.panels
                .iter()
                .flat_map(|(_, s)| s.iter().flat_map(|s| s.x.iter().copied())),
        )
        .map(|(a, b)| padded(a, b, 0.0))
        .unwrap_or((0.0, 1.0));
        let np = self.panels.len();
        let areas = plots.split_evenly((np, 1));
        let legends = legend.split_evenly((np, 1));
        for (pi, (y_label, series)) in self.panels.iter().enumerate() {
            let last = pi + 1 == np;
            let y = min_max(series.iter().flat_map(|s| s.y.iter().copied())).unwrap_or((0.0, 1.0));
            let y_range = padded(y.0, y.1, 0.06);
            let ax = Axes {
                x_label: if last { self.x_label } else { "" },
                y_label,
                x_range,
                y_range,
                x_label_area: if last { 62 } else { 34 },
            };
            let mut chart = ax.build(&areas[pi])?;
            let mut entries = Vec::new();
            for (si, s) in series.iter().enumerate() {
                let colour = series_colour(s.colour.unwrap_or(si));
                let pts = s.x.iter().copied().zip(s.y.iter().copied());
                let stroke = colour.stroke_width(2);
                match s.style {
                    LineStyle::Solid => {
                        chart.draw_series(LineSeries::new(pts, stroke)).msg()?;
                    }
                    LineStyle::Dashed => {
                        chart
                            .draw_series(DashedLineSeries::new(pts, 9, 6, stroke))
                            .msg()?;
                    }
                }
                if self.markers {
                    let pts = s.x.iter().copied().zip(s.y.iter().copied());
                    chart
                        .draw_series(pts.map(|p| Circle::new(p, 4, colour.filled())))
                        .msg()?;
                }
                if !s.name.is_empty() {
                    entries.push(LegendEntry {
                        label: s.name.clone(),
                        mark: LegendMark::Line {
                            colour,
                            dashed: s.style == LineStyle::Dashed,
                            marker: self.markers,
                        },
                    });
                }
            }
            axes::legend(&legends[pi], &entries, 14)?;
        }
        Ok(())
    }
}
