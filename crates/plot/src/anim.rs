//! Animated GIF of a trajectory: the stick figure, bars, target, obstacles, balls and a time stamp,
//! one frame every `1/fps` seconds, looping forever.
//!
//! Frames are drawn with the same scene code as the stick diagram into an RGB buffer, mapped onto a
//! fixed 256-colour palette (a 6x6x6 colour cube plus 40 greys, so colours do not flicker between
//! frames) and encoded with the `gif` crate.

use crate::error::PlotError;
use crate::output::{check_extension, render_rgb, write_atomic};
use crate::spatial::{
    all_joint_points, ball_at, ball_extent, check_balls, check_scene, check_trajectory, ee_trail,
    pose_at, BallSample, Obstacle, Scene,
};
use brachia::trajectory::Trajectory;
use brachia::{CancelToken, Robot};
use plotters::style::RGBColor;
use std::path::Path;

/// Options of [`animate_gif`].
#[derive(Debug, Clone, PartialEq)]
pub struct AnimOptions {
    /// Frames per second (0 < fps <= 100). GIF delays are whole hundredths of a second, so the
    /// played rate is `100 / round(100 / fps)`. Default 25.
    pub fps: f64,
    /// Frame size in pixels (width, height), each 64..=2000. Default 640 x 560.
    pub size: (u32, u32),
    /// Title drawn above the plot ("" for none).
    pub title: String,
    /// Bar positions `[x, y]`, m.
    pub bars: Vec<[f64; 2]>,
    /// The target bar `[x, y]`, m.
    pub target: Option<[f64; 2]>,
    /// Obstacles.
    pub obstacles: Vec<Obstacle>,
    /// Moving balls: each inner vector is one ball's track ordered by time (interpolated linearly,
    /// held at its ends).
    pub balls: Vec<Vec<BallSample>>,
    /// Draw the end-effector path travelled so far. Default true.
    pub trail: bool,
    /// Extra time the last frame stays on screen before the loop restarts, s (>= 0). Default 1.
    pub end_pause_s: f64,
    /// Checked before every frame: once it is set the animation stops with
    /// [`PlotError::Cancelled`] and nothing is written. Default `None` (never stopped).
    pub cancel: Option<CancelToken>,
}

impl Default for AnimOptions {
    fn default() -> Self {
        AnimOptions {
            fps: 25.0,
            size: (640, 560),
            title: String::new(),
            bars: Vec::new(),
            target: None,
            obstacles: Vec::new(),
            balls: Vec::new(),
            trail: true,
            end_pause_s: 1.0,
            cancel: None,
        }
    }
}

/// Largest number of frames one animation may have.
pub const MAX_FRAMES: usize = 3000;

/// Times of the frames of a trajectory from `t0` to `t1` at `fps`: `t0 + k / fps` for
/// `k = 0..=ceil((t1 - t0) fps)`, the last clamped to `t1` (so the final pose is always shown).
pub fn frame_times(t0: f64, t1: f64, fps: f64) -> Vec<f64> {
    let k_max = ((t1 - t0) * fps - 1e-9).ceil().max(0.0) as usize;
    (0..=k_max).map(|k| (t0 + k as f64 / fps).min(t1)).collect()
}

/// Write an animated GIF of `traj` to `path` (must end in `.gif`), looping forever.
///
/// Errors: [`PlotError::InvalidData`] for a bad trajectory (as [`crate::stick_diagram`]), fps or size
/// out of range, more than [`MAX_FRAMES`] frames; [`PlotError::Cancelled`] once `opts.cancel` is set
/// (checked before every frame); I/O errors name the file.
pub fn animate_gif(
    path: impl AsRef<Path>,
    robot: &Robot,
    traj: &Trajectory,
    opts: &AnimOptions,
) -> Result<(), PlotError> {
    let path = path.as_ref();
    check_extension(path, "gif")?;
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    check_trajectory(robot, traj).map_err(bad)?;
    check_scene(&opts.bars, opts.target, &opts.obstacles).map_err(bad)?;
    check_balls(&opts.balls).map_err(bad)?;
    check_options(opts).map_err(bad)?;
    let (t0, t1) = (traj.t[0], traj.t[traj.len() - 1]);
    if (t1 - t0) * opts.fps > MAX_FRAMES as f64 {
        return Err(bad(format!(
            "{} s at {} fps exceeds {MAX_FRAMES} frames",
            t1 - t0,
            opts.fps
        )));
    }
    let times = frame_times(t0, t1, opts.fps);

    // one view for all frames
    let mut base = Scene::new(&opts.title, &opts.bars, opts.target, &opts.obstacles);
    base.fit(all_joint_points(robot, traj));
    base.fit(ball_extent(&opts.balls));
    let frames = times.iter().map(|&t| Frame {
        t,
        joints: pose_at(robot, traj, t),
        trail: if opts.trail {
            ee_trail(robot, traj, t)
        } else {
            Vec::new()
        },
    });
    encode_frames(path, base.bounds, t0, opts, frames)
}

