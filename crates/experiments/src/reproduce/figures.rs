//! The reproduction's figures (paper Figs. 3-8) and animations, drawn with `brachia-plot` from the runs'
//! data. Nothing here simulates: every function reads a finished run.
//!
//! Conventions: SI units (s, m, rad, rad/s, N m, J); the grip bar at the origin, y up. Each static figure
//! is a PNG with an SVG beside it; animations are GIFs.

use crate::track_folder::TrackFolder;
use crate::track_run::PlantWorld;
use crate::CancelToken;
use brachia::trajectory::Trajectory;
use brachia::Robot;
use brachia_plot::{
    animate_gif, stick_diagram, time_series, xy_path, AnimOptions, BallSample, Obstacle, Panel,
    PlotError, Series, StickOptions, TimeSeriesFigure, XyPathFigure,
};
use brachia_rapier::Obstacle as WorldObstacle;
use std::path::{Path, PathBuf};

/// Time between the poses of a stick diagram, s.
const STICK_EVERY_S: f64 = 0.1;

/// Figure paths are `dir/<name>.png` (+ `.svg`) and `dir/<name>.gif`.
pub(crate) struct FigureDir {
    dir: PathBuf,
    /// Every figure file asked for (`dir/<name>.png` or `.gif`; the caller drops those not written).
    pub written: Vec<PathBuf>,
    /// Once set, no further figure is drawn (see [`FigureDir::path`]).
    cancel: CancelToken,
}

impl FigureDir {
    pub(crate) fn new(dir: &Path, cancel: &CancelToken) -> Self {
        FigureDir {
            dir: dir.to_path_buf(),
            written: Vec::new(),
            cancel: cancel.clone(),
        }
    }

    /// `dir/<name>.<ext>`; once the cancel token is set, a path the plotting refuses by its extension
    /// before it draws anything, so the figures left are skipped at once (the caller then discards
    /// the whole drawing).
    fn path(&mut self, name: &str, ext: &str) -> PathBuf {
        if self.cancel.is_cancelled() {
            return self.dir.join(format!("{name}.{ext}.cancelled"));
        }
        let p = self.dir.join(format!("{name}.{ext}"));
        self.written.push(p.clone());
        p
    }

    pub(crate) fn png(&mut self, name: &str) -> PathBuf {
        self.path(name, "png")
    }

    pub(crate) fn gif(&mut self, name: &str) -> PathBuf {
        self.path(name, "gif")
    }

    /// The cancel token, for the animations to check before every frame.
    fn cancel(&self) -> Option<CancelToken> {
        Some(self.cancel.clone())
    }
}

/// The static obstacles a planner knew, for drawing.
fn task_obstacles(circles: &[brachia::model::Circle]) -> Vec<Obstacle> {
    circles
        .iter()
        .map(|c| Obstacle {
            center: c.center,
            radius: c.radius,
        })
        .collect()
}

/// The fixed circles of a plant's world (drawn as obstacles) and its balls' tracks (drawn moving).
fn world_drawing(world: &PlantWorld) -> (Vec<Obstacle>, Vec<Vec<BallSample>>) {
    let mut fixed = Vec::new();
    let mut balls = Vec::new();
    for (id, o) in world.obstacles.iter().enumerate() {
        match o {
            WorldObstacle::Circle(c) => fixed.push(Obstacle {
                center: c.center,
                radius: c.radius,
            }),
            WorldObstacle::Ball(b) => balls.push(
                world
                    .track
                    .iter()
                    .map(|row| BallSample {
                        t: row[0],
                        x: row[1 + 2 * id],
                        y: row[2 + 2 * id],
                        r: b.radius,
                    })
                    .collect(),
            ),
        }
    }
    (fixed, balls)
}

fn stick_options(title: &str, target: [f64; 2], obstacles: Vec<Obstacle>) -> StickOptions {
    StickOptions {
        title: title.into(),
        every_s: STICK_EVERY_S,
        bars: vec![[0.0, 0.0]],
        target: Some(target),
        obstacles,
        ..StickOptions::default()
    }
}

