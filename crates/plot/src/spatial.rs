//! Pictures in the robot's plane (x right, y up, metres, equal axis scale): end-effector paths and
//! stick diagrams of the robot over time. Poses come from `brachia`'s forward kinematics
//! ([`Robot::joint_positions`]); nothing is simulated here.

use crate::axes::{self, Axes, LegendEntry, LegendMark};
use crate::error::PlotError;
use crate::output::{write_static, Drawable, OrMsg};
use crate::series::{check_curve, LineStyle, Series};
use crate::style::{equal_aspect, format_number, padded, series_colour, time_colour};
use brachia::trajectory::Trajectory;
use brachia::Robot;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::Path;

/// A circular obstacle in the plane.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Obstacle {
    /// Centre `[x, y]`, m.
    pub center: [f64; 2],
    /// Radius, m (> 0).
    pub radius: f64,
}

/// One sample of a moving ball's track.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct BallSample {
    /// Time, s (same clock as the trajectory).
    pub t: f64,
    /// Centre x, m.
    pub x: f64,
    /// Centre y, m.
    pub y: f64,
    /// Radius, m.
    pub r: f64,
}

/// End-effector paths in the plane (e.g. desired dashed vs actual solid), with the bars, the target
/// and obstacles marked. Axes are "x (m)" and "y (m)" at equal scale.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct XyPathFigure {
    /// Title.
    pub title: String,
    /// Paths: `x` and `y` of each [`Series`] are positions in m.
    pub paths: Vec<Series>,
    /// Bar positions `[x, y]`, m (drawn as dark discs).
    pub bars: Vec<[f64; 2]>,
    /// The target bar `[x, y]`, m (drawn as a red ring).
    pub target: Option<[f64; 2]>,
    /// Obstacles (drawn as grey circles).
    pub obstacles: Vec<Obstacle>,
    /// Image size in pixels; `None` = 1000 x 800.
    pub size: Option<(u32, u32)>,
}

/// Options of [`stick_diagram`].
#[derive(Debug, Clone, PartialEq)]
pub struct StickOptions {
    /// Title.
    pub title: String,
    /// Time between drawn poses, s (> 0). The final pose is always drawn. Default 0.1.
    pub every_s: f64,
    /// Bar positions `[x, y]`, m (the grip bar is usually `[0, 0]`).
    pub bars: Vec<[f64; 2]>,
    /// The target bar `[x, y]`, m.
    pub target: Option<[f64; 2]>,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Moving balls: each inner vector is one ball's track, ordered by time; a ball is drawn at each
    /// pose time (position interpolated linearly, held at the ends of its track) unless it has not
    /// moved since its last drawn copy.
    pub balls: Vec<Vec<BallSample>>,
    /// Image size in pixels; `None` = 1100 x 800.
    pub size: Option<(u32, u32)>,
}

impl Default for StickOptions {
    fn default() -> Self {
        StickOptions {
            title: String::new(),
            every_s: 0.1,
            bars: Vec::new(),
            target: None,
            obstacles: Vec::new(),
            balls: Vec::new(),
            size: None,
        }
    }
}

/// Write the end-effector path figure to `path` (PNG) and beside it `.svg`.
///
/// Errors: [`PlotError::InvalidData`] for no paths, an empty or non-finite path, non-finite bars,
/// target or obstacles; I/O errors name the file.
pub fn xy_path(path: impl AsRef<Path>, fig: &XyPathFigure) -> Result<(), PlotError> {
    let path = path.as_ref();
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    if fig.paths.is_empty() {
        return Err(bad("no paths to draw".into()));
    }
    for s in &fig.paths {
        check_curve(&s.name, &s.x, &s.y).map_err(bad)?;
    }
    check_scene(&fig.bars, fig.target, &fig.obstacles).map_err(bad)?;
    let mut scene = Scene::new(&fig.title, &fig.bars, fig.target, &fig.obstacles);
    scene.paths = &fig.paths;
    scene.legend = true;
    scene.fit(fig.paths.iter().flat_map(|s| {
        s.x.iter()
            .zip(&s.y)
            .map(|(&x, &y)| [x, y])
            .collect::<Vec<_>>()
    }));
    write_static(path, fig.size.unwrap_or((1000, 800)), &scene)
}