/// One frame of [`encode_frames`]: its time, the joint positions, the trail so far (world, m).
struct Frame {
    t: f64,
    joints: Vec<[f64; 2]>,
    trail: Vec<[f64; 2]>,
}

/// Draw every frame into the shared view `bounds` and encode the looping GIF (time stamps from `t0`).
fn encode_frames(
    path: &Path,
    bounds: Option<(f64, f64, f64, f64)>,
    t0: f64,
    opts: &AnimOptions,
    frames: impl ExactSizeIterator<Item = Frame>,
) -> Result<(), PlotError> {
    let (w, h) = opts.size;
    let palette = palette();
    let encode_err = |e: gif::EncodingError| PlotError::Encode {
        path: path.to_path_buf(),
        message: e.to_string(),
    };
    let count = frames.len();
    let mut bytes = Vec::new();
    {
        let mut enc =
            gif::Encoder::new(&mut bytes, w as u16, h as u16, &palette).map_err(encode_err)?;
        enc.set_repeat(gif::Repeat::Infinite).map_err(encode_err)?;
        let delay = (100.0 / opts.fps).round().max(1.0) as u16;
        let pause = (opts.end_pause_s * 100.0).round().min(60000.0) as u16;
        let mut indices = vec![0u8; w as usize * h as usize];
        for (fi, fr) in frames.enumerate() {
            if opts.cancel.as_ref().is_some_and(CancelToken::is_cancelled) {
                return Err(PlotError::Cancelled {
                    path: path.to_path_buf(),
                });
            }
            let mut scene = Scene::new(&opts.title, &opts.bars, opts.target, &opts.obstacles);
            scene.bounds = bounds;
            scene.trail = fr.trail;
            scene.poses.push((fr.joints, ROBOT_COLOUR));
            for track in &opts.balls {
                if let Some(b) = ball_at(track, fr.t) {
                    scene.balls.push((b, RGBColor(180, 80, 0)));
                }
            }
            scene.stamp = Some(format!("t = {} s", format_stamp(fr.t - t0)));
            let rgb = render_rgb((w, h), &scene).map_err(|message| PlotError::Render {
                path: path.to_path_buf(),
                message,
            })?;
            for (i, px) in rgb.chunks_exact(3).enumerate() {
                indices[i] = palette_index(px[0], px[1], px[2]);
            }
            let last = fi + 1 == count;
            let frame = gif::Frame {
                width: w as u16,
                height: h as u16,
                delay: if last {
                    delay.saturating_add(pause)
                } else {
                    delay
                },
                buffer: std::borrow::Cow::Borrowed(&indices),
                ..gif::Frame::default()
            };
            enc.write_frame(&frame).map_err(encode_err)?;
        }
        enc.into_inner().map_err(encode_err)?;
    }
    write_atomic(&[(path, bytes.as_slice())])
}

/// Write an animated GIF of poses given in the world (`path` must end in `.gif`), looping forever:
/// one frame per entry of `poses` (time s, joint positions m, in drawing order; the times ascending),
/// with the trail of `hands` (one point per pose: the swinging hand, world) drawn up to each frame. For
/// motions that no single [`Trajectory`] describes, e.g. a ladder traverse whose grip changes.
/// `opts.fps` sets each frame's delay (the poses should be sampled at that rate); `opts.trail` switches
/// the trail.
///
/// Errors: [`PlotError::InvalidData`] for no poses, non-finite points, `hands` of another length,
/// times not ascending, more than [`MAX_FRAMES`] poses, fps or size out of range.
pub fn animate_poses_gif(
    path: impl AsRef<Path>,
    poses: &[(f64, Vec<[f64; 2]>)],
    hands: &[[f64; 2]],
    opts: &AnimOptions,
) -> Result<(), PlotError> {
    let path = path.as_ref();
    check_extension(path, "gif")?;
    let bad = |reason: String| PlotError::InvalidData {
        path: path.to_path_buf(),
        reason,
    };
    check_options(opts).map_err(bad)?;
    check_scene(&opts.bars, opts.target, &opts.obstacles).map_err(bad)?;
    check_balls(&opts.balls).map_err(bad)?;
    if poses.is_empty() || poses.len() > MAX_FRAMES {
        return Err(bad(format!(
            "{} poses: need 1 to {MAX_FRAMES}",
            poses.len()
        )));
    }
    if hands.len() != poses.len() {
        return Err(bad(format!(
            "{} hand points for {} poses",
            hands.len(),
            poses.len()
        )));
    }
    let finite = |p: &[f64; 2]| p[0].is_finite() && p[1].is_finite();
    if let Some((t, _)) = poses
        .iter()
        .find(|(t, j)| !t.is_finite() || j.is_empty() || !j.iter().all(finite))
    {
        return Err(bad(format!("the pose at t = {t} is empty or not finite")));
    }
    if !hands.iter().all(finite) {
        return Err(bad("a hand point is not finite".into()));
    }
    if poses.windows(2).any(|w| w[1].0 < w[0].0) {
        return Err(bad("pose times must ascend".into()));
    }
    let mut base = Scene::new(&opts.title, &opts.bars, opts.target, &opts.obstacles);
    base.fit(poses.iter().flat_map(|(_, j)| j.iter().copied()));
    base.fit(ball_extent(&opts.balls));
    let frames = poses.iter().enumerate().map(|(i, (t, j))| Frame {
        t: *t,
        joints: j.clone(),
        trail: if opts.trail {
            hands[..=i].to_vec()
        } else {
            Vec::new()
        },
    });
    encode_frames(path, base.bounds, poses[0].0, opts, frames)
}

