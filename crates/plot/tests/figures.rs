//! Every figure function writes a valid, non-blank PNG (+ SVG) or GIF from synthetic data, keeps
//! circles round on spatial plots, and rejects bad data or unwritable paths with an error that names
//! the path and leaves no file behind.

mod support;

use brachia_plot::*;
use std::path::Path;

/// Decoded PNG: (width, height, RGB bytes).
fn read_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let bytes = std::fs::read(path).expect("png exists");
    assert_eq!(
        &bytes[..8],
        b"\x89PNG\r\n\x1a\n",
        "PNG signature of {path:?}"
    );
    let dec = png::Decoder::new(std::io::Cursor::new(bytes));
    let mut reader = dec.read_info().expect("png header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("png data");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// Fraction of pixels that are not white.
fn ink(rgb: &[u8]) -> f64 {
    let n = rgb.len() / 3;
    rgb.chunks_exact(3)
        .filter(|p| p != &[255, 255, 255])
        .count() as f64
        / n as f64
}

/// Number of dark (text-like) pixels in rows `y0..y1`.
fn dark_pixels(w: u32, rgb: &[u8], y0: u32, y1: u32) -> usize {
    let row = w as usize * 3;
    rgb[y0 as usize * row..y1 as usize * row]
        .chunks_exact(3)
        .filter(|p| p.iter().all(|&c| c < 90))
        .count()
}

/// Bounding box (x0, x1, y0, y1) of pixels within `tol` of `colour`.
fn bbox_of(w: u32, rgb: &[u8], colour: [u8; 3], tol: i32) -> Option<(u32, u32, u32, u32)> {
    let mut b: Option<(u32, u32, u32, u32)> = None;
    for (i, p) in rgb.chunks_exact(3).enumerate() {
        if (0..3).all(|c| (p[c] as i32 - colour[c] as i32).abs() <= tol) {
            let (x, y) = (i as u32 % w, i as u32 / w);
            b = Some(match b {
                None => (x, x, y, y),
                Some((a, bb, c, d)) => (a.min(x), bb.max(x), c.min(y), d.max(y)),
            });
        }
    }
    b
}

/// The SVG beside a PNG: starts like an SVG document and contains `needles`.
fn check_svg(png_path: &Path, needles: &[&str]) {
    let svg = std::fs::read_to_string(png_path.with_extension("svg")).expect("svg exists");
    assert!(svg.contains("<svg"), "not an SVG");
    assert!(svg.trim_end().ends_with("</svg>"), "SVG not closed");
    for n in needles {
        assert!(svg.contains(n), "SVG lacks {n:?}");
    }
}

/// Only the named files exist in `dir` (no temporary leftovers).
fn files_in(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

fn three_panels() -> TimeSeriesFigure {
    let tr = support::swing(1.0, 0.01);
    let col = |f: &dyn Fn(usize) -> f64| (0..tr.len()).map(f).collect::<Vec<f64>>();
    let mut panels = Vec::new();
    for (label, pick) in [("q (rad)", 0), ("qd (rad/s)", 1), ("tau (N m)", 2)] {
        let m = if pick == 2 { 3 } else { 4 };
        let mut series = Vec::new();
        for i in 0..m {
            let y = col(&|k| match pick {
                0 => tr.q(k)[i],
                1 => tr.qd(k)[i],
                _ => tr.tau(k)[i],
            });
            let tracked: Vec<f64> = y.iter().map(|v| v + 0.02).collect();
            series.push(
                Series::new(format!("joint {} desired", i + 1), tr.t.clone(), y)
                    .dashed()
                    .colour(i),
            );
            series.push(
                Series::new(format!("joint {} tracked", i + 1), tr.t.clone(), tracked).colour(i),
            );
        }
        panels.push(Panel {
            y_label: label.into(),
            series,
        });
    }
    TimeSeriesFigure {
        title: "Tracking test".into(),
        x_label: "t (s)".into(),
        panels,
        size: Some((900, 800)),
    }
}

#[test]
fn time_series_writes_png_and_svg_with_text() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("ts.png");
    time_series(&p, &three_panels()).unwrap();
    let (w, h, rgb) = read_png(&p);
    assert_eq!((w, h), (900, 800));
    let ink = ink(&rgb);
    assert!(ink > 0.02 && ink < 0.6, "ink fraction {ink}");
    // the title is drawn in the top band
    assert!(dark_pixels(w, &rgb, 0, 35) > 50);
    check_svg(
        &p,
        &[
            "Tracking test",
            "t (s)",
            "q (rad)",
            "tau (N m)",
            "joint 4 tracked",
        ],
    );
    assert_eq!(files_in(dir.path()), vec!["ts.png", "ts.svg"]);
}

#[test]
fn line_plot_draws_markers_and_labels() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("line.png");
    let x: Vec<f64> = (0..6).map(|k| 0.2 + 0.1 * k as f64).collect();
    let y: Vec<f64> = x.iter().map(|r| 0.4 + r * r).collect();
    line_plot(
        &p,
        &LinePlot {
            title: "T vs r2".into(),
            x_label: "r2 (m)".into(),
            y_label: "T_freefall (s)".into(),
            series: vec![Series::new("model", x, y)],
            size: None,
        },
    )
    .unwrap();
    let (w, h, rgb) = read_png(&p);
    assert_eq!((w, h), (900, 600));
    assert!(ink(&rgb) > 0.01);
    let svg = std::fs::read_to_string(p.with_extension("svg")).unwrap();
    // six data markers plus one legend marker, all filled circles
    assert!(
        svg.matches("<circle").count() >= 7,
        "{}",
        svg.matches("<circle").count()
    );
    check_svg(&p, &["r2 (m)", "T_freefall (s)", "model"]);
}

