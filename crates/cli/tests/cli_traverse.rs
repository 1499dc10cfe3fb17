//! `brachia traverse` as a user runs it: a short even ladder for the 3-link robot (coarse knots, a few
//! seconds in release) writes its staged run folder; a bar out of reach is exit 2 with nothing written.
//!
//! Conventions: world frame, m; SI units.

mod common;

use common::{brachia, report, root};

fn scenario(dir: &std::path::Path, bars: &str) -> std::path::PathBuf {
    let p = dir.join("ladder.toml");
    let params = root().join("params/three-link.toml");
    std::fs::write(
        &p,
        format!(
            "params = {:?}\n[ladder]\nbars = [{bars}]\n[planner]\nknot_dt = 0.04\n",
            params.display().to_string()
        ),
    )
    .unwrap();
    p
}

#[test]
fn traverse_writes_the_run_folder_of_a_short_ladder() {
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(
        dir.path(),
        "{ x = 0.0, y = 0.0 }, { x = 0.8, y = 0.0 }, { x = 1.6, y = 0.1 }",
    );
    let out = dir.path().join("run");
    let o = brachia()
        .args(["traverse", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for f in [
        "traverse.csv",
        "report.json",
        "scenario.toml",
        "traverse_stick.png",
        "traverse_stick.svg",
        "energy_per_swing.png",
        "energy_per_swing.svg",
        "traverse.gif",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    let gif = std::fs::read(out.join("traverse.gif")).unwrap();
    assert!(gif.starts_with(b"GIF89a"), "traverse.gif is a GIF");
    let r = report(&out);
    assert_eq!(r["completed"], true);
    assert_eq!(r["swings"].as_array().unwrap().len(), 2);
    for s in r["swings"].as_array().unwrap() {
        for key in [
            "energy_j",
            "positive_work_j",
            "duration_s",
            "capture_error_m",
            "switch_residual_m_s",
        ] {
            assert!(s[key].as_f64().is_some(), "swing lacks {key}: {s}");
        }
    }
    let csv = std::fs::read_to_string(out.join("traverse.csv")).unwrap();
    let csv = csv
        .strip_prefix("# brachia traverse schema 1\n")
        .expect("the schema line");
    let header = csv.lines().next().unwrap();
    assert!(header.starts_with("t,q1,q2,q3,qd1,qd2,qd3,tau2,tau3,ee_x,ee_y,swing,holding_hand"));
    // no staging folder is left next to the run folder
    let left: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains("partial"))
        .collect();
    assert!(left.is_empty());
}

#[test]
fn a_bar_out_of_reach_is_exit_2_and_nothing_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let sc = scenario(
        dir.path(),
        "{ x = 0.0, y = 0.0 }, { x = 0.8, y = 0.0 }, { x = 2.5, y = 0.0 }",
    );
    let out = dir.path().join("run");
    let o = brachia()
        .args(["traverse", "--scenario"])
        .arg(&sc)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("ladder.bars[2]") && err.contains("out of reach"),
        "{err}"
    );
    assert!(!out.exists());
}