/// Write a stick diagram of `traj` to `path` (PNG) and beside it `.svg`: the robot every
/// `opts.every_s` seconds, coloured from light (start) to dark (end), the end-effector path, bars,
/// target, obstacles and balls.
///
/// Errors: [`PlotError::InvalidData`] for an empty trajectory, a link count different from the
/// robot's, non-finite or decreasing samples, `every_s` not positive (or more than 2000 poses),
/// non-finite scene data.
pub fn stick_diagram(
    path: impl AsRef<Path>,
    robot: &Robot,
    traj: &Trajectory,
    opts: &StickOptions,
) -> Result<(), PlotError> {
    let path = path.as_ref();
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    check_trajectory(robot, traj).map_err(bad)?;
    check_scene(&opts.bars, opts.target, &opts.obstacles).map_err(bad)?;
    check_balls(&opts.balls).map_err(bad)?;
    if !(opts.every_s.is_finite() && opts.every_s > 0.0) {
        return Err(bad(format!(
            "every_s must be positive, got {}",
            opts.every_s
        )));
    }
    let (t0, t1) = (traj.t[0], traj.t[traj.len() - 1]);
    let count = ((t1 - t0) / opts.every_s).floor();
    if count > 2000.0 {
        return Err(bad(format!(
            "every_s = {} s gives {count} poses over {} s (at most 2000)",
            opts.every_s,
            t1 - t0
        )));
    }
    let mut times: Vec<f64> = (0..=count as usize)
        .map(|k| t0 + k as f64 * opts.every_s)
        .collect();
    let last = *times.last().unwrap_or(&t0);
    if t1 - last > 0.3 * opts.every_s || times.len() == 1 {
        times.push(t1);
    } else if let Some(l) = times.last_mut() {
        *l = t1;
    }
    if t1 == t0 {
        times.truncate(1);
    }
    let span = (t1 - t0).max(1e-12);
    let mut scene = Scene::new(&opts.title, &opts.bars, opts.target, &opts.obstacles);
    scene.legend = true;
    scene.trail = ee_trail(robot, traj, t1);
    scene.fit(all_joint_points(robot, traj));
    scene.fit(ball_extent(&opts.balls));
    // a ball that has not moved since its last drawn copy is not drawn again
    let mut last_ball: Vec<Option<([f64; 2], f64)>> = vec![None; opts.balls.len()];
    for &t in &times {
        let frac = (t - t0) / span;
        let colour = time_colour(frac);
        scene.poses.push((pose_at(robot, traj, t), colour));
        for (i, track) in opts.balls.iter().enumerate() {
            if let Some(b) = ball_at(track, t) {
                if last_ball[i] != Some(b) {
                    scene.balls.push((b, colour));
                    last_ball[i] = Some(b);
                }
            }
        }
    }
    scene.time_bar = Some((t0, t1));
    write_static(path, opts.size.unwrap_or((1100, 800)), &scene)
}