#[test]
fn xy_path_marks_bars_target_and_keeps_circles_round() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("xy.png");
    let robot = support::paper_robot();
    let tr = support::swing(1.0, 0.01);
    let (x, y): (Vec<f64>, Vec<f64>) = (0..tr.len())
        .map(|k| {
            let e = robot.ee_position(tr.q(k));
            (e[0], e[1])
        })
        .unzip();
    let target = robot.ee_position(&support::Q_END);
    xy_path(
        &p,
        &XyPathFigure {
            title: "EE path".into(),
            paths: vec![
                Series::new("desired", x.clone(), y.clone()).dashed(),
                Series::new("actual", x, y),
            ],
            bars: vec![[0.0, 0.0], target],
            target: Some(target),
            obstacles: vec![Obstacle {
                center: [-0.9, 0.4],
                radius: 0.15,
            }],
            // a wide canvas: equal scale must not stretch x
            size: Some((1200, 500)),
        },
    )
    .unwrap();
    let (w, _, rgb) = read_png(&p);
    // the target ring is drawn in its own red
    assert!(bbox_of(w, &rgb, [215, 25, 28], 10).is_some());
    check_svg(
        &p,
        &[
            "x (m)",
            "y (m)",
            "desired",
            "actual",
            "target bar",
            "obstacle",
        ],
    );
}

#[test]
fn stick_diagram_fades_through_time_and_draws_round_balls() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("stick.png");
    let robot = support::paper_robot();
    let tr = support::swing(1.0, 0.01);
    let ball = vec![BallSample {
        t: 0.0,
        x: -1.3,
        y: 0.5,
        r: 0.12,
    }];
    stick_diagram(
        &p,
        &robot,
        &tr,
        &StickOptions {
            title: "stick".into(),
            every_s: 0.25,
            bars: vec![[0.0, 0.0]],
            balls: vec![ball],
            size: Some((1300, 600)),
            ..StickOptions::default()
        },
    )
    .unwrap();
    let (w, _, rgb) = read_png(&p);
    // first and last poses in their time colours
    let c0 = time_colour(0.0);
    let c1 = time_colour(1.0);
    assert!(
        bbox_of(w, &rgb, [c0.0, c0.1, c0.2], 2).is_some(),
        "no start-colour pixels"
    );
    assert!(
        bbox_of(w, &rgb, [c1.0, c1.1, c1.2], 2).is_some(),
        "no end-colour pixels"
    );
    // the stationary ball's fill (orange mixed 35 % over white) is as wide as it is tall
    let (x0, x1, y0, y1) = bbox_of(w, &rgb, [246, 208, 173], 4).expect("ball fill drawn");
    let (bw, bh) = ((x1 - x0) as i32, (y1 - y0) as i32);
    assert!(bw > 20, "ball too small: {bw}");
    assert!(
        (bw - bh).abs() <= 2,
        "ball is {bw} x {bh} pixels: axes not equal"
    );
    check_svg(&p, &["stick", "time (s)", "ball", "bar"]);
}

