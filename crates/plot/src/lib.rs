//! # brachia-plot
//!
//! Figures and animations for brachia's experiments: plain functions over plain data. Each static
//! figure writes a PNG at the given path (which must end in `.png`) and an SVG beside it (same name,
//! `.svg`); [`animate_gif`] writes an infinitely looping GIF. Files are rendered in memory, written to
//! a hidden temporary file in the target folder and renamed, so a failure leaves no half-written file.
//! Every function returns [`PlotError`], which names the path; bad data (empty, NaN, mismatched
//! lengths) is an error, never a panic.
//!
//! | function | picture |
//! |---|---|
//! | [`time_series`] | stacked panels of curves over a shared x axis (q / qd / tau, desired dashed vs tracked solid) |
//! | [`line_plot`] | one panel of y(x) curves with markers (parameter sweeps) |
//! | [`xy_path`] | end-effector paths in the plane, bars, target and obstacles, equal axis scale |
//! | [`pose_diagram`] | poses given in world coordinates (a traverse whose grip changes), light to dark |
//! | [`stick_diagram`] | the robot every `every_s` seconds, light (start) to dark (end), equal axis scale |
//! | [`heatmap`] | a value over a 2-D grid, colour bar, values printed, failed cells hatched |
//! | [`bar_chart`] | grouped bars, one per series in every category, values printed, a note per category |
//! | [`animate_gif`] | the moving stick figure with bars, target, obstacles, balls and a time stamp |
//! | [`animate_poses_gif`] | the same from world poses (a traverse whose grip changes) |
//!
//! ## Conventions (as in `brachia`)
//! Planar frame at the grip point, x right, y up, gravity along -y; `q[0]` is the absolute angle of
//! link 1 from +x, `q[i>0]` relative; SI units. Poses are computed with
//! [`brachia::Robot::joint_positions`] from the trajectory's `q` (interpolated linearly between
//! samples); this crate never simulates.
//!
//! Text uses the bundled DejaVu Sans (`assets/DejaVuSans.ttf`, Bitstream Vera licence in
//! `assets/DejaVuSans-LICENSE.txt`), so no system fonts or font libraries are needed.

mod anim;
mod axes;
mod bars;
mod error;
mod frame;
mod heatmap;
mod output;
mod poses;
mod series;
mod spatial;
mod style;

pub use anim::{animate_gif, animate_poses_gif, frame_times, AnimOptions, MAX_FRAMES};
pub use bars::{bar_chart, BarChart, BarSeries};
pub use error::PlotError;
pub use frame::{pose_frame_rgb, FrameScene};
pub use heatmap::{heatmap, Heatmap};
pub use poses::{pose_diagram, PoseFigure, MAX_POSES};
pub use series::{line_plot, time_series, LinePlot, LineStyle, Panel, Series, TimeSeriesFigure};
pub use spatial::{stick_diagram, xy_path, BallSample, Obstacle, StickOptions, XyPathFigure};
pub use style::{equal_aspect, format_number, series_colour, time_colour, value_colour};