/// Trajectory sanity: non-empty, right link count, consistent lengths, finite and non-decreasing.
pub(crate) fn check_trajectory(robot: &Robot, traj: &Trajectory) -> Result<(), String> {
    if traj.is_empty() {
        return Err("the trajectory has no samples".into());
    }
    if traj.n != robot.n() {
        return Err(format!(
            "the trajectory has {} links but the robot has {}",
            traj.n,
            robot.n()
        ));
    }
    if traj.q.len() != traj.len() * traj.n {
        return Err(format!(
            "q holds {} values, expected {} samples x {} links",
            traj.q.len(),
            traj.len(),
            traj.n
        ));
    }
    if let Some(k) = traj.t.iter().position(|t| !t.is_finite()) {
        return Err(format!("non-finite time at sample {k}"));
    }
    if let Some(k) = traj.t.windows(2).position(|w| w[1] < w[0]) {
        return Err(format!(
            "time decreases at sample {}: {} after {}",
            k + 1,
            traj.t[k + 1],
            traj.t[k]
        ));
    }
    if let Some(i) = traj.q.iter().position(|v| !v.is_finite()) {
        return Err(format!(
            "non-finite joint angle at sample {}, joint {}",
            i / traj.n,
            i % traj.n + 1
        ));
    }
    Ok(())
}

/// Bars, target and obstacles must be finite; obstacle radii positive.
pub(crate) fn check_scene(
    bars: &[[f64; 2]],
    target: Option<[f64; 2]>,
    obstacles: &[Obstacle],
) -> Result<(), String> {
    if let Some(b) = bars.iter().find(|b| !b.iter().all(|v| v.is_finite())) {
        return Err(format!("non-finite bar position {b:?}"));
    }
    if let Some(t) = target.filter(|t| !t.iter().all(|v| v.is_finite())) {
        return Err(format!("non-finite target {t:?}"));
    }
    if let Some(o) = obstacles.iter().find(|o| {
        !(o.center.iter().all(|v| v.is_finite()) && o.radius.is_finite() && o.radius > 0.0)
    }) {
        return Err(format!("invalid obstacle {o:?}"));
    }
    Ok(())
}

/// Ball tracks must be finite, non-negative radii, time-ordered.
pub(crate) fn check_balls(balls: &[Vec<BallSample>]) -> Result<(), String> {
    for (i, track) in balls.iter().enumerate() {
        if let Some(b) = track
            .iter()
            .find(|b| ![b.t, b.x, b.y, b.r].iter().all(|v| v.is_finite()) || b.r < 0.0)
        {
            return Err(format!("ball {i}: invalid sample {b:?}"));
        }
        if track.windows(2).any(|w| w[1].t < w[0].t) {
            return Err(format!("ball {i}: samples are not ordered by time"));
        }
    }
    Ok(())
}

/// Joint positions (grip, link ends, EE) at time `t`, q interpolated linearly between samples.
pub(crate) fn pose_at(robot: &Robot, traj: &Trajectory, t: f64) -> Vec<[f64; 2]> {
    let mut x = vec![0.0; 2 * traj.n];
    traj.state_at(t, &mut x);
    let mut pts = vec![[0.0; 2]; robot.n() + 1];
    robot.joint_positions(&x[..robot.n()], &mut pts);
    pts
}

/// End-effector positions of every sample up to time `t_end`.
pub(crate) fn ee_trail(robot: &Robot, traj: &Trajectory, t_end: f64) -> Vec<[f64; 2]> {
    (0..traj.len())
        .take_while(|&k| traj.t[k] <= t_end)
        .map(|k| robot.ee_position(traj.q(k)))
        .collect()
}

/// Every joint position of every sample (to size the view).
pub(crate) fn all_joint_points(robot: &Robot, traj: &Trajectory) -> Vec<[f64; 2]> {
    let mut pts = vec![[0.0; 2]; robot.n() + 1];
    let mut out = Vec::with_capacity(traj.len() * (robot.n() + 1));
    for k in 0..traj.len() {
        robot.joint_positions(traj.q(k), &mut pts);
        out.extend_from_slice(&pts);
    }
    out
}

/// Corner points of every ball sample's bounding box.
pub(crate) fn ball_extent(balls: &[Vec<BallSample>]) -> Vec<[f64; 2]> {
    balls
        .iter()
        .flatten()
        .flat_map(|b| [[b.x - b.r, b.y - b.r], [b.x + b.r, b.y + b.r]])
        .collect()
}

