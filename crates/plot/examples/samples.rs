//! Render one sample of every figure type from synthetic data, for looking at them.
//!
//! Usage: `cargo run -p brachia-plot --example samples -- [OUT_DIR]` (default `/tmp/plot-samples`).

#[path = "../tests/support/mod.rs"]
mod support;

use brachia_plot::*;
use std::path::PathBuf;

fn main() -> Result<(), PlotError> {
    let dir = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "/tmp/plot-samples".into()),
    );
    std::fs::create_dir_all(&dir).map_err(|source| PlotError::Io {
        path: dir.clone(),
        source,
    })?;
    let robot = support::paper_robot();
    let desired = support::swing(1.6, 0.01);
    // a "tracked" copy: desired plus a decaying offset
    let mut tracked = desired.clone();
    for k in 0..tracked.len() {
        let t = tracked.t[k];
        for i in 0..4 {
            tracked.q[k * 4 + i] += 0.06 * (-3.0 * t).exp() * (9.0 * t + i as f64).cos();
        }
    }
    let t = desired.t.clone();
    let col = |tr: &brachia::trajectory::Trajectory, f: &dyn Fn(usize) -> f64| -> Vec<f64> {
        (0..tr.len()).map(f).collect()
    };
    let mut panels = vec![
        Panel {
            y_label: "q (rad)".into(),
            series: vec![],
        },
        Panel {
            y_label: "qd (rad/s)".into(),
            series: vec![],
        },
        Panel {
            y_label: "τ (N m)".into(),
            series: vec![],
        },
    ];
    for i in 0..4 {
        let qd = col(&desired, &|k| desired.q(k)[i]);
        let qt = col(&tracked, &|k| tracked.q(k)[i]);
        panels[0].series.push(
            Series::new(format!("q{} desired", i + 1), t.clone(), qd)
                .dashed()
                .colour(i),
        );
        panels[0]
            .series
            .push(Series::new(format!("q{} tracked", i + 1), t.clone(), qt).colour(i));
        let vd = col(&desired, &|k| desired.qd(k)[i]);
        panels[1]
            .series
            .push(Series::new(format!("qd{}", i + 1), t.clone(), vd).colour(i));
    }
    for j in 0..3 {
        let u = col(&desired, &|k| desired.tau(k)[j]);
        panels[2]
            .series
            .push(Series::new(format!("τ{}", j + 2), t.clone(), u).colour(j + 1));
    }
    time_series(
        dir.join("time_series.png"),
        &TimeSeriesFigure {
            title: "Joint trajectories: desired (dashed) vs tracked (solid)".into(),
            x_label: "t (s)".into(),
            panels,
            size: None,
        },
    )?;

    let r2: Vec<f64> = (0..9).map(|k| 0.2 + 0.05 * k as f64).collect();
    let tf: Vec<f64> = r2.iter().map(|r| 0.35 + 0.6 * r * r).collect();
    let tf2: Vec<f64> = r2.iter().map(|r| 0.30 + 0.5 * r).collect();
    line_plot(
        dir.join("line_plot.png"),
        &LinePlot {
            title: "Free-fall time against link-2 length".into(),
            x_label: "r2 (m)".into(),
            y_label: "T_freefall (s)".into(),
            series: vec![
                Series::new("model", r2.clone(), tf),
                Series::new("physics", r2.clone(), tf2).dashed(),
            ],
            size: None,
        },
    )?;

    let ee = |tr: &brachia::trajectory::Trajectory| -> (Vec<f64>, Vec<f64>) {
        (0..tr.len())
            .map(|k| {
                let p = robot.ee_position(tr.q(k));
                (p[0], p[1])
            })
            .unzip()
    };
    let (dx, dy) = ee(&desired);
    let (ax, ay) = ee(&tracked);
    let target = robot.ee_position(&support::Q_END);
    let obstacles = vec![Obstacle {
        center: [0.55, -0.95],
        radius: 0.12,
    }];
    xy_path(
        dir.join("xy_path.png"),
        &XyPathFigure {
            title: "End-effector path".into(),
            paths: vec![
                Series::new("desired", dx, dy).dashed().colour(0),
                Series::new("actual", ax, ay).colour(3),
            ],
            bars: vec![[0.0, 0.0], target],
            target: Some(target),
            obstacles: obstacles.clone(),
            size: None,
        },
    )?;

    let ball: Vec<BallSample> = (0..=16)
        .map(|k| {
            let t = k as f64 * 0.1;
            BallSample {
                t,
                x: -1.2 + 0.9 * t,
                y: -1.3 + 3.0 * t - 0.5 * 9.81 * t * t * 0.5,
                r: 0.05,
            }
        })
        .collect();
    stick_diagram(
        dir.join("stick.png"),
        &robot,
        &desired,
        &StickOptions {
            title: "Swing, every 0.1 s".into(),
            every_s: 0.1,
            bars: vec![[0.0, 0.0], target],
            target: Some(target),
            obstacles: obstacles.clone(),
            balls: vec![ball.clone()],
            size: None,
        },
    )?;

    let xs = vec![0.30, 0.355, 0.40, 0.45];
    let ys = vec![0.35, 0.45, 0.56, 0.70, 0.85];
    let values = (0..ys.len() * xs.len())
        .map(|i| {
            if i == 6 || i == 17 {
                None
            } else {
                Some(1.5 + 0.37 * (i as f64).sqrt())
            }
        })
        .collect();
    heatmap(
        dir.join("heatmap.png"),
        &Heatmap {
            title: "Energy of the swing".into(),
            x_label: "L2 (m)".into(),
            y_label: "m2 (kg)".into(),
            xs,
            ys,
            values,
            colourbar_label: "E (J)".into(),
            size: None,
        },
    )?;

    animate_gif(
        dir.join("swing.gif"),
        &robot,
        &desired,
        &AnimOptions {
            title: "Swing".into(),
            bars: vec![[0.0, 0.0], target],
            target: Some(target),
            obstacles,
            balls: vec![ball],
            ..AnimOptions::default()
        },
    )?;
    Ok(())
}
