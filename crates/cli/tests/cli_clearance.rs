//! A plan folder whose trajectory passes through an obstacle the scenario avoids is not tracked.
//!
//! `scenarios/obstacle-ignored.toml` plans the paper's obstacle scenario without avoidance: the swing
//! hits the obstacle, and that plan is converged (nothing was required of the obstacle). Tracked with
//! `scenarios/obstacle.toml`, which avoids the same obstacle, its folder is refused before anything is
//! run: its trajectory breaks the clearance that scenario requires.

mod common;

use common::{brachia, report};

#[test]
fn track_refuses_a_plan_whose_trajectory_breaks_the_scenarios_clearance() {
    let dir = tempfile::tempdir().unwrap();
    let plan = dir.path().join("plan");
    let o = brachia()
        .args([
            "plan",
            "--scenario",
            "scenarios/obstacle-ignored.toml",
            "--out",
        ])
        .arg(&plan)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let r = report(&plan);
    assert_eq!(r["converged"], true);
    assert!(r["clearance_violation"].is_null());
    assert!(r["min_obstacle_clearance_m"].as_f64().unwrap() < 0.0);
    let out = dir.path().join("track");
    let o = brachia()
        .args(["track", "--scenario", "scenarios/obstacle.toml", "--plan"])
        .arg(&plan)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    for part in ["clearance_violation", "obstacle 0", "not tracked"] {
        assert!(err.contains(part), "{part:?} not in {err}");
    }
    assert!(!out.exists());
}
