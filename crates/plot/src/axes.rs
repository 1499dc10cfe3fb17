//! Layout pieces shared by the figures: title, a labelled 2-D chart, and a legend column.

use crate::output::OrMsg;
use crate::style::{format_number, FONT};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontTransform;

/// Pixels reserved left of a chart for tick labels and the (rotated) y label.
pub(crate) const Y_LABEL_AREA: u32 = 92;
/// Chart margins in pixels: top, right, left (bottom is 0: the x label area follows).
const MARGIN_TOP: u32 = 14;
const MARGIN_RIGHT: u32 = 22;
const MARGIN_LEFT: u32 = 6;
/// Font sizes in pixels.
pub(crate) const TITLE_SIZE: u32 = 26;
pub(crate) const TICK_SIZE: u32 = 16;
pub(crate) const LABEL_SIZE: u32 = 19;

/// A 2-D chart over f64 coordinates.
pub(crate) type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

/// Draw `text` as the figure title and return the area below it (the whole area when empty).
pub(crate) fn title<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    text: &str,
) -> Result<DrawingArea<DB, Shift>, String> {
    if text.is_empty() {
        return Ok(root.clone());
    }
    root.titled(text, (FONT, TITLE_SIZE)).msg()
}

/// Axis labels and ranges of one chart.
pub(crate) struct Axes<'a> {
    /// X label with unit ("" for none).
    pub x_label: &'a str,
    /// Y label with unit.
    pub y_label: &'a str,
    /// Visible x range.
    pub x_range: (f64, f64),
    /// Visible y range.
    pub y_range: (f64, f64),
    /// Pixels below the plot for x tick labels and the x label.
    pub x_label_area: u32,
}

impl Axes<'_> {
    /// Size in pixels of the plotting rectangle this chart gets inside an area of `dims`.
    pub(crate) fn plot_pixels(&self, dims: (u32, u32)) -> (u32, u32) {
        (
            dims.0
                .saturating_sub(MARGIN_LEFT + MARGIN_RIGHT + Y_LABEL_AREA)
                .max(1),
            dims.1.saturating_sub(MARGIN_TOP + self.x_label_area).max(1),
        )
    }

    /// Build the chart on `area` and draw its grid, ticks and labels.
    ///
    /// Tick labels go through [`tick_value`] so a tick at zero never reads `-2.78e-17`.
    pub(crate) fn build<'b, DB: DrawingBackend>(
        &self,
        area: &'b DrawingArea<DB, Shift>,
    ) -> Result<Chart<'b, DB>, String> {
        let mut chart = ChartBuilder::on(area)
            .margin_top(MARGIN_TOP)
            .margin_right(MARGIN_RIGHT)
            .margin_left(MARGIN_LEFT)
            .x_label_area_size(self.x_label_area)
            .y_label_area_size(Y_LABEL_AREA)
            .build_cartesian_2d(
                self.x_range.0..self.x_range.1,
                self.y_range.0..self.y_range.1,
            )
            .msg()?;
        // a tick at zero can carry rounding noise (-2.78e-17): snap values far below the span to 0
        let snap = |span: f64| move |v: &f64| format_number(tick_value(*v, span));
        let (fx, fy) = (
            snap(self.x_range.1 - self.x_range.0),
            snap(self.y_range.1 - self.y_range.0),
        );
        chart
            .configure_mesh()
            .x_desc(self.x_label)
            .label_style((FONT, TICK_SIZE))
            .axis_desc_style((FONT, LABEL_SIZE))
            .x_label_formatter(&fx)
            .y_label_formatter(&fy)
            .x_labels(8)
            .y_labels(6)
            .bold_line_style(RGBColor(222, 222, 222))
            .light_line_style(RGBColor(242, 242, 242))
            .max_light_lines(4)
            .draw()
            .msg()?;
        // the mesh would draw the y label unrotated with ab_glyph: draw it rotated ourselves
        if !self.y_label.is_empty() {
            let (_, yr) = chart.plotting_area().get_pixel_range();
            let base = area.get_base_pixel();
            let yc = (yr.start + yr.end) / 2 - base.1;
            vertical_text(
                area,
                self.y_label,
                LABEL_SIZE,
                (MARGIN_LEFT as i32 + 12, yc),
            )?;
        }
        Ok(chart)
    }
}

