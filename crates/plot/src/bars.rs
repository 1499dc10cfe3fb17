//! Grouped bar charts: one group per category along x, one bar per series in every group (a
//! success rate per disturbance family and controller, say), the value printed above each bar where
//! it fits (10 px or larger) and a note under each category (its run count).

use crate::axes::{self, vertical_text, LABEL_SIZE, TICK_SIZE};
use crate::error::PlotError;
use crate::output::{write_static, Drawable, OrMsg};
use crate::style::{format_number, series_colour, FONT};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// One series of a [`BarChart`]: a bar in every category (`None`: no bar, the category has no value
/// for it).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BarSeries {
    /// Legend label.
    pub name: String,
    /// One value per category, in the order of [`BarChart::categories`].
    pub values: Vec<Option<f64>>,
}

/// Bars grouped by category, the y axis from 0 to `y_max`.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct BarChart {
    /// Title.
    pub title: String,
    /// Y-axis label with unit.
    pub y_label: String,
    /// Category names, left to right.
    pub categories: Vec<String>,
    /// A note under each category name (empty: none), e.g. `"50 runs"`.
    pub notes: Vec<String>,
    /// Series (at least one), each with one value per category (finite, 0..=`y_max`).
    pub series: Vec<BarSeries>,
    /// Top of the y axis (> 0), e.g. 100 for a percentage.
    pub y_max: f64,
    /// Image size in pixels; `None` = 1200 x 640.
    pub size: Option<(u32, u32)>,
}

/// Write the bar chart to `path` (PNG) and beside it `.svg`.
///
/// Errors: [`PlotError::InvalidData`] for no categories or series, a series or the notes of the
/// wrong length, a non-positive `y_max` or a value that is not finite or outside `0..=y_max`.
pub fn bar_chart(path: impl AsRef<Path>, fig: &BarChart) -> Result<(), PlotError> {
    let path = path.as_ref();
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    if fig.categories.is_empty() || fig.series.is_empty() {
        return Err(bad(format!(
            "{} categories and {} series: both must be at least one",
            fig.categories.len(),
            fig.series.len()
        )));
    }
    if !(fig.y_max.is_finite() && fig.y_max > 0.0) {
        return Err(bad(format!("y_max {} must be finite and > 0", fig.y_max)));
    }
    if !fig.notes.is_empty() && fig.notes.len() != fig.categories.len() {
        return Err(bad(format!(
            "{} notes for {} categories",
            fig.notes.len(),
            fig.categories.len()
        )));
    }
    for s in &fig.series {
        if s.values.len() != fig.categories.len() {
            return Err(bad(format!(
                "series '{}' has {} values for {} categories",
                s.name,
                s.values.len(),
                fig.categories.len()
            )));
        }
        if let Some(v) = s
            .values
            .iter()
            .flatten()
            .find(|v| !(v.is_finite() && (0.0..=fig.y_max).contains(*v)))
        {
            return Err(bad(format!(
                "series '{}' has the value {v}, outside 0..={}",
                s.name, fig.y_max
            )));
        }
    }
    write_static(path, fig.size.unwrap_or((1200, 640)), fig)
}

fn anchored(size: u32, h: HPos, v: VPos) -> TextStyle<'static> {
    (FONT, size).into_font().color(&BLACK).pos(Pos::new(h, v))
}

