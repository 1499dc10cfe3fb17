//! Heat maps of a scalar over a 2-D parameter grid (e.g. energy against two link lengths), with a
//! colour bar, the value printed in every cell and failed cells hatched grey and labelled.

use crate::axes::{self, vertical_text, LABEL_SIZE, TICK_SIZE};
use crate::error::PlotError;
use crate::output::{write_static, Drawable, OrMsg};
use crate::style::{format_number, luminance, min_max, value_colour, FONT};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::Path;

/// A grid of values over `xs` x `ys`.
///
/// Layout: `values[iy * xs.len() + ix]` is the cell at column `xs[ix]` and row `ys[iy]`; row 0 is
/// drawn at the bottom. `None` marks a failed cell (the experiment gave no value).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Heatmap {
    /// Title.
    pub title: String,
    /// X-axis label with unit.
    pub x_label: String,
    /// Y-axis label with unit.
    pub y_label: String,
    /// Column values (tick labels), left to right.
    pub xs: Vec<f64>,
    /// Row values (tick labels), bottom to top.
    pub ys: Vec<f64>,
    /// Cell values, row-major, `ys.len() * xs.len()`; `None` = failed.
    pub values: Vec<Option<f64>>,
    /// Label of the colour bar with unit, e.g. `"E (J)"`.
    pub colourbar_label: String,
    /// Image size in pixels; `None` = 1000 x 760.
    pub size: Option<(u32, u32)>,
}

/// Write the heat map to `path` (PNG) and beside it `.svg`.
///
/// Errors: [`PlotError::InvalidData`] for an empty grid, non-finite axis values or cell values, or
/// a value count different from `xs.len() * ys.len()`.
pub fn heatmap(path: impl AsRef<Path>, fig: &Heatmap) -> Result<(), PlotError> {
    let path = path.as_ref();
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    if fig.xs.is_empty() || fig.ys.is_empty() {
        return Err(bad(format!(
            "empty grid: {} columns x {} rows",
            fig.xs.len(),
            fig.ys.len()
        )));
    }
    if fig.values.len() != fig.xs.len() * fig.ys.len() {
        return Err(bad(format!(
            "{} values for {} columns x {} rows",
            fig.values.len(),
            fig.xs.len(),
            fig.ys.len()
        )));
    }
    if fig.xs.iter().chain(&fig.ys).any(|v| !v.is_finite()) {
        return Err(bad("non-finite axis value".into()));
    }
    if let Some(i) = fig
        .values
        .iter()
        .position(|v| v.is_some_and(|v| !v.is_finite()))
    {
        return Err(bad(format!(
            "non-finite value at column {}, row {} (use None for a failed cell)",
            i % fig.xs.len(),
            i / fig.xs.len()
        )));
    }
    write_static(path, fig.size.unwrap_or((1000, 760)), fig)
}

/// Colours of failed cells.
const FAILED_FILL: RGBColor = RGBColor(222, 222, 222);
const FAILED_HATCH: RGBColor = RGBColor(150, 150, 150);

/// Draw grey fill and diagonal hatching in the pixel box `[x0, x1] x [y0, y1]`.
fn hatched<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    (x0, y0, x1, y1): (i32, i32, i32, i32),
) -> Result<(), String> {
    area.draw(&Rectangle::new([(x0, y0), (x1, y1)], FAILED_FILL.filled()))
        .msg()?;
    // lines x - x0 = k + (y - y0), clipped to the box
    let mut k = -(y1 - y0);
    while k < x1 - x0 {
        let ya = y0.max(y0 - k);
        let yb = y1.min(y0 + (x1 - x0) - k);
        if ya < yb {
            let p = (x0 + k + (ya - y0), ya);
            let q = (x0 + k + (yb - y0), yb);
            area.draw(&PathElement::new(vec![p, q], FAILED_HATCH.stroke_width(1)))
                .msg()?;
        }
        k += 9;
    }
    Ok(())
}

fn anchored(size: u32, colour: RGBColor, h: HPos, v: VPos) -> TextStyle<'static> {
    (FONT, size).into_font().color(&colour).pos(Pos::new(h, v))
}

/// Index stride so that labels of width `label_w` do not overlap at `cell` pixels per cell.
fn label_stride(cell: f64, label_w: f64) -> usize {
    ((label_w + 8.0) / cell.max(1.0)).ceil().max(1.0) as usize
}