/// A ball's centre and radius at time `t` (linear interpolation, held at the track's ends).
pub(crate) fn ball_at(track: &[BallSample], t: f64) -> Option<([f64; 2], f64)> {
    let first = track.first()?;
    let last = track.last()?;
    if t <= first.t {
        return Some(([first.x, first.y], first.r));
    }
    if t >= last.t {
        return Some(([last.x, last.y], last.r));
    }
    let k = track.partition_point(|b| b.t <= t).max(1) - 1;
    let (a, b) = (track[k], track[k + 1]);
    let f = if b.t > a.t {
        (t - a.t) / (b.t - a.t)
    } else {
        0.0
    };
    Some((
        [a.x + f * (b.x - a.x), a.y + f * (b.y - a.y)],
        a.r + f * (b.r - a.r),
    ))
}

/// Colours of the scene elements.
const BAR_COLOUR: RGBColor = RGBColor(40, 40, 40);
const TARGET_COLOUR: RGBColor = RGBColor(215, 25, 28);
const OBSTACLE_COLOUR: RGBColor = RGBColor(120, 120, 120);
const TRAIL_COLOUR: RGBColor = RGBColor(150, 150, 150);
const BALL_COLOUR: RGBColor = RGBColor(230, 120, 20);

/// Everything drawn in the plane; shared by the path figure, the stick diagram and animation frames.
pub(crate) struct Scene<'a> {
    pub title: &'a str,
    pub bars: &'a [[f64; 2]],
    pub target: Option<[f64; 2]>,
    pub obstacles: &'a [Obstacle],
    /// Curves in the plane (x, y in m).
    pub paths: &'a [Series],
    /// End-effector trail (thin grey).
    pub trail: Vec<[f64; 2]>,
    /// Robot poses (joint positions) with their colours, drawn in order.
    pub poses: Vec<(Vec<[f64; 2]>, RGBColor)>,
    /// Balls (centre, radius) with their colours.
    pub balls: Vec<(([f64; 2], f64), RGBColor)>,
    /// Data box to show (before equal-aspect widening): x_lo, x_hi, y_lo, y_hi.
    pub bounds: Option<(f64, f64, f64, f64)>,
    /// Draw a legend column.
    pub legend: bool,
    /// Time range for the colour bar of a stick diagram.
    pub time_bar: Option<(f64, f64)>,
    /// Text in the top-left corner of the plot (time stamp of an animation frame).
    pub stamp: Option<String>,
}

impl<'a> Scene<'a> {
    /// A scene with the static elements; the box already covers them.
    pub(crate) fn new(
        title: &'a str,
        bars: &'a [[f64; 2]],
        target: Option<[f64; 2]>,
        obstacles: &'a [Obstacle],
    ) -> Self {
        let mut s = Scene {
            title,
            bars,
            target,
            obstacles,
            paths: &[],
            trail: Vec::new(),
            poses: Vec::new(),
            balls: Vec::new(),
            bounds: None,
            legend: false,
            time_bar: None,
            stamp: None,
        };
        s.fit(bars.iter().copied().chain(target));
        s.fit(
            obstacles
                .iter()
                .flat_map(|o| {
                    let (c, r) = (o.center, o.radius);
                    [[c[0] - r, c[1] - r], [c[0] + r, c[1] + r]]
                })
                .collect::<Vec<_>>(),
        );
        s
    }

    /// Grow the data box to include `pts`.
    pub(crate) fn fit(&mut self, pts: impl IntoIterator<Item = [f64; 2]>) {
        for p in pts {
            self.bounds = Some(match self.bounds {
                None => (p[0], p[0], p[1], p[1]),
                Some((a, b, c, d)) => (a.min(p[0]), b.max(p[0]), c.min(p[1]), d.max(p[1])),
            });
        }
    }

