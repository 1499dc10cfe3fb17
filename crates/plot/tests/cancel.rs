//! An animation stops once its cancel token is set: checked before every frame, it returns
//! `PlotError::Cancelled` naming the file and leaves nothing behind (no GIF, no temporary file).

mod support;

use brachia::CancelToken;
use brachia_plot::{animate_gif, animate_poses_gif, AnimOptions, PlotError, MAX_FRAMES};
use std::path::Path;

fn entries(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect()
}

fn assert_cancelled(r: Result<(), PlotError>, path: &Path) {
    match r {
        Err(PlotError::Cancelled { path: p }) => assert_eq!(p, path),
        other => panic!("expected Cancelled, got {other:?}"),
    }
    assert!(entries(path.parent().unwrap()).is_empty());
}

#[test]
fn a_token_set_before_the_first_frame_draws_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("anim.gif");
    let cancel = CancelToken::new();
    cancel.cancel();
    let opts = AnimOptions {
        size: (160, 140),
        cancel: Some(cancel),
        ..AnimOptions::default()
    };
    let r = animate_gif(
        &p,
        &support::paper_robot(),
        &support::swing(1.0, 0.01),
        &opts,
    );
    assert_cancelled(r, &p);
    let poses = vec![(0.0, vec![[0.0, 0.0], [0.1, -0.2]]); 3];
    let hands = vec![[0.1, -0.2]; 3];
    assert_cancelled(animate_poses_gif(&p, &poses, &hands, &opts), &p);
}

#[test]
fn a_token_set_from_another_thread_stops_a_long_animation() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("long.gif");
    let cancel = CancelToken::new();
    // the longest animation allowed at full size: far more frames than are drawn before the token is set
    let duration = (MAX_FRAMES - 1) as f64 / 25.0;
    let opts = AnimOptions {
        cancel: Some(cancel.clone()),
        ..AnimOptions::default()
    };
    let traj = support::swing(duration, 0.01);
    let robot = support::paper_robot();
    let setter = std::thread::spawn(move || {
        std::thread::sleep(std::time::Duration::from_millis(100));
        cancel.cancel();
    });
    let r = animate_gif(&p, &robot, &traj, &opts);
    setter.join().unwrap();
    assert_cancelled(r, &p);
}

#[test]
fn an_unset_token_changes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let (a, b) = (dir.path().join("a.gif"), dir.path().join("b.gif"));
    let robot = support::paper_robot();
    let traj = support::swing(0.5, 0.01);
    let plain = AnimOptions {
        size: (160, 140),
        ..AnimOptions::default()
    };
    let with_token = AnimOptions {
        cancel: Some(CancelToken::new()),
        ..plain.clone()
    };
    animate_gif(&a, &robot, &traj, &plain).unwrap();
    animate_gif(&b, &robot, &traj, &with_token).unwrap();
    assert_eq!(std::fs::read(&a).unwrap(), std::fs::read(&b).unwrap());
}