impl Drawable for Heatmap {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let body = axes::title(root, &self.title)?;
        let (w, h) = body.dim_in_pixel();
        let (w, h) = (w as i32, h as i32);
        let (nx, ny) = (self.xs.len(), self.ys.len());
        let (left, right, top, bottom) = (104, 170, 16, 74);
        let (gx0, gx1, gy0, gy1) = (
            left,
            (w - right).max(left + 1),
            top,
            (h - bottom).max(top + 1),
        );
        let cw = (gx1 - gx0) as f64 / nx as f64;
        let ch = (gy1 - gy0) as f64 / ny as f64;
        let range = min_max(self.values.iter().flatten().copied());
        let frac = |v: f64| match range {
            Some((lo, hi)) if hi > lo => (v - lo) / (hi - lo),
            _ => 0.5,
        };
        let measure = |s: &str, size: u32| {
            body.estimate_text_size(s, &TextStyle::from((FONT, size).into_font()))
                .map(|(w, _)| w as f64)
                .unwrap_or(s.len() as f64 * size as f64 * 0.6)
        };
        // cells
        for iy in 0..ny {
            for ix in 0..nx {
                let x0 = gx0 + (ix as f64 * cw).round() as i32;
                let x1 = gx0 + ((ix + 1) as f64 * cw).round() as i32;
                let y1 = gy1 - (iy as f64 * ch).round() as i32;
                let y0 = gy1 - ((iy + 1) as f64 * ch).round() as i32;
                let centre = ((x0 + x1) / 2, (y0 + y1) / 2);
                let (text, text_colour) = match self.values[iy * nx + ix] {
                    Some(v) => {
                        let c = value_colour(frac(v));
                        body.draw(&Rectangle::new([(x0, y0), (x1, y1)], c.filled()))
                            .msg()?;
                        let tc = if luminance(c) < 0.5 { WHITE } else { BLACK };
                        (format_number(v), tc)
                    }
                    None => {
                        hatched(&body, (x0, y0, x1, y1))?;
                        ("failed".to_string(), RGBColor(60, 60, 60))
                    }
                };
                body.draw(&Rectangle::new([(x0, y0), (x1, y1)], WHITE.stroke_width(1)))
                    .msg()?;
                // largest font up to 17 px that fits the cell
                let mut size = 17u32.min((ch * 0.42) as u32);
                while size >= 8 && measure(&text, size) > cw - 6.0 {
                    size -= 1;
                }
                if size >= 8 {
                    body.draw_text(
                        &text,
                        &anchored(size, text_colour, HPos::Center, VPos::Center),
                        centre,
                    )
                    .msg()?;
                }
            }
        }
        body.draw(&Rectangle::new(
            [(gx0, gy0), (gx1, gy1)],
            BLACK.stroke_width(1),
        ))
        .msg()?;
        // x ticks under the cell centres
        let xw = self
            .xs
            .iter()
            .map(|v| measure(&format_number(*v), TICK_SIZE))
            .fold(0.0, f64::max);
        let stride = label_stride(cw, xw);
        for ix in (0..nx).step_by(stride) {
            let x = gx0 + ((ix as f64 + 0.5) * cw).round() as i32;
            body.draw(&PathElement::new(vec![(x, gy1), (x, gy1 + 5)], BLACK))
                .msg()?;
            body.draw_text(
                &format_number(self.xs[ix]),
                &anchored(TICK_SIZE, BLACK, HPos::Center, VPos::Top),
                (x, gy1 + 8),
            )
            .msg()?;
        }
        body.draw_text(
            &self.x_label,
            &anchored(LABEL_SIZE, BLACK, HPos::Center, VPos::Bottom),
            ((gx0 + gx1) / 2, h - 8),
        )
        .msg()?;
        // y ticks beside the row centres
        let stride = label_stride(ch, TICK_SIZE as f64);
        for iy in (0..ny).step_by(stride) {
            let y = gy1 - ((iy as f64 + 0.5) * ch).round() as i32;
            body.draw(&PathElement::new(vec![(gx0 - 5, y), (gx0, y)], BLACK))
                .msg()?;
            body.draw_text(
                &format_number(self.ys[iy]),
                &anchored(TICK_SIZE, BLACK, HPos::Right, VPos::Center),
                (gx0 - 8, y),
            )
            .msg()?;
        }
        vertical_text(&body, &self.y_label, LABEL_SIZE, (16, (gy0 + gy1) / 2))?;
        // colour bar
        let (bx0, bx1) = (gx1 + 26, gx1 + 50);
        let (by0, by1) = (gy0 + 10, gy1 - 60);
        let bh = (by1 - by0).max(1);
        for k in 0..bh {
            let c = value_colour(1.0 - k as f64 / (bh - 1).max(1) as f64);
            body.draw(&Rectangle::new(
                [(bx0, by0 + k), (bx1, by0 + k + 1)],
                c.filled(),
            ))
            .msg()?;
        }
        body.draw(&Rectangle::new(
            [(bx0, by0), (bx1, by1)],
            BLACK.stroke_width(1),
        ))
        .msg()?;
        let ticks: Vec<f64> = match range {
            Some((lo, hi)) if hi > lo => (0..5).map(|k| lo + (hi - lo) * k as f64 / 4.0).collect(),
            Some((lo, _)) => vec![lo],
            None => Vec::new(),
        };
        for v in ticks {
            let y = by1 - (frac(v) * (bh - 1) as f64).round() as i32;
            body.draw(&PathElement::new(vec![(bx1, y), (bx1 + 5, y)], BLACK))
                .msg()?;
            body.draw_text(
                &format_number(v),
                &anchored(TICK_SIZE, BLACK, HPos::Left, VPos::Center),
                (bx1 + 8, y),
            )
            .msg()?;
        }
        vertical_text(
            &body,
            &self.colourbar_label,
            LABEL_SIZE,
            (w - 16, (by0 + by1) / 2),
        )?;
        // legend for failed cells
        if self.values.iter().any(|v| v.is_none()) {
            let y = by1 + 24;
            hatched(&body, (bx0, y, bx1, y + 20))?;
            body.draw(&Rectangle::new(
                [(bx0, y), (bx1, y + 20)],
                BLACK.stroke_width(1),
            ))
            .msg()?;
            body.draw_text(
                "failed",
                &anchored(TICK_SIZE, BLACK, HPos::Left, VPos::Center),
                (bx1 + 8, y + 10),
            )
            .msg()?;
        }
        Ok(())
    }
}