/// Check fps, the end pause and the frame size of `opts`.
fn check_options(opts: &AnimOptions) -> Result<(), String> {
    if !(opts.fps.is_finite() && opts.fps > 0.0 && opts.fps <= 100.0) {
        return Err(format!("fps must be in (0, 100], got {}", opts.fps));
    }
    if !(opts.end_pause_s.is_finite() && opts.end_pause_s >= 0.0) {
        return Err(format!(
            "end_pause_s must be >= 0, got {}",
            opts.end_pause_s
        ));
    }
    let (w, h) = opts.size;
    if !(64..=2000).contains(&w) || !(64..=2000).contains(&h) {
        return Err(format!("frame size {w} x {h} outside 64..=2000 pixels"));
    }
    Ok(())
}

/// Colour of the robot in animation frames.
const ROBOT_COLOUR: RGBColor = RGBColor(20, 50, 140);

/// Time stamp with two decimals.
fn format_stamp(t: f64) -> String {
    format!("{t:.2}")
}

/// The fixed palette: 216 cube colours (levels 0, 51, ..., 255) then 40 greys, as RGB bytes.
fn palette() -> Vec<u8> {
    let mut p = Vec::with_capacity(768);
    for r in 0..6u8 {
        for g in 0..6u8 {
            for b in 0..6u8 {
                p.extend_from_slice(&[r * 51, g * 51, b * 51]);
            }
        }
    }
    for k in 0..40u32 {
        let v = (k * 255 / 39) as u8;
        p.extend_from_slice(&[v, v, v]);
    }
    p
}

/// Palette index of an RGB colour: a grey from the grey ramp when the channels are close, else the
/// nearest cube colour.
fn palette_index(r: u8, g: u8, b: u8) -> u8 {
    let (mx, mn) = (r.max(g).max(b), r.min(g).min(b));
    if mx - mn <= 16 {
        let l = (r as u32 + g as u32 + b as u32) / 3;
        return 216 + ((l * 39 + 127) / 255) as u8;
    }
    let q = |c: u8| (c as u32 + 25) / 51;
    (q(r) * 36 + q(g) * 6 + q(b)) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_times_cover_the_trajectory() {
        let t = frame_times(0.0, 1.0, 10.0);
        assert_eq!(t.len(), 11);
        assert_eq!(t[10], 1.0);
        let t = frame_times(0.5, 1.53, 25.0);
        assert_eq!(t.len(), 27); // ceil(1.03 * 25) + 1
        assert!((t[1] - 0.54).abs() < 1e-12);
        assert_eq!(*t.last().unwrap(), 1.53);
        assert_eq!(frame_times(2.0, 2.0, 25.0), vec![2.0]);
    }

    #[test]
    fn palette_maps_colours_to_nearby_entries() {
        let p = palette();
        assert_eq!(p.len(), 768);
        for &(r, g, b) in &[
            (255, 255, 255),
            (0, 0, 0),
            (20, 50, 140),
            (215, 25, 28),
            (128, 128, 128),
            (175, 205, 235),
        ] {
            let i = palette_index(r, g, b) as usize;
            let (pr, pg, pb) = (p[3 * i], p[3 * i + 1], p[3 * i + 2]);
            let d = (pr as i32 - r as i32)
                .abs()
                .max((pg as i32 - g as i32).abs())
                .max((pb as i32 - b as i32).abs());
            assert!(d <= 26, "({r},{g},{b}) -> ({pr},{pg},{pb})");
        }
        assert_eq!(palette_index(255, 255, 255) as usize, 255);
    }
}