fn anim_options(
    title: &str,
    target: [f64; 2],
    obstacles: Vec<Obstacle>,
    balls: Vec<Vec<BallSample>>,
    cancel: Option<CancelToken>,
) -> AnimOptions {
    AnimOptions {
        title: title.into(),
        bars: vec![[0.0, 0.0]],
        target: Some(target),
        obstacles,
        balls,
        cancel,
        ..AnimOptions::default()
    }
}

/// Column `i` of a flat row-major array with rows of `width`.
fn column(flat: &[f64], width: usize, i: usize) -> Vec<f64> {
    flat.chunks_exact(width).map(|r| r[i]).collect()
}

/// Fig. 5: joint positions, velocities and torques, desired (dashed) vs tracked (solid).
pub(crate) fn joint_tracking(
    figs: &mut FigureDir,
    name: &str,
    title: &str,
    run: &TrackFolder,
) -> Result<(), PlotError> {
    let log = &run.log;
    let n = log.n;
    let t = log.t.clone();
    let empty = Trajectory::new(n);
    let r = run.plan.as_ref().map_or(&empty, |p| &p.trajectory);
    let mut q = Vec::new();
    let mut qd = Vec::new();
    for i in 0..n {
        q.push(
            Series::new(
                format!("q{} desired", i + 1),
                t.clone(),
                column(&log.ref_x, 2 * n, i),
            )
            .dashed()
            .colour(i),
        );
        q.push(
            Series::new(
                format!("q{} MPC", i + 1),
                t.clone(),
                column(&log.x, 2 * n, i),
            )
            .colour(i),
        );
        qd.push(
            Series::new(
                format!("qd{} desired", i + 1),
                t.clone(),
                column(&log.ref_x, 2 * n, n + i),
            )
            .dashed()
            .colour(i),
        );
        qd.push(
            Series::new(
                format!("qd{} MPC", i + 1),
                t.clone(),
                column(&log.x, 2 * n, n + i),
            )
            .colour(i),
        );
    }
    let mut tau = Vec::new();
    for j in 0..n - 1 {
        // the planned torque, when the run folder holds its plan
        if !r.t.is_empty() {
            tau.push(
                Series::new(
                    format!("tau{} desired", j + 2),
                    r.t.clone(),
                    column(&r.tau, n - 1, j),
                )
                .dashed()
                .colour(j + 1),
            );
        }
        tau.push(
            Series::new(
                format!("tau{} MPC", j + 2),
                t.clone(),
                column(&log.tau, n - 1, j),
            )
            .colour(j + 1),
        );
    }
    time_series(
        figs.png(name),
        &TimeSeriesFigure {
            title: title.into(),
            x_label: "t (s)".into(),
            panels: vec![
                Panel {
                    y_label: "joint angle q (rad)".into(),
                    series: q,
                },
                Panel {
                    y_label: "joint velocity qd (rad/s)".into(),
                    series: qd,
                },
                Panel {
                    y_label: "joint torque tau (N m)".into(),
                    series: tau,
                },
            ],
            size: None,
        },
    )
}

/// A stick diagram of a tracked run (with the plant's obstacles and balls).
pub(crate) fn tracked_stick(
    figs: &mut FigureDir,
    name: &str,
    title: &str,
    robot: &Robot,
    run: &TrackFolder,
    target: [f64; 2],
) -> Result<(), PlotError> {
    let (fixed, balls) = world_drawing(&run.world);
    let mut o = stick_options(title, target, fixed);
    o.balls = balls;
    stick_diagram(figs.png(name), robot, &run.log.trajectory(), &o)
}

/// A stick diagram of a plan.
pub(crate) fn planned_stick(
    figs: &mut FigureDir,
    name: &str,
    title: &str,
    robot: &Robot,
    traj: &Trajectory,
    target: [f64; 2],
    obstacles: &[brachia::model::Circle],
) -> Result<(), PlotError> {
    stick_diagram(
        figs.png(name),
        robot,
        traj,
        &stick_options(title, target, task_obstacles(obstacles)),
    )
}