/// Draw `text` rotated by 90 degrees (reading bottom to top) centred at `pos`.
pub(crate) fn vertical_text<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    text: &str,
    size: u32,
    pos: (i32, i32),
) -> Result<(), String> {
    let style = (FONT, size)
        .into_font()
        .transform(FontTransform::Rotate270)
        .color(&BLACK)
        .pos(plotters::style::text_anchor::Pos::new(
            plotters::style::text_anchor::HPos::Center,
            plotters::style::text_anchor::VPos::Center,
        ));
    area.draw_text(text, &style, pos).msg()
}

/// What a legend row shows left of its label.
#[derive(Debug, Clone, Copy)]
pub(crate) enum LegendMark {
    /// A line sample.
    Line {
        colour: RGBColor,
        dashed: bool,
        marker: bool,
    },
    /// A filled disc.
    Disc { colour: RGBColor },
    /// An outlined circle.
    Ring { colour: RGBColor },
}

/// One legend row.
#[derive(Debug, Clone)]
pub(crate) struct LegendEntry {
    /// Text.
    pub label: String,
    /// Sample.
    pub mark: LegendMark,
}

/// Width in pixels of a legend column that fits every label (0 when there are none).
pub(crate) fn legend_width<'a, DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    labels: impl IntoIterator<Item = &'a str>,
) -> u32 {
    let widest = labels
        .into_iter()
        .filter(|l| !l.is_empty())
        .map(|l| {
            root.estimate_text_size(l, &TextStyle::from((FONT, LEGEND_SIZE).into_font()))
                .map(|(w, _)| w)
                .unwrap_or(8 * l.len() as u32)
        })
        .max();
    match widest {
        Some(w) => w + SAMPLE_W + 34,
        None => 0,
    }
}

/// Legend font size in pixels.
pub(crate) const LEGEND_SIZE: u32 = 16;
/// Width of the sample drawn left of each legend label.
const SAMPLE_W: u32 = 38;

/// Draw legend rows from the top of `area`, starting `top` pixels down.
pub(crate) fn legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[LegendEntry],
    top: i32,
) -> Result<(), String> {
    let row = LEGEND_SIZE as i32 + 8;
    let x0 = 6;
    let sw = SAMPLE_W as i32;
    for (i, e) in entries.iter().enumerate() {
        let y = top + row / 2 + i as i32 * row;
        match e.mark {
            LegendMark::Line {
                colour,
                dashed,
                marker,
            } => {
                let style = colour.stroke_width(2);
                if dashed {
                    for k in 0..3 {
                        let a = x0 + k * 14;
                        area.draw(&PathElement::new(vec![(a, y), (a + 8, y)], style))
                            .msg()?;
                    }
                } else {
                    area.draw(&PathElement::new(vec![(x0, y), (x0 + sw - 6, y)], style))
                        .msg()?;
                }
                if marker {
                    area.draw(&Circle::new((x0 + sw / 2 - 3, y), 4, colour.filled()))
                        .msg()?;
                }
            }
            LegendMark::Disc { colour } => {
                area.draw(&Circle::new((x0 + sw / 2 - 3, y), 6, colour.filled()))
                    .msg()?;
            }
            LegendMark::Ring { colour } => {
                area.draw(&Circle::new(
                    (x0 + sw / 2 - 3, y),
                    7,
                    colour.stroke_width(2),
                ))
                .msg()?;
            }
        }
        let style = (FONT, LEGEND_SIZE).into_font().color(&BLACK).pos(
            plotters::style::text_anchor::Pos::new(
                plotters::style::text_anchor::HPos::Left,
                plotters::style::text_anchor::VPos::Center,
            ),
        );
        area.draw_text(&e.label, &style, (x0 + sw + 4, y)).msg()?;
    }
    Ok(())
}

/// A tick value as it should be printed on an axis spanning `span`: values smaller than 1e-9 of the
/// span are rounding noise around zero and print as 0.
pub(crate) fn tick_value(v: f64, span: f64) -> f64 {
    if v.abs() <= 1e-9 * span.abs() {
        0.0
    } else {
        v
    }
}

#[cfg(test)]
mod tick_tests {
    use super::tick_value;
    use crate::format_number;

    #[test]
    fn zero_ticks_lose_their_rounding_noise() {
        assert_eq!(format_number(tick_value(-2.78e-17, 0.2)), "0");
        assert_eq!(format_number(tick_value(0.05, 0.2)), "0.05");
        // a genuinely tiny axis keeps its values
        assert_eq!(tick_value(1e-12, 1e-11), 1e-12);
    }
}
