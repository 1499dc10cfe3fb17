//! One frame of a robot pose as an RGB image in memory (for live viewers and learning environments):
//! the same scene code as the stick diagram and the animations, drawn into a buffer instead of a file.

use crate::output::render_rgb;
use crate::spatial::{Obstacle, Scene};
use crate::PlotError;
use plotters::style::RGBColor;

/// Colour of the robot's links.
const ROBOT_COLOUR: RGBColor = RGBColor(20, 50, 140);

/// Smallest and largest frame side, pixels.
const SIDE_RANGE: (u32, u32) = (64, 2000);

/// What one frame shows besides the robot.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct FrameScene {
    /// Frame size in pixels (width, height), each 64..=2000.
    pub size: (u32, u32),
    /// Bar positions `[x, y]`, m (the grip bar among them).
    pub bars: Vec<[f64; 2]>,
    /// The target bar `[x, y]`, m.
    pub target: Option<[f64; 2]>,
    /// Fixed obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Free balls: centre `[x, y]` and radius, m.
    pub balls: Vec<([f64; 2], f64)>,
    /// Data box to show, `(x_lo, x_hi, y_lo, y_hi)` in m (widened to equal aspect); `None`: fitted
    /// to what is drawn.
    pub bounds: Option<(f64, f64, f64, f64)>,
    /// Text in the top-left corner ("" for none).
    pub stamp: String,
}

/// The frame of the pose `joints` (joint positions from the grip to the hand, m) as row-major RGB
/// bytes, `height * width * 3`.
///
/// Errors: [`PlotError::InvalidData`] for a size out of range or a non-finite point,
/// [`PlotError::Render`] when the backend fails (`path` is empty: nothing is written).
pub fn pose_frame_rgb(scene: &FrameScene, joints: &[[f64; 2]]) -> Result<Vec<u8>, PlotError> {
    let bad = |reason: String| PlotError::InvalidData {
        path: Default::default(),
        reason,
    };
    let (w, h) = scene.size;
    let (lo, hi) = SIDE_RANGE;
    if !(lo..=hi).contains(&w) || !(lo..=hi).contains(&h) {
        return Err(bad(format!(
            "frame size {w} x {h}: each side must be {lo}..={hi} pixels"
        )));
    }
    let finite = |p: &[f64; 2]| p.iter().all(|v| v.is_finite());
    if !joints.iter().all(finite) || !scene.balls.iter().all(|(c, r)| finite(c) && r.is_finite()) {
        return Err(bad("a joint or ball position is not finite".into()));
    }
    let mut s = Scene::new("", &scene.bars, scene.target, &scene.obstacles);
    match scene.bounds {
        Some(b) => s.bounds = Some(b),
        None => s.fit(joints.iter().copied()),
    }
    s.poses.push((joints.to_vec(), ROBOT_COLOUR));
    for &(c, r) in &scene.balls {
        s.balls.push(((c, r), RGBColor(180, 80, 0)));
    }
    if !scene.stamp.is_empty() {
        s.stamp = Some(scene.stamp.clone());
    }
    render_rgb((w, h), &s).map_err(|message| PlotError::Render {
        path: Default::default(),
        message,
    })
}