    /// Legend rows for what this scene contains.
    fn legend_entries(&self) -> Vec<LegendEntry> {
        let mut e = Vec::new();
        for (i, s) in self.paths.iter().enumerate() {
            if !s.name.is_empty() {
                e.push(LegendEntry {
                    label: s.name.clone(),
                    mark: LegendMark::Line {
                        colour: series_colour(s.colour.unwrap_or(i)),
                        dashed: s.style == LineStyle::Dashed,
                        marker: false,
                    },
                });
            }
        }
        if !self.trail.is_empty() {
            e.push(LegendEntry {
                label: "end-effector path".into(),
                mark: LegendMark::Line {
                    colour: TRAIL_COLOUR,
                    dashed: false,
                    marker: false,
                },
            });
        }
        if !self.bars.is_empty() {
            e.push(LegendEntry {
                label: "bar".into(),
                mark: LegendMark::Disc { colour: BAR_COLOUR },
            });
        }
        if self.target.is_some() {
            e.push(LegendEntry {
                label: "target bar".into(),
                mark: LegendMark::Ring {
                    colour: TARGET_COLOUR,
                },
            });
        }
        if !self.obstacles.is_empty() {
            e.push(LegendEntry {
                label: "obstacle".into(),
                mark: LegendMark::Ring {
                    colour: OBSTACLE_COLOUR,
                },
            });
        }
        if !self.balls.is_empty() {
            e.push(LegendEntry {
                label: "ball".into(),
                mark: LegendMark::Disc {
                    colour: BALL_COLOUR,
                },
            });
        }
        e
    }
}

/// Points of a circle as a closed polygon (96 segments).
fn circle_points(c: [f64; 2], r: f64) -> Vec<(f64, f64)> {
    (0..=96)
        .map(|k| {
            let a = k as f64 / 96.0 * std::f64::consts::TAU;
            (c[0] + r * a.cos(), c[1] + r * a.sin())
        })
        .collect()
}

