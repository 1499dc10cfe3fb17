//! A diagram of poses already placed in the plane: for motions whose frame changes along the way (a
//! ladder traverse re-roots the chain at every bar), the caller gives world joint positions directly.
//!
//! Conventions (as in `brachia`): x right, y up, metres, equal axis scale; poses are the chain's joint
//! positions from one end to the other, coloured from light (start) to dark (end) by their time.

use crate::error::PlotError;
use crate::output::write_static;
use crate::spatial::{check_scene, Obstacle, Scene};
use crate::style::time_colour;
use std::path::Path;

/// Poses in world coordinates with the bars, obstacles and a hand trail.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PoseFigure {
    /// Title.
    pub title: String,
    /// `(t, joint positions)`: time in s (non-decreasing) and the chain's points `[x, y]` in m.
    pub poses: Vec<(f64, Vec<[f64; 2]>)>,
    /// A path drawn thin and grey (e.g. the swinging hand), m.
    pub trail: Vec<[f64; 2]>,
    /// Bars `[x, y]`, m.
    pub bars: Vec<[f64; 2]>,
    /// The goal bar, m (a red ring).
    pub target: Option<[f64; 2]>,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Image size in pixels; `None` = 1400 x 700.
    pub size: Option<(u32, u32)>,
}

/// Most poses a [`PoseFigure`] may hold.
pub const MAX_POSES: usize = 2000;

/// Write the pose diagram to `path` (PNG) and beside it `.svg`.
///
/// Errors: [`PlotError::InvalidData`] for no poses, more than [`MAX_POSES`], an empty or non-finite
/// pose, decreasing times, non-finite trail or scene data.
pub fn pose_diagram(path: impl AsRef<Path>, fig: &PoseFigure) -> Result<(), PlotError> {
    let path = path.as_ref();
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    if fig.poses.is_empty() || fig.poses.len() > MAX_POSES {
        return Err(bad(format!(
            "{} poses (need 1..={MAX_POSES})",
            fig.poses.len()
        )));
    }
    for (k, (t, pts)) in fig.poses.iter().enumerate() {
        if !t.is_finite() || pts.is_empty() || pts.iter().flatten().any(|v| !v.is_finite()) {
            return Err(bad(format!("pose {k} (t = {t}) is empty or not finite")));
        }
    }
    if fig.poses.windows(2).any(|w| w[1].0 < w[0].0) {
        return Err(bad("pose times decrease".into()));
    }
    if fig.trail.iter().flatten().any(|v| !v.is_finite()) {
        return Err(bad("the trail is not finite".into()));
    }
    check_scene(&fig.bars, fig.target, &fig.obstacles).map_err(bad)?;
    let t0 = fig.poses[0].0;
    let t1 = fig.poses[fig.poses.len() - 1].0;
    let span = (t1 - t0).max(1e-12);
    let mut scene = Scene::new(&fig.title, &fig.bars, fig.target, &fig.obstacles);
    scene.legend = true;
    scene.trail = fig.trail.clone();
    for (t, pts) in &fig.poses {
        scene.fit(pts.iter().copied());
        scene
            .poses
            .push((pts.clone(), time_colour((t - t0) / span)));
    }
    scene.time_bar = Some((t0, t1));
    write_static(path, fig.size.unwrap_or((1400, 700)), &scene)
}