#[test]
fn heatmap_prints_values_and_marks_failed_cells() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("heat.png");
    let xs = vec![0.3, 0.4, 0.5];
    let ys = vec![1.0, 2.0];
    let values = vec![
        Some(1.25),
        Some(2.5),
        None,
        Some(3.75),
        Some(5.0),
        Some(6.25),
    ];
    heatmap(
        &p,
        &Heatmap {
            title: "energy".into(),
            x_label: "r2 (m)".into(),
            y_label: "m2 (kg)".into(),
            xs,
            ys,
            values,
            colourbar_label: "E (J)".into(),
            size: Some((800, 600)),
        },
    )
    .unwrap();
    let (w, h, rgb) = read_png(&p);
    assert_eq!((w, h), (800, 600));
    // extremes of the colour map appear (lowest and highest cell)
    let lo = value_colour(0.0);
    let hi = value_colour(1.0);
    assert!(bbox_of(w, &rgb, [lo.0, lo.1, lo.2], 1).is_some());
    assert!(bbox_of(w, &rgb, [hi.0, hi.1, hi.2], 1).is_some());
    check_svg(&p, &["1.25", "6.25", "failed", "E (J)", "r2 (m)", "0.4"]);
}

#[test]
fn animate_gif_has_one_frame_per_tick_and_loops() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("anim.gif");
    let robot = support::paper_robot();
    let tr = support::swing(1.0, 0.01);
    let opts = AnimOptions {
        fps: 10.0,
        size: (320, 280),
        bars: vec![[0.0, 0.0]],
        target: Some(robot.ee_position(&support::Q_END)),
        balls: vec![vec![
            BallSample {
                t: 0.0,
                x: -1.0,
                y: 0.3,
                r: 0.05,
            },
            BallSample {
                t: 1.0,
                x: 0.5,
                y: 0.3,
                r: 0.05,
            },
        ]],
        ..AnimOptions::default()
    };
    animate_gif(&p, &robot, &tr, &opts).unwrap();
    let file = std::fs::File::open(&p).unwrap();
    let mut opts_dec = gif::DecodeOptions::new();
    opts_dec.set_color_output(gif::ColorOutput::Indexed);
    let mut dec = opts_dec.read_info(file).unwrap();
    assert_eq!((dec.width(), dec.height()), (320, 280));
    assert_eq!(dec.repeat(), gif::Repeat::Infinite);
    let mut frames = Vec::new();
    while let Some(f) = dec.read_next_frame().unwrap() {
        frames.push((f.delay, f.buffer.to_vec()));
    }
    assert_eq!(frames.len(), frame_times(0.0, 1.0, 10.0).len());
    assert_eq!(frames.len(), 11);
    assert_eq!(frames[0].0, 10); // 1/10 s
    assert_eq!(frames[10].0, 110); // plus the 1 s end pause
    assert_ne!(frames[0].1, frames[10].1, "the robot did not move");
    assert_eq!(files_in(dir.path()), vec!["anim.gif"]);
}

#[test]
fn bad_data_is_an_error_naming_the_path_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.png");
    let mut fig = three_panels();
    fig.panels[1].series[2].y[5] = f64::NAN;
    let e = time_series(&p, &fig).unwrap_err();
    assert!(matches!(e, PlotError::InvalidData { .. }), "{e}");
    assert!(
        e.to_string().contains("bad.png") && e.to_string().contains("index 5"),
        "{e}"
    );

    let empty = TimeSeriesFigure::single("t", "x", "y", vec![Series::new("a", vec![], vec![])]);
    assert!(matches!(
        time_series(&p, &empty),
        Err(PlotError::InvalidData { .. })
    ));
    let ragged = TimeSeriesFigure::single(
        "t",
        "x",
        "y",
        vec![Series::new("a", vec![1.0, 2.0], vec![1.0])],
    );
    assert!(matches!(
        time_series(&p, &ragged),
        Err(PlotError::InvalidData { .. })
    ));
    assert!(matches!(
        time_series(&p, &TimeSeriesFigure::default()),
        Err(PlotError::InvalidData { .. })
    ));
    assert!(matches!(
        line_plot(&p, &LinePlot::default()),
        Err(PlotError::InvalidData { .. })
    ));
    assert!(matches!(
        xy_path(&p, &XyPathFigure::default()),
        Err(PlotError::InvalidData { .. })
    ));

    let mut hm = Heatmap {
        xs: vec![1.0, 2.0],
        ys: vec![1.0],
        values: vec![Some(1.0), Some(f64::NAN)],
        ..Heatmap::default()
    };
    assert!(matches!(
        heatmap(&p, &hm),
        Err(PlotError::InvalidData { .. })
    ));
    hm.values.pop();
    assert!(matches!(
        heatmap(&p, &hm),
        Err(PlotError::InvalidData { .. })
    ));

    let robot = support::paper_robot();
    let mut tr = support::swing(0.5, 0.05);
    let zero_step = StickOptions {
        every_s: 0.0,
        ..StickOptions::default()
    };
    assert!(matches!(
        stick_diagram(&p, &robot, &tr, &zero_step),
        Err(PlotError::InvalidData { .. })
    ));
    let g = dir.path().join("bad.gif");
    let no_fps = AnimOptions {
        fps: 0.0,
        ..AnimOptions::default()
    };
    assert!(matches!(
        animate_gif(&g, &robot, &tr, &no_fps),
        Err(PlotError::InvalidData { .. })
    ));
    tr.q[7] = f64::INFINITY;
    assert!(matches!(
        stick_diagram(&p, &robot, &tr, &StickOptions::default()),
        Err(PlotError::InvalidData { .. })
    ));
    assert!(matches!(
        animate_gif(&g, &robot, &tr, &AnimOptions::default()),
        Err(PlotError::InvalidData { .. })
    ));
    let three_links = brachia::trajectory::Trajectory::new(3);
    assert!(matches!(
        stick_diagram(&p, &robot, &three_links, &StickOptions::default()),
        Err(PlotError::InvalidData { .. })
    ));
    // wrong extensions
    let good = support::swing(0.5, 0.05);
    assert!(matches!(
        animate_gif(
            dir.path().join("a.png"),
            &robot,
            &good,
            &AnimOptions::default()
        ),
        Err(PlotError::InvalidPath { .. })
    ));
    assert!(matches!(
        time_series(dir.path().join("a.svg"), &three_panels()),
        Err(PlotError::InvalidPath { .. })
    ));
    assert!(
        files_in(dir.path()).is_empty(),
        "{:?}",
        files_in(dir.path())
    );
}