impl Drawable for Scene<'_> {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let body = axes::title(root, self.title)?;
        let entries = if self.legend {
            self.legend_entries()
        } else {
            Vec::new()
        };
        let mut legend_w = axes::legend_width(root, entries.iter().map(|e| e.label.as_str()));
        if self.time_bar.is_some() {
            legend_w = legend_w.max(150);
        }
        let (w, _) = body.dim_in_pixel();
        let (plot_area, legend_area) = body.split_horizontally(w.saturating_sub(legend_w));
        let (x0, x1, y0, y1) = self.bounds.unwrap_or((-1.0, 1.0, -1.0, 1.0));
        let (x0, x1) = padded(x0, x1, 0.06);
        let (y0, y1) = padded(y0, y1, 0.06);
        let mut ax = Axes {
            x_label: "x (m)",
            y_label: "y (m)",
            x_range: (x0, x1),
            y_range: (y0, y1),
            x_label_area: 62,
        };
        let (pw, ph) = ax.plot_pixels(plot_area.dim_in_pixel());
        let (a, b, c, d) = equal_aspect((x0, x1, y0, y1), pw, ph);
        ax.x_range = (a, b);
        ax.y_range = (c, d);
        let mut chart = ax.build(&plot_area)?;
        for o in self.obstacles {
            let pts = circle_points(o.center, o.radius);
            chart
                .draw_series(std::iter::once(Polygon::new(
                    pts.clone(),
                    OBSTACLE_COLOUR.mix(0.25).filled(),
                )))
                .msg()?;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    pts,
                    OBSTACLE_COLOUR.stroke_width(2),
                )))
                .msg()?;
        }
        if self.trail.len() > 1 {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    self.trail.iter().map(|p| (p[0], p[1])).collect::<Vec<_>>(),
                    TRAIL_COLOUR.stroke_width(1),
                )))
                .msg()?;
        }
        for (i, s) in self.paths.iter().enumerate() {
            let colour = series_colour(s.colour.unwrap_or(i));
            let pts = s.x.iter().copied().zip(s.y.iter().copied());
            match s.style {
                LineStyle::Solid => {
                    chart
                        .draw_series(LineSeries::new(pts, colour.stroke_width(2)))
                        .msg()?;
                }
                LineStyle::Dashed => {
                    chart
                        .draw_series(DashedLineSeries::new(pts, 9, 6, colour.stroke_width(2)))
                        .msg()?;
                }
            }
        }
        for ((c, r), colour) in &self.balls {
            let pts = circle_points(*c, *r);
            chart
                .draw_series(std::iter::once(Polygon::new(
                    pts.clone(),
                    BALL_COLOUR.mix(0.35).filled(),
                )))
                .msg()?;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    pts,
                    colour.stroke_width(2),
                )))
                .msg()?;
        }
        for (pts, colour) in &self.poses {
            let line: Vec<(f64, f64)> = pts.iter().map(|p| (p[0], p[1])).collect();
            chart
                .draw_series(std::iter::once(PathElement::new(
                    line.clone(),
                    colour.stroke_width(3),
                )))
                .msg()?;
            chart
                .draw_series(line.iter().map(|&p| Circle::new(p, 3, colour.filled())))
                .msg()?;
        }
        for b in self.bars {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (b[0], b[1]),
                    6,
                    BAR_COLOUR.filled(),
                )))
                .msg()?;
        }
        if let Some(t) = self.target {
            chart
                .draw_series(std::iter::once(Circle::new(
                    (t[0], t[1]),
                    9,
                    TARGET_COLOUR.stroke_width(3),
                )))
                .msg()?;
        }
        if let Some(text) = &self.stamp {
            let pos = (a + 0.03 * (b - a), d - 0.03 * (d - c));
            let style = (crate::style::FONT, axes::LABEL_SIZE)
                .into_font()
                .color(&BLACK)
                .pos(plotters::style::text_anchor::Pos::new(
                    plotters::style::text_anchor::HPos::Left,
                    plotters::style::text_anchor::VPos::Top,
                ));
            chart
                .draw_series(std::iter::once(Text::new(text.clone(), pos, style)))
                .msg()?;
        }
        axes::legend(&legend_area, &entries, 20)?;
        if let Some((t0, t1)) = self.time_bar {
            let top = 20 + entries.len() as i32 * (axes::LEGEND_SIZE as i32 + 8) + 30;
            time_bar(&legend_area, top, t0, t1)?;
        }
        Ok(())
    }
}

/// A vertical colour bar of the stick diagram's time colours with its start and end times.
fn time_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    top: i32,
    t0: f64,
    t1: f64,
) -> Result<(), String> {
    let (x, w, h) = (14, 22, 220);
    let font = (crate::style::FONT, axes::LEGEND_SIZE).into_font();
    area.draw_text("time (s)", &font.color(&BLACK), (x - 4, top - 24))
        .msg()?;
    for k in 0..h {
        let c = time_colour(k as f64 / (h - 1) as f64);
        area.draw(&Rectangle::new(
            [(x, top + k), (x + w, top + k + 1)],
            c.filled(),
        ))
        .msg()?;
    }
    area.draw(&Rectangle::new(
        [(x, top), (x + w, top + h)],
        BLACK.stroke_width(1),
    ))
    .msg()?;
    let anchor =
        |v| plotters::style::text_anchor::Pos::new(plotters::style::text_anchor::HPos::Left, v);
    area.draw_text(
        &format!("{} (start)", format_number(t0)),
        &font
            .color(&BLACK)
            .pos(anchor(plotters::style::text_anchor::VPos::Top)),
        (x + w + 6, top),
    )
    .msg()?;
    area.draw_text(
        &format!("{} (end)", format_number(t1)),
        &font
            .color(&BLACK)
            .pos(anchor(plotters::style::text_anchor::VPos::Bottom)),
        (x + w + 6, top + h),
    )
    .msg()?;
    Ok(())
}