/// Fig. 6b: EE path, desired vs tracked, in the plane.
pub(crate) fn ee_path(
    figs: &mut FigureDir,
    name: &str,
    title: &str,
    runs: &[(&str, &TrackFolder)],
    target: [f64; 2],
) -> Result<(), PlotError> {
    let Some((_, first)) = runs.first() else {
        return Ok(());
    };
    let xs = |ee: &[[f64; 2]], c: usize| ee.iter().map(|p| p[c]).collect::<Vec<_>>();
    let mut paths = vec![Series::new(
        "desired",
        xs(&first.log.ref_ee, 0),
        xs(&first.log.ref_ee, 1),
    )
    .dashed()
    .colour(0)];
    for (i, (label, r)) in runs.iter().enumerate() {
        paths.push(Series::new(*label, xs(&r.log.ee, 0), xs(&r.log.ee, 1)).colour(i + 1));
    }
    let (obstacles, _) = world_drawing(&first.world);
    xy_path(
        figs.png(name),
        &XyPathFigure {
            title: title.into(),
            paths,
            bars: vec![[0.0, 0.0]],
            target: Some(target),
            obstacles,
            size: None,
        },
    )
}

/// Fig. 6b / 8b: EE error over time (x, y components and distance) of one or more runs.
pub(crate) fn ee_error(
    figs: &mut FigureDir,
    name: &str,
    title: &str,
    runs: &[(&str, &TrackFolder)],
    contact_s: Option<f64>,
) -> Result<(), PlotError> {
    let mut ex = Vec::new();
    let mut ey = Vec::new();
    let mut dist = Vec::new();
    for (i, (label, r)) in runs.iter().enumerate() {
        let l = &r.log;
        let e: Vec<[f64; 2]> =
            l.ee.iter()
                .zip(&l.ref_ee)
                .map(|(a, b)| [a[0] - b[0], a[1] - b[1]])
                .collect();
        ex.push(Series::new(*label, l.t.clone(), e.iter().map(|v| v[0]).collect()).colour(i));
        ey.push(Series::new(*label, l.t.clone(), e.iter().map(|v| v[1]).collect()).colour(i));
        dist.push(
            Series::new(
                *label,
                l.t.clone(),
                e.iter().map(|v| v[0].hypot(v[1])).collect(),
            )
            .colour(i),
        );
    }
    if let Some(tc) = contact_s {
        // a vertical marker at the first contact, spanning the distance panel
        let top = dist
            .iter()
            .flat_map(|s| s.y.iter().copied())
            .fold(0.0, f64::max);
        dist.push(
            Series::new(
                format!("first contact {tc:.3} s"),
                vec![tc, tc],
                vec![0.0, top.max(1e-3)],
            )
            .dashed()
            .colour(9),
        );
    }
    time_series(
        figs.png(name),
        &TimeSeriesFigure {
            title: title.into(),
            x_label: "t (s)".into(),
            panels: vec![
                Panel {
                    y_label: "EE error x (m)".into(),
                    series: ex,
                },
                Panel {
                    y_label: "EE error y (m)".into(),
                    series: ey,
                },
                Panel {
                    y_label: "EE distance to reference (m)".into(),
                    series: dist,
                },
            ],
            size: None,
        },
    )
}

/// An animation of a tracked run (stick figure, bar, target, obstacles, balls, time stamp).
pub(crate) fn tracked_gif(
    figs: &mut FigureDir,
    name: &str,
    title: &str,
    robot: &Robot,
    run: &TrackFolder,
    target: [f64; 2],
) -> Result<(), PlotError> {
    let (fixed, balls) = world_drawing(&run.world);
    let opts = anim_options(title, target, fixed, balls, figs.cancel());
    animate_gif(figs.gif(name), robot, &run.log.trajectory(), &opts)
}

/// An animation of a plan.
pub(crate) fn planned_gif(
    figs: &mut FigureDir,
    name: &str,
    title: &str,
    robot: &Robot,
    traj: &Trajectory,
    target: [f64; 2],
    obstacles: &[brachia::model::Circle],
) -> Result<(), PlotError> {
    let opts = anim_options(
        title,
        target,
        task_obstacles(obstacles),
        Vec::new(),
        figs.cancel(),
    );
    animate_gif(figs.gif(name), robot, traj, &opts)
}