#[test]
fn unwritable_paths_fail_without_leftovers() {
    let dir = tempfile::tempdir().unwrap();
    // parent folder missing
    let p = dir.path().join("missing").join("fig.png");
    let e = time_series(&p, &three_panels()).unwrap_err();
    assert!(matches!(e, PlotError::Io { .. }), "{e}");
    assert!(e.to_string().contains("fig.png"), "{e}");
    assert_eq!(e.path(), p.as_path());

    // the target name is taken by a folder: the rename fails, temporaries are removed
    let taken = dir.path().join("taken.png");
    std::fs::create_dir(&taken).unwrap();
    let e = time_series(&taken, &three_panels()).unwrap_err();
    assert!(matches!(e, PlotError::Io { .. }), "{e}");
    let robot = support::paper_robot();
    let tr = support::swing(0.3, 0.05);
    let taken_gif = dir.path().join("taken.gif");
    std::fs::create_dir(&taken_gif).unwrap();
    let e = animate_gif(&taken_gif, &robot, &tr, &AnimOptions::default()).unwrap_err();
    assert!(matches!(e, PlotError::Io { .. }), "{e}");
    assert_eq!(files_in(dir.path()), vec!["taken.gif", "taken.png"]);
    assert!(files_in(&taken).is_empty());
}

#[test]
fn one_pose_and_constant_data_still_draw() {
    // degenerate but valid input: a single-sample trajectory, constant curves, one heat-map cell
    let dir = tempfile::tempdir().unwrap();
    let robot = support::paper_robot();
    let mut tr = brachia::trajectory::Trajectory::new(4);
    tr.push(0.0, &support::Q_START, &[0.0; 4], &[0.0; 3]);
    stick_diagram(
        dir.path().join("one.png"),
        &robot,
        &tr,
        &StickOptions::default(),
    )
    .unwrap();
    animate_gif(
        dir.path().join("one.gif"),
        &robot,
        &tr,
        &AnimOptions::default(),
    )
    .unwrap();
    let flat = TimeSeriesFigure::single(
        "flat",
        "t (s)",
        "y (m)",
        vec![Series::new("c", vec![0.0, 1.0], vec![2.0, 2.0])],
    );
    time_series(dir.path().join("flat.png"), &flat).unwrap();
    let point = TimeSeriesFigure::single(
        "pt",
        "t (s)",
        "y (m)",
        vec![Series::new("c", vec![1.0], vec![1.0])],
    );
    time_series(dir.path().join("pt.png"), &point).unwrap();
    heatmap(
        dir.path().join("cell.png"),
        &Heatmap {
            xs: vec![1.0],
            ys: vec![1.0],
            values: vec![None],
            ..Heatmap::default()
        },
    )
    .unwrap();
    assert_eq!(read_png(&dir.path().join("cell.png")).0, 1000);
}