impl Drawable for BarChart {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let body = axes::title(root, &self.title)?;
        let (w, h) = body.dim_in_pixel();
        let (w, h) = (w as i32, h as i32);
        let (left, right, top, bottom) = (96, 20, 44, 70);
        let (gx0, gx1, gy0, gy1) = (
            left,
            (w - right).max(left + 1),
            top,
            (h - bottom).max(top + 1),
        );
        let measure = |s: &str, size: u32| {
            body.estimate_text_size(s, &TextStyle::from((FONT, size).into_font()))
                .map(|(w, _)| w as f64)
                .unwrap_or(s.len() as f64 * size as f64 * 0.6)
        };
        let sy = |v: f64| gy1 - ((v / self.y_max) * (gy1 - gy0) as f64).round() as i32;
        // legend in one row above the bars
        let mut lx = gx0;
        for (i, s) in self.series.iter().enumerate() {
            body.draw(&Rectangle::new(
                [(lx, 10), (lx + 16, 26)],
                series_colour(i).filled(),
            ))
            .msg()?;
            body.draw_text(
                &s.name,
                &anchored(TICK_SIZE, HPos::Left, VPos::Center),
                (lx + 22, 18),
            )
            .msg()?;
            lx += 22 + measure(&s.name, TICK_SIZE) as i32 + 24;
        }
        // grid and y ticks: five steps of y_max
        for k in 0..=5 {
            let v = self.y_max * k as f64 / 5.0;
            let y = sy(v);
            body.draw(&PathElement::new(
                vec![(gx0, y), (gx1, y)],
                RGBColor(222, 222, 222).stroke_width(1),
            ))
            .msg()?;
            body.draw_text(
                &format_number(v),
                &anchored(TICK_SIZE, HPos::Right, VPos::Center),
                (gx0 - 8, y),
            )
            .msg()?;
        }
        vertical_text(&body, &self.y_label, LABEL_SIZE, (16, (gy0 + gy1) / 2))?;
        let nc = self.categories.len();
        let ns = self.series.len();
        let gw = (gx1 - gx0) as f64 / nc as f64;
        let bw = gw * 0.8 / ns as f64;
        for (ci, cat) in self.categories.iter().enumerate() {
            let g0 = gx0 as f64 + ci as f64 * gw + 0.1 * gw;
            for (si, s) in self.series.iter().enumerate() {
                let Some(v) = s.values[ci] else { continue };
                let x0 = (g0 + si as f64 * bw).round() as i32;
                let x1 = ((g0 + (si + 1) as f64 * bw).round() as i32 - 1).max(x0 + 1);
                let y = sy(v).min(gy1 - 1);
                body.draw(&Rectangle::new(
                    [(x0, y), (x1, gy1)],
                    series_colour(si).filled(),
                ))
                .msg()?;
                // the value above the bar, in the largest font up to the tick size that fits
                let text = format_number(v);
                let mut size = TICK_SIZE - 2;
                while size >= 10 && measure(&text, size) > (x1 - x0) as f64 {
                    size -= 1;
                }
                if size >= 10 {
                    body.draw_text(
                        &text,
                        &anchored(size, HPos::Center, VPos::Bottom),
                        ((x0 + x1) / 2, y - 2),
                    )
                    .msg()?;
                }
            }
            let xc = (gx0 as f64 + (ci as f64 + 0.5) * gw).round() as i32;
            let mut size = TICK_SIZE;
            while size > 9 && measure(cat, size) > gw - 4.0 {
                size -= 1;
            }
            body.draw_text(cat, &anchored(size, HPos::Center, VPos::Top), (xc, gy1 + 8))
                .msg()?;
            if let Some(note) = self.notes.get(ci).filter(|n| !n.is_empty()) {
                body.draw_text(
                    note,
                    &anchored(TICK_SIZE - 2, HPos::Center, VPos::Top),
                    (xc, gy1 + 30),
                )
                .msg()?;
            }
        }
        body.draw(&PathElement::new(
            vec![(gx0, gy0), (gx0, gy1), (gx1, gy1)],
            BLACK.stroke_width(1),
        ))
        .msg()?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart() -> BarChart {
        BarChart {
            title: "success by family".into(),
            y_label: "success (%)".into(),
            categories: vec!["a".into(), "b".into()],
            notes: vec!["2 runs".into(), "2 runs".into()],
            series: vec![
                BarSeries {
                    name: "mpc".into(),
                    values: vec![Some(100.0), Some(50.0)],
                },
                BarSeries {
                    name: "pd".into(),
                    values: vec![Some(0.0), None],
                },
            ],
            y_max: 100.0,
            size: Some((600, 400)),
        }
    }

    #[test]
    fn bars_are_drawn_to_png_and_svg_and_bad_values_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("bars.png");
        bar_chart(&png, &chart()).unwrap();
        let svg = std::fs::read_to_string(dir.path().join("bars.svg")).unwrap();
        assert!(svg.contains("mpc") && svg.contains("2 runs"));
        let img = std::fs::read(&png).unwrap();
        assert_eq!(&img[1..4], b"PNG");
        let mut bad = chart();
        bad.series[0].values[1] = Some(120.0);
        let e = bar_chart(dir.path().join("bad.png"), &bad).unwrap_err();
        assert!(e.to_string().contains("120"), "{e}");
        assert!(!dir.path().join("bad.png").exists());
        let mut short = chart();
        short.series[1].values.pop();
        assert!(bar_chart(dir.path().join("short.png"), &short).is_err());
    }
}
